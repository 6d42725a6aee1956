"""Coalesced triplets in real packings: how clusters live, across radii, angles and water.

    .venv/bin/python benchmarks/bench_triplet_packings.py [--n 1000] [--steps 300]
        [--warmup 100] [--every 10] [--radii equal,poly25] [--theta 0,30,60]
        [--water 0.03,0.05,0.10] [--label NAME] [--write]

Each packing (1,000 spheres r = 1 mm, equal or uniform in r (1 +- 0.25), settled dry under
gravity in a box, cached in ``out/bench_yade/``) is wetted at each water content and
contact angle by :class:`~capbridge.yade.engine.CapbridgeEngine` (conserved liquid on
films, coalescence checked every ``--every`` steps) and run ``--warmup`` + ``--steps``
steps, once with triplet forces on and once off (each in a fresh YADE process, one
thread; ``benchmarks/bench_yade_triplet.py --run``); YADE's Law2 on each packing once
(``bench_yade_triplet.py --run-law2``, theta = 30 deg files) as the native reference.

Per run (triplet forces on; events over warm-up + timed steps, per 100 steps):
merges and splits, clusters alive per step, lives of the ended clusters (median steps),
coalesced triplets met at the checks answered by the table / refused (doublet forces
kept) / of mixed angles, clusters of four grains or more met per check, the largest
change of a grain's force at merge and at split (units 2 pi gamma r, median / p90),
the liquid ledger error, CPU ms per step on / off / Law2.  Each run's JSON is kept in
``out/bench_triplet_packings/<label>/`` (a rerun with the same label reuses it);
``--write`` puts the markdown table in ``benchmarks/RESULTS.md`` as the section
"YADE: coalesced triplets across packings (<label>)".
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_yade as by  # noqa: E402
import bench_yade_triplet as bt  # noqa: E402
from results_file import write_section  # noqa: E402

FUZZ = {"equal": 0.0, "poly25": 0.25}
OUT = by.ROOT / "out" / "bench_triplet_packings"


def packing_path(radii, n):
    """The cached settled packing (made on first use, ~1.5 min for 1,000 grains)."""
    by.CACHE.mkdir(parents=True, exist_ok=True)
    path = by.CACHE / (f"mono_packing_{n}.npz" if radii == "equal"
                       else f"{radii}_packing_{n}.npz")
    if not path.exists():
        code = ("import sys; sys.path.insert(0, %r); import bench_yade as by; "
                "by.make_poly_packing(%d, %r, fuzz=%r)" % (str(HERE), n, str(path),
                                                           FUZZ[radii]))
        subprocess.run([sys.executable, "-c", code], check=True, env=by._env())
    return path


def one(args, cache):
    """A run's result, from ``cache`` when it exists (resume), else run and keep it."""
    if cache.exists():
        return json.loads(cache.read_text(encoding="utf-8"))
    res = bt._run(args)
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(res, default=str), encoding="utf-8")
    return res


def row(radii, theta, water, on, off, law2, total_steps):
    t = on["triplets"]
    ev, life = t.get("events", {}), t.get("life", {})
    per100 = 100.0 / total_steps
    seen = max(life.get("triplets_seen", 0), 1)
    checks = max(on["coalescence"].get("checks", 1), 1)

    def q(d, key):
        return f"{d[key]:.2f}" if d.get("n") else "-"

    splits = ev.get("split_geometry", 0) + ev.get("split_energy", 0)
    return (f"| {radii} | {theta:g} | {100 * water:g} | {ev.get('merged', 0) * per100:.1f} | "
            f"{splits * per100:.1f} | {life.get('cluster_steps', 0) / total_steps:.1f} | "
            f"{q(life.get('ended_lives', {}), 'median')} | "
            f"{100 * life.get('triplets_live', 0) / seen:.0f} / "
            f"{100 * life.get('triplets_refused', 0) / seen:.0f} / "
            f"{100 * life.get('triplets_mixed', 0) / seen:.0f} | "
            f"{life.get('larger_seen', 0) / checks:.0f} | "
            f"{q(life.get('merge_jump', {}), 'median')} / {q(life.get('merge_jump', {}), 'p90')} | "
            f"{q(life.get('split_jump', {}), 'median')} / {q(life.get('split_jump', {}), 'p90')} | "
            f"{on['budget_error']:.0e} | {on['ms_per_step']:.2f} / {off['ms_per_step']:.2f} / "
            f"{law2['ms_per_step']:.2f} | {on['ms_per_step'] / off['ms_per_step']:.2f} |")


HEADER = ["| radii | θ° | water % | merges /100 | splits /100 | alive /step | life (median "
          "steps) | triplets: table / refused / mixed % | ≥4-grain clusters /check | jump at "
          "merge (med / p90) | jump at split (med / p90) | ledger | CPU ms on / off / Law2 | "
          "on/off |", "|" + "---|" * 14]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--warmup", type=int, default=100)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("--radii", default="equal,poly25")
    ap.add_argument("--theta", default="0,30,60")
    ap.add_argument("--water", default="0.03,0.05,0.10")
    ap.add_argument("--table", default=str(by.ROOT / "data" / "triplet_table_packings.nc"))
    ap.add_argument("--label", default="current", help="cache folder and section name")
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    radii = a.radii.split(",")
    bad = [r for r in radii if r not in FUZZ]
    if bad:
        raise SystemExit(f"bench_triplet_packings: error: --radii {bad}: allowed {list(FUZZ)}")
    thetas = [float(x) for x in a.theta.split(",")]
    waters = [float(x) for x in a.water.split(",")]
    runs = [(r, th, w) for r in radii for th in thetas for w in waters]
    total = a.steps + a.warmup
    lines = [f"### YADE: coalesced triplets across packings ({a.label})", "",
             f"{by.machine()}; command: `python benchmarks/bench_triplet_packings.py "
             f"{' '.join(argv or sys.argv[1:])}`; {a.n} spheres settled dry, {a.warmup} + "
             f"{a.steps} steps, coalescence checked every {a.every} steps, one run each.", ""]
    lines += HEADER
    files = by.ensure_files()
    suction, factor, _ = by.choose_suction(r_mean=1e-3, r_min=1e-3, r_max=1e-3)
    law2 = {}
    for k, (r, th, w) in enumerate(runs, 1):
        pk = packing_path(r, a.n)
        tag = f"{r}_t{th:g}_w{w:g}"
        res = {}
        for v in ("on", "off"):
            res[v] = one(["--run", v, pk, a.steps, a.warmup, w, a.table, a.every, th],
                         OUT / a.label / f"{tag}_{v}.json")
        if r not in law2:
            law2[r] = one(["--run-law2", pk, files, a.steps, a.warmup, suction, factor],
                          OUT / a.label / f"{r}_law2.json")
        lines.append(row(r, th, w, res["on"], res["off"], law2[r], total))
        print(f"[{k}/{len(runs)}] {lines[-1]}", file=sys.stderr, flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if a.write:
        write_section(lines[0], text)            # this label's section only
    return 0


if __name__ == "__main__":
    sys.exit(main())
