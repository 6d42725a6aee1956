"""YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` lookup replayed in Python.

Given the ``M(r=...)`` files of an export (:func:`~capbridge.yade.law2_files.
read_capillary_files`), :func:`law2_force` is the force YADE's Law2 applies to a pair of
spheres, following ``capillarylaw::interpolate`` branch by branch: check an export (what
a scene will get between and beyond the tabulated points) without running YADE.  The
tests compare it with YADE itself.
"""
from __future__ import annotations

import numpy as np

_ZERO = np.zeros(6)  # V, F, delta1, delta2, nn11, nn33


def _interp_block(rows, P):
    """``TableauD::Interpolate3``: linear in P; zeros beyond the largest P."""
    p = rows[:, 1]
    for k in range(1, len(rows)):
        if p[k] > P:
            w = (P - p[k - 1]) / (p[k] - p[k - 1])
            lo, hi = rows[k - 1, 2:], rows[k, 2:]
            return lo + (hi - lo) * w
        if p[k] == P:
            return rows[k, 2:].copy()
    return _ZERO.copy()


def _interp_file(blocks, D, P):
    """``Tableau::Interpolate2``: linear in D between consecutive blocks."""
    if D < blocks[0][0]:
        raise ValueError(f"D={D} below the first block (YADE reads out of bounds)")
    for i, (d_i, rows) in enumerate(blocks):
        if d_i > D:
            d_lo, rows_lo = blocks[i - 1]
            w = (D - d_lo) / (d_i - d_lo)
            return _interp_block(rows_lo, P) * (1 - w) + _interp_block(rows, P) * w
        if d_i == D:
            return _interp_block(rows, P)
    return _ZERO.copy()


def law2_interpolate(files, ratio, D, P):
    """What ``Law2_ScGeom_CapillaryPhys_Capillarity`` reads from ``files`` (YADE units).

    ``files``: list of ``(ratio, blocks)`` as from :func:`read_capillary_files`;
    ``ratio`` = R/r >= 1, ``D`` = d/R >= 0, ``P`` = uc R/gamma > 0.
    Returns a dict ``V, F, delta1, delta2, nn11, nn33`` (all zero = no bridge), following
    YADE's ``capillarylaw::interpolate`` step by step (same branches, same order).
    """
    out = _ZERO.copy()
    for i, (r_i, blocks) in enumerate(files):
        if r_i > ratio:
            if i == 0:
                raise ValueError("ratio below the first file's ratio")
            r_lo, blocks_lo = files[i - 1]
            w = (ratio - r_lo) / (r_i - r_lo)
            out = _interp_file(blocks_lo, D, P) * (1 - w) + _interp_file(blocks, D, P) * w
            break
        if r_i == ratio:
            out = _interp_file(blocks, D, P)
            break
    return dict(zip(("V", "F", "delta1", "delta2", "nn11", "nn33"), map(float, out)))


def law2_force(files, radius1, radius2, distance, suction, surface_tension):
    """Capillary force [N] YADE's Law2 applies to two spheres (SI inputs).

    ``distance`` is the gap between the surfaces [m] (negative = overlap, treated as 0),
    ``suction`` = u_gas - u_liquid [Pa] > 0.  Returns ``(force, volume)`` with the force
    positive for attraction and the bridge volume [m^3] (0 = no bridge).
    """
    r_small, r_large = sorted((float(radius1), float(radius2)))
    res = law2_interpolate(files, r_large / r_small, max(distance, 0.0) / r_large,
                           suction * r_large / surface_tension)
    return (res["F"] * 2.0 * np.pi * r_large * surface_tension, res["V"] * r_large**3)
