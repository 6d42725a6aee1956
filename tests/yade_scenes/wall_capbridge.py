"""Spheres pulled away from a Wall, a tilted Box and a Facet, each with a capbridge wall
bridge.

    python wall_capbridge.py [--theta-s 20] [--theta-w 40] [--vstar 0.05] [--steps 240]
        [--stretch 1.15] [--vtk DIR] [--rule fixed|conserved]

Sphere k (radius R_k) starts touching its partner and is driven (fixed, with a
velocity) along the partner's outward normal so that the gap goes from 0 to ``stretch``
times the exact rupture gap in ``steps`` steps:

==  ===============  ============================  =========  ==================
k   radius [mm]      partner                       angles     bridge
==  ===============  ============================  =========  ==================
0   1.0              Wall (axis x) at x = -10 mm   (ts, tw)   V* = vstar
1   1.5              Box tilted 30 deg about z     (ts, tw)   V* = vstar
2   0.8              Facet (plane z = 10 mm)       (ts, tw)   V* = vstar
==  ===============  ============================  =========  ==================

(``--rule conserved``: the liquid is a total on the grains' films, 2 V* R^3 each; the
bridges take half of each sphere's film and give it back at rupture.)
Each row: the gap of each sphere (from the known geometry), the force YADE applied to
each sphere and to each partner body (``O.forces.f``, after the step), the number of
wall bridges and the liquid ledger.  With ``--vtk DIR`` the bridges are written at
step ``steps // 3`` (``cap.write_vtk``) and by a recorder every 40 steps, and the
engine's own wall records at that step are in the result.  With ``--reload``: run 2/3 of the steps, ``O.saveTmp``, record 60 steps, ``O.loadTmp``,
record the same 60 steps again.  Prints one JSON line.
"""
import argparse
import math
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
import yade  # noqa: E402
from yade.minieigenHP import Quaternion, Vector3  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402
from capbridge.solvers.sphere_wall import sphere_wall_rupture_distance  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--theta-s", type=float, default=20.0)
cli.add_argument("--theta-w", type=float, default=40.0)
cli.add_argument("--vstar", type=float, default=0.05)
cli.add_argument("--gamma", type=float, default=0.073)
cli.add_argument("--steps", type=int, default=240)
cli.add_argument("--stretch", type=float, default=1.15)
cli.add_argument("--vtk", default=None)
cli.add_argument("--rule", choices=("fixed", "conserved"), default="fixed")
cli.add_argument("--reload", action="store_true", help="O.saveTmp / O.loadTmp check")
cfg = cli.parse_args(sys.argv[1:])

mm = 1e-3
grain = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, label="grain"))
wallmat = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, label="wallmat"))

radii = [1.0 * mm, 1.5 * mm, 0.8 * mm]
tilt = math.radians(30.0)
box_n = np.array([math.cos(tilt), math.sin(tilt), 0.0])        # the box's local +x face
box_c, box_hx = np.array([20.0, 0.0, 0.0]) * mm, 1.0 * mm
normals = [np.array([1.0, 0, 0]), box_n, np.array([0, 0, 1.0])]
feet = [np.array([-10.0, 0, 0]) * mm, box_c + box_hx * box_n, np.array([0, 20.0, 10.0]) * mm]
n_spheres = 3

w_ids = [O.bodies.append(utils.wall(-10.0 * mm, axis=0, sense=0, material=wallmat)),
         O.bodies.append(utils.box(tuple(box_c), (box_hx, 5 * mm, 5 * mm), fixed=True,
                                   orientation=Quaternion(Vector3(0, 0, 1), tilt),
                                   material=wallmat)),
         O.bodies.append(utils.facet([(-5 * mm, 15 * mm, 10 * mm), (5 * mm, 15 * mm, 10 * mm),
                                      (0, 28 * mm, 10 * mm)], material=wallmat))]
s_ids = [O.bodies.append(utils.sphere(tuple(feet[k] + radii[k] * normals[k]), radii[k],
                                      fixed=True, material=grain))
         for k in range(n_spheres)]

theta = {"grain": cfg.theta_s, "wallmat": cfg.theta_w}
if cfg.rule == "fixed":
    amount = {"bridge_volume_star": cfg.vstar}
else:
    # films hold 2 V* R^3 each: the first bridge takes half (film_fraction 0.5)
    amount = {"liquid_volume": float(sum(2 * cfg.vstar * r**3 for r in radii[:3])),
              "conserve_liquid": True}
cap = CapbridgeEngine(theta=theta, gamma=cfg.gamma, walls=True, label="walls",
                      initial_wet_gap=1e-9 * mm, coalescence=False, **amount)
d_r = float(sphere_wall_rupture_distance(cfg.vstar, cfg.theta_s, cfg.theta_w)["gap"])
O.dt = 1e-6
for k in range(n_spheres):
    speed = cfg.stretch * d_r * radii[k] / (cfg.steps * O.dt)
    O.bodies[s_ids[k]].state.vel = Vector3(*(speed * normals[k]))
engines = [ForceResetter(),
           InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb(), Bo1_Box_Aabb(),
                                  Bo1_Facet_Aabb()]),
           InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(),
                            Ig2_Box_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                           [Ip2_FrictMat_FrictMat_FrictPhys()],
                           [Law2_ScGeom_FrictPhys_CundallStrack()]),
           cap.pyrunner(),
           NewtonIntegrator(damping=0.0)]
if cfg.vtk:
    engines.append(cap.vtk_recorder(cfg.vtk, every=40))
O.engines = engines

rows, vtk = [], None
if cfg.reload:
    # O.saveTmp at 2/3, 60 steps (the ruptures included), O.loadTmp, the same 60 steps
    O.run(2 * cfg.steps // 3, True)
    O.saveTmp()
    runs = []
    for _ in range(2):
        rec = []
        for _ in range(60):
            O.step()
            rec.append({"f": [[float(x) for x in O.forces.f(i)] for i in s_ids + w_ids],
                        "n": cap.walls.n_bridges, "films": cap.model.films.tolist()})
        runs.append(rec)
        O.loadTmp()
    yade_runtime.emit_result({"before": runs[0], "after": runs[1], "messages": cap.messages})
    sys.exit(0)
for it in range(cfg.steps):
    gaps = [float(np.dot(np.array(tuple(O.bodies[s_ids[k]].state.pos)) - feet[k], normals[k]))
            - radii[k] for k in range(n_spheres)]
    O.step()
    st = cap.walls.summary()
    rows.append({"gap": gaps,
                 "f": [[float(x) for x in O.forces.f(i)] for i in s_ids],
                 "f_wall": [[float(x) for x in O.forces.f(i)] for i in w_ids],
                 "t_wall": [[float(x) for x in O.forces.t(i)] for i in w_ids],
                 "n_wall_bridges": st["n_bridges"], "wall_volume": st["volume"],
                 "budget_error": cap.budget()["balance_error"],
                 "films": cap.model.films.tolist()})
    if cfg.vtk and it == cfg.steps // 3:
        files = cap.write_vtk(f"{cfg.vtk}/now.vtp")
        rec = cap.walls.records(cap.ids)
        vtk = {"files": [str(f) for f in files],
               **{k: np.asarray(v).tolist() for k, v in rec.items()}}
yade_runtime.emit_result({"radii": radii, "normals": [n.tolist() for n in normals],
                          "s_ids": s_ids, "w_ids": w_ids, "d_rupt_star": d_r,
                          "theta_s": cfg.theta_s, "theta_w": cfg.theta_w, "vstar": cfg.vstar,
                          "gamma": cfg.gamma, "rule": cfg.rule, "rows": rows, "vtk": vtk,
                          "state": cap.state(), "messages": cap.messages})
