"""Two spheres pulled apart slowly with a volume-controlled capbridge bridge.

    python pull_apart_capbridge.py --r1 1e-3 --r2 2e-3 --theta 40 --vstar 0.05 \
        --steps 400 --stretch 1.3 [--refresh 1] [--tolerance 1e-3] [--gamma 0.073] \
        [--backend python|native --dir DIR]

``--backend python`` (default): :class:`CapbridgeEngine` (a PyRunner).  ``--backend
native``: YADE's compiled Law2 on the fixed-volume files of
:class:`capbridge.yade.native_volume.NativeVolumeBridges` written to DIR.

Sphere 0 is fixed at the origin; sphere 1 (fixed too, i.e. driven) starts touching it
and moves away at constant velocity along a skew direction, so that the gap goes from 0
to ``stretch`` times the table's rupture gap in ``steps`` steps.  The bridge forms at
the first step (``initial_wet_gap``) with V = vstar r1^3 (r1 the smaller radius).
Every row holds the gap at which the force was computed and the force YADE applied to
both spheres (read from O.forces after the step).  Prints one JSON line.
"""
import argparse
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.utils import *  # noqa: E402,F401,F403
import yade  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--r1", type=float, default=1e-3)
cli.add_argument("--r2", type=float, default=1e-3)
cli.add_argument("--theta", type=float, default=0.0)
cli.add_argument("--theta2", type=float, default=None,
                 help="contact angle of sphere 1's material (python backend; default theta)")
cli.add_argument("--vstar", type=float, default=0.05)
cli.add_argument("--gamma", type=float, default=0.073)
cli.add_argument("--steps", type=int, default=400)
cli.add_argument("--stretch", type=float, default=1.3)
cli.add_argument("--refresh", type=int, default=1)
cli.add_argument("--tolerance", type=float, default=1e-3, help="force_tolerance")
cli.add_argument("--backend", choices=("python", "native"), default="python")
cli.add_argument("--dir", default=None, help="where the native backend writes its files")
cfg = cli.parse_args(sys.argv[1:])

rs = min(cfg.r1, cfg.r2)
if cfg.backend == "python":
    theta = cfg.theta if cfg.theta2 is None else {"m0": cfg.theta, "m1": cfg.theta2}
    cap = CapbridgeEngine(theta=theta, gamma=cfg.gamma, bridge_volume=cfg.vstar * rs**3,
                          initial_wet_gap=1e-9 * rs, refresh_every=cfg.refresh,
                          force_tolerance=cfg.tolerance, label="pull")
    factor = 1.0
    ip2, law, cap_engine = (Ip2_FrictMat_FrictMat_FrictPhys(), Law2_ScGeom_FrictPhys_CundallStrack(),
                            cap.pyrunner())
else:
    from capbridge.yade.native_volume import NativeVolumeBridges  # noqa: E402

    cap = NativeVolumeBridges(cfg.dir, cfg.theta, [cfg.r1, cfg.r2], bridge_volume_star=cfg.vstar,
                              gamma=cfg.gamma)
    factor = cap.detection_factor
    ip2, law = Ip2_FrictMat_FrictMat_CapillaryPhys(), Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)
    cap_engine = cap.law2()
    cap_engine.createDistantMeniscii = True          # wet the touching pair at step 1
# the rupture gap this bridge will have (same table, same lookup)
from capbridge.dem.bridges import SceneTable, default_table_path  # noqa: E402

t_small, t_large = cfg.theta, cfg.theta if cfg.theta2 is None else cfg.theta2
if cfg.r2 < cfg.r1:
    t_small, t_large = t_large, t_small
tab = SceneTable(default_table_path(), [t_small], [max(cfg.r1, cfg.r2) / rs],
                 theta_pairs=[(t_small, t_large)])
d_r = float(tab.predict(0.0, cfg.vstar, t_small, max(cfg.r1, cfg.r2) / rs,
                        theta2=t_large)["rupture_gap"][()]) * rs

axis = np.array([1.0, 2.0, 2.0]) / 3.0
mat = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5,
                                  label="m0"))
mat1 = O.materials.append(FrictMat(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5,
                                   label="m1")) if cfg.theta2 is not None else mat
b0 = O.bodies.append(utils.sphere((0, 0, 0), cfg.r1, fixed=True, material=mat))
b1 = O.bodies.append(utils.sphere(tuple((cfg.r1 + cfg.r2) * axis), cfg.r2, fixed=True,
                                  material=mat1))
O.dt = 1e-6
speed = cfg.stretch * d_r / (cfg.steps * O.dt)
O.bodies[b1].state.vel = Vector3(*(speed * axis))
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=factor)]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=factor)], [ip2], [law]),
    cap_engine,
    NewtonIntegrator(damping=0.0),
]
rows = []
for k in range(cfg.steps):
    p0, p1 = O.bodies[b0].state.pos, O.bodies[b1].state.pos
    gap = float((p1 - p0).norm()) - cfg.r1 - cfg.r2
    O.step()
    if cfg.backend == "native":
        cap_engine.createDistantMeniscii = False      # later bridges only at contact
        inter = O.interactions.has(b0, b1) and O.interactions[b0, b1].isReal
        n_b = int(inter and O.interactions[b0, b1].phys.meniscus)
    else:
        n_b = cap.model.n_bridges
    f0, f1 = O.forces.f(b0), O.forces.f(b1)
    rows.append({"gap": gap, "f0": [float(x) for x in f0], "f1": [float(x) for x in f1],
                 "n_bridges": n_b})
yade_runtime.emit_result({"r1": cfg.r1, "r2": cfg.r2, "theta": cfg.theta, "theta2": cfg.theta2,
                          "vstar": cfg.vstar,
                          "gamma": cfg.gamma, "axis": axis.tolist(), "d_rupt": d_r,
                          "backend": cfg.backend, "refresh": cfg.refresh,
                          "state": cap.state() if cfg.backend == "python" else cap.info,
                          "yade_version": yade.config.version, "rows": rows})
