"""Three grains of the El Korchi et al. (2017) triplet, wetted by capbridge's engine.

    python triplet_capbridge.py --cases 0:6.2e-9,0:7e-9,30:10.6e-9

Bottom grains 8.3 mm apart (r = 4 mm), top grain 8.7 mm from each, every grain fixed;
as in the experiment, two bridges of the given volume each [m^3] join the top grain to
the bottom ones (``initial_pairs``; none between the bottom grains).  Every case
(contact angle [deg]: volume) is a fresh scene in this process, stepped once.  Prints
the engine's coalescence report (which pairs of bridges the geometric criterion
merges), the filling angles, the forces (doublet forces: no triplet table yet) and the
engine's messages, per case.
"""
import argparse
import math
import sys

from capbridge.dem_plugin import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.utils import *  # noqa: E402,F401,F403

from capbridge.dem_plugin.engine import CapbridgeEngine  # noqa: E402


def _cases(text):
    return [tuple(float(x) for x in c.split(":")) for c in text.split(",") if c.strip()]


cli = argparse.ArgumentParser()
cli.add_argument("--cases", type=_cases, default=[(0.0, 14e-9)],
                 help="comma-separated theta:volume")
cfg = cli.parse_args(sys.argv[1:])

r = 4e-3
h = math.sqrt(8.7e-3**2 - (8.3e-3 / 2) ** 2)
centres = [(0, 0, 0), (8.3e-3, 0, 0), (4.15e-3, 0, h)]
out = []
for theta, volume in cfg.cases:
    O.reset()
    mat = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5))
    ids = [O.bodies.append(utils.sphere(c, r, fixed=True, material=mat)) for c in centres]
    cap = CapbridgeEngine(theta=theta, bridge_volume=volume,
                          initial_pairs=[(ids[0], ids[2]), (ids[1], ids[2])],
                          coalescence_every=1, label="triplet")
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack()]),
                 cap.pyrunner(), NewtonIntegrator(damping=0.0)]
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
