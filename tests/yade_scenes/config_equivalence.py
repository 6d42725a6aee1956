"""The same small wet pile with CapbridgeEngine made from flat keywords or from keyword
groups (capbridge.yade.config): prints the engine's saved parameters, its state and the
forces and positions, so that the two can be compared.

    python config_equivalence.py --style flat|groups [--steps 300]
"""
import argparse
import json
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import pack, utils  # noqa: E402

from capbridge.yade.config import Coalescence, Formation, GravityCorrection, Speed, WaterContent  # noqa: E402
from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--style", choices=("flat", "groups"), required=True)
cli.add_argument("--steps", type=int, default=300)
cfg = cli.parse_args(sys.argv[1:])

box = ((0, 0, 0), (0.006, 0.006, 0.012))
sp = pack.SpherePack()
sp.makeCloud(box[0], box[1], rMean=1e-3, rRelFuzz=0.2, num=40, seed=3)
glass = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600,
                                    frictionAngle=0.4, label="glass"))
O.bodies.append(utils.aabbWalls(box, thickness=0, material=glass))
sp.toSimulation(material=glass)

if cfg.style == "flat":
    cap = CapbridgeEngine(theta={"glass": 20.0}, gamma=0.073, water_content=0.01,
                          film_fraction=0.4, formation_gap=1e-5, initial_wet_gap=5e-5,
                          coalescence_every=50, gravity_correction="on",
                          force_tolerance=1e-3, skin=2e-4)
else:
    cap = CapbridgeEngine.configure(
        theta={"glass": 20.0}, gamma=0.073,
        liquid=WaterContent(0.01, film_fraction=0.4),
        formation=Formation(gap=1e-5, initial_wet_gap=5e-5),
        coalescence=Coalescence(every=50), gravity=GravityCorrection("on"),
        speed=Speed(force_tolerance=1e-3, skin=2e-4))
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    cap.pyrunner(),
    NewtonIntegrator(damping=0.3, gravity=(0, 0, -9.81)),
]
O.dt = 0.5 * utils.PWaveTimeStep()
O.run(cfg.steps, True)
ids = [b.id for b in O.bodies]
s = cap.state()
yade_runtime.emit_result({
    "params": cap._params,
    "state": {k: s[k] for k in ("n_bridges", "events", "budget", "coalescence", "gravity")},
    "bridges": {k: np.asarray(v).tolist() for k, v in cap.bridges().items()},
    "pos": [list(O.bodies[i].state.pos) for i in ids],
    "force": [list(O.forces.f(i)) for i in ids] + [list(O.forces.permF(i)) for i in ids],
})
