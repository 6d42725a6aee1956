"""Exact axisymmetric liquid bridge between two spheres (Young-Laplace, no gravity).

The meridian of an axisymmetric surface of constant mean curvature ``h = P*/2`` is a
Delaunay roulette.  Written in arc length ``s`` from its point of smallest radius ``n``
(the neck; Kenmotsu's representation, rearranged so that it is regular as h -> 0):

    S(s) = sin(h s) / h          (= s for h = 0)
    y(s)^2 = n^2 + B S^2,        B = 1 - 2 h n = sqrt(1 - 4 h F*)
    dx/ds = (n + B h S^2) / y
    y cos(psi) - h y^2 = F*      (first integral: the axial force, constant along y)

so a profile is fixed by two numbers (h, F*) and every integral along it (axial length,
volume, area) is a smooth quadrature.  With ``s = n sinh(u)`` the integrands stay smooth
even for slender necks, and Gauss-Legendre quadrature converges spectrally.

Sphere 1 (radius 1, the normalising radius) is centred at x = 0, sphere 2 (radius
``ratio`` >= 1) at x = 1 + ratio + d*.  The contact line on sphere i sits at half filling
angle beta_i; Young's law fixes the meridian's slope there:

    psi_1 = beta_1 + theta_1 - pi/2,   psi_2 = pi/2 - beta_2 - theta_2
    F* = sin b1 sin(b1 + t1) - h sin^2 b1 = R sin b2 sin(b2 + t2) - h R^2 sin^2 b2

Unknowns (h, beta_1[, beta_2]) are found by a vectorised damped Newton method on the gap,
the volume (or the pressure, for suction control) and the force balance, many points at
once.  The stable branch is the one on which the gap decreases as the neck widens at
fixed volume; the rupture distance d*_rupt(V*) is the end of that branch (the fold of
d* along the family of equilibria at fixed V*).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from capbridge.status import Status
from capbridge.validation import check_range

#: Gauss-Legendre nodes used by default (error < 1e-10 relative in F*, V*; see tests).
DEFAULT_NODES = 48
THETA_MAX_DEG = 90.0
RATIO_MAX = 10.0


@dataclasses.dataclass(frozen=True)
class SolverSettings:
    """Numerical settings of the exact solver (written into every table)."""

    nodes: int = DEFAULT_NODES       #: Gauss-Legendre nodes along the meridian
    tol: float = 1e-12               #: Newton tolerance on the scaled residuals
    max_iter: int = 60               #: Newton iterations before a point is flagged

    def as_dict(self):
        return dataclasses.asdict(self)


def _cap_volume(radius, beta):
    """Volume of the spherical cap of half-angle ``beta``, free of cancellation.

    pi R^3 (1 - cos b)^2 (2 + cos b) / 3 with 1 - cos b = 2 sin^2(b/2): accurate to
    round-off even for tiny caps on large spheres (the textbook form loses ~1/b^4).
    """
    v = 2.0 * np.sin(0.5 * beta) ** 2
    return np.pi * radius**3 * v * v * (2.0 + np.cos(beta)) / 3.0


def _cap_area(radius, beta):
    """Area of the spherical cap of half-angle ``beta``: 4 pi R^2 sin^2(b/2)."""
    return 4.0 * np.pi * radius**2 * np.sin(0.5 * beta) ** 2


_GL_CACHE: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _gauss_legendre(n):
    if n not in _GL_CACHE:
        _GL_CACHE[n] = np.polynomial.legendre.leggauss(n)
    return _GL_CACHE[n]


# --------------------------------------------------------------------------------------
# The profile between two contact lines
# --------------------------------------------------------------------------------------


def _arc_position(n, B, h, y, psi):
    """Arc length s from the neck of the point (y, psi) on the roulette (n, B, h)."""
    a = y * np.sin(psi)
    b = n - y * np.cos(psi)
    k = np.divide(2.0 * h, B, out=np.full_like(B, np.inf), where=B > 0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        g = np.where(k == 0.0, a, np.arctan2(k * a, 1.0 + k * b) / np.where(k == 0.0, 1.0, k))
        return g / B


def bridge_profile(h, beta1, beta2, theta1, theta2, ratio, nodes=DEFAULT_NODES):
    """Gap, volume, force and shape of the bridge fixed by (h, beta1, beta2).

    All arguments in radians / dimensionless, broadcast together.  ``beta2`` must make
    the force balance hold (it does by symmetry for equal spheres and angles); the
    returned ``force_balance`` residual says how well it does.
    Returns a dict of arrays; ``feasible`` is False where no such profile exists.
    """
    h, beta1, beta2, theta1, theta2, ratio = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (h, beta1, beta2, theta1, theta2, ratio)))
    R = ratio
    y1 = np.sin(beta1)
    y2 = R * np.sin(beta2)
    psi1 = beta1 + theta1 - 0.5 * np.pi
    psi2 = 0.5 * np.pi - beta2 - theta2
    F1 = y1 * np.cos(psi1) - h * y1**2
    F2 = y2 * np.cos(psi2) - h * y2**2
    F = F1
    disc = 1.0 - 4.0 * h * F
    feasible = (disc >= 0.0) & (F > 0.0) & (beta1 > 0) & (beta2 > 0)
    B = np.sqrt(np.where(disc > 0, disc, 0.0))
    n = 2.0 * F / (1.0 + B)
    nn = np.where(feasible, n, 1.0)
    s1 = _arc_position(nn, B, h, y1, psi1)
    s2 = _arc_position(nn, B, h, y2, psi2)
    ds = s2 - s1
    period = np.pi / np.maximum(np.abs(h), 1e-300)
    ds = np.where((ds < 0) & (h != 0), ds + period, ds)
    s2 = s1 + ds
    feasible &= np.isfinite(ds) & (ds > 0)
    # substitution s = n sinh(u) keeps the integrands smooth through slender necks
    u1 = np.arcsinh(s1 / nn)
    u2 = np.arcsinh(s2 / nn)
    t, w = _gauss_legendre(nodes)
    half = 0.5 * (u2 - u1)
    u = (u1 + half)[..., None] + half[..., None] * t
    s = nn[..., None] * np.sinh(u)
    jac = nn[..., None] * np.cosh(u) * half[..., None]
    hh = h[..., None]
    S = s * np.sinc(hh * s / np.pi)
    y = np.sqrt(nn[..., None] ** 2 + B[..., None] * S**2)
    dxds = (nn[..., None] + B[..., None] * hh * S**2) / y
    wj = w * jac
    length = np.sum(wj * dxds, axis=-1)
    vol_rev = np.pi * np.sum(wj * y**2 * dxds, axis=-1)
    area = 2.0 * np.pi * np.sum(wj * y, axis=-1)
    # cos b - 1 = -2 sin^2(b/2): no cancellation for small caps on large spheres
    gap = length - 2.0 * np.sin(0.5 * beta1) ** 2 - 2.0 * R * np.sin(0.5 * beta2) ** 2
    volume = vol_rev - _cap_volume(1.0, beta1) - _cap_volume(R, beta2)
    wet1 = _cap_area(1.0, beta1)
    wet2 = _cap_area(R, beta2)
    energy = area - np.cos(theta1) * wet1 - np.cos(theta2) * wet2
    bad = ~feasible
    out = dict(gap=gap, volume=volume, force=F, pressure=2.0 * h, neck_parameter=n,
               area=area, energy=energy, force_balance=F2 - F1, feasible=feasible)
    # the neck (y = n) lies on the bridge only if the arc passes s = 0
    out["neck_radius"] = np.where((s1 < 0) & (s2 > 0), n, np.minimum(y1, y2))
    for key in ("gap", "volume", "neck_radius", "area", "energy"):
        out[key] = np.where(bad, np.nan, out[key])
    return out


# --------------------------------------------------------------------------------------
# Vectorised damped Newton method
# --------------------------------------------------------------------------------------


def _residual_norm(r):
    return np.max(np.abs(r), axis=0)


_MAX_STEP = [2.0, 0.2, 0.2]  # largest Newton step in h, beta1, beta2
_NOISE_FLOOR = 1e-8  # residuals below this may be round-off (see _newton)


def _newton(fun, x, *, tol, max_iter, max_step):
    """Solve fun(x) = 0 for many independent points at once.

    ``x`` has shape (m, N): m unknowns for N points; ``fun(x, idx)`` maps the unknowns
    of the points ``idx`` to residuals of the same shape (NaN where the profile does
    not exist).  The Jacobian is taken by
    forward differences; steps are clipped to ``max_step`` (per unknown) and halved
    until the residual decreases.  Returns (x, converged, iterations).
    """
    x = np.array(x, float)
    m, npts = x.shape
    r = fun(x, np.arange(npts))
    norm = _residual_norm(r)
    conv = norm < tol
    iters = np.zeros(npts, int)
    max_step = np.asarray(max_step, float).reshape(m, 1)
    for _ in range(max_iter):
        todo = ~conv & np.isfinite(norm)
        if not todo.any():
            break
        ia = np.flatnonzero(todo)
        xa, ra = x[:, todo], r[:, todo]
        jac = np.empty((xa.shape[1], m, m))
        for j in range(m):
            eps = 1e-7 * (1.0 + np.abs(xa[j]))
            xp = xa.copy()
            xp[j] += eps
            jac[:, :, j] = ((fun(xp, ia) - ra) / eps).T
        det = np.linalg.det(jac)
        singular = ~np.isfinite(det) | (np.abs(det) < 1e-300)
        jac[singular] = np.eye(m)
        dx = -np.linalg.solve(jac, ra.T[..., None])[..., 0].T
        dx[:, singular] = np.nan
        # at the round-off floor of the residuals (relative volume of a tiny bridge on a
        # big sphere: ~1e-12) the Newton correction itself is the measure: accept the
        # point once it would move x by less than 1e-13 relative
        floor = ~singular & (norm[todo] < _NOISE_FLOOR) & np.all(
            np.abs(dx) <= 1e-13 * (1.0 + np.abs(xa)), axis=0)
        if floor.any():
            conv[ia[floor]] = True
            iters[ia[floor]] += 1
            keep = ~floor
            ia, xa, ra, jac, dx = ia[keep], xa[:, keep], ra[:, keep], jac[keep], dx[:, keep]
            todo = np.zeros(npts, bool)
            todo[ia] = True
            if not ia.size:
                break
        scale = np.min(np.where(np.abs(dx) > max_step, max_step / np.abs(dx), 1.0), axis=0)
        dx *= scale
        lam = np.ones(xa.shape[1])
        accepted = np.zeros(xa.shape[1], bool)
        na = norm[todo]
        xnew, rnew, nnew = xa.copy(), ra.copy(), na.copy()
        for _bt in range(12):
            trial = ~accepted & np.isfinite(dx).all(axis=0)
            if not trial.any():
                break
            xt = xa[:, trial] + lam[trial] * dx[:, trial]
            rt = fun(xt, ia[trial])
            nt = _residual_norm(rt)
            ok = np.isfinite(nt) & ((nt < (1 - 1e-4 * lam[trial]) * na[trial]) | (nt < tol))
            idx = np.flatnonzero(trial)[ok]
            xnew[:, idx], rnew[:, idx], nnew[idx] = xt[:, ok], rt[:, ok], nt[ok]
            accepted[idx] = True
            lam[trial] *= 0.5
        # a point that cannot decrease its residual is stalled: leave it unconverged
        stalled = ~accepted
        nnew[stalled] = np.nan
        x[:, todo], r[:, todo], norm[todo] = xnew, rnew, nnew
        iters[todo] += 1
        conv |= norm < tol
    return x, conv, iters


# --------------------------------------------------------------------------------------
# Starting points: the toroidal (circular-meridian) approximation
# --------------------------------------------------------------------------------------


def _toroidal_volume(beta, gap, theta, nodes=24):
    """Volume and mean curvature of the toroidal bridge between unit spheres."""
    c = np.cos(beta + theta)
    rho1 = (1.0 - np.cos(beta) + 0.5 * gap) / c
    rho2 = np.sin(beta) - rho1 * (1.0 - np.sin(beta + theta))
    w = rho1 * c
    t, wt = _gauss_legendre(nodes)
    x = 0.5 * w[..., None] * (t + 1.0)
    y = rho2[..., None] + rho1[..., None] - np.sqrt(np.maximum(rho1[..., None] ** 2 - x**2, 0))
    vol = 2.0 * np.pi * 0.5 * w * np.sum(wt * y**2, axis=-1) - 2.0 * _cap_volume(1.0, beta)
    h = 0.5 * (1.0 / rho2 - 1.0 / rho1)
    ok = (rho2 > 0) & (c > 0)
    return np.where(ok, vol, np.nan), np.where(ok, h, np.nan)


def _toroidal_guess(gap, volume, theta, n_beta=160):
    """(h, beta) of the toroidal bridge holding ``volume`` at ``gap`` (equal spheres)."""
    gap, volume, theta = np.broadcast_arrays(gap, volume, theta)
    frac = np.linspace(0.01, 0.99, n_beta)
    bmax = np.clip(0.5 * np.pi - theta - 0.02, 0.05, None)
    beta = bmax[..., None] * frac
    vol, h = _toroidal_volume(beta, gap[..., None], theta[..., None])
    vol = np.where(np.isfinite(vol), vol, -np.inf)
    # first beta on the grid whose toroidal volume reaches the target
    above = vol >= volume[..., None]
    k = np.where(above.any(-1), np.argmax(above, axis=-1), n_beta - 1)
    k0 = np.maximum(k - 1, 0)
    take = lambda a, i: np.take_along_axis(a, i[..., None], -1)[..., 0]  # noqa: E731
    v0, v1 = take(vol, k0), take(vol, k)
    b0, b1 = take(beta, k0), take(beta, k)
    f = np.clip(np.where(np.isfinite(v0) & (v1 > v0), (volume - v0) / (v1 - v0), 1.0), 0, 1)
    b = b0 + f * (b1 - b0)
    _, hb = _toroidal_volume(b, gap, theta)
    return hb, b


# --------------------------------------------------------------------------------------
# Problem set-up shared by the public solvers
# --------------------------------------------------------------------------------------


@dataclasses.dataclass
class _Case:
    """Flattened, validated inputs (radians) of a batch of doublets."""

    shape: tuple
    theta1: np.ndarray
    theta2: np.ndarray
    ratio: np.ndarray

    @property
    def symmetric(self):
        return (self.ratio == 1.0) & (self.theta1 == self.theta2)

    def take(self, idx):
        return self.theta1[idx], self.theta2[idx], self.ratio[idx]


def _validate_common(theta, ratio, theta2):
    theta = check_range("theta", theta, 0.0, THETA_MAX_DEG, high_open=True, units=" deg",
                        hint="contact angles are supported in [0, 90) degrees")
    theta2 = theta if theta2 is None else check_range(
        "theta2", theta2, 0.0, THETA_MAX_DEG, high_open=True, units=" deg",
        hint="contact angles are supported in [0, 90) degrees")
    ratio = check_range("ratio", ratio, 1.0, RATIO_MAX,
                        hint="ratio = R2/R1 with R1 the smaller (normalising) radius")
    return theta, ratio, theta2


def _make_case(arrays, theta, ratio, theta2):
    b = np.broadcast_arrays(*arrays, theta, ratio, theta2)
    shape = b[0].shape
    flat = [np.ascontiguousarray(a, dtype=float).ravel() for a in b]
    *vals, t1, r, t2 = flat
    return vals, _Case(shape, np.radians(t1), np.radians(t2), r)


def _equivalent_guess(gap, volume, case, idx):
    """Starting (h, beta1, beta2) from the toroidal bridge between equivalent spheres.

    Unequal spheres are replaced by equal ones of the harmonic-mean radius (Derjaguin),
    with the contact-line radius shared by both grains.
    """
    t1, t2, R = case.take(idx)
    reff = 2.0 * R / (1.0 + R)
    h, b = _toroidal_guess(gap / reff, volume / reff**3, 0.5 * (t1 + t2))
    a = reff * np.sin(b)
    b1 = np.arcsin(np.clip(a, 0, 1))
    b2 = np.arcsin(np.clip(a / R, 0, 1))
    return h / reff, b1, b2


def _unknowns(h, b1, b2, sym):
    return np.vstack([h, b1]) if sym else np.vstack([h, b1, b2])


def _split(x, sym):
    return (x[0], x[1], x[1]) if sym else (x[0], x[1], x[2])


def _volume_problem(gap_t, vol_t, case, sub, sym, nodes):
    """Residuals (gap, relative volume[, force balance]) for points ``sub`` of a batch."""
    t1, t2, R = case.take(sub)

    def fun(x, idx):
        h, b1, b2 = _split(x, sym)
        p = bridge_profile(h, b1, b2, t1[idx], t2[idx], R[idx], nodes)
        res = [p["gap"] - gap_t[idx], p["volume"] / vol_t[idx] - 1.0]
        if not sym:
            res.append(p["force_balance"])
        res = np.vstack(res)
        res[:, ~p["feasible"]] = np.nan
        return res

    return fun


def _branch_slope(x, vol_t, case, sub, sym, nodes):
    """d(gap)/d(neck) along the equilibria at fixed volume: < 0 on the stable branch."""
    t1, t2, R = case.take(sub)

    def g(xx):
        p = bridge_profile(*_split(xx, sym), t1, t2, R, nodes)
        rows = [p["gap"], p["neck_parameter"], p["volume"] / vol_t]
        if not sym:
            rows.append(p["force_balance"])
        return np.vstack(rows)

    g0 = g(x)
    m = x.shape[0]
    jac = np.empty((x.shape[1], m + 1, m))
    for j in range(m):
        eps = 1e-6 * (1.0 + np.abs(x[j]))
        xp = x.copy()
        xp[j] += eps
        jac[:, :, j] = ((g(xp) - g0) / eps).T
    # tangent of {volume = const, force balance = 0}: null vector of those rows
    if sym:
        tangent = np.stack([-jac[:, 2, 1], jac[:, 2, 0]], axis=1)
    else:
        tangent = np.cross(jac[:, 2, :], jac[:, 3, :])
    dgap = np.einsum("nj,nj->n", jac[:, 0, :], tangent)
    dneck = np.einsum("nj,nj->n", jac[:, 1, :], tangent)
    return dgap / dneck


def _result_arrays(npts):
    nan = np.full(npts, np.nan)
    return {k: nan.copy() for k in ("force", "pressure", "beta1", "beta2", "neck_radius",
                                    "area", "energy", "volume", "gap")} | {
        "status": np.full(npts, int(Status.NOT_CONVERGED), np.int8),
        "iterations": np.zeros(npts, np.int16)}


def _store(out, idx, h, b1, b2, case, nodes):
    t1, t2, R = case.take(idx)
    p = bridge_profile(h, b1, b2, t1, t2, R, nodes)
    out["force"][idx] = p["force"]
    out["pressure"][idx] = p["pressure"]
    out["beta1"][idx] = np.degrees(b1)
    out["beta2"][idx] = np.degrees(b2)
    for k in ("neck_radius", "area", "energy", "volume", "gap"):
        out[k][idx] = p[k]
    out["status"][idx] = Status.CONVERGED


# --------------------------------------------------------------------------------------
# The family of equilibria at fixed volume, and its end: rupture
# --------------------------------------------------------------------------------------


def _family_point(neck, vol_t, case, sub, sym, x0, settings):
    """Equilibrium of the fixed-volume family whose Delaunay neck radius is ``neck``.

    The neck radius falls monotonically from contact to pinch-off along the family,
    through the fold, so it parametrises the whole family (beta does not: it turns).
    Returns (x, gap, ok).
    """
    t1, t2, R = case.take(sub)

    def fun(x, idx):
        h, b1, b2 = _split(x, sym)
        p = bridge_profile(h, b1, b2, t1[idx], t2[idx], R[idx], settings.nodes)
        res = [p["neck_parameter"] - neck[idx], p["volume"] / vol_t[idx] - 1.0]
        if not sym:
            res.append(p["force_balance"])
        res = np.vstack(res)
        res[:, ~p["feasible"]] = np.nan
        return res

    x, ok, _ = _newton(fun, x0, tol=settings.tol, max_iter=settings.max_iter,
                       max_step=_MAX_STEP[: x0.shape[0]])
    h, b1, b2 = _split(x, sym)
    gap = bridge_profile(h, b1, b2, t1, t2, R, settings.nodes)["gap"]
    return x, np.where(ok, gap, np.nan), ok


def _contact_state(volume, case, sub, sym, settings, n_continuation=12):
    """Equilibrium at touching grains (d* = 0): the widest bridge of the family.

    Started from the toroidal bridge; where that start is too far off (large contact
    angles give convex bridges the toroid cannot represent) the contact angles are
    raised step by step from 40 degrees, each solve starting from the last.
    """
    gap_t = np.zeros(sub.size)
    h, b1, b2 = _equivalent_guess(gap_t, volume, case, sub)
    fun = _volume_problem(gap_t, volume, case, sub, sym, settings.nodes)
    x, ok, _ = _newton(fun, _unknowns(h, b1, b2, sym), tol=settings.tol,
                       max_iter=settings.max_iter, max_step=_MAX_STEP[: 2 if sym else 3])
    bad = np.flatnonzero(~ok)
    if bad.size:
        t1, t2, R = case.take(sub[bad])
        start = np.radians(40.0)
        xb = None
        for f in np.linspace(0.0, 1.0, n_continuation):
            c = _Case((bad.size,), np.minimum(t1, start) + f * np.maximum(t1 - start, 0),
                      np.minimum(t2, start) + f * np.maximum(t2 - start, 0), R)
            idx = np.arange(bad.size)
            if xb is None:
                xb = _unknowns(*_equivalent_guess(gap_t[bad], volume[bad], c, idx), sym)
            fun = _volume_problem(gap_t[bad], volume[bad], c, idx, sym, settings.nodes)
            xb, okb, _ = _newton(fun, xb, tol=settings.tol, max_iter=settings.max_iter,
                                 max_step=_MAX_STEP[: 2 if sym else 3])
        x[:, bad] = xb
        ok[bad] = okb
    return x, ok


def _rupture(volume, case, sub, sym, settings, n_walk=48, n_golden=40):
    """Walk the family from contact towards thinner necks; the gap's maximum is rupture.

    Returns (gap_rupt, x_rupt, ok) for the points ``sub`` (all symmetric or all not).
    """
    xc, ok_c = _contact_state(volume, case, sub, sym, settings)
    t1, t2, R = case.take(sub)
    n_hi = bridge_profile(*_split(xc, sym), t1, t2, R, settings.nodes)["neck_parameter"]
    fracs = np.linspace(1.0, 0.02, n_walk)
    gaps = np.full((n_walk, sub.size), -np.inf)
    xs = np.full((n_walk,) + xc.shape, np.nan)
    x_prev = xc
    alive = ok_c.copy()
    for k, f in enumerate(fracs):
        x, gap, ok = _family_point(n_hi * f, volume, case, sub, sym, x_prev, settings)
        ok &= alive
        gaps[k] = np.where(ok, gap, -np.inf)
        xs[k] = x
        x_prev = np.where(ok, x, x_prev)
        # two falls in a row after the maximum: this point is done
        alive &= ok & ~((k >= 2) & (gaps[k] < gaps[k - 1]) & (gaps[k - 1] < gaps[k - 2]))
        if not alive.any():
            break
    kmax = np.argmax(gaps, axis=0)
    cols = np.arange(sub.size)
    lo = n_hi * fracs[np.minimum(kmax + 1, n_walk - 1)]
    hi = n_hi * fracs[np.maximum(kmax - 1, 0)]
    x_mid = xs[kmax, :, cols].T
    # golden-section search for the maximum of gap(neck) inside [lo, hi]
    g = 0.5 * (np.sqrt(5.0) - 1.0)
    a, b = lo.copy(), hi.copy()
    c, d = b - g * (b - a), a + g * (b - a)
    xcand, fc, _ = _family_point(c, volume, case, sub, sym, x_mid, settings)
    xdand, fd, _ = _family_point(d, volume, case, sub, sym, x_mid, settings)
    for _ in range(n_golden):
        left = np.nan_to_num(fc, nan=-np.inf) >= np.nan_to_num(fd, nan=-np.inf)
        # the maximum is in [a, d] when f(c) >= f(d), else in [c, b]
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        new = np.where(left, b - g * (b - a), a + g * (b - a))
        seed = np.where(left, xcand, xdand)
        xn, fn, _ = _family_point(new, volume, case, sub, sym, seed, settings)
        c, d = np.where(left, new, d), np.where(left, c, new)
        fc, fd = np.where(left, fn, fd), np.where(left, fc, fn)
        xcand, xdand = np.where(left, xn, xdand), np.where(left, xcand, xn)
    x_r, gap_r, ok_r = _family_point(0.5 * (a + b), volume, case, sub, sym, xcand, settings)
    ok_r &= ok_c & (gaps.max(axis=0) > -np.inf) & (kmax > 0) & (kmax < n_walk - 1)
    return np.where(ok_r, gap_r, np.nan), x_r, ok_r


# --------------------------------------------------------------------------------------
# Public solvers
# --------------------------------------------------------------------------------------


def _solve_volume_batch(gap_t, vol_t, case, sub, sym, settings, out):
    """Fill ``out`` for the points ``sub`` (all symmetric or all not)."""
    g, v = gap_t[sub], vol_t[sub]
    fun = _volume_problem(g, v, case, sub, sym, settings.nodes)
    x0 = _unknowns(*_equivalent_guess(g, v, case, sub), sym)
    x, ok, iters = _newton(fun, x0, tol=settings.tol, max_iter=settings.max_iter,
                           max_step=_MAX_STEP[: x0.shape[0]])
    if ok.any():
        slope = _branch_slope(x[:, ok], v[ok], case, sub[ok], sym, settings.nodes)
        ok[np.flatnonzero(ok)[~(slope < 0)]] = False
    good = np.flatnonzero(ok)
    _store(out, sub[good], *_split(x[:, good], sym), case, settings.nodes)
    out["iterations"][sub[good]] = iters[good]
    rest = np.flatnonzero(~ok)
    if rest.size:
        _solve_by_family(g[rest], v[rest], case, sub[rest], sym, settings, out)


def _solve_by_family(g, v, case, sub, sym, settings, out):
    """Safe path: find rupture first, then bisect the neck radius on the stable branch."""
    d_r, x_r, ok_r = _rupture(v, case, sub, sym, settings)
    t1, t2, R = case.take(sub)
    ruptured = ok_r & (g > d_r)
    out["status"][sub[ruptured]] = Status.RUPTURED
    out["force"][sub[ruptured]] = 0.0
    todo = np.flatnonzero(ok_r & ~ruptured)
    if not todo.size:
        return
    sub_t, g_t, v_t = sub[todo], g[todo], v[todo]
    xc, okc = _contact_state(v_t, case, sub_t, sym, settings)
    n_lo = bridge_profile(*_split(x_r[:, todo], sym), t1[todo], t2[todo], R[todo],
                          settings.nodes)["neck_parameter"]
    n_hi = bridge_profile(*_split(xc, sym), t1[todo], t2[todo], R[todo],
                          settings.nodes)["neck_parameter"]
    x_lo, x_hi = x_r[:, todo], xc
    for _ in range(60):  # gap falls from d_rupt to 0 as the neck widens
        mid = 0.5 * (n_lo + n_hi)
        xm, gm, okm = _family_point(mid, v_t, case, sub_t, sym, 0.5 * (x_lo + x_hi), settings)
        above = gm > g_t
        n_lo, x_lo = np.where(above & okm, mid, n_lo), np.where(above & okm, xm, x_lo)
        n_hi, x_hi = np.where(~above & okm, mid, n_hi), np.where(~above & okm, xm, x_hi)
        if np.all(np.abs(n_hi - n_lo) < 1e-13 * (1 + n_hi)):
            break
    fun = _volume_problem(g_t, v_t, case, sub_t, sym, settings.nodes)
    x, ok, _ = _newton(fun, 0.5 * (x_lo + x_hi), tol=settings.tol,
                       max_iter=settings.max_iter, max_step=_MAX_STEP[: x_lo.shape[0]])
    ok &= okc
    good = np.flatnonzero(ok)
    _store(out, sub_t[good], *_split(x[:, good], sym), case, settings.nodes)


def _finish(out, shape):
    return {k: v.reshape(shape) for k, v in out.items()}


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
        energy E* = A - cos t1 A_w1 - cos t2 A_w2 [-], status (capbridge.status.Status),
        iterations.  Beyond rupture: status RUPTURED and force 0.

    Examples
    --------
    Small bridges at contact pull with F* -> cos(theta) (Israelachvili):

    >>> r = solve_doublet(0.0, 1e-5, 30.0)
    >>> round(float(r["force"]) / np.cos(np.radians(30.0)), 2)
    0.99
    """
    settings = settings or SolverSettings()
    gap = check_range("gap d*", gap, 0.0, np.inf,
                      hint="d* is the gap between the sphere surfaces; overlapping grains are not supported")
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta, ratio, theta2 = _validate_common(theta, ratio, theta2)
    (g, v), case = _make_case([gap, volume], theta, ratio, theta2)
    out = _result_arrays(g.size)
    for sym in (True, False):
        sub = np.flatnonzero(case.symmetric == sym)
        if sub.size:
            _solve_volume_batch(g, v, case, sub, sym, settings, out)
    return _finish(out, case.shape)


def rupture_distance(volume, theta, ratio=1.0, theta2=None, settings=None):
    """Rupture distance d*_rupt(V*): the largest gap with an equilibrium bridge.

    Returns a dict with ``gap`` (d*_rupt) and the bridge at rupture (force, pressure,
    beta1, beta2 [deg], neck_radius, status).

    >>> r = rupture_distance(0.01, 0.0)
    >>> round(float(r["gap"]), 3)     # Lian et al. 1993: (1 + theta/2) V*^(1/3) = 0.215
    0.219
    """
    settings = settings or SolverSettings()
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta, ratio, theta2 = _validate_common(theta, ratio, theta2)
    (v,), case = _make_case([volume], theta, ratio, theta2)
    out = _result_arrays(v.size)
    for sym in (True, False):
        sub = np.flatnonzero(case.symmetric == sym)
        if sub.size:
            d_r, x_r, ok = _rupture(v[sub], case, sub, sym, settings)
            good = np.flatnonzero(ok)
            _store(out, sub[good], *_split(x_r[:, good], sym), case, settings.nodes)
    return _finish(out, case.shape)
