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

from capbridge.tables import DOUBLET_TABLE
from capbridge.tables.description import (describe_doublet_gravity, describe_table,
                                          json_friendly)
from capbridge.status import HAS_RESULT, Status, status_in
from capbridge.surrogate.grid import (UniformAxis, bilinear, bilinear_flat, refine_axis,
                                      trilinear)
from capbridge.surrogate.base import (SurrogateBase, apply_no_result_rule, has_number,
                                     worst_status)
from capbridge.physics.gravity import (BOND_MAX, check_bond, doublet_gravity_forces,
                                         gravity_vector, liquid_weight)
from capbridge.validation import (CONTACT_OVERLAP_MAX, CapbridgeInputError, check_choice,
                                  check_gap, check_int, check_range)

VARIABLES = ("force", "pressure", "beta1", "beta2")
#: the table's response to gravity on the liquid (:mod:`capbridge.tables.doublet_gravity`):
#: first-order share of the weight on grain 1 with gravity along the axis, and the second
#: derivative of the attraction in the axial component b_n of b = Bo g_hat
GRAVITY_VARIABLES = ("weight_share_axial", "force_gravity_curvature_axial")
#: tolerance of the gravity part's estimated error, relative to the attraction F0: above
#: it a lookup with gravity is APPROXIMATE (a table's ``gravity_response_rtol`` if it
#: has one; the same 1e-3 as the generator's)
GRAVITY_RTOL = 1e-3

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
SI_DENSITY_RANGE = (0.0, 2.5e4)          # [kg/m^3]: density difference liquid - gas
SI_GRAVITY_RANGE = (0.0, 1e3)            # [m/s^2]: |g| (centrifuges included)



def si_bond(radius, surface_tension, density_difference, gravity):
    """Bond number and direction of gravity from SI inputs.

    Bo = drho |g| r^2 / gamma (:func:`capbridge.dimensionless.bond_number`).

    Parameters
    ----------
    radius : array_like
        Normalising radius r [m].
    surface_tension : float
        gamma [N/m].
    density_difference : float
        drho = rho_liquid - rho_gas [kg/m^3], in :data:`SI_DENSITY_RANGE`.
    gravity : array_like (3,)
        Acceleration of gravity as a vector [m/s^2] (direction: where it pulls), its
        length in :data:`SI_GRAVITY_RANGE`.

    Returns
    -------
    bond : ndarray
        Bo [-] (0 where drho or |g| is 0).
    direction : ndarray (3,)
        Unit vector along gravity ((0, 0, -1) when |g| = 0).

    >>> bo, d = si_bond(4e-3, 0.073, 997.0, (0.0, 0.0, -9.81))
    >>> round(float(bo), 2), d.tolist()
    (2.14, [0.0, 0.0, -1.0])
    """
    from capbridge.dimensionless import bond_number

    slip = "SI units expected: density in kg/m^3, gravity in m/s^2 (a unit slip?)"
    drho = check_range("predict_si density_difference", density_difference,
                       *SI_DENSITY_RANGE, units=" kg/m^3", hint=slip)
    g = check_range("predict_si gravity", gravity, units=" m/s^2",
                    hint="give the acceleration vector (gx, gy, gz)")
    if g.shape != (3,):
        raise CapbridgeInputError(f"predict_si gravity={np.asarray(gravity).tolist()!r}: "
                                  "give one vector of three components (gx, gy, gz) in m/s^2")
    norm = float(np.linalg.norm(g))
    check_range("predict_si |gravity|", norm, *SI_GRAVITY_RANGE, units=" m/s^2", hint=slip)
    direction = g / norm if norm > 0 else np.array([0.0, 0.0, -1.0])
    return bond_number(radius, surface_tension, drho, norm), direction

#: exponent of the rupture distance in V*: d*_rupt ~ (1 + theta/2) V*^(1/3)
#: (Lian, Thornton & Adams 1993), used to keep the state (bridge or none) when a
#: volume outside the table is clipped
_RUPTURE_EXPONENT = 1.0 / 3.0


class DoubletSurrogate(SurrogateBase):
    """Interpolating surrogate of a doublet table (scikit-learn style: fit, predict).

    Follows the surrogate contract of :mod:`capbridge.surrogate.base` (NotFittedError,
    ``has_gravity_``, :meth:`summary`, statuses, the no-result rule).

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
        # checked here, stored as given (scikit-learn's get_params/clone contract); fit
        # uses the checked values
        self._settings(refine, theta_step)
        self.refine = refine
        self.theta_step = theta_step
        self.out_of_range = out_of_range
        self.clip_hint = clip_hint

    # ----------------------------------------------------------------------------- fit
    def fit(self, table, *, allow_unverified=None):
        """Load and validate a table (path or Dataset); refinement is done lazily.

        The table is checked (:func:`~capbridge.tables.doublet.validate_doublet_table`:
        checksums, axes, units, physical bounds and the gravity response's invariants)
        and so are this surrogate's refinement settings against those of the table's
        error model.  A file without the table checksum ``table_sha256`` is refused
        unless ``allow_unverified=True`` (or inside
        :func:`capbridge.tables.netcdf_io.allow_unverified_tables`); a Dataset
        built in memory needs none (:func:`~capbridge.tables.netcdf_io.read_table`).
        """
        from capbridge.tables.doublet import validate_doublet_table

        if isinstance(table, xr.Dataset):
            ds = validate_doublet_table(table, "doublet table (Dataset)")
        else:
            ds = validate_doublet_table(_open(table, allow_unverified), str(table))
        refine, theta_step = self._settings(self.refine, self.theta_step)
        if any(k.startswith("holdout_") for k in ds.attrs):
            ref = int(ds.attrs.get("holdout_refine", DEFAULT_REFINE))
            step = float(ds.attrs.get("holdout_theta_step", DEFAULT_THETA_STEP))
            keep = "the table's stored error model does not hold on a coarser grid"
            check_int("refine", refine, ref, MAX_REFINE, hint=keep)
            check_range("theta_step", theta_step, MIN_THETA_STEP, step, units=" deg",
                        hint=keep)
        self.table_ = ds
        self.ratios_ = np.asarray(ds["ratio"].values, float)
        self.theta_ = np.asarray(ds["theta"].values, float)
        self.volume_ = np.asarray(ds["volume"].values, float)
        self.s_ = np.asarray(ds["s"].values, float)
        self.theta_axis_ = UniformAxis(self.theta_[0], self.theta_[-1],
                                 int(round((self.theta_[-1] - self.theta_[0]) / theta_step)) + 1)
        lv = np.log(self.volume_)
        self.logv_axis_ = UniformAxis(lv[0], lv[-1], (len(lv) - 1) * refine + 1)
        self.s_axis_ = UniformAxis(self.s_[0], self.s_[-1], (len(self.s_) - 1) * refine + 1)
        self.refine_, self.theta_step_ = refine, theta_step
        self._fine = {}
        self._ratio_basis = None
        self.holdout_ = {k: v for k, v in ds.attrs.items() if k.startswith("holdout_")}
        self.gravity_bond_max_ = validated_axial_bond(ds.attrs)
        self.has_gravity_ = all(n in ds for n in GRAVITY_VARIABLES)
        self._gravity_cache = {}            # the gravity layers, prepared at first use
        return self

    @staticmethod
    def _settings(refine, theta_step):
        """The checked (refine, theta_step)."""
        refine = check_int("refine", refine, 1, MAX_REFINE,
                           hint="fine-grid nodes per table interval")
        theta_step = float(check_range("theta_step", theta_step, MIN_THETA_STEP, 90.0,
                                       units=" deg"))
        return refine, theta_step

    def summary(self):
        """What the surrogate was fitted on and its error model (JSON-friendly dict),
        for ``capbridge info``: ``table`` (what the table says about itself:
        :func:`~capbridge.tables.description.describe_table`); from it, as before it,
        ``command``, ``git_commit`` and ``axes``, with ``checksum`` (the table carries
        a data checksum), ``points`` and ``converged`` points; the fine-grid settings,
        the stored held-out errors (``holdout_*``) and the gravity response (None
        without one: its variables, the supported and validated Bond numbers, and
        :func:`~capbridge.tables.description.describe_doublet_gravity`)."""
        self._check_fitted()
        ds = self.table_
        table = describe_table(ds, ("ratio", "theta", "volume", "s"))
        st = np.asarray(ds["status"].values)
        gravity = None
        if self.has_gravity_:
            gravity = {"variables": [n for n in GRAVITY_VARIABLES + (
                "weight_share_transverse", "response_error", "rupture_gap_gravity")
                if n in ds], "bond_max_supported": BOND_MAX,
                "bond_max_validated": float(self.gravity_bond_max_)}
            gravity.update(describe_doublet_gravity(ds, GRAVITY_VARIABLES + (
                "weight_share_transverse", "response_error", "gravity_status",
                "rupture_gap_gravity")))
        return {"table": table, "command": table["command"],
                "git_commit": table["git_commit"], "checksum": "data_sha256" in ds.attrs,
                "axes": table["axes"],
                "points": int(st.size), "converged": int((st == Status.CONVERGED).sum()),
                "refine": self.refine_, "theta_step": self.theta_step_,
                "holdout_error": {k: json_friendly(v) for k, v in self.holdout_.items()},
                "gravity": gravity}

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
            fine = refine_axis(vals, 0, self.theta_, self.theta_axis_.nodes)
            fine = refine_axis(fine, 1, lv, self.logv_axis_.nodes)
            if fine.ndim == 3:
                fine = refine_axis(fine, 2, self.s_, self.s_axis_.nodes)
            self._fine[key] = np.ascontiguousarray(fine)
        return self._fine[key]

    # ------------------------------------------------------------------------- predict
    def _validate(self, gap, volume, theta, ratio):
        gap = check_gap("gap d*", gap)     # DEM contacts (small overlaps) are gap 0
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

        A gap below zero down to -:data:`~capbridge.validation.CONTACT_OVERLAP_MAX` (grains
        in contact overlap in a DEM) is answered at contact, d* = 0.

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

    def predict_si(self, radius1, radius2, surface_tension, gap, volume, theta,
                   density_difference=None, gravity=None):
        """The bridge in SI units: radii, gap [m], volume [m^3], gamma [N/m], theta [deg].

        Returns force [N] (attraction > 0), pressure [Pa], beta1/beta2 [deg] on the
        smaller/larger grain, rupture_gap [m] and status.  The smaller radius
        normalises (``capbridge.dimensionless``).

        With gravity on the liquid: ``density_difference`` drho [kg/m^3] and
        ``gravity`` the acceleration vector [m/s^2] (default (0, 0, -9.81)) in the frame
        with grain 1 (``radius1``) at the origin and grain 2 on +x.  Bo = drho |g| R^2 /
        gamma (R the smaller radius, :func:`capbridge.dimensionless.bond_number`) and
        the answer of :meth:`predict_vectors`: extra keys ``F1``, ``F2`` (..., 3) [N]
        on grain 1 and 2, ``bond`` and ``rupture_gap`` with gravity; ``force`` stays
        the zero-gravity attraction [N].

        >>> sur = DoubletSurrogate().fit(default_table())
        >>> f = sur.predict_si(1e-3, 1e-3, 0.072, 0.0, 1e-12, 0.0)["force"]
        >>> round(float(f / (2 * np.pi * 0.072 * 1e-3)), 2)  # V* = 1e-3 at contact: near cos(0)
        0.94
        """
        from capbridge.dimensionless import to_dimensionless, to_si

        self._check_fitted()
        slip = "SI units expected: radii in m, surface_tension in N/m (a unit slip?)"
        r1 = check_range("predict_si radius1", radius1, *SI_RADIUS_RANGE, units=" m", hint=slip)
        r2 = check_range("predict_si radius2", radius2, *SI_RADIUS_RANGE, units=" m", hint=slip)
        check_range("predict_si surface_tension", surface_tension, *SI_SURFACE_TENSION_RANGE,
                    units=" N/m", hint=slip)
        check_gap("predict_si gap", gap, units=" m",
                  overlap_max=CONTACT_OVERLAP_MAX * np.minimum(r1, r2))
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
        out = {"force": si["force"], "pressure": si["pressure"], "beta1": res["beta1"],
               "beta2": res["beta2"], "rupture_gap": si["gap"], "status": res["status"]}
        if density_difference is None and gravity is None:
            return out
        bond, direction = si_bond(r, surface_tension,
                                  0.0 if density_difference is None else density_difference,
                                  (0.0, 0.0, -9.81) if gravity is None else gravity)
        # the surrogate's grain 1 is the smaller one: mirror x where radius1 > radius2
        swap = np.asarray(r1 > r2)
        d = np.where(swap[..., None], direction * np.array([-1.0, 1.0, 1.0]), direction)
        try:
            vec = self.predict_vectors(q["gap"], q["volume"], theta, np.maximum(r1, r2) / r,
                                       bond=bond, gravity=d)
        except CapbridgeInputError as exc:
            raise CapbridgeInputError(f"predict_si: {exc} (Bo = density_difference [kg/m^3]"
                                      " |gravity| [m/s^2] R^2 / surface_tension, R the "
                                      "smaller radius [m])") from None
        mirror = np.array([-1.0, 1.0, 1.0])
        F1 = np.where(swap[..., None], vec["F2"] * mirror, vec["F1"])
        F2 = np.where(swap[..., None], vec["F1"] * mirror, vec["F2"])
        fs = to_si(r, surface_tension, force=1.0)["force"]
        fs = np.asarray(fs)[..., None]
        out.update(F1=F1 * fs, F2=F2 * fs, bond=np.asarray(bond),
                   rupture_gap=to_si(r, surface_tension, gap=vec["rupture_gap"])["gap"],
                   status=vec["status"])
        return out

    # ---------------------------------------------------------------------- gravity
    def _check_bond(self, bond):
        return check_bond(bond, self.has_gravity_, "doublet", ", ".join(GRAVITY_VARIABLES),
                          "the exact solver (capbridge solve doublet --bond)")

    def predict_vectors(self, gap, volume, theta, ratio=1.0, bond=0.0, gravity=None):
        """Force vectors on both grains, with gravity on the liquid.

        Frame: grain 1 (radius 1, the smaller) at the origin, grain 2 on +x (the
        convention of :mod:`capbridge.solvers.young_laplace_gravity`); n = (1, 0, 0).

        Parameters
        ----------
        gap, volume, theta, ratio : array_like
            As for :meth:`predict` (d*, V*, theta [deg], R2/R1).
        bond : array_like, default 0
            Bo = drho g R1^2 / gamma, in [0, :data:`BOND_MAX`].  Bo = 0 gives exactly
            the answer of :meth:`predict`.
        gravity : array_like (..., 3), optional
            Direction along which gravity pulls, in this frame; default (0, 0, -1)
            (across the axis).

        Returns
        -------
        dict
            ``F1``, ``F2`` (..., 3): forces on grain 1 and 2 [F*], from
            :func:`~capbridge.physics.gravity.doublet_gravity_forces`,

                F1 = F0 n + W [w b_n n + u b_perp] + c b_n^2 n / 2,
                F2 = -F0 n - c b_n^2 n / 2 + W [(1 - w) b_n n + (1 - u) b_perp],

            W = V*/(2 pi), b = Bo g_hat, b_n = b . n; F0 the zero-gravity force of the
            table, w (``weight_share_axial``), c (``force_gravity_curvature_axial``) and
            u (``weight_share_transverse``, the lever rule; 1/2 if the table has none)
            interpolated (multilinear, log V*) at the point's (ratio, theta, V*, s).
            ``force`` F0, ``share``, ``curvature``, ``share_transverse``,
            ``gravity_error`` (below), ``gravity`` b, ``rupture_gap``
            (with gravity: the zero-gravity d*_rupt times the relative shift
            ``rupture_gap_gravity`` / ``rupture_gap`` of the rupture sub-grid, interpolated
            at Bo_axial = |b_n| on the side gravity_axis = sign(b_n), linear in Bo from
            1 at Bo = 0),
            ``rupture_gap_zero_gravity`` and ``status``:

            * gap beyond the rupture distance with gravity: RUPTURED, F1 = F2 = 0;
            * gap beyond the zero-gravity rupture but inside the one with gravity:
              OUT_OF_RANGE, no number (the table has no bridge there);
            * b with a transverse component and gap within the last 10 % of the
              rupture distance: APPROXIMATE (rupture under transverse gravity is not
              computed); in that last 10 % also a point outside the rupture sub-grid
              (its nearest edge);
            * |b_n| above ``gravity_bond_max_``, the largest Bo at which the table's
              held-out exact solutions (``gravity_holdout_*``, gravity along the axis)
              of lookups not flagged otherwise stay within ``gravity_response_rtol``
              of the attraction: APPROXIMATE (their own estimate leaves out the
              interpolation between the response's nodes); so is gravity across the
              axis beyond its range measured against Surface Evolver
              (:data:`TRANSVERSE_BOND_UNEQUAL`, :data:`TRANSVERSE_GAP_FRACTION`);
            * the response not available at a corner (``gravity_status``): NOT_CONVERGED;
              a corner ABOVE_TOLERANCE (its step-halving error estimate, near rupture)
              or a point outside the response's sub-grid (its nearest edge):
              APPROXIMATE;
            * ``gravity_error`` above ``gravity_response_rtol`` (:data:`GRAVITY_RTOL`):
              APPROXIMATE.  It estimates the error of the gravity part relative to |F0|:
              the terms the representation leaves out along the axis, the nodes'
              ``response_error`` e (at Bo = h) scaled as (|b_n|/h)^3, or ^4 beyond h
              (the leading omitted term is cubic, quartic for equal grains); for a table
              without ``weight_share_transverse`` and unequal grains also W |b_perp| / 2,
              the largest error of taking the transverse share as 1/2.
        """
        self._check_fitted()
        base = self.predict(gap, volume, theta, ratio, variables=("force",))
        st = np.array(base["status"], np.int8)
        shape = st.shape
        bo = self._check_bond(bond)
        direction = (0.0, 0.0, -1.0) if gravity is None else gravity
        gravity_vector(1.0, direction)             # three finite components, not all zero
        try:
            bo = np.broadcast_to(bo, shape)
            b = np.broadcast_to(gravity_vector(bo, direction), shape + (3,))
        except ValueError:
            raise CapbridgeInputError(
                f"bond of shape {np.shape(bond)} and gravity of shape {np.shape(gravity)} "
                f"do not broadcast to the points' shape {shape} (gravity: (..., 3))") from None
        g, V, t, R = (np.broadcast_to(np.asarray(x, float), shape)
                      for x in (gap, volume, theta, ratio))
        F0 = np.array(base["force"], float)
        rup0 = np.array(base["rupture_gap"], float)
        rup = rup0.copy()
        share = np.full(shape, 0.5)
        share_t = np.full(shape, 0.5)
        curv = np.zeros(shape)
        gerr = np.zeros(shape)
        on = bo > 0
        if on.any():
            bn = b[..., 0]
            s = np.sqrt(np.clip(1.0 - g / rup0, 0.0, 1.0))
            resp = self.gravity_response(R[on], t[on], V[on], s[on])
            share[on], curv[on] = resp["share"], resp["curvature"]
            share_t[on] = resp["share_transverse"]
            code = resp["status"]
            est = self._gravity_error(resp["error"], b[on], R[on], V[on], F0[on])
            gerr[on] = est
            rg, rcode = self._rupture_gravity(R[on], t[on], V[on], np.abs(bn[on]),
                                              np.sign(bn[on]), rup0[on])
            rup[on] = rg
            sto = st[on]
            gon = g[on]
            near = gon > 0.9 * rg
            # the rupture distance with gravity only decides RUPTURED: a rupture sub-grid
            # without the point (clipped: code 1) matters next to rupture only
            code = worst_status(code, np.where(near | (rcode == Status.NOT_CONVERGED), rcode,
                                               np.int8(Status.CONVERGED)))
            has = status_in(sto, (Status.CONVERGED, Status.EXTRAPOLATED))
            beyond0 = sto == Status.RUPTURED
            sto = np.where(has & (code == Status.NOT_CONVERGED), np.int8(Status.NOT_CONVERGED),
                           sto)
            sto = np.where(beyond0 & (gon <= rg), np.int8(Status.OUT_OF_RANGE), sto)
            sto = np.where(status_in(sto, (Status.CONVERGED, Status.EXTRAPOLATED)) & (gon > rg),
                           np.int8(Status.RUPTURED), sto)
            b_perp = np.linalg.norm(b[on][:, 1:], axis=-1)
            transverse = b_perp > 0
            rtol = float(self.table_.attrs.get("gravity_response_rtol", GRAVITY_RTOL))
            unvalidated = ((np.abs(bn[on]) > self.gravity_bond_max_ * (1 + 1e-12))
                           | _transverse_unvalidated(b_perp, R[on], gon, rg))
            sto = np.where((sto == Status.CONVERGED)
                           & ((code == Status.APPROXIMATE) | (transverse & near) | (est > rtol)
                              | unvalidated),
                           np.int8(Status.APPROXIMATE), sto)
            st[on] = sto
        n = np.broadcast_to(np.array([1.0, 0.0, 0.0]), shape + (3,))
        F1, F2 = doublet_gravity_forces(F0, n, V, b, share, curv, share_t)
        F1 = np.where(on[..., None], F1, F0[..., None] * n)
        F2 = np.where(on[..., None], F2, -F0[..., None] * n)
        ruptured = st == Status.RUPTURED
        nores = ~status_in(st, HAS_RESULT + (Status.EXTRAPOLATED, Status.RUPTURED))
        for F in (F1, F2):
            F[ruptured] = 0.0
            F[nores] = np.nan
        return {"F1": F1, "F2": F2, "force": np.where(nores, np.nan, F0),
                "share": share, "curvature": curv, "share_transverse": share_t,
                "gravity": np.array(b),
                "gravity_error": np.where(nores, np.nan, gerr),
                "rupture_gap": rup, "rupture_gap_zero_gravity": rup0, "status": st}

    def _gravity_error(self, e_node, b, ratio, volume, F0):
        """Estimated error of the gravity part, relative to |F0| (see predict_vectors)."""
        h = float(self.table_.attrs.get("gravity_bond_step", 0.5))
        x = np.abs(b[:, 0]) / h
        axial = e_node * np.where(x <= 1.0, x**3, x**4)
        b_perp = np.linalg.norm(b[:, 1:], axis=-1)
        unknown = (ratio > 1.0 + 1e-12) & ("weight_share_transverse" not in self.table_)
        transverse = np.where(unknown, 0.5 * liquid_weight(volume) * b_perp, 0.0)
        return axial + transverse / np.maximum(np.abs(F0), 1e-300)

    def gravity_response(self, ratio, theta, volume, s):
        """The table's gravity response at points (ratio, theta [deg], V*, s).

        Returns a dict of arrays: ``share`` w, ``curvature`` c, ``share_transverse`` u
        (1/2 for a table without ``weight_share_transverse``), ``error`` the nodes' own
        estimate ``response_error`` (0 for a table without it), all interpolated, and
        ``status`` (int8 :class:`~capbridge.status.Status`): CONVERGED, APPROXIMATE
        (clipped to the sub-grid, or a corner ABOVE_TOLERANCE), NOT_CONVERGED (not
        available: no number).  (Before the surrogate contract: ``code`` 0, 1, 2.)
        """
        self._check_fitted()
        if not self.has_gravity_:
            raise CapbridgeInputError(
                f"this doublet table has no gravity response ({', '.join(GRAVITY_VARIABLES)})")
        pts = {"ratio": ratio, "theta": theta, "volume": volume, "s": s}
        n = np.size(ratio)
        fields = [("share", "weight_share_axial", None),
                  ("curvature", "force_gravity_curvature_axial", None),
                  ("share_transverse", "weight_share_transverse", 0.5),
                  ("error", "response_error", 0.0)]
        have = [f for f in fields if f[1] in self.table_]
        lookup, n_masks = self._gravity_layers(tuple(name for _, name, _ in have))
        vals, code = lookup(pts)
        out = {key: np.full(n, default, float) for key, _, default in fields}
        for j, (key, _, _) in enumerate(have):
            out[key] = np.nan_to_num(vals[:, j], nan=0.0) if key == "error" else vals[:, j]
        if n_masks:
            above, bad = vals[:, len(have)], vals[:, len(have) + 1]
            code = np.where(above > 0, worst_status(code, Status.APPROXIMATE), code)
            code = np.where(bad > 0, np.int8(Status.NOT_CONVERGED), code)
        out["status"] = code.astype(np.int8)
        return out

    def _gravity_layers(self, names):
        """A :class:`_GridLookup` of the response's variables ``names`` and the masks of
        its ABOVE_TOLERANCE and result-less nodes stacked along a last dim "layer" (one
        interpolation serves them all), made once per fit; and the number of masks."""
        if "layers" not in self._gravity_cache:
            ds = self.table_
            layers = [ds[name] for name in names]
            if "gravity_status" in ds:
                st = ds["gravity_status"]
                layers += [(st == Status.ABOVE_TOLERANCE).astype(float),
                           (~st.isin([int(x) for x in HAS_RESULT])).astype(float)]
            dims = layers[0].dims
            stacked = xr.DataArray(
                np.stack([np.asarray(x.transpose(*dims).values, float) for x in layers],
                         axis=-1), dims=dims + ("layer",),
                coords={d: ds[d].values for d in dims if d in ds.coords})
            self._gravity_cache["layers"] = (_GridLookup(stacked, stack="layer"),
                                             len(layers) - len(names))
        return self._gravity_cache["layers"]

    def _rupture_shift(self):
        """Per side of gravity (g_hat.n = -1, +1): the bond nodes and a
        :class:`_GridLookup` of q = ``rupture_gap_gravity`` / ``rupture_gap`` of the same
        node (NaN where the solve did not converge) over them, made once per fit."""
        if "rupture" not in self._gravity_cache:
            da = self.table_["rupture_gap_gravity"]
            if "rupture_gravity_status" in self.table_:
                ok = self.table_["rupture_gravity_status"] == Status.CONVERGED
                da = da.where(ok)
            dim = {_axis_name(d): d for d in da.dims}
            # relative to the zero-gravity rupture distance of the same node: the sub-grid
            # is coarser than the table (and may not cover every ratio or angle), and the
            # relative shift d_rupt(Bo)/d_rupt(0) varies much less across it than d_rupt
            base = self.table_["rupture_gap"]
            base = base.sel({a: da[dim[a]].values for a in ("ratio", "theta", "volume")
                             if a in dim}, method="nearest")
            base = base.rename({a: dim[a] for a in base.dims if a in dim and dim[a] != a})
            base = base.assign_coords({d: da[d].values for d in base.dims})
            da = da / base
            sides = {}
            for sgn in (-1.0, 1.0):
                sl = da.sel({dim["gravity_axis"]: sgn}) if "gravity_axis" in dim else da
                sides[sgn] = (np.asarray(sl[dim["bond"]].values, float),
                              _GridLookup(sl, stack=dim["bond"]))
            self._gravity_cache["rupture"] = sides
        return self._gravity_cache["rupture"]

    def _rupture_gravity(self, ratio, theta, volume, bond_axial, side, rup0):
        """Rupture distance with gravity along the axis: ``rup0`` (zero gravity, at the
        point) times q = ``rupture_gap_gravity`` / ``rupture_gap`` of the sub-grid's
        nodes, multilinear in (ratio, theta, log V*) and linear in Bo between the
        ``bond`` nodes, q = 1 at Bo = 0; side 0 (gravity across): ``rup0``.  Status
        APPROXIMATE where the point or Bo lies outside the sub-grid (its edge),
        NOT_CONVERGED where a node has no result, else CONVERGED."""
        if "rupture_gap_gravity" not in self.table_:
            return rup0.copy(), np.where(bond_axial > 0, np.int8(Status.APPROXIMATE),
                                         np.int8(Status.CONVERGED)).astype(np.int8)
        sides = self._rupture_shift()
        out = rup0.copy()
        code = np.full(rup0.shape, Status.CONVERGED, np.int8)
        for sgn in (-1.0, 1.0):
            m = (side == sgn) & (bond_axial > 0)
            if not m.any():
                continue
            bonds, lookup = sides[sgn]
            vals, cds = lookup({"ratio": ratio[m], "theta": theta[m],
                                "volume": volume[m]})    # (n, bonds), one pass
            x = bond_axial[m]
            if bonds[0] > 0:
                bonds = np.concatenate([[0.0], bonds])
                vals = np.concatenate([np.ones((x.size, 1)), vals], -1)
            # linear in Bo between the bond nodes, constant beyond the last (np.interp's
            # rule), point by point
            k = np.clip(np.searchsorted(bonds, x, side="right") - 1, 0, bonds.size - 2)
            t = np.clip((x - bonds[k]) / (bonds[k + 1] - bonds[k]), 0.0, 1.0)
            rows = np.arange(x.size)
            q = vals[rows, k] + t * (vals[rows, k + 1] - vals[rows, k])
            r = rup0[m] * q
            above = x > bonds[-1] * (1 + 1e-12)
            out[m] = r
            code[m] = np.where(~np.isfinite(r), np.int8(Status.NOT_CONVERGED),
                               np.where(above, np.int8(Status.APPROXIMATE), cds))
        return out, code


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
        d_r = bilinear(self._fine_grid(jr, "rupture_gap"), it, ft, iv, fv)
        s = np.sqrt(np.clip(1.0 - gap / d_r, 0.0, 1.0))
        i_s, fs = self.s_axis_.locate(s)
        out = {"rupture_gap": d_r}
        for name in variables:
            out[name] = trilinear(self._fine_grid(jr, name), it, ft, iv, fv, i_s, fs)
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
        val = bilinear_flat(grid.ravel(), iv * ax_s.n + i_s, ax_s.n, fs, fv)
        if name == "force":
            val = np.where(s2 < 0.0, 0.0, val)
        return val


def _axis_name(dim):
    """The table axis a dimension of a gravity variable samples: the sub-grids of
    :mod:`capbridge.tables.doublet_gravity` are named ``gravity_theta``,
    ``rupture_volume``, ... (nodes of the table's own axes)."""
    for prefix in ("gravity_", "rupture_"):
        if dim.startswith(prefix) and dim[len(prefix):] in ("ratio", "theta", "volume", "s",
                                                            "bond", "gravity_axis"):
            return dim[len(prefix):]
    return dim


#: gravity across the axis, measured against direct Surface Evolver minimisations
#: (``benchmarks/gravity_doublet_validity.json``, error <= 1e-3 F0): equal grains up to
#: Bo = 2.5 at d* <= 0.22 d*_rupt, ratio 2 up to 0.5 (the transverse second-order change
#: of the attraction, not represented, is 1.05e-3 F0 at 2.14), and at 0.8 d*_rupt only
#: 0.05 (4.5e-3 F0 at Bo = 1; the bridge pinches off at 1.5).  Beyond these, APPROXIMATE:
#: the transverse Bo allowed for unequal grains, and the part of the gap (from
#: TRANSVERSE_GAP_FRACTION of the rupture distance on) where only TRANSVERSE_BOND_NEAR is.
TRANSVERSE_BOND_UNEQUAL = 0.5
TRANSVERSE_GAP_FRACTION = 0.5
TRANSVERSE_BOND_NEAR = 0.05


def _transverse_unvalidated(b_perp, ratio, gap, rupture_gap):
    """Where gravity across the axis lies outside its measured validity (above)."""
    return (((ratio > 1.0 + 1e-12) & (b_perp > TRANSVERSE_BOND_UNEQUAL * (1 + 1e-12)))
            | ((gap > TRANSVERSE_GAP_FRACTION * rupture_gap)
               & (b_perp > TRANSVERSE_BOND_NEAR * (1 + 1e-12))))


def validated_axial_bond(attrs):
    """Largest Bo of the table's held-out check with gravity (``gravity_holdout_*``) up to
    which the lookups the table calls converged stay within ``gravity_response_rtol`` of
    the attraction (at that Bo and every smaller one); BOND_MAX for a table without the
    check (its lookups rely on their own estimate alone)."""
    if "gravity_holdout_bonds" not in attrs:
        return BOND_MAX
    rtol = float(attrs.get("gravity_response_rtol", GRAVITY_RTOL))
    best = 0.0
    for b, e in zip(np.atleast_1d(attrs["gravity_holdout_bonds"]),
                    np.atleast_1d(attrs["gravity_holdout_max_effect_error_converged"])):
        if not e <= rtol:
            break
        best = float(b)
    return best


class _GridLookup:
    """Multilinear interpolation of ``da`` (dims among ratio, theta, volume, s; log V*
    along volume), prepared once: ``lookup(points)`` with ``points`` name -> array, one
    entry per dim.

    Coordinates outside the variable's axis are clipped to it (status APPROXIMATE); a
    NaN at a corner with a positive weight gives NOT_CONVERGED (value NaN); dims of
    length 1 are taken constant (APPROXIMATE where the point is not on that node).
    ``stack``: a dim of ``da`` that is not interpolated but carried along (values (n,
    its size), one pass for all; NOT_CONVERGED where any of them meets a NaN).
    Returns (values, status), the status an int8 :class:`~capbridge.status.Status`.
    """

    def __init__(self, da, stack=None):
        from scipy.interpolate import RegularGridInterpolator

        self.stack, self.axes = stack, []       # (name, coordinate, interpolated?)
        sel, grid = {}, []
        for d in da.dims:
            if d == stack:
                continue
            name = _axis_name(d)
            c = np.asarray(da[d].values, float)
            self.axes.append((name, c, c.size > 1))
            if c.size == 1:
                sel[d] = 0
            else:
                grid.append(np.log(c) if name == "volume" else c)
        dims = [d for d in da.dims if d not in sel and d != stack]
        vals = np.asarray(da.isel(sel).transpose(*dims, *([stack] if stack else [])).values,
                          float)
        self.const = vals if not grid else None
        if grid:
            nan = ~np.isfinite(vals)
            self.rgi = RegularGridInterpolator(grid, np.where(nan, 0.0, vals))
            self.rgi_nan = (RegularGridInterpolator(grid, nan.astype(float)) if nan.any()
                            else None)

    def __call__(self, points):
        n = np.asarray(next(iter(points.values()))).size
        code = np.full(n, Status.CONVERGED, np.int8)
        xs = []
        for name, c, interpolated in self.axes:
            if name not in points:
                raise ValueError(f"unexpected dimension {name!r}")
            x = np.broadcast_to(np.asarray(points[name], float), (n,))
            tol = 1e-9 * max(1.0, np.max(np.abs(c)))
            code = worst_status(code, np.where((x < c[0] - tol) | (x > c[-1] + tol),
                                               np.int8(Status.APPROXIMATE),
                                               np.int8(Status.CONVERGED)))
            if interpolated:
                x = np.clip(x, c[0], c[-1])
                xs.append(np.log(x) if name == "volume" else x)
        if self.const is not None:
            return np.broadcast_to(self.const, (n,) + self.const.shape).copy(), code
        xs = np.stack(xs, -1)
        out = self.rgi(xs)
        if self.rgi_nan is not None:
            hit = self.rgi_nan(xs) > 0
            code = np.where(hit.any(-1) if self.stack else hit, np.int8(Status.NOT_CONVERGED),
                            code).astype(np.int8)
            out = np.where(hit, np.nan, out)
        return out, code


def default_table():
    """The shipped doublet table, ``data/doublet_table.nc`` of this checkout."""
    return DOUBLET_TABLE


def _open(path, allow_unverified=None):
    from capbridge.tables.netcdf_io import read_table

    return read_table(path, allow_unverified=allow_unverified)


#: Bond numbers of the doublet table's held-out check with gravity (issue 10's values)
GRAVITY_HOLDOUT_BONDS = (0.05, 0.5, 1.0, 2.14, 2.5)


def gravity_holdout_errors(surrogate, n=12, seed=2, bonds=GRAVITY_HOLDOUT_BONDS,
                           exclude_band=0.2, progress=False):
    """Error of the surrogate with gravity along the axis against the exact solver.

    Random points uniform in theta and log V* over the gravity response's sub-grid, in
    s in [``exclude_band``, 1] and over the table's ratios (the i-th point takes ratio
    i mod the number of ratios: ratio 1 and unequal grains both); each at every Bo of
    ``bonds`` with gravity pulling from grain 1 to grain 2 and back
    (:func:`~capbridge.solvers.young_laplace_gravity.solve_doublet_gravity`, the exact
    axisymmetric solution, is the direct solve).  The error of a point is the largest
    over the two grains of |F_surrogate - F_exact| relative to the exact attraction at
    Bo = 0; ``effect`` errors compare the gravity parts only (F(b) - F(0) of each), so
    the table's error without gravity drops out.

    Returns
    -------
    dict
        ``bonds``, per Bo: ``max_error``, ``median_error``, ``max_effect_error``,
        ``max_effect_error_converged`` (points whose lookup status is CONVERGED, i.e.
        whose own estimate ``gravity_error`` is below the tolerance), ``n`` (exact and
        lookup both with a number), ``n_approximate``, ``n_exact_failed`` (lookups left
        out: the exact bridge at that Bo ruptured or its solver failed, or the lookup had
        no number, a cell next to rupture touching a node without a response; a point
        whose zero-gravity solve or lookup failed counts once, not once per direction);
        and ``estimate_ratio_max``, the largest actual effect error over the estimate
        among points with an estimate above 1e-6.  On a table that already carries this
        check, lookups above its validated Bo are APPROXIMATE, so the CONVERGED set
        differs from the one the table was checked with.
    """
    from capbridge.solvers.young_laplace_gravity import solve_doublet_gravity

    ds = surrogate.table_
    rng = np.random.default_rng(seed)
    th_ax, v_ax = np.asarray(ds["gravity_theta"], float), np.asarray(ds["gravity_volume"],
                                                                     float)
    th = rng.uniform(th_ax[0], th_ax[-1], n)
    v = np.exp(rng.uniform(np.log(v_ax[0]), np.log(v_ax[-1]), n))
    s = rng.uniform(exclude_band, 1.0, n)
    ratios = np.asarray(surrogate.ratios_, float)
    R = ratios[np.arange(n) % ratios.size]
    base = surrogate.predict(0.0, v, th, R)
    gap = base["rupture_gap"] * (1.0 - s**2)
    zero = surrogate.predict(gap, v, th, R)
    ex0 = [solve_doublet_gravity(gap[i], v[i], th[i], 0.0, R[i]) for i in range(n)]
    out = {k: [] for k in ("max_error", "median_error", "max_effect_error",
                           "max_effect_error_converged", "n", "n_approximate",
                           "n_exact_failed")}
    ratio_max = 0.0
    xhat = np.array([1.0, 0.0, 0.0])
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(bonds) * n, desc="gravity held-out points", unit="pt")
    for bo in bonds:
        err, eff, eff_ok, n_app, n_fail = [], [], [], 0, 0
        for i in range(n):
            if bar is not None:
                bar.update(1)
            f0 = float(ex0[i]["force"])
            if ex0[i]["status"] != Status.CONVERGED or zero["status"][i] != Status.CONVERGED:
                n_fail += 1
                continue
            for axis in (-1.0, 1.0):
                ex = solve_doublet_gravity(gap[i], v[i], th[i], bo, R[i], gravity_axis=axis)
                r = surrogate.predict_vectors(gap[i], v[i], th[i], R[i], bond=bo,
                                              gravity=(axis, 0.0, 0.0))
                if ex["status"] != Status.CONVERGED:
                    n_fail += 1
                    continue
                if not np.isfinite(r["F1"]).all() or r["status"] == Status.RUPTURED:
                    n_fail += 1
                    continue
                F1x, F2x = float(ex["force1"]) * xhat, -float(ex["force2"]) * xhat
                e = max(np.abs(r["F1"] - F1x).max(), np.abs(r["F2"] - F2x).max()) / f0
                F0s = float(zero["force"][i])
                d1 = (r["F1"] - F0s * xhat) - (F1x - f0 * xhat)
                d2 = (r["F2"] + F0s * xhat) - (F2x + f0 * xhat)
                ee = max(np.abs(d1).max(), np.abs(d2).max()) / f0
                err.append(e)
                eff.append(ee)
                if r["status"] == Status.CONVERGED:
                    eff_ok.append(ee)
                else:
                    n_app += 1
                est = float(r["gravity_error"])
                if est > 1e-6:
                    ratio_max = max(ratio_max, ee / est)
        out["max_error"].append(float(np.max(err)) if err else float("nan"))
        out["median_error"].append(float(np.median(err)) if err else float("nan"))
        out["max_effect_error"].append(float(np.max(eff)) if eff else float("nan"))
        # no converged lookup at this Bo: nothing validated there
        out["max_effect_error_converged"].append(float(np.max(eff_ok)) if eff_ok
                                                 else float("nan"))
        out["n"].append(len(err))
        out["n_approximate"].append(n_app)
        out["n_exact_failed"].append(n_fail)
    if bar is not None:
        bar.close()
    out.update(bonds=[float(b) for b in bonds], estimate_ratio_max=float(ratio_max),
               n_points=int(n), exclude_band=float(exclude_band), seed=int(seed))
    return out


def holdout_errors(surrogate, n=400, seed=0, ratio=1.0, exclude_band=0.0):
    """Relative force error of the surrogate against exact solutions at random points.

    Points are uniform in theta, log V* and s inside the table (s >= exclude_band, i.e.
    a band next to rupture can be left out and is then stated).  Returns a dict with
    the points, both forces and the median and max relative error over the points the
    exact solver converged on.
    """
    from capbridge.solvers.young_laplace import solve_doublet

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
