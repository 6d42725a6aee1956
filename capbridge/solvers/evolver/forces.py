"""Forces on the grains from a converged shape, and by virtual work.

Sign and units: ``forces[k]`` is the force the liquid exerts on grain k, in units of
2 pi gamma r (F*).  For a doublet the attraction is F_0 . u_01 (u_01 the unit vector from
grain 0 to grain 1), positive when the grains are pulled together.

Direct method (boundary method) on grain k, per body wetting it::

    F = sum_contact_edges L nu  -  P S  +  Bo (k.c S + M k / R)

with L the edge length, nu the conormal of the liquid-gas surface (unit, tangent to the
surface, normal to the contact line, pointing away from the line into the meniscus),
P the body's Lagrange multiplier (pressure at height h = 0), S = \\int_cap n dA the
vector area of the wetted cap (exact for the contact polygon), and the last term the
hydrostatic part -\\int_cap (-Bo h) n dA with M = \\int_cap p p^T dA.  Two conormals are
computed: from Young's law at the contact line (``nu = cos t (n x t) + sin t n``; the
default, second-order accurate) and from the facets touching the line (first order;
its angle to the grain is the *measured* contact angle, a diagnostic).

Virtual work: F . u = -(E(+delta u) - E(-delta u)) / (2 delta) with E the minimised
total energy (surface + gravitational), re-minimised at fixed mesh topology after moving
the grain (central differences).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import cap_second_moment, vector_area


@dataclass
class DirectForces:
    young: np.ndarray                  # (N, 3) F*, Young's-law conormal
    facet: np.ndarray                  # (N, 3) F*, facet conormal
    pressure_part: np.ndarray          # (N, 3) F*, -P S (+ hydrostatic)
    measured_angle_deg: dict = field(default_factory=dict)   # constraint -> mean angle
    reversed_edges: int = 0            # contact edges oriented against their facet
    pole_clearance: float = 1.0        # min over contact vertices of 1 + s/R (0 = pole)


def _directed_facets(snap):
    """(vertex id -> row, lookup of directed edges).

    The lookup maps the rows (a, b) of a directed edge to the third corner of the facet
    that has it (the last such facet when several do), or -1 when no facet has it.
    """
    idx = snap.index_of()
    tri = np.vectorize(idx.get, otypes=[int])(snap.facets)
    nv = len(snap.vertices)
    keys = (tri * nv + np.roll(tri, -1, axis=1)).ravel()        # (a,b), (b,c), (c,a)
    thirds = np.roll(tri, 1, axis=1).ravel()                    #   c,     a,     b
    order = np.argsort(keys, kind="stable")
    keys = keys[order]

    def third(a, b):
        k = np.asarray(a) * nv + np.asarray(b)
        if not len(keys):
            return np.full(k.shape, -1)
        pos = np.maximum(np.searchsorted(keys, k, side="right") - 1, 0)   # last with (a, b)
        return np.where(keys[pos] == k, thirds[order[pos]], -1)

    return idx, third


def direct_forces(snap, mp):
    """:class:`DirectForces` of a parsed snapshot for a :class:`.datafile.MeshedProblem`."""
    pb = mp.problem
    X = snap.vertices
    idx, third = _directed_facets(snap)
    n = pb.n_grains
    F_y = np.zeros((n, 3))
    F_f = np.zeros((n, 3))
    F_p = np.zeros((n, 3))
    measured = {}
    reversed_edges = 0
    clearance = 2.0
    up = pb.up
    for (bi, g), cn in mp.contact_constraints.items():
        e = snap.contact_edges.get(cn)
        if e is None or len(e) == 0:
            continue
        ia = np.array([idx[int(v)] for v in e[:, 0]])
        ib = np.array([idx[int(v)] for v in e[:, 1]])
        thirds = third(ia, ib)
        rev = thirds < 0                          # edge oriented against its facet
        reversed_edges += int(rev.sum())
        if rev.any():
            back = third(ib[rev], ia[rev])
            thirds[rev] = np.where(back < 0, ia[rev], back)
        c = pb.centres[g]
        R = pb.radii[g]
        th = np.radians(pb.contact_angles_deg[g])
        p0, p1 = X[ia], X[ib]
        ring = next(r for r in mp.meshes[bi].rings if r.grain == g)
        s = (p0 - c) @ ring.axis / R
        clearance = min(clearance, float(np.min(1.0 + s)))
        d = p1 - p0
        L = np.linalg.norm(d, axis=1)
        t = d / L[:, None]
        ns = 0.5 * (p0 + p1) - c
        ns /= np.linalg.norm(ns, axis=1)[:, None]
        w = np.cross(ns, t)                      # tangent to grain, into the wet cap
        w /= np.linalg.norm(w, axis=1)[:, None]
        nu_y = np.cos(th) * w + np.sin(th) * ns
        q = X[thirds] - p0
        nu_f = q - np.einsum("ij,ij->i", q, t)[:, None] * t
        nu_f /= np.linalg.norm(nu_f, axis=1)[:, None]
        ang = np.degrees(np.arctan2(np.einsum("ij,ij->i", nu_f, ns),
                                    np.einsum("ij,ij->i", nu_f, w)))
        measured[cn] = float(np.sum(ang * L) / np.sum(L))
        S = vector_area(c, p0, p1)
        P = snap.body_pressure.get(bi + 1, np.nan)
        fp = -P * S
        if pb.bond > 0:
            M = cap_second_moment(c, R, ring.axis, p0, p1)
            fp = fp + pb.bond * ((up @ c) * S + M @ up / R)
        F_p[g] += fp
        F_y[g] += fp + (L[:, None] * nu_y).sum(axis=0)
        F_f[g] += fp + (L[:, None] * nu_f).sum(axis=0)
    two_pi = 2.0 * np.pi
    return DirectForces(F_y / two_pi, F_f / two_pi, F_p / two_pi, measured, reversed_edges,
                        clearance)


def doublet_axis(pb, i=0, j=1):
    u = pb.centres[j] - pb.centres[i]
    return u / np.linalg.norm(u)


def neck(snap, mp, body=0):
    """Neck of a two-grain body: (radius, axial position, centre-line unit vector).

    The radius is the minimum of a parabola fitted, in the axial coordinate, to the
    distances from the centre line of the free vertices near the narrowest point.
    Returns (nan, nan, u) for bodies wetting more or fewer than two grains.
    """
    pb = mp.problem
    grains = pb.bodies[body].grains
    i, j = grains[0], grains[-1]
    u = doublet_axis(pb, i, j)
    if len(grains) != 2:
        return np.nan, np.nan, u
    idx = snap.index_of()
    fb = snap.facet_body == body + 1
    vid = np.unique(snap.facets[fb].ravel())
    contact_ids = set()
    for (bi, g), cn in mp.contact_constraints.items():
        if bi == body and cn in snap.contact_edges:
            contact_ids.update(snap.contact_edges[cn].ravel().tolist())
    free = np.array([idx[int(v)] for v in vid if int(v) not in contact_ids], int)
    if len(free) < 6:
        return np.nan, np.nan, u
    x = snap.vertices[free] - pb.centres[i]
    t = x @ u
    rho = np.linalg.norm(x - t[:, None] * u, axis=1)
    k0 = int(np.argmin(rho))
    span = max(np.ptp(t), 1e-9)
    for frac in (0.15, 0.25, 0.4, 1.0):
        sel = np.abs(t - t[k0]) <= frac * span
        if sel.sum() >= 6 and np.ptp(t[sel]) > 0:
            break
    A = np.vstack([np.ones(sel.sum()), t[sel], t[sel] ** 2]).T
    coef, *_ = np.linalg.lstsq(A, rho[sel], rcond=None)
    if coef[2] > 0:
        tm = -coef[1] / (2 * coef[2])
        tm = float(np.clip(tm, t[sel].min(), t[sel].max()))
        r = float(coef[0] + coef[1] * tm + coef[2] * tm * tm)
    else:
        tm, r = float(t[k0]), float(rho[k0])
    return r, tm, u


def neck_force(neck_radius, pressure):
    """Axial force F* at the neck of an axisymmetric bridge: y0 - P* y0^2 / 2."""
    return neck_radius - pressure * neck_radius ** 2 / 2.0


# --------------------------------------------------------------------------------------
# direct force through cuts away from the contact line (shell average)
# --------------------------------------------------------------------------------------


def _crossed(X, tri, phi):
    """Facets crossed by the level set phi = 0 (phi per vertex), split at their lone corner.

    Returns (nin, cross, lone_in, a, b, d, p, q): ``nin`` the number of corners with
    phi < 0 of every facet, ``cross`` the facets with one or two; for those, ``a`` the
    lone corner (inside when ``lone_in``, else outside), ``b``, ``d`` the next corners in
    the facet's order and ``p``, ``q`` the zero crossings on the edges a-b and a-d
    (linear in phi).
    """
    ins = phi[tri] < 0                                     # (nf, 3)
    nin = ins.sum(axis=1)
    cross = (nin == 1) | (nin == 2)
    t = tri[cross]
    s = ins[cross]
    lone_in = s.sum(axis=1) == 1
    lone = np.where(lone_in, np.argmax(s, axis=1), np.argmin(s, axis=1))
    rows = np.arange(len(t))
    a = t[rows, lone]
    b = t[rows, (lone + 1) % 3]
    d = t[rows, (lone + 2) % 3]

    def interp(i, j):
        w = phi[i] / (phi[i] - phi[j])
        return X[i] + w[:, None] * (X[j] - X[i])

    return nin, cross, lone_in, a, b, d, interp(a, b), interp(a, d)


def _cut(X, tri, nrm, c, phi):
    """Cut of a triangulated free surface by the sphere |x - c| = rho (phi = |x - c| - rho
    per vertex).

    Returns (S_D, T, segments): S_D = \\int_D n dA of D, the part of the sphere inside the
    liquid (n outward), from the cut polygon; T = sum of L nu_out (facet conormals
    pointing out of the sphere); segments (m, 2, 3) oriented as the boundary of D.
    """
    phi = np.where(phi == 0.0, 1e-15, phi)
    _, cross, lone_in, _, _, _, p, q = _crossed(X, tri, phi)
    if not np.any(cross):
        return np.zeros(3), np.zeros(3), np.zeros((0, 2, 3))
    n = nrm[cross]
    # facet boundary runs a -> b -> d (counter-clockwise about n); the lone corner a lies
    # to the left of p -> q.  Inside part on the left: p -> q if the lone vertex is
    # inside, else q -> p.
    start = np.where(lone_in[:, None], p, q)
    end = np.where(lone_in[:, None], q, p)
    tv = end - start
    L = np.linalg.norm(tv, axis=1)
    ok = L > 0
    start, end, tv, L, n = start[ok], end[ok], tv[ok], L[ok], n[ok]
    tv = tv / L[:, None]
    left = np.cross(n, tv)                                 # towards the inside part
    nu_out = -left
    T = (L[:, None] * nu_out).sum(axis=0)
    # D's boundary runs opposite to the inner free surface's: end -> start
    S_D = 0.5 * np.cross(end - c, start - c).sum(axis=0)
    segs = np.stack([end, start], axis=1)
    return S_D, T, segs


def _inside_volume(X, tri, phi):
    """\\int (x/3).n dA over the parts of the facets with phi < 0 (facets cut straight)."""
    nin, _, lone_in, a, b, d, p, q = _crossed(X, tri, phi)

    def det(a, b, c):
        return np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0

    full = tri[nin == 3]
    vol = det(X[full[:, 0]], X[full[:, 1]], X[full[:, 2]]).sum()
    li = lone_in
    vol += det(X[a[li]], p[li], q[li]).sum()
    lo = ~lone_in
    vol += det(p[lo], X[b[lo]], X[d[lo]]).sum() + det(p[lo], X[d[lo]], q[lo]).sum()
    return float(vol)


def cut_forces(snap, mp, n_eta=16, band=(0.25, 0.75)):
    """Direct forces (F*, (N, 3)) through spheres concentric with each wetted grain.

    For grain k wetted by body b the liquid is cut by spheres of radius rho = R_k + eta,
    eta between ``band`` fractions of half the smallest gap from grain k to the other
    grains of the body (so that the cut separates grain k's cap from the rest, away from
    the contact line where the discrete surface is least accurate: at theta = 0 the
    contact-line formula converges slowly).  Force balance on the liquid between the
    cap and the cut surface D::

        F_k = -P S_D + sum L nu_out + Bo (k.c S_D + M_D k / rho) - Bo V_in k

    (S_D = \\int_D n dA, M_D = \\int_D p p^T dA, nu_out the free surface's conormal across
    the cut, V_in the liquid volume inside the cut sphere, k = up), averaged over
    ``n_eta`` cuts.  Returns None when no such cut exists.
    """
    from .geometry import area_field, content_field, line_integral

    pb = mp.problem
    idx = snap.index_of()
    X = snap.vertices
    up = pb.up
    F = np.zeros((pb.n_grains, 3))
    for bi, body in enumerate(pb.bodies):
        sel = snap.facet_body == bi + 1
        tri = np.vectorize(idx.get, otypes=[int])(snap.facets[sel])
        if len(tri) == 0:
            return None
        nrm = np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]])
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
        P = snap.body_pressure.get(bi + 1, np.nan)
        for g in body.grains:
            c = pb.centres[g]
            R = pb.radii[g]
            gaps = [np.linalg.norm(c - pb.centres[j]) - R - pb.radii[j]
                    for j in body.grains if j != g]
            half = 0.5 * min(gaps)
            if half <= 0:
                return None
            etas = half * np.linspace(band[0], band[1], n_eta)
            dist = np.linalg.norm(X - c, axis=1)
            acc = np.zeros(3)
            cap_content = 0.0
            if pb.bond > 0:
                ring = next(r for r in mp.meshes[bi].rings if r.grain == g)
                cn = mp.contact_constraints[(bi, g)]
                e = snap.contact_edges.get(cn)
                if e is None or len(e) == 0:
                    return None
                ia = [idx[int(v)] for v in e[:, 0]]
                ib = [idx[int(v)] for v in e[:, 1]]
                cap_content = line_integral(content_field(c, R, ring.axis), X[ia], X[ib])
            for eta in etas:
                rho = R + eta
                phi = dist - rho
                S_D, T, segs = _cut(X, tri, nrm, c, phi)
                if len(segs) == 0:
                    return None
                f = -P * S_D + T
                if pb.bond > 0:
                    p0, p1 = segs[:, 0], segs[:, 1]
                    A_D = line_integral(area_field(c, rho, ring.axis), p0, p1)
                    M_D = cap_second_moment(c, rho, ring.axis, p0, p1)
                    V_in = (_inside_volume(X, tri, phi) + (c @ S_D + rho * A_D) / 3.0
                            + cap_content)
                    f = f + pb.bond * ((up @ c) * S_D + M_D @ up / rho) - pb.bond * V_in * up
                acc += f
            F[g] += acc / n_eta
    return F / (2.0 * np.pi)
