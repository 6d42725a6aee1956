"""Forces between lookups in a packing: the expansion's error and how often clusters are looked up.

    .venv/bin/python benchmarks/bench_triplet_expansion.py [--water-content 0.03,0.05]
        [--packing mono] [--steps 300] [--warmup 100] [--table data/triplet_table_packings.nc]

Between two lookups of a coalesced triplet the engine takes its pair forces from the
first-order expansion about the last lookup (``LiquidClusters.expansion``,
``REUSE_GAP``).  This runs ``bench_yade_triplet.py``'s "on" variant (the 1,000-grain
packing, theta = 30 deg, coalescence checked every 10 steps) with the step's answer
checked against a fresh lookup at every step, and reports, over all the run's
cluster-steps (warm-up and timed steps): the error of the grain forces (pair forces
along the centre lines, without the gravity parts) relative to the cluster's largest
grain force (median, p99, max), the share of cluster-steps that were looked up, the
steps with a lookup of live clusters, and the cluster-steps whose status or
lower-energy state differs from the fresh lookup's.
The check itself costs a lookup per step: CPU times here mean nothing (the side-by-side
timings are ``bench_yade_triplet.py``'s).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_yade as by  # noqa: E402
import bench_yade_triplet as byt  # noqa: E402

MARK = "EXPANSION_CHECK "


def run_checked(packing, steps, warmup, water_content, table, every):
    """One "on" run with every step's expanded answer compared with a fresh lookup."""
    from capbridge.dem.triplet_clusters import LiquidClusters
    from capbridge.status import HAS_RESULT, Status, status_in

    seen = {"err": [], "looked": 0, "cluster_steps": 0, "steps_with_call": 0,
            "status_differs": 0, "status_pairs": {}, "lower_differs": 0, "steps": 0}
    expanded = LiquidClusters._expanded_lookup

    def checked(self, model, pos):
        before = self.expansion["gaps"].copy()
        out = expanded(self, model, pos)
        after = self.expansion["gaps"]
        fresh = ~((before == after) | (np.isnan(before) & np.isnan(after))).all(axis=1)
        ref = self.lookup(model, pos, self.grains, self.volume, gravity=True)
        ok = status_in(ref["status"], HAS_RESULT) & status_in(out["status"], HAS_RESULT)
        F, Fr = (np.einsum("kp,kpi->kpi", r["f"], r["u"]) for r in (out, ref))
        scale = np.abs(Fr).max(axis=(1, 2))
        if ok.any():
            seen["err"] += (np.abs(F - Fr).max(axis=(1, 2))[ok] / scale[ok]).tolist()
        differ = out["status"] != ref["status"]
        seen["status_differs"] += int(differ.sum())
        for a, b in zip(out["status"][differ], ref["status"][differ]):
            key = f"{Status(int(a)).name.lower()}->{Status(int(b)).name.lower()}"
            seen["status_pairs"][key] = seen["status_pairs"].get(key, 0) + 1
        seen["lower_differs"] += int((out["lower"] != ref["lower"]).sum())
        seen["looked"] += int(fresh.sum())
        seen["cluster_steps"] += int(fresh.size)
        seen["steps_with_call"] += int(fresh.any())
        seen["steps"] += 1
        return out

    LiquidClusters._expanded_lookup = checked
    byt.run_capbridge("on", packing, steps, warmup, water_content, table, every)
    e = np.asarray(seen.pop("err"))
    seen.update({"n": int(e.size), "median": float(np.median(e)),
                 "p99": float(np.percentile(e, 99)), "max": float(e.max())})
    print(MARK + json.dumps(seen), flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--water-content", default="0.03,0.05")
    ap.add_argument("--packing", default="mono", choices=("mono", "poly25"))
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--warmup", type=int, default=100)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("--table", default=str(by.ROOT / "data" / "triplet_table_packings.nc"))
    a = ap.parse_args(argv)
    packing = by.CACHE / f"{a.packing}_packing_1000.npz"
    if not packing.exists():
        raise SystemExit(f"bench_triplet_expansion: error: {packing} not found (run "
                         "benchmarks/bench_yade_triplet.py first)")
    print("| packing, water | cluster-steps | looked up | steps with a lookup of live clusters | force error "
          "median / p99 / max | statuses differing | lower-energy state differing |\n"
          "|---|---|---|---|---|---|---|")
    for wc in (float(x) for x in a.water_content.split(",")):
        out = subprocess.run([sys.executable, __file__, "--check", str(packing), str(a.steps),
                              str(a.warmup), str(wc), a.table, str(a.every)],
                             capture_output=True, text=True, env=by._env(), timeout=3600)
        line = [x for x in out.stdout.splitlines() if x.startswith(MARK)]
        if not line:
            raise SystemExit(f"run at {wc} failed:\n{out.stderr[-3000:]}")
        r = json.loads(line[0][len(MARK):])
        print(f"| {a.packing}, {wc:g} | {r['cluster_steps']} | "
              f"{r['looked'] / max(r['cluster_steps'], 1):.3f} | "
              f"{r['steps_with_call']} of {r['steps']} | {r['median']:.1e} / {r['p99']:.1e} / "
              f"{r['max']:.1e} | {r['status_differs']} {r['status_pairs']} | "
              f"{r['lower_differs']} |")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--check":
        p, steps, warmup, wc, table, every = sys.argv[2:8]
        run_checked(p, int(steps), int(warmup), float(wc), table, int(every))
    else:
        sys.exit(main())
