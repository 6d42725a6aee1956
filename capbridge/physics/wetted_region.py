"""Capillary force of one liquid body on a grain from the grain's wetted region.

Whatever the shape of a liquid body (a bridge, a coalesced triplet, a cluster), the force
it exerts on a wetted sphere of radius r depends only on the body's Laplace pressure and
on the contact line on that sphere.  The pressure pushes on the wetted region, and the
surface tension pulls along the conormal nu of the liquid surface at the line, which
Young's law fixes: nu = cos(theta) w + sin(theta) n, with n the sphere's outer unit normal
and w the unit tangent to the sphere normal to the line, pointing into the wetted region.
On a sphere the line integral of w is (2 / r) times the vector area of the region it
encloses, so (dimensionless: F* = F / (2 pi gamma r), P* = dp r / gamma)::

    F*_i = [(2 cos(theta) - P*) S*_i + sin(theta) L*_i] / (2 pi)

    S*_i = S_i / r^2,  S_i = int_{wetted} n dA = 1/2 oint (x - c_i) x dx
    L*_i = (1 / r) oint n dl

(the contact line run with the wetted region on its left seen from outside the grain).
For a cap of half-angle alpha about the unit vector e, S* = pi sin^2(alpha) e and
L* = 2 pi sin(alpha) cos(alpha) e, and the formula gives the doublet's closed form
F* = [sin(alpha) sin(alpha + theta) - sin^2(alpha) P* / 2] e.

Note that L* does not depend on the line's orientation (the complementary region has
-S* and the same L*), and a fully wetted sphere has S* = L* = 0.

A base model of a coalesced body therefore needs the body's pressure and each grain's
wetted region.  :func:`predict_regions` is one such model with no energy minimisation
(the "hull model"): caps of the toroidal bridges at the body's pressure
(:func:`toroidal_half_angles`, from :func:`meridian_half_angles`), the spherical convex
hull of the caps of each triangle of the body (:func:`cap_hull_polygon`) and the
spherical triangle of each filled tetrahedron, combined by :func:`union_region`.  Its
accuracy against Surface Evolver is measured in ``benchmarks/bench_wetted_region.py``
(``benchmarks/RESULTS.md``).

All S*, L* are on the grain's own sphere (lengths / its radius R_i); for unequal radii
the force in units of 2 pi gamma r is R_i [(2 cos(theta) - P* R_i) S*_i +
sin(theta) L*_i] / (2 pi) with P* = dp r / gamma.  The functions here take equal radii
(R_i = r) unless said otherwise.

Layer: physics (numpy only).
"""
from __future__ import annotations

import numpy as np

__all__ = ["region_force", "cap_region", "cap_half_angle", "polygon_region",
           "meridian_half_angles", "toroidal_half_angles", "toroidal_fold",
           "window_radius", "torus_reach", "pair_caps", "union_region",
           "cap_hull_polygon", "window_balls", "predict_regions", "body_volume",
           "pressure_from_volume"]


def region_force(pressure, theta, S, L):
    """Force F* of a liquid body on one grain from the grain's wetted region.

    Parameters
    ----------
    pressure : float or array_like
        Laplace pressure of the body, P* = dp r / gamma (dp = liquid minus gas; < 0 in
        suction).
    theta : float or array_like
        Contact angle on the grain [deg].
    S : array_like, shape (..., 3)
        Vector area of the wetted region, S* = S / r^2.
    L : array_like, shape (..., 3)
        Line integral of the grain's outer unit normal along the contact line, divided
        by r.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        F* = F / (2 pi gamma r) = [(2 cos(theta) - P*) S* + sin(theta) L*] / (2 pi).

    Examples
    --------
    A cap of half-angle alpha about x reproduces the doublet's closed form
    sin(alpha) sin(alpha + theta) - sin^2(alpha) P* / 2:

    >>> a, th, P = np.radians(25.0), 30.0, -3.0
    >>> S, L = cap_region(a, [1.0, 0.0, 0.0])
    >>> F = region_force(P, th, S, L)
    >>> closed = np.sin(a) * np.sin(a + np.radians(th)) - 0.5 * np.sin(a) ** 2 * P
    >>> bool(np.isclose(F[0], closed)), F[1:].tolist()
    (True, [0.0, 0.0])
    """
    P = np.asarray(pressure, float)[..., None]
    t = np.radians(np.asarray(theta, float))[..., None]
    S = np.asarray(S, float)
    L = np.asarray(L, float)
    return ((2.0 * np.cos(t) - P) * S + np.sin(t) * L) / (2.0 * np.pi)


def cap_region(alpha, axis):
    """S* and L* of a spherical cap of half-angle ``alpha`` [rad] about ``axis``.

    Parameters
    ----------
    alpha : float or array_like
        Half-angle of the cap seen from the grain's centre [rad], in [0, pi].
    axis : array_like, shape (..., 3)
        Direction of the cap's centre (need not be unit).

    Returns
    -------
    S, L : numpy.ndarray, shape (..., 3)
        S* = pi sin^2(alpha) e, L* = 2 pi sin(alpha) cos(alpha) e (e the unit axis).
        A fully wetted sphere (alpha = pi) has S* = L* = 0.

    >>> S, L = cap_region(np.pi / 2, [0, 0, 2.0])
    >>> np.round(S / np.pi, 12).tolist(), np.round(L, 12).tolist()
    ([0.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    """
    a = np.asarray(alpha, float)[..., None]
    e = np.asarray(axis, float)
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    return np.pi * np.sin(a) ** 2 * e, 2.0 * np.pi * np.sin(a) * np.cos(a) * e


def cap_half_angle(S):
    """Half-angle [rad] (<= pi/2) of the cap with vector area S* (|S*| <= pi).

    >>> round(float(cap_half_angle(cap_region(0.4, [1, 1, 0])[0])), 12)
    0.4
    """
    s = np.linalg.norm(np.asarray(S, float), axis=-1) / np.pi
    return np.arcsin(np.sqrt(np.clip(s, 0.0, 1.0)))


def polygon_region(segments, centre, radius=1.0):
    """S* and L* of a wetted region bounded by a contact-line polygon on a sphere.

    Parameters
    ----------
    segments : array_like, shape (m, 2, 3)
        Edges (a, b) of the contact line (one or several closed loops), each run with
        the wetted region on its left seen from outside the grain; lengths in r.
    centre : array_like, shape (3,)
        The grain's centre.
    radius : float
        The grain's radius / r.

    Returns
    -------
    S, L : numpy.ndarray, shape (3,)
        S* = 1/2 sum (a - c) x (b - c) / R^2 and L* = sum |b - a| n_mid / R, n_mid the
        unit normal of the sphere at the edge's midpoint.

    >>> t = np.linspace(0, 2 * np.pi, 2001)
    >>> a = 0.3
    >>> p = np.stack([np.sin(a) * np.cos(t), np.sin(a) * np.sin(t), np.cos(a) + 0 * t], 1)
    >>> S, L = polygon_region(np.stack([p[:-1], p[1:]], 1), [0, 0, 0])
    >>> Sc, Lc = cap_region(a, [0, 0, 1])
    >>> bool(np.allclose(S, Sc, atol=1e-5)), bool(np.allclose(L, Lc, atol=1e-5))
    (True, True)
    """
    seg = np.asarray(segments, float)
    c = np.asarray(centre, float)
    a = seg[:, 0] - c
    b = seg[:, 1] - c
    S = 0.5 * np.cross(a, b).sum(axis=0) / radius ** 2
    m = 0.5 * (a + b)
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    L = (np.linalg.norm(b - a, axis=1)[:, None] * m).sum(axis=0) / radius
    return S, L


def meridian_half_angles(distance, ri, rj, theta, curvature):
    """Wetted caps of a bridge whose meridian is a circle of given curvature.

    The toroidal approximation of a bridge between spheres i and j: in a plane through
    the line of centres the liquid surface is a circle of signed radius
    rho = 1 / curvature (> 0: concave, its centre outside the liquid) meeting each
    sphere at the contact angle theta.  Its centre lies at
    D_k = sqrt(r_k^2 + rho^2 + 2 r_k rho cos(theta)) from centre k; the contact point on
    sphere i is at polar angle alpha_i from the direction to j with
    (x0, y0) = r_i (cos alpha_i, sin alpha_i) + rho (cos(alpha_i + theta),
    sin(alpha_i + theta)) (Fisher's construction; for equal spheres
    cos(alpha + theta) = curvature (1 - cos(alpha) + d / 2), d the surface gap).

    Parameters
    ----------
    distance : float or array_like
        Distance between the centres / r.
    ri, rj : float or array_like
        Radii / r.
    theta : float or array_like
        Contact angle [deg].
    curvature : float or array_like
        Meridian curvature 1 / rho, times r (|curvature| < 1e-4 is taken as +-1e-4).

    Returns
    -------
    alpha_i, alpha_j : numpy.ndarray
        Half-angles [rad] of the wetted caps, the smallest solution with both in
        (0, pi - theta); NaN where none (a concave meridian too curved to span the gap).
    neck : numpy.ndarray
        y0 - rho: the neck radius (concave) or bulge radius (convex) of the meridian
        circle, / r.

    For theta = 0 and equal grains at contact the caps are at arccos(1 / (1 + rho)):

    >>> a, _, y = meridian_half_angles(2.0, 1.0, 1.0, 0.0, 2.0)
    >>> bool(np.isclose(a, np.arccos(1 / 1.5))), bool(np.isclose(y, np.sqrt(1.5**2 - 1) - 0.5))
    (True, True)
    """
    d, ri, rj, t, k = np.broadcast_arrays(*[np.asarray(x, float) for x in (
        distance, ri, rj, np.radians(theta), curvature)])
    k = np.where(np.abs(k) < 1e-4, np.where(k < 0, -1e-4, 1e-4), k)
    rho = 1.0 / k
    Di = np.sqrt(ri ** 2 + rho ** 2 + 2 * ri * rho * np.cos(t))
    Dj = np.sqrt(rj ** 2 + rho ** 2 + 2 * rj * rho * np.cos(t))
    x0 = (Di ** 2 - Dj ** 2 + d ** 2) / (2 * d)
    tol = 1e-6 * (1 + np.abs(rho))
    best_i = np.full(d.shape, np.inf)
    best_j = np.full(d.shape, np.nan)
    neck = np.full(d.shape, np.nan)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(Di ** 2 - x0 ** 2)
        psi_i = np.arccos(np.clip((ri ** 2 + Di ** 2 - rho ** 2) / (2 * ri * Di), -1, 1))
        psi_j = np.arccos(np.clip((rj ** 2 + Dj ** 2 - rho ** 2) / (2 * rj * Dj), -1, 1))
        for s in (1.0, -1.0):            # the meridian circle's centre above or below
            y0 = s * h
            phi_i = np.arctan2(y0, x0)
            phi_j = np.arctan2(y0, d - x0)
            for si in (1.0, -1.0):       # which intersection with sphere i
                ai = phi_i + si * psi_i
                ei = np.hypot(x0 - ri * np.cos(ai) - rho * np.cos(ai + t),
                              y0 - ri * np.sin(ai) - rho * np.sin(ai + t))
                for sj in (1.0, -1.0):
                    aj = phi_j + sj * psi_j
                    ej = np.hypot(d - x0 - rj * np.cos(aj) - rho * np.cos(aj + t),
                                  y0 - rj * np.sin(aj) - rho * np.sin(aj + t))
                    ok = ((ei < tol) & (ej < tol) & (ai > 0) & (aj > 0)
                          & (ai + t < np.pi) & (aj + t < np.pi) & (ai < best_i))
                    best_i = np.where(ok, ai, best_i)
                    best_j = np.where(ok, aj, best_j)
                    neck = np.where(ok, y0 - rho, neck)
    best_i = np.where(np.isfinite(best_i), best_i, np.nan)
    return best_i, best_j, neck


#: meridian curvatures scanned by :func:`toroidal_half_angles` (times r)
_K_GRID = np.concatenate([np.linspace(-5.0, 10.0, 1501), np.linspace(10.05, 60.0, 1000)])


def toroidal_half_angles(distance, ri, rj, theta, pressure):
    """Wetted caps of the toroidal bridge between two spheres at a given pressure.

    The meridian circle (:func:`meridian_half_angles`) whose curvature k and neck
    radius y_n satisfy Laplace's law at the neck, P* = 1 / y_n - k.  Of the solutions,
    the one with the widest caps (the stable, larger-volume branch).  At suctions beyond
    the bridge's minimum pressure there is none; the caps of that minimum are returned
    (``exists`` False): a bridge inside a coalesced body keeps wetting its grains.

    Parameters
    ----------
    distance, ri, rj : float
        Distance between the centres and radii / r.
    theta : float
        Contact angle [deg].
    pressure : float
        P* = dp r / gamma.

    Returns
    -------
    alpha_i, alpha_j : float
        Half-angles [rad].
    exists : bool
        Whether a toroidal bridge at ``pressure`` exists.

    >>> ai, aj, ok = toroidal_half_angles(2.0, 1.0, 1.0, 30.0, -1.787)
    >>> ok, round(float(np.degrees(ai)), 0)
    (True, 29.0)
    """
    a, b, yn = meridian_half_angles(distance, ri, rj, theta, _K_GRID)
    with np.errstate(divide="ignore", invalid="ignore"):
        Pk = 1.0 / yn - _K_GRID
    ok = np.isfinite(Pk) & np.isfinite(a) & (yn > 0)
    if not ok.any():
        return np.nan, np.nan, False
    g = Pk - pressure
    cross = np.where(ok[:-1] & ok[1:] & (np.sign(g[:-1]) != np.sign(g[1:])))[0]
    if len(cross):
        best = None
        for c in cross:                  # linear interpolation in the bracket
            w = g[c] / (g[c] - g[c + 1])
            ai = a[c] + w * (a[c + 1] - a[c])
            aj = b[c] + w * (b[c + 1] - b[c])
            if best is None or ai > best[0]:
                best = (float(ai), float(aj))
        return best[0], best[1], True
    m = np.argmin(np.where(ok, Pk, np.inf))
    return float(a[m]), float(b[m]), False


def toroidal_fold(distance, ri, rj, theta):
    """The fold of the toroidal bridge family: its least pressure on the stable side.

    Following the bridges of :func:`meridian_half_angles` from rupture (the smallest
    caps, P* -> +inf) toward wider caps, the pressure falls to a minimum and rises again
    (or falls until the family ends); the first minimum is the fold, where the stable
    bridge ceases to exist under more suction.  Unlike the global minimum over the
    scanned curvatures (which ``toroidal_half_angles`` returns when no bridge exists),
    the fold moves continuously with the gap and theta.

    Returns
    -------
    alpha_i, alpha_j : float
        The fold's half-angles [rad] (NaN where no bridge of the family exists).
    pressure : float
        P* at the fold.

    >>> ai, aj, Pf = toroidal_fold(2.2, 1.0, 1.0, 0.0)
    >>> round(float(np.degrees(ai)), 0), round(Pf, 2)
    (21.0, -1.51)
    """
    a, b, yn = meridian_half_angles(distance, ri, rj, theta, _K_GRID)
    with np.errstate(divide="ignore", invalid="ignore"):
        Pk = 1.0 / yn - _K_GRID
    ok = np.isfinite(Pk) & np.isfinite(a) & np.isfinite(b) & (yn > 0)
    idx = np.where(ok)[0]
    if not len(idx):
        return np.nan, np.nan, np.nan
    top = idx[-1]                        # the rupture end (the largest curvature)
    m = top
    while m - 1 >= 0 and ok[m - 1]:
        m -= 1
    seg = np.arange(top, m - 1, -1)      # from rupture toward wider caps
    # slope of P* per unit curvature walked (negative while P* falls)
    s = (Pk[seg[1:]] - Pk[seg[:-1]]) / (_K_GRID[seg[:-1]] - _K_GRID[seg[1:]])
    up = np.where(s >= 0)[0]
    if len(up):                          # the first minimum
        f = seg[up[0]]
    else:                                # none: the first place it falls slowest
        mx = np.where((s[1:-1] > s[:-2]) & (s[1:-1] >= s[2:]))[0]
        f = seg[mx[0] + 1] if len(mx) else seg[-1]
    return float(a[f]), float(b[f]), float(Pk[f])


#: window-ball radius standing for P* >= 0 (flat windows), times r
_B_FLAT = 1e6


def window_radius(pressure, kappa=2.0):
    """Radius kappa / |P*| of the window balls (gas spheres of the body's curvature),
    continued through P* >= 0 by a very large ball (a flat window, the limit P* -> 0-)."""
    return kappa / max(-float(pressure), kappa / _B_FLAT)


def torus_reach(distance, ri, rj, theta, ball):
    """How far the liquid between two grains reaches toward their line of centres.

    A gas torus of tube radius ``ball`` (the body's window radius, :func:`window_radius`)
    around the line of centres, meeting both grains at the contact angle: in a plane
    through the line of centres a circle whose centre is at
    D_k = sqrt(R_k^2 + b^2 + 2 R_k b cos(theta)) from centre k.  Returns the polar angles
    (about the direction to the other grain) [rad] at which it meets each grain, >= 0; 0
    where the torus passes through the gap (its circle reaches the line of centres, or
    fits between the grains).  A very large ball gives the flat limit (90 deg - theta
    for equal grains); the angles shrink as the ball does.

    >>> bi, bj = torus_reach(2.2, 1.0, 1.0, 30.0, 1e6)
    >>> round(float(np.degrees(bi)), 3)
    60.0
    >>> torus_reach(2.2, 1.0, 1.0, 0.0, 0.05)
    (0.0, 0.0)
    """
    d, b, t = float(distance), float(ball), np.radians(theta)
    Di = np.sqrt(ri ** 2 + b ** 2 + 2 * ri * b * np.cos(t))
    Dj = np.sqrt(rj ** 2 + b ** 2 + 2 * rj * b * np.cos(t))
    x0 = (Di ** 2 - Dj ** 2 + d ** 2) / (2 * d)
    h2 = Di ** 2 - x0 ** 2
    if h2 <= 0:
        return 0.0, 0.0
    h = np.sqrt(h2)
    out = []
    for R, D, x in ((ri, Di, x0), (rj, Dj, d - x0)):
        psi = np.arccos(np.clip((R ** 2 + D ** 2 - b ** 2) / (2 * R * D), -1, 1))
        out.append(max(float(np.arctan2(h, x) - psi), 0.0))
    return out[0], out[1]


def pair_caps(distance, ri, rj, theta, pressure, missing_bridge="reach", window_kappa=2.0):
    """Half-angles of a bridged pair's caps in a coalesced body at pressure P*.

    The toroidal bridge's (:func:`toroidal_half_angles`) where it exists at P*.  Where
    it does not (more suction than its fold, :func:`toroidal_fold`), by
    ``missing_bridge``:

    * ``"reach"``: the fold's caps, but no wider than the reach beta(P*) of the gas
      torus of the body's window radius (:func:`torus_reach`, :func:`window_radius`):
      in suction beta exceeds every existing bridge's caps, so the caps are the fold's
      at the fold and shrink as the suction grows, to zero where a gas torus of the
      body's curvature passes through the gap (continuous in P*, the gap and theta;
      where the fold is at P* > 0 the caps jump there from beta to the fold's);
    * ``"fold"``: the fold's caps;
    * ``"minimum"``: the caps at the least pressure over the scanned curvatures
      (:func:`toroidal_half_angles`; may jump with the gap and theta where that least
      pressure is at the scan's end);
    * ``"none"``: no cap.

    Returns
    -------
    alpha_i, alpha_j : float
        [rad]; NaN where the pair has no bridge of any kind.
    exists : bool
        Whether the toroidal bridge exists at P*.
    """
    ai, aj, ok = toroidal_half_angles(distance, ri, rj, theta, pressure)
    if ok or missing_bridge == "minimum":
        return ai, aj, ok
    if missing_bridge == "none":
        return 0.0, 0.0, False
    fi, fj, Pf = toroidal_fold(distance, ri, rj, theta)
    if missing_bridge == "fold" or not np.isfinite(fi):
        return fi, fj, False
    bi, bj = torus_reach(distance, ri, rj, theta, window_radius(pressure, window_kappa))
    return min(fi, bi), min(fj, bj), False


def _cap_boundary(e, alpha, n):
    """n + 1 points (closed) of a cap's circle, counter-clockwise seen from outside."""
    h = np.array([1.0, 0.0, 0.0]) if abs(e[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(e, h)
    u /= np.linalg.norm(u)
    w = np.cross(e, u)
    t = np.linspace(0.0, 2 * np.pi, n + 1)
    return (np.cos(alpha) * e[None, :] + np.sin(alpha) * (np.cos(t)[:, None] * u
                                                         + np.sin(t)[:, None] * w))


def _polygon_boundary(V, n):
    """Great-circle edges of a spherical polygon (vertices V, counter-clockwise seen
    from outside), n points per edge; (m + 1, 3) closed."""
    pts = []
    for a, b in zip(V, np.roll(V, -1, axis=0)):
        w = np.linspace(0.0, 1.0, n, endpoint=False)[:, None]
        p = (1 - w) * a + w * b
        pts.append(p / np.linalg.norm(p, axis=1, keepdims=True))
    pts.append(V[:1])
    return np.concatenate(pts)


def _inside(piece, x, eps=1e-12):
    kind, data = piece
    if kind == "cap":
        e, alpha = data
        return x @ e > np.cos(alpha) + eps
    V = data
    res = np.ones(len(x), bool)
    for a, b in zip(V, np.roll(V, -1, axis=0)):
        res &= x @ np.cross(a, b) > eps
    return res


def union_region(pieces, n=720, holes=()):
    """S* and L* (unit sphere) of a union of convex pieces of the sphere.

    Parameters
    ----------
    pieces : list
        ``("cap", (e, alpha))`` (unit axis e, half-angle alpha [rad] in (0, pi/2]) or
        ``("polygon", V)`` (spherical polygon, unit vertices (m, 3) counter-clockwise seen
        from outside, within a hemisphere).
    n : int
        Boundary points per cap circle (polygons: n / 8 per edge); the error of S* and
        L* is O(1 / n) where boundaries cross.
    holes : sequence of (e, alpha)
        Caps taken out of the union (dry discs).

    Returns
    -------
    S, L : numpy.ndarray, shape (3,)
        The region's boundary is the part of each piece's boundary outside every other
        piece and every hole, and the part of each hole's circle inside the union,
        run with the region on its left; S* = 1/2 sum a x b, L* = sum |b - a| n.

    Two equal caps on opposite sides cancel:

    >>> S, L = union_region([("cap", ([1., 0, 0], 0.5)), ("cap", ([-1., 0, 0], 0.5))])
    >>> bool(np.allclose(S, 0, atol=1e-12)), bool(np.allclose(L, 0, atol=1e-12))
    (True, True)
    """
    norm = []
    for kind, data in pieces:
        if kind == "cap":
            e = np.asarray(data[0], float)
            norm.append(("cap", (e / np.linalg.norm(e), float(data[1]))))
        else:
            V = np.asarray(data, float)
            norm.append(("polygon", V / np.linalg.norm(V, axis=1, keepdims=True)))
    hl = [("cap", (np.asarray(e, float) / np.linalg.norm(e), float(a)))
          for e, a in holes if np.isfinite(a) and a > 0]
    S = np.zeros(3)
    L = np.zeros(3)

    def add(a, b, keep):
        nonlocal S, L
        a, b = a[keep], b[keep]
        m = 0.5 * (a + b)
        m = m / np.linalg.norm(m, axis=1, keepdims=True)
        S += 0.5 * np.cross(a, b).sum(axis=0)
        L += (np.linalg.norm(b - a, axis=1)[:, None] * m).sum(axis=0)

    def mids(p):
        m = 0.5 * (p[:-1] + p[1:])
        ln = np.linalg.norm(m, axis=1, keepdims=True)
        return m / np.where(ln > 0, ln, 1.0)

    for k, (kind, data) in enumerate(norm):
        if kind == "cap":
            p = _cap_boundary(data[0], data[1], n)
        else:
            p = _polygon_boundary(data, max(n // 8, 4))
        m = mids(p)
        out = np.ones(len(m), bool)
        for q, other in enumerate(norm + hl):
            if q != k:
                out &= ~_inside(other, m)
        add(p[:-1], p[1:], out)
    for k, (_, (e, a)) in enumerate(hl):
        p = _cap_boundary(e, a, n)[::-1]          # clockwise: the region on its left
        m = mids(p)
        inside = np.zeros(len(m), bool)
        for piece in norm:
            inside |= _inside(piece, m)
        for q, other in enumerate(hl):
            if q != k:
                inside &= ~_inside(other, m)
        add(p[:-1], p[1:], inside)
    return S, L


def cap_hull_polygon(e1, a1, e2, a2):
    """The spherical quadrilateral that, with the two caps, makes their convex hull.

    Its vertices are the points where the two great circles tangent to both caps (with
    both caps on the same side) touch them.  ``a2 = 0`` makes cap 2 a point.

    Returns
    -------
    numpy.ndarray, shape (4, 3), or None
        Vertices counter-clockwise seen from outside; None when one cap holds the other
        or no such tangent exists.
    """
    e1 = np.asarray(e1, float) / np.linalg.norm(e1)
    e2 = np.asarray(e2, float) / np.linalg.norm(e2)
    g = float(e1 @ e2)
    if 1 - g * g < 1e-12:
        return None
    s1, s2 = np.sin(a1), np.sin(a2)
    a = (s1 - g * s2) / (1 - g * g)
    b = (s2 - g * s1) / (1 - g * g)
    base = a * e1 + b * e2
    c2 = 1.0 - base @ base
    if c2 <= 0:
        return None
    w = np.cross(e1, e2)
    w /= np.linalg.norm(w)
    pts = []
    for sgn in (1.0, -1.0):
        nrm = base + sgn * np.sqrt(c2) * w
        pts.append(((e1 - s1 * nrm) / np.cos(a1), (e2 - s2 * nrm) / np.cos(a2)))
    V = np.array([pts[0][0], pts[0][1], pts[1][1], pts[1][0]])
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    centre = V.sum(axis=0)
    if centre @ np.cross(V[1] - V[0], V[2] - V[0]) < 0:
        V = V[::-1]
    return V


def _ccw(V):
    V = np.asarray(V, float)
    V = V / np.linalg.norm(V, axis=1, keepdims=True)
    if V.sum(axis=0) @ np.cross(V[1] - V[0], V[2] - V[0]) < 0:
        V = V[::-1]
    return V


def window_balls(centres, radii, theta, ball):
    """Centres of the gas balls of radius ``ball`` that touch three grains at the
    contact angle (the windows of a pore body), or an empty array.

    A ball meeting sphere m at the contact angle theta has its centre at
    D_m = sqrt(R_m^2 + b^2 + 2 R_m b cos(theta)) from c_m; the balls touching three
    grains are the two intersections of those three spheres, one on each side of the
    plane of the centres.

    Returns
    -------
    numpy.ndarray, shape (k, 3), k = 0 or 2
    """
    C = np.asarray(centres, float)
    R = np.asarray(radii, float)
    t = np.radians(theta)
    D = np.sqrt(R ** 2 + ball ** 2 + 2 * R * ball * np.cos(t))
    ex = C[1] - C[0]
    dx = np.linalg.norm(ex)
    ex /= dx
    i = ex @ (C[2] - C[0])
    ey = C[2] - C[0] - i * ex
    dy = np.linalg.norm(ey)
    if dy < 1e-12:
        return np.zeros((0, 3))
    ey /= dy
    ez = np.cross(ex, ey)
    x = (D[0] ** 2 - D[1] ** 2 + dx ** 2) / (2 * dx)
    y = (D[0] ** 2 - D[2] ** 2 + i ** 2 + dy ** 2 - 2 * i * x) / (2 * dy)
    z2 = D[0] ** 2 - x ** 2 - y ** 2
    if z2 <= 0:
        return np.zeros((0, 3))
    z = np.sqrt(z2)
    base = C[0] + x * ex + y * ey
    return np.array([base + z * ez, base - z * ez])


def predict_regions(centres, radii, theta, pressure, pairs, max_open_gap=1.0,
                    open_side="mirror", pores=True, windows=True, window_kappa=2.0,
                    pore_shape="kite", flat_windows=False, missing_bridge="reach",
                    positive_pressure="flat", n=720):
    """Wetted regions (S*, L*) of every grain of one coalesced body, without minimisation.

    Grain i's region is the union of

    * a cap toward each bridged neighbour j (``pairs``), its half-angle that of the
      toroidal bridge at the body's pressure (:func:`toroidal_half_angles`; beyond the
      bridge's fold, caps that shrink with the suction, :func:`pair_caps`);
    * for each triangle of the body (i bridged to j and k, the gap j-k at most
      ``max_open_gap``) a pore piece on each of its grains (``pore_shape``): by default
      (``"kite"``, with ``windows``) in suction the spherical polygon through the
      directions to the other two grains and to the triangle's window balls (gas
      spheres of radius 2 / |P*|, the Laplace radius of a spherical window, touching
      the three grains at the contact angle, :func:`window_balls`), less the balls'
      dry discs, continued through P* >= 0 by flat windows (the limit P* -> 0-, so that
      the regions are continuous in P*; ``positive_pressure``); where no window ball
      exists (a ball that passes through the triangle, or one that would cut another
      grain), the spherical convex hull of the caps toward the other two
      (:func:`cap_hull_polygon`), with, on an open side's grains, a cap toward the far
      grain (``open_side``);
    * for each filled tetrahedron (four grains, six bridged pairs), the spherical
      triangle spanned by the directions to the other three.

    Accuracy against Surface Evolver: ``benchmarks/bench_wetted_region.py`` (good in
    suction, poor for the convex bodies of P* > 0).

    Parameters
    ----------
    centres : array_like, shape (N, 3)
        Grain centres / r.
    radii : array_like, shape (N,)
        Radii / r.
    theta : float
        Contact angle [deg], all grains.
    pressure : float
        The body's P*.
    pairs : sequence of (i, j)
        Bridged pairs of the body (0-based).
    max_open_gap : float
        Largest surface gap / r of an open side whose triangle holds a pore body.
    open_side : {"point", "toroidal", "mirror"}
        The cap of an open side's grain toward the far grain: the point facing it,
        the toroidal cap of that pair at the body's pressure (none where no such
        bridge exists), or as wide as the grain's cap toward its bridged neighbour.
    pores : bool
        False: the caps alone (no triangle or tetrahedron pieces), the bridges of the
        body at its pressure.
    windows : bool
        In suction (P* < 0; at any P* with ``positive_pressure="flat"``), take out of
        each grain the dry discs of the window balls
        (:func:`window_balls`) of every triangle of the body: gas spheres of radius
        ``window_kappa / |P*|`` (2: a spherical window, Laplace-consistent) touching
        the triangle's three grains, except those that would cut another grain of the
        body (the pore's inside, e.g. a filled tetrahedron's).
    pore_shape : {"hull", "kite"}
        The pore piece of each triangle on each of its grains: the convex hull of the
        caps toward the other two ("hull"), or, where window balls exist, the
        spherical polygon through the directions to the other two grains and the
        directions to the window balls ("kite", with ``windows``; hull elsewhere).
    flat_windows : bool
        With ``pore_shape="kite"`` and P* >= 0 (no window ball), the pore piece of a
        triangle on a grain is the lune between the directions to the other two grains,
        cut at latitude +-(90 deg - theta) from the plane of the triangle (flat windows
        meeting the grains at the contact angle) instead of the hull.
    missing_bridge : {"reach", "fold", "minimum", "none"}
        A bridged pair with no toroidal bridge at the body's pressure (its suction is
        beyond the bridge's fold, e.g. wide gaps at large theta, where the bridge's
        pressure never falls below zero), :func:`pair_caps`: the fold's caps, no wider
        than the reach of a gas torus of the body's curvature ("reach", continuous in
        the gap and P*), the fold's caps ("fold"), the caps at the least pressure over
        the scanned curvatures ("minimum", the model before 2026-11-27: it jumps with
        the gap), or no cap ("none"), the pair's liquid then being the pore's alone.
    positive_pressure : {"flat", "hull"}
        The pore piece of a triangle at P* >= 0: the window construction with flat
        windows (balls of radius :func:`window_radius`, the limit of the suction's
        pieces as P* -> 0-: continuous through P* = 0), or, as before 2026-11-27, the
        convex hull of the caps (or the lune of ``flat_windows``), which jumps there.
    n : int
        Boundary resolution (:func:`union_region`).

    Returns
    -------
    S, L : numpy.ndarray, shape (N, 3)
        Per grain, on its unit sphere (S* for a grain of radius R is R^2 times this).
    info : dict
        ``alpha`` {(i, j): (alpha_i, alpha_j, exists)}, ``triangles``, ``tetrahedra``.

    One pair is the toroidal doublet:

    >>> S, L, info = predict_regions([[0, 0, 0], [2.1, 0, 0]], [1, 1], 30.0, -2.0, [(0, 1)])
    >>> ai = info["alpha"][(0, 1)][0]
    >>> bool(np.allclose(S[0], cap_region(ai, [1, 0, 0])[0], atol=1e-4))
    True
    """
    if missing_bridge not in ("reach", "fold", "minimum", "none"):
        raise ValueError("missing_bridge must be 'reach', 'fold', 'minimum' or 'none', "
                         f"got {missing_bridge!r}")
    if positive_pressure not in ("flat", "hull"):
        raise ValueError(f"positive_pressure must be 'flat' or 'hull', got {positive_pressure!r}")
    C = np.asarray(centres, float)
    N = len(C)
    R = np.broadcast_to(np.asarray(radii, float), (N,))
    bridged = {tuple(sorted(p)) for p in pairs}
    alpha = {}
    for i, j in sorted(bridged):
        alpha[(i, j)] = pair_caps(np.linalg.norm(C[j] - C[i]), R[i], R[j], theta, pressure,
                                  missing_bridge, window_kappa)

    def u(i, j):
        v = C[j] - C[i]
        return v / np.linalg.norm(v)

    def cap_of(i, j):
        """(axis, half-angle) of grain i's cap toward j, or None."""
        key = (min(i, j), max(i, j))
        if key in alpha:
            ai, aj, ok = alpha[key]
            a = ai if i < j else aj
        elif open_side == "mirror":
            # the cap of grain i toward its bridged neighbour in the same triangle
            a = max((alpha[(min(i, m), max(i, m))][0 if i < m else 1]
                     for m in range(N) if (min(i, m), max(i, m)) in alpha),
                    default=0.0)
        elif open_side == "toroidal":
            ai, aj, ok = toroidal_half_angles(np.linalg.norm(C[j] - C[i]), R[min(i, j)],
                                              R[max(i, j)], theta, pressure)
            a = (ai if i < j else aj) if ok else 0.0
        else:
            a = 0.0
        return (u(i, j), float(a)) if np.isfinite(a) else None

    def cap_pieces():
        """Per grain, the caps toward its bridged neighbours."""
        out = [[] for _ in range(N)]
        for i, j in sorted(bridged):
            for g, h in ((i, j), (j, i)):
                c = cap_of(g, h)
                if c is not None and c[1] > 0:
                    out[g].append(("cap", c))
        return out

    pieces = cap_pieces()
    neigh = {i: sorted({j for p in bridged for j in p if i in p} - {i}) for i in range(N)}
    triangles = []
    for i in range(N):
        for a_, j in enumerate(neigh[i]):
            for k in neigh[i][a_ + 1:]:
                gap = np.linalg.norm(C[j] - C[k]) - R[j] - R[k]
                if gap > max_open_gap or not pores:
                    continue
                triangles.append((i, j, k))
                hulls = [(i, j, k)]
                if (min(j, k), max(j, k)) not in bridged:
                    hulls += [(j, i, k), (k, i, j)]
                for g, p, q in hulls:
                    cp, cq = cap_of(g, p), cap_of(g, q)
                    if cp is None or cq is None:
                        continue
                    V = cap_hull_polygon(cp[0], cp[1], cq[0], cq[1])
                    if V is not None:
                        pieces[g].append(("polygon", V))
                    if cq[1] > 0 and (min(g, q), max(g, q)) not in bridged:
                        pieces[g].append(("cap", cq))
    tetrahedra = []
    for i in range(N):
        for a_, j in enumerate(neigh[i]):
            for b_, k in enumerate(neigh[i][a_ + 1:]):
                for l in neigh[i][a_ + b_ + 2:]:
                    if pores and all((min(x, y), max(x, y)) in bridged
                           for x, y in ((j, k), (j, l), (k, l))):
                        pieces[i].append(("polygon", _ccw([u(i, j), u(i, k), u(i, l)])))
                        tetrahedra.append(tuple(sorted((i, j, k, l))))
    holes = [[] for _ in range(N)]
    # window balls: in suction, and at P* >= 0 as flat windows (positive_pressure="flat")
    use_balls = windows and pores and (pressure < 0 or positive_pressure == "flat")
    bw = (window_radius(pressure, window_kappa) if positive_pressure == "flat"
          else window_kappa / max(abs(float(pressure)), 1e-12))
    Dm = np.sqrt(R ** 2 + bw ** 2 + 2 * R * bw * np.cos(np.radians(theta)))
    if windows and pores and pore_shape == "kite" and (use_balls or flat_windows):
        # replace each triangle's hull pieces by polygons through the window balls
        pieces = cap_pieces()
        for i, j, k in triangles:
            balls = []
            for b in (window_balls(C[[i, j, k]], R[[i, j, k]], theta, bw)
                      if use_balls else []):
                dist = np.linalg.norm(C - b, axis=1)
                if not any(dist[m] < Dm[m] - 1e-9 for m in range(N) if m not in (i, j, k)):
                    balls.append(b)
            for m, a_, b_ in ((i, j, k), (j, i, k), (k, i, j)):
                if m != i and (min(j, k), max(j, k)) in bridged:
                    continue            # a closed triangle: each grain once, as i
                if not balls and flat_windows and pressure >= 0 and not use_balls:
                    # flat windows: the grains cut the planes at +-cos(theta) from the
                    # plane of the centres at the contact angle; the pore piece spans
                    # the lune between the directions to the other two grains up to
                    # latitude +-(90 deg - theta)
                    nz = np.cross(C[a_] - C[m], C[b_] - C[m])
                    nz /= np.linalg.norm(nz)
                    lat = np.pi / 2 - np.radians(theta)
                    V = []
                    for x, sg in ((a_, 1), (b_, 1), (b_, -1), (a_, -1)):
                        V.append(np.cos(lat) * u(m, x) + sg * np.sin(lat) * nz)
                    V = [u(m, a_), V[0], V[1], u(m, b_), V[2], V[3]]
                    pieces[m].append(("polygon", _ccw(V)))
                elif balls:
                    V = [u(m, a_)] + [(balls[0] - C[m]) / np.linalg.norm(balls[0] - C[m])] \
                        + [u(m, b_)] + [(bb - C[m]) / np.linalg.norm(bb - C[m])
                                        for bb in balls[1:]]
                    pieces[m].append(("polygon", _ccw(V)))
                else:
                    cp, cq = cap_of(m, a_), cap_of(m, b_)
                    if cp is not None and cq is not None:
                        Vh = cap_hull_polygon(cp[0], cp[1], cq[0], cq[1])
                        if Vh is not None:
                            pieces[m].append(("polygon", Vh))
        for i, j, k, l in sorted(set(tetrahedra)):
            for m in (i, j, k, l):
                o = [x for x in (i, j, k, l) if x != m]
                pieces[m].append(("polygon", _ccw([u(m, x) for x in o])))
    if use_balls:
        for tri in sorted({tuple(sorted(t)) for t in triangles}):
            tri = list(tri)
            for b in window_balls(C[tri], R[tri], theta, bw):
                dist = np.linalg.norm(C - b, axis=1)
                others = [m for m in range(N) if m not in tri]
                if any(dist[m] < Dm[m] - 1e-9 for m in others):
                    continue
                for m in tri:
                    cpsi = (R[m] ** 2 + dist[m] ** 2 - bw ** 2) / (2 * R[m] * dist[m])
                    holes[m].append((b - C[m], float(np.arccos(np.clip(cpsi, -1, 1)))))
    S = np.zeros((N, 3))
    L = np.zeros((N, 3))
    for g in range(N):
        if pieces[g]:
            S[g], L[g] = union_region(pieces[g], n, holes=holes[g])
    return S, L, {"alpha": alpha, "triangles": triangles,
                  "tetrahedra": sorted(set(tetrahedra))}


def _in_tetrahedron(x, V):
    """Whether the points x (M, 3) lie in the tetrahedron with vertices V (4, 3)."""
    T = np.stack([V[1] - V[0], V[2] - V[0], V[3] - V[0]], axis=1)
    if abs(np.linalg.det(T)) < 1e-14:
        return np.zeros(len(x), bool)
    lam = np.linalg.solve(T, (x - V[0]).T).T
    return np.all(lam >= 0, axis=1) & (lam.sum(axis=1) <= 1)


def body_volume(centres, radii, theta, pressure, pairs, max_open_gap=1.0,
                window_kappa=2.0, n_samples=400_000, seed=0, missing_bridge="minimum"):
    """Liquid volume V* of the window model's body at pressure P* < 0 (Monte Carlo).

    The body is the union, outside every grain, of

    * each bridged pair's toroidal bridge at P* (:func:`toroidal_half_angles`): the
      points between the two contact planes closer to the line of centres than the
      meridian circle;
    * for each triangle of the body (as in :func:`predict_regions`) the double
      pyramid of its three centres and its two window-ball centres
      (:func:`window_balls`), outside the window balls;
    * each filled tetrahedron of centres.

    Parameters
    ----------
    centres, radii, theta, pressure, pairs, max_open_gap, window_kappa
        As :func:`predict_regions` (equal radii or not; lengths / r).
    n_samples : int
        Uniform samples in the bounding box of the grains (deterministic ``seed``);
        the standard error is about sqrt(V_box V / n_samples).
    seed : int
    missing_bridge : {"minimum", "none"}
        As :func:`predict_regions`: a bridged pair with no toroidal bridge at P*
        holds the bridge of its pressure minimum, or no bridge (only pore liquid).

    Returns
    -------
    float
        V* = V / r^3; NaN for a body with a pore (a triangle) at P* >= 0 (no window
        balls: the model's pore is not closed there).

    >>> V = body_volume([[0, 0, 0], [2.1, 0, 0]], [1, 1], 30.0, -2.0, [(0, 1)])
    >>> 0.05 < V < 0.2
    True
    """
    C = np.asarray(centres, float)
    N = len(C)
    R = np.broadcast_to(np.asarray(radii, float), (N,))
    t = np.radians(theta)
    lo = C.min(axis=0) - R.max()
    hi = C.max(axis=0) + R.max()
    rng = np.random.default_rng(seed)
    x = lo + (hi - lo) * rng.random((int(n_samples), 3))
    box = float(np.prod(hi - lo))
    solid = np.zeros(len(x), bool)
    for m in range(N):
        solid |= np.linalg.norm(x - C[m], axis=1) < R[m]
    liquid = np.zeros(len(x), bool)
    bridged = sorted({tuple(sorted(p)) for p in pairs})
    for i, j in bridged:
        d = float(np.linalg.norm(C[j] - C[i]))
        ai, aj, ok = toroidal_half_angles(d, R[i], R[j], theta, pressure)
        if not (np.isfinite(ai) and np.isfinite(aj)) or (not ok and missing_bridge == "none"):
            continue
        rho = (d - R[i] * np.cos(ai) - R[j] * np.cos(aj)) / (np.cos(ai + t) + np.cos(aj + t))
        x0 = R[i] * np.cos(ai) + rho * np.cos(ai + t)
        y0 = R[i] * np.sin(ai) + rho * np.sin(ai + t)
        u = (C[j] - C[i]) / d
        s = (x - C[i]) @ u
        r_ = np.linalg.norm(x - C[i] - s[:, None] * u, axis=1)
        inside_s = (s >= R[i] * np.cos(ai)) & (s <= d - R[j] * np.cos(aj))
        with np.errstate(invalid="ignore"):
            root = np.sqrt(np.clip(rho ** 2 - (s - x0) ** 2, 0.0, None))
        prof = y0 - np.sign(rho) * root
        liquid |= inside_s & (r_ <= prof)
    bw = window_kappa / max(abs(float(pressure)), 1e-12)
    Dm = np.sqrt(R ** 2 + bw ** 2 + 2 * R * bw * np.cos(t))
    neigh = {i: sorted({j for p in bridged for j in p if i in p} - {i}) for i in range(N)}
    tris = set()
    for i in range(N):
        for a_, j in enumerate(neigh[i]):
            for k in neigh[i][a_ + 1:]:
                if np.linalg.norm(C[j] - C[k]) - R[j] - R[k] <= max_open_gap:
                    tris.add(tuple(sorted((i, j, k))))
    if tris and not pressure < 0:
        return float("nan")
    for tri in sorted(tris):
        tri = list(tri)
        for b in window_balls(C[tri], R[tri], theta, bw):
            dist = np.linalg.norm(C - b, axis=1)
            if any(dist[m] < Dm[m] - 1e-9 for m in range(N) if m not in tri):
                continue
            inb = np.linalg.norm(x - b, axis=1) < bw
            liquid |= _in_tetrahedron(x, np.vstack([C[tri], b])) & ~inb
    for i in range(N):
        for a_, j in enumerate(neigh[i]):
            for b_, k in enumerate(neigh[i][a_ + 1:]):
                for l in neigh[i][a_ + b_ + 2:]:
                    if all(tuple(sorted((p, q))) in bridged
                           for p, q in ((j, k), (j, l), (k, l))):
                        liquid |= _in_tetrahedron(x, C[[i, j, k, l]])
    return box * float(np.mean(liquid & ~solid))


def pressure_from_volume(centres, radii, theta, volume, pairs, bracket=(-60.0, -0.02),
                         xtol=1e-4, **kw):
    """The window model's pressure P* < 0 at which its body holds ``volume``.

    Solves :func:`body_volume` (``kw`` passed on: ``max_open_gap``, ``window_kappa``,
    ``n_samples``, ``seed``, ``missing_bridge``) = V* for P* in ``bracket`` by Brent's
    method on log(-P*); the Monte Carlo samples are the same at every P* (fixed seed),
    so the volume is a step function of P* with steps of about V_box / n_samples.

    Returns
    -------
    float
        P*; NaN when ``volume`` is not within the model's volumes over the bracket
        (above the volume at the weakest suction: a body at P* >= 0, where the model
        has no closed pore, or below that at the strongest).

    >>> P = pressure_from_volume([[0, 0, 0], [2.1, 0, 0]], [1, 1], 30.0, 0.1, [(0, 1)],
    ...                          n_samples=100_000)
    >>> V = body_volume([[0, 0, 0], [2.1, 0, 0]], [1, 1], 30.0, P, [(0, 1)],
    ...                 n_samples=100_000)
    >>> bool(P < 0 and abs(V - 0.1) < 0.01)
    True
    """
    from scipy.optimize import brentq

    lo, hi = float(bracket[0]), float(bracket[1])
    if not lo < hi < 0:
        raise ValueError(f"bracket must be two negative pressures lo < hi, got {bracket}")

    def g(s):
        return body_volume(centres, radii, theta, -np.exp(s), pairs, **kw) - volume

    a, b = np.log(-hi), np.log(-lo)
    ga, gb = g(a), g(b)
    if not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0:
        return float("nan")
    return float(-np.exp(brentq(g, a, b, xtol=xtol)))
