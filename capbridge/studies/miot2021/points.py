"""The Evolver points of the study: their kinds, the statuses that count as a result,
and the name under which a point's shape is kept."""
from __future__ import annotations

from capbridge.status import Status
from capbridge.studies.miot2021.experiment import UL_PER_VSTAR

#: statuses of a point whose numbers are used (by name, as in the CSV files, and by code)
HAS_RESULT_NAMES = ("converged", "above_tolerance")
HAS_RESULT_CODES = (int(Status.CONVERGED), int(Status.ABOVE_TOLERANCE))

#: kinds of Evolver points
DOUBLET, COALESCED, BRIDGES = 0, 1, 2
KIND_NAMES = {DOUBLET: "doublet", COALESCED: "coalesced", BRIDGES: "bridges"}


def point_key(kind, theta, volume, bond, gap, level):
    """File name (without ``.npz``) of a point's plane section under the shapes directory."""
    return (f"{KIND_NAMES[int(kind)]}_t{theta:g}_v{float(volume) * UL_PER_VSTAR:.4f}"
            f"_bo{bond:g}_d{gap:g}_L{int(level)}")
