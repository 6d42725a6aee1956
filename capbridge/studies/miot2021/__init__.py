"""``capbridge reproduce miot2021``: the triplet study of Miot et al. (2021) redone.

The experiment's triplet (El Korchi et al. 2017; ``DESIGN.md``): three glass beads of
radius r = 4 mm, bottom gap 0.3 mm (d23* = 0.075), top gaps 0.7 mm (d12* = d13* =
0.175); volumes in ul = mm^3, V* = V / 64.  Grain 1 is the top grain, gravity along -z.

What is computed (stages; each Evolver stage is a resumable :func:`run_sweep`):

* ``exact``       separate bridges 1-2 and 1-3 (equal volumes) by the exact doublet
                  solver, no gravity: vertical force on the top grain against volume;
                  coalescence volumes V_coal(theta) by the caps criterion (and the
                  other criteria of :mod:`capbridge.solvers.triplet`), linear fit.
* ``doublets``    Fig. 3: V* = 0.008 and 0.156, theta = 0: exact, energy method
                  (Evolver virtual work), closed forms (Pitois, Richefeu, Willett).
* ``bridges``     separate bridges by Evolver: with gravity (Bo = 2.14, 2.26) the force
                  before coalescence and the signed gap left between the wetted caps
                  on the top grain, whose zero gives V_coal under gravity; without
                  gravity near V_coal, to measure how far the mesh-based criterion is
                  from the exact one (the bias is removed from the gravity values).
* ``coalesced``   one body wetting the three grains (Evolver), from V_coal to 40 ul,
                  without gravity and with both Bond numbers; pair forces, energies,
                  lowest point of the lower meniscus (trimer or dimer).
* ``energy``      coalesced bodies below V_coal (no gravity), for the energy crossing.

Outputs in ``output_dir``: PNG figures, CSV tables, ``summary.json`` and ``CLAIMS.md``
(the paper's stated numbers beside ours).  Evolver results are checkpointed per point
under ``checkpoint_dir`` (rerun the same command to resume); shapes (plane sections)
are kept there too.

Contact angles: theta = 0, 15, ..., 75 deg without gravity; with gravity 0-60 deg at
gamma = 0.073 N/m and 55, 60 deg at gamma = 0.0693 N/m (the paper's calibration).  Not
90 deg: the exact doublet solver covers [0, 90) (at 90 deg a bridge between spheres has no
concave branch to continue from, and the exact-solver V_coal is given up to 89 deg
instead).

The package, by idea: :mod:`.experiment` (the triplet, volume units), :mod:`.paper` (the
paper's stated numbers), :mod:`.plan` (what is computed), :mod:`.points` (the kinds of
Evolver points), :mod:`.compute` (running the solves), :mod:`.analyse` (reducing the
results to the paper's quantities), :mod:`.figures`, :mod:`.claims` (``CLAIMS.md``) and
:mod:`.pipeline` (:func:`run`: all of it in order).  The names below are those the module
``capbridge.studies.miot2021`` had before it became a package.
"""
from __future__ import annotations

from capbridge.studies.miot2021.analyse import build_summary
from capbridge.studies.miot2021.claims import write_claims
from capbridge.studies.miot2021.compute import doublet_exact, exact_stage, solve_points
from capbridge.studies.miot2021.experiment import (D12, D13, D23, GAMMAS, RADIUS,
                                                   UL_PER_VSTAR, ul, vstar)
from capbridge.studies.miot2021.figures import make_figures
from capbridge.studies.miot2021.paper import FIG3_VOLUMES, PAPER, PAPER_LINE_TEXT, paper_line
from capbridge.studies.miot2021.pipeline import analyse_and_write, run
from capbridge.studies.miot2021.plan import Plan
from capbridge.studies.miot2021.points import (BRIDGES, COALESCED, DOUBLET, HAS_RESULT_CODES,
                                               HAS_RESULT_NAMES, KIND_NAMES)

__all__ = [
    "BRIDGES", "COALESCED", "D12", "D13", "D23", "DOUBLET", "FIG3_VOLUMES", "GAMMAS",
    "HAS_RESULT_CODES", "HAS_RESULT_NAMES", "KIND_NAMES", "PAPER", "PAPER_LINE_TEXT", "Plan",
    "RADIUS", "UL_PER_VSTAR", "analyse_and_write", "build_summary", "doublet_exact",
    "exact_stage", "make_figures", "paper_line", "run", "solve_points", "ul", "vstar",
    "write_claims",
]
