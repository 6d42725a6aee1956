"""Doublet validation of the Evolver driver against the exact Young-Laplace solver.

    python -m capbridge.solvers.evolver.validate [--quick] [--max-refine 4] [--json out]

Prints one line per point (V*, d*, theta, ratio): exact F*, Evolver F* (virtual work,
extrapolated and finest level), direct F*, neck F*, relative errors, level, facets and
time; and a summary of the largest error.  Points beyond rupture (exact solver status
not converged) are skipped.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from capbridge.status import Status

from .minimise import Settings, doublet_force


def grid(quick=False):
    if quick:
        return [(0.05, 0.1, t, 1.0) for t in (0.0, 30.0, 60.0)]
    pts = []
    for v in (0.008, 0.05, 0.2):
        for d in (0.02, 0.1, 0.3):
            for t in (0.0, 30.0, 60.0):
                pts.append((v, d, t, 1.0))
    for v, d, t in ((0.05, 0.1, 0.0), (0.05, 0.1, 30.0), (0.2, 0.05, 60.0)):
        pts.append((v, d, t, 2.0))
    return pts


def run(points, settings):
    from capbridge.solvers.young_laplace import solve_doublet
    rows = []
    for v, d, t, ratio in points:
        ex = solve_doublet(d, v, t, ratio=ratio)
        if int(ex["status"]) != int(Status.CONVERGED):
            print(f"V*={v:<6} d*={d:<5} theta={t:<4} ratio={ratio}: exact solver status "
                  f"{int(ex['status'])}, skipped", flush=True)
            continue
        t0 = time.monotonic()
        F, r = doublet_force(d, v, t, ratio=ratio, settings=settings)
        fx = float(ex["force"])
        row = dict(volume=v, gap=d, theta=t, ratio=ratio, exact=fx,
                   status=r.status.name.lower(), reason=r.reason,
                   vw=r.axial_force(which="forces_vw") if r.forces_vw is not None else np.nan,
                   vw_extrapolated=F,
                   direct=r.axial_force(which="forces_direct") if r.forces_direct is not None
                   else np.nan,
                   neck=float(r.neck_force[0]) if r.neck_force is not None else np.nan,
                   error_estimate=r.error_estimate.get("force", np.nan),
                   level=r.refinement, n_facets=r.n_facets, cpu=r.cpu_time,
                   wall=time.monotonic() - t0, warnings=r.warnings)
        for k in ("vw", "vw_extrapolated", "direct", "neck"):
            row[f"err_{k}"] = row[k] / fx - 1.0
        rows.append(row)
        print(f"V*={v:<6} d*={d:<5} theta={t:<4} ratio={ratio}: exact {fx:.5f}  "
              f"evolver {F:.5f} ({row['err_vw_extrapolated']:+.3%}; finest "
              f"{row['err_vw']:+.3%}; direct {row['err_direct']:+.2%}; neck "
              f"{row['err_neck']:+.2%})  est.err {row['error_estimate'] / fx:.2%}  "
              f"L{r.refinement} {r.n_facets} facets  cpu {r.cpu_time:.1f}s  "
              f"wall {row['wall']:.1f}s  {row['status']}", flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--max-refine", type=int, default=4)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    rows = run(grid(a.quick), Settings(max_refine=a.max_refine))
    ok = [r for r in rows if r["status"] in ("converged", "above_tolerance")]
    if ok:
        worst = max(ok, key=lambda r: abs(r["err_vw_extrapolated"]))
        print(f"\n{len(ok)}/{len(rows)} converged; largest |dF*|/F* = "
              f"{abs(worst['err_vw_extrapolated']):.3%} at V*={worst['volume']}, "
              f"d*={worst['gap']}, theta={worst['theta']}, ratio={worst['ratio']}; "
              f"median {np.median([abs(r['err_vw_extrapolated']) for r in ok]):.3%}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
