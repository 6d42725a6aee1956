"""Vertical doublet with gravity: exact solver against Surface Evolver, and F*(Bo).

    nice -n 5 .venv/bin/python benchmarks/gravity_axis_check.py [--max-refine 3] [--no-evolver]

Writes ``benchmarks/gravity_axis_check.json`` (refuses to replace it without
``--overwrite``):

* ``evolver``: for a few (d*, V*, theta, ratio) and Bo in {0 (reference), 0.05, 0.5,
  2.14}, gravity along the axis (grain 1 below, plus grain 1 above for the unequal pair
  at Bo = 2.14), the axial forces on both grains, the pressure at the centre of grain 1
  and the energy from :func:`capbridge.solvers.young_laplace_gravity.solve_doublet_gravity`
  beside :func:`capbridge.solvers.evolver.minimise_bridge` (topology "doublet",
  ``max_refine``), their differences, Evolver's own error estimate and CPU time, and the
  difference of the *gravity effect* F(Bo) - F(0) (Evolver's discretisation error
  cancels in it to first order).  One Evolver process at a time (shared machine).
* ``bond_response``: exact F1, F2 and their mean on Bo = 0, 0.25, ..., 2.5 at the same
  points, least-squares fits F = F0 + a Bo + b Bo^2 (and the fit's largest residual),
  and |b Bo^2| / |a Bo| at Bo = 0.13 (1 mm grains, water) and 2.14 (4 mm, the paper):
  whether a first-order response in Bo is enough.
* ``rupture_response``: d*_rupt(Bo) / d*_rupt(0) - 1 at the volumes and angles of the
  points, Bo in {0.13, 0.5, 2.14}.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys
import time

import numpy as np

from capbridge.solvers.young_laplace_gravity import (rupture_distance_gravity,
                                                       solve_doublet_gravity)

OUT = pathlib.Path(__file__).with_name("gravity_axis_check.json")
#: (d*, V*, theta [deg], ratio): a mid-size bridge at 30 deg, a convex-ish one at 60 deg,
#: an unequal pair (gravity changes its mean force at first order), a theta = 0 bridge
POINTS = [(0.1, 0.05, 30.0, 1.0), (0.2, 0.1, 60.0, 1.0), (0.05, 0.05, 30.0, 2.0),
          (0.05, 0.02, 0.0, 1.0)]
#: extra points for the Bo response only: large bridges near rupture (0.75-0.8 d*_rupt)
FIT_ONLY = [(0.45, 0.1, 30.0, 1.0), (0.5, 0.3, 0.0, 1.0), (0.3, 0.1, 30.0, 2.0)]
BONDS = [0.05, 0.5, 2.14]
FIT_BONDS = np.linspace(0.0, 2.5, 11)


def exact(d, V, th, ratio, bond, gravity_axis=-1.0):
    r = solve_doublet_gravity(d, V, th, bond, ratio, gravity_axis=gravity_axis)
    return {k: float(r[k]) for k in ("force1", "force2", "force", "pressure_centre1",
                                     "energy", "beta1", "beta2", "status")}


def evolver(d, V, th, ratio, bond, gravity_axis, max_refine):
    from capbridge.solvers.evolver import minimise_bridge

    centres = [[0.0, 0.0, 0.0], [1.0 + ratio + d, 0.0, 0.0]]
    t = time.monotonic()
    res = minimise_bridge(centres, [1.0, ratio], [th, th], V, "doublet", bond=bond,
                          gravity_dir=(gravity_axis, 0.0, 0.0), max_refine=max_refine,
                          workers=1)
    out = {"status": res.status.name.lower(), "reason": res.reason,
           "refinement": res.refinement, "cpu_s": round(res.cpu_time, 2),
           "wall_s": round(time.monotonic() - t, 1)}
    if res.converged:
        out.update(force1=float(res.forces[0, 0]), force2=float(-res.forces[1, 0]),
                   force_error_estimate=float(res.force_error[:, 0].max()),
                   pressure_centre1=float(res.pressure[0]),
                   energy=float(res.energy_extrapolated),
                   energy_error_estimate=float(res.error_estimate.get("energy", np.nan)))
    return out


def compare_evolver(max_refine):
    rows = []
    cases = [(p, bo, -1.0) for p in POINTS for bo in [0.0] + BONDS]
    cases.append((POINTS[2], 2.14, 1.0))    # unequal grains, the small one above
    ref = {}
    for (d, V, th, ratio), bo, ga in cases:
        ex = exact(d, V, th, ratio, bo, ga)
        ev = evolver(d, V, th, ratio, bo, ga, max_refine)
        row = dict(gap=d, volume=V, theta=th, ratio=ratio, bond=bo, gravity_axis=ga,
                   exact=ex, evolver=ev)
        if "force1" in ev:
            row["diff"] = {k: ev[k] - ex[k] for k in ("force1", "force2",
                                                      "pressure_centre1", "energy")}
            row["rel_diff"] = {k: row["diff"][k] / abs(ex[k]) for k in ("force1", "force2")}
            if bo == 0.0:
                ref[(d, V, th, ratio)] = row
            elif (d, V, th, ratio) in ref:
                r0 = ref[(d, V, th, ratio)]
                row["effect_diff"] = {
                    k: (ev[k] - r0["evolver"][k]) - (ex[k] - r0["exact"][k])
                    for k in ("force1", "force2")}
                row["effect_exact"] = {k: ex[k] - r0["exact"][k] for k in ("force1", "force2")}
        rows.append(row)
        print(json.dumps({k: row.get(k) for k in ("gap", "volume", "theta", "ratio", "bond",
                                                   "gravity_axis", "rel_diff", "effect_diff")}
                         | {"evolver_status": ev["status"], "cpu_s": ev["cpu_s"]}), flush=True)
    summary = {}
    for bo in BONDS:
        rel = [max(abs(r["rel_diff"]["force1"]), abs(r["rel_diff"]["force2"]))
               for r in rows if r["bond"] == bo and "rel_diff" in r]
        eff = [max(abs(r["effect_diff"]["force1"]), abs(r["effect_diff"]["force2"]))
               for r in rows if r["bond"] == bo and "effect_diff" in r]
        summary[str(bo)] = {"max_rel_force_diff": max(rel) if rel else None,
                            "max_abs_effect_diff": max(eff) if eff else None,
                            "n": len(rel)}
    return rows, summary


def bond_response():
    out = []
    from capbridge.solvers.young_laplace import rupture_distance

    for d, V, th, ratio in POINTS + FIT_ONLY:
        r = solve_doublet_gravity(d, V, th, FIT_BONDS, ratio)
        ok = bool(np.all(r["status"] == 0))
        row = dict(gap=d, volume=V, theta=th, ratio=ratio, bonds=FIT_BONDS.tolist(),
                   gap_over_rupture_gap_bo0=d / float(rupture_distance(V, th, ratio)["gap"]),
                   status=r["status"].tolist(), all_converged=ok)
        if not ok:
            out.append(row)
            print(json.dumps({k: row[k] for k in ("gap", "volume", "theta", "ratio", "status")}))
            continue
        for key in ("force1", "force2", "force"):
            F = r[key]
            A = np.vander(FIT_BONDS, 3, increasing=True)
            coef, *_ = np.linalg.lstsq(A, F, rcond=None)
            F0, a, b = coef
            fit = {"F0": F0, "a": a, "b": b, "values": F.tolist(),
                   "max_fit_residual": float(np.max(np.abs(A @ coef - F))),
                   "rel_change_at_2.14": float(np.interp(2.14, FIT_BONDS, F) / F[0] - 1)}
            for bo in (0.13, 2.14):
                # for equal grains and angles the mean force is even in Bo (a mirror
                # image): a vanishes there and the ratio is meaningless; the first and
                # second-order changes relative to F0 say the same thing in every case
                fit[f"second_over_first_at_{bo}"] = (abs(b * bo**2) / abs(a * bo)
                                                     if a != 0 else None)
                fit[f"first_over_F0_at_{bo}"] = abs(a * bo / F0)
                fit[f"second_over_F0_at_{bo}"] = abs(b * bo**2 / F0)
            row[key] = {k: (float(v) if isinstance(v, (float, np.floating)) else v)
                        for k, v in fit.items()}
        out.append(row)
        print(json.dumps({k: row[k] for k in ("gap", "volume", "theta", "ratio")}
                         | {k: {kk: row[k][kk] for kk in ("a", "b", "max_fit_residual",
                                                          "second_over_first_at_0.13",
                                                          "second_over_first_at_2.14",
                                                          "second_over_F0_at_2.14")}
                            for k in ("force1", "force2", "force")}), flush=True)
    return out


def rupture_response():
    """Rupture distance with gravity along the axis, relative to Bo = 0, at the volumes
    and angles of POINTS (both directions of gravity for unequal grains)."""
    out = []
    for _, V, th, ratio in POINTS:
        for ga in ((-1.0, 1.0) if ratio != 1.0 else (-1.0,)):
            bonds = np.array([0.0, 0.13, 0.5, 2.14])
            r = rupture_distance_gravity(V, th, bonds, ratio, gravity_axis=ga)
            row = dict(volume=V, theta=th, ratio=ratio, gravity_axis=ga,
                       bonds=bonds.tolist(), d_rupt=r["gap"].tolist(),
                       status=r["status"].tolist(),
                       rel_change=(r["gap"] / r["gap"][0] - 1).tolist())
            out.append(row)
            print(json.dumps(row), flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-refine", type=int, default=3)
    ap.add_argument("--no-evolver", action="store_true")
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args(argv)
    if OUT.exists() and not args.overwrite:
        sys.exit(f"gravity_axis_check: error: {OUT} exists; pass --overwrite to replace it")
    t = time.monotonic()
    result = {"command": "nice -n 5 .venv/bin/python benchmarks/gravity_axis_check.py "
                         + " ".join(argv if argv is not None else sys.argv[1:]),
              "git_commit": subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True,
                                           text=True, cwd=OUT.parent).stdout.strip(),
              "conventions": "F* = F/(2 pi gamma r), attraction > 0; force1 on grain 1 "
                             "(radius 1, centre x=0) towards grain 2, force2 on grain 2 "
                             "towards grain 1; gravity_axis -1: grain 1 below; pressure "
                             "at the height of the centre of grain 1; energy E* with "
                             "gravitational energy from that height",
              "bond_response": bond_response(),
              "rupture_response": rupture_response()}
    if not args.no_evolver:
        rows, summary = compare_evolver(args.max_refine)
        result.update(max_refine=args.max_refine, evolver=rows, evolver_summary=summary)
    result["wall_s"] = round(time.monotonic() - t, 1)
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    print("wrote", OUT, f"({result['wall_s']} s)")


if __name__ == "__main__":
    main()
