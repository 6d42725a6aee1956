"""Exact axisymmetric liquid bridge between two spheres (Young-Laplace, no gravity).

Profile
-------
The meridian of an axisymmetric surface of constant mean curvature ``h = P*/2`` is a
Delaunay roulette.  Written in arc length ``s`` from one of its points of extremal
radius ``n`` (Kenmotsu's representation, rearranged so that it is regular as h -> 0):

    S(s) = sin(h s) / h          (= s for h = 0),   C(s) = cos(h s)
    y(s)^2 = n^2 + B S^2,        B = sqrt(1 - 4 h F*),   n = 2 F* / (1 + B)
    dx/ds = cos(psi) = (n + B h S^2) / y,   dy/ds = sin(psi) = B S C / y
    y cos(psi) - h y^2 = F*      (first integral: the axial force, the same on every
                                  cross-section and on both grains)
    dpsi/ds = cos(psi) / y - 2 h (the meridian's curvature)

so every integral along it (axial length, volume, area) is a smooth quadrature.  The
substitution ``s = |n| sinh(u)`` keeps the integrands smooth through slender necks, and
Gauss-Legendre quadrature converges spectrally (48 nodes: ~1e-11 relative).

Sphere 1 (radius 1, the normalising radius) is centred at x = 0, sphere 2 (radius
``ratio`` >= 1) at x = 1 + ratio + d*.  The contact line on sphere i sits at half filling
angle beta_i; Young's law fixes the meridian's slope there:

    psi_1 = beta_1 + theta_1 - pi/2,   psi_2 = pi/2 - beta_2 - theta_2.

Unknowns: the bridge is *anchored* on sphere 1.  ``(h, beta1)`` fix the contact circle on
sphere 1, the slope there and hence the roulette (F* = sin b1 sin(b1 + t1) - h sin^2 b1);
the third unknown is the arc length ``L`` of the meridian from grain 1 to grain 2.  The
end point fixes beta2 = asin(y(L)/R); three residuals remain: Young's angle on grain 2,
the gap and the volume.  This chart is smooth everywhere on the physical branch: it has
no phase ambiguity (barrels whose contact line sits at the roulette's neck, profiles
longer than one period of the unduloid), no choice of root for beta2 (the force balance
holds by construction) and no degeneracy at cylinders, which the (h, beta1, beta2) and
(h, n, s1, s2) charts all have.  The Jacobian column in L is analytic; the columns in h
and beta1 are forward differences, evaluated in the same vectorised pass.

Stability and rupture
---------------------
At fixed volume the equilibria form a one-parameter family.  It starts at contact
(d* = 0, widest bridge) and the stable branch ends where the determinant
D = det d(angle, gap, volume)/d(h, beta1, L) first vanishes.  For unequal spheres (or
angles) that is the fold of d* along the family (the largest gap).  For equal spheres
and angles it is the point where the symmetric bridge becomes unstable to the
antisymmetric mode (liquid flowing towards one grain): at theta = 0 this coincides with
the fold of the symmetric family, at theta > 0 it comes before it (V* = 0.3, theta = 60:
1.020 against 1.239; V* = 0.01, theta = 60: 0.313 against 0.359; V* = 0.1, theta = 30:
0.6107 against 0.6123).  The bifurcation is subcritical: for ratio 1 + epsilon the family
folds there, so this rupture distance is the limit ratio -> 1 of the unequal-sphere one
(and it agrees with Lian's (1 + theta/2) V*^(1/3) far better than the symmetric fold
does at large theta).  D > 0 from contact to rupture; a second determinant restricted to
symmetric shapes (the midpoint slope in place of Young's angle) is > 0 up to the
symmetric fold.  Under suction control (given P*) the same holds with
E = det d(angle, gap)/d(beta1, L), and the branch ends at the largest gap at that
pressure.  A positive D is necessary, not sufficient: beyond the fold other branches of
equilibria (thinner necks, larger curvature) have an even number of unstable modes and
D > 0 again, so a solution is only accepted when it is reached from a stable state.

Solution path (vectorised over points)
--------------------------------------
* Starting point: the bridge with a circular meridian meeting both grains at their
  contact angles (closed form for any radius ratio and pair of angles), at the beta1
  that holds the volume (or has the pressure).
* Far from rupture (d* < 1/4 of Lian's estimate): one damped Newton solve.  Otherwise a
  solve at half the gap, then a predictor-corrector step along the family (tangent per
  unit gap from the last Jacobian) to the target; the corrector must stay near the
  predictor.  Both must end with D > 0 (and the symmetric determinant > 0).
* Anything else is solved on the family: pseudo-arclength continuation in scaled
  unknowns from a stable state (the half-gap solution, else the contact state) towards
  larger gaps until the target gap is passed or D changes sign; rupture is then located
  by a safeguarded secant (Illinois) search on D along the chord of the bracketing
  steps, and the target is solved from the nearest family point (next to the fold,
  where Newton converges slowly, by the same root search on the gap).
* Suction control: the family of every distinct (P*, theta1, theta2, ratio) is walked
  once from contact to its largest gap and shared by all the gaps asked at that
  pressure, as in a table; each gap is solved from the nearest sample.

Round-off: the cap volumes and the gap are written without cancellation (1 - cos b =
2 sin^2(b/2)), and Newton accepts a point at the round-off floor of the residuals when
its correction falls below 1e-13 relative (the relative volume of a tiny bridge on a
large grain cannot reach 1e-12).

Supported range: theta1, theta2 in [0, 90) deg, ratio in [1, 10], V* from ~1e-9 to the
volume at which beta1 approaches 90 deg for equal spheres (V* ~ 1.8 at contact, theta =
0), beta1 up to 0.9 pi on the smaller grain (engulfed by a large bridge at ratio 10).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from capbridge.dimensionless import cap_area, cap_height, cap_volume, centre_distance
from capbridge.status import Status
from capbridge.validation import check_range

#: Gauss-Legendre nodes used by default (error < 1e-10 relative in F*, V*; see tests).
DEFAULT_NODES = 48
THETA_MAX_DEG = 90.0
RATIO_MAX = 10.0
#: largest half filling angle on grain 1 (beyond 90 deg the small grain of a very
#: unequal pair is engulfed, e.g. ratio 10 at small suction)
_BETA1_MAX = 0.9 * np.pi

__all__ = [
    "SolverSettings",
    "bridge_profile",
    "bridge_shape",
    "bridge_meridian",
    "solve_doublet",
    "rupture_distance",
    "solve_doublet_suction",
    "suction_rupture_distance",
]


@dataclasses.dataclass(frozen=True)
class SolverSettings:
    """Numerical settings of the exact solver (written into every table)."""

    nodes: int = DEFAULT_NODES       #: Gauss-Legendre nodes along the meridian
    tol: float = 1e-12               #: Newton tolerance on the scaled residuals
    max_iter: int = 60               #: Newton iterations before a point is flagged

    def as_dict(self):
        return dataclasses.asdict(self)


# --------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------

_GL_CACHE: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _gauss_legendre(n):
    if n not in _GL_CACHE:
        _GL_CACHE[n] = np.polynomial.legendre.leggauss(n)
    return _GL_CACHE[n]


def _wrap(a):
    """Angle in (-pi, pi]."""
    return np.pi - np.remainder(np.pi - a, 2.0 * np.pi)


def _arc_position(n, B, h, y, psi):
    """Arc length s from the extremum y = n of the roulette to the point (y, psi).

    Defined modulo the period pi/|h|; returned in (-pi/(2|h|), pi/(2|h|)].
    """
    a = y * np.sin(psi)
    b = n - y * np.cos(psi)
    with np.errstate(invalid="ignore", divide="ignore"):
        hz = np.where(h == 0.0, 1.0, h)
        s = np.arctan2(2.0 * hz * a, B + 2.0 * hz * b) / (2.0 * hz)
        return np.where(h == 0.0, a / B, s)


def _roulette(h, beta1, theta1):
    """(y1, psi1, F, B, n, s1) of the roulette through the contact line on grain 1."""
    y1 = np.sin(beta1)
    psi1 = beta1 + theta1 - 0.5 * np.pi
    cp, sp = np.cos(psi1), np.sin(psi1)
    force = y1 * cp - h * y1 * y1
    # 1 - 4 h F as a sum of squares: never negative, no cancellation near cylinders
    B = np.hypot(1.0 - 2.0 * h * y1 * cp, 2.0 * h * y1 * sp)
    n = 2.0 * force / (1.0 + B)
    s1 = _arc_position(n, B, h, y1, psi1)
    return y1, psi1, force, B, n, s1


def _point(n, B, h, s):
    """(y, sin psi, cos psi) at arc position s."""
    S = s * np.sinc(h * s / np.pi)
    C = np.cos(h * s)
    y = np.sqrt(n * n + B * S * S)
    with np.errstate(invalid="ignore", divide="ignore"):
        return y, B * S * C / y, (n + B * h * S * S) / y


def _shape(h, beta1, length, theta1, theta2, ratio, nodes=DEFAULT_NODES, integrals=True):
    """Everything about the anchored profile (h, beta1, L); arrays broadcast together.

    Closed-form end quantities always; with ``integrals`` the quadratures (gap, volume,
    area, energy, neck radius) as well.
    """
    h, b1, L, t1, t2, R = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (h, beta1, length, theta1, theta2, ratio)))
    y1, psi1, force, B, n, s1 = _roulette(h, b1, t1)
    s2 = s1 + L
    ye, sin_e, cos_e = _point(n, B, h, s2)
    q = ye / R
    feasible = ((b1 > 0.0) & (b1 < _BETA1_MAX) & (L > 0.0) & (q < 1.0) & (ye > 0.0)
                & np.isfinite(s1) & np.isfinite(ye) & np.isfinite(h))
    b2 = np.arcsin(np.clip(q, 0.0, 1.0))
    cos_b2 = np.sqrt(np.clip(1.0 - q * q, 0.0, None))
    psi_e = np.arctan2(sin_e, cos_e)
    angle = _wrap(psi_e - (0.5 * np.pi - b2 - theta2))
    # midpoint slope: zero exactly for mirror-symmetric profiles
    ym, sin_m, cos_m = _point(n, B, h, s1 + 0.5 * L)
    out = dict(h=h, beta1=b1, length=L, beta2=b2, cos_b2=cos_b2, angle=angle, sym=sin_m,
               force=force, pressure=2.0 * h, n=n, B=B, s1=s1, s2=s2, y1=y1, ye=ye,
               sin_e=sin_e, cos_e=cos_e, ym=ym, sin_m=sin_m, cos_m=cos_m,
               feasible=feasible, R=R)
    if not integrals:
        return out
    c = np.where(feasible, np.maximum(np.abs(n), 1e-12 * (1.0 + np.abs(L))), 1.0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        u1 = np.arcsinh(np.where(feasible, s1, 0.0) / c)
        u2 = np.arcsinh(np.where(feasible, s2, 1.0) / c)
        t, w = _gauss_legendre(nodes)
        half = 0.5 * (u2 - u1)
        u = (u1 + half)[..., None] + half[..., None] * t
        s = c[..., None] * np.sinh(u)
        wj = w * c[..., None] * np.cosh(u) * half[..., None]
        hh = h[..., None]
        S = s * np.sinc(hh * s / np.pi)
        y = np.sqrt(n[..., None] ** 2 + B[..., None] * S * S)
        num = n[..., None] + B[..., None] * hh * S * S       # = y cos(psi)
        axial = np.sum(wj * num / y, axis=-1)
        vol_rev = np.pi * np.sum(wj * y * num, axis=-1)
        area = 2.0 * np.pi * np.sum(wj * y, axis=-1)
    # cap heights as 2 R sin^2(b/2): no cancellation for small caps on large spheres
    gap = axial - cap_height(1.0, b1) - cap_height(R, b2)
    volume = vol_rev - cap_volume(1.0, b1) - cap_volume(R, b2)
    energy = area - np.cos(t1) * cap_area(1.0, b1) - np.cos(t2) * cap_area(R, b2)
    # smallest radius of the free surface: the contact circles or a neck y = |n|
    # (the necks sit at s = k pi/|h|, k integer)
    period = np.pi / np.maximum(np.abs(h), 1e-300)
    k = np.ceil(s1 / period)
    has_neck = (h == 0.0) & (s1 < 0.0) & (s2 > 0.0) | (h != 0.0) & (k * period < s2)
    neck = np.minimum(np.minimum(y1, ye), np.where(has_neck, np.abs(n), np.inf))
    bad = ~feasible
    for key, val in (("gap", gap), ("volume", volume), ("area", area), ("energy", energy),
                     ("neck_radius", neck)):
        out[key] = np.where(bad, np.nan, val)
    return out


def bridge_shape(h, beta1, length, theta1, theta2, ratio, nodes=DEFAULT_NODES):
    """Gap, volume, force and shape of the bridge anchored on grain 1.

    Parameters (radians / dimensionless, broadcast together): mean curvature ``h``
    (= P*/2), half filling angle ``beta1`` on grain 1, arc length ``length`` of the
    meridian from grain 1 to grain 2, contact angles and radius ratio.  The profile is
    an equilibrium when ``angle`` (the misfit of Young's angle on grain 2, rad) is zero.
    Returns a dict of arrays (gap, volume, force, pressure, beta2 [rad], angle,
    neck_radius, area, energy, feasible, ...).
    """
    return _shape(h, beta1, length, theta1, theta2, ratio, nodes)


def bridge_profile(h, beta1, beta2, theta1, theta2, ratio, nodes=DEFAULT_NODES):
    """Gap, volume, force and shape of the bridge fixed by (h, beta1, beta2).

    The meridian runs from the contact line on grain 1 to the first point of the
    roulette that matches the contact line on grain 2 within one period (profiles
    longer than a period need :func:`bridge_shape`).  ``force_balance`` is the misfit
    of the axial force between the two contact lines (zero for an equilibrium).
    """
    h, b1, b2, t1, t2, R = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (h, beta1, beta2, theta1, theta2, ratio)))
    y1, psi1, force, B, n, s1 = _roulette(h, b1, t1)
    y2 = R * np.sin(b2)
    psi2 = 0.5 * np.pi - b2 - t2
    s2 = _arc_position(n, B, h, y2, psi2)
    period = np.pi / np.maximum(np.abs(h), 1e-300)
    ds = np.where((s2 - s1 <= 0) & (h != 0), s2 - s1 + period, s2 - s1)
    out = _shape(h, b1, np.where(ds > 0, ds, np.nan), t1, t2, R, nodes)
    out["force_balance"] = (y2 * np.cos(psi2) - h * y2 * y2) - force
    return out


def bridge_meridian(gap, pressure, beta1, beta2, theta1, theta2=None, n=801, ratio=1.0,
                    necks=False):
    """Meridian (x, y) of the exact bridge between the spheres of radii 1 at (0, 0) and
    ``ratio`` at (1 + ratio + gap, 0).

    Parameters
    ----------
    gap : float
        Gap d* between the sphere surfaces [-].
    pressure : float
        Laplace pressure P* [-].
    beta1, beta2 : float
        Half filling angles on spheres 1 and 2 [deg].
    theta1 : float
        Contact angle on sphere 1 [deg].
    theta2 : float, optional
        Contact angle on sphere 2 [deg]; defaults to ``theta1``.
    n : int
        Points from the contact line on sphere 1 to that on sphere 2, denser near the
        ends (uniform in the angle of a cosine).
    ratio : float
        Radius ratio R2/R1 [-].
    necks : bool
        Also include the roulette's necks (its points of smallest radius) that lie on
        the meridian, so that ``y.min()`` is the bridge's ``neck_radius`` to round-off.

    Returns
    -------
    x, y : numpy.ndarray
        Axial position from the centre of sphere 1 and distance from the axis, in units
        of R1.  The inputs are those of :func:`solve_doublet`'s output (``pressure``,
        ``beta1``, ``beta2``).  x is the integral of cos(psi) along the arc, by
        Gauss-Legendre on every interval (in the variable of :func:`bridge_shape`,
        smooth through slender necks), so it is exact to ~1e-13.

    Raises
    ------
    ValueError
        The rebuilt profile does not end on sphere 2 (to 1e-6): inputs that are not an
        equilibrium.

    Examples
    --------
    >>> r = solve_doublet(0.1, 0.05, 20.0)
    >>> x, y = bridge_meridian(0.1, r["pressure"], r["beta1"], r["beta2"], 20.0)
    >>> bool(abs(np.hypot(x[-1] - 2.1, y[-1]) - 1) < 1e-12)
    True
    """
    theta2 = theta1 if theta2 is None else theta2
    h = np.float64(0.5 * float(pressure))
    b1, b2, t1, t2 = (np.radians(float(v)) for v in (beta1, beta2, theta1, theta2))
    prof = bridge_profile(h, b1, b2, t1, t2, float(ratio))
    nn, B = prof["n"], prof["B"]
    s1, L = float(prof["s1"]), float(prof["length"])
    s = s1 + L * 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, n)))
    if necks:
        # the necks sit at s = k pi/|h| (s = 0 for h = 0): see _shape
        period = np.pi / abs(h) if h != 0.0 else np.inf
        k = np.arange(np.ceil(s1 / period), np.floor((s1 + L) / period) + 1) \
            if np.isfinite(period) else np.array([0.0])
        inner = k * period if np.isfinite(period) else k
        s = np.union1d(s, inner[(inner > s1) & (inner < s1 + L)])
    # x by Gauss-Legendre in u = asinh(s / c) on every interval (as in _shape)
    c = max(abs(float(nn)), 1e-12 * (1.0 + L))
    u = np.arcsinh(s / c)
    t, w = _gauss_legendre(12)
    half = 0.5 * np.diff(u)
    uu = (u[:-1] + half)[:, None] + half[:, None] * t
    ss = c * np.sinh(uu)
    _, _, cosp = _point(nn, B, h, ss)
    dx = np.sum(w * cosp * c * np.cosh(uu) * half[:, None], axis=1)
    x = np.cos(b1) + np.concatenate([[0.0], np.cumsum(dx)])
    y = _point(nn, B, h, s)[0]
    end = np.hypot(x[-1] - centre_distance(gap, ratio), y[-1]) - float(ratio)
    if not (np.isfinite(end) and abs(end) < 1e-6):
        raise ValueError(f"meridian does not close on sphere 2 (miss {end:.2e})")
    return x, y


# --------------------------------------------------------------------------------------
# Residuals and Jacobians, vectorised over points
# --------------------------------------------------------------------------------------

@dataclasses.dataclass
class _Points:
    """Flattened inputs (radians) of a batch of doublets and their targets."""

    theta1: np.ndarray
    theta2: np.ndarray
    ratio: np.ndarray
    gap: np.ndarray = None
    volume: np.ndarray = None
    h: np.ndarray = None           # fixed mean curvature (suction control)

    @property
    def size(self):
        return self.theta1.size

    @property
    def symmetric(self):
        return (self.ratio == 1.0) & (self.theta1 == self.theta2)

    def take(self, idx):
        f = lambda a: None if a is None else a[idx]  # noqa: E731
        return _Points(self.theta1[idx], self.theta2[idx], self.ratio[idx], f(self.gap),
                       f(self.volume), f(self.h))


def _derivs_L(p, vol_scale):
    """Analytic d/dL of angle, sym, gap and relative volume at the profile ``p``."""
    R = p["R"]
    with np.errstate(invalid="ignore", divide="ignore"):
        db2 = p["sin_e"] / (R * p["cos_b2"])
        kap_e = p["cos_e"] / p["ye"] - 2.0 * p["h"]
        kap_m = p["cos_m"] / p["ym"] - 2.0 * p["h"]
        sb2 = np.sin(p["beta2"])
        return dict(
            angle=kap_e + db2,
            sym=0.5 * p["cos_m"] * kap_m,
            gap=p["cos_e"] - R * sb2 * db2,
            volume=np.pi * (p["ye"] ** 2 * p["cos_e"] - R**3 * sb2**3 * db2) / vol_scale,
        )


def _evaluate(z, pts, nodes, *, fixed_h=False, jac=True, integrals=True):
    """Values (and derivatives) of angle, sym, gap, volume/V at the unknowns ``z``.

    ``z`` is (h, beta1, L) with shape (3, N); with ``fixed_h`` the h row is given and
    only beta1 and L are unknowns.  Returns (values: dict key -> (N,),
    derivs: dict key -> (N, 3) in the order h, beta1, L, shape) where derivs is None
    without ``jac``.  Forward differences in h and beta1 are evaluated in the same pass
    as the base point.
    """
    N = z.shape[1]
    vscale = pts.volume if pts.volume is not None else np.ones(N)
    cols = [1] if fixed_h else [0, 1]
    if jac:
        eps = [1e-7 * (1.0 + np.abs(z[j])) for j in cols]
        zz = np.tile(z, (1, 1 + len(cols)))
        for k, j in enumerate(cols):
            zz[j, (k + 1) * N:(k + 2) * N] += eps[k]
        rep = 1 + len(cols)
        t1, t2, R = (np.tile(a, rep) for a in (pts.theta1, pts.theta2, pts.ratio))
    else:
        zz, t1, t2, R = z, pts.theta1, pts.theta2, pts.ratio
    p = _shape(zz[0], zz[1], zz[2], t1, t2, R, nodes, integrals=integrals)
    vals = {"angle": p["angle"], "sym": p["sym"]}
    if integrals:
        vals["gap"] = p["gap"]
        vals["volume"] = p["volume"] / (np.tile(vscale, zz.shape[1] // N))
    base = {k: v[:N] for k, v in vals.items()}
    base["feasible"] = p["feasible"][:N]
    shape = {k: v[:N] for k, v in p.items() if np.ndim(v)}
    if not jac:
        return base, None, shape
    dL = _derivs_L(shape, vscale)
    der = {}
    for key in vals:
        d = np.zeros((N, 3))
        for k, j in enumerate(cols):
            diff = vals[key][(k + 1) * N:(k + 2) * N] - base[key]
            if key == "angle":
                diff = _wrap(diff)
            d[:, j] = diff / eps[k]
        d[:, 2] = dL[key]
        der[key] = d
    ok = np.ones(N, bool)
    for k in range(len(cols)):
        ok &= p["feasible"][(k + 1) * N:(k + 2) * N]
    base["feasible"] = base["feasible"] & ok
    return base, der, shape


# --------------------------------------------------------------------------------------
# Vectorised damped Newton method
# --------------------------------------------------------------------------------------

_NOISE_FLOOR = 1e-8  # residuals below this may be round-off (see _newton)


def _newton(system, z, *, tol, max_iter, max_step):
    """Solve system(z) = 0 for many independent points at once.

    ``z`` has shape (m, N).  ``system(z, idx)`` returns (residuals (m, n), Jacobian
    (n, m, m), feasible (n,), extra) for the points ``idx``, ``extra`` a dict of per-point
    arrays (leading axis n) kept for the last accepted iterate of every point.  Steps
    are clipped to ``max_step(z)`` (per unknown) and halved until the residual's
    max-norm decreases.  A point converges when its residual is below ``tol`` or, at
    the round-off floor of the residuals (below 1e-8), when the Newton correction is
    below 1e-13 relative.  Returns (z, converged, iterations, extra).
    """
    z = np.array(z, float)
    m, npts = z.shape
    r, J, feas, ex = system(z, np.arange(npts))
    extra = {k: np.array(v) for k, v in ex.items()}
    norm = np.where(feas, np.max(np.abs(r), axis=0), np.nan)
    conv = norm < tol
    iters = np.zeros(npts, int)
    for _ in range(max_iter):
        todo = ~conv & np.isfinite(norm)
        if not todo.any():
            break
        ia = np.flatnonzero(todo)
        za, ra, Ja = z[:, ia], r[:, ia], J[ia]
        with np.errstate(invalid="ignore", over="ignore"):
            det = np.linalg.det(Ja)
            singular = ~np.isfinite(det) | (det == 0.0)
            Ja = np.where(singular[:, None, None], np.eye(m), Ja)
            dz = -np.linalg.solve(Ja, ra.T[..., None])[..., 0].T
        dz[:, singular] = np.nan
        floor = (~singular & (norm[ia] < _NOISE_FLOOR)
                 & np.all(np.abs(dz) <= 1e-13 * (1.0 + np.abs(za)), axis=0))
        conv[ia[floor]] = True
        iters[ia[floor]] += 1
        keep = ~floor
        ia, za, dz = ia[keep], za[:, keep], dz[:, keep]
        if not ia.size:
            break
        cap = max_step(za)
        with np.errstate(invalid="ignore", divide="ignore"):
            scale = np.min(np.where(np.abs(dz) > cap, cap / np.abs(dz), 1.0), axis=0)
        dz *= scale
        lam = np.ones(ia.size)
        accepted = np.zeros(ia.size, bool)
        na = norm[ia]
        for _bt in range(14):
            trial = ~accepted & np.isfinite(dz).all(axis=0)
            if not trial.any():
                break
            it = np.flatnonzero(trial)
            zt = za[:, it] + lam[it] * dz[:, it]
            rt, Jt, ft, ext = system(zt, ia[it])
            nt = np.where(ft, np.max(np.abs(rt), axis=0), np.nan)
            ok = np.isfinite(nt) & ((nt < (1 - 1e-4 * lam[it]) * na[it]) | (nt < tol))
            good = it[ok]
            tgt = ia[good]
            z[:, tgt], r[:, tgt], J[tgt], norm[tgt] = zt[:, ok], rt[:, ok], Jt[ok], nt[ok]
            for k, v in ext.items():
                extra[k][tgt] = v[ok]
            accepted[good] = True
            lam[it] *= 0.5
        # a point that cannot decrease its residual is stalled: leave it unconverged
        norm[ia[~accepted]] = np.nan
        iters[ia] += 1
        conv |= norm < tol
    return z, conv, iters, extra


def _max_step(z):
    """Largest Newton step: relative in h and L, absolute in beta1."""
    m = z.shape[0]
    if m == 3:     # (h, beta1, L)
        return np.vstack([0.5 * (1.0 + np.abs(z[0])), np.full(z.shape[1], 0.15),
                          0.5 * np.abs(z[2]) + 1e-3])
    return np.vstack([np.full(z.shape[1], 0.15), 0.5 * np.abs(z[1]) + 1e-3])  # (beta1, L)


# --------------------------------------------------------------------------------------
# Equilibrium conditions, stability, and the families of equilibria
# --------------------------------------------------------------------------------------

def _constraint_key(sym):
    """Residual that makes a profile an equilibrium: Young's angle on grain 2, or for
    equal spheres and angles the midpoint slope (which keeps the mirror symmetry and
    stays regular through the symmetry-breaking point)."""
    return "sym" if sym else "angle"


def _indicators(d, symmetric, fixed_h):
    """Stability determinants from the derivatives ``d`` (columns = the unknowns).

    full = det d(angle, gap[, volume])/d(unknowns); sym = the same with the midpoint
    slope in place of the angle (1 for points that are not symmetric).  Both are > 0
    from contact to the end of the stable branch (module docstring); their orientation
    (positive at contact) is checked in the tests.
    """
    rows = ["gap"] if fixed_h else ["gap", "volume"]
    with np.errstate(invalid="ignore"):
        full = np.linalg.det(np.stack([d["angle"]] + [d[k] for k in rows], 1))
        symd = np.linalg.det(np.stack([d["sym"]] + [d[k] for k in rows], 1))
    return full, np.where(symmetric, symd, 1.0)


class _Problem:
    """Equilibria of a batch of doublets at fixed volume (unknowns z = (h, beta1, L)) or,
    with ``fixed_h``, at fixed mean curvature (unknowns (beta1, L))."""

    def __init__(self, pts, sym, settings, fixed_h):
        self.pts, self.sym, self.settings, self.fixed_h = pts, sym, settings, fixed_h
        self.ck = _constraint_key(sym)
        self.scale = None

    @property
    def m(self):
        return 2 if self.fixed_h else 3

    def full_z(self, x, idx):
        return np.vstack([self.pts.h[idx], x]) if self.fixed_h else x

    def evaluate(self, x, idx):
        """Values and derivatives with respect to the unknowns of the points ``idx``."""
        sub = self.pts.take(idx)
        v, d, _ = _evaluate(self.full_z(x, idx), sub, self.settings.nodes,
                            fixed_h=self.fixed_h)
        if self.fixed_h:
            d = {k: dd[:, 1:] for k, dd in d.items()}
        return v, d, sub

    def constraints(self, v, d):
        """Rows that define the family (equilibrium [and volume])."""
        keys = [self.ck] if self.fixed_h else [self.ck, "volume"]
        vals = [v[self.ck]] if self.fixed_h else [v[self.ck], v["volume"] - 1.0]
        return np.vstack(vals), np.stack([d[k] for k in keys], axis=1)

    def extras(self, v, d, sub, idx):
        """Per-point data kept by Newton for the last iterate (see :meth:`summarize`)."""
        ex = {"gap": v["gap"], "feasible": v["feasible"]}
        for k in ("angle", "sym", "gap") + (() if self.fixed_h else ("volume",)):
            ex["d_" + k] = d[k]
        return ex

    def summarize(self, ex, idx):
        """Stability indicators (and the family tangent) from Newton's extras."""
        d = {k[2:]: v for k, v in ex.items() if k.startswith("d_")}
        symmetric = self.pts.symmetric[idx]
        full, symd = _indicators(d, symmetric, self.fixed_h)
        ind = np.where(symmetric, np.minimum(full, symd), full)
        out = dict(full=full, symd=symd, ind=np.where(ex["feasible"], ind, np.nan),
                   gap=ex["gap"])
        if self.scale is not None:
            out["tangent"] = self.tangent(d, idx)
            out["dgap"] = d["gap"]
        return out

    def target_system(self):
        """Residuals (constraint, gap - d[, volume - V]) for solving at the target gap."""

        def system(x, idx):
            v, d, sub = self.evaluate(x, idx)
            rc, Jc = self.constraints(v, d)
            r = np.vstack([rc[:1], v["gap"] - sub.gap, rc[1:]])
            J = np.concatenate([Jc[:, :1], d["gap"][:, None, :], Jc[:, 1:]], axis=1)
            return r, J, v["feasible"], self.extras(v, d, sub, idx)

        return system

    def solve(self, x0, idx=None, max_iter=None):
        """Newton at the target gaps of the points ``idx`` (default: all).

        Returns (x, ok, iters, stable), stable = converged with both stability
        determinants > 0.
        """
        return self.solve_with_rate(x0, idx, max_iter)[:4]

    def stable(self, ex, idx):
        out = self.summarize(ex, idx)
        return (out["full"] > 0) & (out["symd"] > 0)

    def solve_with_rate(self, x0, idx=None, max_iter=None):
        """As :meth:`solve`, plus dx/dd: the tangent of the family at fixed volume (or h)
        per unit gap, from the last Jacobian."""
        idx = np.arange(x0.shape[1]) if idx is None else idx
        system = self.target_system()
        x, ok, iters, ex = _newton(lambda x, jdx: system(x, idx[jdx]), x0,
                                   tol=self.settings.tol,
                                   max_iter=max_iter or self.settings.max_iter,
                                   max_step=_max_step)
        keys = [self.ck, "gap"] + ([] if self.fixed_h else ["volume"])
        J = np.stack([ex["d_" + k] for k in keys], axis=1)
        e = np.zeros((len(idx), self.m, 1))
        e[:, 1, 0] = 1.0
        with np.errstate(invalid="ignore", over="ignore"):
            good = np.isfinite(J).all(axis=(1, 2)) & (np.abs(np.linalg.det(
                np.where(np.isfinite(J), J, 0.0))) > 0)
            rate = np.full((len(idx), self.m), np.nan)
            if good.any():
                rate[good] = np.linalg.solve(J[good], e[good])[..., 0]
        return x, ok, iters, ok & self.stable(ex, idx), rate.T

    # -- continuation ------------------------------------------------------------------

    def set_scale(self, x):
        self.scale = self.scale_of(x)

    def scale_of(self, x):
        """Scales of the unknowns for continuation: h by 1 + |h|, L by L, beta1 by 1."""
        if self.fixed_h:
            return np.vstack([np.ones(x.shape[1]), np.abs(x[1]) + 1e-3])
        return np.vstack([1.0 + np.abs(x[0]), np.ones(x.shape[1]), np.abs(x[2]) + 1e-3])

    def tangent(self, d, idx):
        """Unit tangent of the family in scaled unknowns (sign arbitrary), shape (m, n)."""
        _, J = self.constraints({k: np.zeros(len(idx)) for k in ("angle", "sym", "volume")}, d)
        Jw = J * self.scale[:, idx].T[:, None, :]
        if self.fixed_h:
            t = np.stack([-Jw[:, 0, 1], Jw[:, 0, 0]], axis=1)
        else:
            t = np.cross(Jw[:, 0], Jw[:, 1])
        with np.errstate(invalid="ignore"):
            return (t / np.linalg.norm(t, axis=1, keepdims=True)).T

    def correct(self, x0, idx, w_ref, u, sigma, max_iter=15):
        """Family points with u . (x/scale - w_ref) = sigma (u unit vectors)."""

        def system(x, jdx):
            gidx = idx[jdx]
            v, d, sub = self.evaluate(x, gidx)
            r, J = self.constraints(v, d)
            sc = self.scale[:, gidx]
            arc = np.einsum("jn,jn->n", u[:, jdx], x / sc - w_ref[:, jdx]) - sigma[jdx]
            Ja = (u[:, jdx] / sc).T[:, None, :]
            return (np.vstack([r, arc]), np.concatenate([J, Ja], axis=1), v["feasible"],
                    self.extras(v, d, sub, gidx))

        return _newton(system, x0, tol=self.settings.tol, max_iter=max_iter,
                       max_step=_max_step)


def _walk(prob, x_start, gap_stop=None, max_steps=200, ds0=0.05):
    """Follow the families from the stable states ``x_start`` towards larger gaps.

    Pseudo-arclength continuation in scaled unknowns; a point stops at the first sign
    change of the stability indicator (the bracket around rupture) or, with
    ``gap_stop``, once its gap exceeds gap_stop (``reached``).  Returns a dict with the
    samples (list of (x, gap, recorded)), the bracket (x_lo, ind_lo, x_hi, ind_hi) and
    the flags bracketed / reached / failed.
    """
    N = x_start.shape[1]
    every = np.arange(N)
    prob.set_scale(x_start)
    v, d, sub = prob.evaluate(x_start, every)
    ex = prob.summarize(prob.extras(v, d, sub, every), every)
    t = ex["tangent"]
    t *= np.where(np.einsum("nj,jn->n", ex["dgap"], t * prob.scale) < 0, -1.0, 1.0)
    x, gap, ind = x_start.copy(), ex["gap"].copy(), ex["ind"].copy()
    active = np.isfinite(ind) & (ind > 0) & np.all(np.isfinite(t), axis=0)
    failed = ~active
    bracketed = np.zeros(N, bool)
    reached = np.zeros(N, bool)
    if gap_stop is not None:
        reached = active & (gap >= gap_stop)
        active &= ~reached
    x_hi, ind_hi = np.full_like(x, np.nan), np.full(N, np.nan)
    ds = np.full(N, ds0)
    samples = [(x.copy(), gap.copy(), np.isfinite(gap))]
    for _ in range(max_steps):
        ia = np.flatnonzero(active)
        if not ia.size:
            break
        sc = prob.scale[:, ia]
        wp = x[:, ia] / sc + ds[ia] * t[:, ia]
        xn, ok, iters, exn = prob.correct(wp * sc, ia, wp, t[:, ia], np.zeros(ia.size))
        exn = prob.summarize(exn, ia)
        tn = exn["tangent"]
        cosang = np.einsum("jn,jn->n", tn, t[:, ia])
        tn *= np.where(cosang < 0, -1.0, 1.0)
        ind_n, gap_n = exn["ind"], exn["gap"]
        ok &= np.isfinite(ind_n) & np.all(np.isfinite(tn), axis=0) & (np.abs(cosang) > 0.9)
        # guard against jumping to another branch
        ok &= np.abs(gap_n - gap[ia]) < 0.5 * (0.05 + np.abs(gap[ia]))
        flip = ok & (ind_n <= 0)
        # on the stable branch the gap grows along the walk: a step that lands on a
        # stable-looking point with a smaller gap (or a falling gap) has jumped over
        # the fold and back (two sign changes of the indicator): shorten it
        rate_n = np.einsum("nj,jn->n", exn["dgap"], tn * sc)
        ok &= flip | ((gap_n > gap[ia]) & (rate_n > 0))
        adv = ok & ~flip
        fi = ia[flip]
        x_hi[:, fi], ind_hi[fi] = xn[:, flip], ind_n[flip]
        bracketed[fi] = True
        active[fi] = False
        ai = ia[adv]
        x[:, ai], gap[ai], ind[ai], t[:, ai] = xn[:, adv], gap_n[adv], ind_n[adv], tn[:, adv]
        ds[ai] = np.minimum(ds[ai] * np.where(iters[adv] <= 2, 2.0, 1.3), 0.5)
        bi = ia[~ok]
        ds[bi] *= 0.25
        dead = bi[ds[bi] < 1e-9]
        failed[dead] = True
        active[dead] = False
        rec = np.zeros(N, bool)
        rec[ai] = True
        if gap_stop is not None:
            hit = rec & (gap >= gap_stop)
            reached |= hit
            active &= ~hit
        samples.append((x.copy(), gap.copy(), rec))
    failed |= active   # ran out of steps
    return dict(samples=samples, x_lo=x, ind_lo=ind, x_hi=x_hi, ind_hi=ind_hi,
                bracketed=bracketed, reached=reached, failed=failed)


def _chord_root(prob, x_lo, x_hi, f_lo, f_hi, active, value, n_iter=60):
    """Zero of ``value`` on the family between x_lo (value > 0) and x_hi (value <= 0).

    Illinois (modified regula falsi) in the arc parameter along the chord between the
    two family points (each trial point is put back on the family), with a bisection
    whenever a step fails to halve the bracket.  ``value(summary, idx)`` maps
    :meth:`_Problem.summarize` output to the function.  Returns (x_a, f_a, x_b, f_b,
    width) for the ends of the final bracket, width relative to its start.
    """
    N = x_lo.shape[1]
    sc = prob.scale
    w_lo = x_lo / sc
    chord = x_hi / sc - w_lo
    length = np.linalg.norm(chord, axis=0)
    with np.errstate(invalid="ignore"):
        u = chord / length
    a, b = np.zeros(N), length.copy()
    fa, fb = f_lo.copy(), f_hi.copy()
    xa, xb = x_lo.copy(), x_hi.copy()
    side = np.zeros(N, int)
    active = active & np.isfinite(length) & (length > 0) & np.isfinite(fa) & np.isfinite(fb)
    width = 4.0 * (b - a)
    for _ in range(n_iter):
        ia = np.flatnonzero(active)
        if not ia.size:
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            c = (a[ia] * fb[ia] - b[ia] * fa[ia]) / (fb[ia] - fa[ia])
        inside = np.isfinite(c) & (c > a[ia]) & (c < b[ia])
        slow = (b[ia] - a[ia]) > 0.5 * width[ia]
        width[ia] = b[ia] - a[ia]
        c = np.where(inside & ~slow, c, 0.5 * (a[ia] + b[ia]))
        f = (c - a[ia]) / (b[ia] - a[ia])
        x0 = (1 - f) * xa[:, ia] + f * xb[:, ia]
        xc, ok, _, ex = prob.correct(x0, ia, w_lo[:, ia], u[:, ia], c)
        fc = value(prob.summarize(ex, ia), ia)
        ok &= np.isfinite(fc)
        # a failed evaluation counts as the far side (shrinks towards the near end)
        fc = np.where(ok, fc, -1e-3 * np.abs(fa[ia]))
        xc = np.where(ok, xc, x0)
        pos = fc > 0
        ip, ineg = ia[pos], ia[~pos]
        fb[ip] = np.where(side[ip] == 1, 0.5 * fb[ip], fb[ip])
        a[ip], fa[ip], xa[:, ip], side[ip] = c[pos], fc[pos], xc[:, pos], 1
        fa[ineg] = np.where(side[ineg] == -1, 0.5 * fa[ineg], fa[ineg])
        b[ineg], fb[ineg], xb[:, ineg], side[ineg] = c[~pos], fc[~pos], xc[:, ~pos], -1
        active[ia] = (b[ia] - a[ia]) > 1e-10 * (1.0 + length[ia])
    with np.errstate(invalid="ignore"):
        return xa, fa, xb, fb, (b - a) / (1.0 + length)


def _illinois(prob, walk, n_iter=60):
    """Zero of the stability indicator on the family inside the walk's bracket.

    Returns (x, ok): the stable end of the final bracket.  The indicator comes from
    finite differences (noise ~1e-9 of its scale): a bracket that stalls below 1e-7 is
    as good as the rupture gap needs (its error is ~ the square of that at a fold).
    """
    xa, _, _, _, width = _chord_root(prob, walk["x_lo"], walk["x_hi"], walk["ind_lo"],
                                     walk["ind_hi"], walk["bracketed"].copy(),
                                     lambda summary, ia: summary["ind"], n_iter)
    return xa, walk["bracketed"] & (width < 1e-7)


def _family_bracket(walk, x_end, gap_end, targets, cols=None):
    """The walk's samples on either side of each target gap (gap rises on the walk).

    ``x_end``/``gap_end`` close the walk (rupture or last sample); ``cols`` maps each
    target to its family (default: one family per target).  Returns (x_lo, g_lo, x_hi,
    g_hi), unknowns (m, n) and gaps (n,), with g_lo < target <= g_hi where the walk
    brackets the target.
    """
    xs = np.array([s[0] for s in walk["samples"]] + [x_end])           # (K, m, F)
    gs = np.array([np.where(s[2], s[1], np.nan) for s in walk["samples"]] + [gap_end])
    cols = np.arange(targets.size) if cols is None else cols
    gfill = np.fmax.accumulate(np.nan_to_num(gs, nan=-np.inf), axis=0)[:, cols]
    k = np.clip(np.sum(gfill < targets[None, :], axis=0), 1, xs.shape[0] - 1)
    pts_ = np.arange(targets.size)
    return xs[k - 1, :, cols].T, gfill[k - 1, pts_], xs[k, :, cols].T, gfill[k, pts_]


def _start_on_family(bracket, targets):
    """Starting unknowns for the target gaps: linear in the gap inside the bracket."""
    x0, g0, x1, g1 = bracket
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.clip(np.where(g1 > g0, (targets - g0) / (g1 - g0), 0.0), 0.0, 1.0)
    return (1 - f) * x0 + f * x1


def _rupture_of(prob, x_start, ok_start, gap_stop=None):
    """Walk from stable states to rupture (or to ``gap_stop``) and locate rupture.

    Returns (gap_r, x_r, ok_r, walk); ok_r is False for points that reached gap_stop
    before rupture (their gap_r is NaN: rupture lies beyond).
    """
    walk = _walk(prob, x_start, gap_stop=gap_stop)
    walk["failed"] |= ~ok_start
    x_r, ok = _illinois(prob, walk)
    ok &= ok_start & walk["bracketed"] & ~walk["failed"]
    z = prob.full_z(x_r, np.arange(x_r.shape[1]))
    p = _shape(z[0], z[1], z[2], prob.pts.theta1, prob.pts.theta2, prob.pts.ratio,
               prob.settings.nodes)
    ok &= np.isfinite(p["gap"])
    return np.where(ok, p["gap"], np.nan), x_r, ok, walk


def _solve_on_family(prob, x_start, ok_start, out, idx_out):
    """Safe path: walk the family from stable states towards the target gaps.

    Points whose family reaches the target gap first are solved from the nearest
    sample; the others have their rupture located and are RUPTURED when the target lies
    beyond it (or solved from the rupture end when it does not).
    """
    pts = prob.pts
    d_r, x_r, ok_r, walk = _rupture_of(prob, x_start, ok_start, gap_stop=pts.gap)
    ruptured = ok_r & (pts.gap > d_r)
    _store_ruptured(out, idx_out[ruptured], pts.take(ruptured))
    todo = np.flatnonzero((ok_r & ~ruptured) | (walk["reached"] & ok_start))
    if not todo.size:
        return
    x_end = np.where(ok_r, x_r, walk["x_lo"])
    g_end = np.where(ok_r, d_r, walk["samples"][-1][1])
    bracket = _family_bracket(walk, x_end, g_end, pts.gap)
    x0 = _start_on_family(bracket, pts.gap)[:, todo]
    x, ok, iters, stable = prob.solve(x0, todo)
    good = ok & stable
    if not good.all():
        # next to a fold Newton converges slowly (the Jacobian is nearly singular):
        # find the target gap on the family itself, between the samples around it
        bad = todo[~good]
        xb, okb = _gap_on_family(prob, bracket, bad)
        x[:, ~good], good[~good] = xb, okb
    good = np.flatnonzero(good)
    _store(out, idx_out[todo[good]], prob.full_z(x[:, good], todo[good]),
           pts.take(todo[good]), prob.settings.nodes)
    out["iterations"][idx_out[todo[good]]] = iters[good]


def _gap_on_family(prob, bracket, idx):
    """Family points with the target gap of the points ``idx``: a root of
    target - gap along the chord between the walk's samples that bracket it
    (``bracket`` from :func:`_family_bracket`, one family per point)."""
    N = prob.pts.size
    target = prob.pts.gap
    x_lo, g_lo, x_hi, g_hi = bracket
    f_lo, f_hi = target - g_lo, target - g_hi
    active = np.zeros(N, bool)
    active[idx] = (f_lo[idx] > 0) & (f_hi[idx] <= 0)
    xa, fa, xb, fb, _ = _chord_root(prob, x_lo, x_hi, f_lo, f_hi, active,
                                    lambda summary, ia: target[ia] - summary["gap"])
    use_a = np.abs(fa) <= np.abs(fb)
    x = np.where(use_a, xa, xb)[:, idx]
    err = np.where(use_a, fa, fb)[idx]
    # the family points satisfy the equilibrium (and volume) to Newton's tolerance
    return x, active[idx] & (np.abs(err) < 1e-10 * (1.0 + target[idx]))


def _store_ruptured(out, idx, sub):
    out["status"][idx] = Status.RUPTURED
    out["force"][idx] = 0.0
    out["gap"][idx] = sub.gap
    if sub.volume is not None:
        out["volume"][idx] = sub.volume
    if sub.h is not None:
        out["pressure"][idx] = 2.0 * sub.h


# --------------------------------------------------------------------------------------
# Starting points
# --------------------------------------------------------------------------------------


def _circle_bridge(beta1, gap, t1, t2, R):
    """Bridge with a circular meridian meeting both spheres at their contact angles.

    Closed form (all arguments broadcast): the circle through the contact line on
    grain 1 with the slope of Young's law there, whose signed radius makes it meet
    grain 2 at theta2.  Returns (volume, h, L, beta2, ok), h the mean curvature at the
    arc's midpoint and L its arc length: a starting point for any radius ratio and
    pair of angles (the Derjaguin toroid only knows equal spheres and one angle).
    """
    D = centre_distance(gap, R)
    cb, sb = np.cos(beta1), np.sin(beta1)
    a1 = beta1 + t1
    den = 2.0 * (np.cos(t1) - D * np.cos(a1) - R * np.cos(t2))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        rho = (R * R - 1.0 - D * D + 2.0 * D * cb) / den          # signed meridian radius
        cx = cb + rho * np.cos(a1)
        cy = sb + rho * np.sin(a1)
        w = -((cx - D) + 1j * cy) / (R + rho * np.exp(-1j * t2))
        beta2 = -np.angle(w)
        psi1 = a1 - 0.5 * np.pi
        psi2 = 0.5 * np.pi - beta2 - t2
        L = (psi2 - psi1) * rho
        # smallest radius on the arc (at psi = 0 if the arc passes it, for concave arcs)
        lo, hi = np.minimum(psi1, psi2), np.maximum(psi1, psi2)
        y_ext = np.where((lo < 0) & (hi > 0), cy - rho, np.inf)
        ymin = np.minimum(np.minimum(sb, R * np.sin(beta2)), y_ext)

        def G(p):
            return rho * (cy * cy * np.sin(p) - cy * rho * (p + 0.5 * np.sin(2 * p))
                          + rho * rho * (np.sin(p) - np.sin(p) ** 3 / 3.0))

        vol = np.pi * (G(psi2) - G(psi1)) - cap_volume(1.0, beta1) - cap_volume(R, beta2)
        pm = 0.5 * (psi1 + psi2)
        ym = cy - rho * np.cos(pm)
        h = 0.5 * (np.cos(pm) / ym - 1.0 / rho)
    ok = (np.isfinite(rho) & np.isfinite(vol) & (L > 0) & (beta2 > 0) & (beta2 < 0.5 * np.pi)
          & (ymin > 0) & np.isfinite(h) & (np.abs(rho) < 1e6))
    return vol, h, L, beta2, ok


_GRID = np.concatenate([np.geomspace(1e-3, 0.04, 16), np.linspace(0.05, 1.0, 56)])


def _circle_grid(pts):
    """The circular-meridian bridges on a grid of beta1 (rows: points), geometric below
    4 % of the largest angle so that tiny bridges (V* ~ 1e-8) are resolved."""
    frac = _GRID
    bmax = np.minimum(_BETA1_MAX - 0.02, np.pi - pts.theta1 - 0.2)
    beta = bmax[:, None] * frac
    col = lambda a: np.asarray(a, float)[:, None]  # noqa: E731
    vol, h, L, b2, ok = _circle_bridge(beta, col(pts.gap), col(pts.theta1),
                                       col(pts.theta2), col(pts.ratio))
    return beta, vol, h, L, ok


def _interp_rows(k, f, *arrays):
    """Linear interpolation between columns k and k + 1 with weight f, row by row."""
    rows = np.arange(k.size)
    return [a[rows, k] + f * (a[rows, k + 1] - a[rows, k]) for a in arrays]


def _volume_guess(pts):
    """Starting (h, beta1, L): the circular-meridian bridge holding the volume at the gap
    of ``pts`` (the smallest beta1 that does)."""
    gap, volume = pts.gap, pts.volume
    beta, vol, h, L, ok = _circle_grid(pts)
    n_beta = beta.shape[1]
    v = np.where(ok & (vol > 0), vol, -np.inf)
    above = v >= volume[:, None]
    k = np.where(above.any(1), np.argmax(above, axis=1), n_beta - 1)
    k = np.clip(k - 1, 0, n_beta - 2)
    rows = np.arange(k.size)
    v0, v1 = v[rows, k], v[rows, k + 1]
    # volume ~ beta^4 for small bridges: interpolate log(volume) in log(beta)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(np.isfinite(v0) & (v1 > v0) & (v0 > 0),
                     np.log(volume / v0) / np.log(v1 / v0), 1.0)
    f = np.clip(np.nan_to_num(f, nan=1.0), 0, 1)
    b = np.exp(np.log(beta[rows, k]) + f * np.log(beta[rows, k + 1] / beta[rows, k]))
    _, hh, LL, _, okb = _circle_bridge(b, gap, pts.theta1, pts.theta2, pts.ratio)
    bad = ~(okb & np.isfinite(hh) & np.isfinite(LL) & (LL > 0))
    return np.vstack([np.where(bad, 0.0, hh), b, np.where(bad, 0.1, LL)])


def _suction_guess(pts):
    """Starting (beta1, L) at the fixed mean curvature h of ``pts``: the circular-meridian
    bridge whose midpoint curvature is h, on the branch connected to contact (the
    largest beta1)."""
    gap, h = pts.gap, pts.h
    beta, vol, hg, L, ok = _circle_grid(pts)
    n_beta = beta.shape[1]
    f = np.where(ok, hg - h[:, None], np.nan)
    cross = ((np.sign(f[:, 1:]) != np.sign(f[:, :-1]))
             & np.isfinite(f[:, 1:]) & np.isfinite(f[:, :-1]))
    # prefer crossings with beta1 below 90 degrees (beyond, only if there is none)
    below = beta[:, 1:] < 0.5 * np.pi
    cross = np.where((cross & below).any(1, keepdims=True), cross & below, cross)
    last = np.where(cross.any(1), n_beta - 2 - np.argmax(cross[:, ::-1], axis=1), -1)
    k = np.maximum(last, 0)
    rows = np.arange(k.size)
    f0, f1 = f[rows, k], f[rows, k + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.clip(np.where(f1 != f0, f0 / (f0 - f1), 0.5), 0, 1)
    (b,) = _interp_rows(k, w, beta)
    # no crossing: take the widest valid circle
    kk = np.where(ok.any(1), n_beta - 1 - np.argmax(ok[:, ::-1], axis=1), n_beta // 2)
    b = np.where(last >= 0, b, beta[rows, kk])
    _, _, LL, _, okb = _circle_bridge(b, gap, pts.theta1, pts.theta2, pts.ratio)
    return np.vstack([b, np.where(okb & np.isfinite(LL) & (LL > 0), LL, 0.1)])


# --------------------------------------------------------------------------------------
# Problem set-up shared by the public solvers
# --------------------------------------------------------------------------------------


def _validate_common(theta, ratio, theta2):
    theta = check_range("theta", theta, 0.0, THETA_MAX_DEG, high_open=True, units=" deg",
                        hint="contact angles are supported in [0, 90) degrees")
    theta2 = theta if theta2 is None else check_range(
        "theta2", theta2, 0.0, THETA_MAX_DEG, high_open=True, units=" deg",
        hint="contact angles are supported in [0, 90) degrees")
    ratio = check_range("ratio", ratio, 1.0, RATIO_MAX,
                        hint="ratio = R2/R1 with R1 the smaller (normalising) radius")
    return theta, ratio, theta2


def _make_points(arrays, theta, ratio, theta2):
    b = np.broadcast_arrays(*arrays, theta, ratio, theta2)
    shape = b[0].shape
    flat = [np.ascontiguousarray(a, dtype=float).ravel() for a in b]
    *vals, t1, r, t2 = flat
    return vals, _Points(np.radians(t1), np.radians(t2), r), shape


def _result_arrays(npts):
    nan = np.full(npts, np.nan)
    return {k: nan.copy() for k in ("force", "pressure", "beta1", "beta2", "neck_radius",
                                    "area", "energy", "volume", "gap")} | {
        "status": np.full(npts, int(Status.NOT_CONVERGED), np.int8),
        "iterations": np.zeros(npts, np.int16)}


def _store(out, idx, z, pts, nodes):
    p = _shape(z[0], z[1], z[2], pts.theta1, pts.theta2, pts.ratio, nodes)
    out["force"][idx] = p["force"]
    out["pressure"][idx] = p["pressure"]
    out["beta1"][idx] = np.degrees(p["beta1"])
    out["beta2"][idx] = np.degrees(p["beta2"])
    for k in ("neck_radius", "area", "energy", "volume", "gap"):
        out[k][idx] = p[k]
    out["status"][idx] = Status.CONVERGED


def _finish(out, shape):
    return {k: v.reshape(shape) for k, v in out.items()}


def _groups(pts):
    """Indices of the symmetric and of the other points."""
    s = pts.symmetric
    return [(True, np.flatnonzero(s)), (False, np.flatnonzero(~s))]


# --------------------------------------------------------------------------------------
# Stable starting states: direct solves, else the contact state by continuation
# --------------------------------------------------------------------------------------


#: Newton iterations of a direct solve from a closed-form guess (the family is the
#: fallback: a direct solve that has not converged by then rarely does later)
_DIRECT_ITER = 20


def _guess(pts, fixed_h):
    if fixed_h:
        return _suction_guess(pts)
    return _volume_guess(pts)


def _contact_state(pts, sym, settings, fixed_h, n_continuation=10):
    """Equilibrium at touching grains (d* = 0): the widest bridge of the family.

    Started from the toroidal bridge; where that fails or lands on another branch, the
    contact angles are raised step by step from min(theta, 30 deg) and the radius ratio
    from 1, each solve starting from the last.  Returns (x, ok, stable): a converged
    contact state may be unstable under suction control (convex bridges at P* > 0:
    then no stable bridge exists at that pressure).
    """
    p0 = dataclasses.replace(pts, gap=np.zeros(pts.size))
    x, ok, _, stable = _Problem(p0, sym, settings, fixed_h).solve(_guess(p0, fixed_h))
    bad = np.flatnonzero(~(ok & stable))
    if bad.size:
        pb = p0.take(bad)
        start = np.radians(30.0)
        xb = None
        for f in np.linspace(0.0, 1.0, n_continuation):
            pc = dataclasses.replace(
                pb, theta1=np.minimum(pb.theta1, start) + f * np.maximum(pb.theta1 - start, 0),
                theta2=np.minimum(pb.theta2, start) + f * np.maximum(pb.theta2 - start, 0),
                ratio=1.0 + f * (pb.ratio - 1.0))
            if xb is None:
                xb = _guess(pc, fixed_h)
            xn, okb, _, stb = _Problem(pc, sym, settings, fixed_h).solve(xb)
            xb = np.where(okb, xn, xb)
        take = okb & (stb | ~stable[bad])
        x[:, bad[take]] = xb[:, take]
        ok[bad[take]] = True
        stable[bad[take]] = stb[take]
    return x, ok, stable & ok


def _stable_starts(pts, sym, settings, fixed_h, fraction=0.6):
    """Stable states below the target gaps: a direct solve at ``fraction`` of the gap,
    else the contact state.  Returns (x, ok, no_branch); no_branch marks points whose
    contact state is unstable (no stable branch at all)."""
    ps = dataclasses.replace(pts, gap=fraction * pts.gap)
    x, ok, _, stable = _Problem(ps, sym, settings, fixed_h).solve(_guess(ps, fixed_h),
                                                                  max_iter=_DIRECT_ITER)
    ok &= stable
    no_branch = np.zeros(pts.size, bool)
    bad = np.flatnonzero(~ok)
    if bad.size:
        xc, okc, stc = _contact_state(pts.take(bad), sym, settings, fixed_h)
        x[:, bad] = xc
        ok[bad] = stc
        no_branch[bad] = okc & ~stc
    return x, ok, no_branch


def _near_rupture(pts, fixed_h):
    """Points for which a direct solve from the closed-form guess is not trusted.

    Near rupture the toroidal guess is poor and Newton can land on another branch of
    equilibria (thinner neck, larger curvature) on which the stability determinants
    are positive again (an even number of unstable modes).  Those points are solved by
    continuation in the gap from half their gap.  Far from rupture (d* below a quarter
    of Lian's estimate) the direct solve is safe.
    """
    if fixed_h:
        return pts.gap > 0
    theta = 0.5 * (pts.theta1 + pts.theta2)
    return pts.gap > 0.25 * (1.0 + 0.5 * theta) * np.cbrt(pts.volume)


def _solve_batch(idx, pts, sym, settings, fixed_h, out):
    """Fill ``out`` for the points ``idx`` (all symmetric or all not).

    Far from rupture: one Newton solve from the closed-form guess.  Near rupture: a
    solve at half the gap, then a predictor-corrector step along the family to the
    target (the family's tangent per unit gap comes from the last Jacobian).  Points
    that neither path places on the stable branch are solved on the family itself.
    """
    sub = pts.take(idx)
    N = sub.size
    prob = _Problem(sub, sym, settings, fixed_h)
    x = np.full((prob.m, N), np.nan)
    done = np.zeros(N, bool)
    iters = np.zeros(N, int)
    x_start = np.full((prob.m, N), np.nan)
    ok_start = np.zeros(N, bool)
    near = _near_rupture(sub, fixed_h)
    far = np.flatnonzero(~near)
    if far.size:
        xf, okf, itf, stf = prob.solve(_guess(sub.take(far), fixed_h), far,
                                       max_iter=_DIRECT_ITER)
        x[:, far], done[far], iters[far] = xf, okf & stf, itf
    nr = np.flatnonzero(near)
    if nr.size:
        half = dataclasses.replace(sub.take(nr), gap=0.5 * sub.gap[nr])
        ph = _Problem(half, sym, settings, fixed_h)
        xh, okh, ith, sth, rate = ph.solve_with_rate(_guess(half, fixed_h),
                                                     max_iter=_DIRECT_ITER)
        okh &= sth & np.isfinite(rate).all(axis=0)
        x_start[:, nr[okh]], ok_start[nr[okh]] = xh[:, okh], True
        go = np.flatnonzero(okh)
        if go.size:
            xp = xh[:, go] + 0.5 * half.gap[go] * rate[:, go]
            xn, okn, itn, stn = prob.solve(xp, nr[go], max_iter=_DIRECT_ITER)
            # the corrector must stay near the predictor (same branch)
            close = np.max(np.abs(xn - xp) / prob.scale_of(xh[:, go]), axis=0) < 0.5
            acc = okn & stn & close
            tgt = nr[go[acc]]
            x[:, tgt], done[tgt], iters[tgt] = xn[:, acc], True, ith[go[acc]] + itn[acc]
    good = np.flatnonzero(done)
    _store(out, idx[good], prob.full_z(x[:, good], good), sub.take(good), settings.nodes)
    out["iterations"][idx[good]] = iters[good]
    rest = np.flatnonzero(~done)
    if rest.size:
        rsub = sub.take(rest)
        have = ok_start[rest]
        x_s, ok_s = x_start[:, rest], have.copy()
        need = np.flatnonzero(~have)
        no_branch = np.zeros(rest.size, bool)
        if need.size:
            xs2, oks2, nb2 = _stable_starts(rsub.take(need), sym, settings, fixed_h)
            x_s[:, need], ok_s[need], no_branch[need] = xs2, oks2, nb2
        _store_ruptured(out, idx[rest[no_branch]], rsub.take(no_branch))
        _solve_on_family(_Problem(rsub, sym, settings, fixed_h), x_s, ok_s, out, idx[rest])


def _solve_suction_batch(idx, pts, sym, settings, out):
    """Suction control: every point is solved on its family at fixed pressure.

    Far beyond the largest gap at a given pressure, equilibria of other branches exist
    whose stability determinant is positive too, and a direct solve cannot tell them
    from the stable one; so the family of each distinct (P*, theta1, theta2, ratio) is
    walked once from contact to its largest gap (shared by all the gaps asked at that
    pressure, as in a table), and each target gap is solved from the nearest sample.
    """
    sub = pts.take(idx)
    keys = np.stack([sub.h, sub.theta1, sub.theta2, sub.ratio], axis=1)
    uk, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.ravel()
    pu = _Points(uk[:, 1], uk[:, 2], uk[:, 3], gap=np.zeros(len(uk)), h=uk[:, 0])
    x_c, ok_c, st_c = _contact_state(pu, sym, settings, True)
    prob_u = _Problem(pu, sym, settings, True)
    d_max, x_r, ok_r, walk = _rupture_of(prob_u, x_c, st_c)
    no_bridge = (ok_c & ~st_c)[inv] | (ok_r[inv] & (sub.gap > d_max[inv]))
    _store_ruptured(out, idx[no_bridge], sub.take(no_bridge))
    todo = np.flatnonzero(ok_r[inv] & ~no_bridge)
    if not todo.size:
        return
    x0 = _start_on_family(_family_bracket(walk, x_r, d_max, sub.gap[todo], cols=inv[todo]),
                          sub.gap[todo])
    prob = _Problem(sub, sym, settings, True)
    x, ok, iters, stable = prob.solve(x0, todo)
    good = np.flatnonzero(ok & stable)
    _store(out, idx[todo[good]], prob.full_z(x[:, good], todo[good]),
           sub.take(todo[good]), settings.nodes)
    out["iterations"][idx[todo[good]]] = iters[good]


def _rupture_batch(idx, pts, sym, settings, fixed_h, out):
    sub = pts.take(idx)
    x_c, ok_c, st_c = _contact_state(sub, sym, settings, fixed_h)
    prob = _Problem(sub, sym, settings, fixed_h)
    d_r, x_r, ok, _ = _rupture_of(prob, x_c, st_c)
    good = np.flatnonzero(ok)
    _store(out, idx[good], prob.full_z(x_r[:, good], good), sub.take(good), settings.nodes)
    # no stable bridge at any gap (suction control at some P* > 0)
    none = np.flatnonzero(ok_c & ~st_c)
    out["status"][idx[none]] = Status.RUPTURED
    out["force"][idx[none]] = 0.0


# --------------------------------------------------------------------------------------
# Public solvers
# --------------------------------------------------------------------------------------


def solve_doublet(gap, volume, theta, ratio=1.0, theta2=None, settings=None):
    """Liquid bridge of given volume between two spheres, on the stable branch.

    Parameters
    ----------
    gap : array_like
        Gap between the sphere surfaces d* = d / R1 [-], >= 0.
    volume : array_like
        Liquid volume V* = V / R1^3 [-], > 0.
    theta : array_like
        Contact angle on sphere 1 [deg], in [0, 90).
    ratio : array_like, default 1
        Radius ratio R2 / R1 in [1, 10] (R1, the smaller, normalises everything).
    theta2 : array_like, optional
        Contact angle on sphere 2 [deg]; defaults to ``theta``.
    settings : SolverSettings, optional

    Returns
    -------
    dict of arrays broadcast to the inputs' shape:
        force F* = F / (2 pi gamma R1) (attraction > 0), pressure P* = dp R1 / gamma,
        beta1, beta2 half filling angles [deg], neck_radius [-], area (liquid-gas) [-],
        energy E* = A - cos t1 A_w1 - cos t2 A_w2 [-], volume, gap, status
        (capbridge.status.Status), iterations.  Beyond rupture: status RUPTURED and
        force 0 (gap and volume echo the input, the rest NaN).

    Notes
    -----
    The stable branch ends at :func:`rupture_distance`; for equal spheres and angles
    with theta > 0 that is the symmetry-breaking point, which comes before the fold of
    the symmetric family (module docstring).

    Examples
    --------
    Small bridges at contact pull with F* -> cos(theta) (Israelachvili):

    >>> r = solve_doublet(0.0, 1e-7, 30.0)
    >>> round(float(r["force"]) / np.cos(np.radians(30.0)), 2)
    0.99
    """
    settings = settings or SolverSettings()
    gap = _check_gap(gap)
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta, ratio, theta2 = _validate_common(theta, ratio, theta2)
    (g, v), pts, shape = _make_points([gap, volume], theta, ratio, theta2)
    pts.gap, pts.volume = g, v
    out = _result_arrays(g.size)
    for sym, idx in _groups(pts):
        if idx.size:
            _solve_batch(idx, pts, sym, settings, False, out)
    return _finish(out, shape)


def rupture_distance(volume, theta, ratio=1.0, theta2=None, settings=None):
    """Rupture distance d*_rupt(V*): the end of the stable branch at fixed volume.

    Returns a dict with ``gap`` (d*_rupt) and the bridge at rupture (force, pressure,
    beta1, beta2 [deg], neck_radius, area, energy, volume, status, iterations).

    >>> r = rupture_distance(0.01, 0.0)
    >>> round(float(r["gap"]), 3)     # Lian et al. 1993: (1 + theta/2) V*^(1/3) = 0.215
    0.219
    """
    settings = settings or SolverSettings()
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta, ratio, theta2 = _validate_common(theta, ratio, theta2)
    (v,), pts, shape = _make_points([volume], theta, ratio, theta2)
    pts.volume = v
    out = _result_arrays(v.size)
    for sym, idx in _groups(pts):
        if idx.size:
            _rupture_batch(idx, pts, sym, settings, False, out)
    return _finish(out, shape)


def _check_gap(gap):
    return check_range("gap d*", gap, 0.0, np.inf,
                       hint="d* is the gap between the sphere surfaces; "
                            "overlapping grains are not supported")


def _check_pressure(pressure):
    return check_range("pressure P*", pressure, -np.inf, np.inf,
                       hint="P* = dp R1 / gamma must be finite (negative for suction)")


def solve_doublet_suction(gap, pressure, theta, ratio=1.0, theta2=None, settings=None):
    """Liquid bridge at given Laplace pressure (suction control), on the stable branch.

    The branch is the one connected to contact (the wider neck: at fixed pressure the
    gap falls as the filling angle grows on it); it ends at the largest gap that
    pressure allows (:func:`suction_rupture_distance`), beyond which the status is
    RUPTURED and the force 0.  A bridge solved at fixed volume has the same shape at
    its own pressure only while it is on that branch (small gaps): further out it is
    unstable under pressure control, and this function returns the wider bridge.

    The family of each distinct (pressure, theta, theta2, ratio) is computed once and
    shared by all the gaps asked at that pressure, so grids of suction x gap (YADE's
    tables) cost little more than their number of pressures.

    Positive pressures: where the contact state itself is unstable under pressure
    control (convex bridges at large angles) no bridge is on the branch and every gap
    is RUPTURED; where no contact state exists at that pressure (P* above the largest
    contact pressure, e.g. P* > ~1 at theta = 40 deg) the points are NOT_CONVERGED.
    Both cases are absent for P* <= 0 (suction).

    Parameters
    ----------
    gap : array_like
        d* = d / R1 [-], >= 0.
    pressure : array_like
        P* = dp R1 / gamma [-], dp = p_liquid - p_gas (negative for suction).  YADE's
        suction s* = -dp R2/gamma (normalised by the larger radius) is
        -pressure * ratio.
    theta, ratio, theta2, settings
        As in :func:`solve_doublet`.

    Returns
    -------
    dict with the keys of :func:`solve_doublet`; ``volume`` is an output.

    Examples
    --------
    The suction solve at the pressure of a volume solve returns that volume:

    >>> r = solve_doublet(0.05, 0.01, 20.0)
    >>> s = solve_doublet_suction(0.05, r["pressure"], 20.0)
    >>> round(float(s["volume"]), 6)
    0.01
    """
    settings = settings or SolverSettings()
    gap = _check_gap(gap)
    pressure = _check_pressure(pressure)
    theta, ratio, theta2 = _validate_common(theta, ratio, theta2)
    (g, p), pts, shape = _make_points([gap, pressure], theta, ratio, theta2)
    pts.gap, pts.h = g, 0.5 * p
    out = _result_arrays(g.size)
    for sym, idx in _groups(pts):
        if idx.size:
            _solve_suction_batch(idx, pts, sym, settings, out)
    return _finish(out, shape)


def suction_rupture_distance(pressure, theta, ratio=1.0, theta2=None, settings=None):
    """Largest gap with a stable bridge at given Laplace pressure P* (suction control).

    Returns a dict with ``gap`` and the bridge there (keys of :func:`solve_doublet`);
    status RUPTURED (gap NaN) where no bridge is stable at that pressure, NOT_CONVERGED
    where no contact state was found (see :func:`solve_doublet_suction`).

    >>> r = suction_rupture_distance(-2.0, 0.0)
    >>> bool(r["status"] == 0) and float(r["gap"]) > 0
    True
    """
    settings = settings or SolverSettings()
    pressure = _check_pressure(pressure)
    theta, ratio, theta2 = _validate_common(theta, ratio, theta2)
    (p,), pts, shape = _make_points([pressure], theta, ratio, theta2)
    pts.h = 0.5 * p
    out = _result_arrays(p.size)
    for sym, idx in _groups(pts):
        if idx.size:
            _rupture_batch(idx, pts, sym, settings, True, out)
    return _finish(out, shape)
