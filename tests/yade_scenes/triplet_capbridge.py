"""Three grains wetted by capbridge's engine: coalescence reported, or triplet forces.

    python triplet_capbridge.py --cases 0:6.2e-9,0:7e-9,30:10.6e-9
    python triplet_capbridge.py --closing --volume 2e-10 --gaps 0.5,0.06,0.1 \
        --pull-gap 0.3 --steps 150,20,100,10 [--theta 0] [--table T] [--triplet-forces on]

``--cases`` (report only): the El Korchi et al. (2017) triplet: bottom grains 8.3 mm
apart (r = 4 mm), top grain 8.7 mm from each, every grain fixed; as in the experiment,
two bridges of the given volume each [m^3] join the top grain to the bottom ones
(``initial_pairs``; none between the bottom grains), with ``triplet_forces=False``.
Every case (contact angle [deg]: volume) is a fresh scene in this process, stepped
once.  Prints the engine's coalescence report (which pairs of bridges the geometric
criterion merges), the filling angles, the forces (doublet forces) and the engine's
messages, per case.

``--closing``: three equal grains (radius ``--r``) driven kinematically (fixed bodies
with a velocity), two bridges of ``--volume`` each from the shared grain 2 to grains 0
and 1, the coalescence check at every step.  ``--gaps g01_start,g01_end,g`` (gaps / r):
grain 1 moves on the arc around grain 2 (gap g kept) from gap g01_start to g01_end
from grain 0 in the first ``steps[0]`` steps (closing the angle at grain 2 until the
caps meet), stays ``steps[1]`` steps, moves straight away from grain 2 until their gap
is ``--pull-gap`` in ``steps[2]`` steps, stays ``steps[3]`` steps.  ``--restart M``:
after the hold, ``O.saveTmp``, M steps, ``O.loadTmp``, the same M steps again (no pull).  Every row: the
centres the engine saw, the forces YADE applied after the step, the engine's bridges
(grains, volumes, gaps), liquid ledger and triplet report.  Prints one JSON line.
"""
import argparse
import math
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.utils import *  # noqa: E402,F401,F403

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402


def _cases(text):
    return [tuple(float(x) for x in c.split(":")) for c in text.split(",") if c.strip()]


cli = argparse.ArgumentParser()
cli.add_argument("--cases", type=_cases, default=[(0.0, 14e-9)],
                 help="comma-separated theta:volume")
cli.add_argument("--closing", action="store_true")
cli.add_argument("--r", type=float, default=1e-3)
cli.add_argument("--gaps", type=yade_runtime.float_list, default=[0.5, 0.06, 0.1])
cli.add_argument("--volume", type=float, default=1e-10, help="per bridge [m^3]")
cli.add_argument("--theta", type=float, default=0.0)
cli.add_argument("--pull-gap", type=float, default=0.3)
cli.add_argument("--steps", type=yade_runtime.float_list, default=[150, 20, 100, 10])
cli.add_argument("--table", default=None, help="triplet table (default the shipped one)")
cli.add_argument("--triplet-forces", choices=("on", "off", "default"), default="default")
cli.add_argument("--restart", type=int, default=0,
                 help="after the hold: O.saveTmp, M steps, O.loadTmp, the same M steps "
                      "again (and no pull)")
cfg = cli.parse_args(sys.argv[1:])

MAT = dict(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5)


def _engines(cap):
    return [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                            [Law2_ScGeom_FrictPhys_CundallStrack()]),
            cap.pyrunner(), NewtonIntegrator(damping=0.0)]


def report_cases():
    r = 4e-3
    h = math.sqrt(8.7e-3**2 - (8.3e-3 / 2) ** 2)
    centres = [(0, 0, 0), (8.3e-3, 0, 0), (4.15e-3, 0, h)]
    out = []
    for theta, volume in cfg.cases:
        O.reset()
        mat = O.materials.append(FrictMat(**MAT))
        ids = [O.bodies.append(utils.sphere(c, r, fixed=True, material=mat)) for c in centres]
        cap = CapbridgeEngine(theta=theta, bridge_volume=volume,
                              initial_pairs=[(ids[0], ids[2]), (ids[1], ids[2])],
                              coalescence_every=1, label="triplet", triplet_forces=False)
        O.engines = _engines(cap)
        O.dt = 1e-7
        O.step()
        rep = cap.coalescence_report
        m = cap.model
        g = cap._last_geom
        b_i, b_j = m.filling_angles(g["gap"])
        out.append({
            "volume": volume, "theta": theta, "state": cap.state(),
            "bridges": {"id1": m.bi.tolist(), "id2": m.bj.tolist(), "gap": g["gap"].tolist(),
                        "force": g["force"].tolist(), "beta_on_id1": b_i.tolist(),
                        "beta_on_id2": b_j.tolist()},
            "triplets": cap.coalesced_triplets().tolist(), "closed": rep.closed.tolist(),
            "forces": [list(O.forces.f(i)) for i in ids], "messages": cap.messages})
    yade_runtime.emit_result({"cases": out})


def closing():
    r = cfg.r
    g01a, g01b, g = cfg.gaps
    L = (2 + g) * r                        # centre distance 0-2 and 1-2, kept

    d0 = (2 + g01a) * r
    p2 = np.array([d0 / 2, 0.0, math.sqrt(L**2 - (d0 / 2) ** 2)])
    centres = [np.zeros(3), None, p2]

    def on_arc(g01):
        """Grain 1 on the circle of radius L around grain 2 (plane y = 0), at centre
        distance (2 + g01) r from grain 0: the direction 2 -> 0 turned by the angle at
        grain 2 of that triangle, 2 asin(d / 2L), towards +x."""
        alpha = 2.0 * math.asin((2 + g01) * r / (2 * L))
        w = -p2 / L
        c, s_ = math.cos(alpha), math.sin(alpha)
        turned = [np.array([w[0] * c + sg * w[2] * s_, 0.0, -sg * w[0] * s_ + w[2] * c])
                  for sg in (1.0, -1.0)]
        return p2 + L * max(turned, key=lambda v: v[0])

    centres[1] = on_arc(g01a)
    O.reset()
    mat = O.materials.append(FrictMat(**MAT))
    ids = [O.bodies.append(utils.sphere(tuple(c), r, fixed=True, material=mat)) for c in centres]
    kw = {} if cfg.triplet_forces == "default" else {"triplet_forces": cfg.triplet_forces == "on"}
    cap = CapbridgeEngine(theta=cfg.theta, bridge_volume=cfg.volume,
                          initial_pairs=[(ids[0], ids[2]), (ids[1], ids[2])],
                          coalescence_every=1, label="triplet", triplet_table=cfg.table, **kw)
    O.engines = _engines(cap)
    O.dt = 1e-5
    n_close, n_hold, n_pull, n_end = (int(x) for x in cfg.steps)
    path = [on_arc(g01a + (g01b - g01a) * (k + 1) / n_close) for k in range(n_close)]
    path += [path[-1]] * n_hold
    start = path[-1]
    u = (start - p2) / np.linalg.norm(start - p2)
    far = p2 + u * (2 + cfg.pull_gap) * r
    path += [start + (far - start) * (k + 1) / n_pull for k in range(n_pull)]
    path += [path[-1]] * n_end
    if cfg.restart:
        path = path[:n_close + n_hold]
    rows = []
    b1 = O.bodies[ids[1]]
    for target in path:
        pos = [list(O.bodies[i].state.pos) for i in ids]
        # the velocity that lands grain 1 on the next point of the path
        b1.state.vel = Vector3(*((target - np.array(pos[1])) / O.dt))
        O.step()
        m = cap.model
        g = cap._last_geom
        rows.append({"iter": int(O.iter), "pos": pos,
                     "forces": [list(O.forces.f(i)) for i in ids],
                     "bi": m.bi.tolist(), "bj": m.bj.tolist(), "vol": m.vol.tolist(),
                     "gap": g["gap"].tolist(), "bridge_force": g["force"].tolist(),
                     "budget": m.budget(), "triplets": cap.triplet_report()})
    out = {"r": r, "gamma": cap.gamma, "theta": cfg.theta, "volume": cfg.volume,
           "rows": rows}
    if cfg.restart:
        b1.state.vel = Vector3(0, 0, 0)
        O.saveTmp("triplet")
        runs = []
        for k in range(2):
            if k:
                O.loadTmp("triplet")
            runs.append([])
            for _ in range(cfg.restart):
                O.step()
                runs[-1].append({"iter": int(O.iter),
                                 "forces": [list(O.forces.f(i)) for i in ids],
                                 "triplets": cap.triplet_report()})
        out["restart"] = runs
    out.update(state=cap.state(), messages=cap.messages)
    yade_runtime.emit_result(out)


if cfg.closing:
    closing()
else:
    report_cases()
