"""A few hundred wet grains settle under gravity, are shaken, and settle again.

    python packing_capbridge.py --n 300 --rule conserved|fixed|native [--steps 6000] [--seed 1]

capbridge's engine gives the grains capillary cohesion with volume-controlled bridges:
``conserved`` is a water content of 1 % with liquid conservation (bridges + liquid on
grains = total; the grains start dry of bridges, the liquid on them, and bridges form
at contact), ``fixed`` a fixed volume per bridge (V* = 0.02; the pairs of the initial
cloud closer than 0.1 R start wet), ``native`` the fixed-volume rule (V* = 0.02) through
YADE's compiled Law2 (NativeVolumeBridges; bidisperse grains, radius ratio 1.25, and
``--dir`` for its files).  Half-way the grains
get a random velocity kick so that bridges rupture and re-form.  Prints one JSON line
with the liquid ledger at every record, whether every position and force stayed finite,
and what the test needs to recompute the total liquid.
"""
import argparse
import math
import sys

import numpy as np

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import pack, utils  # noqa: E402
from yade.utils import *  # noqa: E402,F401,F403
import yade  # noqa: E402,F401
from yade import _utils  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--n", type=int, default=300)
cli.add_argument("--rule", choices=("conserved", "fixed", "native"), default="conserved")
cli.add_argument("--dir", default=".", help="files of the native rule")
cli.add_argument("--steps", type=int, default=6000)
cli.add_argument("--seed", type=int, default=1)
cli.add_argument("--water-content", type=float, default=0.01)
cli.add_argument("--vstar", type=float, default=0.02)
cfg = cli.parse_args(sys.argv[1:])

R = 1e-3
side = (cfg.n * 4 / 3 * math.pi * R**3 / 0.6) ** (1 / 3)
sp = pack.SpherePack()
if cfg.rule == "native":          # radius ratio 1.25: one of YADE's file ratios
    sp.makeCloud((0, 0, 0), (side, side, 2.2 * side), rMean=1.1 * R, rRelFuzz=0, num=cfg.n // 2,
                 seed=cfg.seed)
    sp.makeCloud((0, 0, 0), (side, side, 2.2 * side), rMean=0.88 * R, rRelFuzz=0,
                 num=cfg.n - cfg.n // 2, seed=cfg.seed + 1)
else:
    sp.makeCloud((0, 0, 0), (side, side, 2.2 * side), rMean=R, rRelFuzz=0.2, num=cfg.n,
                 seed=cfg.seed)
mat = O.materials.append(FrictMat(young=1e6, poisson=0.3, density=2600, frictionAngle=0.4,
                                  label="glass"))
O.bodies.append(utils.aabbWalls([(0, 0, 0), (side, side, 2.2 * side)], thickness=0, material=mat))
ids = sp.toSimulation(material=mat)
if cfg.rule == "conserved":
    cap = CapbridgeEngine(theta={"glass": 20.0}, gamma=0.073, water_content=cfg.water_content,
                          coalescence_every=500, label="pack")
elif cfg.rule == "fixed":
    cap = CapbridgeEngine(theta={"glass": 20.0}, gamma=0.073, bridge_volume_star=cfg.vstar,
                          initial_wet_gap=0.1 * R, coalescence_every=500, label="pack")
if cfg.rule == "native":
    from capbridge.yade.native_volume import NativeVolumeBridges  # noqa: E402

    radii = [O.bodies[i].shape.radius for i in ids]
    nb = NativeVolumeBridges(cfg.dir, 20.0, radii, bridge_volume_star=cfg.vstar, gamma=0.073)
    f = nb.detection_factor
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=f), Bo1_Box_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=f), Ig2_Box_Sphere_ScGeom()],
                        [Ip2_FrictMat_FrictMat_CapillaryPhys()],
                        [Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)]),
        nb.law2(),
        NewtonIntegrator(damping=0.3, gravity=(0, 0, -9.81)),
    ]
else:
    O.engines = yade_runtime.box_engines(cap.pyrunner())
O.dt = 0.5 * utils.PWaveTimeStep()


def finite():
    xyz = [np.fromiter(_utils.coordsAndDisplacements(k)[0], float) for k in range(3)]
    return bool(all(np.all(np.isfinite(c)) for c in xyz))


records = []
seen, ever = set(), set()          # native rule: bridged pairs at the last record, ever before
chunk = max(1, cfg.steps // 12)
rng = np.random.default_rng(cfg.seed)
kicked = False
all_finite = True
while O.iter < cfg.steps:
    O.run(chunk, True)
    if not kicked and O.iter >= cfg.steps // 2:
        for i in ids:
            O.bodies[i].state.vel = Vector3(*rng.normal(0.0, 0.15, 3))
        kicked = True
    if cfg.rule == "native":
        sc = nb.scan(pairs=True)
        now = {tuple(sorted(p)) for p in sc.pop("pairs").tolist()}
        all_finite &= finite() and math.isfinite(sc["total_volume"])
        records.append({"iter": O.iter, "scan": sc, "n_bridges": sc["n_bridges"],
                        "lost": len(seen - now), "new": len(now - seen),
                        "reformed": len((now - seen) & ever),
                        "unbalanced": float(utils.unbalancedForce())})
        ever |= seen
        seen = now
        continue
    b = cap.budget()
    st = cap.state()
    all_finite &= finite() and st["finite"]
    br = cap.bridges()
    records.append({"iter": O.iter, "budget": b, "n_bridges": st["n_bridges"],
                    "sum_bridge_volumes": float(np.sum(br["volume"])),
                    "max_force": float(np.max(np.abs(br["force"]), initial=0.0)) if br["force"] is not None else 0.0,
                    "coalescence": st["coalescence"], "unbalanced": float(utils.unbalancedForce())})
mass = float(sum(O.bodies[i].state.mass for i in ids))
radii = np.array([O.bodies[i].shape.radius for i in ids])
py = cfg.rule != "native"
yade_runtime.emit_result({"rule": cfg.rule, "n": len(ids), "mass": mass,
                          "water_content": cfg.water_content, "vstar": cfg.vstar,
                          "r_min": float(radii.min()),
                          "liquid_density": cap.liquid_density if py else None,
                          "finite": bool(all_finite), "records": records,
                          "state": cap.state() if py else nb.info,
                          "messages": cap.messages[-5:] if py else []})
