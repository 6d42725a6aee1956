"""What a capbridge table can prove about itself, checked when it is loaded.

The checksum (:func:`capbridge.tables.netcdf_io.table_checksum`) says whether a file
is the one capbridge wrote; these checks say whether its content is what the generator
guarantees, whatever the checksum (a table allowed without one still goes through
them).  Each check is an invariant of the generator that wrote the table, never a
property the physics merely suggests:

doublet (:mod:`capbridge.tables.doublet`, :mod:`~capbridge.tables.doublet_gravity`)
    units of every variable the code reads; where ``status`` is converged: F*, P*,
    beta1, beta2, neck radius and gap finite, |F*| <= 2 ratio/(1 + ratio) (Derjaguin's
    limit), angles in [0, 180], neck > 0, and the gap on its node
    d* = d*_rupt (1 - s^2) (how the table's s axis is defined); a converged rupture
    distance finite and > 0.  Gravity response where it has a result: every variable
    finite, the transverse share u = 1 - x_c/D in [0, 1] (the liquid's centre of mass
    lies between the centres), for equal grains w = u = 1/2 (mirror symmetry), the
    status converged exactly where the point's own estimate ``response_error`` is
    within ``gravity_response_rtol``, and its F(0) equal to the table's F* at the node
    (the same bridge from two solvers).  Rupture with gravity: > 0 where converged.
triplet (:mod:`capbridge.tables.triplet`, :mod:`~capbridge.tables.triplet_gravity`)
    units; where a point has a result: pair forces, force vectors, P*, E*, force error
    finite (error >= 0); V*_coal > 0 and V* = V*_coal v (how the v axis is defined);
    the pair forces are the least-squares decomposition of the stored force vectors on
    the point's centre lines, with the stored ``pair_residual``; permutation symmetry
    (the cube is the canonical geometries relabelled): pair forces within the points'
    own ``force_error``, status and V*_coal equal; gravity response: finite where it
    has a result and the sum rule (the grains carry the liquid's weight,
    sum_i dF_i/db = V*/(2 pi) I) within the point's own ``gravity_sum_residual``.
coalescence (:mod:`capbridge.tables.coalescence`)
    units; V_coal > 0 wherever it has a number and a number exactly where the status
    is converged; the symmetry of each configuration (pair: d12 <-> d13; ring: every
    permutation); the linear law V0, dV, fit_rms, fit_max refitted from V_coal; the
    held-out errors recomputed from the table and its stored error model
    (``interpolation_error_*``) their summary.

Every refusal is one :class:`~capbridge.tables.netcdf_io.TableError` line naming
the table, the variable and the index, and what to do.
"""
from __future__ import annotations

import itertools
import json

import numpy as np
import xarray as xr

from capbridge.dimensionless import TRIPLET_PAIR_NAMES, TRIPLET_PAIRS

__all__ = ["table_kind", "check_table", "check_doublet", "check_triplet",
           "check_coalescence", "ANGLE_UNITS"]

#: units accepted for an angle (CF: both spellings mean degrees)
ANGLE_UNITS = ("degree", "degrees")
#: round-off allowed where the generator computes a value from others exactly (copies,
#: products, the same least squares): relative to the quantity's own scale
ROUND_OFF = 1e-9
#: equal grains carry exactly half of the weight (mirror symmetry); the computed w is
#: within 5.3e-8 of 1/2 in the shipped table (central differences of the solver)
HALF_SHARE_TOL = 1e-6
#: the gravity solver's F(0) against the table's F* at the same node: 3e-12 measured
#: (relative); both are the exact bridge, solved twice
BOND_ZERO_TOL = 1e-6
#: the sum rule is stored as the largest element of |sum_i G_i - W I| / W in the
#: canonical frame; relabelled points carry it rotated, so it is checked on the
#: frame-independent Frobenius norm, which is at most 3 times the largest element of
#: a 3 x 3 matrix
SUM_RULE_NORM_FACTOR = 3.0


def _error(text):
    from capbridge.tables.netcdf_io import TableError

    return TableError(" ".join(text.split()))


def _regen(kind):
    return (f"the table is damaged or was edited: regenerate it "
            f"(`capbridge generate {kind}`) or use the original file")


def table_kind(ds: xr.Dataset) -> str | None:
    """``"triplet"``, ``"coalescence"``, ``"doublet"`` or None (another table)."""
    if "f12" in ds.variables:
        return "triplet"
    if any(str(n).startswith("V_coal_") for n in ds.data_vars):
        return "coalescence"
    if "force" in ds.variables and "ratio" in ds.dims:
        return "doublet"
    return None


def check_table(ds: xr.Dataset, source="table") -> xr.Dataset:
    """The checks of the table's kind (:func:`table_kind`); other tables pass."""
    kind = table_kind(ds)
    fn = {"doublet": check_doublet, "triplet": check_triplet,
          "coalescence": check_coalescence}.get(kind)
    if fn is not None:
        fn(ds, source)
    return ds


# ------------------------------------------------------------------------------ helpers
def _check_units(ds, source, expected, kind):
    for name in sorted(map(str, ds.variables)):
        want = expected(name)
        if want is None:
            continue
        got = str(ds[name].attrs.get("units", ""))
        ok = got in ANGLE_UNITS if want in ANGLE_UNITS else got == want
        if not ok:
            raise _error(
                f"{source}: {name!r} has units {got!r}, expected {want!r} (capbridge tables "
                f"are dimensionless by the normalising radius and gamma, angles in "
                f"degrees); {_regen(kind)}")


def _first(mask):
    return tuple(int(k) for k in np.argwhere(mask)[0])


def _where(da, idx):
    return ", ".join(f"{d}={_coord(da, d, i)}" for d, i in zip(da.dims, idx))


def _coord(da, d, i):
    try:
        return f"{float(da[d].values[i]):g}"
    except (KeyError, TypeError, ValueError, IndexError):
        return str(i)


def _refuse(ds, source, name, mask, what, kind, values=None):
    """Refuse at the first True of ``mask`` (on ``ds[name]``'s dims), naming it."""
    mask = np.asarray(mask)
    if not mask.any():
        return
    da = ds[name]
    idx = _first(mask)
    v = np.asarray(da.values if values is None else values)[idx]
    n = int(mask.sum())
    raise _error(f"{source}: {name}={v!r} at ({_where(da, idx)}) {what}"
                 f"{f' ({n} such points)' if n > 1 else ''}; {_regen(kind)}")


def _has_result(status):
    from capbridge.status import HAS_RESULT, status_in

    return status_in(status, HAS_RESULT)


def _values(ds, name, dims=None):
    da = ds[name]
    if dims is not None:
        da = da.transpose(*dims, ...)
    return np.asarray(da.values, float)


# ------------------------------------------------------------------------------ doublet
def _doublet_units():
    from capbridge.tables.doublet_gravity import GRAVITY_ATTRS
    from capbridge.tables.doublet import ATTRS

    units = {n: a["units"] for n, a in ATTRS.items()}
    units |= {n: a["units"] for n, a in GRAVITY_ATTRS.items()}
    return units


def check_doublet(ds: xr.Dataset, source="doublet table") -> xr.Dataset:
    """The doublet table's invariants (module docstring); variables that are missing
    are skipped (completeness is :func:`~capbridge.tables.doublet.
    validate_doublet_table`'s)."""
    from capbridge.status import Status

    kind = "doublet"
    units = _doublet_units()
    _check_units(ds, source, lambda n: units.get(n), kind)
    dims = ("ratio", "theta", "volume", "s")
    if "status" in ds and all(d in ds["status"].dims for d in dims):
        ok = ds["status"].transpose(*dims).values == Status.CONVERGED
        fields = [n for n in ("force", "pressure", "beta1", "beta2", "neck_radius", "gap")
                  if n in ds and set(ds[n].dims) == set(dims)]
        vals = {n: _values(ds, n, dims) for n in fields}
        for n in fields:
            _refuse(ds.transpose(*dims, ...), source, n, ok & ~np.isfinite(vals[n]),
                    "is not a number where status is converged", kind, vals[n])
        sub = ds.transpose(*dims, ...)
        if "force" in vals and "ratio" in ds.coords:
            ratio = np.asarray(ds["ratio"].values, float).reshape(-1, 1, 1, 1)
            limit = 2 * ratio / (1 + ratio) * (1 + 1e-6)
            _refuse(sub, source, "force", ok & ~(np.abs(vals["force"]) <= limit),
                    "exceeds |F*| <= 2 ratio/(1 + ratio) (Derjaguin's limit, the largest "
                    "force of a bridge) at a converged point", kind, vals["force"])
        for n in ("beta1", "beta2"):
            if n in vals:
                b = vals[n]
                _refuse(sub, source, n, ok & ~((b >= 0) & (b <= 180)),
                        "is outside [0, 180] deg at a converged point", kind, b)
        if "neck_radius" in vals:
            _refuse(sub, source, "neck_radius", ok & ~(vals["neck_radius"] > 0),
                    "is not positive at a converged point", kind, vals["neck_radius"])
        if "gap" in vals and "rupture_gap" in ds and "s" in ds.coords:
            d_r = _values(ds, "rupture_gap", dims[:3])[..., None]
            s = np.asarray(ds["s"].values, float)
            want = d_r * (1.0 - s ** 2)
            bad = ok & ~(np.abs(vals["gap"] - want) <= ROUND_OFF * np.abs(d_r) + 1e-300)
            _refuse(sub, source, "gap", bad, "is not d*_rupt (1 - s^2) of its node (the "
                    "definition of the s axis)", kind, vals["gap"])
    if "rupture_gap" in ds and "rupture_status" in ds:
        rdims = ds["rupture_gap"].dims
        rok = ds["rupture_status"].transpose(*rdims).values == Status.CONVERGED
        d_r = np.asarray(ds["rupture_gap"].values, float)
        _refuse(ds, source, "rupture_gap", rok & ~(np.isfinite(d_r) & (d_r > 0)),
                "is not a positive number where rupture_status is converged", kind)
        if "rupture_force" in ds and ds["rupture_force"].dims == rdims:
            _refuse(ds, source, "rupture_force",
                    rok & ~np.isfinite(ds["rupture_force"].values),
                    "is not a number where rupture_status is converged", kind)
    _check_doublet_gravity(ds, source)
    return ds


def _check_doublet_gravity(ds, source):
    from capbridge.status import Status

    kind = "doublet"
    names = ("weight_share_axial", "force_gravity_curvature_axial",
             "weight_share_transverse", "force_bond_zero", "response_error")
    if "gravity_status" not in ds:
        return
    gdims = ds["gravity_status"].dims
    st = ds["gravity_status"].values
    has = _has_result(st)
    present = [n for n in names if n in ds and ds[n].dims == gdims]
    for n in present:
        _refuse(ds, source, n, has & ~np.isfinite(ds[n].values),
                "is not a number where gravity_status has a result", kind)
    if "weight_share_transverse" in present:
        u = ds["weight_share_transverse"].values
        _refuse(ds, source, "weight_share_transverse", has & ~((u >= 0) & (u <= 1)),
                "is outside [0, 1]: the share u = 1 - x_c/D of the transverse weight (the "
                "liquid's centre of mass lies between the centres)", kind)
    if "ratio" in gdims:
        equal = np.isclose(ds["ratio"].values, 1.0, rtol=0, atol=1e-12)
        shape = [1] * len(gdims)
        shape[gdims.index("ratio")] = -1
        equal = np.broadcast_to(equal.reshape(shape), st.shape)
        for n in ("weight_share_axial", "weight_share_transverse"):
            if n in present:
                x = ds[n].values
                _refuse(ds, source, n, has & equal & ~(np.abs(x - 0.5) <= HALF_SHARE_TOL),
                        f"is not 1/2 for equal grains (mirror symmetry; tolerance "
                        f"{HALF_SHARE_TOL:g})", kind)
    rtol = ds.attrs.get("gravity_response_rtol")
    if "response_error" in present and rtol is not None:
        try:
            rtol = float(rtol)
        except (TypeError, ValueError):
            raise _error(f"{source}: global attribute gravity_response_rtol={rtol!r} is "
                         f"not a number; {_regen(kind)}") from None
        e = ds["response_error"].values
        _refuse(ds, source, "gravity_status", (st == Status.CONVERGED) & ~(e <= rtol),
                f"is converged where the point's own error estimate response_error is above "
                f"gravity_response_rtol={rtol:g}", kind)
        _refuse(ds, source, "gravity_status", (st == Status.ABOVE_TOLERANCE) & ~(e > rtol),
                f"is above_tolerance where response_error is within "
                f"gravity_response_rtol={rtol:g}", kind)
    if "force_bond_zero" in present and "force" in ds and \
            all(d in ds.coords for d in ("gravity_theta", "gravity_volume", "gravity_s")):
        sub = _doublet_nodes(ds)
        if sub is not None:
            f0 = ds["force_bond_zero"].values
            bad = has & ~(np.abs(f0 - sub) <= BOND_ZERO_TOL * np.maximum(1.0, np.abs(sub)))
            _refuse(ds, source, "force_bond_zero", bad,
                    f"differs from the table's force at the same node by more than "
                    f"{BOND_ZERO_TOL:g} (the same bridge from two solvers)", kind)
    if "rupture_gap_gravity" in ds and "rupture_gravity_status" in ds:
        rg = ds["rupture_gap_gravity"].values
        ok = ds["rupture_gravity_status"].transpose(*ds["rupture_gap_gravity"].dims).values \
            == Status.CONVERGED
        _refuse(ds, source, "rupture_gap_gravity", ok & ~(np.isfinite(rg) & (rg > 0)),
                "is not a positive number where rupture_gravity_status is converged", kind)


def _doublet_nodes(ds):
    """The table's force on the gravity sub-grid's nodes, in the layout of
    ``force_bond_zero`` (None when the sub-grid's nodes are not nodes of the table)."""
    out = ds["force"]
    for d, g in (("theta", "gravity_theta"), ("volume", "gravity_volume"), ("s", "gravity_s")):
        axis = np.asarray(ds[d].values, float)
        want = np.asarray(ds[g].values, float)
        idx = np.array([int(np.argmin(np.abs(axis - w))) for w in want])
        if idx.size == 0 or not np.allclose(axis[idx], want, rtol=1e-12, atol=1e-15):
            return None
        out = out.isel({d: idx}).rename({d: g}).assign_coords({g: want})
    return np.asarray(out.transpose(*ds["force_bond_zero"].dims).values, float)


# ------------------------------------------------------------------------------ triplet
PAIRS, PAIR_NAMES = TRIPLET_PAIRS, TRIPLET_PAIR_NAMES
_TDIMS = ("d12", "d13", "d23", "theta", "v")


def _triplet_units():
    from capbridge.tables.triplet import ATTRS, GRAVITY_ATTRS

    units = {n: a["units"] for n, a in ATTRS.items()}
    units |= {n: a["units"] for n, a in GRAVITY_ATTRS.items()}

    def expected(name):
        if name in units:
            return units[name]
        for prefix in ("holdout_", "gravity_holdout_"):
            if name.startswith(prefix) and name[len(prefix):] in units:
                return units[name[len(prefix):]]
        if name in ("gravity_v", "gravity_component", "holdout", "gravity_holdout"):
            return "1"
        return None
    return expected


def check_triplet(ds: xr.Dataset, source="triplet table") -> xr.Dataset:
    """The triplet table's invariants (module docstring); skipped where the table lacks
    the variables (its completeness is the surrogate's check)."""
    kind = "triplet"
    _check_units(ds, source, _triplet_units(), kind)
    need = PAIR_NAMES + ("status",)
    if not all(n in ds and set(ds[n].dims) == set(_TDIMS) for n in need):
        return ds
    sub = ds.transpose(*_TDIMS, ...)
    has = _has_result(sub["status"].values)
    for n in PAIR_NAMES + ("pressure", "energy_extrapolated", "force_error"):
        if n in sub and sub[n].dims == _TDIMS:
            _refuse(sub, source, n, has & ~np.isfinite(sub[n].values),
                    "is not a number where status has a result", kind)
    if "force_error" in sub and sub["force_error"].dims == _TDIMS:
        _refuse(sub, source, "force_error", has & ~(sub["force_error"].values >= 0),
                "is negative: an error estimate is >= 0", kind)
    F = None
    if "force" in sub and sub["force"].dims == _TDIMS + ("grain", "component"):
        F = np.asarray(sub["force"].values, float)
        bad = has[..., None, None] & ~np.isfinite(F)
        _refuse(sub, source, "force", bad.any((-1, -2)),
                "is not a number where status has a result", kind, F[..., 0, 0])
    if "volume_coalescence" in sub and sub["volume_coalescence"].dims == _TDIMS[:4]:
        vc = np.asarray(sub["volume_coalescence"].values, float)
        _refuse(sub, source, "volume_coalescence", np.isfinite(vc) & ~(vc > 0),
                "is not positive: a coalescence volume is > 0", kind)
        _refuse(sub, source, "volume_coalescence", has.any(-1) & ~np.isfinite(vc),
                "is not a number where points have a result", kind)
        if "volume" in sub and sub["volume"].dims == _TDIMS:
            vol = np.asarray(sub["volume"].values, float)
            want = vc[..., None] * np.asarray(sub["v"].values, float)
            fin = np.isfinite(want)
            bad = fin & ~(np.abs(vol - want) <= ROUND_OFF * np.abs(want))
            _refuse(sub, source, "volume", bad, "is not V*_coal v of its node (the "
                    "definition of the v axis)", kind)
    fv = np.stack([np.asarray(sub[n].values, float) for n in PAIR_NAMES])
    if F is not None:
        _check_pair_decomposition(sub, source, F, fv, has)
    _check_permutations(sub, source, fv, has)
    _check_triplet_gravity(ds, source)
    return ds


def _centres(g):
    from capbridge.solvers.triplet import triplet_geometry

    try:
        return triplet_geometry(*g).centres
    except Exception:          # not a triangle: nothing to check there
        return None


def _check_pair_decomposition(sub, source, F, fv, has):
    """f_ij = least squares of sum_j f_ij u_ij = F_i (capbridge.solvers.triplet.
    pair_forces) at every point with a result, and its residual."""
    kind = "triplet"
    gaps = [np.asarray(sub[d].values, float) for d in _TDIMS[:3]]
    resid = np.asarray(sub["pair_residual"].values, float) \
        if "pair_residual" in sub and sub["pair_residual"].dims == _TDIMS else None
    for a, b, c in itertools.product(*(range(g.size) for g in gaps)):
        h = has[a, b, c]
        if not h.any():
            continue
        C = _centres((gaps[0][a], gaps[1][b], gaps[2][c]))
        if C is None:
            continue
        A = np.zeros((9, 3))
        for m, (i, j) in enumerate(PAIRS):
            u = (C[j] - C[i]) / np.linalg.norm(C[j] - C[i])
            A[3 * i:3 * i + 3, m] = u
            A[3 * j:3 * j + 3, m] = -u
        Fp = F[a, b, c][h].reshape(-1, 9)                       # (n, 9)
        f = np.linalg.lstsq(A, Fp.T, rcond=None)[0].T           # (n, 3)
        scale = np.maximum(np.linalg.norm(F[a, b, c][h], axis=-1).max(-1), 1e-300)
        stored = fv[:, a, b, c][:, h].T                         # (n, 3)
        err = np.abs(f - stored).max(-1) / scale
        if np.any(err > ROUND_OFF):
            k = int(np.argmax(err))
            m = int(np.argmax(np.abs(f[k] - stored[k])))
            mask = np.zeros(has.shape, bool)
            idx = np.argwhere(h)[k]
            mask[(a, b, c) + tuple(idx)] = True
            _refuse(sub, source, PAIR_NAMES[m], mask,
                    f"is not the pair force of the stored force vectors (least squares on "
                    f"the centre lines gives {f[k, m]:.6g})", kind)
        if resid is not None:
            r = np.linalg.norm(f @ A.T - Fp, axis=-1) / scale
            bad = ~(np.abs(r - resid[a, b, c][h]) <= ROUND_OFF)
            if bad.any():
                mask = np.zeros(has.shape, bool)
                mask[(a, b, c) + tuple(np.argwhere(h)[int(np.argmax(bad))])] = True
                _refuse(sub, source, "pair_residual", mask,
                        "is not the residual of the stored forces' pair decomposition",
                        kind)


def _check_permutations(sub, source, fv, has):
    """The cube is the canonical geometries relabelled: relabelling the grains maps
    the table onto itself."""
    kind = "triplet"
    gaps = [np.asarray(sub[d].values, float) for d in _TDIMS[:3]]
    n = gaps[0].size
    if not (gaps[1].size == n and gaps[2].size == n and np.array_equal(gaps[0], gaps[1])
            and np.array_equal(gaps[0], gaps[2])):
        return
    old = np.meshgrid(*(np.arange(n),) * 3, indexing="ij")        # gap index per pair
    ferr = np.asarray(sub["force_error"].values, float) if "force_error" in sub \
        and sub["force_error"].dims == _TDIMS else np.zeros(has.shape)
    ferr = np.where(np.isfinite(ferr), ferr, 0.0)
    st = np.asarray(sub["status"].values)
    vc = np.asarray(sub["volume_coalescence"].values, float) \
        if "volume_coalescence" in sub and sub["volume_coalescence"].dims == _TDIMS[:4] \
        else None
    for perm in itertools.permutations(range(3)):
        if perm == (0, 1, 2):
            continue
        # new grain i is old grain perm[i]: the new pair m is the old pair P[m]
        P = [PAIRS.index(tuple(sorted((perm[i], perm[j])))) for i, j in PAIRS]
        new = tuple(old[P[m]] for m in range(3))
        for m in range(3):
            a = fv[m][new]                                 # new point's f_m
            b = fv[P[m]]                                   # old point's f_P[m]
            tol = np.maximum(ferr[new], ferr) + 1e-12
            both = has & has[new]
            bad = both & ~(np.abs(a - b) <= tol)
            if bad.any():
                idx = _first(bad)
                ni = tuple(int(x[idx[:3]]) for x in new) + idx[3:]
                mask = np.zeros(has.shape, bool)
                mask[ni] = True
                _refuse(sub, source, PAIR_NAMES[m], mask,
                        f"breaks the permutation symmetry: the same triplet relabelled has "
                        f"{b[idx]:.6g} (difference {abs(a[idx] - b[idx]):.3g} above the "
                        f"points' force_error {tol[idx]:.3g})", kind)
        bad = st[new] != st
        _refuse(sub, source, "status", bad, "breaks the permutation symmetry (the "
                "relabelled triplet has another status)", kind)
        if vc is not None:
            x, y = vc[new], vc
            bad = ~((np.isnan(x) & np.isnan(y)) | (np.abs(x - y) <= ROUND_OFF * np.abs(y)))
            _refuse(sub, source, "volume_coalescence", bad, "breaks the permutation "
                    "symmetry (the relabelled triplet has another V*_coal)", kind)


def _check_triplet_gravity(ds, source):
    kind = "triplet"
    names = ("force_gravity_gradient", "force_gravity_curvature", "gravity_sum_residual",
             "gravity_status")
    if not all(n in ds for n in names):
        return
    gd = _TDIMS[:4] + ("gravity_v",)
    tdims = gd + ("grain", "component", "gravity_component")
    if set(ds["force_gravity_gradient"].dims) != set(tdims) or \
            set(ds["gravity_status"].dims) != set(gd):
        return
    sub = ds.transpose(*tdims, ...)
    has = _has_result(sub["gravity_status"].transpose(*gd).values)
    G = np.asarray(sub["force_gravity_gradient"].values, float)
    C = np.asarray(sub["force_gravity_curvature"].transpose(*tdims).values, float)
    res = np.asarray(sub["gravity_sum_residual"].transpose(*gd).values, float)
    gsub = ds.transpose(*gd, ...)
    for n, x in (("force_gravity_gradient", G), ("force_gravity_curvature", C)):
        _refuse(gsub, source, "gravity_status", has & ~np.isfinite(x).all((-1, -2, -3)),
                f"has a result where {n} is not a number", kind)
    _refuse(gsub, source, "gravity_sum_residual", has & ~(np.isfinite(res) & (res >= 0)),
            "is not a number >= 0 where gravity_status has a result", kind)
    if "volume_coalescence" not in ds:
        return
    vc = np.asarray(ds["volume_coalescence"].transpose(*_TDIMS[:4]).values, float)
    W = vc[..., None] * np.asarray(ds["gravity_v"].values, float) / (2 * np.pi)
    M = G.sum(axis=-3) - W[..., None, None] * np.eye(3)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.linalg.norm(M, axis=(-2, -1)) / W
        carried = np.trace(G.sum(axis=-3), axis1=-2, axis2=-1) / (3 * W)
    bad = has & np.isfinite(W) & ~(rel <= SUM_RULE_NORM_FACTOR * res + ROUND_OFF)
    if bad.any():
        idx = _first(bad)
        raise _error(
            f"{source}: force_gravity_gradient at ({_where(gsub['gravity_status'], idx)}) "
            f"breaks the sum rule: the grains' responses carry {carried[idx]:.4g} times "
            f"the liquid's weight V*/(2 pi) (relative residual {rel[idx]:.3g}, the "
            f"point's stored gravity_sum_residual {res[idx]:.3g})"
            f"{f' ({int(bad.sum())} such points)' if bad.sum() > 1 else ''}; "
            f"{_regen(kind)}")


# -------------------------------------------------------------------------- coalescence
def _coalescence_units():
    from capbridge.tables.coalescence import COALESCENCE_ATTRS

    def expected(name):
        if name in ("d12", "d13", "d23", "theta"):
            return COALESCENCE_ATTRS[name]["units"]
        for c in ("pair", "ring"):
            if name in (f"V_coal_{c}", f"V0_{c}", f"dV_{c}", f"fit_rms_{c}",
                        f"fit_max_{c}"):
                return "1"
            hd = f"heldout_{c}"
            if name == f"{hd}_theta":
                return COALESCENCE_ATTRS["theta"]["units"]
            if name.startswith(f"{hd}_") and not name.endswith("_status"):
                return "1"
        return None
    return expected


def check_coalescence(ds: xr.Dataset, source="coalescence table") -> xr.Dataset:
    """The coalescence table's invariants (module docstring)."""
    from capbridge.status import Status

    kind = "coalescence"
    _check_units(ds, source, _coalescence_units(), kind)
    dims4 = ("d12", "d13", "d23", "theta")
    for c in ("pair", "ring"):
        name = f"V_coal_{c}"
        if name not in ds or set(ds[name].dims) != set(dims4):
            continue
        sub = ds.transpose(*dims4, ...)
        V = np.asarray(sub[name].values, float)
        _refuse(sub, source, name, np.isfinite(V) & ~(V > 0),
                "is not positive: a coalescence volume is > 0", kind)
        st = None
        if f"status_{c}" in sub:
            st = np.asarray(sub[f"status_{c}"].transpose(*dims4).values)
            ok = st == Status.CONVERGED
            _refuse(sub, source, name, ok & ~np.isfinite(V),
                    f"is not a number where status_{c} is converged", kind)
            _refuse(sub, source, name, ~ok & np.isfinite(V),
                    f"is a number where status_{c} says no coalescence was found", kind)
        n = V.shape[0]
        if V.shape[:3] == (n, n, n):
            perms = [(1, 0, 2)] if c == "pair" else \
                [p for p in itertools.permutations(range(3)) if p != (0, 1, 2)]
            for p in perms:
                W = np.transpose(V, p + (3,))
                bad = ~((np.isnan(W) & np.isnan(V)) | (np.abs(W - V) <= ROUND_OFF * np.abs(V)))
                what = "d12 <-> d13 (the two bridges on grain 1)" if c == "pair" else \
                    "every permutation of the gaps (the closed ring)"
                _refuse(sub, source, name, bad, f"breaks the symmetry under {what}", kind)
        _check_linear_law(sub, source, c, V, st)
        _check_heldout(ds, source, c)
    return ds


def _check_linear_law(sub, source, c, V, st):
    from capbridge.tables.coalescence import fit_rows
    from capbridge.status import Status

    kind = "coalescence"
    names = [f"{k}_{c}" for k in ("V0", "dV", "fit_rms", "fit_max")]
    if not all(n in sub and set(sub[n].dims) == {"d12", "d13", "d23"} for n in names):
        return
    theta = np.asarray(sub["theta"].values, float)
    status = st if st is not None else np.where(np.isfinite(V), Status.CONVERGED,
                                                Status.NOT_CONVERGED)
    flat_V = V.reshape(-1, theta.size)
    flat_st = np.asarray(status).reshape(-1, theta.size)
    try:
        rows = fit_rows(theta, np.where(np.isfinite(flat_V), flat_V, 1.0), flat_st)
    except Exception:            # a non-positive or odd V_coal: refused above
        return
    scale = np.nanmax(np.abs(V)) if np.isfinite(V).any() else 1.0
    for name, row in zip(names, rows):
        stored = np.asarray(sub[name].transpose("d12", "d13", "d23").values, float)
        want = row.reshape(stored.shape)
        bad = ~((np.isnan(want) & np.isnan(stored))
                | (np.abs(stored - want) <= ROUND_OFF * scale))
        _refuse(sub, source, name, bad, f"is not the least-squares line of V_coal_{c} "
                f"over theta (refitted: {want[_first(bad)] if bad.any() else 0:.6g})", kind,
                stored)


def _check_heldout(ds, source, c):
    """The held-out errors recomputed from the table, and the stored error model."""
    from capbridge.tables.coalescence import (error_summary, fit_errors,
                                                         interpolation_errors)

    kind = "coalescence"
    hd = f"heldout_{c}"
    pts_names = [f"{hd}_{d}" for d in ("d12", "d13", "d23", "theta")]
    if not all(n in ds for n in pts_names + [f"{hd}_V_coal"]):
        return
    pts = np.stack([np.asarray(ds[n].values, float) for n in pts_names])
    Vh = np.asarray(ds[f"{hd}_V_coal"].values, float)
    errs = {}
    for method in ("linear", "cubic", "fit"):
        name = f"{hd}_error_{method}"
        if name not in ds:
            continue
        try:
            with np.errstate(invalid="ignore", divide="ignore"):
                e = fit_errors(ds, c, pts, Vh) if method == "fit" else \
                    interpolation_errors(ds, c, pts, Vh, method)
        except Exception as exc:      # points outside the grid, too few nodes: damaged
            raise _error(f"{source}: {hd} cannot be checked against the table "
                         f"({type(exc).__name__}: {exc}); {_regen(kind)}") from None
        stored = np.asarray(ds[name].values, float)
        bad = ~((np.isnan(e) & np.isnan(stored)) | (np.abs(e - stored) <= ROUND_OFF))
        _refuse(ds, source, name, bad, f"is not the error of the table's {method} "
                f"{'law' if method == 'fit' else 'interpolation'} at the held-out point", kind)
        errs["linear_law" if method == "fit" else method] = error_summary(stored)
    attr = f"interpolation_error_{c}"
    if attr not in ds.attrs or not errs:
        return
    try:
        model = json.loads(str(ds.attrs[attr]))
    except ValueError:
        raise _error(f"{source}: global attribute {attr} is not JSON; {_regen(kind)}") \
            from None
    for method, summary in errs.items():
        got = model.get(method) if isinstance(model, dict) else None
        for key, want in summary.items():
            x = None if not isinstance(got, dict) else got.get(key)
            same = isinstance(x, (int, float)) and (
                (np.isnan(want) and np.isnan(x)) or abs(x - want) <= ROUND_OFF * max(1, abs(want)))
            if not same:
                raise _error(
                    f"{source}: global attribute {attr} says {method} {key} = {x!r}, but the "
                    f"table's held-out errors give {want:.6g}; {_regen(kind)}")
