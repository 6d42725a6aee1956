"""Triplet surrogate: lookup throughput (one core), held-out errors, unequal radii.

Two steps:

``python benchmarks/bench_triplet.py evolver``
    Surface Evolver reference of the unequal-radii approximation: one coalesced body on
    each of the triplets of :data:`UNEQUAL_CASES` (radii ratios up to 2), at the
    settings of the shipped triplet table (level 3, Richardson, ftol = etol = 1e-2, one
    Evolver process).  Results are cached in ``benchmarks/triplet_unequal_evolver.json``
    (one entry per case, written after each case, keyed by the case's inputs): a rerun
    computes only the missing cases, so the benchmark is reproducible without Evolver.

``python benchmarks/bench_triplet.py [--table T] [--coalescence-table C] [--write]``
    Single-thread lookup rate of :class:`~capbridge.surrogate.triplet.TripletSurrogate`
    beside :class:`~capbridge.surrogate.doublet.DoubletSurrogate` in the same run, the
    held-out errors (multilinear on the raw grid against cubic refinement), and the
    errors of the unequal-radii approximations against the cached Evolver results.
    Prints a markdown section; ``--write`` appends it to ``benchmarks/RESULTS.md``
    under the heading "Triplet surrogate".

Thread counts are pinned to 1 (OPENBLAS/OMP/MKL) before numpy is imported.
"""
from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from results_file import write_section  # noqa: E402
CACHE = HERE / "triplet_unequal_evolver.json"
VCOAL_CACHE = HERE / "triplet_vcoal_exact.json"

#: (radii R1, R2, R3; gaps d12, d13, d23 between surfaces; theta [deg]; target v) in
#: units of the smallest radius.  Gaps <= 0.15 R_min keep every normalisation of the
#: approximation inside the table's gap range [0, 0.2]; v is the target
#: V / (R_h^3 V*_coal(gaps / R_h)) with R_h the harmonic mean of the radii.
UNEQUAL_CASES = [
    ((1.0, 1.0, 2.0), (0.05, 0.05, 0.05), 0.0, 1.2),
    ((1.0, 2.0, 2.0), (0.0, 0.1, 0.05), 30.0, 1.4),
    ((2.0, 1.0, 1.0), (0.1, 0.1, 0.0), 60.0, 1.2),
    ((1.0, 1.5, 2.0), (0.05, 0.1, 0.15), 0.0, 1.4),
    ((1.5, 1.0, 1.25), (0.02, 0.08, 0.12), 40.0, 1.2),
    ((1.0, 1.25, 1.25), (0.1, 0.05, 0.1), 20.0, 1.4),
    ((1.2, 1.8, 1.0), (0.0, 0.0, 0.1), 0.0, 1.2),
    ((1.0, 2.0, 1.5), (0.12, 0.03, 0.06), 60.0, 1.4),
    ((1.0, 1.1, 1.2), (0.05, 0.15, 0.1), 30.0, 1.2),
    ((2.0, 2.0, 1.0), (0.1, 0.05, 0.05), 70.0, 1.4),
    ((1.0, 1.6, 1.3), (0.08, 0.08, 0.02), 50.0, 1.3),
    ((1.0, 1.0, 1.0), (0.05, 0.1, 0.15), 30.0, 1.3),     # equal radii: control
    ((1.0, 2.0, 1.5), (0.03, 0.06, 0.09), 10.0, 1.25),
    ((1.4, 1.0, 2.0), (0.07, 0.0, 0.04), 45.0, 1.5),
    ((1.0, 1.3, 1.7), (0.1, 0.1, 0.1), 80.0, 1.3),
    ((1.75, 1.0, 1.75), (0.02, 0.02, 0.09), 25.0, 1.1),
    ((1.0, 1.0, 1.0), (0.03, 0.07, 0.1), 50.0, 1.3),      # equal radii: control
]

#: Evolver settings of the shipped triplet table (capbridge.tables.triplet.EvolverPlan)
EVOLVER_SETTINGS = dict(ftol=1e-2, etol=1e-2, max_refine=3, min_refine=2, workers=1,
                        level_timeout=300.0, total_timeout=900.0)
RETRY_RINGS = (8, 12)


def triangle_centres(radii, gaps):
    """Centres (3, 3) in the plane y = 0: grain 1 at the origin, grain 2 on +x, grain 3
    at z > 0, centre distances R_i + R_j + d_ij."""
    R = np.asarray(radii, float)
    d12, d13, d23 = gaps
    a, b, c = R[0] + R[1] + d12, R[0] + R[2] + d13, R[1] + R[2] + d23
    x3 = (a * a + b * b - c * c) / (2 * a)
    return np.array([[0.0, 0.0, 0.0], [a, 0.0, 0.0], [x3, 0.0, np.sqrt(b * b - x3 * x3)]])


def case_key(case):
    radii, gaps, theta, v = case
    return json.dumps({"radii": list(radii), "gaps": list(gaps), "theta": theta, "v": v})


def _target_volume(radii, gaps, theta, v):
    """V* = v R_h^3 V*_coal(gaps / R_h, theta) (exact equal-sphere coalescence volume)."""
    from capbridge.dimensionless import canonical_triplet
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry

    Rh = 3.0 / np.sum(1.0 / np.asarray(radii, float))
    srt, _ = canonical_triplet(*(np.asarray(gaps) / Rh))
    r = find_coalescence(triplet_geometry(*srt), theta)
    if r.status != "coalescence":
        raise RuntimeError(f"no coalescence volume for {gaps}, theta={theta}")
    return float(v * Rh**3 * r.V_coal), float(r.V_coal)


def solve_coalesced(centres, radii, theta, volume):
    """One coalesced triplet by Surface Evolver with the table's settings (a retry with
    more ring points after a mesh failure): the cache entry's solver part (status,
    reason, refinement, CPU time, attempts, settings; forces, pair forces, pressure and
    errors when converged)."""
    from capbridge.solvers.evolver import Settings, minimise_bridge
    from capbridge.solvers.triplet import pair_forces

    attempts = []
    for ring in RETRY_RINGS:
        res = minimise_bridge(centres, list(radii), theta, volume, topology="coalesced",
                              settings=Settings(n_ring=ring, **EVOLVER_SETTINGS))
        attempts.append({"n_ring": ring, "status": res.status.name.lower(),
                         "reason": res.reason, "cpu_time": res.cpu_time})
        if res.converged or not any(k in res.reason for k in
                                    ("degenerate", "fold", "driver error")):
            break
    entry = {"status": res.status.name.lower(), "reason": res.reason,
             "refinement": int(res.refinement),
             "cpu_time": float(sum(a["cpu_time"] for a in attempts)),
             "attempts": attempts, "settings": EVOLVER_SETTINGS}
    if res.converged and res.forces is not None:
        F = np.asarray(res.forces, float)
        f, resid = pair_forces(centres, F)
        entry.update({"forces": F.tolist(),
                      "force_error": np.asarray(res.force_error, float).tolist(),
                      "force_error_rel": float(res.error_estimate.get("force_rel", np.nan)),
                      "pair_forces": [f[(0, 1)], f[(0, 2)], f[(1, 2)]],
                      "pair_residual": resid,
                      "pressure": float(np.asarray(res.pressure).ravel()[0]),
                      "energy_extrapolated": float(res.energy_extrapolated)})
    return entry


def run_evolver(cases=UNEQUAL_CASES, cache=CACHE):
    """Solve the missing cases with Surface Evolver, one at a time; update the cache."""
    from capbridge.tables.atomic import atomic_target

    done = json.loads(cache.read_text()) if cache.exists() else {}
    for n, case in enumerate(cases):
        key = case_key(case)
        if key in done:
            continue
        radii, gaps, theta, v = case
        centres = triangle_centres(radii, gaps)
        volume, vcoal_h = _target_volume(radii, gaps, theta, v)
        entry = {"radii": list(radii), "gaps": list(gaps), "theta": theta, "v_target": v,
                 "centres": centres.tolist(), "volume": volume,
                 "harmonic_mean_radius": 3.0 / float(np.sum(1.0 / np.asarray(radii))),
                 "V_coal_harmonic": vcoal_h,
                 **solve_coalesced(centres, radii, theta, volume)}
        done[key] = entry
        with atomic_target(cache) as tmp:
            Path(tmp).write_text(json.dumps(done, indent=1, sort_keys=True) + "\n")
        print(f"case {n + 1}/{len(cases)}: {entry['status']} in {entry['cpu_time']:.1f} CPU s"
              f" (pair forces {entry.get('pair_forces')})", flush=True)
    return done


def run_vcoal(n=16, seed=11, cache=VCOAL_CACHE):
    """Exact V*_coal (find_coalescence at the sorted gaps) at n random geometries and
    angles inside the shipped table's box (gaps 0-0.2, theta 0-80 deg); cached."""
    from capbridge.dimensionless import canonical_triplet
    from capbridge.tables.atomic import atomic_target
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        g = rng.uniform(0.0, 0.2, 3)
        t = float(rng.uniform(0.0, 80.0))
        srt, _ = canonical_triplet(*g)
        r = find_coalescence(triplet_geometry(*srt), t)
        out.append({"gaps": g.tolist(), "theta": t,
                    "V_coal": r.V_coal if r.status == "coalescence" else None})
    with atomic_target(cache) as tmp:
        Path(tmp).write_text(json.dumps({"seed": seed, "points": out}, indent=1) + "\n")
    return out


def vcoal_errors(table, coalescence_table=None, cache=VCOAL_CACHE):
    """Relative V*_coal errors at the cached exact points, per way of getting it."""
    from capbridge.surrogate.triplet import TripletSurrogate

    pts = [p for p in json.loads(cache.read_text())["points"] if p["V_coal"]]
    g = np.array([p["gaps"] for p in pts]).T
    t = np.array([p["theta"] for p in pts])
    V = np.array([p["V_coal"] for p in pts])
    ways = [("triplet table, splines", "cubic", None),
            ("triplet table, multilinear", "linear", None)]
    if coalescence_table:
        ways.append(("coalescence table (sorted gaps, cubic) + node residual", "cubic",
                     coalescence_table))
    out = {}
    for name, method, ct in ways:
        s = TripletSurrogate(method=method).fit(table, coalescence_table=ct)
        inside = s.covers(*g, t)
        if not inside.any():
            continue
        r = s.coalescence_volume(*(x[inside] for x in g), t[inside])
        e = np.abs(r["volume_coalescence"] / V[inside] - 1)
        law = np.abs((r["V0"] + t[inside] / 90 * r["dV"]) / V[inside] - 1)
        out[name] = (float(np.median(e)), float(np.max(e)), float(np.median(law)),
                     float(np.max(law)), int(inside.sum()))
    return out or {"(no point inside the table)": (np.nan,) * 4 + (0,)}


def _rate(fn, n, repeat=3):
    """(evaluations per CPU second, per wall second): best of ``repeat`` runs of fn().

    CPU time of this process is the per-core figure on a shared machine (the wall clock
    also counts the time other jobs hold the core); both are reported."""
    cpu = wall = np.inf
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - w0)
    return n / cpu, n / wall


def _random_points(sur, n, seed):
    """Gaps, theta uniform in the table; v uniform 1 % inside its range."""
    rng = np.random.default_rng(seed)
    g = rng.uniform(sur.gaps_[0], sur.gaps_[-1], (3, n))
    t = rng.uniform(sur.theta_[0], sur.theta_[-1], n)
    span = sur.v_[-1] - sur.v_[0]
    v = rng.uniform(sur.v_[0] + 0.01 * span, sur.v_[-1] - 0.01 * span, n)
    return g, t, v * sur.coalescence_volume(*g, t)["volume_coalescence"]


def throughput(sur, n, seed=1):
    """Lookup rates of the triplet and doublet surrogates on n random points each."""
    from capbridge.surrogate.doublet import DoubletSurrogate

    g, t, V = _random_points(sur, n, seed)
    sur.predict(*(x[:10] for x in g), V[:10], t[:10])
    trip = _rate(lambda: sur.predict(*g, V, t), n)
    ans = sur.predict(*g, V, t)["status"]
    dsur = DoubletSurrogate().fit(ROOT / "data" / "doublet_table.nc")
    rng = np.random.default_rng(seed)
    th = rng.uniform(dsur.theta_[0], dsur.theta_[-1], n)
    vol = np.exp(rng.uniform(np.log(dsur.volume_[0]), np.log(dsur.volume_[-1]), n))
    gap = dsur.predict(0.0, vol, th)["rupture_gap"] * (1 - rng.uniform(0.2, 1.0, n) ** 2)
    dsur.predict(gap[:10], vol[:10], th[:10])
    doub = _rate(lambda: dsur.predict(gap, vol, th), n)
    m = min(n, 100_000)
    C = _centres(g[:, :m])
    vec = _rate(lambda: sur.predict_vectors(C, V[:m], t[:m]), m)
    return {"n": n, "triplet": trip, "doublet": doub, "vectors": vec, "m_vectors": m,
            "answered": float(np.mean(np.isin(ans, (0, 7))))}


def _centres(g):
    """Equal unit spheres with gaps g (3, n): centres (n, 3, 3)."""
    a, b, c = 2 + g
    x3 = (a * a + b * b - c * c) / (2 * a)
    C = np.zeros((g.shape[1], 3, 3))
    C[:, 1, 0] = a
    C[:, 2, 0], C[:, 2, 2] = x3, np.sqrt(b * b - x3 * x3)
    return C


def accuracy(table, coalescence_table=None):
    """Held-out errors per method and lookup mode; refinement error of the default grid."""
    from capbridge.surrogate.triplet import (DEFAULT_REFINE, METHODS, TripletSurrogate,
                                             holdout_errors)

    rows = {}
    for method in METHODS:
        s = TripletSurrogate(method=method).fit(table, coalescence_table=coalescence_table)
        if s.holdout_ is None:
            break
        for by in ("volume", "v"):
            e = holdout_errors(s, by=by)
            rows[(method, by)] = (e["median_rel_error"], e["max_rel_error"], e["n"],
                                  int(e["used"].size), e["max_rel_to_largest"])
    base = TripletSurrogate().fit(table, coalescence_table=coalescence_table)
    g, t, V = _random_points(base, 400, 2)
    v = V / base.coalescence_volume(*g, t)["volume_coalescence"]
    a = base.predict(*g, V, t)
    ok = np.isin(a["status"], (0, 7))
    exact = base.spline_at(*(x[ok] for x in g), t[ok], v[ok])
    d = np.max(np.abs(np.stack([a[n][ok] for n in ("f12", "f13", "f23")], 1)
                      / exact[:, :3] - 1), 1)
    h = base.holdout_
    if h is not None:
        vc = base.coalescence_volume(h["d12"], h["d13"], h["d23"], h["theta"])
        vc_err = np.abs(vc["volume_coalescence"] * h["v"] / h["volume"] - 1)
        rows["V_coal"] = (float(np.median(vc_err)), float(np.max(vc_err)), vc_err.size)
    return rows, {"refine": DEFAULT_REFINE,
                  "median": float(np.median(d)) if d.size else np.nan,
                  "max": float(np.max(d)) if d.size else np.nan, "n": int(ok.sum())}, base


def unequal(sur, cache=CACHE):
    """Errors of each unequal-radii scheme against the cached Evolver results."""
    from capbridge.surrogate.triplet import UNEQUAL_SCHEMES
    from capbridge.validation import CapbridgeInputError

    data = json.loads(cache.read_text())
    out = {}
    for scheme in UNEQUAL_SCHEMES:
        rel, ctrl, skipped, vec = [], [], [], []
        for key, e in data.items():
            if "pair_forces" not in e:
                skipped.append((key, e["status"]))
                continue
            try:
                r = sur.predict_vectors(np.array(e["centres"]), e["volume"], e["theta"],
                                        radii=np.array(e["radii"]), unequal=scheme)
            except CapbridgeInputError as exc:
                skipped.append((key, str(exc)[:80]))
                continue
            if int(r["status"]) not in (0, 7, 9):          # no result in that cell
                from capbridge.status import status_name
                skipped.append((key, f"status {status_name(int(r['status']))}"))
                continue
            f = np.array([float(r[n]) for n in ("f12", "f13", "f23")])
            ref = np.array(e["pair_forces"])
            err = np.abs(f / ref - 1)
            F, Fe = r["forces"], np.array(e["forces"])
            verr = float(np.max(np.linalg.norm(F - Fe, axis=1)) /
                         np.max(np.linalg.norm(Fe, axis=1)))
            if len(set(e["radii"])) == 1:
                ctrl.extend(err)
            else:
                rel.extend(err)
                vec.append(verr)
        rel = np.array(rel)
        out[scheme] = {"median": float(np.median(rel)) if rel.size else np.nan,
                       "max": float(np.max(rel)) if rel.size else np.nan,
                       "n_triplets": len(vec), "vector_max": max(vec) if vec else np.nan,
                       "control_max": float(np.max(ctrl)) if ctrl else np.nan,
                       "skipped": skipped}
    return out, data


def sur_source(args):
    return "from the coalescence table" if args.coalescence_table else \
        "interpolated in the triplet table"


def bench(args):
    from capbridge.surrogate.triplet import METHODS, UNEQUAL_SCHEMES

    t0 = time.perf_counter()
    rows, refine_err, sur = accuracy(args.table, args.coalescence_table)
    vce = vcoal_errors(args.table, args.coalescence_table)
    tp = throughput(sur, args.n)
    une, data = unequal(sur)
    cpu = [e["cpu_time"] for e in data.values()]
    n_equal = sum(len(set(e["radii"])) == 1 for e in data.values())
    shipped = Path(args.table).resolve() == (ROOT / "data" / "triplet_table.nc").resolve()
    table_opt = "" if shipped else f" --table {Path(args.table).name}"
    load = os.getloadavg()
    lines = [
        f"### Triplet surrogate ({time.strftime('%Y-%m-%d')})", "",
        f"Command: `.venv/bin/python benchmarks/bench_triplet.py --write{table_opt}` (table "
        f"`{Path(args.table).name}`" + (f", coalescence table "
                                         f"`{Path(args.coalescence_table).name}`"
                                         if args.coalescence_table else "") +
        f"); machine: {platform.processor() or platform.machine()}, {os.cpu_count()} "
        f"cores shared with other jobs (load average {load[0]:.1f}), one thread "
        f"(OPENBLAS/OMP/MKL_NUM_THREADS=1), numpy {np.__version__}, Python "
        f"{platform.python_version()}; whole run {time.perf_counter() - t0:.0f} s.", ""]
    lines += [args.note, ""] if args.note else []
    lines += [f"Lookup rate, {tp['n']:,} random points each (triplet: gaps, theta uniform in "
        f"the table, v uniform 1 % inside its range; {100 * tp['answered']:.1f} % of them "
        "in cells with a result; doublet: the benchmark points of bench_doublet.py). "
        "Per CPU second of this process (the per-core figure on a shared machine) and "
        "per wall second:", "",
        "| lookup | evaluations / CPU s | evaluations / wall s |", "|---|---:|---:|",
        f"| TripletSurrogate.predict (any geometry, V*, theta) | {tp['triplet'][0]:,.0f} | "
        f"{tp['triplet'][1]:,.0f} |",
        f"| TripletSurrogate.predict_vectors ({tp['m_vectors']:,} points) | "
        f"{tp['vectors'][0]:,.0f} | {tp['vectors'][1]:,.0f} |",
        f"| DoubletSurrogate.predict (any theta), same run | {tp['doublet'][0]:,.0f} | "
        f"{tp['doublet'][1]:,.0f} |", "",
        "Held-out Evolver points of the table (one refinement level finer), relative "
        "error of the pair forces f_ij (every pair of every point with a result):", "",
        "| method | looked up by | median | max | max, relative to the largest f_ij "
        "| pair forces (points used / stored) |",
        "|---|---|---:|---:|---:|---:|"]
    vc = rows.pop("V_coal", None)
    if not rows:
        lines.append("| (this table has no held-out points) | | | | | |")
    for (method, by), (med, mx, n, tot, mxl) in rows.items():
        name = f"{method}: {METHODS[method]}"
        mode = {"volume": "V* (V*_coal interpolated too)", "v": "v = V*/V*_coal (exact)"}[by]
        lines.append(f"| {name} | {mode} | {med:.2e} | {mx:.2e} | {mxl:.2e} | {3 * n} "
                     f"({n} / {tot}) |")
    lines += ["", "V*_coal (the volume scale of v) against exact coalescence volumes at "
              f"{next(iter(vce.values()))[4]} random geometries and angles "
              "(`benchmarks/triplet_vcoal_exact.json`, `bench_triplet.py vcoal`); the "
              "linear law V0 + (theta/90) dV beside it:", "",
              "| V*_coal from | median | max | linear law: median | max |",
              "|---|---:|---:|---:|---:|"]
    for name, (m1, x1, m2, x2, _) in vce.items():
        lines.append(f"| {name} | {m1:.1e} | {x1:.1e} | {m2:.1e} | {x2:.1e} |")
    lines += [] if vc is None else [
        "", f"V*_coal at the {vc[2]} held-out geometries (exact: their V* / v) against "
              f"the surrogate's ({sur_source(args)}): median {vc[0]:.1e}, max {vc[1]:.1e} "
              "relative."]
    lines += [
        "", f"Fine-grid error (lookup against the spline interpolant it stands for, "
        f"evaluated directly; refine {refine_err['refine']} steps per table interval in "
        f"gaps, theta, v; {refine_err['n']} random points with a result): median "
        f"{refine_err['median']:.1e}, max {refine_err['max']:.1e} relative in f_ij.", "",
        f"Unequal radii: {len(data)} coalesced triplets solved by Surface Evolver "
        f"(`benchmarks/triplet_unequal_evolver.json`, `bench_triplet.py evolver`: level "
        f"3, ftol = etol = 1e-2; {np.median(cpu):.1f} CPU s per triplet, median); radii "
        f"ratios up to 2, {n_equal} with equal radii as controls; relative error of f_ij "
        "over the unequal triplets answered by the table:", "",
        "| scheme | median | max | force vectors: max error / max F_i | equal control, max "
        "| triplets |",
        "|---|---:|---:|---:|---:|---:|"]
    for scheme, e in une.items():
        lines.append(f"| {scheme}: {UNEQUAL_SCHEMES[scheme]} | {e['median']:.2e} | "
                     f"{e['max']:.2e} | {e['vector_max']:.2e} | {e['control_max']:.2e} | "
                     f"{e['n_triplets']} |")
    lines.append("")
    for scheme, e in une.items():
        kinds = {"gaps outside the table": 0, "v outside the table": 0,
                 "no result in the cell": 0}
        for _, why in e["skipped"]:
            kinds["v outside the table" if why.startswith("volume") else
                  "no result in the cell" if why.startswith("status") else
                  "gaps outside the table"] += 1
        if e["skipped"]:
            lines.append(f"- {scheme}: {len(e['skipped'])} triplets not answered (" +
                         ", ".join(f"{k}: {n}" for k, n in kinds.items() if n) + ")")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        write_section("### Triplet surrogate", text)
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("step", nargs="?", default="bench", choices=("bench", "evolver", "vcoal"))
    p.add_argument("--table", default=os.environ.get("CAPBRIDGE_TRIPLET_TABLE",
                                                     str(ROOT / "data" / "triplet_table.nc")))
    coal = ROOT / "data" / "triplet_coalescence.nc"
    p.add_argument("--coalescence-table", default=str(coal) if coal.exists() else None,
                   help="default: data/triplet_coalescence.nc if it exists")
    p.add_argument("--n", type=int, default=1_000_000, help="points of the rate runs")
    p.add_argument("--note", default="", help="a paragraph printed under the command")
    p.add_argument("--write", action="store_true",
                   help="append the section to benchmarks/RESULTS.md")
    args = p.parse_args(argv)
    if args.step == "evolver":
        run_evolver()
        return 0
    if args.step == "vcoal":
        run_vcoal()
        return 0
    return bench(args)


if __name__ == "__main__":
    sys.exit(main())
