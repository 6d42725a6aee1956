"""Two equal pull-aparts in a periodic cell: one inside the cell, one across its boundary.

    python periodic_capbridge.py [--theta 30] [--vstar 0.05] [--steps 200] [--stretch 1.2]
        [--shear 0.2] [--vtk DIR]

The cell is a 12 mm cube sheared by ``shear`` (second base vector (shear L, L, 0)).
Pair 0-1 sits inside the cell (z = 2 mm); pair 2-3 (z = 8 mm) touches only through the
cell's y faces: sphere 3 is placed at the image of "sphere 2 + 2R e_y" shifted back by
the second base vector, so the two are ~L apart in the scene's coordinates.  Spheres
1 and 3 are driven along +y at the same speed (gap from 0 to ``stretch`` times the
rupture gap), 0 and 2 are fixed; each pair has a bridge of V* = vstar from the first
step.  Each row: the gap of both pairs (nearest image, from the scene), the forces YADE
applied to the four spheres, and the number of bridges.  With ``--vtk DIR`` the bridges
are written at step ``steps // 2``.  Prints one JSON line.
"""
import argparse
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.minieigenHP import Matrix3, Vector3  # noqa: E402

from capbridge.dem.bridges import SceneTable, default_table_path  # noqa: E402
from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--theta", type=float, default=30.0)
cli.add_argument("--vstar", type=float, default=0.05)
cli.add_argument("--steps", type=int, default=200)
cli.add_argument("--stretch", type=float, default=1.2)
cli.add_argument("--shear", type=float, default=0.2)
cli.add_argument("--vtk", default=None)
cfg = cli.parse_args(sys.argv[1:])

mm, R, L = 1e-3, 1e-3, 12e-3
O.periodic = True
O.cell.hSize = Matrix3(L, cfg.shear * L, 0, 0, L, 0, 0, 0, L)
h2 = np.array([cfg.shear * L, L, 0.0])                      # second base vector
mat = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, label="grain"))
c = [np.array([6.0, 5.0, 2.0]) * mm, np.array([6.0, 11.0, 8.0]) * mm]
centres = [c[0], c[0] + [0, 2 * R, 0], c[1], c[1] + [0, 2 * R, 0] - h2]
ids = [O.bodies.append(utils.sphere(tuple(x), R, fixed=True, material=mat)) for x in centres]
tab = SceneTable(default_table_path(), [cfg.theta], [1.0])
d_r = float(tab.predict(0.0, cfg.vstar, cfg.theta, 1.0)["rupture_gap"][()]) * R
cap = CapbridgeEngine(theta=cfg.theta, bridge_volume_star=cfg.vstar, initial_wet_gap=1e-9 * R,
                      label="periodic")
O.dt = 1e-6
speed = cfg.stretch * d_r / (cfg.steps * O.dt)
for i in (ids[1], ids[3]):
    O.bodies[i].state.vel = Vector3(0, speed, 0)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             cap.pyrunner(),
             NewtonIntegrator(damping=0.0)]


def pos(i):
    return np.array(tuple(O.bodies[i].state.pos))


rows, vtk = [], None
for it in range(cfg.steps):
    raw = [pos(ids[1]) - pos(ids[0]), pos(ids[3]) - pos(ids[2])]
    # nearest image of pair 2-3: shift back by the second base vector (the scene's layout)
    gaps = [float(np.linalg.norm(raw[0])) - 2 * R, float(np.linalg.norm(raw[1] + h2)) - 2 * R]
    O.step()
    rows.append({"gap": gaps, "raw_distance": [float(np.linalg.norm(d)) for d in raw],
                 "f": [[float(x) for x in O.forces.f(i)] for i in ids],
                 "n_bridges": cap.model.n_bridges})
    if cfg.vtk and it == cfg.steps // 2:
        files = cap.write_vtk(f"{cfg.vtk}/periodic.vtp")
        b = cap.bridges()
        vtk = {"files": [str(f) for f in files], "id1": b["id1"].tolist(), "id2": b["id2"].tolist(),
               "volume": b["volume"].tolist(), "force": b["force"].tolist(),
               "centres": [pos(i).tolist() for i in ids]}
yade_runtime.emit_result({"ids": ids, "R": R, "L": L, "shear": cfg.shear, "d_rupt": d_r,
                          "theta": cfg.theta, "vstar": cfg.vstar, "rows": rows, "vtk": vtk,
                          "state": cap.state(), "messages": cap.messages})
