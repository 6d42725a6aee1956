"""Status of every computed or looked-up point (stored as CF flag values in tables)."""
from __future__ import annotations

import enum
from functools import lru_cache

import numpy as np


class Status(enum.IntEnum):
    """Why a number is (or is not) there.  Never a silent NaN."""

    CONVERGED = 0        #: solution found to the stated tolerance
    RUPTURED = 1         #: beyond the rupture distance: no bridge, force zero
    NOT_CONVERGED = 2    #: the solver failed; the point carries no result
    NOT_COMPUTED = 3     #: not yet computed (resumable sweeps)
    COALESCED = 4        #: bridges have merged; the doublet answer does not apply
    OUT_OF_RANGE = 5     #: outside the table; no extrapolation unless asked
    EXTRAPOLATED = 6     #: outside the table, answered by an explicit fallback
    #: finished at the finest level allowed (``max_refine``) with its own estimated
    #: error above the tolerance (``ftol``/``etol``): numbers are there, the stated
    #: precision is not reached (the estimate is in the result)
    ABOVE_TOLERANCE = 7
    #: no equilibrium of this liquid body exists here (e.g. a coalesced body below the
    #: smallest volume at which it holds together): the separate bridges apply
    NO_EQUILIBRIUM = 8
    #: answered by a documented approximation outside the table's assumptions (e.g. a
    #: triplet of unequal grains from the equal-sphere table); its error is documented
    APPROXIMATE = 9


#: statuses whose numbers are a result (the others carry none, or a force of 0)
HAS_RESULT = (Status.CONVERGED, Status.ABOVE_TOLERANCE, Status.APPROXIMATE)


#: one past the largest status code
_N_CODES = max(Status) + 1


@lru_cache(maxsize=None)
def _mask(codes):
    table = np.zeros(_N_CODES, bool)
    table[list(codes)] = True
    table.flags.writeable = False
    return table


def status_in(status, codes):
    """True where ``status`` (integer codes, any shape) is one of ``codes``.

    What ``np.isin(status, codes)`` gives, by indexing a boolean table of the few
    codes; ``np.isin`` sorts its arguments on every call, which costs ~0.1 ms even
    for a handful of points and is paid on every DEM step.

    >>> status_in([0, 5, 9], HAS_RESULT).tolist()
    [True, False, True]
    >>> status_in([-1, 12], HAS_RESULT).tolist()
    [False, False]
    """
    codes = tuple(sorted({int(c) for c in codes}))
    idx = np.asarray(status).astype(np.intp)
    if idx.size and not 0 <= idx.min() <= idx.max() < _N_CODES:
        return np.isin(status, codes)          # not a status code: matches none of them
    return _mask(codes)[idx]


def cf_flag_attributes():
    """``flag_values``/``flag_meanings`` attributes for a status variable."""
    return {
        "flag_values": [int(s) for s in Status],
        "flag_meanings": " ".join(s.name.lower() for s in Status),
        "long_name": "status of the point",
    }


def status_name(code):
    """Lower-case name of a status code, as written to CSV and JSON."""
    return Status(int(code)).name.lower()
