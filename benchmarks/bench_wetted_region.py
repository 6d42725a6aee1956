"""The wetted region of each grain under a coalesced liquid body: what it looks like, and a
base model of the forces built on it (issue 18 item 2, issue 19 item 2).

    .venv/bin/python benchmarks/bench_wetted_region.py [--max-refine 2] [--write]

The force of one liquid body on grain i depends only on the body's Laplace pressure and
on the grain's contact line (:mod:`capbridge.physics.wetted_region`)::

    F*_i = [(2 cos(theta) - P*) S*_i + sin(theta) L*_i] / (2 pi)

with S*_i the vector area of the wetted region and L*_i the line integral of the grain's
unit normal along the contact line.  A base model for coalesced bodies therefore needs
(a) the pressure from the volume and (b) each grain's wetted region.  On Surface Evolver
solutions (triplets with an open third side and closed ones, theta 0/30/60 deg,
v = V/V_coal 1.2/2/3; filled tetrahedra and rhombi of four grains) this measures:

1. the formula on the final mesh's contact lines against Evolver's forces (a check);
2. diagnostic: one spherical cap per grain with Evolver's S*_i (so only L*_i is
   modelled): error in |F_i| and in direction;
3. the shape of the wetted regions: the contact line's polar angle about the direction
   to each neighbour (min / max over azimuth), and the share of S*_i inside the caps
   toward the bridged neighbours;
4. predictive candidates (no Evolver for the regions, Evolver's P*;
   :func:`~capbridge.physics.wetted_region.predict_regions`): the toroidal bridges at
   P* alone, the hull model, the window model (the default) and variants: error per
   grain relative to the body's max |F_i|, and the net force of each body;
5. level-3 checks of a few bodies (``--max-refine 3 --only KEY --collect-only`` adds
   them to the cache);
6. (a) the volume the window model implies at Evolver's P* against the body's
   (:func:`~capbridge.physics.wetted_region.body_volume`).

Evolver results (contact-line polygons, forces, pressures) are cached in
``benchmarks/evolver_out/wetted_region.json``; a rerun computes only missing cases.
Runs one Evolver process at a time.  ``--write`` puts the section in RESULTS.md.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

from capbridge.physics import wetted_region as wr  # noqa: E402

CACHE = HERE / "evolver_out" / "wetted_region.json"
SECTION = "### Wetted regions of coalesced bodies: a base model from pressure and contact lines"

#: triplet geometries (d12, d13, d23): grain 1 (index 0) is bridged to grains 2 and 3
TRIPLETS = {"open 0.3": (0.0, 0.0, 0.3), "open 0.6": (0.0, 0.0, 0.6),
            "open 0.45 asym": (0.0, 0.1, 0.45), "closed 0.1": (0.1, 0.1, 0.1)}
TRIPLET_V = (1.2, 2.0, 3.0)
THETAS = (0.0, 30.0, 60.0)
GAP4 = 0.05
D4 = 2.0 + GAP4


def clusters():
    h = D4 * np.sqrt(3) / 2
    return {
        "tetrahedron": (np.array([[0, 0, 0], [D4, 0, 0], [D4 / 2, h, 0],
                                  [D4 / 2, h / 3, D4 * np.sqrt(2 / 3)]]), (0.4, 0.8)),
        "rhombus": (np.array([[0, 0, 0], [D4, 0, 0], [D4 / 2, h, 0], [D4 / 2, -h, 0]]),
                    (0.5, 1.0)),
    }


CLUSTER_THETAS = (0.0, 30.0)


def bridged_pairs(centres, radii, max_gap=0.2):
    """Pairs (i, j) whose surface gap is at most ``max_gap`` (the bridges of the body)."""
    n = len(centres)
    out = []
    for i in range(n):
        for j in range(i + 1, n):
            gap = np.linalg.norm(centres[i] - centres[j]) - radii[i] - radii[j]
            if gap <= max_gap + 1e-9:
                out.append((i, j))
    return out


# ---------------------------------------------------------------------------------------
# Evolver runs
# ---------------------------------------------------------------------------------------

def contact_polygons(shape):
    """Per grain: the contact-line edges (a, b) of the final mesh, as point pairs (m, 2, 3),
    oriented so that 1/2 sum (a - c) x (b - c) is the vector area of the wetted cap."""
    tri = np.asarray(shape.triangles)
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    b = e[cnt[inv].ravel() == 1]
    cg = np.asarray(shape.contact_grain)
    X = np.asarray(shape.points)
    out = []
    for g in range(len(shape.centres)):
        sel = b[(cg[b[:, 0]] == g) & (cg[b[:, 1]] == g)]
        out.append(np.stack([X[sel[:, 0]], X[sel[:, 1]]], axis=1))
    return out


def solve_case(case, max_refine):
    """One Evolver body: dict with forces, pressure, status, cpu and contact lines."""
    t0 = time.process_time()
    if case["kind"] == "triplet":
        from capbridge.solvers.triplet import triplet_geometry
        from capbridge.solvers.triplet_evolver import evolver_triplet
        g = triplet_geometry(*case["gaps"])
        r = evolver_triplet(case["V"], g, case["theta"], max_refine=max_refine,
                            keep_shape=True)
        centres = g.centres
    else:
        from capbridge.solvers.cluster import solve_cluster
        centres = np.asarray(case["centres"], float)
        r = solve_cluster(centres, 1.0, case["V"], case["theta"], max_refine=max_refine,
                          keep_shape=True)
        r = dict(r, status=getattr(r["status"], "name", str(r["status"])).lower())
    out = {"status": str(r["status"]), "reason": str(r.get("reason", "")),
           "centres": np.asarray(centres, float).tolist(),
           "cpu_s": float(r.get("cpu_time") or 0.0) + (time.process_time() - t0)}
    if r.get("forces") is None or r.get("shape") is None:
        out.update(forces=None, pressure=None, lines=None, refinement=None)
        return out
    fe = r.get("force_error")
    out.update(forces=np.asarray(r["forces"], float).tolist(),
               force_error=None if fe is None else np.asarray(fe, float).tolist(),
               pressure=float(r["pressure"]),
               refinement=int(r.get("refinement") if r.get("refinement") is not None else -1),
               lines=[p.tolist() for p in contact_polygons(r["shape"])])
    return out


def case_list():
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry
    cases = []
    for name, gaps in TRIPLETS.items():
        g = triplet_geometry(*gaps)
        for th in THETAS:
            vc = float(find_coalescence(g, th).V_coal)
            for v in TRIPLET_V:
                cases.append({"kind": "triplet", "name": name, "gaps": list(gaps),
                              "theta": th, "v": v, "V_coal": vc, "V": v * vc})
    for name, (C, vols) in clusters().items():
        for th in CLUSTER_THETAS:
            for V in vols:
                cases.append({"kind": "cluster", "name": name, "centres": C.tolist(),
                              "theta": th, "V": V, "v": None, "V_coal": None})
    return cases


def key(case, max_refine):
    if case["kind"] == "triplet":
        return (f"triplet {case['gaps']} theta={case['theta']:g} v={case['v']:g} "
                f"L{max_refine}")
    return f"cluster {case['name']} theta={case['theta']:g} V={case['V']:g} L{max_refine}"


def solve_into(cache, path, case, max_refine):
    """Solve ``case`` (:func:`solve_case`) into ``cache`` under :func:`key` and write the
    cache to ``path`` (atomically); returns the result."""
    from capbridge.tables.atomic import atomic_target

    k = key(case, max_refine)
    t = time.time()
    res = solve_case(case, max_refine)
    cache[k] = dict(case, **res)
    print(f"{k}: {res['status']} P*={res['pressure']} cpu {res['cpu_s']:.1f} s "
          f"(wall {time.time() - t:.1f} s)", flush=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_target(path) as tmp:
        Path(tmp).write_text(json.dumps(cache, indent=0))
    return res


def collect(max_refine, only=None):
    cache = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    for case in case_list():
        k = key(case, max_refine)
        if only and only not in k:
            continue
        if k in cache:
            continue
        solve_into(cache, CACHE, case, max_refine)
    return {k: v for k, v in cache.items() if k.endswith(f"L{max_refine}")
            and (not only or only in k)}



# ---------------------------------------------------------------------------------------
# analysis
# ---------------------------------------------------------------------------------------

def family(c):
    if c["kind"] == "cluster":
        return c["name"]
    return "triplet closed" if c["name"].startswith("closed") else "triplet open side"


def polar(seg, C, g, j):
    """Polar angles [deg] of the contact-line vertices of grain g about the direction
    to grain j."""
    x = seg[:, 0] - C[g]
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    u = (C[j] - C[g]) / np.linalg.norm(C[j] - C[g])
    return np.degrees(np.arccos(np.clip(x @ u, -1, 1)))


def lobe(seg, C, g, j):
    """Signed reach of grain g's wetted region toward grain j: the smallest polar angle
    [deg] of the contact line about the direction to j, positive when that direction
    lies inside the region (the line passes beyond it), negative when outside."""
    u = (C[j] - C[g]) / np.linalg.norm(C[j] - C[g])
    h = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(u, h)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)

    def proj(x):
        x = x - C[g]
        x = x / np.linalg.norm(x, axis=1, keepdims=True)
        d = 1.0 + x @ u                       # stereographic from -u
        return np.stack([x @ e1 / d, x @ e2 / d], axis=1)

    a, b = proj(seg[:, 0]), proj(seg[:, 1])
    ang = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.einsum("ij,ij->i", a, b))
    inside = abs(ang.sum()) > np.pi
    m = float(polar(seg, C, g, j).min())
    return m if inside else -m


#: the options of ``predict_regions`` before 2026-11-27, which this benchmark's section
#: measured (the continuous model that replaced them as the defaults is measured in
#: ``bench_base_residual.py``)
OLD_DEFAULTS = dict(missing_bridge="minimum", positive_pressure="hull")
VARIANTS = {
    "bridges only": dict(OLD_DEFAULTS, pores=False),
    "hull, open side: point": dict(OLD_DEFAULTS, pore_shape="hull", windows=False,
                                   open_side="point"),
    "hull, open side: mirror": dict(OLD_DEFAULTS, pore_shape="hull", windows=False,
                                    open_side="mirror"),
    "window model (default)": dict(OLD_DEFAULTS),
    "window balls 1/|P*|": dict(OLD_DEFAULTS, window_kappa=1.0),
    "window, P* >= 0: flat windows": dict(OLD_DEFAULTS, flat_windows=True),
}
DEFAULT = "window model (default)"     # the default until 2026-11-27


def analyse(cases):
    """Per grain rows of every measure (dicts), from the cached Evolver bodies."""
    rows = []
    for k, c in sorted(cases.items()):
        if c["forces"] is None:
            continue
        C = np.asarray(c["centres"], float)
        n = len(C)
        F = np.asarray(c["forces"], float)
        P, th = float(c["pressure"]), float(c["theta"])
        scale = float(np.linalg.norm(F, axis=1).max())
        pairs = bridged_pairs(C, np.ones(n))
        preds = {}
        for name, kw in VARIANTS.items():
            S, L, info = wr.predict_regions(C, np.ones(n), th, P, pairs, **kw)
            preds[name] = (wr.region_force(P, th, S, L), S, info)
        for g in range(n):
            seg = np.asarray(c["lines"][g], float)
            Sm, Lm = wr.polygon_region(seg, C[g])
            Fm = wr.region_force(P, th, Sm, Lm)
            a = wr.cap_half_angle(Sm)
            Sc, Lc = wr.cap_region(a, Sm)
            Fc = wr.region_force(P, th, Sm, Lc)
            # bridge caps with Evolver's own outer half-angle (min polar angle about
            # the neighbour) and the toroidal ones at P*
            nb = [j for i_, j in pairs if i_ == g] + [i_ for i_, j in pairs if j == g]
            meas, tor = [], []
            for j in nb:
                meas.append((C[j] - C[g], np.radians(polar(seg, C, g, j).min())))
                key = (min(g, j), max(g, j))
                al = preds[DEFAULT][2]["alpha"][key]
                tor.append(np.degrees(al[0] if g < j else al[1]))
            Scaps, _ = wr.union_region([("cap", m) for m in meas])
            openn = [j for j in range(n) if j != g and j not in nb
                     and np.linalg.norm(C[j] - C[g]) - 2 <= 1.0]
            ex = [preds[DEFAULT][2]["alpha"][(min(g, j), max(g, j))][2] for j in nb]
            row = {"key": k, "family": family(c), "theta": th, "v": c.get("v"),
                   "toroidal_exists": ex,
                   "V": c["V"], "P": P, "grain": g, "scale": scale,
                   "err_mesh": float(np.linalg.norm(Fm - F[g]) / scale),
                   "cap_mag": float(abs(np.linalg.norm(Fc) - np.linalg.norm(Fm))
                                    / max(np.linalg.norm(Fm), 1e-12)),
                   "cap_dir": float(np.degrees(np.arccos(np.clip(
                       Fc @ Fm / max(np.linalg.norm(Fc) * np.linalg.norm(Fm), 1e-300),
                       -1, 1)))),
                   "cap_vs_ev": float(np.linalg.norm(Fc - F[g]) / scale),
                   "alpha_ev": [float(np.degrees(m[1])) for m in meas],
                   "alpha_tor": tor,
                   "pore_share": float(np.linalg.norm(Sm - Scaps) / np.linalg.norm(Sm)),
                   "open_lobe": [lobe(seg, C, g, j) for j in openn]}
            for name, (Fp, S, _) in preds.items():
                row["err " + name] = float(np.linalg.norm(Fp[g] - F[g]) / scale)
                row["sum " + name] = float(np.linalg.norm(Fp.sum(axis=0)) / scale)
            rows.append(row)
    return rows


def _q(x, qs=(50, 100)):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return np.percentile(x, qs) if x.size else np.full(len(qs), np.nan)


def section(cases, a):
    rows = analyse(cases)
    fams = ["triplet open side", "triplet closed", "tetrahedron", "rhombus"]
    thetas = sorted({r["theta"] for r in rows})
    n_ok = sum(1 for c in cases.values() if c["forces"] is not None)
    failed = [k for k, c in cases.items() if c["forces"] is None]
    cpu = sum(c["cpu_s"] for c in cases.values())
    cpu_name = platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu_name = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mach = f"{cpu_name}, {os.cpu_count()} cores, Python {platform.python_version()}"
    full = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    cpu_all = sum(c["cpu_s"] for c in full.values())
    out = [SECTION, "",
           f"Command: `python benchmarks/bench_wetted_region.py --max-refine {a.max_refine}"
           f"{' --write' if a.write else ''}` ({mach}; Evolver runs one at a time beside a "
           f"two-process sweep; {len(cases)} bodies, {n_ok} with a result, refinement "
           f"level {a.max_refine}, {cpu / 60:.1f} CPU min; with the level-3 checks "
           f"{cpu_all / 60:.1f} CPU min; cached in "
           "`benchmarks/evolver_out/wetted_region.json`).  Triplets (gaps d12, d13, d23): "
           + ", ".join(f"{k} {v}" for k, v in TRIPLETS.items())
           + f", theta {'/'.join(f'{t:g}' for t in THETAS)} deg, v = V/V_coal "
           f"{'/'.join(f'{v:g}' for v in TRIPLET_V)} (V_coal from `find_coalescence`); "
           f"four grains (gaps {GAP4}): tetrahedron V* 0.4/0.8, rhombus V* 0.5/1.0, theta "
           f"{'/'.join(f'{t:g}' for t in CLUSTER_THETAS)}.  Bridged pairs: gap <= 0.2.  "
           "Force errors are per grain, |F_model - F_Evolver| / max_k |F_Evolver,k| of the "
           "body (median / max), unless said otherwise."
           + (f"  No result: {'; '.join(failed)}." if failed else ""), ""]
    # 1. check of the formula on the mesh
    out += ["1. The formula on the final mesh's contact lines (Evolver's S*_i, L*_i, P*) "
            "against Evolver's forces (virtual work, extrapolated over levels): the "
            "level-2 contact line's own error.", "",
            "| theta | grains | median | max |", "|---|---|---|---|"]
    for t in thetas:
        e = [r["err_mesh"] for r in rows if r["theta"] == t]
        q = _q(e)
        out.append(f"| {t:g} | {len(e)} | {q[0]:.3f} | {q[1]:.3f} |")
    # 2. diagnostic: one cap with Evolver's S
    out += ["", "2. Diagnostic: one spherical cap per grain with the vector area S*_i of "
            "Evolver's contact line (only L*_i modelled), against the formula on the "
            "same line (so the mesh error cancels): relative error of |F_i|, angle "
            "between the forces; last column against Evolver's forces.", "",
            "| theta | grains | abs rel. error of |F| (median / max) | direction, deg "
            "(median / max) | against Evolver (median / max) |", "|---|---|---|---|---|"]
    for t in thetas:
        sel = [r for r in rows if r["theta"] == t]
        m, d, ev = (_q([r[x] for r in sel]) for x in ("cap_mag", "cap_dir", "cap_vs_ev"))
        out.append(f"| {t:g} | {len(sel)} | {m[0]:.3f} / {m[1]:.3f} | {d[0]:.2f} / "
                   f"{d[1]:.2f} | {ev[0]:.3f} / {ev[1]:.3f} |")
    # 3. shapes
    out += ["", "3. What the wetted regions look like.  Bridge caps: the contact line's "
            "smallest polar angle about the direction to a bridged neighbour (the cap's "
            "outer edge) against the toroidal bridge at the body's P* "
            "(`toroidal_half_angles`), degrees.  Pore share: |S*_i - S*_caps| / |S*_i|, "
            "S*_caps the union of caps with Evolver's own outer half-angles.  Open-side "
            "lobe (median over the open side's two grains and geometries, by v): the "
            "smallest polar angle of the line about the direction to the far grain, "
            "positive when the region contains that direction (the liquid reaches round "
            "the centre line by that much), negative when it stops short of it.", "",
            "| family | theta | bridge cap: Evolver (min-max) | toroidal minus Evolver "
            "(median / max abs) | pore share (median / max) | open-side lobe by v "
            "(deg) |", "|---|---|---|---|---|---|"]
    for f in fams:
        for t in thetas:
            sel = [r for r in rows if r["family"] == f and r["theta"] == t]
            if not sel:
                continue
            ae = np.concatenate([r["alpha_ev"] for r in sel])
            at = np.concatenate([r["alpha_tor"] for r in sel])
            dd = _q(np.abs(at - ae))
            ps = _q([r["pore_share"] for r in sel])
            lob = {}
            for r in sel:
                for x in r["open_lobe"]:
                    lob.setdefault(r["v"] if r["v"] is not None else r["V"], []).append(x)
            lobs = ", ".join(f"v {kv:g}: {np.median(x):+.1f}" for kv, x in sorted(lob.items()))
            out.append(f"| {f} | {t:g} | {ae.min():.1f}-{ae.max():.1f} | {dd[0]:.1f} / "
                       f"{dd[1]:.1f} | {ps[0]:.2f} / {ps[1]:.2f} | {lobs or '-'} |")
    # 4. predictive candidates
    out += ["", "4. Predictive candidates (Evolver's P*, no Evolver for the regions; "
            "`predict_regions` with the options named): bridges only = the caps of the "
            "toroidal bridges at P*; hull = those caps plus, per triangle of the body "
            "(third gap <= 1), the spherical convex hull of the caps toward the other "
            "two grains, on an open side's grains with a cap toward the far grain (a "
            "point, or mirror: as wide as the grain's bridge cap), and per filled "
            "tetrahedron the spherical triangle of the three directions; window model "
            "(the default) = caps plus, per triangle and grain, the spherical polygon "
            "through the directions to the other two grains and to the window balls "
            "(gas spheres of radius 2/|P*| touching the three grains at theta; radius "
            "1/|P*| in the next column), less the balls' dry discs, and the hull-mirror "
            "pieces where no ball exists (P* >= 0); last column: for P* >= 0 the lune "
            "between the neighbours cut at latitude +-(90 - theta) deg (flat windows) "
            "instead.", "",
            "| family | theta | grains | " + " | ".join(VARIANTS) + " |",
            "|---|---|---|" + "---|" * len(VARIANTS)]
    groups = [(f"{f}", t, lambda r, f=f, t=t: r["family"] == f and r["theta"] == t)
              for f in fams for t in thetas]
    groups += [("all, P* < 0", "all", lambda r: r["P"] < 0),
               ("all, P* >= 0", "all", lambda r: r["P"] >= 0),
               ("all", "all", lambda r: True)]
    for name_, t, pick in groups:
        sel = [r for r in rows if pick(r)]
        if not sel:
            continue
        cells = []
        for name in VARIANTS:
            q = _q([r["err " + name] for r in sel])
            cells.append(f"{q[0]:.3f} / {q[1]:.3f}")
        out.append(f"| {name_} | {t if t == 'all' else format(t, 'g')} | {len(sel)} | "
                   + " | ".join(cells) + " |")
    sums = {name: _q([r["sum " + name] for r in rows if r["grain"] == 0])
            for name in VARIANTS}
    out.append("| net force of the body, |sum F_i| / max |F_i| | all | "
               f"{sum(r['grain'] == 0 for r in rows)} bodies | "
               + " | ".join(f"{sums[n][0]:.3f} / {sums[n][1]:.3f}" for n in VARIANTS)
               + " |")
    nex = sum(len(r["toroidal_exists"]) for r in rows)
    nno = sum(not x for r in rows for x in r["toroidal_exists"])
    out += ["", f"Bridged grain-neighbour pairs without a toroidal bridge at the body's P* "
            f"(caps at the bridge's pressure minimum instead): {nno} of {nex}."]
    vol_lines, vol = volumes(cases)
    out += level3(a)
    out += vol_lines
    out += ["", verdict(rows, vol), ""]
    return "\n".join(out)


def volumes(cases):
    """(a): the liquid volume the window model implies at Evolver's P*, against the
    body's volume (Monte Carlo, ``body_volume``; bodies in suction)."""
    per = {}
    for k, c in sorted(cases.items()):
        if c["forces"] is None or not c["pressure"] < 0:
            continue
        C = np.asarray(c["centres"], float)
        n = len(C)
        pairs = bridged_pairs(C, np.ones(n))
        Vm = wr.body_volume(C, np.ones(n), c["theta"], c["pressure"], pairs)
        Vb = wr.body_volume(C, np.ones(n), c["theta"], c["pressure"], pairs,
                            max_open_gap=-1.0)
        if n > 3:          # the tetrahedron's interior counts as pore, not bridge
            Vb = sum(wr.body_volume(C[[i, j]], np.ones(2), c["theta"], c["pressure"],
                                    [(0, 1)]) for i, j in pairs)
        per.setdefault((family(c), c["theta"]), []).append((Vm / c["V"], Vb / c["V"]))
    if not per:
        return [], {}
    out = ["", "6. (a) The volume the window model implies at Evolver's P* (toroidal "
           "bridges + window pores + filled tetrahedra, Monte Carlo with 4e5 samples, "
           "`body_volume`) over the body's volume, bodies in suction; beside it the "
           "bridges alone (each a toroidal bridge at P*, counted separately).", "",
           "| family | theta | bodies | model / true (median, min-max) | bridges / true "
           "(median, min-max) |", "|---|---|---|---|---|"]
    allm = []
    for (f, t), x in sorted(per.items()):
        m = np.array([y[0] for y in x])
        b = np.array([y[1] for y in x])
        allm += list(m)
        out.append(f"| {f} | {t:g} | {len(x)} | {np.median(m):.2f} ({m.min():.2f}-"
                   f"{m.max():.2f}) | {np.median(b):.2f} ({b.min():.2f}-{b.max():.2f}) |")
    closed = [y[0] for (f, _), x in per.items() if f != "triplet open side" for y in x]
    opened = [y[0] for (f, _), x in per.items() if f == "triplet open side" for y in x]
    return out, {"closed": _q(closed, (0, 50, 100)), "open": _q(opened, (0, 50, 100))}


def level3_pairs(cache, level):
    """(key at level 3, its level-``level`` entry, its level-3 entry, largest Evolver
    change of a grain force from ``level`` to 3 relative to the largest L3 force) for
    every body of ``cache`` solved at both levels with a result."""
    for k3, c3 in sorted(cache.items()):
        if not k3.endswith(" L3") or c3["forces"] is None:
            continue
        c2 = cache.get(k3[:-3] + f" L{level}")
        if c2 is None or c2["forces"] is None:
            continue
        F2, F3 = np.asarray(c2["forces"]), np.asarray(c3["forces"])
        yield k3, c2, c3, np.linalg.norm(F2 - F3, axis=1).max() / np.linalg.norm(F3, axis=1).max()


def level3(a):
    """Bodies computed at level 3 as well: Evolver's L2 forces against L3, and the
    default model against both."""
    cache = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    lines = []
    for k3, c2, c3, moved in level3_pairs(cache, a.max_refine):
        k2 = k3[:-3] + f" L{a.max_refine}"
        r3 = analyse({k3: c3})
        r2 = analyse({k2: c2})
        lines.append(f"| {k3[:-3]} | {c2['pressure']:.3f} / {c3['pressure']:.3f} | "
                     f"{moved:.3f} | "
                     f"{max(r['err_mesh'] for r in r2):.3f} / "
                     f"{max(r['err_mesh'] for r in r3):.3f} | "
                     f"{max(r['err ' + DEFAULT] for r in r2):.3f} / "
                     f"{max(r['err ' + DEFAULT] for r in r3):.3f} | {c3['cpu_s']:.0f} |")
    if not lines:
        return []
    return ["", f"5. Checks at refinement level 3 (`--max-refine 3 --only ...`): P* at "
            f"levels {a.max_refine} / 3; Evolver's level-{a.max_refine} forces against "
            "level 3 (max over grains, relative to max |F_i|); the formula on the mesh "
            "against Evolver's own forces (max, level 2 / 3); the window model against "
            "Evolver (max, level 2 / 3); CPU s of the level-3 run.", "",
            "| body | P* | L2 vs L3 forces | mesh formula | window model | CPU s |",
            "|---|---|---|---|---|---|"] + lines


def verdict(rows, vol):
    def q(sel, name=DEFAULT):
        return _q([r["err " + name] for r in sel])
    neg = [r for r in rows if r["P"] < 0]
    pos = [r for r in rows if r["P"] >= 0]
    qn, qp, qb = q(neg), q(pos), q(rows, "bridges only")
    diag = _q([r["cap_mag"] for r in rows if r["theta"] > 0])
    ddir = _q([r["cap_dir"] for r in rows if r["theta"] > 0])
    ps = _q([r["pore_share"] for r in rows], (10, 90))
    sn = _q([r["sum " + DEFAULT] for r in neg if r["grain"] == 0])
    sp = _q([r["sum " + DEFAULT] for r in pos if r["grain"] == 0])
    return (
        "Verdict.  (1) What matters is S*_i: a single cap with Evolver's vector area "
        f"gives |F_i| within {100 * diag[0]:.1f} % (median; max {100 * diag[1]:.1f} %) "
        f"and the direction within {ddir[1]:.1f} deg for theta > 0 (at theta = 0 the "
        "force is (2 - P*) S*_i / 2 pi exactly), so a base model only has to place each "
        "grain's wetted area and its mean direction; the contact line's detailed shape "
        "is second order.  (2) The wetted regions are not caps about the centre lines: "
        "the outer edges of the bridge caps follow the toroidal bridge at the body's "
        "pressure within a few degrees (worse at theta = 60), but the pore adds "
        f"{100 * ps[0]:.0f}-{100 * ps[1]:.0f} % (p10-p90) of |S*_i|, spread between the "
        "neighbours and, on an open side, a lobe that reaches round the centre line to "
        "the far grain as v grows.  (3) Bridges alone at P* are short by a median "
        f"{100 * qb[0]:.0f} % of the body's largest force (max {100 * qb[1]:.0f} %).  The "
        "window model (toroidal caps + per triangle a pore piece through the window "
        "balls of radius 2/|P*|, Laplace-consistent, no fitted parameter, but chosen "
        "among the variants of section 4 on these same bodies: no held-out set yet) "
        "gives in "
        f"suction (P* < 0, {len(neg)} grains) a median {100 * qn[0]:.1f} % and max "
        f"{100 * qn[1]:.1f} %; for P* >= 0 ({len(pos)} grains, theta = 60 and the wide "
        f"open sides at large v) a median {100 * qp[0]:.1f} % and max {100 * qp[1]:.1f} % "
        "(the convex body spreads far beyond the caps' hull; neither flat windows nor "
        "the hull fix it).  Unlike Evolver's, the model's forces need not balance: "
        f"|sum F_i| / max |F_i| of a body is a median {100 * sn[0]:.1f} % (max "
        f"{100 * sn[1]:.1f} %) in suction, {100 * sp[0]:.1f} % (max {100 * sp[1]:.1f} %) "
        "for P* >= 0, to be removed before use in DEM.  (a) At Evolver's P* the model's "
        "body holds too much liquid: "
        f"{vol['closed'][1]:.2f} x the true volume (median; {vol['closed'][0]:.2f}-"
        f"{vol['closed'][2]:.2f}) for closed triangles and clusters, "
        f"{vol['open'][1]:.2f} x ({vol['open'][0]:.2f}-{vol['open'][2]:.2f}) with an "
        "open side (its pyramid fills the open side up to the window balls), so "
        "solving P* from the volume with it would give too much suction (P* too "
        "negative) and shift the forces: the pressure-volume part (a) is not solved.  "
        "It is a usable base for the forces at a known P* in suction, defined for any "
        "geometry and pressure, not yet for convex bodies nor for the volume.  Next: a "
        "pore-piece rule for P* >= 0 (there the pore takes the largest share of S*_i, "
        "section 3, and the region spreads away from the plane of the triangle as v "
        "grows), a pore volume consistent with the windows (the open side's sheet, not "
        "a filled pyramid) to close (a), and then the smoothness of the triplet table's "
        "residual against this base along v and the gaps, as for the doublet base.")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--max-refine", type=int, default=2)
    ap.add_argument("--only", default=None, help="only cases whose key contains this")
    ap.add_argument("--collect-only", action="store_true")
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    cases = collect(a.max_refine, a.only)
    if a.collect_only:
        return 0
    text = section(cases, a)
    print(text)
    if a.write:
        from results_file import write_section
        write_section(SECTION, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
