"""capbridge's dimensionless values in YADE's units, and back.

YADE's capillary files scale lengths by the **larger** radius ``R`` of the pair
(capbridge uses the smaller one, ``r``; ``ratio = R/r``), and take the suction
``uc = u_gas - u_liquid >= 0`` as the capillary pressure: ``D = d/R``, ``P = uc R/gamma``,
``V = V/R^3``, ``F = F/(2 pi gamma R)`` in the ``M(r=...)`` files (``F/(gamma R)``, no
2 pi, in ``CapillarityEngine``'s file), areas over ``R^2``.
"""
from __future__ import annotations

import numpy as np

#: how the writers print YADE's values
FLOAT_FORMAT = "%.15g"


def to_yade_units(ratio, suction=None, gap=None, volume=None, force=None, area=None,
                  nn=None, delaunay=False):
    """Convert capbridge's dimensionless values (radius r) to YADE's (radius R = ratio r).

    Returns a dict with the keys given: ``P`` (uc R/gamma), ``D``, ``V``, ``F``
    (``F/(2 pi gamma R)``, or ``F/(gamma R)`` when ``delaunay``), ``area`` and ``nn``
    (over R^2).

    >>> out = to_yade_units(2.0, suction=3.0, gap=0.2, volume=0.8, force=1.0)
    >>> [round(float(out[k]), 6) for k in ("P", "D", "V", "F")]
    [6.0, 0.1, 0.1, 0.5]
    """
    rho = np.asarray(ratio, float)
    out = {}
    if suction is not None:
        out["P"] = np.asarray(suction, float) * rho
    if gap is not None:
        out["D"] = np.asarray(gap, float) / rho
    if volume is not None:
        out["V"] = np.asarray(volume, float) / rho**3
    if force is not None:
        out["F"] = np.asarray(force, float) / rho * (2.0 * np.pi if delaunay else 1.0)
    if area is not None:
        out["area"] = np.asarray(area, float) / rho**2
    if nn is not None:
        out["nn"] = np.asarray(nn, float) / rho**2
    return out


def from_yade_units(ratio, P=None, D=None, V=None, F=None, delaunay=False):
    """Inverse of :func:`to_yade_units`: YADE's dimensionless values back to capbridge's.

    Returns a dict with ``suction``, ``gap``, ``volume``, ``force`` for the keys given.
    """
    rho = np.asarray(ratio, float)
    out = {}
    if P is not None:
        out["suction"] = np.asarray(P, float) / rho
    if D is not None:
        out["gap"] = np.asarray(D, float) * rho
    if V is not None:
        out["volume"] = np.asarray(V, float) * rho**3
    if F is not None:
        out["force"] = np.asarray(F, float) * rho / (2.0 * np.pi if delaunay else 1.0)
    return out
