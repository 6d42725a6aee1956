"""Exact doublet slices for a pair of different contact angles (theta1 != theta2).

capbridge's shipped doublet table holds bridges with one contact angle on both grains.
A bridge between two materials of different wettability is not the bridge of the mean
angle (issue 9 measured 16-20 % too strong for (0, 60) deg and 31-39 % for (0, 80) deg),
so :class:`~capbridge.dem.scene_table.SceneTable` asks this module, at scene start,
for the exact solutions of the pairs of angles the scene holds, on the shipped table's
own coarse grid (ratio x V* x s, s = sqrt(1 - d*/d*_rupt)).  The scene table then
refines them with the same cubic splines as every other slice, so a mixed pair has the
accuracy the table has for equal angles (held-out error of the table: median ~5e-5,
max <= 0.35 % on tabulated ratios for d* <= 0.96 d*_rupt).

Convention (capbridge's): grain 1 is the smaller one (R1, which scales everything),
theta1 its angle, theta2 the angle on the larger grain (ratio = R2/R1 >= 1).  For equal
radii the two orders are the same bridge mirrored (beta1 and beta2 swap).

Cost: one rupture solve per (ratio, V*) and one bridge solve per (ratio, V*, s) point:
about 1 s per coarse ratio on one core (625 + 25 points); results are kept in memory
for the process (:func:`exact_coarse`).
"""
from __future__ import annotations

import functools

import numpy as np

from capbridge.status import Status

__all__ = ["exact_coarse", "VARIABLES"]

#: the bridge variables a slice may hold (the table's names)
VARIABLES = ("force", "pressure", "beta1", "beta2")


@functools.lru_cache(maxsize=64)
def _exact_one_ratio(theta1, theta2, ratio, volumes, s_nodes):
    """Exact coarse slice for one ratio: dict name -> (nV, nS) and rupture_gap (nV,)."""
    from capbridge.solvers.young_laplace import rupture_distance, solve_doublet

    v = np.asarray(volumes, float)
    s = np.asarray(s_nodes, float)
    rup = rupture_distance(v, theta1, ratio, theta2)
    if np.any(rup["status"] != Status.CONVERGED):
        bad = v[rup["status"] != Status.CONVERGED]
        raise RuntimeError(f"exact rupture solve failed for theta = ({theta1:g}, {theta2:g}) "
                           f"deg, ratio {ratio:g}, V* = {bad.tolist()}: no mixed-angle slice "
                           "(the engine refuses rather than guess)")
    d_r = rup["gap"]
    inner = s > 0                               # s = 0 is the rupture point itself
    gap = d_r[:, None] * (1.0 - s[None, inner] ** 2)
    res = solve_doublet(gap, v[:, None], theta1, ratio, theta2)
    out = {}
    ok = res["status"] == Status.CONVERGED
    if not ok.all():
        iv, js = np.nonzero(~ok)
        raise RuntimeError(f"exact bridge solve failed at {iv.size} points for theta = "
                           f"({theta1:g}, {theta2:g}) deg, ratio {ratio:g} (first: V* = "
                           f"{v[iv[0]]:g}, s = {s[inner][js[0]]:g}); no mixed-angle slice")
    for name in VARIABLES:
        full = np.empty((v.size, s.size))
        full[:, inner] = res[name]
        full[:, ~inner] = rup[name][:, None]
        out[name] = full
    out["rupture_gap"] = np.asarray(d_r, float)
    return out


def exact_coarse(theta1, theta2, ratios, volumes, s_nodes, variables=("force",)):
    """Exact doublet solutions on a coarse (ratio, V*, s) grid for angles (theta1, theta2).

    Parameters
    ----------
    theta1, theta2 : float
        Contact angles [deg] on the smaller grain (R1) and on the larger grain.
    ratios : sequence of float
        Radius ratios R2/R1 >= 1 (the table's coarse ratios needed by the scene).
    volumes : sequence of float
        V* = V/R1^3 nodes (the table's coarse volume axis).
    s_nodes : sequence of float
        s = sqrt(1 - d*/d*_rupt) nodes in [0, 1] (the table's coarse s axis); the gap of
        a node is d* = d*_rupt (1 - s^2), d*_rupt from
        :func:`~capbridge.solvers.young_laplace.rupture_distance` at that V*.
    variables : names among :data:`VARIABLES`.

    Returns
    -------
    dict
        ``name -> (n_ratio, n_V, n_s)`` arrays (force F* = F/(2 pi gamma R1), attraction
        > 0; pressure P* = dp R1/gamma; beta1, beta2 half filling angles [deg] on grains
        1 and 2) and ``rupture_gap`` (n_ratio, n_V) d*_rupt.  Every point converged:
        a failed solve raises ``RuntimeError`` (never a silent NaN).
    """
    vols = tuple(float(x) for x in volumes)
    ss = tuple(float(x) for x in s_nodes)
    parts = [_exact_one_ratio(float(theta1), float(theta2), float(r), vols, ss) for r in ratios]
    out = {name: np.stack([p[name] for p in parts]) for name in variables}
    out["rupture_gap"] = np.stack([p["rupture_gap"] for p in parts])
    return out
