"""Surface Evolver driver: the paper's protocol against ours, and a stress run.

    .venv/bin/python benchmarks/bench_evolver.py compare [--paper-refine 4 5]
        [--paper-full D1 ...] [--ref-level 5] [--out DIR]
    .venv/bin/python benchmarks/bench_evolver.py stress [--n 200] [--seed 3]
        [--max-refine 2] [--tol 1e-2] [--jobs 2] [--out DIR]
    .venv/bin/python benchmarks/bench_evolver.py report [--out DIR]

``compare`` (one run, ONE Evolver process at a time, points interleaved): on two doublets
and three coalesced trimers (the paper's triplet d12 = d13 = 0.175, d23 = 0.075, unit
radii), the force component the paper computes (doublet: attraction along the axis;
trimer: vertical force on the top grain) by

* ours: :func:`minimise` with its default settings, computing that component only
  (``Settings.vw_components``; central virtual work, Newton steps, Richardson over the
  levels, stop by criteria) -- and, for information, with all force vectors;
* the paper's protocol (:mod:`capbridge.solvers.evolver.protocols`): starting body,
  N refinements with 36 gradient steps between and 1400 after, forward difference with
  delta d* = 0.06 between two independent minimisations.  The paper uses N = 6;
  ``--paper-refine`` chooses the N measured on every point and ``--paper-full`` the
  points on which N = 6 is measured too.  Where N = 6 is not measured, its CPU time is
  extrapolated from the two finest measured N by their growth per refinement (see
  :func:`_paper_n6`; checked against the points where N = 6 is measured) and its error
  is taken as that of the finest measured N.

Errors are against the exact Young-Laplace solver (doublets) or a highly refined
reference (trimers: our method to level ``--ref-level``, Richardson-extrapolated, with
its own error estimate).  The bias of the forward difference alone (perfectly converged energies,
delta d* = 0.06) is reported beside it: exact for the doublets, from our refined energies
for the trimers.

``stress``: random triplets (gaps uniform 0-0.4, V* log-uniform 0.01-0.6, theta uniform
0-80 deg, topology uniform among two bridges / three bridges / one coalesced body, each
point redrawn until it is consistent with rupture and coalescence, see
:func:`draw_points`), run through
:func:`capbridge.tables.sweep.run_sweep` (parallel, resumable, progress bar) with
coarse settings; counts of converged and flagged points and a histogram of the reasons.

``report`` prints the markdown of both from the saved results.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import re
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "evolver_out"
PAPER_DELTA = 0.06
#: refinement level of the trimer references (``compare --ref-level``)
REF_LEVEL = 5
GAPS = (0.175, 0.175, 0.075)

POINTS = {
    "D1": dict(kind="doublet", gap=0.05, volume=0.008, theta=0.0),
    "D2": dict(kind="doublet", gap=0.1, volume=0.156, theta=0.0),
    "T1": dict(kind="trimer", volume=16 / 64, theta=0.0),
    "T2": dict(kind="trimer", volume=20 / 64, theta=0.0),
    "T3": dict(kind="trimer", volume=24 / 64, theta=30.0),
}


def _machine():
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        load = os.getloadavg()
    except OSError:
        load = (np.nan,) * 3
    return dict(cpu=cpu, cores=os.cpu_count(), python=platform.python_version(),
                numpy=np.__version__, load=[round(x, 2) for x in load],
                evolver=_evolver_version())


def _evolver_version():
    import subprocess
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "evolver-nox"],
                             capture_output=True, text=True, timeout=10).stdout
        return f"evolver-nox {out}".strip()
    except Exception:
        return "unknown"


# ---------------------------------------------------------------------------------------
# compare
# ---------------------------------------------------------------------------------------

def problem(pt):
    from capbridge.dimensionless import triplet_centres
    from capbridge.solvers.evolver import doublet_problem, make_problem
    p = POINTS[pt]
    if p["kind"] == "doublet":
        return doublet_problem(p["gap"], p["volume"], p["theta"])
    return make_problem(triplet_centres(*GAPS), 1.0, p["theta"], p["volume"], "coalesced")


def settings(**kw):
    from capbridge.solvers.evolver import Settings
    base = dict(workers=1, level_timeout=4 * 3600.0, total_timeout=12 * 3600.0)
    base.update(kw)
    return Settings(**base)


def run_ours(pt, all_forces=False, **kw):
    from capbridge.solvers.evolver import minimise
    from capbridge.solvers.evolver.protocols import reported_component
    pb = problem(pt)
    g, u = reported_component(pb)      # reported force = F[g] . u (attraction > 0)
    if not all_forces:
        kw["vw_components"] = [(g, u)]
    t0 = time.monotonic()
    r = minimise(pb, settings(**kw))
    F = float(r.forces[g] @ u) if r.forces is not None else np.nan
    est = float(np.abs(r.force_error[g]) @ np.abs(u)) if r.force_error is not None else np.nan
    return dict(status=r.status.name.lower(), reason=r.reason, force=F, error_estimate=est,
                level=r.refinement, n_facets=r.n_facets, cpu=r.cpu_time,
                wall=time.monotonic() - t0, energy=r.energy,
                energy_extrapolated=r.energy_extrapolated, warnings=r.warnings,
                levels=[dict(level=rec.level, n_facets=rec.n_facets, energy=rec.energy,
                             force=(float(rec.forces_vw[g] @ u) if rec.forces_vw is not None
                                    else None),
                             cpu_cumulative=rec.diagnostics.get("cpu_cumulative"))
                        for rec in r.levels])


def run_paper(pt, n_refine):
    from capbridge.solvers.evolver.protocols import forward_difference_force, paper_stretch
    pb = problem(pt)
    grain, d, sign = paper_stretch(pb)
    r = forward_difference_force(pb, grain, d, delta=PAPER_DELTA, n_refine=n_refine,
                                 ngrad_between=36, ngrad_after=1400)
    return dict(ok=r.ok, reason=r.reason, force=sign * r.force if r.ok else np.nan,
                cpu=r.cpu_time, wall=r.wall_time, n_facets=r.base.n_facets,
                cpu_base=r.base.cpu_time, cpu_moved=r.moved.cpu_time,
                energy_base=r.base.energy, energy_moved=r.moved.energy)


def run_reference(pt):
    """Exact solver (doublets) or our method to REF_LEVEL, Richardson (trimers); and the
    forward-difference secant with perfectly converged energies (bias of delta = 0.06)."""
    from capbridge.solvers.young_laplace import solve_doublet
    p = POINTS[pt]
    if p["kind"] == "doublet":
        r0 = solve_doublet(p["gap"], p["volume"], p["theta"])
        r1 = solve_doublet(p["gap"] + PAPER_DELTA, p["volume"], p["theta"])
        return dict(force=float(r0["force"]), error=0.0, kind="exact Young-Laplace",
                    secant=(float(r1["energy"]) - float(r0["energy"])) / PAPER_DELTA
                    / (2 * np.pi))
    from capbridge.solvers.evolver import minimise
    from capbridge.solvers.evolver.protocols import paper_stretch
    ref = _study_reference(pt) or run_ours(pt, max_refine=REF_LEVEL, min_refine=REF_LEVEL,
                                           etol=0.0, ftol=0.0)
    pb = problem(pt)
    grain, d, sign = paper_stretch(pb)
    moved = minimise(pb.moved(grain, PAPER_DELTA * d),
                     settings(max_refine=REF_LEVEL, min_refine=REF_LEVEL, etol=0.0,
                              ftol=0.0, virtual_work=False))
    secant = (sign * -(moved.energy_extrapolated - ref["energy_extrapolated"])
              / PAPER_DELTA / (2 * np.pi))
    return dict(force=ref["force"], error=ref["error_estimate"],
                kind=f"ours, level {ref['level']} ({ref['n_facets']} facets), Richardson",
                secant=secant, secant_status=moved.status.name.lower(), ours=ref,
                cpu=ref["cpu"] + moved.cpu_time)


STUDY_CACHE = HERE.parent / "examples" / "evolver_convergence" / "cache.json"


def _study_reference(pt):
    """The same refined computation from the convergence study, if it is there (the
    paper's triplet, coalesced, V* = 16/64, theta = 0: our method to level 5, the
    vertical component only), Richardson-extrapolated over its levels."""
    from capbridge.solvers.evolver.minimise import _richardson, _richardson_array
    p = POINTS[pt]
    if not (p["kind"] == "trimer" and abs(p["volume"] - 16 / 64) < 1e-12 and p["theta"] == 0):
        return None
    d = _load(STUDY_CACHE).get("triplet_coalesced/ours-levels")
    if not d or len(d.get("levels", [])) < 3 or d["levels"][-1]["level"] < 5:
        return None
    lv = d["levels"]
    Fx, Fe, _ = _richardson_array([np.array([r["force"]]) for r in lv])
    # energies: Richardson over the same levels (for the secant)
    Ex, _, _ = _richardson([r["energy"] for r in lv], 1.0)
    return dict(force=float(Fx[0]), error_estimate=float(Fe[0]), level=lv[-1]["level"],
                n_facets=lv[-1]["n_facets"], energy_extrapolated=Ex, cpu=d.get("cpu"),
                source=str(STUDY_CACHE.relative_to(HERE.parent)))


def _load(path):
    if path.exists():
        with open(path) as fh:
            return json.load(fh)
    return {}


def _save(path, data):
    tmp = path.with_suffix(".tmp")
    with open(tmp, "w") as fh:
        json.dump(data, fh, indent=1, default=float)
    os.replace(tmp, path)


def compare(a):
    global REF_LEVEL
    REF_LEVEL = a.ref_level
    os.environ["CAPBRIDGE_EVOLVER_WORKERS"] = "1"
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "compare.json"
    res = _load(path)
    res.setdefault("_runs", []).append(dict(started=time.strftime("%Y-%m-%d %H:%M:%S"),
                                            machine=_machine(), argv=sys.argv[1:]))
    _save(path, res)

    def do(key, fn, *args, **kw):
        if key in res:
            return res[key]
        print(f"[{time.strftime('%H:%M:%S')}] {key} ...", flush=True)
        t0 = time.monotonic()
        try:
            res[key] = fn(*args, **kw)
        except Exception as exc:
            res[key] = dict(error=f"{type(exc).__name__}: {exc}")
        res[key]["_finished"] = time.strftime("%Y-%m-%d %H:%M:%S")
        res[key]["_load"] = [round(x, 2) for x in os.getloadavg()]
        _save(path, res)
        d = res[key]
        print(f"    {time.monotonic() - t0:.0f} s wall: force {d.get('force')}, "
              f"cpu {d.get('cpu')}, {d.get('status', d.get('reason', ''))}", flush=True)
        return d

    pts = a.points or list(POINTS)
    # timing runs, interleaved per point
    for pt in pts:
        do(f"{pt}/ours", run_ours, pt)
        if POINTS[pt]["kind"] == "trimer":
            do(f"{pt}/ours-allforces", run_ours, pt, all_forces=True)
        for n in a.paper_refine:
            do(f"{pt}/paper-{n}", run_paper, pt, n)
        if pt in (a.paper_full or []):
            do(f"{pt}/paper-6", run_paper, pt, 6)
    # references (not timed against anything)
    for pt in pts:
        do(f"{pt}/reference", run_reference, pt)
    print(compare_markdown(res))


def _paper_n6(paper, Fr):
    """CPU time and error of the paper's protocol with N = 6 refinements: measured if run,
    else modelled from the two finest measured levels a < b: CPU(6) = CPU(b) *
    (CPU(b)/CPU(a))^(6 - b) (the growth per refinement still rises towards 4 at these
    levels, so this underestimates CPU(6): the ratio quoted is conservative); error that
    of level b (the forward-difference bias dominates it, see the FD-bias column)."""
    if 6 in paper:
        return paper[6]["cpu"], paper[6]["force"] / Fr - 1
    lv = sorted(n for n in paper if n < 6)
    if len(lv) < 2:
        return np.nan, np.nan
    a, b = lv[-2], lv[-1]
    growth = (paper[b]["cpu"] / paper[a]["cpu"]) ** (1.0 / (b - a))
    return paper[b]["cpu"] * growth ** (6 - b), paper[b]["force"] / Fr - 1


def compare_markdown(res):
    L = []
    rows = []
    for pt, p in POINTS.items():
        ref = res.get(f"{pt}/reference")
        ours = res.get(f"{pt}/ours")
        if not ref or not ours or "force" not in ref:
            continue
        Fr = ref["force"]
        desc = (f"doublet V*={p['volume']:g}, d*={p['gap']:g}, θ={p['theta']:g}°"
                if p["kind"] == "doublet" else
                f"trimer V*={p['volume'] * 64:g}/64, θ={p['theta']:g}°")
        paper = {n: res.get(f"{pt}/paper-{n}") for n in range(1, 8)}
        paper = {n: d for n, d in paper.items() if d and d.get("ok")}
        allf = res.get(f"{pt}/ours-allforces")
        cpu6, err6 = _paper_n6(paper, Fr)
        rows.append(dict(pt=pt, desc=desc, Fr=Fr, ref=ref, ours=ours, paper=paper, allf=allf,
                         cpu6=cpu6, cpu6_measured=6 in paper, err6=err6))
    if not rows:
        return "(no complete points yet)"
    ns = sorted(set(n for r in rows for n in r["paper"]) | {6})
    L.append("| point | reference F* | ours: F* (error) | ours: level, CPU s | "
             + " | ".join(f"paper N={n}: error, CPU s" for n in ns) +
             " | FD bias (δd*=0.06) | CPU ratio paper(N=6)/ours |")
    L.append("|---" * (6 + len(ns)) + "|")
    for r in rows:
        o = r["ours"]
        cells = []
        for n in ns:
            d = r["paper"].get(n)
            if d:
                cells.append(f"{d['force'] / r['Fr'] - 1:+.2%}, {d['cpu']:.1f}")
            elif n == 6 and np.isfinite(r["cpu6"]):
                cells.append(f"({r['err6']:+.2%}), ({r['cpu6']:.0f} model)")
            else:
                cells.append("–")
        bias = r["ref"]["secant"] / r["Fr"] - 1 if r["ref"].get("secant") is not None else np.nan
        refs = f"{r['Fr']:.5f}" + ("" if r["ref"]["error"] == 0 else
                                   f" ± {r['ref']['error']:.1e}")
        L.append(f"| {r['pt']}: {r['desc']} | {refs} | {o['force']:.5f} "
                 f"({o['force'] / r['Fr'] - 1:+.3%}) | L{o['level']} ({o['n_facets']}), "
                 f"{o['cpu']:.1f} | " + " | ".join(cells) +
                 f" | {'n/a' if not np.isfinite(bias) else f'{bias:+.2%}'} | "
                 f"{r['cpu6'] / o['cpu']:.0f}×"
                 + ("" if r["cpu6_measured"] else " (model)") + " |")
    ratios = [r["cpu6"] / r["ours"]["cpu"] for r in rows]
    L.append("")
    L.append(f"CPU ratio paper (N = 6) / ours: min {min(ratios):.0f}×, median "
             f"{np.median(ratios):.0f}×, max {max(ratios):.0f}× over {len(rows)} points.")
    for r in rows:
        if r["allf"] and "cpu" in r["allf"]:
            L.append(f"- {r['pt']}: ours with all force vectors (3 grains × 2 in-plane "
                     f"directions): {r['allf']['cpu']:.1f} CPU s, top-grain component "
                     f"{r['allf']['force'] / r['Fr'] - 1:+.3%}; ratio paper(N=6)/ours-all "
                     f"{r['cpu6'] / r['allf']['cpu']:.0f}×")
    growth = [r["paper"][5]["cpu"] / r["paper"][4]["cpu"] for r in rows
              if 4 in r["paper"] and 5 in r["paper"]]
    g6 = [r["paper"][6]["cpu"] / r["paper"][5]["cpu"] for r in rows
          if 5 in r["paper"] and 6 in r["paper"]]
    if growth:
        L.append(f"- paper protocol CPU growth per refinement: N 4→5 {min(growth):.2f}–"
                 f"{max(growth):.2f}×" + (f"; N 5→6 (measured) {min(g6):.2f}–{max(g6):.2f}×"
                                          if g6 else ""))
    return "\n".join(L)


# ---------------------------------------------------------------------------------------
# stress run
# ---------------------------------------------------------------------------------------

TOPOLOGIES = ("two bridges", "three bridges", "coalesced")
#: reason categories (first failure kind found in the reason text)
REASONS = ("converged", "converged, estimate above tolerance", "coalesced (caps met)",
           "pinch", "fold", "penetration", "degenerate", "volume", "energy", "contact",
           "pole", "orientation", "timeout", "newton", "virtual work", "evolver",
           "no starting body", "driver error", "other")
_KINDS = ("pinch", "fold", "penetration", "degenerate", "volume", "energy", "contact",
          "pole", "orientation", "timeout", "newton", "evolver")


def classify(status, reason, warnings=()):
    from capbridge.status import Status
    if status in (Status.CONVERGED, Status.ABOVE_TOLERANCE):
        est = status == Status.ABOVE_TOLERANCE or any("above tolerance" in w for w in warnings)
        return REASONS.index("converged, estimate above tolerance" if est else "converged")
    if status == Status.COALESCED:
        return REASONS.index("coalesced (caps met)")
    r = reason or ""
    if "no valid starting body" in r:
        return REASONS.index("no starting body")
    if "driver error" in r:
        return REASONS.index("driver error")
    if "time-out" in r or "timed out" in r or "timeout" in r:
        return REASONS.index("timeout")
    if "did not converge" in r:
        return REASONS.index("newton")
    m = re.search(r"(?:level \d+(?: virtual work)?: )?(\w+): ", r)
    kinds = re.findall(r"\b(" + "|".join(_KINDS) + r")\b", r)
    if "neck radius fell" in r or "pinching" in r:
        return REASONS.index("pinch")
    if "energy change grew" in r:
        return REASONS.index("energy")
    if m and m.group(1) in _KINDS:
        return REASONS.index(m.group(1))
    if kinds:
        return REASONS.index(kinds[0])
    if "virtual" in r:
        return REASONS.index("virtual work")
    return REASONS.index("other")


def _shared_grain(d):
    """Grain whose two gaps are the smallest pair (the shared grain of two bridges)."""
    pairs = {0: (d[0], d[1]), 1: (d[0], d[2]), 2: (d[1], d[2])}
    return min(pairs, key=lambda s: max(pairs[s]))


def _two_bridge_pairs(k):
    others = [g for g in range(3) if g != k]
    return ((k, others[0]), (k, others[1]))


def draw_points(n, seed):
    """Random stress points, about a third of each topology, each physically consistent.

    Topology uniform among two bridges / three bridges / one coalesced body; then gaps
    (d12, d13, d23) uniform in [0, 0.4], theta uniform in [0, 80] deg and V* log-uniform
    in [0.01, 0.6], redrawn until the topology makes sense:

    * separate bridges (V*/2 or V*/3 each): every bridge below 0.9 of its exact rupture
      distance and the total volume below the coalescence volume of that layout (wetted
      caps meeting, a meniscus reaching the third grain: ``find_coalescence`` of
      :mod:`capbridge.solvers.triplet`); two bridges share the grain whose two gaps are
      the smallest;
    * one coalesced body: V* log-uniform in [max(0.01, V_coal), 0.6], V_coal that of the
      two bridges it would otherwise be (gaps redrawn while V_coal >= 0.6).

    Returns (points, rejected draws per topology).
    """
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry
    from capbridge.solvers.young_laplace import rupture_distance
    rng = np.random.default_rng(seed)
    lo, hi = np.log(0.01), np.log(0.6)
    rows = []
    rejected = {name: 0 for name in TOPOLOGIES}
    while len(rows) < n:
        t = int(rng.integers(0, 3))
        while True:
            d = rng.uniform(0.0, 0.4, size=3)
            th = float(rng.uniform(0.0, 80.0))
            V = float(np.exp(rng.uniform(lo, hi)))
            k = _shared_grain(d)
            two = _two_bridge_pairs(k)
            gap_of = {(0, 1): d[0], (0, 2): d[1], (1, 2): d[2]}

            def within_rupture(gaps, vb):
                rd = float(rupture_distance(vb, th)["gap"])
                return all(g < 0.9 * rd for g in gaps)

            def v_coal(bridges):
                r = find_coalescence(triplet_geometry(*d), th, bridges=bridges, n_scan=16)
                return r.V_coal if np.isfinite(r.V_coal) else np.inf

            if t == 0:
                ok = (within_rupture([gap_of[tuple(sorted(p))] for p in two], V / 2)
                      and V < v_coal(two))
            elif t == 1:
                ok = within_rupture(d, V / 3) and V < v_coal(((0, 1), (0, 2), (1, 2)))
            else:
                vc = v_coal(two)
                ok = vc < np.exp(hi)
                if ok:
                    V = float(np.exp(rng.uniform(max(lo, np.log(vc)), hi)))
            if ok:
                break
            rejected[TOPOLOGIES[t]] += 1
        rows.append((d[0], d[1], d[2], V, th, t))
    a = np.array(rows, float)
    return dict(index=np.arange(n), d12=a[:, 0], d13=a[:, 1], d23=a[:, 2], volume=a[:, 3],
                theta=a[:, 4], topology=a[:, 5].astype(int)), rejected


def stress_problem(d12, d13, d23, volume, theta, topology):
    """Problem of a stress point.  Grains: 0 at the origin, 1 on +x, 2 in the plane."""
    from capbridge.dimensionless import triplet_centres
    from capbridge.solvers.evolver import make_problem
    C = triplet_centres(d12, d13, d23)
    if topology == 2:
        return make_problem(C, 1.0, theta, volume, "coalesced")
    if topology == 1:
        return make_problem(C, 1.0, theta, [volume / 3] * 3, "bridges",
                            pairs=[(0, 1), (0, 2), (1, 2)])
    k = _shared_grain((d12, d13, d23))
    return make_problem(C, 1.0, theta, [volume / 2] * 2, "bridges",
                        pairs=list(_two_bridge_pairs(k)))


#: settings of the stress run (set from the command line before the sweep starts)
STRESS = dict(max_refine=2, tol=1e-2, reasons_dir=None)


def solve_stress_chunk(index, d12, d13, d23, volume, theta, topology):
    """run_sweep solver: one or more stress points, serially (one Evolver at a time)."""
    from capbridge.solvers.evolver import minimise
    from capbridge.status import Status, status_name
    n = len(index)
    out = {k: np.full(n, np.nan) for k in ("cpu", "wall", "force_error_rel", "balance",
                                            "n_facets", "refinement", "direct_vs_vw_rel")}
    out["status"] = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    out["reason_code"] = np.zeros(n, np.int16)
    for m in range(n):
        t0 = time.monotonic()
        try:
            pb = stress_problem(float(d12[m]), float(d13[m]), float(d23[m]),
                                float(volume[m]), float(theta[m]), int(topology[m]))
            r = minimise(pb, settings(max_refine=STRESS["max_refine"],
                                      min_refine=min(2, STRESS["max_refine"]),
                                      ftol=STRESS["tol"], etol=STRESS["tol"],
                                      level_timeout=600.0, total_timeout=1800.0))
            status, reason, warns = r.status, r.reason, list(r.warnings)
        except Exception as exc:                   # counted, never crashes the sweep
            r = None
            status, reason, warns = Status.NOT_CONVERGED, f"driver error: {exc!r}", []
        out["status"][m] = int(status)
        out["reason_code"][m] = classify(status, reason, warns)
        out["wall"][m] = time.monotonic() - t0
        if r is not None:
            out["cpu"][m] = r.cpu_time
            out["n_facets"][m] = r.n_facets
            out["refinement"][m] = r.refinement
            if r.converged:
                F = r.forces
                out["balance"][m] = float(np.abs(F.sum(axis=0)).max()
                                          / max(np.abs(F).max(), 1e-12))
                out["force_error_rel"][m] = r.error_estimate.get("force_rel", np.nan)
                out["direct_vs_vw_rel"][m] = r.error_estimate.get("direct_vs_vw_rel", np.nan)
        if STRESS["reasons_dir"]:
            with open(os.path.join(STRESS["reasons_dir"], f"{int(index[m]):04d}.json"),
                      "w") as fh:
                json.dump(dict(index=int(index[m]), status=status_name(status),
                               category=REASONS[out["reason_code"][m]], reason=reason,
                               warnings=warns), fh)
    return out


def stress(a):
    from capbridge.tables.sweep import run_sweep
    os.environ["CAPBRIDGE_EVOLVER_WORKERS"] = "1"
    out = Path(a.out)
    ck = out / f"stress_n{a.n}_seed{a.seed}_L{a.max_refine}_tol{a.tol:g}"
    reasons = ck / "reasons"
    reasons.mkdir(parents=True, exist_ok=True)
    STRESS.update(max_refine=a.max_refine, tol=a.tol, reasons_dir=str(reasons))
    pfile = ck / "points.json"
    if pfile.exists():
        saved = _load(pfile)
        pts = {k: np.asarray(v) for k, v in saved["points"].items()}
        redrawn = saved["redrawn"]
    else:
        print("drawing points (exact rupture distances and coalescence volumes) ...",
              flush=True)
        pts, redrawn = draw_points(a.n, a.seed)
        _save(pfile, dict(points={k: v.tolist() for k, v in pts.items()}, redrawn=redrawn))
    print("topologies:", {TOPOLOGIES[t]: int((pts["topology"] == t).sum()) for t in range(3)},
          f"(rejected draws: {redrawn})", flush=True)
    if a.draw_only:
        return
    t0 = time.monotonic()
    machine = _machine()
    res = run_sweep(solve_stress_chunk, pts, checkpoint_dir=ck / "chunks", chunk_size=1,
                    n_jobs=a.jobs, desc="stress",
                    settings=dict(max_refine=a.max_refine, tol=a.tol, solver="minimise"))
    wall = time.monotonic() - t0
    summary = dict(n=a.n, seed=a.seed, max_refine=a.max_refine, tol=a.tol, jobs=a.jobs,
                   wall=wall, redrawn=redrawn, machine=machine, computed=len(res.computed),
                   reused=len(res.reused), chunk_failures=len(res.failures))
    cols = {k: np.asarray(v).tolist() for k, v in res.items()}
    _save(ck / "summary.json", dict(summary=summary, columns=cols))
    import csv
    with open(ck / "points.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        keys = list(cols)
        w.writerow(keys + ["topology_name", "category"])
        for i in range(a.n):
            w.writerow([cols[k][i] for k in keys] + [TOPOLOGIES[int(cols["topology"][i])],
                                                     REASONS[int(cols["reason_code"][i])]])
    print(stress_markdown(ck))


def stress_markdown(ck):
    from capbridge.status import Status
    d = _load(Path(ck) / "summary.json")
    if not d:
        return "(no stress run yet)"
    s, c = d["summary"], d["columns"]
    st = np.array(c["status"])
    rc = np.array(c["reason_code"])
    topo = np.array(c["topology"])
    L = [f"{s['n']} random triplets (seed {s['seed']}), max_refine {s['max_refine']}, "
         f"tol {s['tol']:g} (etol = ftol), {s['jobs']} worker processes (one Evolver "
         f"each): wall {s['wall'] / 60:.1f} min ({s['computed']} computed, "
         f"{s['reused']} reused from checkpoints), {s['chunk_failures']} sweep chunk "
         f"failures (exceptions); draws rejected as inconsistent with their topology: "
         f"{s.get('redrawn')}.", ""]
    L.append("| topology | points | converged | coalesced (flag) | not converged |")
    L.append("|---|---|---|---|---|")
    for t, name in enumerate(TOPOLOGIES):
        sel = topo == t
        L.append(f"| {name} | {sel.sum()} | {(st[sel] == Status.CONVERGED).sum()} | "
                 f"{(st[sel] == Status.COALESCED).sum()} | "
                 f"{(st[sel] == Status.NOT_CONVERGED).sum()} |")
    L.append(f"| all | {len(st)} | {(st == Status.CONVERGED).sum()} | "
             f"{(st == Status.COALESCED).sum()} | {(st == Status.NOT_CONVERGED).sum()} |")
    L += ["", "| outcome / reason | count | two bridges | three bridges | coalesced |",
          "|---|---|---|---|---|"]
    for k, name in enumerate(REASONS):
        n = int((rc == k).sum())
        if n:
            L.append(f"| {name} | {n} | " + " | ".join(str(int(((rc == k) & (topo == t)).sum()))
                                                       for t in range(3)) + " |")
    cpu = np.array(c["cpu"], float)
    ok = st == Status.CONVERGED
    if ok.any():
        bal = np.array(c["balance"], float)[ok]
        fe = np.array(c["force_error_rel"], float)[ok]
        L.append("")
        L.append(f"Converged points: Evolver CPU per point median {np.nanmedian(cpu[ok]):.1f} s "
                 f"(max {np.nanmax(cpu[ok]):.0f} s); |sum of force vectors| / max force: "
                 f"median {np.nanmedian(bal):.1e}, max {np.nanmax(bal):.1e}; estimated "
                 f"relative force error: median {np.nanmedian(fe):.1e}, 90th percentile "
                 f"{np.nanpercentile(fe, 90):.1e}.")
    return "\n".join(L)


def report(a):
    out = Path(a.out)
    print("## compare\n")
    print(compare_markdown(_load(out / "compare.json")))
    for ck in sorted(out.glob("stress_*")):
        print(f"\n## {ck.name}\n")
        print(stress_markdown(ck))


def _exit_on_sigterm():
    """A ``kill`` then unwinds normally: temporary Evolver directories are removed."""
    import signal
    signal.signal(signal.SIGTERM, lambda *a: sys.exit(143))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("compare")
    c.add_argument("--paper-refine", type=int, nargs="+", default=[4, 5])
    c.add_argument("--paper-full", nargs="*", default=["D1"])
    c.add_argument("--points", nargs="*")
    c.add_argument("--ref-level", type=int, default=5,
                   help="refinement level of the trimer references (Richardson over levels)")
    c.add_argument("--out", default=str(OUT))
    s = sub.add_parser("stress")
    s.add_argument("--n", type=int, default=200)
    s.add_argument("--seed", type=int, default=3)
    s.add_argument("--max-refine", type=int, default=2)
    s.add_argument("--tol", type=float, default=1e-2)
    s.add_argument("--jobs", type=int, default=2)
    s.add_argument("--draw-only", action="store_true")
    s.add_argument("--out", default=str(OUT))
    r = sub.add_parser("report")
    r.add_argument("--out", default=str(OUT))
    a = ap.parse_args(argv)
    _exit_on_sigterm()
    {"compare": compare, "stress": stress, "report": report}[a.cmd](a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
