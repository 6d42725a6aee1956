"""Two fixed spheres under YADE's CapillarityEngine (CapillaryPhysDelaunay physics).

    python two_spheres_delaunay.py --dir DIR --file capillaryfile_theta0.txt \
        --r1 1e-3 --r2 2e-3 --suction 100 --gamma 0.073 --gaps=0,1e-4 [--volumes=V0,V1]

Suction-controlled (default): the engine's imposePressure=True, every bridge takes the
suction.  With --volumes (one per gap, m^3) the engine runs volume-controlled
(imposePressure=False, totalVolumeConstant=False): after the first step the bridge
volume is set to the given value before each step, and the engine interpolates force
and suction at that volume.  Also reports the engine's solveStandalone() at each state.
Prints one JSON line (CAPBRIDGE_RESULT ...).

Do not name globals like the yade launcher's (opts, args, par, ...): under
``yade -x`` the scene shares the launcher's globals.
"""
import argparse
import os
import sys

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.utils import *  # noqa: E402,F401,F403  (as the yade launcher does)
import yade  # noqa: E402


cli = argparse.ArgumentParser()
cli.add_argument("--dir", required=True)
cli.add_argument("--file", default="capillaryfile.txt", help="inputFilename")
cli.add_argument("--r1", type=float, default=1e-3)
cli.add_argument("--r2", type=float, default=1e-3)
cli.add_argument("--suction", type=float, required=True, help="u_gas - u_liquid [Pa]")
cli.add_argument("--gamma", type=float, default=0.073)
cli.add_argument("--gaps", type=yade_runtime.float_list, required=True, help="comma-separated gaps [m]; < 0 = overlap")
cli.add_argument("--volumes", type=yade_runtime.float_list, default=None, help="comma-separated volumes [m^3]")
cfg = cli.parse_args(sys.argv[1:])
if cfg.volumes is not None and len(cfg.volumes) != len(cfg.gaps):
    raise SystemExit("--volumes needs one value per gap")

os.chdir(cfg.dir)

volume_mode = cfg.volumes is not None
cap = CapillarityEngine(inputFilename=cfg.file, capillaryPressure=cfg.suction,
                        liquidTension=cfg.gamma, createDistantMeniscii=True,
                        interactionDetectionFactor=2.0,
                        imposePressure=not volume_mode, totalVolumeConstant=False,
                        label="cap")
b0, b1 = yade_runtime.two_fixed_spheres(cfg.r1, cfg.r2, cfg.gaps[0],
                                        Ip2_FrictMat_FrictMat_CapillaryPhysDelaunay(),
                                        Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True), cap)

rows = []
if volume_mode:
    O.step()   # first step: the engine gives every bridge its volume at capillaryPressure
for k, gap in enumerate(cfg.gaps):
    O.bodies[b1].state.pos = Vector3(0, 0, cfg.r1 + cfg.r2 + gap)
    if volume_mode:
        # YADE 2023.02a caches the last tetrahedron (and its normals) of every bridge
        # without telling the pressure- from the volume-based triangulation, and does not
        # reset it when the engine switches from its first, pressure-based step to volume
        # control: the first volume-based lookups of the bridges present at that switch
        # land in the pressure triangulation.  A fresh interaction has an empty cache.
        if O.interactions.has(b0, b1):
            O.interactions.erase(b0, b1)
        utils.createInteraction(b0, b1)
        O.interactions[b0, b1].phys.vMeniscus = cfg.volumes[k]
    O.step()
    f0 = O.forces.f(b0)
    row = {"gap": gap, "force": float(f0[2])}   # + = attraction (sphere 0 pulled to +z)
    if O.interactions.has(b0, b1) and O.interactions[b0, b1].isReal:
        i = O.interactions[b0, b1]
        row.update(interaction=True, fCap=float(i.phys.fCap.norm()),
                   vMeniscus=float(i.phys.vMeniscus), Delta1=float(i.phys.Delta1),
                   Delta2=float(i.phys.Delta2), meniscus=bool(i.phys.meniscus),
                   capillaryPressure=float(i.phys.capillaryPressure),
                   SInterface=float(i.phys.SInterface))
    else:
        row.update(interaction=False, fCap=0.0, vMeniscus=0.0)
    if not volume_mode:
        rl, rs = max(cfg.r1, cfg.r2), min(cfg.r1, cfg.r2)
        sa = cap.solveStandalone(rl, rs, cfg.suction, gap)
        row.update(standalone_force=float(sa.fCap[0]), standalone_volume=float(sa.vMeniscus))
    rows.append(row)

yade_runtime.emit_result({"engine": "CapillarityEngine", "yade_version": yade.config.version,
                          "volume_mode": volume_mode, "r1": cfg.r1, "r2": cfg.r2,
                          "suction": cfg.suction, "gamma": cfg.gamma, "file": cfg.file,
                          "rows": rows})
