"""Cost of wall bridges: a wet packing settling in a box, with and without wall bridges.

    python wall_packing_bench.py --n 2000 --walls 1|0 [--steps 1500] [--settle 1500]
        [--water-content 0.01] [--seed 1]

``n`` grains (radius 1 mm +-30 %) fall in a box made by ``utils.aabbWalls`` (six
boxes) under gravity with a 1 % water content (conserving rule: liquid on the grains'
films, bridges form at contact, the walls wet with ``walls=True``; contact angle 20
deg on grains and walls).  After ``settle`` steps the engine's timings are reset and
``steps`` more are timed.  Prints one JSON line: ms per step of the capillary engine
(wall clock in its PyRunner) and of the whole step, bridge counts, the ledger error.
"""
import argparse
import math
import sys
import time

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import pack, utils  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--n", type=int, default=2000)
cli.add_argument("--walls", type=int, choices=(0, 1), default=1)
cli.add_argument("--steps", type=int, default=1500)
cli.add_argument("--settle", type=int, default=1500)
cli.add_argument("--water-content", type=float, default=0.01)
cli.add_argument("--seed", type=int, default=1)
cfg = cli.parse_args(sys.argv[1:])

R = 1e-3
side = (cfg.n * 4 / 3 * math.pi * (1.3 * R)**3 / 0.3 / 1.6) ** (1 / 3)   # a loose cloud
sp = pack.SpherePack()
sp.makeCloud((0, 0, 0), (side, side, 1.6 * side), rMean=R, rRelFuzz=0.3, num=cfg.n, seed=cfg.seed)
mat = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600, frictionAngle=0.4,
                                  label="glass"))
walls = O.bodies.append(utils.aabbWalls([(0, 0, 0), (side, side, 1.6 * side)], thickness=0,
                                        material=mat))
sp.toSimulation(material=mat)
cap = CapbridgeEngine(theta={"glass": 20.0}, water_content=cfg.water_content,
                      walls=bool(cfg.walls), coalescence_every=500, label="bench")
O.engines = yade_runtime.box_engines(cap.pyrunner())
O.dt = 0.5 * utils.PWaveTimeStep()
O.run(cfg.settle, True)
cap.timings.update(steps=0, seconds=0.0, cpu_seconds=0.0)
if cap.walls is not None:
    cap.walls.timings.update(updates=0, seconds=0.0, rebuilds=0, rebuild_seconds=0.0)
t0 = time.perf_counter()
O.run(cfg.steps, True)
wall = time.perf_counter() - t0
st = cap.state()
yade_runtime.emit_result({
    "n": cfg.n, "walls": cfg.walls, "steps": cfg.steps,
    "engine_ms_per_step": 1e3 * cap.timings["seconds"] / cap.timings["steps"],
    "engine_cpu_ms_per_step": 1e3 * cap.timings["cpu_seconds"] / cap.timings["steps"],
    "total_ms_per_step": 1e3 * wall / cfg.steps,
    "setup_seconds": cap.timings["setup_seconds"],
    "n_bridges": st["n_bridges"], "wall_bridges": (st["walls"] or {}).get("n_bridges", 0),
    "wall_timings": (st["walls"] or {}).get("timings"),
    "wall_candidates": (st["walls"] or {}).get("candidates"),
    "budget_error": st["budget"]["balance_error"], "liquid": st["liquid"]})
