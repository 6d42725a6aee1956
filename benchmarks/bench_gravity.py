"""Gravity on the liquid: lookup cost with and without gravity, and the triplet table's
gravity response against its held-out direct Evolver points.

``python benchmarks/bench_gravity.py [--write]``

* Lookup rate (one core, threads pinned to 1) of ``DoubletSurrogate.predict`` against
  ``predict_vectors`` at Bo = 0 and Bo = 2.14 (gravity oblique), and of
  ``TripletSurrogate.predict_vectors`` at Bo = 0 and 2.14, interleaved in one run
  (best of ``--repeat`` rounds each) so that the ratios are side by side.
* The triplet gravity response against the direct Evolver minimisations with gravity
  stored in ``data/triplet_table.nc`` (``gravity_holdout_*``, one level finer than the
  response): error of the force vectors with gravity (table + response) and of the
  gravity effect alone, per orientation and Bond number
  (:func:`capbridge.surrogate.triplet.gravity_holdout_errors`).

Prints a markdown section; ``--write`` appends it to ``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = ROOT / "data"


def _best_rate(fn, n, repeat):
    best = np.inf
    for _ in range(repeat):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return n / best


def doublet_points(sur, n, rng):
    theta = rng.uniform(0, 80, n)
    volume = np.exp(rng.uniform(np.log(2e-3), np.log(0.4), n))
    d_r = sur.predict(np.zeros(n), volume, theta)["rupture_gap"]
    gap = d_r * rng.uniform(0.0, 0.9, n)
    return gap, volume, theta


def triplet_points(sur, n, rng):
    from capbridge.solvers.triplet import triplet_geometry

    g = np.sort(rng.uniform(0.0, 0.2, (n, 3)), axis=1)
    theta = rng.uniform(30, 80, n)
    centres = np.stack([triplet_geometry(*x).centres for x in g])
    vc = sur.coalescence_volume(g[:, 0], g[:, 1], g[:, 2], theta)
    volume = vc["volume_coalescence"] * rng.uniform(1.0, 1.9, n)
    return centres, volume, theta


def lookup_rates(n, repeat, seed=0):
    from capbridge.surrogate.doublet import DoubletSurrogate
    from capbridge.surrogate.triplet import TripletSurrogate

    rng = np.random.default_rng(seed)
    ds = DoubletSurrogate().fit(DATA / "doublet_table.nc")
    ts = TripletSurrogate().fit(DATA / "triplet_table.nc",
                                coalescence_table=DATA / "triplet_coalescence.nc")
    gap, vol, th = doublet_points(ds, n, rng)
    cen, tv, tt = triplet_points(ts, n // 4, rng)
    oblique = np.array([1.0, 0.0, -1.0]) / np.sqrt(2)
    cases = {
        "doublet predict (force only)": (lambda: ds.predict(gap, vol, th), n),
        "doublet predict_vectors, Bo = 0": (lambda: ds.predict_vectors(gap, vol, th), n),
        "doublet predict_vectors, Bo = 2.14 oblique":
            (lambda: ds.predict_vectors(gap, vol, th, bond=2.14, gravity=oblique), n),
        "triplet predict_vectors, Bo = 0": (lambda: ts.predict_vectors(cen, tv, tt), n // 4),
        "triplet predict_vectors, Bo = 2.14 oblique":
            (lambda: ts.predict_vectors(cen, tv, tt, bond=2.14, gravity=oblique), n // 4),
    }
    from capbridge.validation import CapbridgeInputError

    rates = {k: 0.0 for k in cases}
    for _ in range(repeat):                       # interleaved rounds, best of each
        for k, (fn, m) in cases.items():
            try:
                rates[k] = max(rates[k], _best_rate(fn, m, 1))
            except CapbridgeInputError:           # e.g. a doublet table without gravity
                rates[k] = np.nan
    return rates


def doublet_holdout_lines():
    """The doublet table's stored held-out check with gravity along the axis
    (``gravity_holdout_*`` attributes written by ``capbridge generate doublet``)."""
    import xarray as xr

    from capbridge.status import Status

    with xr.open_dataset(DATA / "doublet_table.nc") as ds:
        a = dict(ds.attrs)
        st = ds["gravity_status"].values if "gravity_status" in ds else None
    if "gravity_holdout_bonds" not in a:
        return ["Doublet gravity response: not in `data/doublet_table.nc`.", ""]
    col = {k: np.atleast_1d(a[f"gravity_holdout_{k}"]) for k in
           ("bonds", "max_error", "median_error", "max_effect_error",
            "max_effect_error_converged", "n", "n_approximate", "n_exact_failed")}
    L = ["Doublet gravity response (`data/doublet_table.nc`, gravity along the axis: share "
         "w and curvature c on a sub-grid, Richardson-extrapolated differences at Bo = "
         f"{a['gravity_bond_step'] / 2:g} and {a['gravity_bond_step']:g}; "
         f"{int((st == Status.ABOVE_TOLERANCE).sum())} of {st.size} nodes above their own tolerance "
         f"{a['gravity_response_rtol']:g}) against the exact axisymmetric solver with "
         f"gravity at held-out points ({a['gravity_holdout_description']}). Errors "
         "relative to the attraction at Bo = 0.", "",
         "| Bo | median error | max error | max effect error | max effect error, "
         "`converged` lookups | lookups (approximate) | left out: no exact bridge or no number |",
         "|---:|---:|---:|---:|---:|---:|---:|"]
    for k, b in enumerate(col["bonds"]):
        L.append(f"| {b:g} | {col['median_error'][k]:.2e} | {col['max_error'][k]:.2e} | "
                 f"{col['max_effect_error'][k]:.2e} | "
                 f"{col['max_effect_error_converged'][k]:.2e} | {col['n'][k]} "
                 f"({col['n_approximate'][k]}) | {col['n_exact_failed'][k]} |")
    L += ["", "Largest effect error over a lookup's own estimate (`gravity_error`): "
          f"{a['gravity_holdout_estimate_ratio_max']:.3g}.", ""]
    return L


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000, help="doublet lookups per round "
                    "(triplets: a quarter)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--write", action="store_true", help="append to benchmarks/RESULTS.md")
    args = ap.parse_args(argv)

    from capbridge.surrogate.triplet import TripletSurrogate, gravity_holdout_errors

    rates = lookup_rates(args.n, args.repeat)
    ts = TripletSurrogate().fit(DATA / "triplet_table.nc",
                                coalescence_table=DATA / "triplet_coalescence.nc")
    h = gravity_holdout_errors(ts)
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    L = ["## Gravity: lookup cost and the triplet response against held-out Evolver points",
         "", f"Command: `.venv/bin/python benchmarks/bench_gravity.py --n {args.n} --repeat "
         f"{args.repeat} --write` (commit {commit}, "
         f"{platform.machine()}, {os.cpu_count()} cores, one thread, shared machine; rates are "
         f"the best of {args.repeat} interleaved rounds of CPU time).", "",
         "| lookup | per CPU second | ratio to the same surrogate at Bo = 0 |", "|---|---:|---:|"]
    base = {"doublet": rates["doublet predict_vectors, Bo = 0"],
            "triplet": rates["triplet predict_vectors, Bo = 0"]}
    for k, r in rates.items():
        L.append(f"| {k} | {r:,.0f} | {base[k.split()[0]] / r:.2f} |" if np.isfinite(r) else
                 f"| {k} | not available (the table has no gravity response) | - |")
    L += ["", "Triplet gravity response (`data/triplet_table.nc`: first order and diagonal "
          "second order in b = Bo g_hat; settings "
          f"{ts.table_.attrs.get('gravity_settings', '?')}) against direct minimisations "
          "with gravity one level finer. `error`: the force vectors with gravity (table + "
          "response, what a user gets) relative to the largest grain force; `effect`: the "
          "gravity effect F(b) - F(0) alone, same scale. Threshold for the validated range: "
          f"the table's own held-out error without gravity, {h['threshold']:.2%}.", "",
          "| orientation | Bo | error | effect |", "|---|---:|---:|---:|"]
    for k in np.argsort([f"{o}{b:06.2f}" for o, b in zip(h["orientation"], h["bond"])],
                        kind="stable"):
        if h["bond"][k] == 0:
            continue
        e = h["error"][k]
        f = h["effect_error"][k]
        L.append(f"| {h['orientation'][k]} (case {h['case'][k]}) | {h['bond'][k]:.2f} | "
                 + (f"{e:.2%} | {f:.2%} |" if np.isfinite(e) else "no result | - |"))
    L += ["", "Largest error per Bo over the cases: "
          + ", ".join(f"Bo {b:g}: {e:.2%} (effect {f:.2%})" for b, e, f in
                      zip(h["bonds"], h["max_error_by_bond"], h["max_effect_error_by_bond"]))
          + f". Validated up to Bo = {h['bond_max_validated']:g} "
          f"(cases answered with gravity: {min(h['n_cases_by_bond'][1:])}-"
          f"{max(h['n_cases_by_bond'][1:])} of {h['n_cases']}, by Bo); above it lookups with "
          "gravity carry status `approximate`.", ""]
    L += doublet_holdout_lines()
    text = "\n".join(L)
    print(text)
    if args.write:
        with open(HERE / "RESULTS.md", "a", encoding="utf-8") as f:
            f.write("\n" + text)


if __name__ == "__main__":
    main()
