"""Failure detection on a parsed Evolver snapshot (Evolver itself notices none of these).

Each check returns a list of :class:`Failure` (empty when the shape is sound).  A failed
shape is never reported as a result; :mod:`.minimise` retries or flags it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .forces import neck


@dataclass
class Failure:
    kind: str          # short key: volume, penetration, degenerate, fold, orientation, ...
    message: str

    def __str__(self):
        return f"{self.kind}: {self.message}"


@dataclass
class Tolerances:
    volume: float = 1e-6          # relative volume error
    penetration: float = 1e-6     # vertex inside a grain, in units of its radius
    facet_depth: float = 0.5      # facet centroid depth inside a grain / (edge^2 / R)
    min_area_ratio: float = 1e-6  # smallest facet area / mean facet area
    fold_cos: float = -0.3        # adjacent facet normals with a smaller cosine: fold
    pole_clearance: float = 0.15  # contact line may not come closer to the pole antipode
    pinch_edges: float = 0.25     # neck radius below this many mean edge lengths: pinch
    pinch_abs: float = 2e-3       # ... or below this (units of r)
    cap_gap_edges: float = 0.5    # contact lines of two bodies closer than this: merged


def _edges(tri):
    """Directed edges (a, b), (b, c), (c, a) of all facets, in that block order (3 nf, 2)."""
    return np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])


def _min_adjacent_cos(tri, unit, n_vertices):
    """Smallest cosine between the unit normals of two facets sharing an edge (1 if none).

    Facets are neighbours when one has the edge (a, b) and the other (b, a) (consistent
    orientation; boundary edges have no partner)."""
    e = _edges(tri)
    f = np.tile(np.arange(len(tri)), 3)
    key = e[:, 0] * n_vertices + e[:, 1]
    order = np.argsort(key)
    ks = key[order]
    rev = e[:, 1] * n_vertices + e[:, 0]
    pos = np.minimum(np.searchsorted(ks, rev), len(ks) - 1)
    hit = ks[pos] == rev
    if not np.any(hit):
        return 1.0
    cos = np.einsum("ij,ij->i", unit[f[hit]], unit[f[order[pos[hit]]]])
    return min(1.0, float(cos.min()))


def analyse(snap, mp, tol=None, direct=None):
    """All failures of a snapshot, plus a dict of diagnostics."""
    tol = tol or Tolerances()
    pb = mp.problem
    fails = []
    diag = {}
    if not np.isfinite(snap.energy):
        fails.append(Failure("energy", "energy is not finite"))
        return fails, diag
    # volumes
    for b, v in snap.body_volume.items():
        tgt = snap.body_target.get(b, pb.bodies[b - 1].volume)
        rel = abs(v - tgt) / tgt
        diag[f"volume_error_{b}"] = rel
        if not np.isfinite(rel) or rel > tol.volume:
            fails.append(Failure("volume", f"body {b} volume {v:.6g} vs target {tgt:.6g} "
                                           f"(relative error {rel:.2e})"))
    # energy lower bound: E >= -sum max(cos t,0) * sphere area (+ gravity bound)
    lower = -np.sum(np.maximum(np.cos(np.radians(pb.contact_angles_deg)), 0.0)
                    * 4 * np.pi * pb.radii ** 2)
    if pb.bond > 0:
        h = pb.centres @ pb.up
        lower -= pb.bond * sum(b.volume for b in pb.bodies) * (
            np.max(np.abs(h)) + 2 * np.max(pb.radii) + 10.0)
    if snap.energy < lower:
        fails.append(Failure("energy", f"energy {snap.energy:.6g} below the physical lower "
                                       f"bound {lower:.6g}: falling without bound"))
    idx = snap.index_of()
    X = snap.vertices
    tri = (np.vectorize(idx.get, otypes=[int])(snap.facets) if snap.n_facets
           else np.zeros((0, 3), int))
    if len(tri) == 0:
        fails.append(Failure("mesh", "no facets left"))
        return fails, diag
    e = _edges(tri)
    el = np.linalg.norm(X[e[:, 0]] - X[e[:, 1]], axis=1)
    hmean = float(el.mean())
    diag["mean_edge"] = hmean
    # contact lines present
    contact_vertex_grain = {}
    for (bi, g), cn in mp.contact_constraints.items():
        e = snap.contact_edges.get(cn)
        if e is None or len(e) < 3:
            fails.append(Failure("contact", f"contact line of body {bi + 1} on grain {g + 1} "
                                            "vanished (the liquid left the grain)"))
            continue
        for v in e.ravel():
            contact_vertex_grain[idx[int(v)]] = g
    # penetration of vertices into grains
    worst = 0.0
    own_grain = np.full(len(X), -1)
    cen = X[tri].mean(axis=1)
    emax = el.reshape(3, -1).max(axis=0)      # longest edge of each facet
    for i, g in contact_vertex_grain.items():
        own_grain[i] = g
    for g in range(pb.n_grains):
        d = (np.linalg.norm(X - pb.centres[g], axis=1) - pb.radii[g]) / pb.radii[g]
        own = own_grain == g
        d = np.where(own, 0.0, d)
        worst = min(worst, float(d.min()))
        if d.min() < -tol.penetration:
            n_in = int(np.sum(d < -tol.penetration))
            fails.append(Failure("penetration", f"{n_in} vertices of the free surface inside "
                                                f"grain {g + 1} (depth {-d.min():.2e} r)"))
        # facet centroids deep inside (surface passing through a grain between vertices)
        depth = pb.radii[g] - np.linalg.norm(cen - pb.centres[g], axis=1)
        allowed = tol.facet_depth * emax ** 2 / pb.radii[g] + tol.penetration * pb.radii[g]
        if np.any(depth > allowed):
            fails.append(Failure("penetration", f"{int(np.sum(depth > allowed))} facets pass "
                                                f"through grain {g + 1}"))
    diag["max_penetration"] = -worst
    # degenerate and folded facets
    nrm = np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]])
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    diag["min_area_ratio"] = float(area.min() / area.mean())
    if area.min() < tol.min_area_ratio * area.mean():
        fails.append(Failure("degenerate", f"{int(np.sum(area < tol.min_area_ratio * area.mean()))}"
                                           " degenerate facets"))
    unit = nrm / np.maximum(2 * area, 1e-300)[:, None]
    worst_cos = _min_adjacent_cos(tri, unit, len(X))
    diag["min_normal_cos"] = worst_cos
    if worst_cos < tol.fold_cos:
        fails.append(Failure("fold", f"inverted/folded facets (adjacent normals at "
                                     f"{np.degrees(np.arccos(max(worst_cos, -1))):.0f} deg)"))
    # orientation of contact edges, pole clearance (from the direct-force pass)
    if direct is not None:
        if direct.reversed_edges:
            fails.append(Failure("orientation", f"{direct.reversed_edges} contact edges "
                                                "oriented against their facet"))
        diag["pole_clearance"] = direct.pole_clearance
        if direct.pole_clearance < tol.pole_clearance:
            fails.append(Failure("pole", "a contact line came near the antipode of its "
                                         "integration pole (cap too large)"))
    # pinch-off of two-grain bodies
    for bi, b in enumerate(pb.bodies):
        if len(b.grains) == 2:
            r, _, _ = neck(snap, mp, bi)
            diag[f"neck_radius_{bi + 1}"] = r
            if np.isfinite(r) and r < max(tol.pinch_edges * hmean, tol.pinch_abs):
                fails.append(Failure("pinch", f"bridge {bi + 1} pinching off (neck radius "
                                              f"{r:.3g}, mean edge {hmean:.3g})"))
    # caps of different bodies meeting on a grain
    by_grain = {}
    for (bi, g), cn in mp.contact_constraints.items():
        e = snap.contact_edges.get(cn)
        if e is not None and len(e):
            by_grain.setdefault(g, []).append((bi, np.array([idx[int(v)] for v in e.ravel()])))
    for g, lst in by_grain.items():
        for m in range(len(lst)):
            for n in range(m + 1, len(lst)):
                A, B = X[lst[m][1]], X[lst[n][1]]
                dmin = float(np.min(np.linalg.norm(A[:, None] - B[None], axis=2)))
                if dmin < tol.cap_gap_edges * hmean:
                    fails.append(Failure("coalesced", f"wetted caps of bodies {lst[m][0] + 1} "
                                                      f"and {lst[n][0] + 1} meet on grain "
                                                      f"{g + 1}"))
    return fails, diag
