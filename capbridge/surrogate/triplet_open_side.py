"""Open sides beyond the triplet table: a documented continuation (status APPROXIMATE).

A table computed only where the two bridges on the shared grain have small gaps
(``TripletGrid.max_bridge_gap``: the second table, ``data/triplet_table_packings.nc``)
has an open side, the third gap, up to its last gap node d_max (0.6).  In 1,000-grain
packings at 5 % water every coalesced triplet it refused had its two bridges at contact
and an open side between 0.60 and 0.98 (25 of 25, equal and +-25 % radii; opening
angles up to 97 deg, where this project's Evolver driver finds no starting body for
most of them).  With ``TripletSurrogate(open_side="linear")`` such a triplet is
answered by continuing the table linearly in its open side d from the last two gap
nodes d_prev < d_max, at a fixed volume ratio v (w = (d - d_max) / (d_max - d_prev)):

    V*_coal(d) = V*_coal(d_max) + w [V*_coal(d_max) - V*_coal(d_prev)],
    v = V* / V*_coal(d),
    y(d) = y(d_max, v) + w [y(d_max, v) - y(d_prev, v)]

for the pair forces, pressure, energy and the energy difference to the separated state,
up to d = :data:`OPEN_SIDE_LINEAR_MAX`; beyond it the geometry is refused as before.
Measured against Surface Evolver (``benchmarks/bench_open_side.py``, the table's own
settings) on the 9 of 24 such triplets it solves (open side 0.7-0.98, theta 30-60 deg,
radii up to 1.56; the others have no starting body or fold at opening angles near and
beyond 90 deg): :data:`OPEN_SIDE_ERROR`.  Answers compared there: the table at its edge
with the same V* (4.0 % median, 21 % max of the body's largest pair force), with the
same v (4.6 %, 13 %), and this continuation (1.2 %, 4.0 %).  The gravity response is
the edge's.

:func:`beyond_open_side` says which points are continued; :meth:`TripletSurrogate.predict
<capbridge.surrogate.triplet.TripletSurrogate.predict>` applies it.
"""
from __future__ import annotations

import numpy as np

__all__ = ["OPEN_SIDES", "OPEN_SIDE_LINEAR_MAX", "OPEN_SIDE_ERROR", "beyond_open_side"]

#: what ``TripletSurrogate(open_side=...)`` does with an open side beyond the table
OPEN_SIDES = {
    "refuse": "an open side beyond the table's last gap node is outside the table (an "
              "error, or no lookup in covers())",
    "linear": "continued linearly in the open side at fixed v from the last two gap nodes, "
              "up to OPEN_SIDE_LINEAR_MAX (status APPROXIMATE)",
}

#: the largest open side (gap / r) that ``open_side="linear"`` answers: the largest met
#: in the packings at 5 % water (0.98) and measured (0.979)
OPEN_SIDE_LINEAR_MAX = 1.0

#: errors of the continuation against Surface Evolver, |f_ij - f_ij(Evolver)| over the
#: body's largest |f(Evolver)|, every pair of the 9 triplets (benchmarks/RESULTS.md,
#: "Coalesced triplets beyond the table's open side")
OPEN_SIDE_ERROR = {"median": 0.012, "max": 0.040, "n_triplets": 9,
                   "open_side": (0.7, 0.979),
                   "source": "benchmarks/bench_open_side.py, second table"}


def beyond_open_side(gaps, last_gap, max_bridge_gap, limit=OPEN_SIDE_LINEAR_MAX):
    """True where a point's largest gap (its open side) lies in (last_gap, limit] and the
    other two within the table's bridge gaps: the points the continuation answers.

    Parameters
    ----------
    gaps : sequence of three arrays (d12, d13, d23), lookup units.
    last_gap : float, the table's last gap node d_max.
    max_bridge_gap : float or None, the table's ``max_bridge_gap`` (None: a table
        computed over its whole cube has no open side; nothing is continued).
    limit : float

    >>> beyond_open_side([np.array([0.0, 0.0]), np.array([0.0, 0.1]),
    ...                   np.array([0.8, 1.2])], 0.6, 0.2).tolist()
    [True, False]
    """
    g = np.stack(np.broadcast_arrays(*(np.asarray(x, float) for x in gaps)))
    if max_bridge_gap is None:
        return np.zeros(g.shape[1:], bool)
    srt = np.sort(g, axis=0)
    tol = 1e-12 * max(1.0, last_gap)
    return (srt[2] > last_gap + tol) & (srt[2] <= limit + tol) & \
        (srt[1] <= max_bridge_gap * (1 + 1e-12) + 1e-12)
