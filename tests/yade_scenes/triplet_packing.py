"""Coalesced triplets in a settled wet packing: do they live, or flicker?

    python triplet_packing.py --n 300 --table data/triplet_table.nc [--steps 300]

Equal grains (r = 1 mm, the triplet table's domain) settle dry under gravity in a box;
then capbridge's engine wets them (water content 5 %, theta = 30 deg, conserved liquid,
``triplet_forces=True``, coalescence checked every 5 steps) and the packing, at rest,
runs ``--steps`` steps.  Grains in contact overlap by DEM amounts: every coalesced
triplet has two contacts, the geometry of the round-off bug of issue 16 (lookups that
refused the contacts they were given, so that every merged cluster split again at its
next step).  Prints one JSON line: the cluster events, the clusters alive at each
check, the liquid ledger, and the deepest overlap seen.
"""
import argparse
import math
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import pack, utils  # noqa: E402
import yade  # noqa: E402,F401

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--n", type=int, default=300)
cli.add_argument("--table", required=True)
cli.add_argument("--steps", type=int, default=300)
cli.add_argument("--water-content", type=float, default=0.05)
cfg = cli.parse_args(sys.argv[1:])

R = 1e-3
side = (cfg.n * 4 / 3 * math.pi * R**3 / 0.6) ** (1 / 3)
sp = pack.SpherePack()
sp.makeCloud((0, 0, 0), (side, side, 2.5 * side), rMean=R, rRelFuzz=0, num=cfg.n, seed=3)
mat = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600, frictionAngle=0.3))
O.bodies.append(utils.aabbWalls([(0, 0, 0), (side, side, 2.5 * side)], thickness=0, material=mat))
sp.toSimulation(material=mat)
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                             [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             NewtonIntegrator(damping=0.6, gravity=(0, 0, -9.81))]
O.dt = 0.5 * utils.PWaveTimeStep()
while O.iter < 15000:                 # dry deposition, as the benchmarks' packings
    O.run(500, True)
    if O.iter > 4000 and utils.unbalancedForce() < 0.05:
        break
settle_steps = O.iter

cap = CapbridgeEngine(theta=30.0, gamma=0.073, water_content=cfg.water_content,
                      coalescence_every=5, triplet_forces=True, triplet_table=cfg.table,
                      label="wet")
O.engines = O.engines[:-1] + [cap.pyrunner(), NewtonIntegrator(damping=0.4,
                                                                gravity=(0, 0, -9.81))]
alive, overlap = [], 0.0
for _ in range(cfg.steps // 5):
    O.run(5, True)
    alive.append(int(cap.triplet_report().get("clusters", 0)))
    for i in O.interactions:
        if i.isReal and i.geom is not None and hasattr(i.geom, "penetrationDepth"):
            overlap = max(overlap, i.geom.penetrationDepth)
st = cap.state()
yade_runtime.emit_result({"settle_steps": settle_steps, "triplets": cap.triplet_report(),
                          "alive": alive, "budget_error": st["budget"]["balance_error"],
                          "max_overlap": overlap / R})
