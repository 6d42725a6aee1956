"""Three equal grains, one coalesced triplet, gravity on the liquid (issue 10).

    python gravity_triplet_capbridge.py --table T --gaps g01,g02,g12 --volume V \
        [--mode on] [--gravity 2,-3,-9] [--steps 3] [--r 1e-3]

Three fixed grains of radius r at the gaps (/ r) given, rotated by a fixed rotation q
from the frame of ``triangle_centres`` (``rotation`` in the output); two bridges
of V/2 [m^3] each from grain 2 to grains 0 and 1 (``initial_pairs``), coalescence
checked at every step, ``triplet_forces=True`` with the triplet table T.  Rows: the
forces YADE holds on the three grains after each step, the triplet report.  Prints one
JSON line.
"""
import argparse
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402
from capbridge.dem.triplet_clusters import triangle_centres  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--table", required=True)
cli.add_argument("--gaps", type=yade_runtime.float_list, required=True)
cli.add_argument("--volume", type=float, required=True, help="total liquid [m^3]")
cli.add_argument("--mode", default="on")
cli.add_argument("--gravity", default="2,-3,-9")
cli.add_argument("--steps", type=int, default=3)
cli.add_argument("--r", type=float, default=1e-3)
cfg = cli.parse_args(sys.argv[1:])

r = cfg.r
g01, g02, g12 = cfg.gaps
local = triangle_centres(2 + g01, 2 + g02, 2 + g12) * r
q, _ = np.linalg.qr(np.array([[0.3, -0.5, 0.8], [0.9, 0.2, -0.1], [-0.2, 0.7, 0.4]]))
q[:, 2] *= np.sign(np.linalg.det(q))             # a rotation (det +1), not a mirror
centres = local @ q.T + np.array([0.01, 0.02, 0.03])
mat = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5))
ids = [O.bodies.append(utils.sphere(tuple(c), r, fixed=True, material=mat)) for c in centres]
cap = CapbridgeEngine(theta=0.0, bridge_volume=cfg.volume / 2,
                      initial_pairs=[(ids[0], ids[2]), (ids[1], ids[2])],
                      triplet_forces=True, triplet_table=cfg.table, coalescence_every=1,
                      gravity_correction=cfg.mode, label="gtri")
O.dt = 1e-6
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    cap.pyrunner(),
    NewtonIntegrator(damping=0.0, gravity=tuple(yade_runtime.float_list(cfg.gravity))),
]
rows = []
for _ in range(cfg.steps):
    O.step()
    rows.append({"iter": int(O.iter),
                 "f": [[float(x) for x in O.forces.f(i)] for i in ids],
                 "triplets": cap.triplet_report()})
yade_runtime.emit_result({"rows": rows, "messages": list(cap.messages),
                          "gravity_state": cap.state().get("gravity"),
                          "drho": cap.gravity.drho, "volume": cfg.volume,
                          "bridge_volume_total": float(cap.model.vol.sum()),
                          "centres": centres.tolist(), "rotation": q.tolist()})
