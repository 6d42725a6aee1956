"""A made-up suction table with the layout of a real one, and its fields anywhere.

Its numbers are *not* liquid-bridge solutions but smooth functions known everywhere,
so an export can be checked against the truth between and beyond its grid points:
the writers' every code path, and how YADE's engines interpolate (the tests of
``tests/test_yade_export.py`` do both).  It costs nothing, where the exact export
(:func:`~capbridge.yade.yade_export.export_from_solver`) takes minutes.
"""
from __future__ import annotations

import math

import numpy as np

from capbridge.status import Status
from capbridge.yade.law2_files import YADE_RATIOS
from capbridge.yade.suction_table import SuctionTable


def _synthetic_fields(rr, ss, gg, theta):
    """The made-up smooth fields of :func:`synthetic_suction_table` (capbridge units)."""
    c = math.cos(math.radians(theta))
    a = 0.12 * (1.0 + 0.5 * np.log(rr)) * (0.6 + 0.4 * c)        # g_rupt = a (1 + 2/(1+0.2 s))
    g_rupt = a * (1.0 + 2.0 / (1.0 + 0.2 * ss))
    volume = 0.02 * rr**0.5 * (1.0 + 1.5 * gg) / (1.0 + 0.15 * ss) ** 1.2
    force = c * (1.0 + 0.04 * np.sqrt(ss)) * (1.0 + 0.3 * (1 - 1 / rr)) * (1.0 - 0.55 * gg / g_rupt)
    beta1 = (25.0 + 10.0 / (1.0 + 0.1 * ss)) * (1.0 - 0.3 * gg / g_rupt)
    return {"volume": volume, "force": force, "beta1": beta1, "beta2": beta1 / rr**0.7,
            "area": 0.5 * volume ** (2.0 / 3.0) * (1.0 + gg), "g_rupt": g_rupt, "a": a}


def synthetic_suction_table(ratios=YADE_RATIOS, suctions=None, gaps=None, theta=0.0,
                            edge=True):
    """A smooth, made-up table with the layout of a real one (for format tests only).

    Its numbers are *not* liquid-bridge solutions: smooth positive functions with a
    rupture gap g_rupt(ratio, suction) that shrinks with suction and grows with the
    radius ratio, so every code path of the writers (rupture inside the grid, all ten
    ratios, rupture points in ``edge``) is exercised.  Evaluate the same functions
    anywhere with :func:`synthetic_bridge`.
    """
    ratios = np.asarray(ratios, float)
    suctions = np.asarray(suctions if suctions is not None
                          else np.concatenate([[0.0], np.geomspace(0.05, 200.0, 24)]), float)
    gaps = np.asarray(gaps if gaps is not None else np.linspace(0.0, 0.8, 41), float)
    rr, ss, gg = np.meshgrid(ratios, suctions, gaps, indexing="ij")
    f = _synthetic_fields(rr, ss, gg, theta)
    status = np.where(gg <= f["g_rupt"], int(Status.CONVERGED), int(Status.RUPTURED))
    bad = status != int(Status.CONVERGED)
    for k in ("volume", "beta1", "beta2", "area"):
        f[k][bad] = np.nan
    f["force"][bad] = 0.0
    edge_pts = None
    if edge:
        # rupture at every grid suction (gap off the grid) ...
        r2, s2 = np.meshgrid(ratios, suctions, indexing="ij")
        g_a = _synthetic_fields(r2, s2, 0.0 * s2, theta)["g_rupt"]
        # ... and at every grid gap (suction off the grid), inside the suction range
        r3, g3 = np.meshgrid(ratios, gaps, indexing="ij")
        a = _synthetic_fields(r3, 0.0 * g3, g3, theta)["a"]
        with np.errstate(divide="ignore", invalid="ignore"):
            s_b = (2.0 / (g3 / a - 1.0) - 1.0) / 0.2
        s_b = np.where((g3 > a) & (s_b >= suctions[0]) & (s_b <= suctions[-1]), s_b, np.nan)
        r_e = np.concatenate([r2, r3], axis=1)
        s_e = np.concatenate([s2, s_b], axis=1)
        g_e = np.concatenate([g_a, g3], axis=1)
        fe = _synthetic_fields(r_e, np.nan_to_num(s_e), g_e, theta)
        edge_pts = {"suction": s_e, "gap": g_e, "area": fe["area"],
                    **{k: fe[k] for k in ("volume", "force", "beta1", "beta2")}}
    return SuctionTable(ratio=ratios, suction=suctions, gap=gaps, volume=f["volume"],
                        force=f["force"], beta1=f["beta1"], beta2=f["beta2"], status=status,
                        theta=theta, area=f["area"], edge=edge_pts,
                        attrs={"source": "capbridge.yade.synthetic_table.synthetic_suction_table"})


def synthetic_bridge(ratio, suction, gap, theta=0.0):
    """The synthetic table's fields at any (ratio, suction, gap); force 0 past rupture."""
    f = _synthetic_fields(*np.broadcast_arrays(*(np.asarray(x, float) for x in (ratio, suction, gap))),
                          theta)
    alive = np.asarray(gap) <= f["g_rupt"]
    return {"force": np.where(alive, f["force"], 0.0), "volume": np.where(alive, f["volume"], np.nan),
            "g_rupt": f["g_rupt"]}
