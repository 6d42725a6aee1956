"""Two fixed spheres under YADE's Law2_ScGeom_CapillaryPhys_Capillarity, fed with M(r=...) files.

Run either way (see capbridge.yade.yade_runtime; capbridge must be importable,
e.g. PYTHONPATH=<project root>, which run_yade_script sets):
    python two_spheres_law2.py  --dir DIR --suffix _theta0 --r1 1e-3 --r2 2e-3 \
        --suction 100 --gamma 0.073 --gaps=0,1e-5,2e-4
    yade -n -x two_spheres_law2.py --dir DIR ...

For every gap (surface-to-surface distance, m) the spheres are placed on the z axis,
one step is run and YADE's capillary force is read back (O.forces and the interaction
physics).  The result is printed as one JSON line (CAPBRIDGE_RESULT ...), together with
what capbridge's emulation of YADE's interpolation expects from the same files.
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
cli.add_argument("--dir", required=True, help="directory holding the M(r=...) files")
cli.add_argument("--suffix", default="", help="suffCapFiles")
cli.add_argument("--r1", type=float, default=1e-3)
cli.add_argument("--r2", type=float, default=1e-3)
cli.add_argument("--suction", type=float, required=True, help="u_gas - u_liquid [Pa]")
cli.add_argument("--gamma", type=float, default=0.073, help="surface tension [N/m]")
cli.add_argument("--gaps", type=yade_runtime.float_list, required=True, help="comma-separated gaps [m]; < 0 = overlap")
cli.add_argument("--mindlin", action="store_true", help="Hertz-Mindlin contact physics")
cfg = cli.parse_args(sys.argv[1:])

os.chdir(cfg.dir)  # YADE opens M(r=...)<suffix> relative to the working directory

ip2 = Ip2_FrictMat_FrictMat_MindlinCapillaryPhys() if cfg.mindlin else Ip2_FrictMat_FrictMat_CapillaryPhys()
law = Law2_ScGeom_MindlinPhys_Mindlin(neverErase=True) if cfg.mindlin else Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)
cap = Law2_ScGeom_CapillaryPhys_Capillarity(capillaryPressure=cfg.suction, surfaceTension=cfg.gamma,
                                            suffCapFiles=cfg.suffix, createDistantMeniscii=True,
                                            label="cap")
b0, b1 = yade_runtime.two_fixed_spheres(cfg.r1, cfg.r2, cfg.gaps[0], ip2, law, cap)

from capbridge.yade import yade_export  # noqa: E402

files = yade_export.read_capillary_files(".", cfg.suffix)
rows = []
for gap in cfg.gaps:
    O.bodies[b1].state.pos = Vector3(0, 0, cfg.r1 + cfg.r2 + gap)
    O.step()
    f0 = O.forces.f(b0)                      # force on the lower sphere
    row = {"gap": gap, "force_on_0_z": float(f0[2]),
           # attraction pulls sphere 0 towards sphere 1 (+z): positive = attraction
           "force": float(f0[2])}
    if O.interactions.has(b0, b1) and O.interactions[b0, b1].isReal:
        i = O.interactions[b0, b1]
        row.update(interaction=True, fCap=float(i.phys.fCap.norm()),
                   vMeniscus=float(i.phys.vMeniscus), Delta1=float(i.phys.Delta1),
                   Delta2=float(i.phys.Delta2), meniscus=bool(i.phys.meniscus),
                   penetrationDepth=float(i.geom.penetrationDepth))
    else:
        row.update(interaction=False, fCap=0.0, vMeniscus=0.0)
    exp_f, exp_v = yade_export.law2_force(files, cfg.r1, cfg.r2, gap, cfg.suction, cfg.gamma)
    row.update(expected_force=exp_f, expected_volume=exp_v)
    rows.append(row)

yade_runtime.emit_result({"engine": "Law2_ScGeom_CapillaryPhys_Capillarity",
                          "yade_version": yade.config.version, "python": sys.version.split()[0],
                          "numpy": __import__("numpy").__version__,
                          "r1": cfg.r1, "r2": cfg.r2, "suction": cfg.suction,
                          "gamma": cfg.gamma, "suffix": cfg.suffix, "rows": rows})
