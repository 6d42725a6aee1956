"""Exact axisymmetric liquid bridge between a sphere and a flat wall (Young-Laplace).

Geometry and conventions
------------------------
A sphere of radius R (the normalising radius) is centred at x = 0; the wall is the
plane x = 1 + d* perpendicular to the axis.  Dimensionless as everywhere in capbridge
(:mod:`capbridge.dimensionless`, with R the sphere's radius):

    d* = d / R,  V* = V / R^3,  F* = F / (2 pi gamma R),  P* = dp R / gamma,
    E* = E / (gamma R^2),

attraction positive, angles in degrees: ``theta_s`` on the sphere, ``theta_w`` on the
wall.  The sphere's contact line sits at half filling angle ``beta1``; the wall's
wetted disc has radius ``wall_radius`` (in units of R).

The plane is the limit R2/R1 -> infinity of the doublet
----------------------------------------------------------
The meridian is the same Delaunay roulette as between two spheres, and the solver is
the doublet one (:mod:`capbridge.solvers.young_laplace`: Kenmotsu arc-length chart
(h, beta1, L), vectorised damped Newton, stability determinant, family walk and rupture
search), applied to a "second sphere" of radius ``WALL_RADIUS`` = 1e100.  Every term
that the second sphere contributes differs from the plane's by O(1/R2) and is either
exactly the plane's value or below 1e-99 (far under round-off):

* its contact-line angle beta2 = asin(a / R2) ~ 1e-100 a: Young's condition there is
  psi = pi/2 - theta_w, the plane's;
* its cap height a^2 / (2 R2) ~ 1e-100 (gap measured from the plane x = 1 + d*);
* its cap volume pi a^4 / (4 R2) underflows to exactly 0;
* its wetted area 4 pi R2^2 sin^2(beta2/2) = pi a^2 (the wetted disc) to round-off,
  so the energy E* = A - cos(theta_s) A_s - cos(theta_w) pi a^2 is the plane's;
* no term overflows (R2^3 = 1e300 < 1.8e308).

Only the starting point differs (the doublet's toroidal guess loses every digit of the
gap in 1 + R2 + d*): here it is the closed-form circular meridian from the sphere to
the plane (:func:`_wall_circle`).  Rupture is the fold of d* along the fixed-volume
family (a sphere and a plane have no mirror symmetry, so no symmetry-breaking mode).

Checks (tests/test_sphere_wall.py): F* -> cos(theta_s) + cos(theta_w) as V*, d* -> 0
(F -> 4 pi gamma R cos(theta) for equal angles); for theta_w = 90 deg the wall is the
mirror plane of a symmetric doublet, F*_wall(d*, V*) = F*_doublet(2 d*, 2 V*) exactly;
the doublet at R2/R1 = 1e3 and 1e4 tends to the wall as 1/R2; virtual work
F* = (dE*/dd*)/(2 pi) at fixed volume; rupture against Lian et al. (1993).

References
----------
Kenmotsu (1980), Tohoku Math. J. 32:147 (Delaunay surfaces in arc length);
Lian, Thornton, Adams (1993), J. Colloid Interface Sci. 161:138 (rupture distance);
Israelachvili, Intermolecular and Surface Forces (3rd ed.), section 17.5 (sphere-flat
capillary force 4 pi gamma R cos(theta) at contact, small volumes).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from capbridge.dimensionless import cap_height, cap_volume
from capbridge.solvers import young_laplace as yl
from capbridge.status import Status, cf_flag_attributes
from capbridge.validation import CapbridgeInputError, check_range

#: radius of the sphere that stands for the wall (terms of order 1/WALL_RADIUS vanish)
WALL_RADIUS = 1e100
THETA_WALL_MAX_DEG = 90.0

__all__ = ["WALL_RADIUS", "default_s_axis", "solve_sphere_wall",
           "sphere_wall_rupture_distance", "sphere_wall_table", "wall_shape"]

OUTPUTS = ("force", "pressure", "beta1", "wall_radius", "neck_radius")

ATTRS = {
    "theta_s": dict(units="degree", long_name="contact angle on the sphere"),
    "theta_w": dict(units="degree", long_name="contact angle on the wall"),
    "volume": dict(units="1", long_name="liquid bridge volume V* = V/R^3 (R the sphere's radius)"),
    "s": dict(units="1", long_name="gap coordinate s = sqrt(1 - d*/d*_rupt) (1 contact, 0 rupture)"),
    "gap": dict(units="1", long_name="gap between the sphere surface and the wall d* = d/R"),
    "force": dict(units="1", long_name="capillary force on the sphere towards the wall "
                                       "F* = F/(2 pi gamma R), attraction > 0"),
    "pressure": dict(units="1", long_name="capillary pressure P* = (p_liquid - p_gas) R/gamma"),
    "beta1": dict(units="degree", long_name="half filling angle on the sphere"),
    "wall_radius": dict(units="1", long_name="radius of the wetted disc on the wall / R"),
    "neck_radius": dict(units="1", long_name="smallest radius of the bridge / R"),
    "rupture_gap": dict(units="1", long_name="rupture distance d*_rupt (end of the stable branch)"),
    "rupture_force": dict(units="1", long_name="force F* at rupture"),
}


# --------------------------------------------------------------------------------------
# Input checks and points
# --------------------------------------------------------------------------------------


def _check_angles(theta_s, theta_w):
    ts = check_range("theta_s", theta_s, 0.0, yl.THETA_MAX_DEG, high_open=True, units=" deg",
                     hint="the contact angle on the sphere is supported in [0, 90) degrees")
    tw = ts if theta_w is None else check_range(
        "theta_w", theta_w, 0.0, THETA_WALL_MAX_DEG, units=" deg",
        hint="the contact angle on the wall is supported in [0, 90] degrees")
    return ts, tw


def _check_gap(gap):
    return check_range("gap d*", gap, 0.0, np.inf,
                       hint="d* is the gap between the sphere surface and the wall; "
                            "a sphere overlapping the wall is not supported")


def _make_points(arrays, theta_s, theta_w):
    """Flattened inputs as the doublet solver's points, the wall as a sphere of radius
    WALL_RADIUS.  Returns (values, points, shape)."""
    vals, pts, shape = yl._make_points(arrays, theta_s, 1.0, theta_w)
    pts.ratio = np.full(pts.size, WALL_RADIUS)
    return vals, pts, shape


# --------------------------------------------------------------------------------------
# Profile and starting points
# --------------------------------------------------------------------------------------


def wall_shape(h, beta1, length, theta_s, theta_w, nodes=yl.DEFAULT_NODES):
    """Gap, volume, force and shape of the bridge anchored on the sphere, ending on the wall.

    Parameters (radians / dimensionless, broadcast together): mean curvature ``h``
    (= P*/2), half filling angle ``beta1`` on the sphere, arc length ``length`` of the
    meridian from the sphere to the wall, contact angles [rad].  The profile is an
    equilibrium when ``angle`` (misfit of Young's angle on the wall, rad) is zero.
    Returns the dict of :func:`capbridge.solvers.young_laplace.bridge_shape` plus
    ``wall_radius`` (radius of the wetted disc / R).
    """
    out = yl.bridge_shape(h, beta1, length, theta_s, theta_w, WALL_RADIUS, nodes)
    out["wall_radius"] = out["ye"]
    return out


def _circle_volume(rho, cy, psi):
    """pi * integral of y^2 dx along the circular meridian x = cx + rho sin(psi),
    y = cy - rho cos(psi), up to psi (an antiderivative)."""
    s = np.sin(psi)
    return np.pi * rho * (cy * cy * s - cy * rho * (psi + s * np.cos(psi))
                          + rho * rho * (s - s**3 / 3.0))


def _wall_circle(beta1, gap, theta_s, theta_w):
    """Bridge with a circular meridian meeting the sphere at theta_s and the wall at theta_w.

    Closed form (arguments broadcast, angles in rad): the circle leaves the contact line
    (cos b1, sin b1) with Young's slope psi1 = b1 + theta_s - pi/2 and reaches the plane
    x = 1 + d* with slope psi_w = pi/2 - theta_w, so its signed radius is

        rho = (d* + 1 - cos b1) / (cos theta_w + cos(b1 + theta_s)).

    Returns (volume, h, L, ok): h is the mean curvature at the arc's midpoint and L its
    arc length (a starting point for Newton, not a solution).
    """
    b1 = np.asarray(beta1, float)
    cb, sb = np.cos(b1), np.sin(b1)
    psi1 = b1 + theta_s - 0.5 * np.pi
    psi_w = 0.5 * np.pi - theta_w
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        rho = (gap + cap_height(1.0, b1)) / (np.cos(theta_w) + np.cos(b1 + theta_s))
        cx = cb - rho * np.sin(psi1)
        cy = sb + rho * np.cos(psi1)
        L = (psi_w - psi1) * rho
        lo, hi = np.minimum(psi1, psi_w), np.maximum(psi1, psi_w)
        y_ext = np.where((lo < 0) & (hi > 0), cy - rho, np.inf)
        y_w = cy - rho * np.cos(psi_w)
        ymin = np.minimum(np.minimum(sb, y_w), y_ext)
        vol = _circle_volume(rho, cy, psi_w) - _circle_volume(rho, cy, psi1) - cap_volume(1.0, b1)
        pm = 0.5 * (psi1 + psi_w)
        h = 0.5 * (np.cos(pm) / (cy - rho * np.cos(pm)) - 1.0 / rho)
    ok = (np.isfinite(rho) & (np.abs(rho) < 1e6) & np.isfinite(vol) & (L > 0) & (ymin > 0)
          & np.isfinite(h) & np.isfinite(cx))
    return vol, h, L, ok


_GRID = np.concatenate([np.geomspace(1e-3, 0.04, 16), np.linspace(0.05, 1.0, 56)])


def _wall_guess(pts):
    """Starting (h, beta1, L): the circular-meridian bridge holding the volume at the gap
    (the smallest beta1 that does; volume ~ beta1^4 for small bridges, so log-log
    interpolation between grid angles)."""
    col = lambda a: np.asarray(a, float)[:, None]  # noqa: E731
    bmax = np.minimum(yl._BETA1_MAX - 0.02, np.pi - pts.theta1 - 0.2)
    beta = bmax[:, None] * _GRID
    vol, _, _, ok = _wall_circle(beta, col(pts.gap), col(pts.theta1), col(pts.theta2))
    v = np.where(ok & (vol > 0), vol, -np.inf)
    above = v >= pts.volume[:, None]
    k = np.where(above.any(1), np.argmax(above, axis=1), beta.shape[1] - 1)
    k = np.clip(k - 1, 0, beta.shape[1] - 2)
    rows = np.arange(k.size)
    v0, v1 = v[rows, k], v[rows, k + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(np.isfinite(v0) & (v1 > v0) & (v0 > 0),
                     np.log(pts.volume / v0) / np.log(v1 / v0), 1.0)
    f = np.clip(np.nan_to_num(f, nan=1.0), 0.0, 1.0)
    b = beta[rows, k] * (beta[rows, k + 1] / beta[rows, k]) ** f
    _, h, L, okb = _wall_circle(b, pts.gap, pts.theta1, pts.theta2)
    bad = ~okb
    return np.vstack([np.where(bad, 0.0, h), b, np.where(bad, 0.1, L)])


# --------------------------------------------------------------------------------------
# Solvers
# --------------------------------------------------------------------------------------


def _contact_state(pts, settings, n_continuation=8):
    """Equilibrium at contact (d* = 0), the widest bridge of the fixed-volume family.

    Newton from the circular meridian; points that fail are reached by raising the
    contact angles step by step from min(theta, 30 deg) (as the doublet solver does).
    Returns (x, stable).
    """
    p0 = yl._Points(pts.theta1, pts.theta2, pts.ratio, gap=np.zeros(pts.size),
                    volume=pts.volume)
    x, ok, _, stable = yl._Problem(p0, False, settings, False).solve(_wall_guess(p0))
    bad = np.flatnonzero(~(ok & stable))
    if bad.size:
        pb = p0.take(bad)
        start = np.radians(30.0)
        xb = None
        for f in np.linspace(0.0, 1.0, n_continuation):
            pc = yl._Points(np.minimum(pb.theta1, start) + f * np.maximum(pb.theta1 - start, 0),
                            np.minimum(pb.theta2, start) + f * np.maximum(pb.theta2 - start, 0),
                            pb.ratio, gap=pb.gap, volume=pb.volume)
            xb = _wall_guess(pc) if xb is None else xb
            xn, okb, _, stb = yl._Problem(pc, False, settings, False).solve(xb)
            xb = np.where(okb & stb, xn, xb)
        x[:, bad[okb & stb]] = xb[:, okb & stb]
        stable[bad] = okb & stb
    return x, stable & np.isfinite(x).all(axis=0)


def _finish(out, shape):
    """The doublet result arrays as sphere-wall results: beta2 (~1e-98 deg) becomes the
    radius of the wetted disc on the wall, asin(beta2) * WALL_RADIUS."""
    beta2 = out.pop("beta2")
    out["wall_radius"] = np.sin(np.radians(beta2)) * WALL_RADIUS
    return yl._finish(out, shape)


def _predict_correct(prob, idx, out):
    """Near rupture: a direct solve at half the gap, then one predictor-corrector step
    along the fixed-volume family to the target (the doublet solver's path, with the
    wall's starting point).  The corrector must end stable and near the predictor (same
    branch).  Stores the accepted points in ``out``; returns their mask."""
    pts, settings = prob.pts, prob.settings
    half = pts.take(idx)
    half.gap = 0.5 * half.gap
    xh, okh, ith, sth, rate = yl._Problem(half, False, settings, False).solve_with_rate(
        _wall_guess(half), max_iter=yl._DIRECT_ITER)
    go = np.flatnonzero(okh & sth & np.isfinite(rate).all(axis=0))
    acc = np.zeros(idx.size, bool)
    if go.size:
        xp = xh[:, go] + half.gap[go] * rate[:, go]
        xn, okn, itn, stn = prob.solve(xp, idx[go], max_iter=yl._DIRECT_ITER)
        close = np.max(np.abs(xn - xp) / prob.scale_of(xh[:, go]), axis=0) < 0.5
        ok = okn & stn & close
        yl._store(out, idx[go[ok]], xn[:, ok], pts.take(idx[go[ok]]), settings.nodes)
        out["iterations"][idx[go[ok]]] = ith[go[ok]] + itn[ok]
        acc[go[ok]] = True
    return acc


def solve_sphere_wall(gap, volume, theta_s, theta_w=None, settings=None):
    """Liquid bridge of given volume between a sphere and a flat wall, on the stable branch.

    Parameters
    ----------
    gap : array_like
        Gap between the sphere surface and the wall, d* = d / R [-], >= 0.
    volume : array_like
        Liquid volume V* = V / R^3 [-], > 0.
    theta_s : array_like
        Contact angle on the sphere [deg], in [0, 90).
    theta_w : array_like, optional
        Contact angle on the wall [deg], in [0, 90]; defaults to ``theta_s``.
    settings : capbridge.solvers.young_laplace.SolverSettings, optional

    Returns
    -------
    dict of arrays broadcast to the inputs' shape:
        force F* = F / (2 pi gamma R) on the sphere towards the wall (attraction > 0),
        pressure P* = dp R / gamma, beta1 half filling angle on the sphere [deg],
        wall_radius (wetted disc on the wall / R), neck_radius, area (liquid-gas),
        energy E* = A - cos(theta_s) A_s - cos(theta_w) A_w, volume, gap, status
        (:class:`capbridge.status.Status`), iterations.  Beyond rupture: status
        RUPTURED and force 0.

    Notes
    -----
    As the doublet solver: far from rupture (d* below a quarter of Lian's
    (1 + theta/2) V*^(1/3)) one Newton solve from the circular meridian; nearer, a solve
    at half the gap and a predictor-corrector step along the family; any point that
    does not end stable and on the same branch is solved by walking the fixed-volume
    family from contact (the safe path), so no point lands on an unstable branch.

    Examples
    --------
    A small bridge at contact pulls with 4 pi gamma R cos(theta), i.e. F* = 2 cos(theta):

    >>> r = solve_sphere_wall(0.0, 1e-7, 30.0)
    >>> round(float(r["force"]) / (2 * np.cos(np.radians(30.0))), 3)
    0.995
    """
    settings = settings or yl.SolverSettings()
    gap = _check_gap(gap)
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta_s, theta_w = _check_angles(theta_s, theta_w)
    (g, v), pts, shape = _make_points([gap, volume], theta_s, theta_w)
    pts.gap, pts.volume = g, v
    out = yl._result_arrays(g.size)
    prob = yl._Problem(pts, False, settings, False)
    far = np.flatnonzero(~yl._near_rupture(pts, False))
    done = np.zeros(g.size, bool)
    if far.size:
        x, ok, it, stable = prob.solve(_wall_guess(pts.take(far)), far,
                                       max_iter=yl._DIRECT_ITER)
        good = ok & stable
        yl._store(out, far[good], x[:, good], pts.take(far[good]), settings.nodes)
        out["iterations"][far[good]] = it[good]
        done[far[good]] = True
    near = np.flatnonzero(~done)
    if near.size:
        done[near] = _predict_correct(prob, near, out)
    rest = np.flatnonzero(~done)
    if rest.size:
        sub = pts.take(rest)
        x_c, ok_c = _contact_state(sub, settings)
        yl._solve_on_family(yl._Problem(sub, False, settings, False), x_c, ok_c, out, rest)
    return _finish(out, shape)


def _walk_from_contact(gap, volume, theta_s, theta_w, settings=None):
    """(status, results) of points (1-D) solved by the safe path only: the walk along
    the fixed-volume family from contact (no direct or predictor-corrector solve)."""
    settings = settings or yl.SolverSettings()
    (g, v), pts, shape = _make_points([gap, volume], theta_s, theta_w)
    pts.gap, pts.volume = g, v
    out = yl._result_arrays(g.size)
    x_c, ok_c = _contact_state(pts, settings)
    yl._solve_on_family(yl._Problem(pts, False, settings, False), x_c, ok_c, out,
                        np.arange(g.size))
    res = _finish(out, shape)
    return res["status"], res


def sphere_wall_rupture_distance(volume, theta_s, theta_w=None, settings=None):
    """Rupture distance d*_rupt(V*) of a sphere-wall bridge: the fold of the gap along
    the fixed-volume family (the end of the stable branch).

    Returns a dict with ``gap`` (d*_rupt) and the bridge at rupture (keys of
    :func:`solve_sphere_wall`).

    >>> r = sphere_wall_rupture_distance(0.01, 0.0)
    >>> 0.9 < float(r["gap"]) / 0.01 ** (1 / 3) < 1.1   # Lian et al. 1993: 0.215
    True
    """
    settings = settings or yl.SolverSettings()
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta_s, theta_w = _check_angles(theta_s, theta_w)
    (v,), pts, shape = _make_points([volume], theta_s, theta_w)
    pts.volume = v
    out = yl._result_arrays(v.size)
    x_c, ok_c = _contact_state(pts, settings)
    prob = yl._Problem(pts, False, settings, False)
    _, x_r, ok, _ = yl._rupture_of(prob, x_c, ok_c)
    good = np.flatnonzero(ok)
    yl._store(out, good, x_r[:, good], pts.take(good), settings.nodes)
    return _finish(out, shape)


# --------------------------------------------------------------------------------------
# Table slice
# --------------------------------------------------------------------------------------


def default_s_axis(n_s=25):
    """The doublet table's gap coordinate: s = sqrt(1 - d*/d*_rupt) on [0, 1], clustered
    at contact and rupture (s = (1 - cos(pi u))/2, u uniform), as in
    :meth:`capbridge.tables.doublet.DoubletGrid.shipped`."""
    u = np.linspace(0.0, 1.0, int(n_s))
    return 0.5 * (1.0 - np.cos(np.pi * u))


def sphere_wall_table(theta_s, theta_w, volumes, n_s=25):
    """Exact sphere-wall table slice on (volume, s), like a doublet slice at one (ratio, theta).

    The gap axis is the doublet table's s = sqrt(1 - d*/d*_rupt) (1 at contact, 0 at
    rupture; :mod:`capbridge.tables.doublet`), so an engine interpolates it as
    a doublet slice: rupture is exact and F*(s) is smooth up to the fold.

    Parameters
    ----------
    theta_s, theta_w : float
        Contact angles on the sphere and on the wall [deg].
    volumes : array_like
        V* = V/R^3 values [-], increasing, > 0.
    n_s : int
        Number of s values (>= 2), clustered at both ends.

    Returns
    -------
    xarray.Dataset with dims (volume, s): force, pressure, beta1, wall_radius,
    neck_radius, gap, status; rupture_gap, rupture_force, rupture_status on (volume,);
    scalar coordinates theta_s, theta_w.  Points that did not converge are NaN with
    their status, never a silent number.  A point whose direct solve ends with F* at or
    below F*_rupt (the near-rupture branch jump, e.g. V* ~ 0.06 at (20, 40) deg) is
    solved again by the walk from contact.
    """
    if np.ndim(theta_s) or np.ndim(theta_w):
        raise CapbridgeInputError(f"a table slice has one (theta_s, theta_w) pair, got "
                                  f"theta_s={theta_s!r}, theta_w={theta_w!r}")
    theta_s, theta_w = (float(a) for a in _check_angles(theta_s, theta_w))
    volumes = check_range("volume V*", volumes, 0.0, np.inf, low_open=True).ravel()
    if volumes.size > 1 and np.any(np.diff(volumes) <= 0):
        raise CapbridgeInputError(f"volumes must be strictly increasing, got {volumes.tolist()}")
    n_s = int(check_range("n_s", n_s, 2, 10_000))
    s = default_s_axis(n_s)
    rup = sphere_wall_rupture_distance(volumes, theta_s, theta_w)
    d_r = rup["gap"]
    rup_ok = rup["status"] == Status.CONVERGED
    gap = np.where(rup_ok, d_r, 0.0)[:, None] * (1.0 - s**2)
    inner = s > 0
    shape = (volumes.size, s.size)
    status = np.full(shape, int(Status.NOT_CONVERGED), np.int8)
    full = {name: np.full(shape, np.nan) for name in OUTPUTS}
    # only volumes whose rupture distance was found: the others have no gap axis (they
    # stay NOT_CONVERGED), and nothing is solved at a placeholder gap
    rows = np.flatnonzero(rup_ok)
    if rows.size:
        cells = np.ix_(rows, np.flatnonzero(inner))
        res = solve_sphere_wall(gap[cells], volumes[rows, None], theta_s, theta_w)
        status[cells] = res["status"]
        for name in OUTPUTS:
            full[name][cells] = res[name]
        # F* falls to F*_rupt along the stable branch: a force at or below it is the
        # near-rupture branch jump of the direct solve; those points take the safe path
        jump = (status == Status.CONVERGED) & inner & (full["force"] <= rup["force"][:, None])
        if jump.any():
            i, j = np.nonzero(jump)
            status[i, j], walked = _walk_from_contact(gap[i, j], volumes[i], theta_s, theta_w)
            for name in OUTPUTS:
                full[name][i, j] = walked[name]
    # s = 0 is the rupture point itself: the end state of the family walk
    status[:, ~inner] = np.where(rup_ok, Status.CONVERGED, Status.NOT_CONVERGED)[:, None]
    ok = status == Status.CONVERGED
    data = {}
    for name in OUTPUTS:
        full[name][:, ~inner] = rup[name][:, None]
        data[name] = np.where(ok, full[name], np.nan)
    dims = ("volume", "s")
    return xr.Dataset(
        {name: (dims, data[name], ATTRS[name]) for name in OUTPUTS}
        | {"gap": (dims, np.where(ok, gap, np.nan), ATTRS["gap"]),
           "status": (dims, status, cf_flag_attributes()),
           "rupture_gap": (("volume",), np.where(rup_ok, d_r, np.nan), ATTRS["rupture_gap"]),
           "rupture_force": (("volume",), np.where(rup_ok, rup["force"], np.nan),
                             ATTRS["rupture_force"]),
           "rupture_status": (("volume",), rup["status"].astype(np.int8),
                              cf_flag_attributes() | {"long_name": "status of the rupture solve"})},
        coords={"volume": ("volume", volumes, ATTRS["volume"]),
                "s": ("s", s, ATTRS["s"]),
                "theta_s": ((), theta_s, ATTRS["theta_s"]),
                "theta_w": ((), theta_w, ATTRS["theta_w"])},
        attrs={"title": "capbridge sphere-wall capillary-force table slice "
                        "(exact Young-Laplace, no gravity)",
               "normalising_radius": "R, the sphere's radius",
               "solver_settings": str(yl.SolverSettings().as_dict())})
