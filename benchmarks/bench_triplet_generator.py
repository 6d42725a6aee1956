"""Coalesced-triplet generator: Evolver CPU seconds per table point against force error.

For a few coalesced triplets, each Evolver setting is run once and its effective pair
forces compared with a reference one refinement level finer than the finest setting
(virtual work, Richardson-extrapolated over levels 1-4).  Settings compared:

* ``vw L2`` / ``vw L3``: virtual work, Richardson-extrapolated up to level 2 / 3 (the
  table's choice is ``vw L3``, see :class:`capbridge.tables.triplet.EvolverPlan`);
* ``direct L3`` / ``direct L4``: forces from the converged shape alone (no displaced
  runs), finest level.

Writes a JSON file and prints a markdown table for ``benchmarks/RESULTS.md``.

Usage: ``.venv/bin/python benchmarks/bench_triplet_generator.py [--out FILE]``
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from capbridge.solvers.evolver import minimise_bridge
from capbridge.solvers.triplet import find_coalescence, pair_forces, triplet_geometry
from capbridge.solvers.triplet_evolver import _settings

POINTS = [((0.175, 0.175, 0.075), 0.0, 1.2),      # the paper's triplet, just coalesced
          ((0.05, 0.1, 0.2), 30.0, 1.2),          # no symmetry
          ((0.0, 0.1, 0.1), 60.0, 1.5)]           # grains 2, 3 in contact
SETTINGS = {"vw L2": dict(max_refine=2), "vw L3": dict(max_refine=3),
            "direct L3": dict(max_refine=3, virtual_work=False),
            "direct L4": dict(max_refine=4, virtual_work=False)}
REFERENCE = dict(max_refine=4)


def run(gaps, theta, volume, kw):
    geom = triplet_geometry(*gaps)
    s = _settings(kw["max_refine"], 0.0, False, workers=1, etol=1.0,
                  **{k: v for k, v in kw.items() if k != "max_refine"})
    t0 = time.time()
    res = minimise_bridge(geom.centres, 1.0, theta, volume, topology="coalesced", settings=s)
    f, _ = pair_forces(geom.centres, res.forces)
    return {"status": res.status.name.lower(), "cpu_time": res.cpu_time,
            "wall_time": time.time() - t0, "pair_forces": [f[p] for p in sorted(f)]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/evolver_out/triplet_generator.json")
    args = ap.parse_args(argv)
    rows = []
    for gaps, theta, v in POINTS:
        V = v * find_coalescence(triplet_geometry(*gaps), theta).V_coal
        ref = run(gaps, theta, V, REFERENCE)
        fr = np.array(ref["pair_forces"])
        for name, kw in SETTINGS.items():
            r = run(gaps, theta, V, kw)
            err = np.abs(np.array(r["pair_forces"]) - fr).max() / np.abs(fr).max()
            rows.append({"gaps": gaps, "theta": theta, "v": v, "setting": name,
                         "cpu_time": r["cpu_time"], "max_rel_error_pair_force": float(err),
                         "status": r["status"], "reference_cpu_time": ref["cpu_time"]})
            print(f"{gaps} theta={theta} v={v} {name}: {r['cpu_time']:.1f} CPU s, "
                  f"error {err:.2e} ({r['status']})", flush=True)
    out = {"machine": f"{platform.processor() or platform.machine()}, "
                      f"{platform.python_version()}",
           "date": time.strftime("%Y-%m-%d"), "reference": "virtual work, Richardson over "
           "levels 1-4", "rows": rows}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1))
    print("\n| setting | CPU s per point (mean) | max rel. error in f_ij vs level 4 "
          "(per point) |\n|---|---:|---|")
    for name in SETTINGS:
        rs = [r for r in rows if r["setting"] == name]
        print(f"| {name} | {np.mean([r['cpu_time'] for r in rs]):.1f} | "
              + ", ".join(f"{r['max_rel_error_pair_force']:.2%}" for r in rs) + " |")
    print(f"| reference (vw L4) | {np.mean([r['reference_cpu_time'] for r in rows]):.1f} | - |")


if __name__ == "__main__":
    main()
