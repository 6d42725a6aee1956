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
CACHE = HERE / "triplet_unequal_evolver.json"

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
]

#: Evolver settings of the shipped triplet table (capbridge.generator.triplet_table.EvolverPlan)
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
    from capbridge.generator.triplet import find_coalescence, triplet_geometry

    Rh = 3.0 / np.sum(1.0 / np.asarray(radii, float))
    srt, _ = canonical_triplet(*(np.asarray(gaps) / Rh))
    r = find_coalescence(triplet_geometry(*srt), theta)
    if r.status != "coalescence":
        raise RuntimeError(f"no coalescence volume for {gaps}, theta={theta}")
    return float(v * Rh**3 * r.V_coal), float(r.V_coal)


def run_evolver(cases=UNEQUAL_CASES, cache=CACHE):
    """Solve the missing cases with Surface Evolver, one at a time; update the cache."""
    from capbridge.generator.atomic import atomic_target
    from capbridge.generator.evolver import Settings, minimise_bridge
    from capbridge.generator.triplet import pair_forces

    done = json.loads(cache.read_text()) if cache.exists() else {}
    for n, case in enumerate(cases):
        key = case_key(case)
        if key in done:
            continue
        radii, gaps, theta, v = case
        centres = triangle_centres(radii, gaps)
        volume, vcoal_h = _target_volume(radii, gaps, theta, v)
        attempts = []
        for ring in RETRY_RINGS:
            res = minimise_bridge(centres, list(radii), theta, volume, topology="coalesced",
                                  settings=Settings(n_ring=ring, **EVOLVER_SETTINGS))
            attempts.append({"n_ring": ring, "status": res.status.name.lower(),
                             "reason": res.reason, "cpu_time": res.cpu_time})
            if res.converged or not any(k in res.reason for k in
                                        ("degenerate", "fold", "driver error")):
                break
        entry = {"radii": list(radii), "gaps": list(gaps), "theta": theta, "v_target": v,
                 "centres": centres.tolist(), "volume": volume,
                 "harmonic_mean_radius": 3.0 / float(np.sum(1.0 / np.asarray(radii))),
                 "V_coal_harmonic": vcoal_h, "status": res.status.name.lower(),
                 "reason": res.reason, "refinement": int(res.refinement),
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
        done[key] = entry
        with atomic_target(cache) as tmp:
            Path(tmp).write_text(json.dumps(done, indent=1, sort_keys=True) + "\n")
        print(f"case {n + 1}/{len(cases)}: {entry['status']} in {entry['cpu_time']:.1f} CPU s"
              f" (pair forces {entry.get('pair_forces')})", flush=True)
    return done


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("step", nargs="?", default="bench", choices=("bench", "evolver"))
    p.add_argument("--table", default=os.environ.get("CAPBRIDGE_TRIPLET_TABLE",
                                                     str(ROOT / "data" / "triplet_table.nc")))
    p.add_argument("--coalescence-table", default=None)
    p.add_argument("--write", action="store_true",
                   help="append the section to benchmarks/RESULTS.md")
    args = p.parse_args(argv)
    if args.step == "evolver":
        run_evolver()
        return 0
    return bench(args)


if __name__ == "__main__":
    sys.exit(main())
