"""Doublet answers at any points: the table where both contact angles are equal, the
exact solver where they differ.

The doublet table holds one contact angle on both grains; a bridge between two
different angles is not the bridge of their mean (issue 9), so those points go to the
vectorised exact Young-Laplace solver (thousands of points per second), and each
point says which answered it.
"""
from __future__ import annotations

import numpy as np

from capbridge.solvers.young_laplace import rupture_distance, solve_doublet
from capbridge.status import Status
from capbridge.surrogate.names import DOUBLET_OUTPUTS
from capbridge.validation import check_gap


def lookup_points(sur, d, V, theta, ratio, theta2=None):
    """Answers at points: the table where theta2 == theta, the exact solver elsewhere.

    Parameters
    ----------
    sur : DoubletSurrogate
        A fitted surrogate (:func:`~capbridge.surrogate.load.load_doublet_surrogate`).
    d, V, theta : ndarray (n,)
        Gap d* = d/R1, volume V* = V/R1^3, contact angle on grain 1 [deg].
    ratio : array_like
        R2/R1 >= 1, broadcast to (n,).
    theta2 : ndarray (n,), optional
        Contact angle on grain 2 [deg]; default ``theta`` (the table answers all).

    Returns
    -------
    dict
        The :data:`~capbridge.surrogate.names.DOUBLET_OUTPUTS` keys (n,), ``status``
        (int8) and ``method`` ("table" or "exact").
    """
    d = check_gap("gap d*", d)          # a DEM contact for the exact solver too, as the table
    n = d.size
    mixed = np.zeros(n, bool) if theta2 is None else ~(theta2 == theta)
    out = {k: np.full(n, np.nan) for k in DOUBLET_OUTPUTS}
    status = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    ratio = np.broadcast_to(np.asarray(ratio, float), (n,))
    tab = ~mixed
    if tab.any():
        r = sur.predict(d[tab], V[tab], theta[tab], ratio[tab])
        for k in out:
            out[k][tab] = r[k]
        status[tab] = r["status"]
    if mixed.any():
        args = (V[mixed], theta[mixed], ratio[mixed], theta2[mixed])
        ex = solve_doublet(d[mixed], *args)
        for k in ("force", "pressure", "beta1", "beta2"):
            out[k][mixed] = ex[k]
        out["rupture_gap"][mixed] = rupture_distance(*args)["gap"]
        status[mixed] = ex["status"]
    return out | {"status": status, "method": np.where(mixed, "exact", "table")}
