"""Bad keywords of CapbridgeEngine in a real YADE scene: refused when the engine is made.

    python options_capbridge.py --case all|<case>

Four glass grains in a row (radius 1 mm, touching; ids 0-3) on a steel ``Wall`` (id 4),
with a fifth glass grain of radius 20 mm far away in case ``ratio_20`` (id 5).  Each
case is a fresh scene: the engine is made with the case's keywords (and
``water_content=0.01``, ``theta=20`` unless the case says otherwise), then the engines
are set and the scene runs 3 steps.  Prints one JSON line, per case: ``stage``
("construct": the constructor raised, "run": ``O.run`` raised, "ran": no error), the
error's type and message, ``O.iter`` when it was raised, and for a run the bridges.
"""
import argparse
import math
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
G = (0.0, 0.0, -9.81)

#: case -> keywords (besides the defaults below); None: remove the default
CASES = {
    "label_none": {"label": None},
    "walls_all": {"walls": "all"},
    "theta_nan": {"theta": math.nan},
    "theta_85": {"theta": 85.0},
    "gamma_72": {"gamma": 72.0},
    "triplet_forces_no": {"triplet_forces": "no"},
    "refresh_2_7": {"refresh_every": 2.7},
    "coalescence_every_0": {"coalescence_every": 0},
    "skin_negative": {"skin": -1e-4},
    "table_missing": {"table": "/nonexistent/doublet.nc"},
    "water_content_1": {"water_content": 1.0},                     # meant 1 %
    "theta_no_material": {"theta": {"sand": 20.0}},
    "theta_glass_85": {"theta": {"glass": 85.0}},
    "bridge_volume_large": {"water_content": None, "bridge_volume": 1e-6},   # mm^3 meant
    "ratio_20": {},
    "wall_no_material": {"theta": {"glass": 20.0}, "walls": True},
    "walls_sphere": {"walls": [0]},
    "ids_wall": {"ids": [4]},
    "liquid_volume_large": {"water_content": None, "liquid_volume": 1e-6, "ids": [0, 1, 2, 3]},
    "sample_volume_small": {"water_content": None, "saturation": 0.5, "sample_volume": 1e-9},
    "gravity_nan": {},
    "valid": {"theta": {"glass": 20.0, "steel": 40.0}, "walls": True},
}


def build(case):
    """A fresh scene: four touching glass grains on a steel wall."""
    O.reset()
    glass = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600,
                                        frictionAngle=0.4, label="glass"))
    steel = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=7800,
                                        frictionAngle=0.4, label="steel"))
    for k in range(4):
        O.bodies.append(utils.sphere((2 * R * k * (1 - 1e-4), 0, 0), R, material=glass))
    O.bodies.append(utils.wall((0, 0, -R * (1 - 1e-4)), axis=2, material=steel))
    if case == "ratio_20":
        O.bodies.append(utils.sphere((0, 0.1, 0), 20 * R, material=glass))


def run_case(case):
    build(case)
    kw = {"theta": 20.0, "water_content": 0.01, "label": f"cap_{case}"}
    kw.update(CASES[case])
    kw = {k: v for k, v in kw.items() if v is not None or k == "label"}
    out = {"stage": "construct"}
    try:
        cap = CapbridgeEngine(**kw)
        out["stage"] = "run"
        O.engines = [ForceResetter(),
                     InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
                     InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                                     [Ip2_FrictMat_FrictMat_FrictPhys()],
                                     [Law2_ScGeom_FrictPhys_CundallStrack()]),
                     cap.pyrunner(),
                     NewtonIntegrator(damping=0.3,
                                      gravity=(0.0, 0.0, math.nan) if case == "gravity_nan" else G)]
        O.dt = 1e-6
        O.run(3, True)
        out.update(stage="ran", n_bridges=cap.state()["n_bridges"])
    except Exception as exc:  # the scene reports what the user sees
        out.update(type=type(exc).__name__, message=str(exc))
    out["iter"] = int(O.iter)
    return out


if cfg.case == "all":
    yade_runtime.emit_result({c: run_case(c) for c in CASES})
else:
    yade_runtime.emit_result({cfg.case: run_case(cfg.case)})
