"""Surface Evolver clusters of four grains: the reference set of the cluster force model.

    .venv/bin/python benchmarks/bench_clusters.py [--max-refine 3] [--write]

Issue 19 validates a cluster force model against >= 12 Evolver clusters of four grains:
the filled tetrahedron, the rhombus (two triangles sharing an edge), a chain of four and
a square, each at two volumes and two contact angles (16 clusters), equal unit grains
with surface gaps 0.05.  Each is one liquid body wetting the four grains
(:func:`capbridge.solvers.cluster.solve_cluster`, virtual work, Richardson over the
levels).  Results are kept in ``benchmarks/evolver_out/clusters.json`` (one entry per
cluster, keyed by its name and settings; a rerun computes only the missing ones) and
summarised as a table: status, |F_i| (max), the sum of the forces (must vanish), the
force error estimate, P*, the pair decomposition (determined or not), CPU seconds.
``--write`` puts the table in ``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from capbridge.solvers.cluster import solve_cluster  # noqa: E402
from capbridge.status import status_name  # noqa: E402
from results_file import write_section  # noqa: E402

CACHE = HERE / "evolver_out" / "clusters.json"
SECTION = "### Surface Evolver clusters of four grains"
GAP = 0.05
D = 2.0 + GAP                                     # centre distance of touching-ish grains


def shapes():
    """Centres (4, 3) of the four configurations (unit radii, gaps GAP)."""
    h = D * np.sqrt(3) / 2
    return {
        "tetrahedron": np.array([[0, 0, 0], [D, 0, 0], [D / 2, h, 0],
                                 [D / 2, h / 3, D * np.sqrt(2 / 3)]]),
        "rhombus": np.array([[0, 0, 0], [D, 0, 0], [D / 2, h, 0], [D / 2, -h, 0]]),
        "chain": np.array([[0, 0, 0], [D, 0, 0], [2 * D, 0, 0], [3 * D, 0, 0]]),
        "square": np.array([[0, 0, 0], [D, 0, 0], [D, D, 0], [0, D, 0]]),
    }


#: liquid volumes V* per configuration: a body that wets all four grains (the chain's
#: is long, the tetrahedron's pore is small)
VOLUMES = {"tetrahedron": (0.4, 0.8), "rhombus": (0.5, 1.0), "chain": (0.8, 1.6),
           "square": (0.6, 1.2)}
THETAS = (0.0, 30.0)

#: grains that the configuration's symmetries map onto each other (equal |F_i|)
SYMMETRIC = {"tetrahedron": [[0, 1, 2, 3]], "rhombus": [[0, 1], [2, 3]],
             "chain": [[0, 3], [1, 2]], "square": [[0, 1, 2, 3]]}


def run_case(name, centres, V, theta, max_refine):
    t0 = time.process_time()
    r = solve_cluster(centres, 1.0, V, theta, max_refine=max_refine)
    F = np.asarray(r["forces"], float) if r["forces"] is not None else None
    pf = r.get("pairs") or {}
    return {"name": name, "V": V, "theta": theta, "max_refine": max_refine,
            "status": status_name(r["status"]), "reason": r.get("reason", ""),
            "forces": None if F is None else F.tolist(),
            "force_error": None if r.get("force_error") is None
            else np.asarray(r["force_error"], float).tolist(),
            "pressure": r.get("pressure"), "refinement": r.get("refinement"),
            "pairs_determined": bool(pf.get("determined", False)) if isinstance(pf, dict)
            else False,
            "cpu_s": float(r.get("cpu_time") or 0.0) + (time.process_time() - t0)}


def row(c):
    if c["forces"] is None:
        return (f"| {c['name']} | {c['V']:g} | {c['theta']:g} | {c['status']} | - | - | - "
                f"| - | - | {c['cpu_s']:.0f} |")
    F = np.asarray(c["forces"])
    err = np.asarray(c["force_error"]) if c["force_error"] is not None else np.full(1, np.nan)
    mag = np.linalg.norm(F, axis=1)
    return (f"| {c['name']} | {c['V']:g} | {c['theta']:g} | {c['status']} | "
            f"{mag.max():.4f} | {mag.min():.4f} | {np.abs(F.sum(0)).max():.1e} | "
            f"{np.nanmax(np.abs(err)):.1e} | {c['pressure']:.3f} | "
            f"{'yes' if c['pairs_determined'] else 'no'} | {c['cpu_s']:.0f} |")


def summary(cases):
    """What the table shows, computed: answered cases, the largest force sum, the
    largest relative spread of |F_i| over symmetric grains, the reasons of the others."""
    done = [c for c in cases if c["forces"] is not None]
    worst_sum = max((np.abs(np.sum(c["forces"], axis=0)).max() for c in done), default=0.0)
    spread = 0.0
    for c in done:
        mag = np.linalg.norm(np.asarray(c["forces"]), axis=1)
        for group in SYMMETRIC[c["name"]]:
            spread = max(spread, np.ptp(mag[group]) / mag[group].max())
    reasons = sorted({f"{c['name']}: {c['reason']}" for c in cases if c["forces"] is None})
    return (f"{len(done)} of {len(cases)} answered.  Every answered cluster's forces sum to "
            f"<= {worst_sum:.1e}; |F_i| of symmetric grains agree to {spread:.1e} "
            "(relative).  Not answered: " + ("; ".join(reasons) if reasons else "none") + ".")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--max-refine", type=int, default=3)
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    cache = json.loads(CACHE.read_text(encoding="utf-8")) if CACHE.exists() else {}
    cases = [(n, c, V, t) for n, c in shapes().items() for V in VOLUMES[n] for t in THETAS]
    for k, (name, centres, V, theta) in enumerate(cases, 1):
        key = f"{name}|V={V:g}|theta={theta:g}|level={a.max_refine}"
        if key not in cache:
            cache[key] = run_case(name, centres, V, theta, a.max_refine)
            CACHE.parent.mkdir(parents=True, exist_ok=True)
            CACHE.write_text(json.dumps(cache, indent=1), encoding="utf-8")
        print(f"[{k}/{len(cases)}] {row(cache[key])}", file=sys.stderr, flush=True)
    rows = [row(cache[f"{n}|V={V:g}|theta={t:g}|level={a.max_refine}"])
            for n, _, V, t in cases]
    text = "\n".join([
        SECTION, "",
        f"Command: `python benchmarks/bench_clusters.py --max-refine {a.max_refine}` "
        f"(`capbridge.solvers.cluster.solve_cluster`, one liquid body on four unit grains, "
        f"surface gaps {GAP:g}; cache `benchmarks/evolver_out/clusters.json`).  |F_i|: "
        "force on a grain, F* = F/(2 pi gamma r); sum: largest component of the sum of the "
        "four forces (zero for an isolated body); error: the largest force error estimate "
        "(Richardson over the levels).", "",
        "| cluster | V* | θ° | status | max \\|F_i\\| | min \\|F_i\\| | \\|sum\\| | error "
        "| P* | pairs determined | CPU s |", "|" + "---|" * 11] + rows
        + ["", summary([cache[f"{n}|V={V:g}|theta={t:g}|level={a.max_refine}"]
                        for n, _, V, t in cases])]) + "\n"
    print(text)
    if a.write:
        write_section(SECTION, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
