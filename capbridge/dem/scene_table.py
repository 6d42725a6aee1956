"""A DEM scene's cut of the doublet table: fine lookup grids for its angles and ratios.

:class:`SceneTable` cuts, out of capbridge's doublet table, only what one DEM scene
needs: the contact angles of its materials and the radius ratios of its grain pairs,
refined exactly as :class:`capbridge.surrogate.doublet.DoubletSurrogate` refines them
(cubic splines along theta, log ratio, log V* and s = sqrt(1 - d*/d*_rupt), evaluated on
the surrogate's own fine nodes), so that a lookup gives the surrogate's number to
round-off.  Because a bridge keeps its volume, everything but the gap is fixed when the
bridge forms (:meth:`SceneTable.bridge_constants`: its volume cell, its rupture gap, its
contact angle and ratio): a step costs a square root and four gathers per bridge.
Locating a point and interpolating there is the grid kernel's
(:mod:`capbridge.surrogate.grid`: the axes' ``locate``, :func:`multilinear_flat`).

Conventions (capbridge's): lengths over the *smaller* radius of the pair r,
ratio = R/r >= 1, V* = V/r^3, angles in degrees.
"""
from __future__ import annotations

import math

import numpy as np

from capbridge.status import Status
from capbridge.surrogate.grid import UniformAxis, multilinear_flat, refine_axis

__all__ = ["SceneTable", "default_table_path", "distinct_values"]


def default_table_path():
    """The shipped doublet table, ``<project>/data/doublet_table.nc``."""
    from capbridge.surrogate.doublet import default_table

    return default_table()


def distinct_values(x, rtol=1e-9):
    """Sorted distinct values of ``x`` (values within ``rtol`` of each other merged)."""
    x = np.sort(np.asarray(x, float).ravel())
    if x.size == 0:
        return x
    keep = np.concatenate([[True], np.diff(x) > rtol * np.abs(x[1:])])
    return x[keep]


def _stack(parts, shape):
    """The slices ``parts`` stacked into ``shape`` (no slice: an empty grid, for a scene
    whose wet grains were all erased)."""
    return np.concatenate(parts).reshape(shape) if parts else np.empty(shape)


class SceneTable:
    """Fine lookup grids for the contact angles and radius ratios of one scene.

    Parameters
    ----------
    table : path of a capbridge doublet table, an ``xarray.Dataset``, or a fitted
        :class:`~capbridge.surrogate.doublet.DoubletSurrogate` (its ``refine`` sets the
        fine grid; default ``DoubletSurrogate()``'s).
    thetas : contact angles [deg] the scene uses (one grid stack each).
    ratios : the radius ratios R/r >= 1 of the scene's pairs.  With at most
        ``max_discrete`` distinct values (mono-, bi-, tridisperse packings) every one
        gets its own exact grid and a lookup never interpolates in ratio.  Otherwise, or
        with ``continuous=True`` (continuous size distributions), the range [min, max]
        gets nodes every ``ratio_step`` and a lookup is linear in ratio between them.
    variables : what to tabulate besides the rupture gap ("force", "beta1", "beta2",
        "pressure").

    Only those slices are built: memory is ``len(thetas) * n_ratio_nodes *
    len(variables) * 145 * 145`` doubles with the default refinement.
    """

    def __init__(self, table, thetas, ratios=(1.0,), variables=("force",),
                 ratio_step=0.01, max_discrete=12, continuous=None, theta_pairs=()):
        from capbridge.surrogate.doublet import DoubletSurrogate

        sur = table if isinstance(table, DoubletSurrogate) else DoubletSurrogate().fit(table)
        sur._check_fitted()
        self.surrogate = sur
        ds = sur.table_
        self.variables = tuple(dict.fromkeys(variables))
        for name in self.variables:
            if name not in ds:
                raise ValueError(f"the table has no variable {name!r}")
        self.thetas = distinct_values(thetas)
        pairs = np.asarray(theta_pairs, float).reshape(-1, 2)
        pairs = pairs[np.abs(pairs[:, 0] - pairs[:, 1]) > 1e-9]
        self.theta_pairs = np.unique(pairs, axis=0) if pairs.size else np.empty((0, 2))
        every = np.concatenate([self.thetas, self.theta_pairs.ravel()])
        if np.any(every < sur.theta_[0] - 1e-9) or np.any(every > sur.theta_[-1] + 1e-9):
            raise ValueError(f"contact angles {distinct_values(every).tolist()} deg: the table "
                             f"covers [{sur.theta_[0]:g}, {sur.theta_[-1]:g}] deg")
        ratios = distinct_values(ratios)
        if ratios.size == 0:
            ratios = np.array([1.0])
        if ratios[0] < 1.0 - 1e-12 or ratios[-1] > sur.ratios_[-1] * (1 + 1e-12):
            raise ValueError(f"radius ratios [{ratios[0]:g}, {ratios[-1]:g}]: the table "
                             f"covers [{sur.ratios_[0]:g}, {sur.ratios_[-1]:g}] "
                             "(ratio = larger / smaller radius)")
        ratios = np.clip(ratios, 1.0, sur.ratios_[-1])
        self.discrete = (ratios.size <= max_discrete) if continuous is None else not continuous
        if self.discrete:
            self.ratio_nodes = ratios
        else:
            lo, hi = ratios[0], ratios[-1]
            n = max(2, int(math.ceil((hi - lo) / ratio_step)) + 1)
            self.ratio_axis = UniformAxis(lo, hi, n)
            self.ratio_nodes = self.ratio_axis.nodes
        self.v_axis = sur.logv_axis_
        self.s_axis = sur.s_axis_
        self.vstar_range = (float(sur.volume_[0]), float(sur.volume_[-1]))
        self._check_status(ds)
        self.grids = {}
        # slices: one per equal angle (from the table), then one per mixed pair (exact)
        n_sl = self.thetas.size + self.theta_pairs.shape[0]
        shape = (n_sl, self.ratio_nodes.size, self.v_axis.n, self.s_axis.n)
        mixed = self._build_mixed(ds)
        for name in self.variables:
            parts = ([self._build(ds[name].values)] if self.thetas.size else []) + mixed[name]
            self.grids[name] = np.ascontiguousarray(_stack(parts, shape))
        parts = (([self._build(ds["rupture_gap"].values)] if self.thetas.size else [])
                 + mixed["rupture_gap"])
        self.rupture = np.ascontiguousarray(_stack(parts, shape[:3]))
        self.flat = {name: g.ravel() for name, g in self.grids.items()}

    # -------------------------------------------------------------------------- build
    @staticmethod
    def _check_status(ds):
        bad = int((ds["status"].values != int(Status.CONVERGED)).sum())
        bad_r = int((ds["rupture_status"].values != int(Status.CONVERGED)).sum())
        if bad or bad_r:
            raise ValueError(f"the doublet table has {bad} unconverged points and {bad_r} "
                             "unconverged rupture points; the engine needs a complete table "
                             "(regenerate it)")

    def _theta_weights(self):
        """The surrogate's theta treatment: spline to its fine theta nodes, then linear
        between the two nodes around theta.  Returns (nodes_lo, nodes_hi, w)."""
        ax = self.surrogate.theta_axis_
        it, ft = ax.locate(self.thetas)
        return ax.nodes[it], ax.nodes[it + 1], ft

    def _build(self, values):
        """values: (ratio, theta, volume[, s]) coarse -> (theta, node, vfine[, sfine]),
        with the surrogate's own cubic refinement along each axis."""
        sur = self.surrogate
        lo, hi, w = self._theta_weights()
        a = refine_axis(values, 1, sur.theta_, lo)
        b = refine_axis(values, 1, sur.theta_, hi)
        wb = w.reshape((1, -1) + (1,) * (values.ndim - 2))
        v = a * (1 - wb) + b * wb                                # (ratio, theta, V[, s])
        v = refine_axis(v, 0, np.log(sur.ratios_), np.log(self.ratio_nodes))  # (node, theta, ...)
        v = np.swapaxes(v, 0, 1)                                 # (theta, node, V[, s])
        v = refine_axis(v, 2, np.log(sur.volume_), self.v_axis.nodes)
        if v.ndim == 4:
            v = refine_axis(v, 3, sur.s_, self.s_axis.nodes)
        return v

    def _coarse_ratios_for_nodes(self):
        """The table's coarse ratios a mixed slice is solved on: the nodes themselves
        when they are all tabulated ratios, else those bracketing the nodes plus one
        more on each side (so that the ratio spline is the table's cubic)."""
        rc = self.surrogate.ratios_
        if np.all(np.isclose(self.ratio_nodes[:, None], rc[None, :], rtol=1e-12, atol=0).any(axis=1)):
            return self.ratio_nodes.copy()
        lo = max(int(np.searchsorted(rc, self.ratio_nodes[0], side="right")) - 2, 0)
        hi = min(int(np.searchsorted(rc, self.ratio_nodes[-1], side="left")) + 2, rc.size)
        return rc[lo:hi]

    def _build_mixed(self, ds):
        """Slices of the mixed pairs: exact coarse solutions
        (:func:`~capbridge.dem.mixed_angles.exact_coarse`) refined like the
        table's.  Returns name -> list of (1, node, vfine[, sfine]) arrays."""
        from capbridge.dem.mixed_angles import exact_coarse
        sur = self.surrogate
        out = {name: [] for name in self.variables + ("rupture_gap",)}
        if not self.theta_pairs.size:
            return out
        rc = self._coarse_ratios_for_nodes()
        for t1, t2 in self.theta_pairs:
            ex = exact_coarse(t1, t2, rc, sur.volume_, sur.s_, self.variables)
            for name, v in ex.items():
                if rc.size > 1:
                    v = refine_axis(v, 0, np.log(rc), np.log(self.ratio_nodes))
                v = refine_axis(v, 1, np.log(sur.volume_), self.v_axis.nodes)
                if v.ndim == 3:
                    v = refine_axis(v, 2, sur.s_, self.s_axis.nodes)
                out[name].append(v[None])
        return out

    # ------------------------------------------------------------------------- lookup
    def slice_index(self, theta1, theta2):
        """Slice of each bridge with angle ``theta1`` on its smaller grain and
        ``theta2`` on its larger one: the equal-angle slice when they agree, else the
        exact mixed slice (which must have been asked for in ``theta_pairs``)."""
        t1 = np.atleast_1d(np.asarray(theta1, float))
        t2 = np.broadcast_to(np.asarray(theta2, float), t1.shape)
        same = np.abs(t1 - t2) <= 1e-9
        out = np.empty(t1.shape, np.intp)
        if same.any():
            out[same] = self.theta_index(t1[same])
        if (~same).any():
            p = self.theta_pairs
            hit = (np.abs(p[None, :, 0] - t1[~same, None]) <= 1e-9) & \
                  (np.abs(p[None, :, 1] - t2[~same, None]) <= 1e-9)
            if not hit.any(axis=1).all():
                k = np.flatnonzero(~hit.any(axis=1))[0]
                raise ValueError(f"contact-angle pair ({t1[~same][k]:g}, {t2[~same][k]:g}) "
                                 "deg is not in this SceneTable")
            out[~same] = self.thetas.size + hit.argmax(axis=1)
        return out

    def theta_index(self, theta):
        """Index of each contact angle in :attr:`thetas` (must be one of them)."""
        theta = np.atleast_1d(np.asarray(theta, float))
        idx = np.searchsorted(self.thetas, theta - 1e-9)
        idx = np.clip(idx, 0, self.thetas.size - 1)
        if not np.allclose(self.thetas[idx], theta, rtol=1e-9, atol=1e-9):
            raise ValueError(f"contact angles {np.setdiff1d(theta, self.thetas)} are not in "
                             "this SceneTable")
        return idx

    def ratio_coordinate(self, ratio):
        """(node index, weight toward the next node) of each ratio."""
        r = np.atleast_1d(np.asarray(ratio, float))
        nodes = self.ratio_nodes
        if self.discrete:
            i = np.clip(np.searchsorted(nodes, r * (1 - 1e-9)), 0, nodes.size - 1)
            if not np.allclose(nodes[i], r, rtol=1e-8, atol=0):
                miss = r[~np.isclose(nodes[i], r, rtol=1e-8, atol=0)][0]
                raise ValueError(f"radius ratio {miss:g} is not among this SceneTable's "
                                 f"ratios {nodes.tolist()}")
            return i.astype(np.intp), np.zeros(r.size)
        if np.any(r < nodes[0] * (1 - 1e-9)) or np.any(r > nodes[-1] * (1 + 1e-9)):
            raise ValueError(f"radius ratio outside [{nodes[0]:g}, {nodes[-1]:g}]")
        return self.ratio_axis.locate(np.clip(r, nodes[0], nodes[-1]))

    def volume_coordinate(self, vstar):
        """(cell index, weight) of V* on the fine log V* axis; V* must be in range."""
        v = np.atleast_1d(np.asarray(vstar, float))
        lo, hi = self.vstar_range
        if np.any(v < lo * (1 - 1e-12)) or np.any(v > hi * (1 + 1e-12)):
            bad = v[(v < lo * (1 - 1e-12)) | (v > hi * (1 + 1e-12))][0]
            raise ValueError(f"bridge volume V* = {bad:g} is outside the table's "
                             f"[{lo:g}, {hi:g}]")
        return self.v_axis.locate(np.log(np.clip(v, lo, hi)))

    def bridge_constants(self, theta_idx, ratio, vstar):
        """Everything about a bridge that does not change while it keeps its volume:
        a dict with the flat base index, the weights and the rupture gap d*_rupt."""
        ti = np.atleast_1d(np.asarray(theta_idx, np.intp))
        ri, fr = self.ratio_coordinate(ratio)
        iv, fv = self.volume_coordinate(vstar)
        nR, nV, nS = self.ratio_nodes.size, self.v_axis.n, self.s_axis.n
        cell = (ti * nR + ri) * nV + iv                      # in the (slice, ratio, V*) grid
        const = {"base": (cell * nS).astype(np.intp), "fv": fv, "fr": fr}
        strides, fracs = self._fixed_axes(const, 1)
        const["d_rupt"] = multilinear_flat(self.rupture.ravel(), cell, strides, fracs)
        return const

    def _fixed_axes(self, const, inner):
        """Strides and weights of the axes a bridge's constants fix, outermost first: the
        ratio (a continuous table only) and log V*, for a grid whose inner axes hold
        ``inner`` values per V* node (the s axis: n_s; the rupture gap: 1)."""
        nV = self.v_axis.n
        if self.discrete:
            return (inner,), (const["fv"],)
        # the ratio's cell is at most the last but one (UniformAxis.locate): the next
        # ratio node is always there, read with weight 0 on the last node
        return (nV * inner, inner), (const["fr"], const["fv"])

    def s_coordinate(self, gap_star, d_rupt):
        """(cell, weight) on the s axis; gaps < 0 (overlaps) are taken as contact."""
        return self.s_axis.locate(np.sqrt(np.clip(1.0 - gap_star / d_rupt, 0.0, 1.0)))

    def rows(self, name, const):
        """The whole s-profile of variable ``name`` for bridges with constants
        ``const``: an (n, n_s) array (everything but s interpolated once)."""
        nS = self.s_axis.n
        strides, fracs = self._fixed_axes(const, nS)
        k = const["base"][:, None] + np.arange(nS)[None, :]
        return multilinear_flat(self.flat[name], k, strides, tuple(f[:, None] for f in fracs))

    def lookup(self, name, const, gap_star, s_coord=None):
        """Value of variable ``name`` for bridges with constants ``const`` (see
        :meth:`bridge_constants`) at ``gap_star``.  Beyond the rupture gap the value is
        that of the rupture point (callers drop those bridges)."""
        i_s, fs = s_coord if s_coord is not None else self.s_coordinate(gap_star, const["d_rupt"])
        strides, fracs = self._fixed_axes(const, self.s_axis.n)
        return multilinear_flat(self.flat[name], const["base"] + i_s, strides + (1,),
                                fracs + (fs,))

    def predict(self, gap_star, vstar, theta, ratio, variables=("force",), theta2=None):
        """Convenience: values at arbitrary points (arrays broadcast), force 0 and the
        others NaN beyond rupture; for checks against the surrogate and the exact
        solver (``theta`` on the smaller grain, ``theta2`` on the larger, default
        ``theta``)."""
        g, v, t, r = np.broadcast_arrays(*(np.asarray(a, float) for a in (gap_star, vstar, theta, ratio)))
        t2 = t if theta2 is None else np.broadcast_to(np.asarray(theta2, float), t.shape)
        const = self.bridge_constants(self.slice_index(t.ravel(), t2.ravel()), r.ravel(), v.ravel())
        gs = g.ravel()
        sc = self.s_coordinate(gs, const["d_rupt"])
        out = {"rupture_gap": const["d_rupt"].reshape(g.shape)}
        broken = gs > const["d_rupt"]
        for name in variables:
            val = self.lookup(name, const, gs, sc)
            val = np.where(broken, 0.0 if name == "force" else np.nan, val)
            out[name] = val.reshape(g.shape)
        return out

    @property
    def nbytes(self):
        return int(sum(g.nbytes for g in self.grids.values()) + self.rupture.nbytes)
