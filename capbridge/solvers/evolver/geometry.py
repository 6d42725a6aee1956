"""Sphere-cap line integrals and starting meshes for the Surface Evolver driver.

Only the liquid-gas interface is meshed.  Each wetted cap (the part of grain k inside a
liquid body) is closed off by line integrals along the contact line, i.e. along the
boundary edges of the free surface that lie on sphere k.  All integrals below are taken
along the contact line **counter-clockwise about the sphere's outward normal on the wet
cap** (the wet cap lies on the left when walking along the line, seen from outside the
sphere).  This is exactly the orientation of the free-surface boundary when the facets'
right-hand normals point out of the liquid, so a contact edge that is positively oriented
in its facet is integrated in the right direction.

With ``p = x - c`` (c: sphere centre, R: radius) and ``a`` a unit *pole axis* pointing
into the wet cap (its antipode must stay dry), ``s = a.p``:

* wetted area           A   = \\oint R/(R+s) (a x p) . dl
* vector area           S   = \\int n dA = 1/2 \\oint p x dl      (n: outward sphere normal)
* body volume of cap    Vc  = -1/6 \\oint (c x p) . dl - R^2/3 \\oint (a x p)/(R+s) . dl
  (the contribution of the cap to \\int (x/3).n_out dA over the closed liquid surface,
  n_out pointing into the grain: Evolver's ``symmetric_content`` convention)
* gravity (h = k.x, k the unit "up" vector, F = (k.x)^2/2 k, div F = h)
  \\int_cap F.n_out dA = -\\oint [ ((k.c)^2/4 + (k.c) z/3 + (R^2+z^2)/8) (k x p)
                                 + (k.c) R^2/(3 (R+s)) (a x p) ] . dl,   z = k.p

The only singular point of these forms is the antipode of ``a`` (s = -R).
Second moments over the cap (needed for the hydrostatic force) use, for a symmetric
matrix Q, \\int p.Q p dA = R/3 \\oint ((Q0 p) x p).dl + tr(Q) R^2/3 A with Q0 the
trace-free part of Q (no singularity).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from capbridge.dimensionless import cap_volume

# Gauss-Legendre nodes on [0, 1] for edge quadrature
_GL_X, _GL_W = np.polynomial.legendre.leggauss(5)
_GL_T = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


def unit(v):
    v = np.asarray(v, float)
    n = np.linalg.norm(v)
    if n == 0:
        raise ValueError("zero vector has no direction")
    return v / n


def perp_frame(a):
    """Two unit vectors e1, e2 with (e1, e2, a) right-handed and orthonormal."""
    a = unit(a)
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = unit(np.cross(helper, a))
    e2 = np.cross(a, e1)
    return e1, e2


# ------------------------------------------------------------------------------------
# line integrals over polygonal contact lines (numpy versions of the Evolver integrands)
# ------------------------------------------------------------------------------------


def _edge_points(p0, p1):
    """Quadrature points (m, q, 3) and dl (m, 3) for edges p0 -> p1 of shape (m, 3)."""
    dl = p1 - p0
    q = p0[:, None, :] + _GL_T[None, :, None] * dl[:, None, :]
    return q, dl


def line_integral(field_fn, p0, p1):
    """\\sum_edges \\int field(x).dl along straight edges p0[i] -> p1[i] (5-point Gauss)."""
    p0 = np.atleast_2d(np.asarray(p0, float))
    p1 = np.atleast_2d(np.asarray(p1, float))
    if len(p0) == 0:
        return 0.0
    q, dl = _edge_points(p0, p1)
    f = field_fn(q)                                     # (m, nq, 3)
    return float(np.einsum("mqi,q,mi->", f, _GL_W, dl))


def area_field(centre, radius, axis):
    c, R, a = np.asarray(centre, float), float(radius), unit(axis)

    def f(x):
        p = x - c
        s = p @ a
        return (R / (R + s))[..., None] * np.cross(a, p)
    return f


def content_field(centre, radius, axis):
    c, R, a = np.asarray(centre, float), float(radius), unit(axis)

    def f(x):
        p = x - c
        s = p @ a
        return (-np.cross(c, p) / 6.0
                - (R * R / 3.0 / (R + s))[..., None] * np.cross(a, p))
    return f


def gravity_cap_field(centre, radius, axis, up):
    """Field whose contact-line integral is \\int_cap F.n_out dA, F = (k.x)^2/2 k."""
    c, R, a, k = np.asarray(centre, float), float(radius), unit(axis), unit(up)
    kc = float(k @ c)

    def f(x):
        p = x - c
        s = p @ a
        z = p @ k
        coef = kc * kc / 4.0 + kc * z / 3.0 + (R * R + z * z) / 8.0
        return -(coef[..., None] * np.cross(k, p)
                 + (kc * R * R / 3.0 / (R + s))[..., None] * np.cross(a, p))
    return f


def vector_area(centre, p0, p1):
    """\\int_cap n dA = 1/2 \\oint p x dl (exact for the polygon), n outward of the grain."""
    c = np.asarray(centre, float)
    p0 = np.atleast_2d(p0) - c
    p1 = np.atleast_2d(p1) - c
    # for straight edges \\int p x dl = p0 x p1
    return 0.5 * np.cross(p0, p1).sum(axis=0)


def cap_area_polygon(centre, radius, axis, p0, p1):
    return line_integral(area_field(centre, radius, axis), p0, p1)


def cap_second_moment(centre, radius, axis, p0, p1):
    """M_ij = \\int_cap p_i p_j dA (p = x - c) from the contact line."""
    c, R = np.asarray(centre, float), float(radius)
    A = cap_area_polygon(c, R, axis, p0, p1)
    M = np.zeros((3, 3))
    eye = np.eye(3)
    for i in range(3):
        for j in range(i, 3):
            Q = 0.5 * (np.outer(eye[i], eye[j]) + np.outer(eye[j], eye[i]))
            Q0 = Q - np.trace(Q) / 3.0 * eye

            def f(x, Q0=Q0):
                p = x - c
                return (R / 3.0) * np.cross(p @ Q0.T, p)
            M[i, j] = M[j, i] = line_integral(f, p0, p1) + np.trace(Q) * R * R / 3.0 * A
    return M


# ------------------------------------------------------------------------------------
# starting meshes
# ------------------------------------------------------------------------------------


@dataclass
class Ring:
    """A contact-line polygon on grain ``grain`` (0-based), around pole ``axis``."""

    grain: int
    axis: np.ndarray
    beta: float                 # half-filling angle [rad]
    points: np.ndarray          # (n, 3), counter-clockwise about ``axis`` seen from outside


@dataclass
class BodyMesh:
    """Triangulated free surface of one liquid body (0-based vertex indices)."""

    vertices: np.ndarray                    # (nv, 3)
    triangles: np.ndarray                   # (nf, 3), right-hand normal out of the liquid
    vertex_ring: np.ndarray                 # (nv,) index into ``rings`` (all are contact)
    rings: list = field(default_factory=list)


def ring_points(centre, radius, axis, beta, n, phase=0.0):
    e1, e2 = perp_frame(axis)
    a = unit(axis)
    psi = phase + 2 * np.pi * np.arange(n) / n
    return (np.asarray(centre, float)
            + radius * (np.cos(beta) * a
                        + np.sin(beta) * (np.cos(psi)[:, None] * e1 + np.sin(psi)[:, None] * e2)))


def hull_body(rings, centre=None):
    """Free surface spanning the given rings: their convex hull minus the ring disks.

    With ``centre``, a body that is only star-shaped about that point: the facets are
    those of the convex hull of the ring points' *directions* from ``centre`` (points on
    a sphere: all of them are vertices), placed at the points themselves; every facet
    must then face away from ``centre`` (else ValueError: not star-shaped about it).

    Raises ValueError if a ring is not a face of the hull (rings overlapping or hidden).
    """
    from scipy.spatial import ConvexHull

    pts = np.concatenate([r.points for r in rings])
    owner = np.concatenate([np.full(len(r.points), i) for i, r in enumerate(rings)])
    if centre is None:
        shape, origin = pts, pts.mean(axis=0)
    else:
        origin = np.asarray(centre, float)
        rel = pts - origin
        shape = rel / np.linalg.norm(rel, axis=1)[:, None]
    hull = ConvexHull(shape)
    if len(set(hull.vertices.tolist())) != len(pts):
        raise ValueError("some contact-ring points are not on the convex hull")
    inside = shape.mean(axis=0)
    tris = []
    n_disk = np.zeros(len(rings), int)
    for simplex in hull.simplices:
        o = owner[simplex]
        if o[0] == o[1] == o[2]:
            n_disk[o[0]] += 1
            continue
        a, b, c = shape[simplex]
        nrm = np.cross(b - a, c - a)
        if nrm @ (a - inside) < 0:
            simplex = simplex[[0, 2, 1]]
        if centre is not None:
            a, b, c = pts[simplex]
            if np.cross(b - a, c - a) @ ((a + b + c) / 3.0 - origin) <= 0.0:
                raise ValueError("the body is not star-shaped about the centre")
        tris.append(simplex)
    for i, r in enumerate(rings):
        if n_disk[i] != len(r.points) - 2:
            raise ValueError(f"contact ring on grain {r.grain} is not a face of the hull")
    tris = np.array(tris, int)
    # every ring edge must be a boundary edge of the free surface, oriented as the ring
    # (counter-clockwise about the pole axis seen from outside the grain)
    edges = {}
    for t in tris:
        for k in range(3):
            e = (t[k], t[(k + 1) % 3])
            edges[e] = edges.get(e, 0) + 1
    start = 0
    for r in rings:
        n = len(r.points)
        for m in range(n):
            i, j = start + m, start + (m + 1) % n
            if (i, j) not in edges:
                raise ValueError("ring edge missing or wrongly oriented in the hull surface")
        start += n
    return BodyMesh(vertices=pts, triangles=tris, vertex_ring=owner, rings=list(rings))


def mesh_volume(mesh, centres, radii):
    """Liquid volume enclosed by a body mesh and its wetted caps (same formula as Evolver)."""
    v, t = mesh.vertices, mesh.triangles
    vol = np.einsum("ij,ij->i", v[t[:, 0]], np.cross(v[t[:, 1]], v[t[:, 2]])).sum() / 6.0
    for r in mesh.rings:
        p0 = r.points
        p1 = np.roll(r.points, -1, axis=0)
        vol += line_integral(content_field(centres[r.grain], radii[r.grain], r.axis), p0, p1)
    return float(vol)


def body_rings(grains, centres, radii, beta, n):
    """Circular contact rings for a body wetting ``grains`` (0-based) at half-angle ``beta``.

    Two grains: each pole points at the other centre.  More grains: each pole points at
    the centroid of the body's grain centres.  ``beta`` may be a scalar or per grain.
    """
    centres = np.asarray(centres, float)
    beta = np.broadcast_to(np.asarray(beta, float), (len(grains),))
    if len(grains) == 2:
        i, j = grains
        targets = [centres[j], centres[i]]
    else:
        g = centres[list(grains)].mean(axis=0)
        targets = [g] * len(grains)
    rings = []
    for m, g in enumerate(grains):
        axis = unit(targets[m] - centres[g])
        rings.append(Ring(grain=g, axis=axis, beta=float(beta[m]),
                          points=ring_points(centres[g], radii[g], axis, beta[m], n)))
    return rings


def neighbour_rings(grains, centres, radii, extra, n, near=0.5, beta_max=np.radians(85.0)):
    """Contact rings that reach each grain's neighbours in the body, for clusters whose
    grains do not all face the centroid (two triangles sharing an edge, a bent chain).

    A grain's neighbours are the body's grains within a surface gap of ``near`` times
    the pair's smaller radius.  Its pole points along the mean direction to them and its
    half-angle is the widest angle from that pole to a neighbour plus ``extra`` [rad]
    (at most ``beta_max``), so that the ring encloses every contact of the grain.

    Raises ValueError for a grain without a neighbour, or whose neighbours lie on
    opposite sides (a straight chain: the body would engulf the grain, which a ring
    cannot describe).
    """
    centres = np.asarray(centres, float)
    radii = np.asarray(radii, float)
    rings = []
    for i in grains:
        dirs = []
        for j in grains:
            if j == i:
                continue
            d = centres[j] - centres[i]
            if np.linalg.norm(d) - radii[i] - radii[j] <= near * min(radii[i], radii[j]):
                dirs.append(unit(d))
        if not dirs:
            raise ValueError(f"grain {i} has no neighbour in the body within a gap of "
                             f"{near:g} x its radius")
        total = np.sum(dirs, axis=0)
        if np.linalg.norm(total) < 0.2 * len(dirs):
            raise ValueError(f"grain {i}'s neighbours in the body lie on opposite sides: "
                             "the body would engulf it")
        axis = unit(total)
        spread = max(float(np.arccos(np.clip(d @ axis, -1.0, 1.0))) for d in dirs)
        beta = min(spread + extra, beta_max)
        rings.append(Ring(grain=i, axis=axis, beta=beta,
                          points=ring_points(centres[i], radii[i], axis, beta, n)))
    return rings


def _volume_matched(make, lo, hi, volume, centres, radii, centre=None, scan=0):
    """The hull body of ``make(x)`` (:func:`hull_body` about ``centre``) whose liquid
    volume is closest to ``volume`` for x in [lo, hi] (x grows the rings), or ValueError
    if no x gives a valid hull.  If even the largest valid hull holds too little liquid,
    that hull is returned (Evolver then inflates it to the target volume); if the
    smallest holds too much, the smallest.

    Validity is not monotonic in x (near-touching grains give invalid hulls between
    valid ones): without ``scan``, hi is shrunk until valid and lo must be valid; with
    ``scan`` > 0, that many evenly spaced x are tried first and the bisection runs
    between the two valid ones that bracket the volume.
    """
    def vol(x):
        try:
            return mesh_volume(hull_body(make(x), centre), centres, radii)
        except ValueError:
            return np.nan

    if scan:
        xs = np.linspace(lo, hi, scan)
        vs = np.array([vol(x) for x in xs])
        ok = np.isfinite(vs)
        if not ok.any():
            raise ValueError("no valid hull")
        xs, vs = xs[ok], vs[ok]
        enough = np.flatnonzero(vs >= volume)
        if not enough.size:
            return hull_body(make(xs[np.argmax(vs)]), centre)
        if enough[0] == 0:
            return hull_body(make(xs[0]), centre)
        lo, hi = xs[enough[0] - 1], xs[enough[0]]
    else:
        # shrink hi until the hull is valid
        while not np.isfinite(vol(hi)) and hi > lo:
            hi *= 0.9
        if not np.isfinite(vol(lo)) or hi <= lo:
            raise ValueError("no valid hull")
        if vol(hi) < volume:
            return hull_body(make(hi), centre)
        if vol(lo) > volume:
            return hull_body(make(lo), centre)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        vm = vol(mid)
        if not np.isfinite(vm) or vm > volume:
            hi = mid
        else:
            lo = mid
    # lo is a valid hull (the midpoint that ended the bisection was never tested)
    return hull_body(make(lo), centre)


#: a starting body within this factor of the target volume is taken as it is; beyond it
#: the next construction is tried (Evolver inflating or deflating a body several times
#: over folds its facets)
VOLUME_FACTOR_OK = 2.0


def starting_body(grains, centres, radii, volume, n=8, beta_max=np.radians(80.0)):
    """Hull body with circular rings whose enclosed liquid volume is close to ``volume``.

    Constructions, in order, the first within :data:`VOLUME_FACTOR_OK` of ``volume``
    taken (else the valid one nearest to it, as a ratio):

    1. every pole at the centroid of the body's grain centres, one half-angle for all,
       found by bisection (:func:`body_rings`), spanned by the convex hull;
    2. (four grains or more) rings reaching each grain's neighbours
       (:func:`neighbour_rings`, the extra half-angle found by a scan and bisection),
       spanned by their convex hull (a grain that does not face the centroid, as in two
       triangles sharing an edge);
    3. the same rings spanned by a surface star-shaped about the grains' centroid
       (:func:`hull_body` with ``centre``: a body that wraps around its grains).

    A body that holds too little liquid even at its largest valid rings is inflated to
    the target by Evolver.  ValueError (with each construction's reason) if none is
    valid.
    """
    centres = np.asarray(centres, float)
    radii = np.asarray(radii, float)
    middle = centres[list(grains)].mean(axis=0)
    constructions = [
        ("with the poles at the centroid",
         lambda: _volume_matched(lambda b: body_rings(grains, centres, radii, b, n),
                                 np.radians(3.0), beta_max, volume, centres, radii))]
    if len(grains) >= 4:
        # clusters only: doublets and triplets (the tables' bodies) keep the centroid
        # hull, so that a committed sweep resumes with the starting bodies it began with
        def reaching(centre):
            neighbour_rings(grains, centres, radii, 0.0, n)     # its own reasons first
            return _volume_matched(lambda e: neighbour_rings(grains, centres, radii, e, n),
                                   np.radians(2.0), np.radians(40.0), volume, centres,
                                   radii, centre=centre, scan=16)
        constructions += [("with rings reaching the neighbours", lambda: reaching(None)),
                          ("star-shaped about the grains' centroid", lambda: reaching(middle))]
    why, found = [], []
    for name, make in constructions:
        try:
            body = make()
        except ValueError as exc:
            why.append(f"{name}: {exc}")
            continue
        off = abs(np.log(mesh_volume(body, centres, radii) / volume))
        if off <= np.log(VOLUME_FACTOR_OK):
            return body
        found.append((off, len(found), body))
    if found:
        return min(found)[2]
    raise ValueError(f"no valid starting body for grains {grains} ({'; '.join(why)})")


def segment_volume(radius, beta):
    """Volume of the sphere segment cut off by the plane of a ring (cap of half-angle beta)."""
    return cap_volume(radius, beta)
