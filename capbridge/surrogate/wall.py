"""Sphere-wall lookup: interpolation in exact sphere-wall table slices.

:class:`SphereWallSurrogate` follows the surrogate contract of
:mod:`capbridge.surrogate.base`.  It is fitted on table slices of the exact sphere-wall
solver (:func:`~capbridge.solvers.sphere_wall.sphere_wall_table`: one (theta_s, theta_w)
pair each, on a V* axis and the doublet table's s = sqrt(1 - d*/d*_rupt) axis), and
looks up a bridge as the DEM engine does (:mod:`capbridge.dem.wall_bridges`, whose
:class:`~capbridge.dem.wall_bridges.WallTable` uses this lookup):

* the rupture gap: cubic spline of log d*_rupt in log V*;
* a profile F*(s) (and P*(s)): cubic spline in log V* at the bridge's volume, then a
  cubic spline in s onto a uniform fine s grid (:data:`N_FINE_S` nodes);
* a value at a gap: linear between the fine s nodes (:func:`profile_value`).

Lengths are by the sphere's radius R: d* = d/R, V* = V/R^3, F* = F/(2 pi gamma R),
P* = dp R/gamma (the doublet's conventions with ratio -> infinity).
"""
from __future__ import annotations

import numpy as np

from capbridge.status import Status
from capbridge.surrogate.base import SurrogateBase, apply_no_result_rule
from capbridge.surrogate.grid import profile_value
from capbridge.surrogate.names import WALL_OUTPUTS
from capbridge.validation import CapbridgeInputError, check_gap, check_int, check_range

__all__ = ["SphereWallSurrogate", "profile_value", "N_FINE_S", "WALL_OUTPUTS"]

#: fine uniform s nodes of a bridge's profile (linear between them)
N_FINE_S = 257
#: variables of a slice the surrogate interpolates (API names)
_SLICE_VARIABLES = ("force", "pressure")


class SphereWallSurrogate(SurrogateBase):
    """Interpolating surrogate of exact sphere-wall table slices (fit / predict).

    Parameters
    ----------
    n_fine_s : int
        Nodes of the uniform fine s grid of a profile (default :data:`N_FINE_S`, the
        engine's).

    ``fit(slices)`` takes the slices (xarray Datasets of
    :func:`~capbridge.solvers.sphere_wall.sphere_wall_table`, all on the same V* and s
    axes, every point converged); ``partial_fit(slices)`` adds more (the engine solves a
    pair's slice when a bridge of that pair first forms).
    """

    def __init__(self, n_fine_s=N_FINE_S):
        check_int("n_fine_s", n_fine_s, 2, 1_000_000)
        self.n_fine_s = n_fine_s

    # ----------------------------------------------------------------------------- fit
    def fit(self, slices):
        """Fit on the table slices (an iterable of Datasets, or one); returns self."""
        for name in ("table_", "pairs_", "volume_", "s_", "fine_s_"):
            self.__dict__.pop(name, None)
        self._values = {name: [] for name in _SLICE_VARIABLES}
        self._rupture = []
        return self.partial_fit(slices)

    def partial_fit(self, slices):
        """Add table slices of (theta_s, theta_w) pairs not held yet; returns self."""
        import xarray as xr

        if isinstance(slices, xr.Dataset):
            slices = [slices]
        if "table_" not in self.__dict__ and not hasattr(self, "_values"):
            return self.fit(slices)
        for ds in slices:
            self._add(ds)
        if "table_" not in self.__dict__:
            raise CapbridgeInputError("SphereWallSurrogate.fit: no table slice given")
        return self

    def _add(self, ds):
        ts, tw = float(ds["theta_s"]), float(ds["theta_w"])
        bad = int((ds["status"].values != int(Status.CONVERGED)).sum()
                  + (ds["rupture_status"].values != int(Status.CONVERGED)).sum())
        if bad:
            raise ValueError(f"sphere-wall table ({ts:g}, {tw:g}) deg has {bad} unconverged "
                             "points: the engine cannot use it")
        volume = np.asarray(ds["volume"].values, float)
        s = np.asarray(ds["s"].values, float)
        if "table_" in self.__dict__:
            if not (np.array_equal(volume, self.volume_) and np.array_equal(s, self.s_)):
                raise CapbridgeInputError(
                    f"sphere-wall slice ({ts:g}, {tw:g}) deg is on other V* or s nodes than "
                    "the slices already fitted")
            if np.any(np.all(np.abs(self.pairs_ - (ts, tw)) <= 1e-9, axis=1)):
                return
        else:
            self.volume_, self.s_ = volume, s
            self.fine_s_ = np.linspace(0.0, 1.0, int(self.n_fine_s))
            self.pairs_ = np.empty((0, 2))
            self.table_ = []
            self.has_gravity_ = False
        for name in _SLICE_VARIABLES:
            self._values[name].append(np.asarray(ds[name].values, float))
        self._rupture.append(np.asarray(ds["rupture_gap"].values, float))
        self.pairs_ = np.vstack([self.pairs_, [ts, tw]])
        self.table_.append(ds)

    # ------------------------------------------------------------------------ lookup
    @property
    def vstar_range_(self):
        """(lowest, highest) V* of the slices."""
        self._check_fitted()
        return float(self.volume_[0]), float(self.volume_[-1])

    def covers(self, theta_s, theta_w):
        """True where the (theta_s, theta_w) pair has a fitted slice."""
        self._check_fitted()
        t = np.column_stack([np.ravel(theta_s), np.ravel(theta_w)]).astype(float)
        return np.any(np.all(np.abs(self.pairs_[None] - t[:, None]) <= 1e-9, axis=2), axis=1)

    def slice_index(self, theta_s, theta_w):
        """Slice of each (theta_s, theta_w) pair; CapbridgeInputError for a pair without
        a slice."""
        self._check_fitted()
        t = np.column_stack([np.atleast_1d(theta_s), np.atleast_1d(theta_w)]).astype(float)
        hit = np.all(np.abs(self.pairs_[None] - t[:, None]) <= 1e-9, axis=2)
        missing = ~hit.any(axis=1)
        if missing.any():
            a, b = t[missing][0]
            raise CapbridgeInputError(
                f"contact angles (theta_s, theta_w) = ({a:g}, {b:g}) deg have no fitted "
                f"sphere-wall slice (fitted: {self.pairs_.tolist()}); fit one "
                "(capbridge.solvers.sphere_wall.sphere_wall_table) or use the exact solver "
                "(solve_sphere_wall)")
        return hit.argmax(axis=1)

    def profiles(self, slice_idx, vstar, name="force"):
        """Rupture gap d*_rupt and profile of ``name`` on ``fine_s_`` of bridges of
        volume ``vstar`` in slices ``slice_idx``: ((k,), (k, n_fine_s))."""
        from scipy.interpolate import CubicSpline

        self._check_fitted()
        vstar = np.atleast_1d(np.asarray(vstar, float))
        lo, hi = self.vstar_range_
        outside = (vstar < lo * (1 - 1e-12)) | (vstar > hi * (1 + 1e-12)) | ~np.isfinite(vstar)
        if np.any(outside):
            raise CapbridgeInputError(
                f"wall bridge V*={vstar[outside][0]!r} is outside the table's [{lo:g}, {hi:g}]")
        lv = np.log(np.clip(vstar, lo, hi))
        logv = np.log(self.volume_)
        slice_idx = np.broadcast_to(np.asarray(slice_idx), vstar.shape)
        d_r = np.empty(vstar.size)
        rows = np.empty((vstar.size, self.fine_s_.size))
        for p in np.unique(slice_idx):
            sel = np.flatnonzero(slice_idx == p)
            d_r[sel] = np.exp(CubicSpline(logv, np.log(self._rupture[p]))(lv[sel]))
            coarse = CubicSpline(logv, self._values[name][p], axis=0)(lv[sel])   # (k, n_s)
            rows[sel] = CubicSpline(self.s_, coarse, axis=1)(self.fine_s_)
        return d_r, rows

    def predict(self, gap, volume, theta_s, theta_w=None):
        """Interpolated sphere-wall bridge at (d*, V*, theta_s, theta_w [deg]).

        A gap below zero down to -:data:`~capbridge.validation.CONTACT_OVERLAP_MAX` is
        a contact (answered at d* = 0); ``theta_w`` defaults to ``theta_s``.

        Returns a dict of arrays (broadcast shape): ``force`` F* (on the sphere towards
        the wall, attraction > 0), ``pressure`` P*, ``rupture_gap`` d*_rupt and
        ``status``: CONVERGED, or RUPTURED beyond the rupture gap (force 0, pressure
        NaN: the no-result rule of :mod:`capbridge.surrogate.base`).  V* outside the
        slices' range, a pair of angles without a slice and bad input raise
        :class:`~capbridge.validation.CapbridgeInputError`.
        """
        self._check_fitted()
        gap = check_gap("gap d*", gap)
        volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
        theta_s = check_range("theta_s", theta_s, 0.0, 90.0, high_open=True, units=" deg")
        theta_w = theta_s if theta_w is None else check_range("theta_w", theta_w, 0.0, 90.0,
                                                                units=" deg")
        shape = np.broadcast_shapes(gap.shape, volume.shape, theta_s.shape, theta_w.shape)
        g, v, ts, tw = (np.broadcast_to(a, shape).ravel() for a in (gap, volume, theta_s,
                                                                    theta_w))
        lo, hi = self.vstar_range_
        outside = (v < lo * (1 - 1e-12)) | (v > hi * (1 + 1e-12))
        if outside.any():
            raise CapbridgeInputError(
                f"volume V*={v[outside][0]!r} is outside the sphere-wall table's range "
                f"[{lo:g}, {hi:g}]; use the exact solver (solve_sphere_wall)")
        p = self.slice_index(ts, tw)
        out = {}
        for name in _SLICE_VARIABLES:
            d_r, rows = self.profiles(p, v, name)
            out[name] = profile_value(rows, g / d_r)
        out["rupture_gap"] = d_r
        status = np.where(g > d_r, np.int8(Status.RUPTURED), np.int8(Status.CONVERGED))
        out["status"] = status.astype(np.int8)
        apply_no_result_rule(out, out["status"])
        return {k: a.reshape(shape) for k, a in out.items()}

    def summary(self):
        """The fitted slices (pairs of angles, V* and s axes) and the lookup (JSON-friendly)."""
        self._check_fitted()
        return {"pairs": self.pairs_.tolist(),
                "volume": {"n": int(self.volume_.size), "min": float(self.volume_[0]),
                           "max": float(self.volume_[-1])},
                "s": {"n": int(self.s_.size)}, "n_fine_s": int(self.fine_s_.size),
                "lookup": "cubic in log V* (log d*_rupt, profiles), cubic in s onto the "
                          "fine s grid, linear between its nodes",
                "holdout_error": None, "gravity": None}
