"""Convergence study of the Surface Evolver driver, after Miot et al. 2021, Appendix A.

    .venv/bin/python examples/evolver_convergence/run_convergence.py [--only CASE ...]
        [--levels CASE_INDEX OURS PAPER ITER] [--plot-only] [--cache FILE]

Cases: a doublet (V* = 0.05, d* = 0.1, theta = 0 and 30 deg; reference: the exact
Young-Laplace solver) and the paper's triplet (d12 = d13 = 0.175, d23 = 0.075, unit radii,
theta = 0): one coalesced body at V* = 16/64 and two bridges (grain 1 with grains 2 and 3)
at V* = 10/64 in all (5/64 each).  Reference for the two bridges: exact (they do not
interact, so the vertical force on the top grain is 2 F*_doublet cos(alpha)); for the
coalesced body: our method at the finest level, Richardson-extrapolated (its own error
estimate is recorded).

Force measured: doublet, the attraction F* along the centre line; triplet, the vertical
force on the top grain (grain 1) towards the midpoint of the bottom pair (attraction > 0).

Computations (all with ONE Evolver process at a time, so that CPU times are comparable;
levels per case in ``LEVELS``).  Our method computes the reported component only
(``Settings.vw_components``: two displaced runs per level, as the paper's forward
difference needs two minimisations); ``ours-default-allforces`` is the cost of all force
vectors (triplets).

* ``ours``: :func:`minimise` with the tolerances set to 0 so that every level 0..Lmax is
  computed; per level the force (central virtual work, Newton-converged), the cumulative
  Evolver CPU time and the Richardson extrapolation over the levels so far.
* ``ours-default``: :func:`minimise` with its default settings (stops by criteria).
* ``paper-L``: the paper's protocol (:mod:`.protocols`) with L refinements, 36 gradient
  steps between, 1400 after, forward difference delta d* = 0.06.
* ``iter-gradient`` / ``iter-newton`` at one refinement level: the same schedule, then
  the energy of the two configurations (x and x + delta u, delta = 0.06) printed along
  the final phase (gradient steps up to 3000, or Newton steps up to 8).

Results are cached in ``cache.json`` (re-running skips what is there); CSV and PNG
files are written next to this script.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import sys
import time

import numpy as np

from capbridge.dimensionless import triplet_centres
from capbridge.solvers.evolver import Settings, doublet_problem, make_problem, minimise
from capbridge.solvers.evolver.minimise import _richardson_array
from capbridge.solvers.evolver.protocols import (forward_difference_force, paper_stretch,
                                                  reported_component)
from capbridge.solvers.young_laplace import solve_doublet

HERE = os.path.dirname(os.path.abspath(__file__))
CACHE = os.path.join(HERE, "cache.json")
PAPER_DELTA = 0.06
N_ITER_GRAD = 3000
N_ITER_NEWTON = 8

CASES = {
    "doublet_theta0": dict(kind="doublet", gap=0.1, volume=0.05, theta=0.0),
    "triplet_coalesced": dict(kind="triplet", topology="coalesced", volume=16 / 64,
                              theta=0.0),
    "triplet_bridges": dict(kind="triplet", topology="bridges", volume=10 / 64, theta=0.0),
    "doublet_theta30": dict(kind="doublet", gap=0.1, volume=0.05, theta=30.0),
}
TRIPLET_GAPS = (0.175, 0.175, 0.075)
#: per case: finest level of our method, most refinements of the paper protocol, level
#: of the iteration study
LEVELS = {"doublet_theta0": (5, 4, 4), "doublet_theta30": (4, 3, 3),
          "triplet_coalesced": (5, 4, 3), "triplet_bridges": (4, 3, 3)}


# ---------------------------------------------------------------------------------------
# problems, measured component, references
# ---------------------------------------------------------------------------------------

def problem(case):
    c = CASES[case]
    if c["kind"] == "doublet":
        return doublet_problem(c["gap"], c["volume"], c["theta"])
    C = triplet_centres(*TRIPLET_GAPS)
    if c["topology"] == "coalesced":
        return make_problem(C, 1.0, c["theta"], c["volume"], "coalesced")
    return make_problem(C, 1.0, c["theta"], [c["volume"] / 2] * 2, "bridges",
                        pairs=[(0, 1), (0, 2)])


def exact(case):
    """Reference force (and the exact forward-difference secant where available)."""
    c = CASES[case]
    if c["kind"] == "doublet":
        r0 = solve_doublet(c["gap"], c["volume"], c["theta"])
        r1 = solve_doublet(c["gap"] + PAPER_DELTA, c["volume"], c["theta"])
        secant = (float(r1["energy"]) - float(r0["energy"])) / PAPER_DELTA / (2 * np.pi)
        return dict(force=float(r0["force"]), secant=secant, kind="exact Young-Laplace")
    if c["topology"] == "bridges":
        C = triplet_centres(*TRIPLET_GAPS)
        pb = problem(case)
        _, m = reported_component(pb)
        u1 = (C[1] - C[0]) / np.linalg.norm(C[1] - C[0])
        u2 = (C[2] - C[0]) / np.linalg.norm(C[2] - C[0])
        r0 = solve_doublet(TRIPLET_GAPS[0], c["volume"] / 2, c["theta"])
        # the paper's displacement moves the top grain up: both gaps grow
        pb1 = pb.moved(0, -PAPER_DELTA * m)
        gap1 = np.linalg.norm(pb1.centres[1] - pb1.centres[0]) - 2.0
        r1 = solve_doublet(gap1, c["volume"] / 2, c["theta"])
        secant = 2 * (float(r1["energy"]) - float(r0["energy"])) / PAPER_DELTA / (2 * np.pi)
        return dict(force=float(r0["force"]) * float(u1 @ m + u2 @ m), secant=secant,
                    kind="exact Young-Laplace (two independent bridges)")
    return None


# ---------------------------------------------------------------------------------------
# tasks (cached)
# ---------------------------------------------------------------------------------------

def load_cache():
    if os.path.exists(CACHE):
        with open(CACHE) as fh:
            return json.load(fh)
    return {}


def save_cache(cache):
    tmp = CACHE + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(cache, fh, indent=1, default=float)
    os.replace(tmp, CACHE)


def study_settings(**kw):
    base = dict(workers=1, level_timeout=4 * 3600.0, total_timeout=12 * 3600.0)
    base.update(kw)
    return Settings(**base)


def task_ours_levels(case, lmax):
    pb = problem(case)
    g, u = reported_component(pb)      # the reported force is F[g] . u (attraction > 0)
    t0 = time.monotonic()
    r = minimise(pb, study_settings(max_refine=lmax, etol=0.0, ftol=0.0,
                                    vw_components=[(g, u)]))
    rows = []
    for rec in r.levels:
        if rec.forces_vw is None:
            continue
        rows.append(dict(level=rec.level, n_facets=rec.n_facets, energy=rec.energy,
                         force=float(rec.forces_vw[g] @ u),
                         force_direct=float(rec.forces_direct[g] @ u),
                         cpu_cumulative=rec.diagnostics.get("cpu_cumulative", np.nan),
                         level_cpu=rec.cpu_time, vw_cpu=rec.diagnostics.get("vw_cpu", np.nan),
                         newton_steps=rec.newton_steps, attempt=rec.attempt))
    return dict(status=r.status.name.lower(), reason=r.reason, warnings=r.warnings,
                levels=rows, wall=time.monotonic() - t0, cpu=r.cpu_time)


def task_ours_default(case, all_forces=False, **kw):
    pb = problem(case)
    g, u = reported_component(pb)      # the reported force is F[g] . u (attraction > 0)
    t0 = time.monotonic()
    if not all_forces:
        kw["vw_components"] = [(g, u)]
    r = minimise(pb, study_settings(**kw))
    F = float(r.forces[g] @ u) if r.forces is not None else np.nan
    Ffin = float(r.forces_vw[g] @ u) if r.forces_vw is not None else np.nan
    return dict(status=r.status.name.lower(), reason=r.reason, warnings=r.warnings,
                force=F, force_finest=Ffin, level=r.refinement, n_facets=r.n_facets,
                cpu=r.cpu_time, wall=time.monotonic() - t0,
                error_estimate=float(r.force_error[g] @ np.abs(u)) if r.force_error is not None
                else np.nan)


def task_paper(case, n_refine, final="gradient", n_after=1400, checkpoints=None):
    pb = problem(case)
    grain, d, sign = paper_stretch(pb)
    kw = dict(n_refine=n_refine, ngrad_between=36, final=final)
    if final == "gradient":
        kw["ngrad_after"] = n_after
    else:
        kw["n_newton"] = n_after
    if checkpoints is not None:
        kw["checkpoints"] = checkpoints
    r = forward_difference_force(pb, grain, d, delta=PAPER_DELTA, **kw)
    k, Fk = r.force_at()
    cpu_k = (r.base.checkpoints[:len(k), 2] + r.moved.checkpoints[:len(k), 2]
             if len(k) else np.zeros(0))
    return dict(ok=r.ok, reason=r.reason, force=sign * r.force if r.ok else np.nan,
                cpu=r.cpu_time, wall=r.wall_time, n_facets=r.base.n_facets,
                iterations=k.tolist(), force_at=(sign * Fk).tolist(), cpu_at=cpu_k.tolist(),
                energy_base_at=(r.base.checkpoints[:len(k), 1].tolist() if len(k) else []),
                energy_base=r.base.energy, energy_moved=r.moved.energy)


def run_tasks(cases):
    cache = load_cache()
    cache.setdefault("_meta", {})
    cache["_meta"].update(machine=f"{platform.processor() or platform.machine()}, "
                                  f"{os.cpu_count()} cores", python=sys.version.split()[0])

    def do(key, fn, *args, **kw):
        if key in cache:
            return cache[key]
        print(f"[{time.strftime('%H:%M:%S')}] {key} ...", flush=True)
        t0 = time.monotonic()
        try:
            cache[key] = fn(*args, **kw)
        except Exception as exc:                       # keep the study going
            cache[key] = dict(error=f"{type(exc).__name__}: {exc}")
        cache[key]["_wall"] = time.monotonic() - t0
        save_cache(cache)
        print(f"    done in {cache[key]['_wall']:.0f} s: "
              f"{ {k: v for k, v in cache[key].items() if k in ('status', 'ok', 'force', 'cpu', 'reason')} }",
              flush=True)
        return cache[key]

    for case in cases:
        lmax, lpaper, lit = LEVELS[case]
        do(f"{case}/ours-default", task_ours_default, case)
        if CASES[case]["kind"] == "triplet":
            do(f"{case}/ours-default-allforces", task_ours_default, case, all_forces=True)
        do(f"{case}/ours-levels", task_ours_levels, case, lmax)
        for L in range(2, lpaper + 1):
            if L == lit:
                continue                      # taken from the gradient iteration run
            do(f"{case}/paper-{L}", task_paper, case, L)
        cps = sorted(set([1, 2, 5, 10, 20, 36, 50, 100, 200, 400, 700, 1000, 1400, 2000,
                          N_ITER_GRAD]))
        do(f"{case}/iter-gradient-{lit}", task_paper, case, lit, "gradient", N_ITER_GRAD, cps)
        do(f"{case}/iter-newton-{lit}", task_paper, case, lit, "newton", N_ITER_NEWTON)
    return cache


# ---------------------------------------------------------------------------------------
# tables and figures
# ---------------------------------------------------------------------------------------

def reference(cache, case):
    ex = exact(case)
    if ex is not None:
        return ex["force"], 0.0, ex["kind"], ex.get("secant")
    lv = cache.get(f"{case}/ours-levels", {}).get("levels", [])
    if len(lv) < 3:
        return np.nan, np.nan, "none", None
    Fx, Fe, p = _richardson_array([np.array([r["force"]]) for r in lv])
    return (float(Fx[0]), float(Fe[0]),
            f"our method, level {lv[-1]['level']} ({lv[-1]['n_facets']} facets), "
            f"Richardson over levels (order {p})", None)


def tables(cache, cases):
    ref_rows, lev_rows, it_rows, te_rows = [], [], [], []
    for case in cases:
        lit = LEVELS[case][2]
        Fref, Ferr, rkind, secant = reference(cache, case)
        ref_rows.append(dict(case=case, reference=Fref, reference_error=Ferr,
                             reference_kind=rkind, exact_secant_delta006=secant))
        rel = (lambda F: F / Fref - 1.0)
        # ours per level (+ Richardson with the levels so far)
        lv = cache.get(f"{case}/ours-levels", {}).get("levels", [])
        for n in range(len(lv)):
            Fx, Fe, p = _richardson_array([np.array([r["force"]]) for r in lv[:n + 1]])
            r = lv[n]
            lev_rows.append(dict(case=case, method="ours (Newton, central VW)", level=r["level"],
                                 n_facets=r["n_facets"], force=r["force"],
                                 rel_error=rel(r["force"]), force_extrapolated=float(Fx[0]),
                                 rel_error_extrapolated=rel(float(Fx[0])),
                                 cpu_cumulative=r["cpu_cumulative"]))
            te_rows.append(dict(case=case, method="ours, finest level", setting=f"L{r['level']}",
                                cpu_per_force=r["cpu_cumulative"],
                                rel_error=abs(rel(r["force"]))))
            if n >= 1:
                te_rows.append(dict(case=case, method="ours, Richardson",
                                    setting=f"L{r['level']}",
                                    cpu_per_force=r["cpu_cumulative"],
                                    rel_error=abs(rel(float(Fx[0])))))
        d = cache.get(f"{case}/ours-default")
        if d and "force" in d:
            te_rows.append(dict(case=case, method="ours, default settings",
                                setting=f"L{d['level']}", cpu_per_force=d["cpu"],
                                rel_error=abs(rel(d["force"]))))
        # paper protocol per number of refinements
        for L in range(1, 8):
            d = cache.get(f"{case}/paper-{L}")
            cpu = None
            if d is None and L == lit:
                it = cache.get(f"{case}/iter-gradient-{L}")
                if it and 1400 in it.get("iterations", []):
                    j = it["iterations"].index(1400)
                    F, cpu, nf = it["force_at"][j], it["cpu_at"][j], it["n_facets"]
                else:
                    continue
            elif d is None or not d.get("ok"):
                continue
            else:
                F, cpu, nf = d["force"], d["cpu"], d["n_facets"]
            lev_rows.append(dict(case=case, method="paper (gradient, FD 0.06)", level=L,
                                 n_facets=nf, force=F, rel_error=rel(F),
                                 force_extrapolated=np.nan, rel_error_extrapolated=np.nan,
                                 cpu_cumulative=cpu))
            te_rows.append(dict(case=case, method="paper protocol", setting=f"{L} refinements",
                                cpu_per_force=cpu, rel_error=abs(rel(F))))
        for fin in ("gradient", "newton"):
            d = cache.get(f"{case}/iter-{fin}-{lit}")
            if not d or "iterations" not in d:
                continue
            for k, F, c, e in zip(d["iterations"], d["force_at"], d["cpu_at"],
                                  d.get("energy_base_at", [np.nan] * len(d["iterations"]))):
                it_rows.append(dict(case=case, minimiser=fin, level=lit, n_facets=d["n_facets"],
                                    iterations=int(k), force=F, rel_error=rel(F),
                                    cpu=c, energy_base=e))
    return ref_rows, lev_rows, it_rows, te_rows


def level_changes(lev_rows, cases):
    """Relative change of the force from each level to the finest (the paper's Appendix A
    statistic: 5 -> 7 remeshings 0.35 % at most, 6 -> 7 0.07 %)."""
    out = []
    for case in cases:
        for meth in ("ours (Newton, central VW)", "paper (gradient, FD 0.06)"):
            rr = sorted((r for r in lev_rows if r["case"] == case and r["method"] == meth),
                        key=lambda r: r["level"])
            if len(rr) < 2:
                continue
            fin = rr[-1]
            for r in rr[:-1]:
                out.append(dict(case=case, method=meth, level=r["level"],
                                finest_level=fin["level"],
                                rel_change=abs(r["force"] / fin["force"] - 1.0)))
    return out


def write_csv(name, rows):
    if not rows:
        return
    keys = list(rows[0].keys())
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    with open(os.path.join(HERE, name), "w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v) for k, v in r.items()})


def plots(ref_rows, lev_rows, it_rows, te_rows, cases):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    titles = {"doublet_theta0": "doublet V*=0.05, d*=0.1, θ=0",
              "doublet_theta30": "doublet V*=0.05, d*=0.1, θ=30°",
              "triplet_coalesced": "paper triplet, coalesced, V*=16/64, θ=0",
              "triplet_bridges": "paper triplet, two bridges, V*=10/64, θ=0"}
    refs = {r["case"]: r for r in ref_rows}
    # 1. force against refinement level
    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.8), squeeze=False)
    for ax, case in zip(axes[0], cases):
        rr = [r for r in lev_rows if r["case"] == case]
        for meth, st in (("ours (Newton, central VW)", "o-"), ("paper (gradient, FD 0.06)", "s--")):
            pts = [r for r in rr if r["method"] == meth]
            if pts:
                ax.plot([r["level"] for r in pts], [r["force"] for r in pts], st, label=meth)
        ex = [r for r in rr if r["method"].startswith("ours") and
              np.isfinite(r["force_extrapolated"])][1:]
        if ex:
            ax.plot([r["level"] for r in ex], [r["force_extrapolated"] for r in ex], "^:",
                    label="ours, Richardson")
        ref = refs[case]
        if np.isfinite(ref["reference"]):
            ax.axhline(ref["reference"], color="k", lw=0.8, label="reference")
        if ref.get("exact_secant_delta006") is not None:
            ax.axhline(ref["exact_secant_delta006"], color="gray", ls=":", lw=0.8,
                       label="exact secant, δd*=0.06")
        _finish_axes(ax, "refinement level", "F*", titles[case])
    _save(fig, "force_vs_refinement.png")
    # 2. force and energy against iterations, relative to the last Newton value
    fig, axes = plt.subplots(2, len(cases), figsize=(4.2 * len(cases), 7.2), squeeze=False)
    for col, case in enumerate(cases):
        rr = [r for r in it_rows if r["case"] == case]
        newton = [r for r in rr if r["minimiser"] == "newton"]
        if not newton:
            continue
        Fc, Ec = newton[-1]["force"], newton[-1]["energy_base"]
        for fin, st in (("gradient", "s-"), ("newton", "o-")):
            pts = [r for r in rr if r["minimiser"] == fin and r["iterations"] > 0]
            if not pts:
                continue
            lab = (f"{fin} steps (level {pts[0]['level']}, {pts[0]['n_facets']} facets)"
                   + (", after 36 gradient steps" if fin == "newton" else ""))
            axes[0, col].loglog([r["iterations"] for r in pts],
                                [max(abs(r["force"] / Fc - 1), 1e-8) for r in pts], st,
                                label=lab)
            axes[1, col].loglog([r["iterations"] for r in pts],
                                [max(abs(r["energy_base"] - Ec), 1e-14) for r in pts], st,
                                label=lab)
        for ax in axes[:, col]:
            ax.axvline(1400, color="gray", ls=":", lw=0.8)
            ax.set_xlabel("iterations after the last refinement")
            ax.legend(fontsize=7)
        axes[0, col].set_ylabel("|F*/F*_Newton − 1| (same FD, δd*=0.06)")
        axes[1, col].set_ylabel("|E* − E*_Newton| (unmoved configuration)")
        axes[0, col].set_title(titles[case], fontsize=9)
    _save(fig, "force_vs_iterations.png")
    # 3. CPU time against error
    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.8), squeeze=False)
    marks = {"ours, finest level": "o-", "ours, Richardson": "^-", "paper protocol": "s--",
             "ours, default settings": "*"}
    for ax, case in zip(axes[0], cases):
        rr = [r for r in te_rows if r["case"] == case]
        ref = refs[case]
        if ref["reference_error"] > 0:
            # a computed reference: its own error estimate bounds what can be resolved,
            # and the point that is the reference (error 0) is not drawn
            ax.axhline(ref["reference_error"] / abs(ref["reference"]), color="k", ls=":",
                       lw=0.8, label="reference's error estimate")
        for meth, st in marks.items():
            pts = [r for r in rr if r["method"] == meth and r["rel_error"] > 0]
            if pts:
                ax.loglog([r["cpu_per_force"] for r in pts],
                          [max(r["rel_error"], 1e-6) for r in pts], st, label=meth,
                          ms=10 if len(st) == 1 else 5)
        _finish_axes(ax, "Evolver CPU s per force (one process)", "|F*/F*_ref − 1|",
                     titles[case])
    _save(fig, "time_vs_error.png")


def _finish_axes(ax, xlabel, ylabel, title):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)


def _save(fig, name):
    import matplotlib.pyplot as plt
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, name), dpi=130)
    plt.close(fig)


def _exit_on_sigterm():
    """A ``kill`` then unwinds normally: temporary Evolver directories are removed."""
    import signal
    signal.signal(signal.SIGTERM, lambda *a: sys.exit(143))


def main(argv=None):
    global CACHE
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=list(CASES))
    ap.add_argument("--levels", nargs=4, type=int, metavar=("CASE_INDEX", "OURS", "PAPER",
                                                           "ITER"), action="append",
                    help="override LEVELS for the case with this index (0-3)")
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--cache", default=CACHE)
    a = ap.parse_args(argv)
    _exit_on_sigterm()
    CACHE = a.cache
    for i, lo, lp, li in a.levels or []:
        LEVELS[list(CASES)[i]] = (lo, lp, li)
    os.environ["CAPBRIDGE_EVOLVER_WORKERS"] = "1"        # one Evolver process at a time
    cases = [c for c in CASES if c in a.only]
    cache = load_cache() if a.plot_only else run_tasks(cases)
    done = [c for c in cases if f"{c}/ours-levels" in cache]
    rows = tables(cache, done)
    for name, r in zip(("reference.csv", "refinement.csv", "iterations.csv",
                        "time_vs_error.csv"), rows):
        write_csv(name, r)
    write_csv("level_changes.csv", level_changes(rows[1], done))
    plots(*rows, done)
    return 0


if __name__ == "__main__":
    sys.exit(main())
