"""The nodes of a triplet table as the triplet surrogate reads them.

:class:`~capbridge.surrogate.triplet.TripletSurrogate` interpolates a full cube of table
nodes (d12, d13, d23, theta, v).  Before any spline goes through it, the cube is read
and made fit for interpolation here:

* :func:`node_data`: the values of :data:`GRID_VARIABLES` at the nodes, which nodes have
  a result and a code per node (converged, above tolerance, failed, no equilibrium);
* :func:`cell_max`: the largest node code (or error) over the corners of every coarse
  cell, which gives a looked-up point its status;
* :func:`fill_failed`: placeholder values at failed nodes, so that the splines through
  the cube stay finite (the cells touching them carry no number anyway);
* :func:`symmetrise`: the average over the 6 relabellings of the grains, which makes
  the surrogate exactly equivariant (relabelling the grains permutes the pair forces).
"""
from __future__ import annotations

import itertools
import json

import numpy as np

from capbridge.dimensionless import TRIPLET_PAIR_NAMES, TRIPLET_PAIRS
from capbridge.status import Status, status_in

__all__ = ["PAIR_NAMES", "PAIRS", "GRID_VARIABLES", "node_data", "cell_max", "fill_failed",
           "symmetrise"]

PAIRS, PAIR_NAMES = TRIPLET_PAIRS, TRIPLET_PAIR_NAMES
#: values interpolated on the 5-D grid, in this order
GRID_VARIABLES = ("f12", "f13", "f23", "pressure", "energy")


def node_data(ds):
    """Values (..., 5) of :data:`GRID_VARIABLES` at the table nodes, the mask of nodes
    with a result and the node codes: 0 converged, 1 above tolerance, 2 failed (any
    reason but the next), 3 no equilibrium of the coalesced body (failure kind
    ``no_equilibrium``)."""
    status = np.asarray(ds["status"].values)
    failure = np.asarray(ds["failure"].values) if "failure" in ds else np.zeros_like(status)
    kinds = list(json.loads(ds.attrs.get("failure_kinds", "{}")) or ["none"])
    no_eq = kinds.index("no_equilibrium") if "no_equilibrium" in kinds else -1
    vals = np.stack([np.asarray(ds[n].values, float) for n in
                     ("f12", "f13", "f23", "pressure", "energy_extrapolated")], -1)
    has = status_in(status, (Status.CONVERGED, Status.ABOVE_TOLERANCE)) & \
        np.isfinite(vals).all(-1)
    code = np.where(status == Status.ABOVE_TOLERANCE, 1, 0)
    code = np.where(~has, np.where(failure == no_eq, 3, 2), code)
    return vals, has, code


def cell_max(node_codes):
    """Largest code over the 2^k corners of every coarse cell."""
    c = node_codes
    for a in range(c.ndim):
        lo = [slice(None)] * c.ndim
        hi = [slice(None)] * c.ndim
        lo[a], hi[a] = slice(0, -1), slice(1, None)
        c = np.maximum(c[tuple(lo)], c[tuple(hi)])
    return c


def _line_fill(v, good, axis):
    """Linear interpolation / extrapolation of the valid nodes along ``axis`` at the
    failed ones (lines with no valid node are left); returns (values, filled mask)."""
    vm = np.moveaxis(np.array(v, float), axis, -1)
    gm = np.moveaxis(np.array(good, bool), axis, -1)
    n = vm.shape[-1]
    x = np.arange(n, dtype=float)
    for idx in np.ndindex(vm.shape[:-1]):
        g = gm[idx]
        if g.all() or not g.any():
            continue
        xs, ys = x[g], vm[idx][g]
        if xs.size == 1:
            fill = np.full(n, ys[0])
        else:
            fill = np.interp(x, xs, ys)
            lo, hi = x < xs[0], x > xs[-1]
            fill[lo] = ys[0] + (x[lo] - xs[0]) * (ys[1] - ys[0]) / (xs[1] - xs[0])
            fill[hi] = ys[-1] + (x[hi] - xs[-1]) * (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
        vm[idx][~g] = fill[~g]
        gm[idx] = True
    return np.moveaxis(vm, -1, axis), np.moveaxis(gm, -1, axis)


def fill_failed(values, ok, axis_order, gap_axes=(0, 1, 2)):
    """Placeholder values at failed nodes, so that splines through the cube stay finite.

    Along each axis in ``axis_order`` (theta and v), failed nodes get the linear
    interpolation or extrapolation of the valid nodes of their line; nodes left (a
    whole (theta, v) plane failed) get the mean of such fills along the three gap axes
    (symmetric under relabelling), then the mean of the valid values.  Cells touching
    a failed node carry no number (their status says why), so the fill only shapes the
    splines in the neighbouring cells.
    """
    v = np.array(values, float)
    good = np.array(ok, bool)
    for a in axis_order:
        v, good = _line_fill(v, good, a)
    if not good.all() and good.any():
        fills = [_line_fill(v, good, a) for a in gap_axes if a < v.ndim]
        total = sum(np.where(m & ~good, f, 0.0) for f, m in fills)
        count = sum((m & ~good).astype(int) for _, m in fills)
        take = count > 0
        v[take] = total[take] / count[take]
        good = good | take
    if not good.all():
        v[~good] = np.nanmean(values[ok]) if ok.any() else 0.0
    return v


def _relabellings():
    """For each relabelling p of the grains (new grain k = old grain p[k]): the old pair
    of every new pair, as indices into PAIRS (the gap axes permute the same way)."""
    out = []
    for p in itertools.permutations(range(3)):
        out.append([PAIRS.index(tuple(sorted((p[i], p[j])))) for i, j in PAIRS])
    return out


def symmetrise(pair_values, scalar_values, codes):
    """Average a full cube over the 6 relabellings of the grains.

    The table stores every relabelled copy of each canonical point, so away from
    ties (two equal gaps) the average changes nothing; at ties it averages the Evolver
    noise between pair forces that are equal by symmetry (f12 = f13 at d12 = d13), so
    that the surrogate is exactly equivariant.  ``pair_values`` (3, g, g, g, ...),
    ``scalar_values`` (m, g, g, g, ...), ``codes`` (g, g, g, ...) -> same shapes
    (codes: the largest over the relabellings).
    """
    nd = pair_values.ndim - 1
    rest = tuple(range(3, nd))
    f = np.zeros_like(pair_values)
    sc = np.zeros_like(scalar_values)
    cd = codes.copy()
    perms = _relabellings()
    for q in perms:
        axes = tuple(q) + rest          # new gap axis m is old gap axis q[m]
        for m in range(3):
            f[m] += np.transpose(pair_values[q[m]], axes)
        sc += np.stack([np.transpose(x, axes) for x in scalar_values])
        cd = np.maximum(cd, np.transpose(codes, axes))
    return f / len(perms), sc / len(perms), cd
