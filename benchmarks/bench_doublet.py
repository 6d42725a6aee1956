"""Run time against error for doublet forces: surrogate, exact solver, closed forms.

All methods are timed in one run, in this process (one core), on the same random points:
equal spheres, V* log-uniform and theta uniform over the shipped table's range, and the gap
uniform in s = sqrt(1 - d*/d*_rupt) over [0.2, 1] (d* <= 0.96 d*_rupt: the band next to
rupture, where dF*/dd* diverges, is left out and reported separately).
Writes a markdown section to stdout; `make bench` appends nothing by itself: paste it
into benchmarks/RESULTS.md with the date.
"""
from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from capbridge.solvers.young_laplace import rupture_distance, solve_doublet
from capbridge.status import Status
from capbridge.physics.closed_forms import CLOSED_FORMS
from capbridge.surrogate.doublet import DoubletSurrogate

TABLE = Path(__file__).resolve().parent.parent / "data" / "doublet_table.nc"


def rate(fn, n, repeat=3):
    """Evaluations per second: best of ``repeat`` runs of fn() over n points."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return n / best, best


def errors(approx, exact):
    rel = np.abs(approx / exact - 1.0)
    rel = rel[np.isfinite(rel)]
    return np.median(rel), np.max(rel)


def main(n_exact=2000, n_fast=1_000_000, seed=42):
    rng = np.random.default_rng(seed)
    sur = DoubletSurrogate().fit(TABLE)
    v_lo, v_hi, th_hi = sur.volume_[0], sur.volume_[-1], sur.theta_[-1]
    theta = rng.uniform(0, th_hi, n_exact)
    volume = np.exp(rng.uniform(np.log(v_lo), np.log(v_hi), n_exact))
    s = rng.uniform(0.2, 1.0, n_exact)
    d_r = rupture_distance(volume, theta)["gap"]
    gap = d_r * (1 - s**2)

    r_exact, t_exact = rate(lambda: solve_doublet(gap, volume, theta), n_exact, repeat=1)
    exact = solve_doublet(gap, volume, theta)
    ok = exact["status"] == Status.CONVERGED
    r_sur, _ = rate(lambda: sur.predict(gap, volume, theta), n_exact)
    f_sur = sur.predict(gap, volume, theta)["force"]

    rows = [("exact solver (Newton, 48 nodes)", r_exact, 0.0, 0.0),
            ("surrogate predict (any theta)", r_sur, *errors(f_sur[ok], exact["force"][ok]))]
    # the fast path: equal spheres, one theta, many points
    th1 = 30.0
    vf = np.exp(rng.uniform(np.log(v_lo), np.log(v_hi), n_fast))
    sf = rng.uniform(0.2, 1.0, n_fast)
    drf = sur.predict(0.0, vf, th1)["rupture_gap"]
    gf = drf * (1 - sf**2)
    sur.predict_fixed_theta(gf[:10], vf[:10], th1)  # builds the slice once
    r_fast, _ = rate(lambda: sur.predict_fixed_theta(gf, vf, th1), n_fast, repeat=5)
    sub = rng.choice(n_fast, 600, replace=False)
    ex1 = solve_doublet(gf[sub], vf[sub], th1)
    ok1 = ex1["status"] == Status.CONVERGED
    rows.append((f"surrogate fast path (theta={th1:g}, equal spheres)", r_fast,
                 *errors(sur.predict_fixed_theta(gf[sub], vf[sub], th1)[ok1], ex1["force"][ok1])))
    # the closed forms' usual range (the issue's comparison): V* <= 0.3, theta <= 60
    usual = ok & (volume <= 0.3) & (theta <= 60)
    sub_rows = []
    for name, fn in CLOSED_FORMS.items():
        r, _ = rate(lambda fn=fn: fn(gap, volume, theta), n_exact)
        f_cf = np.asarray(fn(gap, volume, theta))
        rows.append((f"closed form: {name}", r, *errors(f_cf[ok], exact["force"][ok])))
        sub_rows.append((name, *errors(f_cf[usual], exact["force"][usual])))
    # the band next to rupture, for the record
    s_band = rng.uniform(0.0, 0.2, 600)
    th_b = rng.uniform(0, th_hi, 600)
    v_b = np.exp(rng.uniform(np.log(v_lo), np.log(v_hi), 600))
    g_b = rupture_distance(v_b, th_b)["gap"] * (1 - s_band**2)
    ex_b = solve_doublet(g_b, v_b, th_b)
    okb = (ex_b["status"] == Status.CONVERGED)
    pb = sur.predict(g_b, v_b, th_b)
    okb &= pb["status"] == Status.CONVERGED
    band = errors(pb["force"][okb], ex_b["force"][okb])

    cpu = platform.processor() or "unknown CPU"
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    print(f"### Doublet: run time against error ({time.strftime('%Y-%m-%d')})\n")
    print(f"Command: `.venv/bin/python benchmarks/bench_doublet.py`; machine: {cpu}, "
          f"{os.cpu_count()} cores, one process (one core), numpy {np.__version__}, "
          f"Python {platform.python_version()}.\n")
    print(f"Points: {n_exact} random (V* {v_lo:g}..{v_hi:g} log-uniform, theta 0..{th_hi:g} deg, "
          f"d* <= 0.96 d*_rupt); exact solver converged on {int(ok.sum())}; fast path "
          f"{n_fast} points at theta = {th1:g} (errors on 600 of them).\n")
    print("| method | evaluations/s (1 core) | speed vs exact | median rel. error | max rel. error |")
    print("|---|---:|---:|---:|---:|")
    for name, r, med, mx in rows:
        err = "reference" if name.startswith("exact") else f"{med:.2e} | {mx:.2e}"
        if name.startswith("exact"):
            print(f"| {name} | {r:,.0f} | 1 | reference | reference |")
        else:
            print(f"| {name} | {r:,.0f} | {r / r_exact:,.0f}x | {err} |")
    print(f"\nClosed forms over their usual range only (V* <= 0.3, theta <= 60 deg, "
          f"{int(usual.sum())} of the points):\n")
    print("| closed form | median rel. error | max rel. error |")
    print("|---|---:|---:|")
    for name, med, mx in sub_rows:
        print(f"| {name} | {med:.2e} | {mx:.2e} |")
    print(f"\nNear rupture (0.96 d*_rupt < d* <= d*_rupt, {int(okb.sum())} points): surrogate "
          f"median {band[0]:.2e}, max {band[1]:.2e}.")


if __name__ == "__main__":
    sys.exit(main())
