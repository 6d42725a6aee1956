"""A small wet pile, saved and reloaded: do the capillary forces carry on unchanged?

    python restart_capbridge.py --mode tmp|save|load [--file F] [--tolerance 0] [--refresh 1]
        [--settle 300] [--record 40] [--style flat|groups]

40 grains (radius 1 mm +-20 %) settle for ``settle`` steps in a box under gravity with
a 1 % water content (conserving rule, bridges from the films), then:

``tmp``   O.saveTmp(); ``record`` steps are recorded; O.loadTmp(); the same ``record``
          steps are recorded again.
``save``  O.save(F); ``record`` steps recorded (the reference).
``load``  (a new process, no engine created) O.load(F); ``record`` steps recorded.

A record is, per step, the force YADE applied to every grain (``O.forces.f`` after the
step: contacts + capillary + permanent) and the engine's bridge count and ledger.  A
user's permanent force is set on grain ``--perm-id`` before every run segment (YADE
drops permanent forces on load, the user sets it again).  ``--style``: the engine made
from the flat keywords or from keyword groups (capbridge.yade.config).  Prints one JSON
line.
"""
import argparse
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import pack, utils  # noqa: E402
import yade  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402  (outside the launcher)

cli = argparse.ArgumentParser()
cli.add_argument("--mode", choices=("tmp", "save", "load"), default="tmp")
cli.add_argument("--file", default=None)
cli.add_argument("--tolerance", type=float, default=0.0)
cli.add_argument("--refresh", type=int, default=1)
cli.add_argument("--settle", type=int, default=1500)
cli.add_argument("--record", type=int, default=40)
cli.add_argument("--perm", type=float, default=2e-4, help="user's permanent force [N] (z)")
cli.add_argument("--style", choices=("flat", "groups"), default="flat")
cfg = cli.parse_args(sys.argv[1:])
PERM = (0.0, 0.0, cfg.perm)


def kick():
    """The same random velocities after the save and after the load: bridges rupture
    and form in the recorded window, so a state not restored would show."""
    import random

    rnd = random.Random(7)
    for i in ids:
        O.bodies[i].state.vel = Vector3(*(rnd.uniform(-0.5, 0.5) for _ in range(3)))


def record(n, cap_label):
    from capbridge.yade.engine import get_engine

    kick()
    rows = []
    for _ in range(n):
        O.step()
        cap = get_engine(cap_label)
        rows.append({"iter": int(O.iter),
                     "f": [[float(x) for x in O.forces.f(i)] for i in ids],
                     "perm": [float(x) for x in O.forces.permF(perm_id)],
                     "ours": cap.model.held_grain_forces()[list(cap.ids).index(perm_id)].tolist(),
                     "n_bridges": cap.model.n_bridges, "events": dict(cap.events),
                     "budget_error": cap.budget()["balance_error"],
                     "liquid": cap.state()["liquid"]})
    return rows


if cfg.mode == "load":
    O.load(cfg.file)
    ids = [b.id for b in O.bodies if isinstance(b.shape, Sphere)]
    perm_id = ids[0]
    O.forces.setPermF(perm_id, PERM)
    rows = record(cfg.record, "pile")
    from capbridge.yade.engine import get_engine
    yade_runtime.emit_result({"rows": rows, "messages": get_engine("pile").messages})
    sys.exit(0)

from capbridge.yade.config import Speed, WaterContent  # noqa: E402
from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

box = ((0, 0, 0), (0.008, 0.008, 0.014))
sp = pack.SpherePack()
sp.makeCloud(box[0], box[1], rMean=1e-3, rRelFuzz=0.2, num=40, seed=3)
glass = O.materials.append(FrictMat(young=1e6, poisson=0.3, density=2600, frictionAngle=0.4,
                                    label="glass"))
O.bodies.append(utils.aabbWalls(box, thickness=0, material=glass))
ids = sp.toSimulation(material=glass)
perm_id = ids[0]
if cfg.style == "flat":
    cap = CapbridgeEngine(theta={"glass": 20.0}, gamma=0.073, water_content=0.01,
                          force_tolerance=cfg.tolerance, refresh_every=cfg.refresh,
                          label="pile")
else:
    cap = CapbridgeEngine(theta={"glass": 20.0}, gamma=0.073, liquid=WaterContent(0.01),
                          speed=Speed(force_tolerance=cfg.tolerance,
                                      refresh_every=cfg.refresh), label="pile")
O.engines = yade_runtime.box_engines(cap.pyrunner())
O.dt = 0.5 * utils.PWaveTimeStep()
O.forces.setPermF(perm_id, PERM)
# an extra part of the engine's state (as liquid clusters will be): saved and restored
extra = {"n": 0}
cap.register_state("demo", lambda: {"counter": np.array([extra["n"]])},
                   lambda st: extra.update(n=int(st["counter"][0])))
O.run(cfg.settle, True)
out = {"n_bridges_at_save": cap.model.n_bridges, "iter_at_save": int(O.iter),
       "dt": O.dt, "perm_id": perm_id}
if cfg.mode == "tmp":
    extra["n"] = 11
    O.saveTmp()
    out["before"] = record(cfg.record, "pile")
    extra["n"] = 99
    O.loadTmp()
    O.forces.setPermF(perm_id, PERM)
    out["after"] = record(cfg.record, "pile")
    out["extra_after_load"] = extra["n"]
else:
    O.save(cfg.file)
    out["before"] = record(cfg.record, "pile")
out["state"] = cap.state()
out["messages"] = cap.messages
yade_runtime.emit_result(out)
