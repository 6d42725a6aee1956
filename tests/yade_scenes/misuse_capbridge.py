"""Misuse of CapbridgeEngine in a real YADE scene: a clear error or a documented action.

    python misuse_capbridge.py --case errors|after_newton|duplicate_label|
        duplicate_label_running|water_content|added|erased

Eight wet grains in a row (radius 1 mm, touching), 1 % water content unless the case
says otherwise, a few steps.  Prints one JSON line: the error (type and message) the
case raised, or what the engine did (erased sphere: bridges, ledger); ``errors`` runs
every error case in turn (a fresh scene each) and prints them all.
"""
import argparse
import sys

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--case", required=True)
cfg = cli.parse_args(sys.argv[1:])

R = 1e-3
ERROR_CASES = ("water_content", "after_newton", "duplicate_label", "duplicate_label_running",
               "added")


def build():
    """A fresh scene: eight touching wet grains in a row."""
    O.reset()
    mat = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600, frictionAngle=0.4))
    ids = [O.bodies.append(utils.sphere((2 * R * k * (1 - 1e-4), 0, 0), R, material=mat))
           for k in range(8)]
    return mat, ids


def engines(*caps, after_newton=False):
    core = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                            [Law2_ScGeom_FrictPhys_CundallStrack()])]
    runners = [c.pyrunner() for c in caps]
    newton = [NewtonIntegrator(damping=0.3)]
    O.engines = core + (newton + runners if after_newton else runners + newton)
    O.dt = 1e-6


def run_case(case):
    """What the user sees: the error (type, message), or the engine's state."""
    mat, ids = build()
    out = {}
    try:
        if case == "water_content":
            cap = CapbridgeEngine(theta=20.0, water_content=1.0)       # meant 1 %
            engines(cap)
            O.run(3, True)
        elif case == "after_newton":
            cap = CapbridgeEngine(theta=20.0, water_content=0.01)
            engines(cap, after_newton=True)
            O.run(3, True)
        elif case == "duplicate_label":
            a = CapbridgeEngine(theta=20.0, water_content=0.01)
            b = CapbridgeEngine(theta=40.0, water_content=0.01)         # same default label
            engines(a, b)
            O.run(3, True)
        elif case == "duplicate_label_running":
            a = CapbridgeEngine(theta=20.0, water_content=0.01)
            engines(a)
            O.run(2, True)
            CapbridgeEngine(theta=40.0, water_content=0.01)             # a runs under that label
        elif case == "erased":
            cap = CapbridgeEngine(theta=20.0, water_content=0.01)
            engines(cap)
            O.run(3, True)
            before = cap.state()
            O.bodies.erase(ids[3])
            O.run(3, True)
            out.update(before=before, after=cap.state(), messages=cap.messages)
        elif case == "added":
            cap = CapbridgeEngine(theta=20.0, water_content=0.01)
            engines(cap)
            O.run(3, True)
            O.bodies.append(utils.sphere((0, 5 * R, 0), R, material=mat))
            O.run(3, True)
        else:
            raise SystemExit(f"unknown case {case}")
        out["error"] = None
    except Exception as exc:  # the scene reports what the user would see
        out["error"] = {"type": type(exc).__name__, "message": str(exc)}
    return out


if cfg.case == "errors":
    yade_runtime.emit_result({c: run_case(c) for c in ERROR_CASES})
else:
    yade_runtime.emit_result(run_case(cfg.case))
