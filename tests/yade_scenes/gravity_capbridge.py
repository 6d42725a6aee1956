"""Two equal glass beads and one water bridge with gravity on the liquid (issue 10).

    python gravity_capbridge.py --radius 4e-3 --mode auto --gravity 0,0,-9.81 \
        [--steps 60] [--change-at K --gravity2 gx,gy,gz] [--restart] \
        [--tolerance 0] [--refresh 1] [--rho 997] [--pair2 R2] \
        [--save FILE | --load FILE]

Sphere 0 is fixed at the origin; sphere 1 (fixed, driven) starts at a gap of 0.02 R
along a skew axis (1, 2, 2)/3 and moves away so that the gap grows to 0.2 R in
``steps`` steps (the bridge, V* = 0.05, theta = 20 deg, forms at the first step and does
not rupture).  ``--gravity none`` puts no gravity in NewtonIntegrator.  Every row has
the force YADE holds on each sphere after the step (O.forces), the gap and the bridge
volume.  ``--change-at K``: before step K the NewtonIntegrator's gravity is set to
``--gravity2`` (the user changes it mid-run).  ``--pair2 R2``: a second pair of beads
of radius R2 (bodies 2, 3), 5 cm away, driven the same way (rows: ``f_pair2``).
``--restart``: O.saveTmp after ``steps // 2`` steps, the remaining steps recorded,
O.loadTmp, the same steps recorded again.  ``--save FILE``: O.save after ``steps // 2``
steps, the remaining steps recorded; ``--load FILE`` (a new process): O.load, no
engine made, the remaining steps recorded.  Prints one JSON line.
"""
import argparse
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine, get_engine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--radius", type=float, default=4e-3)
cli.add_argument("--mode", default="auto")
cli.add_argument("--gravity", default="0,0,-9.81")
cli.add_argument("--gravity2", default=None)
cli.add_argument("--change-at", type=int, default=-1)
cli.add_argument("--steps", type=int, default=60)
cli.add_argument("--restart", action="store_true")
cli.add_argument("--tolerance", type=float, default=0.0)
cli.add_argument("--refresh", type=int, default=1)
cli.add_argument("--save", default=None, help="O.save to this file after steps // 2 steps")
cli.add_argument("--load", default=None, help="O.load this file (no engine made here)")
cli.add_argument("--pair2", type=float, default=None,
                 help="radius of a second pair of beads, 5 cm away, driven the same way")
cli.add_argument("--rho", type=float, default=None, help="liquid_density [kg/m^3] (default: "
                 "the engine's)")
cfg = cli.parse_args(sys.argv[1:])

R, VSTAR, THETA, GAMMA = cfg.radius, 0.05, 20.0, 0.073
cap = None
if cfg.load:
    # a new process: the scene with the engine's saved state; no engine is made here
    # (the PyRunner makes it again from the scene's saved parameters)
    O.load(cfg.load)
    b0, b1 = 0, 1
    newton = [e for e in O.engines if type(e).__name__ == "NewtonIntegrator"][0]
else:
    cap = CapbridgeEngine(theta=THETA, gamma=GAMMA, bridge_volume_star=VSTAR,
                          initial_wet_gap=0.05 * R, gravity_correction=cfg.mode,
                          liquid_density=cfg.rho, force_tolerance=cfg.tolerance,
                          refresh_every=cfg.refresh, coalescence=False, label="grav")
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    glass = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600,
                                        frictionAngle=0.5))
    b0 = O.bodies.append(utils.sphere((0, 0, 0), R, fixed=True, material=glass))
    b1 = O.bodies.append(utils.sphere(tuple((2.02 * R) * axis), R, fixed=True,
                                      material=glass))
    O.dt = 1e-6
    O.bodies[b1].state.vel = Vector3(*((0.18 * R / (cfg.steps * O.dt)) * axis))
    if cfg.pair2:
        R2, shift = cfg.pair2, np.array([0.05, 0.0, 0.0])
        b2 = O.bodies.append(utils.sphere(tuple(shift), R2, fixed=True, material=glass))
        b3 = O.bodies.append(utils.sphere(tuple(shift + (2.02 * R2) * axis), R2, fixed=True,
                                          material=glass))
        O.bodies[b3].state.vel = Vector3(*((0.18 * R2 / (cfg.steps * O.dt)) * axis))
    newton = NewtonIntegrator(damping=0.0)
    if cfg.gravity != "none":
        newton.gravity = tuple(yade_runtime.float_list(cfg.gravity))
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                        [Law2_ScGeom_FrictPhys_CundallStrack()]),
        cap.pyrunner(),
        newton,
    ]

def row():
    m = get_engine("grav").model
    p0, p1 = O.bodies[b0].state.pos, O.bodies[b1].state.pos
    return {"iter": int(O.iter), "f0": [float(x) for x in O.forces.f(b0)],
            "f1": [float(x) for x in O.forces.f(b1)],
            "gap": float((p1 - p0).norm()) - 2 * R, "n_bridges": m.n_bridges,
            "volume": float(m.vol.sum()),
            "gravity": [float(x) for x in newton.gravity],
            "f_pair2": ([[float(x) for x in O.forces.f(i)] for i in (2, 3)]
                        if len(O.bodies) > 3 else None)}


def run(n):
    out = []
    for _ in range(n):
        if O.iter == cfg.change_at:
            newton.gravity = tuple(yade_runtime.float_list(cfg.gravity2))
        O.step()
        out.append(row())
    return out


result = {"radius": R, "vstar": VSTAR, "theta": THETA, "gamma": GAMMA, "mode": cfg.mode}
if cfg.load:
    result["rows"] = run(cfg.steps - cfg.steps // 2)
    cap = get_engine("grav")
elif cfg.save:
    run(cfg.steps // 2)
    O.save(cfg.save)
    result["rows"] = run(cfg.steps - cfg.steps // 2)
elif cfg.restart:
    half = cfg.steps // 2
    run(half)
    O.saveTmp()
    result["before"] = run(cfg.steps - half)
    O.loadTmp()
    result["after"] = run(cfg.steps - half)
else:
    result["rows"] = run(cfg.steps)
result["liquid_density"] = cap.gravity.drho           # the weight's drho [kg/m^3]
result["mode"] = cap.gravity_correction
st = cap.state()
result["gravity_state"] = st.get("gravity")
result["messages"] = list(cap.messages)
result["final_gravity"] = [float(x) for x in newton.gravity]
yade_runtime.emit_result(result)
