"""``capbridge`` command line: solve, lookup, generate, info, demo."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from capbridge.reproduce import STUDIES
from capbridge.status import status_name
from capbridge.validation import CapbridgeInputError

DEFAULT_TABLE = Path(__file__).resolve().parent.parent / "data" / "doublet_table.nc"


def _json_value(v):
    v = np.asarray(v)
    if v.ndim == 0:
        x = v.item()
        return None if isinstance(x, float) and not np.isfinite(x) else x
    return [_json_value(x) for x in v]


def cmd_solve_doublet(args):
    from capbridge.generator.young_laplace import solve_doublet, solve_doublet_suction

    if (args.V is None) == (args.P is None):
        raise CapbridgeInputError("give exactly one of --V (volume control) or --P (suction control)")
    if args.V is not None:
        r = solve_doublet(args.d, args.V, args.theta, args.ratio, args.theta2)
    else:
        r = solve_doublet_suction(args.d, args.P, args.theta, args.ratio, args.theta2)
    out = {"d": args.d, "V": r["volume"], "theta": args.theta, "theta2": args.theta2 or args.theta,
           "ratio": args.ratio, "F": r["force"], "P": r["pressure"], "beta1": r["beta1"],
           "beta2": r["beta2"], "neck_radius": r["neck_radius"], "area": r["area"],
           "energy": r["energy"], "status": status_name(r["status"]),
           "units": "dimensionless by R1 and gamma: F*=F/(2 pi gamma R1), P*=dp R1/gamma; angles in degrees"}
    print(json.dumps({k: _json_value(v) if not isinstance(v, str) else v for k, v in out.items()},
                     indent=1))
    return 0 if out["status"] in ("converged", "ruptured") else 3


def _load_surrogate(path, out_of_range="raise"):
    from capbridge.surrogate.doublet import DoubletSurrogate

    path = Path(path)
    if not path.exists():
        raise CapbridgeInputError(f"table {path} not found; make it with `capbridge generate doublet`")
    return DoubletSurrogate(out_of_range=out_of_range).fit(path)


def cmd_lookup_doublet(args):
    import pandas as pd

    df = pd.read_csv(args.input)
    missing = [c for c in ("d", "V", "theta") if c not in df.columns]
    if missing:
        raise CapbridgeInputError(
            f"{args.input}: missing column(s) {missing}; required: d, V, theta (optional ratio), "
            f"found: {list(df.columns)}")
    ratio = df["ratio"].to_numpy(float) if "ratio" in df.columns else 1.0
    sur = _load_surrogate(args.table, "clip" if args.clip else "raise")
    r = sur.predict(df["d"].to_numpy(float), df["V"].to_numpy(float),
                    df["theta"].to_numpy(float), ratio)
    for key, col in (("force", "F"), ("pressure", "P"), ("beta1", "beta1"), ("beta2", "beta2"),
                     ("rupture_gap", "d_rupt")):
        df[col] = r[key]
    df["status"] = [status_name(s) for s in r["status"]]
    df.to_csv(args.output, index=False)
    print(f"wrote {len(df)} rows to {args.output}", file=sys.stderr)
    return 0


def cmd_generate_doublet(args):
    from capbridge.generator.doublet_table import (DoubletGrid, build_doublet_table,
                                                   save_doublet_table)
    from capbridge.surrogate.doublet import DoubletSurrogate, holdout_errors

    grid = DoubletGrid.shipped(args.quick, ratios=args.ratios)
    command = "capbridge " + " ".join(sys.argv[1:]) if args.command is None else args.command
    ds = build_doublet_table(grid, checkpoint_dir=args.checkpoint_dir, n_jobs=args.jobs,
                             scheduler=args.scheduler, progress=not args.no_progress,
                             command=command)
    sur = DoubletSurrogate().fit(ds)
    r = np.asarray(grid.ratio)
    between = np.sqrt(r[1:] * r[:-1])  # halfway (in log) between tabulated ratios
    checks = [(1.0, 0.0)] if 1.0 in grid.ratio else []
    checks += [(float(x), HOLDOUT_BAND) for x in np.sort(np.concatenate([r, between]))]
    for ratio, band in checks:
        h = holdout_errors(sur, n=args.holdout, seed=1, ratio=ratio, exclude_band=band)
        tag = f"ratio{ratio:.4g}_band{band:g}"
        ds.attrs[f"holdout_median_rel_error_force_{tag}"] = h["median_rel_error"]
        ds.attrs[f"holdout_max_rel_error_force_{tag}"] = h["max_rel_error"]
        ds.attrs[f"holdout_n_{tag}"] = h["n"]
    ds.attrs["holdout_description"] = (
        "relative error of the surrogate force against the exact solver at random points "
        "uniform in theta, log V*, and s = sqrt(1 - d*/d*_rupt) in [band, 1]; band 0.2 leaves "
        "out d* > 0.96 d*_rupt, where dF/dd* diverges at the fold; ratios on the grid and "
        "halfway between (cubic spline across ratio slices)")
    save_doublet_table(ds, args.output, command=command)
    print(f"wrote {args.output}", file=sys.stderr)
    return cmd_info_table(argparse.Namespace(table=args.output))


HOLDOUT_BAND = 0.2


def cmd_info_table(args):
    from capbridge.generator.netcdf_io import read_table

    ds = read_table(args.table)
    print(f"table: {args.table}")
    print(f"  made by: {ds.attrs.get('capbridge_command')}")
    for name in ("ratio", "theta", "volume", "s"):
        c = ds[name].values
        print(f"  {name:7s} {len(c):3d} values in [{c.min():g}, {c.max():g}]  ({ds[name].attrs['long_name']})")
    st = ds["status"].values
    print(f"  points: {st.size}, converged: {int((st == 0).sum())}")
    print("  error model (surrogate vs exact, held-out points):")
    for k, v in sorted(ds.attrs.items()):
        if k.startswith("holdout_") and k != "holdout_description":
            print(f"    {k}: {v:.3g}" if isinstance(v, float) else f"    {k}: {v}")
    if "holdout_description" in ds.attrs:
        print(f"    ({ds.attrs['holdout_description']})")
    return 0


def cmd_export_yade(args):
    from capbridge.dem_plugin.yade_export import export_from_solver

    out = Path(args.directory)
    out.mkdir(parents=True, exist_ok=True)
    for theta in args.theta:
        _, paths = export_from_solver(out, theta, n_gaps=args.n_gaps)
        for p in (paths if isinstance(paths, (list, tuple)) else [paths]):
            print(p)
    return 0


def cmd_demo(args):
    from capbridge.surrogate.demo import run_demo

    return run_demo(args.table, args.output_dir)


def cmd_coalescence(args):
    from capbridge.generator.triplet import (CRITERIA, find_coalescence, parse_bridges,
                                             triplet_geometry)

    bridges = parse_bridges(args.bridges)
    theta = [args.theta,
             args.theta if args.theta2 is None else args.theta2,
             args.theta if args.theta3 is None else args.theta3]
    fractions = None
    if args.fractions:
        try:
            fractions = [float(x) for x in args.fractions.split(",")]
        except ValueError:
            raise CapbridgeInputError(f"--fractions {args.fractions!r}: give numbers "
                                      "separated by commas, one per bridge") from None
    geom = triplet_geometry(args.d12, args.d13, args.d23)
    r = find_coalescence(geom, theta, bridges, fractions, v_max=args.v_max)
    out = {"V_coal": r.V_coal, "criterion": r.criterion,
           "criterion_description": CRITERIA.get(r.criterion, ""), "where": r.where,
           "status": r.status,
           "V_coal_per_bridge": {f"{i + 1}{j + 1}": r.V_coal * w
                                 for (i, j), w in zip(r.bridges, r.fractions)},
           "beta": r.beta, "opening_angle": r.opening_angles,
           "alpha": {g: a / 2 for g, a in r.opening_angles.items()},
           "F_bridge": r.forces, "P_bridge": r.pressure,
           "grain_forces": r.grain_forces, "energy_uncoalesced": r.energy,
           "criteria": [{"criterion": c["criterion"], "where": c["where"], "V_coal": c["V"]}
                        for c in r.criteria],
           "inputs": {"d12": args.d12, "d13": args.d13, "d23": args.d23, "theta": theta,
                      "bridges": [f"{i + 1}{j + 1}" for i, j in r.bridges],
                      "fractions": r.fractions},
           "units": "V_coal: total liquid volume V/r^3 (all bridges); angles in degrees "
                    "(beta: half filling angle on each grain; opening_angle: angle at a shared "
                    "grain between the centre lines; alpha = half of it); F* = F/(2 pi gamma r), "
                    "attraction > 0; energies E* = (A_lg - cos(theta) A_wet)/r^2"}
    if args.radius is not None and np.isfinite(r.V_coal):
        out["V_coal_ul"] = r.V_coal * (args.radius * 1e3) ** 3
        out["radius_m"] = args.radius
    if args.energy:
        from capbridge.generator.triplet_evolver import energy_comparison

        if not np.isfinite(r.V_coal):
            out["energy"] = {"error": "no coalescence volume to compare around"}
        else:
            fr = [float(x) for x in args.energy_fractions.split(",")]
            e = energy_comparison(geom, theta, [r.V_coal * f for f in fr], bridges, fractions,
                                  max_refine=args.max_refine)
            out["energy"] = {"V_cross": e["crossing"], "note": e["crossing_note"],
                             "volumes": e["volume"], "E_uncoalesced": e["E_uncoalesced"],
                             "E_coalesced": e["E_coalesced"],
                             "E_coalesced_error": e["E_coalesced_error"],
                             "coalesced_status": e["coalesced_status"],
                             "method": "coalesced: Surface Evolver (Richardson-extrapolated "
                                       f"energy, max refinement {args.max_refine}); separate "
                                       "bridges: exact doublets"}
    print(json.dumps(_json_tree(out), indent=1))
    return 0 if r.status == "coalescence" else 3


def _json_tree(x):
    if isinstance(x, dict):
        return {str(k): _json_tree(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_json_tree(v) for v in x]
    return _json_value(x)


def cmd_reproduce(args):
    import importlib

    study = importlib.import_module(f"capbridge.reproduce.{args.study}")
    ck = args.checkpoint_dir
    if ck is None and not args.quick:
        ck = f".sweep-checkpoints/{args.study}"
    s = study.run(args.output_dir, quick=args.quick, checkpoint_dir=ck,
                     progress=not args.no_progress, max_refine=args.max_refine)
    print(json.dumps({"output_dir": args.output_dir, "files": s.get("files", []),
                      "claims": str(Path(args.output_dir) / "CLAIMS.md"),
                      "timings_s": s.get("timings_s", {})}, indent=1))
    return 0


def build_parser():
    p = argparse.ArgumentParser(prog="capbridge", description=__doc__)
    sub = p.add_subparsers(dest="command_name", required=True)

    solve = sub.add_parser("solve", help="exact solvers").add_subparsers(dest="what", required=True)
    sd = solve.add_parser("doublet", help="exact Young-Laplace bridge between two spheres (JSON out)")
    sd.add_argument("--d", type=float, required=True, help="gap d* = d/R1")
    sd.add_argument("--V", type=float, default=None, help="volume V* = V/R1^3 (volume control)")
    sd.add_argument("--P", type=float, default=None,
                    help="pressure P* = dp R1/gamma, negative for suction (suction control)")
    sd.add_argument("--theta", type=float, required=True, help="contact angle [deg]")
    sd.add_argument("--theta2", type=float, default=None, help="contact angle on grain 2 [deg]")
    sd.add_argument("--ratio", type=float, default=1.0, help="R2/R1 >= 1")
    sd.set_defaults(func=cmd_solve_doublet)

    look = sub.add_parser("lookup", help="surrogate lookups").add_subparsers(dest="what", required=True)
    ld = look.add_parser("doublet", help="interpolate forces for the rows of a CSV")
    ld.add_argument("--input", required=True, help="CSV with columns d, V, theta [, ratio]")
    ld.add_argument("--output", required=True)
    ld.add_argument("--table", default=str(DEFAULT_TABLE))
    ld.add_argument("--clip", action="store_true",
                    help="answer outside the table at its edge (status extrapolated) instead of failing")
    ld.set_defaults(func=cmd_lookup_doublet)

    gen = sub.add_parser("generate", help="regenerate tables").add_subparsers(dest="what", required=True)
    gd = gen.add_parser("doublet", help="sweep the exact solver into a netCDF table")
    gd.add_argument("--output", default=str(DEFAULT_TABLE))
    gd.add_argument("--quick", action="store_true", help="small grid (tests)")
    gd.add_argument("--ratios", type=float, nargs="+", default=None)
    gd.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    gd.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    gd.add_argument("--checkpoint-dir", default=None, help="resumable checkpoints here")
    gd.add_argument("--holdout", type=int, default=600, help="held-out exact points for the error model")
    gd.add_argument("--no-progress", action="store_true")
    gd.add_argument("--command", default=None, help=argparse.SUPPRESS)
    gd.set_defaults(func=cmd_generate_doublet)

    ex = sub.add_parser("export-yade", help="write YADE's native capillary files (M(r=...) sets, "
                        "CapillarityEngine input) from the exact suction-controlled solver")
    ex.add_argument("--directory", required=True)
    ex.add_argument("--theta", type=float, nargs="+", default=[0.0], help="contact angles [deg]")
    ex.add_argument("--n-gaps", type=int, default=61)
    ex.set_defaults(func=cmd_export_yade)

    info = sub.add_parser("info", help="describe a table and its error model")
    info.add_argument("--table", default=str(DEFAULT_TABLE))
    info.set_defaults(func=cmd_info_table)

    demo = sub.add_parser("demo", help="F*(d*) from the shipped table beside the exact solution")
    demo.add_argument("--table", default=str(DEFAULT_TABLE))
    demo.add_argument("--output-dir", default="out")
    demo.set_defaults(func=cmd_demo)

    co = sub.add_parser("coalescence", help="volume at which separate bridges in a triplet of "
                        "equal spheres coalesce (exact shapes; JSON out)")
    co.add_argument("--d12", type=float, required=True, help="gap between grains 1 and 2, d/r")
    co.add_argument("--d13", type=float, required=True, help="gap between grains 1 and 3, d/r")
    co.add_argument("--d23", type=float, required=True, help="gap between grains 2 and 3, d/r")
    co.add_argument("--theta", type=float, required=True, help="contact angle [deg], in [0, 90)")
    co.add_argument("--theta2", type=float, default=None, help="contact angle on grain 2 [deg]")
    co.add_argument("--theta3", type=float, default=None, help="contact angle on grain 3 [deg]")
    co.add_argument("--bridges", default="12,13",
                    help="bridge layout: grain pairs, e.g. 12,13 (default) or 12,13,23")
    co.add_argument("--fractions", default=None,
                    help="share of the total volume held by each bridge, e.g. 0.5,0.5 (default equal)")
    co.add_argument("--v-max", type=float, default=2.5, help="largest total V* searched")
    co.add_argument("--radius", type=float, default=None,
                    help="grain radius [m]: also report V_coal in ul")
    co.add_argument("--energy", action="store_true",
                    help="also compare the energy of one coalesced body (Surface Evolver) with "
                         "the separate bridges and report where they cross (slow)")
    co.add_argument("--energy-fractions", default="0.6,0.8,1.0,1.2",
                    help="volumes of the energy comparison, as fractions of V_coal")
    co.add_argument("--max-refine", type=int, default=3, help="Evolver refinement level (--energy)")
    co.set_defaults(func=cmd_coalescence)

    rep = sub.add_parser("reproduce", help="reproduce a published study (figures, CSV, claims table)")
    rep.add_argument("study", choices=STUDIES)
    rep.add_argument("--quick", action="store_true", help="a handful of points, coarse meshes")
    rep.add_argument("--output-dir", default="examples/miot2021")
    rep.add_argument("--checkpoint-dir", default=None,
                     help="resumable Evolver checkpoints (default .sweep-checkpoints/miot2021 "
                          "for the full run, none with --quick)")
    rep.add_argument("--max-refine", type=int, default=None, help="Evolver refinement level")
    rep.add_argument("--no-progress", action="store_true")
    rep.set_defaults(func=cmd_reproduce)
    return p


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (CapbridgeInputError, FileNotFoundError) as exc:
        print(f"capbridge: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
