"""Two equal spheres under YADE's compiled Law2 built by capbridge (suction control).

    python suction_native_capbridge.py --dir DIR --theta 30 --r 1e-3 --suction 73 \
        --gamma 0.073 --gaps=0,1e-5,...

``capbridge.yade.engine.suction_law2`` builds ``Law2_ScGeom_CapillaryPhys_Capillarity``
on capbridge's exported ``M(r=...)`` files in DIR (suffix for theta).  The spheres are
fixed; for every gap [m] they are placed, one step is run, and the force on sphere 0
(positive: attraction) and the bridge YADE holds are read back.  Prints one JSON line.
"""
import argparse
import sys

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.utils import *  # noqa: E402,F401,F403
import yade  # noqa: E402

from capbridge.yade.engine import suction_law2  # noqa: E402


cli = argparse.ArgumentParser()
cli.add_argument("--dir", required=True)
cli.add_argument("--theta", type=float, required=True)
cli.add_argument("--theta2", type=float, default=None, help="angle on the second grain")
cli.add_argument("--r", type=float, default=1e-3)
cli.add_argument("--suction", type=float, required=True)
cli.add_argument("--gamma", type=float, default=0.073)
cli.add_argument("--gaps", type=yade_runtime.float_list, required=True)
cfg = cli.parse_args(sys.argv[1:])

law = suction_law2(cfg.dir, cfg.theta, cfg.suction, cfg.gamma, export_if_missing=False,
                   theta2=cfg.theta2)
law.createDistantMeniscii = True          # wet the pair at its first position
b0, b1 = yade_runtime.two_fixed_spheres(cfg.r, cfg.r, cfg.gaps[0], Ip2_FrictMat_FrictMat_CapillaryPhys(),
                                        Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True), law)
rows = []
for gap in cfg.gaps:
    O.bodies[b1].state.pos = Vector3(0, 0, 2 * cfg.r + gap)
    O.step()
    row = {"gap": gap, "force": float(O.forces.f(b0)[2])}
    if O.interactions.has(b0, b1) and O.interactions[b0, b1].isReal:
        i = O.interactions[b0, b1]
        row.update(interaction=True, vMeniscus=float(i.phys.vMeniscus), meniscus=bool(i.phys.meniscus))
    else:
        row.update(interaction=False, vMeniscus=0.0)
    rows.append(row)
yade_runtime.emit_result({"theta": cfg.theta, "suction": cfg.suction, "suffix": law.suffCapFiles,
                          "yade_version": yade.config.version, "rows": rows})
