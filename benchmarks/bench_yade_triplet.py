"""ms per step of a wet packing with coalesced triplets: triplet forces on / off, YADE Law2.

    .venv/bin/python benchmarks/bench_yade_triplet.py [--n 1000] [--steps 300]
        [--water-content 0.05] [--table data/triplet_table_packings.nc] [--write]

One run, on one packing: N equal spheres (r = 1 mm; equal, so that the triplet table
applies without the unequal-radii approximation) deposited dry under gravity in a box
(cached in ``out/bench_yade/mono_packing_N.npz``), then, each in a fresh YADE process
(one thread):

``off``    :class:`~capbridge.yade.engine.CapbridgeEngine` at the water content
           (conserved liquid on films, theta = 30 deg), coalescence checked every 10
           steps and reported only (``triplet_forces=False``);
``on``     the same with ``triplet_forces=True`` (``--table``): coalesced triplets get
           the triplet table's forces, split at equal pressure;
``law2``   YADE's compiled ``Law2_ScGeom_CapillaryPhys_Capillarity`` on capbridge's
           theta = 30 deg suction files (``benchmarks/bench_yade.py``'s, same suction
           rule: V* = 0.02 at contact), on the same packing: the native reference
           (suction-controlled, so not the same liquid).

CPU ms per step over ``--steps`` steps after ``--warmup`` steps (the first coalescence
checks, the table load and the merges fall in the warm-up; splits may fall in either
and are reported).  Prints a markdown section; ``--write`` appends it to
``benchmarks/RESULTS.md`` as "YADE: coalesced triplets" (replacing that section only).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_yade as by  # noqa: E402  (packing, suction files, machine, environment)
from results_file import write_section  # noqa: E402

ROOT = by.ROOT
THETA = 30.0
SECTION = "### YADE: coalesced triplets"


def make_mono_packing(n, out):
    """Dry deposition of n spheres of radius 1 mm (bench_yade's deposition, no fuzz)."""
    by.make_poly_packing(n, out, fuzz=0.0)


def run_capbridge(variant, packing, steps, warmup, water_content, table, every, theta=THETA):
    """One capbridge variant (``on`` / ``off``) on the packing; prints the result line."""
    yade, w, utils = by._yade_env()
    from capbridge.yade import yade_runtime
    from capbridge.yade.engine import CapbridgeEngine

    O = yade.Omega()
    d = by.load_packing(O, w, utils, packing)
    cap = CapbridgeEngine(theta=theta, gamma=by.GAMMA, water_content=water_content,
                          coalescence_every=every, triplet_forces=(variant == "on"),
                          triplet_table=table, label="bench")
    O.engines = by.scene_engines(w, [cap.pyrunner()])
    O.dt = 0.5 * utils.PWaveTimeStep()
    t0 = time.perf_counter()
    O.run(warmup, True)
    first = time.perf_counter() - t0
    tri0 = cap.triplet_report()
    c_eng0, n_eng0 = cap.timings["cpu_seconds"], cap.timings["steps"]
    t0, c0 = time.perf_counter(), time.process_time()
    O.run(steps, True)
    st = cap.state()
    yade_runtime.emit_result({
        "variant": variant, "n": int(len(d["rad"])), "steps": steps, "warmup": warmup,
        "ms_per_step": (time.process_time() - c0) / steps * 1e3,
        "wall_ms_per_step": (time.perf_counter() - t0) / steps * 1e3,
        "warmup_seconds": first, "bridges": st["n_bridges"],
        "budget_error": st["budget"]["balance_error"], "coalescence": st["coalescence"],
        "triplets_after_warmup": tri0, "triplets": st["triplets"],
        "engine_cpu_ms_per_call": (cap.timings["cpu_seconds"] - c_eng0)
        / max(cap.timings["steps"] - n_eng0, 1) * 1e3})


def _run(args, timeout=3600):
    out = subprocess.run([sys.executable, __file__, *map(str, args)], capture_output=True,
                         text=True, env=by._env(), timeout=timeout)
    for line in out.stdout.splitlines():
        if line.startswith("CAPBRIDGE_RESULT "):
            return json.loads(line[len("CAPBRIDGE_RESULT "):])
    raise RuntimeError(f"{args[:2]} failed:\n{out.stderr[-3000:]}")


def _section(a, res, command):
    on, off, law2 = res["on"], res["off"], res["law2"]
    t = on["triplets"]
    ev = t.get("events", {})
    lines = [f"{SECTION} ({_dt.date.today()})", "",
             f"{_dt.date.today()}, {by.machine()}; command: `{command}`; triplet table "
             f"`{Path(a.table).name}`.", "",
             f"{on['n']} equal spheres (r = 1 mm) deposited dry, then {a.warmup} warm-up "
             f"steps and {a.steps} timed steps, one run each, one thread.  capbridge: "
             f"water content {a.water_content:g}, theta = {THETA:g} deg, coalescence "
             f"checked every {a.every} steps.", "",
             "| variant | CPU ms/step | ratio to law2 | bridges | coalesced pairs (last check) "
             "| triplet clusters |", "|---|---|---|---|---|---|"]
    for name, r in (("capbridge, triplet forces off", off), ("capbridge, triplet forces on", on),
                    ("YADE Law2 (native, suction)", law2)):
        cl = r.get("triplets", {}).get("clusters", "-") if "triplets" in r else "-"
        co = r.get("coalescence", {}).get("triplets", "-") if "coalescence" in r else "-"
        lines.append(f"| {name} | {r['ms_per_step']:.2f} | "
                     f"{r['ms_per_step'] / law2['ms_per_step']:.2f} | {r.get('bridges', '-')} "
                     f"| {co} | {cl} |")
    lines += ["", f"Triplet forces on / off: {on['ms_per_step'] / off['ms_per_step']:.3f}.  "
              f"Events (on, after warm-up + timed steps): {json.dumps(ev)}; funicular "
              f"clusters at the end: {json.dumps(t.get('funicular', {}))}; table loaded: "
              f"{t.get('table_loaded')} ({t.get('timings', {}).get('load_seconds', 0):.2f} s); "
              f"split time {t.get('timings', {}).get('split_seconds', 0):.2f} s; liquid "
              f"budget error on/off: {on['budget_error']:.1e} / {off['budget_error']:.1e}.", ""]
    if a.note:
        lines += [a.note, ""]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--warmup", type=int, default=100)
    ap.add_argument("--every", type=int, default=10, help="coalescence_every")
    ap.add_argument("--water-content", type=float, default=0.05)
    ap.add_argument("--table", default=str(ROOT / "data" / "triplet_table_packings.nc"))
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--note", default="", help="a paragraph added to the section")
    a = ap.parse_args(argv)
    if not Path(a.table).exists():
        raise SystemExit(f"bench_yade_triplet: error: triplet table {a.table} not found "
                         "(give --table)")
    by.CACHE.mkdir(parents=True, exist_ok=True)
    packing = by.CACHE / f"mono_packing_{a.n}.npz"
    if not packing.exists():
        subprocess.run([sys.executable, __file__, "--make-packing", str(a.n), str(packing)],
                       check=True, env=by._env())
    res = {}
    for v in ("off", "on"):
        res[v] = _run(["--run", v, packing, a.steps, a.warmup, a.water_content, a.table,
                       a.every])
    files = by.ensure_files()
    suction, factor, _ = by.choose_suction(r_mean=1e-3, r_min=1e-3, r_max=1e-3)
    res["law2"] = _run(["--run-law2", packing, files, a.steps, a.warmup, suction, factor])
    args = list(argv or sys.argv[1:])
    if "--note" in args:                      # the note is text, not part of the command
        k = args.index("--note")
        del args[k:k + 2]
    command = "python benchmarks/bench_yade_triplet.py " + " ".join(
        x if not x.startswith("/") else Path(x).name for x in args)
    text = _section(a, res, command)
    print(text)
    print(json.dumps(res, default=str), file=sys.stderr)
    if a.write:
        write_section(SECTION, text)
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--make-packing":
        make_mono_packing(int(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) > 1 and sys.argv[1] == "--run":
        v, packing, steps, warmup, wc, table, every = sys.argv[2:9]
        theta = float(sys.argv[9]) if len(sys.argv) > 9 else THETA
        run_capbridge(v, packing, int(steps), int(warmup), float(wc), table, int(every),
                      theta)
    elif len(sys.argv) > 1 and sys.argv[1] == "--run-law2":
        packing, files, steps, warmup, suction, factor = sys.argv[2:8]
        by.run_wet_poly("law2", packing, files, int(steps), int(warmup), float(suction),
                        float(factor))
    else:
        sys.exit(main())
