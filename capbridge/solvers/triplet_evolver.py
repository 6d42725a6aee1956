"""Triplets by Surface Evolver: coalesced bodies, separate bridges under gravity, energies.

* :func:`evolver_triplet` minimises either one coalesced body wetting the three grains
  (``topology="coalesced"``) or separate bridges (``"bridges"``, needed with gravity,
  where the exact axisymmetric solver does not apply), and returns the force vectors on
  the grains, the vertical force on the top grain, the effective pair forces with the
  residual of their decomposition (:func:`capbridge.solvers.triplet.pair_forces`),
  the energy and, for separate bridges, the angular gap left between the wetted caps of
  two bridges on every shared grain (measured on the converged mesh).
* :func:`minimise_with_ring_retries` runs one minimisation again from finer starting
  rings after a failure on the mesh (also used by :mod:`capbridge.solvers.cluster`).
* :func:`coalescence_from_cap_gaps` locates the coalescence volume of separate bridges
  computed by Evolver (gravity) by extrapolating that cap gap to zero.
* :func:`energy_comparison` puts the energy of the coalesced body (Evolver) beside the
  sum of the exact doublet energies of the separate bridges at the same total volume
  and finds where they cross.

Energies are E* = (A_lg - sum cos(theta_k) A_wet,k) / r^2 (+ Bo * int h dV with gravity)
in both solvers; :func:`energy_convention_check` compares a doublet from both.

Workaround (evolver driver not modified): the cap gaps need the contact-line vertices
of the final mesh, which :class:`~capbridge.solvers.evolver.BridgeResult` does not
carry; the run is made with ``keep_files=True`` and the final dump is reloaded once by
Evolver to print its report (:mod:`capbridge.solvers.evolver.script`), then the
directory is removed.
"""
from __future__ import annotations

import dataclasses
import itertools
import os
import shutil

import numpy as np

from capbridge.status import HAS_RESULT, Status

from .triplet import (TripletGeometry, pair_forces, parse_bridges, uncoalesced_state,
                      volume_fractions, contact_angles)

#: The driver flags two bodies as coalesced when their contact lines come within
#: ``cap_gap_edges`` mean edge lengths (default 0.5: at level 0 that is several degrees,
#: and bridges 2 deg apart were stopped as "coalesced").  Separate bridges are run with
#: 1/20 of an edge here; their caps are then measured (signed) on the final mesh.
CAP_GAP_EDGES = 0.05

#: failure reasons after which a finer starting ring is tried
_MESH_FAILURES = ("degenerate", "fold", "driver error")

__all__ = ["evolver_triplet", "minimise_with_ring_retries", "coalescence_from_cap_gaps",
           "energy_comparison", "energy_convention_check", "cap_gaps_from_snapshot"]


def _settings(max_refine, tol, keep, **kw):
    from capbridge.solvers.evolver import Settings

    from capbridge.solvers.evolver.checks import Tolerances

    kw.setdefault("tolerances", Tolerances(cap_gap_edges=CAP_GAP_EDGES))
    kw.setdefault("min_refine", min(2, max_refine))
    s = Settings(ftol=tol, max_refine=max_refine, **kw)
    if keep:
        s = dataclasses.replace(s, keep_files=True)
    return s


def _polar(P, u):
    """Polar angle about ``u`` and azimuth of unit vectors P (rad)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, u)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    return np.arccos(np.clip(P @ u, -1.0, 1.0)), np.arctan2(P @ e2, P @ e1)


def _signed_gap(PA, PB, uB):
    """min over the contact line A of (polar angle about uB - radius of cap B at the
    same azimuth): > 0 while line A stays outside cap B (rad)."""
    gA, fA = _polar(PA, uB)
    gB, fB = _polar(PB, uB)
    order = np.argsort(fB)
    rB = np.interp(fA, fB[order], gB[order], period=2 * np.pi)
    return float(np.min(gA - rB))


def cap_gaps_from_snapshot(snap, mp, n_sub=4):
    """Signed angular gap [deg] between the wetted caps of two bodies on each grain they
    share: {grain: gap}.

    Each cap is star-shaped about its pole (the direction from the grain to the other
    grain(s) of its body); the gap is the smallest difference between the polar angle of
    a point of one contact line and the other cap's radius at the same azimuth, over
    both orders.  For two axisymmetric bridges it is angle jik - beta_ij - beta_ik
    (negative once the caps overlap).
    """
    pb = mp.problem
    idx = snap.index_of()
    X = snap.vertices
    by_grain = {}
    for (bi, g), cn in mp.contact_constraints.items():
        e = snap.contact_edges.get(cn)
        if e is None or not len(e):
            continue
        a = X[[idx[int(v)] for v in e[:, 0]]]
        b = X[[idx[int(v)] for v in e[:, 1]]]
        t = np.linspace(0.0, 1.0, n_sub + 1)[:-1]
        pts = (a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)
        d = pts - pb.centres[g]
        others = [k for k in pb.bodies[bi].grains if k != g]
        pole = np.mean([pb.centres[k] - pb.centres[g] for k in others], axis=0)
        pole /= np.linalg.norm(pole)
        by_grain.setdefault(g, []).append((d / np.linalg.norm(d, axis=1)[:, None], pole))
    out = {}
    for g, lines in by_grain.items():
        best = np.inf
        for (PA, uA), (PB, uB) in itertools.combinations(lines, 2):
            best = min(best, _signed_gap(PA, PB, uB), _signed_gap(PB, PA, uA))
        if np.isfinite(best):
            out[g] = float(np.degrees(best))
    return out


def _final_snapshot(res):
    """(snapshot, meshed problem) of the final level of a kept run, or (None, None).

    Reloads the final dump once in Evolver to print its report (see the module
    docstring); the kept directory is removed in every case.
    """
    from capbridge.solvers.evolver import parse, runner, script
    from capbridge.solvers.evolver.datafile import mesh_problem

    wd = res.workdir
    try:
        if not wd or res.refinement < 0:
            return None, None
        dump = os.path.join(wd, f"L{res.refinement}.dmp")
        if not os.path.exists(dump):
            return None, None
        mp = mesh_problem(res.problem)
        cmd = (script.prelude(mp.grain_contacts())
               + script.report("final", list(mp.contact_constraints.values()),
                               list(mp.outside_constraints.values()))
               + "quit\n")
        out = runner.run_evolver(os.path.basename(dump), cmd, wd, timeout=120, name="final")
        return parse.parse_reports(out.stdout).get("final"), mp
    finally:
        if wd:
            shutil.rmtree(wd, ignore_errors=True)


def plane_section(snap, normal=(0.0, 1.0, 0.0), offset=0.0):
    """Segments (m, 2, 3) where the free surface crosses the plane n.x = offset."""
    idx = snap.index_of()
    X = snap.vertices
    tri = np.vectorize(idx.get, otypes=[int])(snap.facets)
    s = X @ np.asarray(normal, float) - offset
    s = np.where(s == 0.0, 1e-14, s)
    S = s[tri]                                           # (nf, 3)
    segs = []
    for f in np.flatnonzero((S.min(axis=1) < 0) & (S.max(axis=1) > 0)):
        pts = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            sa, sb = S[f, a], S[f, b]
            if (sa < 0) != (sb < 0):
                t = sa / (sa - sb)
                pts.append(X[tri[f, a]] + t * (X[tri[f, b]] - X[tri[f, a]]))
        if len(pts) == 2:
            segs.append(pts)
    return np.asarray(segs, float).reshape(-1, 2, 3)


def lower_meniscus_height(snap, half_width=0.05):
    """Lowest height z of the free surface within |x| < half_width of the mid-plane
    between grains 2 and 3 (the frame of :func:`~capbridge.solvers.triplet.triplet_geometry`):
    below 0 the liquid wraps under the line of the bottom centres (a "trimer"), above it
    stays on top (a "dimer")."""
    X = snap.vertices
    sel = np.abs(X[:, 0]) < half_width
    return float(X[sel, 2].min()) if np.any(sel) else np.nan


def minimise_with_ring_retries(run, rings=(8, 12, 16)):
    """Run one Evolver minimisation, retried from finer starting rings on mesh failures.

    Parameters
    ----------
    run : callable
        ``run(n_ring) -> BridgeResult``: the minimisation with ``n_ring`` vertices per
        starting contact ring (:class:`~capbridge.solvers.evolver.Settings`).
    rings : sequence of int
        The rings tried in turn; the next one only after a failure on the mesh
        (degenerate or folded facets, or a driver error), which a finer starting ring
        often avoids; a physical failure (pinch, penetration) is not retried.

    Returns
    -------
    (BridgeResult, list of dict)
        The last result, its ``cpu_time`` and ``wall_time`` summed over the attempts,
        and the attempts (``n_ring``, ``status``, ``reason``).
    """
    attempts = []
    wall = cpu = 0.0
    for n_ring in rings:
        res = run(n_ring)
        wall += res.wall_time
        cpu += res.cpu_time
        attempts.append({"n_ring": n_ring, "status": res.status.name.lower(),
                         "reason": res.reason})
        retry = (res.status == Status.NOT_CONVERGED
                 and any(k in res.reason for k in _MESH_FAILURES))
        if not retry:
            break
        if res.workdir and os.path.isdir(res.workdir):
            shutil.rmtree(res.workdir, ignore_errors=True)
    res.wall_time, res.cpu_time = wall, cpu
    return res, attempts


def evolver_triplet(volume, geom: TripletGeometry, theta, topology="coalesced",
                    bridges=((0, 1), (0, 2)), fractions=None, bond=0.0, max_refine=3,
                    tol=3e-3, inspect_mesh=None, retry_rings=(8, 12, 16),
                    gravity_dir=(0.0, 0.0, -1.0), **settings):
    """One Surface Evolver minimisation on the triplet ``geom`` (gravity along
    ``gravity_dir``, a unit vector in the frame of ``geom``; default -z, the paper's).

    ``volume`` is the total V*; for ``topology="bridges"`` it is shared between
    ``bridges`` by ``fractions`` (equal by default).  ``theta`` in degrees (one value or
    one per grain).  Returns a dict (JSON-friendly values):

    status, reason, forces (3, 3) on the grains (F*), force_error (3, 3),
    F_top_vertical (= -F_1 . z: the downward pull on grain 1, the top grain, which the
    experiment's balance measures), pair_forces {"12": f12, ...} and pair_residual
    (meaningful without gravity), force_sum (|sum F|: 0 without gravity, the weight of
    the liquid Bo*V/(2 pi) with it), energy, energy_extrapolated, energy_error,
    refinement, n_facets, cpu_time, wall_time, cap_gaps {"grain g": deg} (separate
    bridges; None when not measured), lower_meniscus_z (coalesced: lowest point of the
    free surface between grains 2 and 3, < 0 for a trimer), section (segments of the
    free surface in the plane of the centres, (m, 2, 3)), warnings.  The last three
    need ``inspect_mesh`` (default: on), which reloads the final mesh once.  ``shape``:
    with ``keep_shape=True`` (a :class:`~capbridge.solvers.evolver.Settings` field,
    passed through ``settings`` like the others) the minimised liquid surface of the
    finest level, a :class:`~capbridge.solvers.shapes.LiquidShape` in the frame of
    ``geom`` and the forces (lengths / r), for
    :func:`~capbridge.solvers.shapes.write_shape`; None otherwise, or without a result.

    A run that fails on the mesh (degenerate or folded facets, or a driver error flagged
    by :func:`~capbridge.solvers.evolver.minimise`) is retried from a finer starting
    ring (``retry_rings``: the number of vertices per starting contact ring);
    ``attempts`` lists them.  A shape that fails with every ring is most likely not an
    equilibrium (e.g. a coalesced body well below its coalescence volume).
    """
    from capbridge.solvers.evolver import minimise_bridge

    t = np.asarray(contact_angles(theta), float)
    if topology == "coalesced":
        vol = float(volume)
        pairs = None
    elif topology == "bridges":
        bridges = parse_bridges(bridges)
        w = volume_fractions(fractions, len(bridges))
        vol = [float(volume) * x for x in w]
        pairs = bridges
    else:
        raise ValueError(f"topology {topology!r}: 'coalesced' or 'bridges'")
    measure = True if inspect_mesh is None else bool(inspect_mesh)
    rings = list(retry_rings) if "n_ring" not in settings else [settings["n_ring"]]
    res, attempts = minimise_with_ring_retries(
        lambda n_ring: minimise_bridge(
            geom.centres, 1.0, t, vol, topology=topology, pairs=pairs, bond=float(bond),
            gravity_dir=tuple(map(float, gravity_dir)),
            settings=_settings(max_refine, tol, measure, **dict(settings, n_ring=n_ring))),
        rings)
    snap, mp = _final_snapshot(res) if measure else (None, None)
    gaps = section = None
    zlow = np.nan
    if snap is not None:
        section = plane_section(snap)
        if topology == "bridges":
            gaps = cap_gaps_from_snapshot(snap, mp)
        else:
            zlow = lower_meniscus_height(snap)
    if res.workdir and os.path.isdir(res.workdir):      # not measured: clean up anyway
        shutil.rmtree(res.workdir, ignore_errors=True)
    out = {"status": res.status.name.lower(), "status_code": int(res.status),
           "reason": res.reason, "topology": topology, "volume": float(volume),
           "bond": float(bond), "theta": t.tolist(), "refinement": int(res.refinement),
           "n_facets": int(res.n_facets), "cpu_time": float(res.cpu_time),
           "wall_time": float(res.wall_time), "warnings": list(res.warnings),
           "energy": float(res.energy), "energy_extrapolated": float(res.energy_extrapolated),
           "energy_error": float(res.error_estimate.get("energy", np.nan)),
           "force_error_rel": float(res.error_estimate.get("force_rel", np.nan)),
           "direct_vs_vw": float(res.error_estimate.get("direct_vs_vw", np.nan)),
           "pressure": (float(res.pressure[0]) if topology == "coalesced"
                        and res.pressure is not None else np.nan),
           "cap_gaps": None if gaps is None else {f"grain {g + 1}": v for g, v in gaps.items()},
           "lower_meniscus_z": zlow, "section": section, "attempts": attempts,
           "shape": res.shape}
    if res.status in HAS_RESULT and res.forces is not None:
        F = np.asarray(res.forces, float)
        f, resid = pair_forces(geom.centres, F)
        out.update({"forces": F.tolist(),
                    "force_error": np.asarray(res.force_error, float).tolist(),
                    "F_top_vertical": float(-F[0, 2]),
                    "pair_forces": {f"{i + 1}{j + 1}": v for (i, j), v in f.items()},
                    "pair_residual": resid,
                    "force_sum": float(np.linalg.norm(F.sum(axis=0)))})
    else:
        out.update({"forces": None, "force_error": None, "F_top_vertical": np.nan,
                    "pair_forces": None, "pair_residual": np.nan, "force_sum": np.nan})
    return out


def coalescence_from_cap_gaps(volumes, gaps, opening_angle, order=2):
    """Total volume at which the signed cap gap on a shared grain closes.

    ``volumes``, ``gaps`` [deg]: separate bridges (e.g. Evolver with gravity); a gap < 0
    means the caps already overlap (the bridges would have merged).  A polynomial of
    degree ``order`` in V through the ``order + 1`` points nearest the first change of
    sign (or the last points, extrapolated, when the gap has not closed yet) gives the
    root.  Also returns the "equivalent half filling angle" beta = (opening_angle -
    gap) / 2 at every point: for a symmetric shared grain that is the paper's beta, to
    compare with alpha = opening_angle / 2.

    >>> V = np.array([10., 12, 14]); g = 2 * (30 - (20 + 0.5 * V))
    >>> round(coalescence_from_cap_gaps(V, g, 60.0)["V_coal"], 6)
    20.0
    """
    V = np.asarray(volumes, float)
    G = np.asarray(gaps, float)
    ok = np.isfinite(V) & np.isfinite(G)
    V, G = V[ok], G[ok]
    order_ = np.argsort(V)
    V, G = V[order_], G[order_]
    beta = 0.5 * (opening_angle - G)
    out = {"volumes": V.tolist(), "gaps": G.tolist(), "beta_equivalent": beta.tolist(),
           "alpha": 0.5 * opening_angle, "V_coal": np.nan, "method": "", "bracketed": False}
    n = min(len(V), order + 1)
    if n < 2:
        out["method"] = "too few separate-bridge points"
        return out
    neg = np.flatnonzero(G <= 0)
    if neg.size and neg[0] > 0:
        k = int(neg[0])                       # first overlapping point
        lo = max(0, min(k - (n - 1) + (n - 1) // 2, len(V) - n))
        sel = slice(lo, lo + n)
        lo_v, hi_v = V[k - 1], V[k]
        out["bracketed"] = True
    elif neg.size:
        out["method"] = "caps already overlap at the smallest volume"
        return out
    else:
        sel = slice(len(V) - n, len(V))
        lo_v, hi_v = V[-1], np.inf
    p = np.polyfit(V[sel], G[sel], n - 1)
    roots = np.roots(p)
    roots = roots[np.abs(roots.imag) < 1e-9].real
    roots = roots[(roots >= lo_v - 1e-9) & (roots <= hi_v + 1e-9)]
    if roots.size:
        out["V_coal"] = float(roots.min())
        out["method"] = (f"signed cap gap, polynomial of degree {n - 1} through "
                         f"{n} points, " + ("interpolated" if out["bracketed"]
                                             else "extrapolated") + " to zero")
    else:
        out["method"] = "cap gap does not close in the extrapolation"
    return out


def energy_convention_check(gap=0.175, volume=0.1, theta=60.0, max_refine=3):
    """The same doublet from the exact solver and from Evolver: both energies.

    Returns {"exact", "evolver", "evolver_extrapolated", "evolver_error", "rel_diff"}.
    """
    from capbridge.solvers.evolver import doublet_force
    from capbridge.solvers.young_laplace import solve_doublet

    ex = float(solve_doublet(gap, volume, theta)["energy"])
    _, res = doublet_force(gap, volume, theta, max_refine=max_refine)
    ev = float(res.energy_extrapolated)
    return {"gap": gap, "volume": volume, "theta": theta, "exact": ex,
            "evolver": float(res.energy), "evolver_extrapolated": ev,
            "evolver_error": float(res.error_estimate.get("energy", np.nan)),
            "status": res.status.name.lower(),
            "rel_diff": abs(ev - ex) / max(abs(ex), 1e-12)}


def energy_comparison(geom, theta, volumes, bridges=((0, 1), (0, 2)), fractions=None,
                      max_refine=3, tol=3e-3, callback=None, evolver_results=None):
    """Energies of the coalesced body (Evolver) and of the separate bridges (exact).

    ``evolver_results`` optionally maps a volume to an already computed
    :func:`evolver_triplet` result (coalesced, no gravity), which is then reused.
    Returns a dict with arrays ``volume``, ``E_uncoalesced``, ``E_coalesced``
    (Richardson-extrapolated), ``E_coalesced_error``, ``coalesced_status``, and
    ``crossing``: the volume where E_coalesced - E_uncoalesced changes sign (linear
    interpolation between converged points) or NaN, with ``crossing_note`` saying
    where the coalesced body is lower when no crossing is bracketed.
    """
    V = np.sort(np.atleast_1d(np.asarray(volumes, float)))
    unc = uncoalesced_state(V, geom, theta, bridges, fractions)
    Eu = np.asarray(unc["energy"], float)
    Ec = np.full(V.shape, np.nan)
    Ee = np.full(V.shape, np.nan)
    st = []
    for n, v in enumerate(V):
        r = None if evolver_results is None else evolver_results.get(float(v))
        if r is None:
            r = evolver_triplet(v, geom, theta, "coalesced", max_refine=max_refine, tol=tol)
        st.append(r["status"])
        if r["status"] in ("converged", "above_tolerance"):
            Ec[n] = r["energy_extrapolated"]
            Ee[n] = r["energy_error"]
        if callback is not None:
            callback(n, v, r)
    d = Ec - Eu
    crossing = np.nan
    note = ""
    ok = np.flatnonzero(np.isfinite(d))
    for a, b in zip(ok[:-1], ok[1:]):
        if np.sign(d[a]) != np.sign(d[b]):
            crossing = float(V[a] + (V[b] - V[a]) * d[a] / (d[a] - d[b]))
            break
    if not np.isfinite(crossing):
        if ok.size == 0:
            note = "no converged coalesced body at these volumes"
        elif np.all(d[ok] < 0):
            note = (f"the coalesced body has the lower energy at every volume where it was "
                    f"found ({V[ok].min():.4g} <= V* <= {V[ok].max():.4g}); a crossing, if "
                    f"any, lies below V* = {V[ok].min():.4g}"
                    + (f" (no coalesced equilibrium found at V* = "
                       f"{', '.join(f'{v:.4g}' for v in V[:ok.min()])})" if ok.min() > 0 else ""))
        else:
            note = (f"the separate bridges have the lower energy at every volume where the "
                    f"coalesced body was found ({V[ok].min():.4g}-{V[ok].max():.4g})")
    return {"volume": V, "E_uncoalesced": Eu, "E_coalesced": Ec, "E_coalesced_error": Ee,
            "coalesced_status": st, "crossing": crossing, "crossing_note": note}
