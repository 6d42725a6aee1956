"""Exact axisymmetric liquid bridge between two spheres with gravity along their axis.

A vertical doublet: grain 1 (radius 1, the normalising radius) centred at x = 0, grain 2
(radius ``ratio`` >= 1) at x = D = 1 + ratio + d*, gravity parallel to the x axis.  The
liquid's pressure is hydrostatic, so the mean curvature of the free surface varies
linearly with height (Young-Laplace with a hydrostatic term):

    2 H(x) = P*(x) = P_m - b (x - x_m),     b = Bo (up . e_x) = -Bo g_x,

with Bo = drho g r^2 / gamma, ``up`` the unit vector opposite to gravity, e_x the unit
vector from grain 1 to grain 2, ``g_x = gravity_axis`` = +-1 the component of gravity's
direction along e_x (-1: gravity pulls from grain 2 towards grain 1, grain 1 below) and
P_m the pressure at the middle of the gap, x_m = 1 + d*/2.  This is the convention of the
Surface Evolver driver (:mod:`capbridge.solvers.evolver`: energy Bo int h dV with
h = up . x, pressure = Lagrange multiplier at h = 0), whose ``pressure`` is P*(0) here.

Meridian
--------
In arc length s from the contact line on grain 1, with psi the angle of the tangent to
the x axis (the conventions of :mod:`capbridge.solvers.young_laplace`):

    dx/ds = cos psi,   dy/ds = sin psi,   dpsi/ds = cos(psi)/y - P*(x),

started at x = cos b1, y = sin b1, psi = b1 + t1 - pi/2 (Young's law on grain 1).  Without
gravity the profile is a Delaunay roulette; with it there is no closed form and the ODE
is integrated (scipy's DOP853, ``rtol`` 1e-12) together with the quadratures carried
along it: pi int y^2 dx (volume of revolution), pi int x y^2 dx (its first moment) and
2 pi int y ds (area).

Unknowns and residuals
----------------------
The chart of the zero-gravity solver: z = (P_m, b1, L), L the arc length of the meridian
from grain 1 to grain 2.  At the end point (x_e, y_e, psi_e), with
b2 = atan2(y_e, D - x_e):

* on grain 2:        hypot(x_e - D, y_e) - ratio = 0,
* Young on grain 2:  psi_e - (pi/2 - b2 - t2) = 0 (mod 2 pi),
* volume:            (pi int y^2 dx - V_cap(1, b1) - V_cap(ratio, b2)) / V* - 1 = 0.

The Jacobian column in L is exact (the ODE's right-hand side at the end point); the
columns in P_m and b1 are forward differences integrated in the same call as the base
trajectory (same steps, so their difference is smooth).  Damped Newton, started from the
exact zero-gravity bridge (:func:`~capbridge.solvers.young_laplace.solve_doublet`),
with continuation in Bo (steps <= ``bond_step``, linear predictor, step halved on
failure).  Every accepted step must keep the stability indicator
-det d(angle, on-grain-2, volume)/d(P_m, b1, L) positive: it is the zero-gravity
solver's determinant times cos(b2) > 0 on its stable branch (a change of rows: the
rupture distances found with it at Bo = 0 are the zero-gravity solver's, tested), and it
vanishes where the branch ends (a fold, or for equal grains and angles at Bo = 0 the
symmetry-breaking point).

Stability and rupture
---------------------
Where natural continuation in Bo stalls, pseudo-arclength continuation in
(P_m, b1, L, Bo) takes over (:func:`_walk`): steps that at most halve the indicator (a
long step next to a sharp end, as for almost symmetric pairs, lands on a neighbouring
branch whose indicator is positive too: two unstable modes), the tangent oriented
towards larger Bo, and where the indicator changes sign a safeguarded secant search on
the chord of the last step.  If the branch ends below the target Bo the bridge has
ruptured: status RUPTURED, force 0, ``rupture_bond`` the Bo of the end.
:func:`rupture_distance_gravity` walks the gap the same way at fixed Bo from half the
zero-gravity rupture distance.  A point whose zero-gravity bridge has ruptured is
RUPTURED at Bo = 0 and NOT_CONVERGED with gravity (gravity moves the rupture distance,
either way for unequal grains: use :func:`rupture_distance_gravity`); a point whose
continuation fails is NOT_CONVERGED.

Forces and energy
-----------------
Force the liquid exerts on each grain along the axis (attraction positive, F* units
F / (2 pi gamma r)): the tension of the free surface along the contact line plus the
hydrostatic pressure over the wetted cap,

    F1 = y1 cos psi1 - P*(0) y1^2/2 + b (1 - cos^3 b1)/3,
    F2 = y2 cos psi2 - P*(D) y2^2/2 - b ratio^3 (1 - cos^3 b2)/3,

(F1 pulls grain 1 towards grain 2, F2 grain 2 towards grain 1).  The grains carry the
liquid's weight: the total force on them is Bo V* / (2 pi) along gravity, i.e.
F2 - F1 = b V* / (2 pi) exactly; ``force`` is their mean (the capillary attraction
proper; without gravity F1 = F2 = force).  Energy (gamma r^2 units; its derivative in
the position of grain 2 at fixed volume is 2 pi F2, checked in the tests):

    E* = A - cos t1 A_w1 - cos t2 A_w2 + b int x dV      (x from the centre of grain 1).

Reference: Miot et al. (2021), Granular Matter 23:66 (Bo = 2.14 for r = 4 mm glass
beads and water); Young-Laplace with hydrostatics e.g. Adams, Johnson, Lovell & Seville
(2002), J. Phys. D 35, 1-10 (gravity on a vertical bridge).

Supported range: as the zero-gravity solver (theta in [0, 90) deg, ratio in [1, 10])
and 0 <= Bo <= ``BOND_MAX``.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.integrate import solve_ivp

from capbridge.dimensionless import cap_area, cap_volume, centre_distance
from capbridge.solvers.young_laplace import (RATIO_MAX, THETA_MAX_DEG, bridge_profile,
                                               rupture_distance, solve_doublet)
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError, check_range

#: largest Bond number accepted (issue 10 asks for 0-2.5; beyond 5 large bridges sag off
#: the lower grain and the continuation from the zero-gravity bridge is untested)
BOND_MAX = 5.0

__all__ = ["GravitySettings", "BOND_MAX", "solve_doublet_gravity", "rupture_distance_gravity",
           "gravity_bridge_state"]

# order of the quantities integrated along the meridian
_X, _Y, _PSI, _VOL, _MOM, _AREA = range(6)
_NQ = 6


@dataclasses.dataclass(frozen=True)
class GravitySettings:
    """Numerical settings of the gravity solver."""

    rtol: float = 1e-12       #: DOP853 relative tolerance
    atol: float = 1e-14       #: DOP853 absolute tolerance
    tol: float = 1e-11        #: Newton tolerance on the residuals (rad, r, relative V)
    max_iter: int = 30        #: Newton iterations per continuation step
    bond_step: float = 0.5    #: largest continuation step in Bo
    fd_step: float = 1e-7     #: forward-difference step in P_m and b1 (relative)

    def as_dict(self):
        return dataclasses.asdict(self)


# --------------------------------------------------------------------------------------
# The meridian: ODE in arc length, k trajectories at once
# --------------------------------------------------------------------------------------


def _rhs(L, p_mid, b, x_mid):
    """Right-hand side d/dt (t = s / L in [0, 1]) of the quantities of k trajectories.

    ``p_mid`` (k,) are their pressures at x_mid; the state is flattened (6, k).
    dpsi/ds = cos(psi)/y - P*(x), P*(x) = p_mid - b (x - x_mid).
    """

    def f(_t, u):
        x, y, psi = u[_X * k:(_X + 1) * k], u[_Y * k:(_Y + 1) * k], u[_PSI * k:(_PSI + 1) * k]
        c, s = np.cos(psi), np.sin(psi)
        py2c = np.pi * y * y * c
        return L * np.concatenate([c, s, c / y - (p_mid - b * (x - x_mid)), py2c, x * py2c,
                                   2.0 * np.pi * y])

    k = p_mid.size
    return f


def _start(beta1, theta1):
    """(x, y, psi) of the contact line on grain 1 (Young's law there)."""
    return np.cos(beta1), np.sin(beta1), beta1 + theta1 - 0.5 * np.pi


def _integrate(p_mid, beta1, L, pt, settings):
    """Integrate k meridians sharing L (arrays p_mid, beta1 of shape (k,)).

    Returns (end state (6, k), min y along each meridian, ok).  ``ok`` is False when the
    integration fails or a meridian reaches the axis (y <= 1e-9: no bridge).
    """
    p_mid, beta1 = np.atleast_1d(p_mid).astype(float), np.atleast_1d(beta1).astype(float)
    k = p_mid.size
    x0, y0, psi0 = _start(beta1, pt["theta1"])
    u0 = np.concatenate([x0, y0, psi0, np.zeros(3 * k)])
    if not (L > 0 and np.all(y0 > 0) and np.all(np.isfinite(u0))):
        return np.full((_NQ, k), np.nan), np.full(k, np.nan), False
    f = _rhs(L, p_mid, pt["b"], pt["x_mid"])

    def axis(_t, u):              # a meridian reaching the axis: no bridge
        return np.min(u[_Y * k:(_Y + 1) * k]) - 1e-9

    axis.terminal = True
    with np.errstate(all="ignore"):
        sol = solve_ivp(f, (0.0, 1.0), u0, method="DOP853", rtol=settings.rtol,
                        atol=settings.atol, events=axis, dense_output=True)
    if sol.status != 0 or not np.all(np.isfinite(sol.y[:, -1])):
        return np.full((_NQ, k), np.nan), np.full(k, np.nan), False
    end = sol.y[:, -1].reshape(_NQ, k)
    # the neck: the smallest y, at a zero of psi (refined on the dense output)
    ymin = _smallest_radius(sol, k)
    return end, ymin, True


def _smallest_radius(sol, k):
    """Smallest radius of each meridian: the ends or an interior minimum of y (a neck,
    where psi crosses zero upwards), located on the dense output by a few secant steps
    on psi."""
    ys = sol.y[_Y * k:(_Y + 1) * k]
    ps = sol.y[_PSI * k:(_PSI + 1) * k]
    ymin = np.minimum(ys[:, 0], ys[:, -1])
    for j in range(k):
        cross = np.flatnonzero((ps[j, :-1] < 0) & (ps[j, 1:] >= 0))
        for i in cross:
            a, b = sol.t[i], sol.t[i + 1]
            fa, fb = ps[j, i], ps[j, i + 1]
            for _ in range(30):
                c = b - fb * (b - a) / (fb - fa) if fb != fa else 0.5 * (a + b)
                fc = sol.sol(c)[_PSI * k + j]
                if abs(fc) < 1e-14:
                    break
                a, fa, b, fb = (b, fb, c, fc)
            ymin[j] = min(ymin[j], sol.sol(c)[_Y * k + j])
    return ymin


# --------------------------------------------------------------------------------------
# Residuals, Jacobian, forces
# --------------------------------------------------------------------------------------


def _wrap(a):
    """Angle in (-pi, pi]."""
    return np.pi - np.remainder(np.pi - a, 2.0 * np.pi)


def _end_values(end, beta1, pt):
    """Residuals (angle, on grain 2, volume) and derived end quantities of trajectories.

    ``end`` is (6, k); returns a dict of (k,) arrays.
    """
    D, R = pt["D"], pt["ratio"]
    xe, ye, pe = end[_X], end[_Y], end[_PSI]
    beta2 = np.arctan2(ye, D - xe)
    vol = end[_VOL] - cap_volume(1.0, beta1) - cap_volume(R, beta2)
    return dict(angle=_wrap(pe - (0.5 * np.pi - beta2 - pt["theta2"])),
                on2=np.hypot(xe - D, ye) - R,
                volume=vol / pt["volume"] - 1.0, beta2=beta2, vol=vol)


def _residuals(z, pt, settings, jac=True):
    """Residuals r (3,), Jacobian J (3, 3) (columns P_m, b1, L) and the end state."""
    pm, b1, L = z
    if jac:
        eps = settings.fd_step * (1.0 + np.abs(z[:2]))
        pms = np.array([pm, pm + eps[0], pm])
        b1s = np.array([b1, b1, b1 + eps[1]])
    else:
        pms, b1s = np.array([pm]), np.array([b1])
    end, ymin, ok = _integrate(pms, b1s, L, pt, settings)
    if not ok:
        return None, None, None
    v = _end_values(end, b1s, pt)
    r = np.array([v["angle"][0], v["on2"][0], v["volume"][0]])
    info = dict(end=end[:, 0], ymin=ymin[0], beta2=v["beta2"][0], vol=v["vol"][0])
    if not (0.0 < b1 < 0.9 * np.pi and 0.0 < info["beta2"] < 0.9 * np.pi
            and np.all(np.isfinite(r))):
        return None, None, None
    if not jac:
        return r, None, info
    J = np.empty((3, 3))
    for col in range(2):
        diff = np.array([v[k][col + 1] - v[k][0] for k in ("angle", "on2", "volume")])
        diff[0] = _wrap(diff[0])
        J[:, col] = diff / eps[col]
    J[:, 2] = _d_dL(end[:, 0], pm, pt)
    return r, J, info


def _d_dL(e, pm, pt):
    """Exact derivative of the residuals in L: the end point moves along the meridian."""
    D, R = pt["D"], pt["ratio"]
    xe, ye, pe = e[_X], e[_Y], e[_PSI]
    c, s = np.cos(pe), np.sin(pe)
    pres = pm - pt["b"] * (xe - pt["x_mid"])
    rho2 = (xe - D) ** 2 + ye**2
    # beta2 = atan2(y, D - x): d beta2 = ((D - x) dy + y dx) / rho^2
    db2 = ((D - xe) * s + ye * c) / rho2
    dpsi = c / ye - pres
    d_on2 = ((xe - D) * c + ye * s) / np.sqrt(rho2)
    # d/d beta2 of V_cap(R, b2) = pi R^3 sin^3 b2
    dvol = np.pi * ye**2 * c - np.pi * R**3 * np.sin(np.arctan2(ye, D - xe)) ** 3 * db2
    return np.array([dpsi + db2, d_on2, dvol / pt["volume"]])


def bridge_forces(z, info, pt):
    """Axial forces on the two grains, pressures and the energy of a solved bridge."""
    pm, b1, _ = z
    e = info["end"]
    b, R, D, x_mid = pt["b"], pt["ratio"], pt["D"], pt["x_mid"]
    x1, y1, psi1 = _start(b1, pt["theta1"])
    b2 = info["beta2"]
    p0 = pm + b * x_mid                       # P*(x = 0), the centre of grain 1
    pD = pm - b * (D - x_mid)                 # P*(x = D), the centre of grain 2
    # 1 - cos^3 = (1 - cos)(1 + cos + cos^2), 1 - cos = 2 sin^2(b/2): no cancellation
    one_c1 = 2.0 * np.sin(0.5 * b1) ** 2 * (1.0 + np.cos(b1) + np.cos(b1) ** 2)
    one_c2 = 2.0 * np.sin(0.5 * b2) ** 2 * (1.0 + np.cos(b2) + np.cos(b2) ** 2)
    F1 = y1 * np.cos(psi1) - 0.5 * p0 * y1**2 + b * one_c1 / 3.0
    F2 = e[_Y] * np.cos(e[_PSI]) - 0.5 * pD * e[_Y] ** 2 - b * R**3 * one_c2 / 3.0
    # first moment int x dV of the liquid: the body of revolution minus the two caps
    # (cap of grain 1 beyond x = cos b1: pi sin^4 b1 / 4; cap of grain 2 about its
    # centre: D V_cap2 - pi R^4 sin^4 b2 / 4)
    moment = (e[_MOM] - 0.25 * np.pi * np.sin(b1) ** 4
              - D * cap_volume(R, b2) + 0.25 * np.pi * R**4 * np.sin(b2) ** 4)
    area = e[_AREA]
    energy = (area - np.cos(pt["theta1"]) * cap_area(1.0, b1)
              - np.cos(pt["theta2"]) * cap_area(R, b2) + b * moment)
    return dict(force1=F1, force2=F2, force=0.5 * (F1 + F2), pressure=pm,
                pressure_centre1=p0, beta1=np.degrees(b1), beta2=np.degrees(b2),
                area=area, energy=energy, volume=info["vol"], neck_radius=info["ymin"],
                moment=moment,
                weight=abs(b) * info["vol"] / (2.0 * np.pi))


# --------------------------------------------------------------------------------------
# Newton and continuation in Bo
# --------------------------------------------------------------------------------------


def _damped_newton(system, w, cap, settings, max_iter):
    """Damped Newton on ``system(w) -> (r, J, info)`` (None where w gives no profile).

    Steps are clipped to ``cap(w)`` per unknown and halved until the max-norm of the
    residual decreases.  Returns (w, converged, iterations, J, info).
    """
    w = np.array(w, float)
    r, J, info = system(w)
    if r is None:
        return w, False, 0, None, None
    norm = np.max(np.abs(r))
    for it in range(1, max_iter + 1):
        if norm < settings.tol:
            return w, True, it - 1, J, info
        try:
            dw = -np.linalg.solve(J, r)
        except np.linalg.LinAlgError:
            return w, False, it, J, info
        dw *= min(1.0, float(np.min(cap(w) / np.maximum(np.abs(dw), 1e-300))))
        lam, accepted = 1.0, False
        for _ in range(10):
            wt = w + lam * dw
            rt, Jt, info_t = system(wt)
            if rt is not None:
                nt = np.max(np.abs(rt))
                if nt < (1.0 - 1e-4 * lam) * norm or nt < settings.tol:
                    w, r, J, info, norm, accepted = wt, rt, Jt, info_t, nt, True
                    break
            lam *= 0.5
        if not accepted:
            # at the integrator's round-off floor a full step no longer decreases |r|
            floor = norm < 1e3 * settings.tol and np.all(np.abs(dw) <= 1e-12 * (1 + np.abs(w)))
            return w, bool(floor), it, J, info
    return w, norm < settings.tol, max_iter, J, info


def _cap_z(z):
    """Largest Newton step: relative in P_m and L, absolute in b1 (as without gravity)."""
    return np.array([0.5 * (1.0 + abs(z[0])), 0.15, 0.5 * abs(z[2]) + 1e-3])


def newton_solve(z, pt, settings, max_iter=None):
    """Damped Newton on (P_m, b1, L) at the point's Bo.  Returns (z, ok, its, J, info)."""
    return _damped_newton(lambda zz: _residuals(zz, pt, settings), z, _cap_z, settings,
                          max_iter or settings.max_iter)


def stability_indicator(J):
    """Stability indicator: -det of the 3 x 3 Jacobian in (P_m, b1, L), positive on the
    stable branch (module docstring)."""
    return -np.linalg.det(J[:, :3])


def point_dict(gap, volume, theta1, theta2, ratio, bond, gravity_axis):
    D = float(centre_distance(gap, ratio))
    return dict(gap=float(gap), volume=float(volume), theta1=float(theta1),
                theta2=float(theta2), ratio=float(ratio), D=D, x_mid=1.0 + 0.5 * gap,
                b=-float(bond) * float(gravity_axis), bond=float(bond))


def zero_gravity_start(pt, zg):
    """Unknowns (P_m, b1, L) of the exact zero-gravity bridge ``zg`` (one point)."""
    h = 0.5 * float(zg["pressure"])
    b1, b2 = np.radians(float(zg["beta1"])), np.radians(float(zg["beta2"]))
    L = float(bridge_profile(h, b1, b2, pt["theta1"], pt["theta2"], pt["ratio"])["length"])
    return np.array([2.0 * h, b1, L])


@dataclasses.dataclass
class _Path:
    """Outcome of a continuation of one point."""

    status: Status = Status.NOT_CONVERGED
    z: np.ndarray = None
    J: np.ndarray = None
    info: dict = None
    pt: dict = None
    iterations: int = 0
    steps: int = 0
    end: float = np.nan       #: parameter (|Bo| or d*) where the stable branch ends

    def accept(self, z, J, info, pt, status=Status.CONVERGED):
        self.status, self.z, self.J, self.info, self.pt = status, z, J, info, pt
        return self


class _Family:
    """Equilibria of one doublet as one parameter varies: ``"bond"`` (|b|, the direction
    of gravity fixed) or ``"gap"`` (d*).  Pseudo-arclength continuation in the scaled
    unknowns w = (P_m / s0, b1, L / s2, parameter), scales fixed at the start."""

    def __init__(self, pt, param, settings, z):
        self.pt, self.param, self.settings = pt, param, settings
        self.sign = 1.0 if pt["b"] >= 0 else -1.0
        self.scale = np.array([1.0 + abs(z[0]), 1.0, abs(z[2])])

    def point(self, value):
        """The point dict at parameter ``value``."""
        if self.param == "bond":
            return dict(self.pt, b=self.sign * value)
        pt = self.pt
        return point_dict(value, pt["volume"], pt["theta1"], pt["theta2"], pt["ratio"],
                           pt["bond"], -pt["b"] / pt["bond"] if pt["bond"] else -1.0)

    def w_of(self, z, value):
        return np.append(z / self.scale, value)

    def evaluate(self, w):
        """Residuals, Jacobian (3 x 4, in w) and the profile at w, or Nones."""
        z, value = w[:3] * self.scale, w[3]
        if value < 0.0:                   # Bo >= 0; d* < 0: overlapping grains
            return None, None, None
        pt = self.point(value)
        r, J, info = _residuals(z, pt, self.settings)
        if r is None:
            return None, None, None
        # the parameter column by a forward difference (a separate integration)
        eps = self.settings.fd_step * (1.0 + abs(value))
        r2, _, _ = _residuals(z, self.point(value + eps), self.settings, jac=False)
        if r2 is None:
            return None, None, None
        dp = (r2 - r) / eps
        dp[0] = _wrap(r2[0] - r[0]) / eps
        Jw = np.column_stack([J * self.scale[None, :], dp])
        return r, Jw, dict(info=info, J=J, pt=pt, z=z)

    @staticmethod
    def tangent(Jw, prev=None):
        """Unit null vector of Jw, oriented along ``prev`` (else towards a larger
        parameter)."""
        t = np.linalg.svd(Jw)[2][-1]
        ref = prev if prev is not None else np.array([0.0, 0.0, 0.0, 1.0])
        return t if t @ ref >= 0 else -t

    def correct(self, w_pred, u, w_ref, c, max_iter=12):
        """Family point with u . (w - w_ref) = c (Newton from ``w_pred``)."""

        def system(ww):
            r, Jw, extra = self.evaluate(ww)
            if r is None:
                return None, None, None
            return np.append(r, u @ (ww - w_ref) - c), np.vstack([Jw, u]), (Jw, extra)

        w, ok, it, _, got = _damped_newton(system, w_pred,
                                           lambda ww: np.array([0.5, 0.15, 0.5, 0.5]),
                                           self.settings, max_iter)
        return w, ok, it, got


def _walk(fam, z, value, target, path, max_steps=100):
    """Pseudo-arclength continuation from (z, value) towards larger parameter values,
    until ``target`` (path CONVERGED at the target, on the stable branch) or the end of
    the stable branch, where the indicator vanishes (path RUPTURED, ``path.end`` the
    parameter there, located by bisection along the chord of the step that crossed it).
    """
    w = fam.w_of(z, value)
    r, Jw, extra = fam.evaluate(w)
    if r is None:
        return path
    t = fam.tangent(Jw)
    ind_w = stability_indicator(extra["J"])
    ds, ds_max = 0.05, 0.2
    for _ in range(max_steps):
        wp = w + ds * t
        wn, ok, it, got = fam.correct(wp, t, wp, 0.0)
        path.iterations += it
        path.steps += 1
        if not ok:
            ds *= 0.5
            if ds < 1e-5:
                return path
            continue
        Jw_n, extra = got
        ind = stability_indicator(extra["J"])
        t_new = fam.tangent(Jw_n, t)
        if t_new @ t < 0.9 or np.linalg.norm(wn - w) > 2.0 * ds:
            # the corrector left the branch (e.g. across a sharp fold onto its return,
            # where the indicator is positive again: two unstable modes)
            ds *= 0.5
            if ds < 1e-5:
                return path
            continue
        if ind > 0 and wn[3] >= target:
            # past the target on the stable branch: solve at the target itself
            f = (target - w[3]) / (wn[3] - w[3])
            pt = fam.point(target)
            zt, okt, it, Jt, info_t = newton_solve(((1 - f) * w[:3] + f * wn[:3]) * fam.scale, pt,
                                              fam.settings, max_iter=12)
            path.iterations += it
            if okt and stability_indicator(Jt) > 0:
                path.accept(zt, Jt, info_t, pt)
            return path
        if 0 < ind < 0.5 * ind_w and ds > 1e-4:
            # approach the end (indicator -> 0) in steps that at most halve the
            # indicator: near a sharp end (an almost symmetric pair, where the stable
            # branch turns close to the symmetry-breaking point) a long step lands on
            # a neighbouring branch whose indicator is positive too
            ds *= 0.5
            continue
        if ind <= 0:
            if ds > 2e-3:
                # the end is within this step: walk up to it in shorter steps, so that
                # the final bracket is short enough for its chord to follow the branch
                # (a long chord can cut another branch: near a symmetry-breaking point
                # the asymmetric branches cross it)
                ds = ds_max = 0.25 * ds
                continue
            return _branch_end(fam, w, wn, target, path)
        if wn[3] <= w[3]:
            # on the stable branch the parameter grows up to the end (where the
            # indicator vanishes first): a step back landed on another branch
            ds *= 0.5
            if ds < 1e-5:
                return path
            continue
        # oriented towards a larger parameter: it grows all along the stable branch
        t, w, ind_w = fam.tangent(Jw_n), wn, ind
        ds = min(1.5 * ds, ds_max)
    return path


def _branch_end(fam, w_lo, w_hi, target, path, max_iter=40):
    """The indicator changes sign between the family points w_lo (> 0) and w_hi (<= 0):
    its zero along their chord by the Illinois (safeguarded secant) method.  The stable
    end of the final bracket is the end of the branch (a fold of the parameter, or for
    equal grains at Bo = 0 the symmetry-breaking point, as in the zero-gravity solver).
    """
    chord = w_hi - w_lo
    length = np.linalg.norm(chord)
    u = chord / length

    def ind_at(c, w_pred):
        w, ok, it, got = fam.correct(w_pred, u, w_lo, c)
        path.iterations += it
        return (w, got[1], stability_indicator(got[1]["J"])) if ok else (None, None, np.nan)

    w_a, ex_a, fa = ind_at(0.0, w_lo)
    w_b, _, fb = ind_at(length, w_hi)
    if not (fa > 0 and fb <= 0):
        return path
    a, b, side = 0.0, length, 0
    for _ in range(max_iter):
        if b - a < 1e-8 * (1.0 + length):
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not a < c < b:
            c = 0.5 * (a + b)
        w_c, ex_c, fc = ind_at(c, w_lo + c * u)
        if not np.isfinite(fc):
            fc = -1e-3 * fa             # a failed point counts as the far side
        if fc > 0:
            a, fa, w_a, ex_a = c, fc, w_c, ex_c
            fb = 0.5 * fb if side == 1 else fb
            side = 1
        else:
            b, fb = c, fc
            fa = 0.5 * fa if side == -1 else fa
            side = -1
    if w_a[3] >= target:             # the target lies on the stable branch after all
        return path
    path.end = float(w_a[3])
    return path.accept(ex_a["z"], ex_a["J"], ex_a["info"], ex_a["pt"], Status.RUPTURED)


def _continue_in_bond(z0, pt, settings):
    """From the zero-gravity solution z0 to the target Bo.

    Natural continuation in b (steps <= ``bond_step``, secant predictor); where it stalls
    (near the end of the branch, where the Jacobian becomes singular) pseudo-arclength
    continuation (:func:`_walk`) takes over and either reaches the target or finds the
    end of the stable branch below it: the bridge has ruptured (``path.end`` is the Bo
    of the end).
    """
    path = _Path()
    target = abs(pt["b"])
    sign = 1.0 if pt["b"] >= 0 else -1.0
    # polish at Bo = 0 (the ODE and the roulette agree to ~1e-11: one or two steps)
    p0 = dict(pt, b=0.0)
    z, ok, it, J, info = newton_solve(z0, p0, settings)
    path.iterations += it
    if not ok or stability_indicator(J) <= 0:
        return path
    hist = [(0.0, z)]
    done = 0.0
    step = min(target, settings.bond_step)
    while done < target:
        nxt = min(done + step, target)
        zp = z if len(hist) < 2 else z + (z - hist[-2][1]) * (nxt - done) / (done - hist[-2][0])
        zn, ok, it, Jn, info_n = newton_solve(zp, dict(pt, b=sign * nxt), settings, max_iter=8)
        path.iterations += it
        path.steps += 1
        # stable branch only; the corrector must not jump far from the predictor
        ok = (ok and stability_indicator(Jn) > 0
              and bool(np.all(np.abs(zn - zp) <= 0.25 * (1.0 + np.abs(zp)))))
        if ok:
            done, z, J, info = nxt, zn, Jn, info_n
            hist.append((done, z))
            step = min(1.5 * step, settings.bond_step)
            continue
        step *= 0.5
        if step < 0.2 * settings.bond_step:      # stalled twice: near the end
            return _walk(_Family(pt, "bond", settings, z), z, done, target, path)
    return path.accept(z, J, info, pt)


# --------------------------------------------------------------------------------------
# Public solver
# --------------------------------------------------------------------------------------

_KEYS = ("force", "force1", "force2", "weight", "pressure", "pressure_centre1", "beta1",
         "beta2", "neck_radius", "area", "energy", "volume", "moment", "gap", "bond",
         "indicator", "rupture_bond")


def _check_gravity_axis(gravity_axis):
    g = np.asarray(gravity_axis, dtype=float)
    bad = ~np.isin(g, (-1.0, 1.0))
    if np.any(bad):
        first = g[bad].flat[0] if g.ndim else float(g)
        raise CapbridgeInputError(
            f"gravity_axis={first!r} is not allowed: -1 (gravity from grain 2 towards "
            "grain 1, grain 1 below) or +1 (grain 1 above)")
    return g


def solve_doublet_gravity(gap, volume, theta, bond, ratio=1.0, theta2=None,
                          gravity_axis=-1.0, settings=None):
    """Liquid bridge of given volume between two spheres, gravity along their axis.

    Parameters
    ----------
    gap : array_like
        Gap between the sphere surfaces d* = d / R1 [-], >= 0.
    volume : array_like
        Liquid volume V* = V / R1^3 [-], > 0.
    theta : array_like
        Contact angle on sphere 1 [deg], in [0, 90).
    bond : array_like
        Bond number Bo = drho g R1^2 / gamma [-], in [0, BOND_MAX].
    ratio : array_like, default 1
        Radius ratio R2 / R1 in [1, 10].
    theta2 : array_like, optional
        Contact angle on sphere 2 [deg]; defaults to ``theta``.
    gravity_axis : array_like of -1 or +1, default -1
        Component of gravity's direction along the axis from grain 1 to grain 2: -1 when
        grain 1 is below grain 2, +1 when it is above.
    settings : GravitySettings, optional

    Returns
    -------
    dict of arrays broadcast to the inputs' shape:
        force1, force2 : F* on grain 1 (towards grain 2) and on grain 2 (towards grain
            1), attraction > 0; force2 - force1 = -gravity_axis Bo V* / (2 pi).
        force : their mean [-];  weight : Bo V* / (2 pi) [-].
        pressure : P* at the middle of the gap x = 1 + d*/2 [-];
        pressure_centre1 : P* at the height of the centre of grain 1 [-].
        beta1, beta2 : half filling angles [deg].
        neck_radius, area, volume, gap, bond : [-].
        energy : E* = A - cos t1 A_w1 - cos t2 A_w2 + b int x dV (x from the centre of
            grain 1) [-].
        moment : int x dV, the liquid's first moment about the centre of grain 1 along
            the axis [-] (its centre of mass is at moment / volume).
        indicator : stability indicator (> 0 on the stable branch).
        status : capbridge.status.Status (CONVERGED or NOT_CONVERGED; see the module
            docstring), iterations, steps (continuation steps in Bo).

    Examples
    --------
    The grains share the liquid's weight; the lower one carries less attraction:

    >>> r = solve_doublet_gravity(0.1, 0.05, 30.0, 2.14)
    >>> bool(r["force1"] < r["force"] < r["force2"])
    True
    """
    settings = settings or GravitySettings()
    gap = check_range("gap d*", gap, 0.0, np.inf,
                      hint="d* is the gap between the sphere surfaces; "
                           "overlapping grains are not supported")
    (d, v, t1, t2, R, bo, ga), shape = validated_inputs(gap, volume, theta, theta2, ratio, bond,
                                                  gravity_axis)
    out = _result_arrays(d.size)
    out["gap"], out["volume"], out["bond"] = d.copy(), v.copy(), bo.copy()
    zg = solve_doublet(d, v, np.degrees(t1), R, np.degrees(t2))   # vectorised starts
    for i in range(d.size):
        if zg["status"][i] != Status.CONVERGED:
            # ruptured without gravity: exact at Bo = 0; with gravity the rupture
            # distance moves (either way for unequal grains), so no verdict there
            if zg["status"][i] == Status.RUPTURED and bo[i] == 0.0:
                out["status"][i] = Status.RUPTURED
                out["force"][i] = out["force1"][i] = out["force2"][i] = 0.0
            continue
        pt = point_dict(d[i], v[i], t1[i], t2[i], R[i], bo[i], ga[i])
        path = _solve_point(pt, {k: zg[k][i] for k in ("pressure", "beta1", "beta2")},
                            settings)
        if path.status == Status.RUPTURED:
            # the end of the branch is a state at another Bo: only its Bo is reported
            out["status"][i] = path.status
            out["iterations"][i], out["steps"][i] = path.iterations, path.steps
            out["force"][i] = out["force1"][i] = out["force2"][i] = 0.0
            out["rupture_bond"][i] = path.end
        else:
            _store(out, i, path)
    return {k: val.reshape(shape) for k, val in out.items()}


def rupture_distance_gravity(volume, theta, bond, ratio=1.0, theta2=None,
                             gravity_axis=-1.0, settings=None):
    """Rupture distance d*_rupt(V*, Bo) of the vertical doublet: the end of the stable
    branch at fixed volume and Bo.

    From a stable bridge at half the zero-gravity rupture distance (solved as in
    :func:`solve_doublet_gravity`), pseudo-arclength continuation in the gap until the
    stability indicator vanishes (a fold of the gap, or for equal grains and angles at
    Bo = 0 the symmetry-breaking point), located by a safeguarded secant search.

    Parameters are those of :func:`solve_doublet_gravity` without ``gap``.  Returns a
    dict with ``gap`` (d*_rupt) and the bridge there (the keys of
    :func:`solve_doublet_gravity`); status CONVERGED where the end was found, else
    NOT_CONVERGED (gap NaN).

    >>> r = rupture_distance_gravity(0.05, 30.0, 2.14)
    >>> bool(0.4 < r["gap"] < 0.5)
    True
    """
    settings = settings or GravitySettings()
    (v, t1, t2, R, bo, ga), shape = validated_inputs(None, volume, theta, theta2, ratio, bond,
                                               gravity_axis)
    out = _result_arrays(v.size)
    out["volume"], out["bond"] = v.copy(), bo.copy()
    d_r0 = rupture_distance(v, np.degrees(t1), R, np.degrees(t2))["gap"]
    for i in range(v.size):
        for frac in (0.5, 0.1):               # a stable start, well inside the branch
            d0 = frac * d_r0[i]
            if not np.isfinite(d0):
                break
            zg = solve_doublet(d0, v[i], np.degrees(t1[i]), R[i], np.degrees(t2[i]))
            if zg["status"] != Status.CONVERGED:
                continue
            pt = point_dict(d0, v[i], t1[i], t2[i], R[i], bo[i], ga[i])
            path = _solve_point(pt, zg, settings)
            if path.status != Status.CONVERGED:
                continue
            end = _walk(_Family(pt, "gap", settings, path.z), path.z, d0, np.inf,
                        _Path(iterations=path.iterations, steps=path.steps))
            if end.status == Status.RUPTURED:
                end.status = Status.CONVERGED     # the end of the branch was found
                _store(out, i, end)
                out["gap"][i] = end.end
            break
    return {k: val.reshape(shape) for k, val in out.items()}


def validated_inputs(gap, volume, theta, theta2, ratio, bond, gravity_axis):
    """Checked inputs (angles in radians), flattened after broadcasting, and the shape."""
    volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
    theta = check_range("theta", theta, 0.0, THETA_MAX_DEG, high_open=True, units=" deg",
                        hint="contact angles are supported in [0, 90) degrees")
    theta2 = theta if theta2 is None else check_range(
        "theta2", theta2, 0.0, THETA_MAX_DEG, high_open=True, units=" deg",
        hint="contact angles are supported in [0, 90) degrees")
    ratio = check_range("ratio", ratio, 1.0, RATIO_MAX,
                        hint="ratio = R2/R1 with R1 the smaller (normalising) radius")
    bond = check_range("Bond number Bo", bond, 0.0, BOND_MAX,
                       hint="Bo = drho g R1^2 / gamma")
    g_axis = _check_gravity_axis(gravity_axis)
    arrays = [volume, np.radians(theta), np.radians(theta2), ratio, bond, g_axis]
    if gap is not None:
        arrays.insert(0, gap)
    b = np.broadcast_arrays(*arrays)
    return [np.ravel(a).astype(float) for a in b], b[0].shape


def _result_arrays(n):
    out = {k: np.full(n, np.nan) for k in _KEYS}
    out["status"] = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    out["iterations"] = np.zeros(n, np.int16)
    out["steps"] = np.zeros(n, np.int16)
    return out


def _solve_point(pt, zg, settings):
    """Continuation from the zero-gravity bridge ``zg`` (its pressure, beta1, beta2) to
    the point's Bo.  Returns a :class:`_Path`."""
    z0 = zero_gravity_start(pt, {k: float(np.ravel(zg[k])[0])
                                  for k in ("pressure", "beta1", "beta2")})
    if not np.all(np.isfinite(z0)):
        return _Path()
    return _continue_in_bond(z0, pt, settings)


def _store(out, i, path):
    """Results of a path into row i of ``out``."""
    out["iterations"][i], out["steps"][i] = path.iterations, path.steps
    out["status"][i] = path.status
    if path.z is None:
        return
    for k, val in bridge_forces(path.z, path.info, path.pt).items():
        out[k][i] = val
    out["gap"][i] = path.pt["gap"]
    out["indicator"][i] = stability_indicator(path.J)


def gravity_bridge_state(gap, volume, theta, bond, z, ratio=1.0, theta2=None,
                         gravity_axis=-1.0, settings=None):
    """Residuals and forces of the profile with unknowns ``z`` = (P_m, b1 [rad], L).

    For diagnostics and tests (one point): returns a dict with ``residuals`` (angle on
    grain 2 [rad], distance of the end point from grain 2, relative volume misfit) and
    the quantities of :func:`solve_doublet_gravity` for that profile (an equilibrium
    only where the residuals vanish).
    """
    settings = settings or GravitySettings()
    theta2 = theta if theta2 is None else theta2
    pt = point_dict(gap, volume, np.radians(theta), np.radians(theta2), ratio, bond,
                     float(_check_gravity_axis(gravity_axis)))
    r, _, info = _residuals(np.asarray(z, float), pt, settings, jac=False)
    if r is None:
        raise CapbridgeInputError(f"z={list(z)} does not give a profile ending on grain 2")
    return dict(bridge_forces(np.asarray(z, float), info, pt), residuals=r)
