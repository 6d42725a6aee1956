"""The study from end to end: the stages in order (:mod:`~capbridge.studies.miot2021.
compute`), then the tables, figures, ``summary.json`` and ``CLAIMS.md`` they reduce to."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from capbridge.dimensionless import bond_number
from capbridge.studies.miot2021.analyse import (add_exact_doublet_forces, build_summary,
                                                coalescence_from_bridges, energy_table,
                                                force_jumps, force_table)
from capbridge.studies.miot2021.claims import write_claims
from capbridge.studies.miot2021.compute import (bridge_points, coalesced_gravity_points,
                                                coalesced_points, doublet_exact,
                                                doublet_points, energy_low_points,
                                                exact_stage, sweep)
from capbridge.studies.miot2021.experiment import GAMMAS, RADIUS
from capbridge.studies.miot2021.figures import make_figures
from capbridge.studies.miot2021.plan import Plan
from capbridge.studies.miot2021.points import BRIDGES


def run(output_dir="examples/miot2021", quick=False, checkpoint_dir=None, progress=True,
        max_refine=None, log=None):
    """Run the reproduction; returns the summary dict (also written to summary.json)."""
    import matplotlib
    matplotlib.use("Agg")
    import pandas as pd

    t_start = time.monotonic()
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    if log is None:
        def log(msg):
            print(f"[miot2021 {time.monotonic() - t_start:7.1f} s] {msg}", file=sys.stderr,
                  flush=True)
    plan = Plan.make(quick, max_refine)
    ck = None if checkpoint_dir is None else Path(checkpoint_dir)
    shapes = None if ck is None else ck / "shapes"
    bonds = {g: float(bond_number(RADIUS, g)) for g in GAMMAS}
    timings = {}

    # ---- exact ------------------------------------------------------------------------
    t0 = time.monotonic()
    dfv, fit, fit_low, curves, vc, alpha = exact_stage(plan, log)
    dfd = doublet_exact()
    timings["exact"] = time.monotonic() - t0

    # ---- doublets (Fig. 3) -----------------------------------------------------------
    t0 = time.monotonic()
    dfdv = add_exact_doublet_forces(sweep("doublets", doublet_points(plan), ck, shapes,
                                          progress))
    timings["doublets"] = time.monotonic() - t0
    log(f"doublets: {len(dfdv)} Evolver points")

    # ---- coalesced, no gravity (+ energy probes below V_coal) ---------------------------
    t0 = time.monotonic()
    dfc0 = sweep("coalesced-nogravity", coalesced_points(plan, vc), ck, shapes, progress)
    pts = energy_low_points(plan, vc)
    if pts:
        dfc0 = pd.concat([dfc0, sweep("energy-low", pts, ck, shapes, progress)],
                         ignore_index=True)
    timings["coalesced_nogravity"] = time.monotonic() - t0

    # ---- separate bridges by Evolver: mesh bias (no gravity) and gravity ------------------
    t0 = time.monotonic()
    dfb = sweep("bridges", bridge_points(plan, vc, bonds), ck, shapes, progress)
    timings["bridges"] = time.monotonic() - t0
    dfg, vc_grav = coalescence_from_bridges(plan, dfb, vc, alpha, bonds)

    # ---- coalesced with gravity -------------------------------------------------------
    t0 = time.monotonic()
    dfcg = sweep("coalesced-gravity", coalesced_gravity_points(plan, vc, vc_grav, bonds), ck,
                 shapes, progress)
    timings["coalesced_gravity"] = time.monotonic() - t0

    summary = analyse_and_write(out, plan, dict(dfv=dfv, fit=fit, fit_low=fit_low,
                                                curves=curves, vc=vc, alpha=alpha, dfd=dfd,
                                                dfdv=dfdv, dfc0=dfc0, dfb=dfb, dfg=dfg,
                                                dfcg=dfcg, bonds=bonds, vc_grav=vc_grav,
                                                shapes=shapes))
    timings["total"] = time.monotonic() - t_start
    summary["timings_s"] = {k: round(v, 1) for k, v in timings.items()}
    summary["command"] = ("capbridge reproduce miot2021" + (" --quick" if quick else "")
                          + f" --output-dir {output_dir}"
                          + (f" --checkpoint-dir {checkpoint_dir}" if checkpoint_dir else ""))
    (out / "summary.json").write_text(json.dumps(_jsonable(summary), indent=1))
    write_claims(out, summary)
    log(f"done in {timings['total']:.0f} s; outputs in {out}")
    return summary


def analyse_and_write(out, plan, R):
    """Reduce the results ``R`` (:mod:`~capbridge.studies.miot2021.analyse`) and write
    the CSV tables and the figures into ``out``; returns the summary."""
    ft = force_table(R)
    ft.to_csv(out / "triplet_forces.csv", index=False, float_format="%.6g")
    R["dfv"].to_csv(out / "coalescence_volumes.csv", index=False, float_format="%.6g")
    R["dfg"].to_csv(out / "coalescence_gravity.csv", index=False, float_format="%.6g")
    jumps = force_jumps(R)
    jumps.to_csv(out / "coalescence_force_jumps.csv", index=False, float_format="%.6g")
    en, cross = energy_table(R)
    en.to_csv(out / "energies.csv", index=False, float_format="%.6g")
    dd = R["dfd"]
    dv = R["dfdv"]
    dd.to_csv(out / "doublet_fig3.csv", index=False, float_format="%.6g")
    if len(dv):
        dv[["volume", "gap", "F_axial", "F_direct", "F_exact", "rel_err_pct",
            "rel_err_direct_pct", "force_err_rel", "refinement", "n_facets", "cpu", "wall",
            "status_name"]].rename(columns={"volume": "V_star", "gap": "d_star"}).to_csv(
            out / "doublet_fig3_evolver.csv", index=False, float_format="%.6g")
    b = R["dfb"]
    b[b["kind"] == BRIDGES].to_csv(out / "evolver_bridges.csv", index=False,
                                   float_format="%.6g")
    figs = make_figures(out, plan, R, ft, en)
    summary = build_summary(plan, R, ft, jumps, cross)
    summary["figures"] = figs
    summary["files"] = sorted(p.name for p in out.iterdir() if p.suffix in (".csv", ".png"))
    return summary


def _jsonable(x):
    """``x`` with numpy numbers as Python ones and NaN/inf as ``None`` (JSON)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not np.isfinite(x) else float(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    return x
