"""One grid kernel for the surrogates and the DEM engine's lookups.

Everything that fills a fine grid from a table's coarse one, locates a point on it and
interpolates there lives here (it was written once per user before):

* :func:`refine_axis`: splines along one axis from the coarse nodes to the fine ones
  (the doublet's, the triplet's and the DEM scene tables' fine grids);
* :class:`UniformAxis`: a uniform axis, index and weight by arithmetic (the doublet's
  theta, log V* and s axes, which :class:`~capbridge.dem.scene_table.SceneTable`
  reads, and its continuous ratio axis);
* :class:`FineAxis`: ``refine`` equal steps per interval of a coarse, possibly
  non-uniform, axis (the triplet's axes);
* :func:`bilinear`, :func:`trilinear`: multilinear interpolation on a grid from the
  (index, weight) pairs of the axes (the doublet's general lookup);
* :func:`multilinear_flat`: the multilinear lookup on a row-major grid at flat indices,
  the DEM's inner loop (:class:`~capbridge.dem.scene_table.SceneTable`'s ``lookup``,
  ``rows`` and rupture gaps), and its case :func:`bilinear_flat` on a (..., log V*, s)
  grid (``DoubletSurrogate.predict_fixed_theta``);
* :func:`profile_value`: linear interpolation of s-profiles on a uniform s grid (the
  sphere-wall bridges), by :func:`rows_linear`, which interpolates one profile per
  point between two of its nodes (also the DEM's gravity response along s, located on
  its non-uniform axis by :class:`FineAxis`);
* :class:`Grid` (simplex or multilinear kernel on a fine n-D grid, several variables)
  and :class:`Descending` (sorted fractions for the simplex kernel): the triplet's.

The arithmetic of each function is the one its users had: moving a user here keeps its
numbers bit for bit.  (The exception: the scene table's profiles, rupture gaps and
coordinates, which had their own a (1 - f) + b f and multiplications by 1/step; on the
kernel they differ from before by round-off, up to a few 1e-15 relative.)
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import make_interp_spline

__all__ = ["refine_axis", "UniformAxis", "FineAxis", "bilinear", "trilinear", "multilinear_flat",
           "bilinear_flat", "rows_linear", "profile_value", "Grid", "Descending",
           "corner_offsets", "corner_weights"]


def refine_axis(values, axis, coarse, fine, degree=None):
    """Spline ``values`` along ``axis`` from the ``coarse`` to the ``fine`` nodes.

    ``degree`` None: cubic, or the highest degree the nodes allow below 4 nodes (the
    surrogates' refinement); 1: linear (the triplet's "cubic_tv" gaps).
    """
    k = (3 if len(coarse) >= 4 else len(coarse) - 1) if degree is None else degree
    return make_interp_spline(coarse, values, k=k, axis=axis)(fine)


class UniformAxis:
    """A uniform fine axis: index and weight by arithmetic, no search."""

    def __init__(self, lo, hi, n):
        self.lo, self.hi, self.n = float(lo), float(hi), int(n)
        self.step = (self.hi - self.lo) / (self.n - 1) if self.n > 1 else 1.0
        self.nodes = np.linspace(lo, hi, n)

    def locate(self, x):
        u = (x - self.lo) / self.step
        i = np.clip(np.floor(u), 0, max(self.n - 2, 0)).astype(np.intp)
        return i, u - i


class FineAxis:
    """Fine axis made of ``refine`` equal steps per coarse interval.

    ``locate(x)`` returns the fine interval index i, the weight of node i+1 and the
    coarse interval; uniform coarse axes by arithmetic, others by one linear index
    map (np.interp on the few coarse nodes), never a search on the fine grid.
    """

    def __init__(self, coarse, refine):
        self.coarse = np.asarray(coarse, float)
        self.refine = int(refine)
        m = self.coarse.size
        self.n = (m - 1) * self.refine + 1
        u = np.arange(self.n) / self.refine                 # coarse index coordinate
        j = np.minimum(np.floor(u).astype(int), m - 2)
        self.nodes = self.coarse[j] + (u - j) * (self.coarse[j + 1] - self.coarse[j])
        self.nodes[-1] = self.coarse[-1]
        steps = np.diff(self.coarse)
        self.uniform = bool(np.allclose(steps, steps[0], rtol=1e-9, atol=0))
        self.lo, self.hi = float(self.coarse[0]), float(self.coarse[-1])
        self._scale = self.refine / steps[0]
        self._index = np.arange(m, dtype=float) * self.refine

    def locate(self, x):
        if self.uniform:
            u = (x - self.lo) * self._scale
        else:
            u = np.interp(x, self.coarse, self._index)
        i = np.minimum(np.maximum(u.astype(np.intp), 0), self.n - 2)
        return i, u - i


def bilinear(grid, i, fi, j, fj):
    a = grid[i, j] * (1 - fj) + grid[i, j + 1] * fj
    b = grid[i + 1, j] * (1 - fj) + grid[i + 1, j + 1] * fj
    return a * (1 - fi) + b * fi


def trilinear(grid, i, fi, j, fj, k, fk):
    def plane(ii):
        a = grid[ii, j, k] * (1 - fk) + grid[ii, j, k + 1] * fk
        b = grid[ii, j + 1, k] * (1 - fk) + grid[ii, j + 1, k + 1] * fk
        return a * (1 - fj) + b * fj

    return plane(i) * (1 - fi) + plane(i + 1) * fi


def multilinear_flat(flat, k, strides, fracs):
    """Multilinear lookup on a row-major grid given flat, at flat indices.

    ``k``: the flat index of each point's lower corner (any shape), ``strides``: the flat
    strides of the interpolated axes, outermost first, ``fracs``: the weights toward the
    next node along each (broadcasting with ``k``).  Nested as lo + (hi - lo) f from the
    innermost axis out: 2^m gathers for m axes, no weight array.
    """
    if not strides:
        return flat[k]
    lo = multilinear_flat(flat, k, strides[1:], fracs[1:])
    hi = multilinear_flat(flat, k + strides[0], strides[1:], fracs[1:])
    return lo + (hi - lo) * fracs[0]


def bilinear_flat(flat, k, stride, fs, fv):
    """Bilinear lookup on a row-major grid (..., n_v, n_s) given flat: ``k`` the flat
    index of each point's lower corner (its cell (iv, i_s) plus the offset of its
    slice), ``stride`` = n_s, ``fs``/``fv`` the weights toward the next s/v node."""
    return multilinear_flat(flat, k, (stride, 1), (fv, fs))


def rows_linear(rows, i, w):
    """Linear interpolation of one profile per point: row k of ``rows`` (k, N, ...)
    between its nodes ``i[k]`` and ``i[k] + 1``, weight ``w[k]`` toward the second
    (the trailing dims of ``rows`` are carried along)."""
    k = np.arange(rows.shape[0])
    w = w.reshape(w.shape + (1,) * (rows.ndim - 2))
    return rows[k, i] * (1 - w) + rows[k, i + 1] * w


def profile_value(rows, x):
    """Linear interpolation of profiles ``rows`` (k, N) on the uniform s grid [0, 1] at
    s = sqrt(1 - x), x = d*/d*_rupt (overlaps count as contact, beyond rupture s = 0)."""
    s = np.sqrt(np.clip(1.0 - x, 0.0, 1.0)) * (rows.shape[1] - 1)
    i = np.minimum(s.astype(np.intp), rows.shape[1] - 2)
    return rows_linear(rows, i, s - i)


#: largest corner block (points x corners x values) that :class:`Grid` gathers at once
GATHER_MAX = 2**21


def corner_offsets(strides):
    """Flat offsets of the 2^k corners of a cell, ordered as :func:`corner_weights`."""
    offs = np.zeros(1, np.intp)
    for s in strides:
        offs = np.concatenate([offs, offs + s])
    return offs


def corner_weights(fracs):
    """(n, 2^k) multilinear weights, corner order of :func:`corner_offsets`."""
    w = np.ones((fracs[0].size, 1))
    for f in fracs:
        f = f[:, None]
        w = np.concatenate([w * (1.0 - f), w * f], axis=1)
    return w


class Grid:
    """Values on a fine grid (shape..., nvar) and the gather that interpolates them.

    ``kernel="simplex"``: piecewise-linear on the Kuhn (Freudenthal) simplices of each
    cell: the k + 1 corners reached from the cell's base by stepping along the axes in
    the order of decreasing fractional position, weights the differences of the sorted
    fractions.  It is exact at the nodes, continuous, invariant under permutations of
    the axes (the triangulation is), and needs k + 1 corners instead of the 2^k of
    ``"multilinear"`` (6 against 32 in 5-D): that is what makes >= 1e6 lookups/s
    possible.  Both kernels are second order in the fine step; on the refined grid their
    difference is part of the measured refinement error.
    """

    def __init__(self, values, kernel="simplex"):
        self.shape = values.shape[:-1]
        self.nvar = values.shape[-1]
        self.flat = np.ascontiguousarray(values.reshape(-1, self.nvar))
        st = np.cumprod((1,) + self.shape[::-1])[:-1][::-1]
        self.strides = st.astype(np.intp)
        self.offsets = corner_offsets(self.strides)
        self.kernel = kernel

    def __call__(self, index, fracs, order=None):
        """Interpolated values (n, nvar) in the cells ``index`` (one int array per axis)
        at the fractional positions ``fracs``; ``order`` (simplex kernel): the
        :class:`Descending` fractions of these axes, if the caller has them already."""
        base = index[0] * self.strides[0]
        for i, s in zip(index[1:], self.strides[1:]):
            base = base + i * s
        if self.kernel == "multilinear":
            w = corner_weights(fracs)
            if base.size * self.offsets.size * self.nvar <= GATHER_MAX:
                # a few points (a DEM step's clusters): one gather of all corners; the
                # per-call cost of 2^k gathers would dominate (0.9 against 0.3 ms for
                # 60 points, 32 corners, 54 values; same sums, in the same order)
                block = np.take(self.flat, base[:, None] + self.offsets, axis=0)
                return np.einsum("nc,ncv->nv", w, block)
            # corner by corner: a (n, 2^k, nvar) gather would not stay in cache
            out = np.take(self.flat, base, axis=0) * w[:, :1]
            for c in range(1, self.offsets.size):
                out += np.take(self.flat, base + self.offsets[c], axis=0) * w[:, c:c + 1]
            return out
        if order is None:
            order = Descending()
            for a, f in enumerate(fracs):
                order = order.insert(f, a)
        f, axis = order.fracs, order.axes
        k = len(f)
        idx = base
        out = np.take(self.flat, idx, axis=0) * (1.0 - f[0])[:, None]
        for m in range(k):
            idx = idx + self.strides[axis[m]]
            w = (f[m] - f[m + 1]) if m + 1 < k else f[m]
            out += np.take(self.flat, idx, axis=0) * w[:, None]
        return out


class Descending:
    """Fractional positions sorted in decreasing order, with the axis of each.

    Built by insertion (compare-exchanges on whole arrays, no per-point sort), so the
    gap axes sorted once serve the 3-D, 4-D (+ theta) and 5-D (+ v) lookups.
    """

    def __init__(self, fracs=(), axes=()):
        self.fracs, self.axes = list(fracs), list(axes)

    def insert(self, frac, axis):
        f = self.fracs + [frac]
        a = self.axes + [np.full(frac.shape, axis, np.int8)]
        for j in range(len(f) - 2, -1, -1):
            swap = f[j] < f[j + 1]
            f[j], f[j + 1] = np.maximum(f[j], f[j + 1]), np.minimum(f[j], f[j + 1])
            a[j], a[j + 1] = np.where(swap, a[j + 1], a[j]), np.where(swap, a[j], a[j + 1])
        return Descending(f, a)
