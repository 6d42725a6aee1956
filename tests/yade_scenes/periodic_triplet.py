"""A coalesced triplet in a periodic cell: inside the cell, then across its boundary.

    python periodic_triplet.py [--theta 30] [--vstar 0.08] [--gap 0.05] [--steps 3]

Three fixed equal grains (r = 1 mm) at the corners of an equilateral triangle (surface gaps
``--gap`` r), each pair joined by a bridge of V* = ``--vstar`` (``initial_pairs``), the
coalescence check at every step and triplet forces on, in a sheared periodic cell
(12 mm).  Two scenes: the triangle in the middle of the cell, and the same triangle moved
so that it straddles the cell's boundary (one grain's centre on the far side: its raw
centre differences are ~1 cell long).  Prints one JSON line: for each placement the
forces YADE applied on the three grains after ``--steps`` steps, the engine's coalescence
summary and triplet report.
"""
import argparse
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.minieigenHP import Matrix3  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--theta", type=float, default=30.0)
cli.add_argument("--vstar", type=float, default=0.12)
cli.add_argument("--gap", type=float, default=0.05)
cli.add_argument("--steps", type=int, default=3)
cfg = cli.parse_args(sys.argv[1:])

R, L, SHEAR = 1e-3, 12e-3, 0.2
side = (2 + cfg.gap) * R
TRIANGLE = np.array([[0.0, 0.0, 0.0], [side, 0.0, 0.0], [side / 2, side * 3**0.5 / 2, 0.0]])


def run(offset):
    O.reset()
    O.periodic = True
    O.cell.hSize = Matrix3(L, SHEAR * L, 0, 0, L, 0, 0, 0, L)
    mat = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600))
    centres = TRIANGLE + offset
    centres[:, 0] %= L             # into the cell along its first base vector (L, 0, 0)
    ids = [O.bodies.append(utils.sphere(tuple(c), R, fixed=True, material=mat))
           for c in centres]
    cap = CapbridgeEngine(theta=cfg.theta, bridge_volume_star=cfg.vstar,
                          initial_pairs=[(ids[0], ids[1]), (ids[0], ids[2]), (ids[1], ids[2])],
                          coalescence_every=1, triplet_forces=True, label="ptriplet")
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                                 [Ip2_FrictMat_FrictMat_FrictPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack()]),
                 cap.pyrunner(), NewtonIntegrator(damping=0.0)]
    O.dt = 1e-6
    O.run(cfg.steps, True)
    raw = [float(np.linalg.norm(np.array(O.bodies[ids[a]].state.pos)
                                - np.array(O.bodies[ids[b]].state.pos)))
           for a, b in ((0, 1), (0, 2), (1, 2))]
    return {"forces": [[float(x) for x in O.forces.f(i)] for i in ids],
            "raw_distances": raw, "coalescence": cap.state()["coalescence"],
            "triplets": cap.triplet_report(), "n_bridges": cap.model.n_bridges}


# inside: the middle of the cell; across: the face x = 0 cuts the triangle, grain 0 is
# put at its image near x = L (raw distances to the others ~ L)
inside = run(np.array([5.0e-3, 5.0e-3, 6.0e-3]))
across = run(np.array([-side / 2 + 0.2e-3, 5.0e-3, 6.0e-3]))
yade_runtime.emit_result({"inside": inside, "across": across})
