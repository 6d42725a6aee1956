"""Fast doublet lookup: interpolation in a capbridge doublet table.

``fit`` turns the table's coarse grid into a fine one by cubic splines along each axis
(theta, log V*, s = sqrt(1 - d*/d*_rupt)); ``predict`` is then a multilinear lookup on
that fine uniform grid: a few array operations per point, no search.  The cubic step
carries the accuracy, the fine grid the speed; both errors are measured on held-out
exact solutions (:func:`holdout_errors`) and stored with the table.

Only the ratio slices and variables a caller asks for are refined (DEM scenes use few).
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from scipy.interpolate import make_interp_spline

from capbridge.status import Status
from capbridge.validation import CapbridgeInputError, check_choice, check_int, check_range

VARIABLES = ("force", "pressure", "beta1", "beta2")

#: fine-grid settings with which a table's stored error model is measured when the
#: table does not say otherwise (``holdout_refine``, ``holdout_theta_step`` attributes)
DEFAULT_REFINE = 6
DEFAULT_THETA_STEP = 0.5
#: memory bounds of the fine grid (about 100 MB per variable and ratio slice)
MAX_REFINE = 12
MIN_THETA_STEP = 0.1

#: plausible SI inputs of :meth:`DoubletSurrogate.predict_si`: a value outside is
#: almost surely a unit slip (radii in mm, gamma in mN/m), refused rather than answered
SI_RADIUS_RANGE = (1e-7, 0.1)            # [m]: 0.1 um to 10 cm grains
SI_SURFACE_TENSION_RANGE = (1e-3, 2.0)   # [N/m]: liquids to molten metals

#: exponent of the rupture distance in V*: d*_rupt ~ (1 + theta/2) V*^(1/3)
#: (Lian, Thornton & Adams 1993), used to keep the state (bridge or none) when a
#: volume outside the table is clipped
_RUPTURE_EXPONENT = 1.0 / 3.0


def _refine_axis(values, axis, coarse, fine):
    """Cubic-spline ``values`` along ``axis`` from the ``coarse`` to the ``fine`` nodes."""
    if len(coarse) < 4:
        k = len(coarse) - 1
    else:
        k = 3
    spline = make_interp_spline(coarse, values, k=k, axis=axis)
    return spline(fine)


def _uniform(lo, hi, n):
    return np.linspace(lo, hi, n)


class _Axis:
    """A uniform fine axis: index and weight by arithmetic, no search."""

    def __init__(self, lo, hi, n):
        self.lo, self.hi, self.n = float(lo), float(hi), int(n)
        self.step = (self.hi - self.lo) / (self.n - 1) if self.n > 1 else 1.0
        self.nodes = _uniform(lo, hi, n)

    def locate(self, x):
        u = (x - self.lo) / self.step
        i = np.clip(np.floor(u), 0, max(self.n - 2, 0)).astype(np.intp)
        return i, u - i


class DoubletSurrogate:
    """Interpolating surrogate of a doublet table (scikit-learn style: fit, predict).

    Parameters
    ----------
    refine : int
        Fine-grid nodes per coarse interval along log V* and s (default 6).
    theta_step : float
        Fine-grid spacing in theta [deg] (default 0.5), at least 0.1.
        Neither it nor ``refine`` may be coarser than the refinement with which the
        table's error model was measured (checked by :meth:`fit`): a coarser grid
        would answer with a larger error than the table states.
    out_of_range : {"raise", "clip"}
        Behaviour for V* outside the table: ``"raise"`` (default) a CapbridgeInputError
        naming the value and the table's range; ``"clip"`` answers at the nearest
        edge of the table with status EXTRAPOLATED, at the same relative position on
        the branch (d*/d*_rupt, with d*_rupt scaled as V*^(1/3)), so a bridge beyond
        its rupture distance is RUPTURED, never a force.  Theta and ratio outside the
        table are always errors: another contact angle is another bridge.
    clip_hint : str
        How the user turns clipping on, named in out-of-table messages (the command
        line passes ``"--clip"``).
    """

    def __init__(self, refine=DEFAULT_REFINE, theta_step=DEFAULT_THETA_STEP,
                 out_of_range="raise", clip_hint="out_of_range='clip'"):
        check_choice("out_of_range", out_of_range, ("raise", "clip"))
        self.refine = check_int("refine", refine, 1, MAX_REFINE,
                                hint="fine-grid nodes per table interval")
        self.theta_step = float(check_range("theta_step", theta_step, MIN_THETA_STEP, 90.0,
                                            units=" deg"))
        self.out_of_range = out_of_range
        self.clip_hint = clip_hint

    # ----------------------------------------------------------------------------- fit
    def fit(self, table):
        """Load and validate a table (path or Dataset); refinement is done lazily.

        The table is checked (:func:`~capbridge.generator.doublet_table.validate_doublet_table`:
        axes, units, checksum, physical bounds) and so are this surrogate's
        refinement settings against those of the table's error model.
        """
        from capbridge.generator.doublet_table import validate_doublet_table

        if isinstance(table, xr.Dataset):
            ds = validate_doublet_table(table, "doublet table (Dataset)")
        else:
            ds = validate_doublet_table(_open(table), str(table))
        if any(k.startswith("holdout_") for k in ds.attrs):
            ref = int(ds.attrs.get("holdout_refine", DEFAULT_REFINE))
            step = float(ds.attrs.get("holdout_theta_step", DEFAULT_THETA_STEP))
            keep = "the table's stored error model does not hold on a coarser grid"
            check_int("refine", self.refine, ref, MAX_REFINE, hint=keep)
            check_range("theta_step", self.theta_step, MIN_THETA_STEP, step, units=" deg",
                        hint=keep)
        self.table_ = ds
        self.ratios_ = np.asarray(ds["ratio"].values, float)
        self.theta_ = np.asarray(ds["theta"].values, float)
        self.volume_ = np.asarray(ds["volume"].values, float)
        self.s_ = np.asarray(ds["s"].values, float)
        self.theta_axis_ = _Axis(self.theta_[0], self.theta_[-1],
                                 int(round((self.theta_[-1] - self.theta_[0]) / self.theta_step)) + 1)
        lv = np.log(self.volume_)
        self.logv_axis_ = _Axis(lv[0], lv[-1], (len(lv) - 1) * self.refine + 1)
        self.s_axis_ = _Axis(self.s_[0], self.s_[-1], (len(self.s_) - 1) * self.refine + 1)
        self._fine = {}
        self._ratio_basis = None
        self.holdout_ = {k: v for k, v in ds.attrs.items() if k.startswith("holdout_")}
        return self

    def _check_fitted(self):
        if not hasattr(self, "table_"):
            raise RuntimeError("DoubletSurrogate is not fitted: call fit(table) first")

    def _fine_grid(self, ratio_index, name):
        """Fine (theta, logV, s) grid of one variable for one ratio slice, cached."""
        key = (ratio_index, name)
        if key not in self._fine:
            sl = self.table_.isel(ratio=ratio_index)
            status = sl["status"].values
            if name == "rupture_gap":
                vals = sl["rupture_gap"].values
                ok = sl["rupture_status"].values == Status.CONVERGED
            else:
                vals = sl[name].values
                ok = status == Status.CONVERGED
            if not ok.all():
                bad = np.argwhere(~ok)[0]
                raise ValueError(
                    f"table slice ratio={self.ratios_[ratio_index]:g} has {int((~ok).sum())} "
                    f"unconverged points (first at index {tuple(bad)}); regenerate the table "
                    "or restrict the lookup range")
            lv = np.log(self.volume_)
            fine = _refine_axis(vals, 0, self.theta_, self.theta_axis_.nodes)
            fine = _refine_axis(fine, 1, lv, self.logv_axis_.nodes)
            if fine.ndim == 3:
                fine = _refine_axis(fine, 2, self.s_, self.s_axis_.nodes)
            self._fine[key] = np.ascontiguousarray(fine)
        return self._fine[key]

    # ------------------------------------------------------------------------- predict
    def _validate(self, gap, volume, theta, ratio):
        gap = check_range("gap d*", gap, 0.0, np.inf, hint="overlapping grains are not supported")
        volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
        theta = check_range("theta", theta, 0.0, 180.0, high_open=True, units=" deg")
        ratio = check_range("ratio", ratio, 1.0, np.inf)
        status = np.zeros(np.broadcast_shapes(gap.shape, volume.shape, theta.shape, ratio.shape),
                          np.int8)
        lims = {"volume V*": (volume, self.volume_[0], self.volume_[-1]),
                "theta": (theta, self.theta_[0], self.theta_[-1]),
                "ratio": (ratio, self.ratios_[0], self.ratios_[-1])}
        for name, (x, lo, hi) in lims.items():
            outside = (x < lo * (1 - 1e-12)) | (x > hi * (1 + 1e-12))
            if np.any(outside):
                first = np.asarray(x)[outside].flat[0]
                msg = f"{name}={first!r} is outside the table's range [{lo:g}, {hi:g}]"
                if name != "volume V*":
                    # clipping would answer for another contact angle or grain pair
                    raise CapbridgeInputError(
                        f"{msg}; use a table that covers it, or the exact solver "
                        "(capbridge solve doublet / young_laplace.solve_doublet)")
                if self.out_of_range == "raise":
                    raise CapbridgeInputError(
                        f"{msg}; use a table that covers it, or {self.clip_hint} to answer "
                        "at the table's edge (status 'extrapolated')")
                status = np.where(np.broadcast_to(outside, status.shape), Status.EXTRAPOLATED,
                                  status)
        v_edge = np.clip(volume, self.volume_[0], self.volume_[-1])
        # gap scaled so that d*/d*_rupt is kept at the edge volume (d*_rupt ~ V*^(1/3))
        gap_scale = (v_edge / volume) ** _RUPTURE_EXPONENT
        return gap, v_edge, theta, ratio, status, gap_scale

    def predict(self, gap, volume, theta, ratio=1.0, variables=VARIABLES):
        """Interpolated bridge at (d*, V*, theta [deg], ratio): dict of arrays.

        Keys: the requested ``variables`` (force F*, pressure P*, beta1, beta2 [deg]),
        ``rupture_gap`` d*_rupt and ``status`` (converged, ruptured: force 0 and the
        others NaN, extrapolated).
        """
        self._check_fitted()
        variables = tuple(check_choice("variables", variables, VARIABLES))
        gap, volume, theta, ratio, status, scale = self._validate(gap, volume, theta, ratio)
        shape = status.shape
        g, v, t, r, sc = (np.broadcast_to(a, shape).ravel()
                          for a in (gap * scale, volume, theta, ratio, scale))
        out = {name: np.zeros(g.size) for name in tuple(variables) + ("rupture_gap",)}
        # on a tabulated ratio: that slice alone; between: a cubic spline across the
        # ratio slices (in log ratio), as linear weights on every slice's prediction
        j = np.argmin(np.abs(np.log(r)[:, None] - np.log(self.ratios_)[None, :]), axis=1)
        on_grid = np.isclose(r, self.ratios_[j], rtol=1e-12, atol=0)
        for jj in np.unique(j[on_grid]):
            which = on_grid & (j == jj)
            part = self._predict_slice(jj, g[which], v[which], t[which], variables)
            for name in out:
                out[name][which] = part[name]
        between = ~on_grid
        if between.any():
            weights = self._ratio_weights(r[between])
            for jj in range(len(self.ratios_)):
                part = self._predict_slice(jj, g[between], v[between], t[between], variables)
                for name in out:
                    out[name][between] += weights[:, jj] * part[name]
        ruptured = g > out["rupture_gap"]
        st = status.ravel().copy()
        st[ruptured] = Status.RUPTURED
        for name in variables:
            out[name][ruptured] = 0.0 if name == "force" else np.nan
        out["rupture_gap"] = out["rupture_gap"] / sc   # at the asked volume when clipped
        res = {name: out[name].reshape(shape) for name in out}
        res["status"] = st.reshape(shape)
        return res

    def predict_si(self, radius1, radius2, surface_tension, gap, volume, theta):
        """The bridge in SI units: radii, gap [m], volume [m^3], gamma [N/m], theta [deg].

        Returns force [N] (attraction > 0), pressure [Pa], beta1/beta2 [deg] on the
        smaller/larger grain, rupture_gap [m] and status.  The smaller radius
        normalises (``capbridge.dimensionless``).

        >>> sur = DoubletSurrogate().fit(_default_table())
        >>> f = sur.predict_si(1e-3, 1e-3, 0.072, 0.0, 1e-12, 0.0)["force"]
        >>> round(float(f / (2 * np.pi * 0.072 * 1e-3)), 2)  # V* = 1e-3 at contact: near cos(0)
        0.94
        """
        from capbridge.dimensionless import to_dimensionless, to_si

        slip = "SI units expected: radii in m, surface_tension in N/m (a unit slip?)"
        r1 = check_range("predict_si radius1", radius1, *SI_RADIUS_RANGE, units=" m", hint=slip)
        r2 = check_range("predict_si radius2", radius2, *SI_RADIUS_RANGE, units=" m", hint=slip)
        check_range("predict_si surface_tension", surface_tension, *SI_SURFACE_TENSION_RANGE,
                    units=" N/m", hint=slip)
        check_range("predict_si gap", gap, 0.0, np.inf, units=" m",
                    hint="overlapping grains are not supported")
        check_range("predict_si volume", volume, 0.0, np.inf, low_open=True, units=" m^3")
        r = np.minimum(r1, r2)
        q = to_dimensionless(r, surface_tension, gap=gap, volume=volume)
        try:
            res = self.predict(q["gap"], q["volume"], theta, np.maximum(r1, r2) / r)
        except CapbridgeInputError as exc:
            raise CapbridgeInputError(
                f"predict_si: {exc} (V* = volume [m^3] / R1^3, d* = gap [m] / R1, ratio = "
                f"R2/R1, R1 the smaller radius [m]; theta in degrees)") from None
        si = to_si(r, surface_tension, force=res["force"], pressure=res["pressure"],
                   gap=res["rupture_gap"])
        return {"force": si["force"], "pressure": si["pressure"], "beta1": res["beta1"],
                "beta2": res["beta2"], "rupture_gap": si["gap"], "status": res["status"]}

    def _ratio_weights(self, ratio):
        """Weights of each ratio slice in the spline through them, at ``ratio``.

        The spline basis depends on the table only: built once per fit, on first use.
        """
        if getattr(self, "_ratio_basis", None) is None:
            n = len(self.ratios_)
            self._ratio_basis = make_interp_spline(np.log(self.ratios_), np.eye(n),
                                                   k=min(3, n - 1), axis=0)
        return self._ratio_basis(np.log(ratio))

    def _predict_slice(self, jr, gap, volume, theta, variables):
        """Trilinear lookup on the fine grid of ratio slice ``jr``."""
        it, ft = self.theta_axis_.locate(theta)
        iv, fv = self.logv_axis_.locate(np.log(volume))
        d_r = _bilinear(self._fine_grid(jr, "rupture_gap"), it, ft, iv, fv)
        s = np.sqrt(np.clip(1.0 - gap / d_r, 0.0, 1.0))
        i_s, fs = self.s_axis_.locate(s)
        out = {"rupture_gap": d_r}
        for name in variables:
            out[name] = _trilinear(self._fine_grid(jr, name), it, ft, iv, fv, i_s, fs)
        return out

    def predict_fixed_theta(self, gap, volume, theta, ratio=1.0, name="force"):
        """Fastest path: one variable, one theta and ratio on the grid, no checks.

        For DEM inner loops and benchmarks; the caller guarantees V* inside the table
        and gap >= 0.  Returns the variable (force is 0 beyond rupture).
        """
        self._check_fitted()
        key = ("slice", float(theta), float(ratio), name)
        if key not in self._fine:
            jr = int(np.flatnonzero(np.isclose(self.ratios_, ratio))[0])
            it, ft = self.theta_axis_.locate(np.array([float(theta)]))
            grid = self._fine_grid(jr, name)
            rup = self._fine_grid(jr, "rupture_gap")
            sl = grid[it[0]] * (1 - ft[0]) + grid[it[0] + 1] * ft[0]
            rl = rup[it[0]] * (1 - ft[0]) + rup[it[0] + 1] * ft[0]
            self._fine[key] = (np.ascontiguousarray(sl), rl)
        grid, rupt = self._fine[key]
        ax_v, ax_s = self.logv_axis_, self.s_axis_
        u = (np.log(volume) - ax_v.lo) * (1.0 / ax_v.step)
        iv = np.minimum(u.astype(np.intp), ax_v.n - 2)
        fv = u - iv
        d_r = rupt[iv] * (1 - fv) + rupt[iv + 1] * fv
        s2 = 1.0 - gap / d_r
        s = np.sqrt(np.maximum(s2, 0.0)) * ((ax_s.n - 1) / (ax_s.hi - ax_s.lo))
        i_s = np.minimum(s.astype(np.intp), ax_s.n - 2)
        fs = s - i_s
        flat = grid.ravel()
        k = iv * ax_s.n + i_s
        a = flat[k] + (flat[k + 1] - flat[k]) * fs
        b = flat[k + ax_s.n] + (flat[k + ax_s.n + 1] - flat[k + ax_s.n]) * fs
        val = a + (b - a) * fv
        if name == "force":
            val = np.where(s2 < 0.0, 0.0, val)
        return val


def _bilinear(grid, i, fi, j, fj):
    a = grid[i, j] * (1 - fj) + grid[i, j + 1] * fj
    b = grid[i + 1, j] * (1 - fj) + grid[i + 1, j + 1] * fj
    return a * (1 - fi) + b * fi


def _trilinear(grid, i, fi, j, fj, k, fk):
    def plane(ii):
        a = grid[ii, j, k] * (1 - fk) + grid[ii, j, k + 1] * fk
        b = grid[ii, j + 1, k] * (1 - fk) + grid[ii, j + 1, k + 1] * fk
        return a * (1 - fj) + b * fj

    return plane(i) * (1 - fi) + plane(i + 1) * fi


def _default_table():
    from pathlib import Path

    return Path(__file__).resolve().parents[2] / "data" / "doublet_table.nc"


def _open(path):
    from capbridge.generator.netcdf_io import read_table

    return read_table(path)


def holdout_errors(surrogate, n=400, seed=0, ratio=1.0, exclude_band=0.0):
    """Relative force error of the surrogate against exact solutions at random points.

    Points are uniform in theta, log V* and s inside the table (s >= exclude_band, i.e.
    a band next to rupture can be left out and is then stated).  Returns a dict with
    the points, both forces and the median and max relative error over the points the
    exact solver converged on.
    """
    from capbridge.generator.young_laplace import solve_doublet

    rng = np.random.default_rng(seed)
    th = rng.uniform(surrogate.theta_[0], surrogate.theta_[-1], n)
    v = np.exp(rng.uniform(np.log(surrogate.volume_[0]), np.log(surrogate.volume_[-1]), n))
    s = rng.uniform(exclude_band, 1.0, n)
    d_r = surrogate.predict(0.0, v, th, ratio)["rupture_gap"]
    gap = d_r * (1.0 - s**2)
    exact = solve_doublet(gap, v, th, ratio)
    approx = surrogate.predict(gap, v, th, ratio)
    ok = (exact["status"] == Status.CONVERGED) & (approx["status"] == Status.CONVERGED)
    rel = np.abs(approx["force"][ok] / exact["force"][ok] - 1.0)
    return {"gap": gap, "volume": v, "theta": th, "s": s, "exact": exact["force"],
            "surrogate": approx["force"], "used": ok,
            "median_rel_error": float(np.median(rel)), "max_rel_error": float(np.max(rel)),
            "n": int(ok.sum()), "exclude_band": exclude_band}
