"""Write capbridge's suction-controlled doublet tables in YADE's own input formats.

Two compiled YADE engines (2023.02a) read precomputed liquid-bridge solutions:

1. ``Law2_ScGeom_CapillaryPhys_Capillarity`` reads ten files ``M(r=1)``..``M(r=10)``
   (:mod:`capbridge.yade.law2_files`: :func:`write_capillary_files`, and
   :mod:`capbridge.yade.law2_interpolation`: what YADE reads from them).
2. ``CapillarityEngine`` reads one unstructured file, ``capillaryfile.txt``
   (:mod:`capbridge.yade.delaunay_files`: :func:`write_delaunay_file`).

Both take a :class:`~capbridge.yade.suction_table.SuctionTable` in capbridge's units
and write YADE's (:mod:`capbridge.yade.yade_units`: lengths over the larger radius),
with a JSON manifest beside (:mod:`capbridge.yade.export_manifest`);
:mod:`capbridge.yade.synthetic_table` makes a table whose truth is known everywhere, to
check an export.  This module is the entry point: :func:`export_from_solver` solves the
table with the exact solver (with the bridges at rupture, :func:`rupture_edge`) and
writes both formats; the names of the modules above are importable from here too.

Accuracy (measured in YADE with the exact solver's export, theta = 30 deg): at
tabulated ratios and suctions both engines reproduce the solver to 1e-4 up to 80 % of
the rupture gap; between tabulated suctions Law2 stays within 0.2 %, CapillarityEngine
within 0.5-3 % (its tetrahedra span neighbouring suctions and ratios in very
anisotropic coordinates).  Near rupture the force is resolved to one grid cell: Law2
fades it linearly to zero over the gap step that contains the rupture gap (with the
table's rupture points, :class:`SuctionTable` ``edge``; without them it drops bridges
already where the next tabulated suction ruptures).

Using the files in YADE (both engines read relative to the working directory)::

    os.chdir(export_dir)
    O.engines = [ForceResetter(),
                 InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=1.5)]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=1.5)],
                                 [Ip2_FrictMat_FrictMat_CapillaryPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)]),
                 Law2_ScGeom_CapillaryPhys_Capillarity(capillaryPressure=uc,  # Pa
                                                       surfaceTension=gamma,
                                                       suffCapFiles=theta_suffix(30)),
                 NewtonIntegrator()]

(or ``Ip2_FrictMat_FrictMat_CapillaryPhysDelaunay()`` and ``CapillarityEngine(
inputFilename="capillaryfile_theta30.txt", capillaryPressure=uc, liquidTension=gamma)``).
Bridges form at contact; ``createDistantMeniscii=True`` (one step) also wets the
pairs already within the detection range.  ``tests/yade_scenes/`` holds runnable scenes.

Uncertain points and YADE quirks are listed in :data:`FORMAT_NOTES`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from capbridge.status import Status
from capbridge.yade.delaunay_files import (DELAUNAY_COLUMNS, delaunay_records,
                                           read_delaunay_file, write_delaunay_file)
from capbridge.yade.export_manifest import FORMAT_NOTES
from capbridge.yade.law2_files import (LAW2_COLUMNS, YADE_RATIOS, capillary_file_blocks,
                                       capillary_file_name, read_capillary_file,
                                       read_capillary_files, theta_suffix,
                                       write_capillary_files)
from capbridge.yade.law2_interpolation import law2_force, law2_interpolate
from capbridge.yade.suction_table import SuctionTable
from capbridge.yade.synthetic_table import synthetic_bridge, synthetic_suction_table
from capbridge.yade.yade_units import from_yade_units, to_yade_units

__all__ = [
    "YADE_RATIOS", "LAW2_COLUMNS", "DELAUNAY_COLUMNS", "FORMAT_NOTES",
    "SuctionTable", "synthetic_suction_table", "synthetic_bridge", "theta_suffix",
    "capillary_file_name",
    "to_yade_units", "from_yade_units",
    "capillary_file_blocks", "write_capillary_files", "read_capillary_file",
    "read_capillary_files", "law2_interpolate", "law2_force",
    "delaunay_records", "write_delaunay_file", "read_delaunay_file",
    "rupture_edge", "export_from_solver",
]

#: the bridge fields taken from the solver into the table (and its rupture points)
_BRIDGE_KEYS = ("volume", "force", "beta1", "beta2", "area")


def rupture_edge(theta, ratios, suctions, gaps, *, solver_kwargs=None, tol=1e-10,
                 max_iter=60, theta2=None):
    """Bridges at rupture for :attr:`SuctionTable.edge`, from the exact solver.

    For every ratio: the rupture of every grid suction (``suction_rupture_distance``),
    and, for every grid gap inside the range of those rupture gaps, the suction whose
    bridge ruptures exactly at that gap (bracketed between grid suctions, Illinois
    iterations on the rupture gap to ``tol``); ``theta2`` the angle on the larger grain
    (default ``theta``).  Returns the ``edge`` dict (capbridge
    units, shape ``(len(ratios), len(suctions) + len(gaps))``, NaN = no point).
    """
    from capbridge.solvers.young_laplace import suction_rupture_distance

    kw = dict(solver_kwargs or {})
    if theta2 is not None:          # only when given: equal angles keep the plain call
        kw["theta2"] = theta2
    ratios, suctions, gaps = (np.asarray(a, float) for a in (ratios, suctions, gaps))
    n_s, n_g = suctions.size, gaps.size
    out = {k: np.full((ratios.size, n_s + n_g), np.nan)
           for k in ("suction", "gap") + _BRIDGE_KEYS}

    def rupture(s, rho):
        r = suction_rupture_distance(-np.asarray(s, float), theta, ratio=float(rho), **kw)
        ok = np.asarray(r["status"]) == int(Status.CONVERGED)
        return {k: np.where(ok, np.asarray(r[k], float), np.nan) for k in ("gap",) + _BRIDGE_KEYS
                if k in r}

    for i, rho in enumerate(ratios):
        a = rupture(suctions, rho)
        out["suction"][i, :n_s] = np.where(np.isfinite(a["gap"]), suctions, np.nan)
        for k in a:
            out[k][i, :n_s] = a[k]
        d_r = a["gap"]
        # brackets [s_j, s_j+1] with d_r(s_j) >= g > d_r(s_j+1) for the grid gaps g
        lo, hi, f_lo, f_hi, idx = [], [], [], [], []
        for k, g in enumerate(gaps):
            if g <= 0:
                continue
            j = np.flatnonzero((d_r[:-1] >= g) & (d_r[1:] < g))
            if j.size:
                j = j[0]
                lo.append(suctions[j]); hi.append(suctions[j + 1])
                f_lo.append(d_r[j] - g); f_hi.append(d_r[j + 1] - g); idx.append(k)
        if not idx:
            continue
        lo, hi, f_lo, f_hi = map(np.array, (lo, hi, f_lo, f_hi))
        idx = np.array(idx)
        target = gaps[idx]
        side = np.zeros(idx.size, int)
        x, b = lo.copy(), None
        for _ in range(max_iter):                 # Illinois (modified regula falsi)
            x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
            b = rupture(x, rho)                   # the bridges at x, kept for the result
            bad = ~np.isfinite(b["gap"])
            if bad.any():                         # no rupture found there: bisect instead
                x[bad] = 0.5 * (lo[bad] + hi[bad])
                b_bad = rupture(x[bad], rho)
                for k in b:
                    b[k][bad] = b_bad[k]
            f = b["gap"] - target
            done = np.abs(f) <= tol * np.maximum(target, 1.0)
            if np.all(done | ~np.isfinite(f)):
                break
            left = f > 0                          # root lies above x
            lo = np.where(left, x, lo); f_lo = np.where(left, f, f_lo)
            hi = np.where(left, hi, x); f_hi = np.where(left, f_hi, f)
            f_hi = np.where(left & (side == 1), f_hi / 2, f_hi)
            f_lo = np.where(~left & (side == -1), f_lo / 2, f_lo)
            side = np.where(left, 1, -1)
        if b is None:
            b = rupture(x, rho)
        good = np.isfinite(b["gap"]) & (np.abs(b["gap"] - target) <= 1e3 * tol * np.maximum(target, 1.0))
        cols = n_s + idx[good]
        out["suction"][i, cols] = x[good]
        out["gap"][i, cols] = target[good]       # exactly the grid gap (within tol)
        for k in _BRIDGE_KEYS:
            if k in b:
                out[k][i, cols] = b[k][good]
    if not np.isfinite(out["area"]).any():
        del out["area"]
    return out


def export_from_solver(directory, theta, ratios=YADE_RATIOS, suctions=None, gaps=None, *,
                       n_gaps=61, suffix=None, law2=True, delaunay=True, edge=True,
                       delaunay_name="capillaryfile{suffix}.txt", solver_kwargs=None,
                       missing="error", theta2=None):
    """Solve the suction-controlled doublets with capbridge's exact solver and write them.

    Calls ``capbridge.solvers.young_laplace.solve_doublet_suction(gap, pressure, theta,
    ratio)`` on the grid ``ratios x suctions x gaps`` (pressure P* = -suction, capbridge
    units: smaller radius), adds the bridges at rupture (:func:`rupture_edge`) unless
    ``edge=False``, then writes :func:`write_capillary_files` (suffix
    :func:`theta_suffix` unless given) and :func:`write_delaunay_file`.

    ``theta2``: contact angle on the larger grain of every pair (default ``theta``).
    YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` reads one set of files for every
    pair of a scene and knows nothing of materials, so mixed angles in these formats
    are right only for a scene whose bridges all join a grain at ``theta`` (the smaller,
    or either when equal) to one at ``theta2``; capbridge's own engine
    (``CapbridgeEngine``) handles any mixture.

    Default grids: 48 suctions, 0 then geometric from 0.02 to 500; ``n_gaps`` gaps from
    0 to 2 % past the largest rupture gap (that of zero suction and the largest ratio).
    YADE's historical files used 350 suctions and 80 distances; the cost here is about
    8 ms per point.  Returns ``(table, paths)``.
    """
    from capbridge.solvers.young_laplace import solve_doublet_suction

    kw = dict(solver_kwargs or {})
    if theta2 is not None:          # only when given: equal angles keep the plain call
        kw["theta2"] = theta2
    ratios = np.asarray(ratios, float)
    suctions = np.asarray(suctions if suctions is not None
                          else np.concatenate([[0.0], np.geomspace(0.02, 500.0, 47)]), float)
    if gaps is None:
        from capbridge.solvers.young_laplace import suction_rupture_distance
        r0 = suction_rupture_distance(np.zeros(ratios.size), theta, ratio=ratios, **kw)
        g_max = np.nanmax(np.where(np.asarray(r0["status"]) == 0, r0["gap"], np.nan))
        if not np.isfinite(g_max):
            raise RuntimeError("no rupture distance at zero suction: give the gaps")
        gaps = np.linspace(0.0, 1.02 * float(g_max), int(n_gaps))
    gaps = np.asarray(gaps, float)
    shape = (ratios.size, suctions.size, gaps.size)
    fields = {k: np.full(shape, np.nan) for k in _BRIDGE_KEYS}
    status = np.full(shape, int(Status.NOT_COMPUTED))
    gg, ss = np.meshgrid(gaps, suctions)                     # (suction, gap)
    for i, rho in enumerate(ratios):
        res = solve_doublet_suction(gg, -ss, theta, ratio=float(rho), **kw)
        for k in fields:
            if k in res:
                fields[k][i] = np.broadcast_to(np.asarray(res[k], float), gg.shape)
        status[i] = np.broadcast_to(np.asarray(res["status"], int), gg.shape)
    conv = status == int(Status.CONVERGED)
    area = fields["area"] if np.all(np.isfinite(fields["area"][conv])) else None
    table = SuctionTable(ratio=ratios, suction=suctions, gap=gaps, status=status, theta=theta,
                         area=area, volume=fields["volume"], force=fields["force"],
                         beta1=fields["beta1"], beta2=fields["beta2"],
                         edge=rupture_edge(theta, ratios, suctions, gaps, solver_kwargs=kw)
                         if edge else None,
                         attrs={"source": "capbridge.solvers.young_laplace.solve_doublet_suction",
                                "rupture_edge": "suction_rupture_distance" if edge else "none",
                                "theta2": float(theta if theta2 is None else theta2)})
    suffix = theta_suffix(theta, theta2) if suffix is None else suffix
    paths = []
    if law2:
        paths += write_capillary_files(table, directory, suffix, missing=missing)
    if delaunay:
        paths += write_delaunay_file(table, Path(directory) / delaunay_name.format(suffix=suffix))
    return table, paths
