"""``capbridge`` command line: solve, lookup, generate, info, demo.

Every user error ends in one line ``capbridge: error: ...`` and exit status 2 (``--debug``
anywhere on the line shows the traceback instead); a sweep with failed chunks exits 3
("N chunks failed, rerun to retry"), an internal error 1.  ``--allow-unverified-table``
anywhere on the line uses tables without a table checksum (older or edited files), with
one warning line each, instead of refusing them.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

from capbridge.studies import STUDIES
from capbridge.tables import DATA_DIR
from capbridge.status import HAS_RESULT, Status, status_name
from capbridge.surrogate.names import CSV_COLUMNS as COL
from capbridge.surrogate.names import DOUBLET_OUTPUTS, csv_columns
from capbridge.surrogate.names import TRIPLET_OUTPUTS as TRIPLET_SURROGATE_OUTPUTS
from capbridge.validation import CapbridgeInputError, check_gap, check_range, interval_text

DATA = DATA_DIR
DEFAULT_TABLE = DATA / "doublet_table.nc"
DEFAULT_TRIPLET_TABLE = DATA / "triplet_table.nc"
DEFAULT_COALESCENCE_TABLE = DATA / "triplet_coalescence.nc"


def _json_value(v):
    v = np.asarray(v)
    if v.ndim == 0:
        x = v.item()
        return None if isinstance(x, float) and not np.isfinite(x) else x
    return [_json_value(x) for x in v]


def parse_gravity(bond, gravity, bond_max, what):
    """(Bo, unit direction) from ``--bond BO`` and ``--gravity X,Y,Z`` (text or None).

    Bo in [0, ``bond_max``] (``what`` names the limit in the message); the direction
    along which gravity pulls, three finite components not all zero, default (0, 0, -1);
    ``--gravity`` without ``--bond`` is refused.  Returns (0.0, None) without
    ``--bond``.  Errors: one CapbridgeInputError line naming the value and the range.
    """
    if bond is None:
        if gravity is not None:
            raise CapbridgeInputError(f"--gravity {gravity} needs --bond BO (the Bond "
                                      f"number, in [0, {bond_max:g}])")
        return 0.0, None
    bo = float(check_range("--bond", bond, 0.0, bond_max,
                           hint=f"Bond number Bo = drho g r^2 / gamma ({what})"))
    if gravity is None:
        return bo, np.array([0.0, 0.0, -1.0])
    parts = [p.strip() for p in str(gravity).split(",")]
    try:
        g = np.array([float(p) for p in parts])
    except ValueError:
        g = None
    if g is None or g.size != 3 or not np.all(np.isfinite(g)) or not np.any(g):
        raise CapbridgeInputError(
            f"--gravity {gravity!r}: give the direction along which gravity pulls as three "
            "finite numbers X,Y,Z, not all zero (e.g. 0,0,-1)")
    from capbridge.physics.gravity import gravity_vector

    return bo, gravity_vector(1.0, g)


def _solve_doublet_gravity(args, bond, direction):
    """``solve doublet --bond``: the exact axisymmetric solver when gravity is along the
    axis (+-x), else Surface Evolver with two spheres (slower)."""
    if args.V is None:
        raise CapbridgeInputError("--bond needs --V (volume control): suction control "
                                  "(--P) with gravity is not available")
    from capbridge.solvers.young_laplace_gravity import validated_inputs
    from capbridge.physics.gravity import liquid_weight

    # the checks of the exact solver, for the Evolver branch too (one line, not a run)
    check_range("gap d* (--d)", args.d, 0.0, np.inf)
    validated_inputs(None, args.V, args.theta, args.theta2, args.ratio, bond, -1.0)
    theta2 = args.theta if args.theta2 is None else args.theta2
    out = {"d": args.d, "V": args.V, "theta": args.theta, "theta2": theta2,
           "ratio": args.ratio, "bond": bond, "gravity": direction.tolist(),
           "frame": "grain 1 (radius 1) at the origin, grain 2 (radius ratio) on +x; "
                    "gravity: the direction it pulls"}
    axial = abs(direction[0]) >= 1.0 - 1e-12 or bond == 0.0
    if axial:
        from capbridge.solvers.young_laplace_gravity import solve_doublet_gravity

        axis = -1.0 if direction[0] <= 0 else 1.0         # any side at Bo = 0
        r = solve_doublet_gravity(args.d, args.V, args.theta, bond, args.ratio, args.theta2,
                                  gravity_axis=axis)
        r = {k: (float(v) if np.ndim(v) == 0 and k != "status" else v) for k, v in r.items()}
        st = Status(int(r["status"]))
        f1, f2 = r["force1"], r["force2"]
        out.update(method="exact (axisymmetric, gravity along the axis)",
                   F1=[f1, 0.0, 0.0], F2=[-f2, 0.0, 0.0], F=r["force"],
                   weight=float(liquid_weight(args.V) * bond),
                   P_centre1=r["pressure_centre1"], beta1=r["beta1"], beta2=r["beta2"],
                   energy=r["energy"], status=status_name(st))
        if st == Status.NOT_CONVERGED:
            out["reason"] = ("no stable bridge reached at this Bo: beyond the rupture "
                             "distance with gravity (see `capbridge lookup doublet "
                             "--bond`, d_rupt), or the solver failed")
    else:
        from capbridge.solvers.evolver import minimise_bridge

        print("capbridge: gravity not along the axis: Surface Evolver (minutes, not "
              "milliseconds)", file=sys.stderr)
        centres = [[0.0, 0.0, 0.0], [1.0 + args.ratio + args.d, 0.0, 0.0]]
        res = minimise_bridge(centres, [1.0, args.ratio], [args.theta, theta2], args.V,
                              "doublet", bond=bond, gravity_dir=tuple(direction),
                              max_refine=args.max_refine)
        st = res.status
        F = res.forces if res.converged else np.full((2, 3), np.nan)
        out.update(method=f"Surface Evolver (level {res.refinement})", F1=F[0], F2=F[1],
                   force_error=res.force_error, weight=float(liquid_weight(args.V) * bond),
                   cpu_time=res.cpu_time, status=status_name(st), reason=res.reason)
    out["units"] = ("dimensionless by R1 and gamma: F* = F/(2 pi gamma R1) (force vectors "
                    "on each grain; F1 + F2 = weight * gravity), P* = dp R1/gamma")
    print(json.dumps(_json_tree(out), indent=1))
    return 0 if st in (Status.CONVERGED, Status.ABOVE_TOLERANCE) else 3


def cmd_solve_doublet(args):
    from capbridge.solvers.young_laplace import solve_doublet, solve_doublet_suction
    from capbridge.solvers.young_laplace_gravity import BOND_MAX as SOLVER_BOND_MAX

    bond, direction = parse_gravity(args.bond, args.gravity, SOLVER_BOND_MAX,
                                    "the exact solver's range")
    if (args.V is None) == (args.P is None):
        raise CapbridgeInputError("give exactly one of --V (volume control) or --P (suction control)")
    if args.bond is not None:
        return _solve_doublet_gravity(args, bond, direction)
    if args.V is not None:
        r = solve_doublet(args.d, args.V, args.theta, args.ratio, args.theta2)
        volume = args.V   # the requested volume, also when the solve failed
    else:
        r = solve_doublet_suction(args.d, args.P, args.theta, args.ratio, args.theta2)
        volume = r["volume"]
    out = {"d": args.d, "V": volume, "theta": args.theta,
           "theta2": args.theta if args.theta2 is None else args.theta2,
           "ratio": args.ratio, COL["force"]: r["force"], COL["pressure"]: r["pressure"],
           "beta1": r["beta1"], "beta2": r["beta2"], "neck_radius": r["neck_radius"], "area": r["area"],
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
    return DoubletSurrogate(out_of_range=out_of_range, clip_hint="--clip").fit(path)


#: lookup doublet: CSV columns read and written (an input column may not be an output)
LOOKUP_INPUTS = ("d", "V", "theta")
LOOKUP_OPTIONAL = ("ratio", "theta2")
LOOKUP_OUTPUTS = csv_columns(DOUBLET_OUTPUTS)
LOOKUP_RESERVED = tuple(LOOKUP_OUTPUTS.values()) + ("status", "method")


def lookup_points(sur, d, V, theta, ratio, theta2=None):
    """Answers for CSV points: the table where theta2 == theta, the exact solver elsewhere.

    Returns a dict of the :data:`LOOKUP_OUTPUTS` keys, ``status`` and ``method``
    ("table" or "exact").  Mixed angles (theta2 != theta) are not in the doublet table;
    the vectorised exact solver answers them (thousands of points per second).
    """
    from capbridge.solvers.young_laplace import rupture_distance, solve_doublet

    d = check_gap("gap d*", d)          # a DEM contact for the exact solver too, as the table
    n = d.size
    mixed = np.zeros(n, bool) if theta2 is None else ~(theta2 == theta)
    out = {k: np.full(n, np.nan) for k in LOOKUP_OUTPUTS}
    status = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    ratio = np.broadcast_to(np.asarray(ratio, float), (n,))
    tab = ~mixed
    if tab.any():
        r = sur.predict(d[tab], V[tab], theta[tab], ratio[tab])
        for k in out:
            out[k][tab] = r[k]
        status[tab] = r["status"]
    if mixed.any():
        args = (V[mixed], theta[mixed], ratio[mixed], theta2[mixed])
        ex = solve_doublet(d[mixed], *args)
        for k in ("force", "pressure", "beta1", "beta2"):
            out[k][mixed] = ex[k]
        out["rupture_gap"][mixed] = rupture_distance(*args)["gap"]
        status[mixed] = ex["status"]
    return out | {"status": status, "method": np.where(mixed, "exact", "table")}


def cmd_lookup_doublet(args):
    import pandas as pd

    from capbridge.tabular_io import check_new_output, read_points_csv

    from capbridge.surrogate.doublet import BOND_MAX

    bond, direction = parse_gravity(args.bond, args.gravity, BOND_MAX,
                                    "the surrogates' range")
    reserved = LOOKUP_RESERVED + (DOUBLET_VECTOR_COLUMNS if args.bond is not None else ())
    columns, x = read_points_csv(args.input, LOOKUP_INPUTS, LOOKUP_OPTIONAL, reserved)
    check_new_output(args.output, inputs=[args.input], overwrite=args.overwrite)
    sur = _load_surrogate(args.table, "clip" if args.clip else "raise")
    if args.bond is not None:
        return _lookup_doublet_gravity(args, sur, columns, x, bond, direction)
    r = lookup_points(sur, x["d"], x["V"], x["theta"], x.get("ratio", 1.0), x.get("theta2"))
    df = pd.DataFrame(columns)
    for key, col in LOOKUP_OUTPUTS.items():
        df[col] = r[key]
    df["status"] = [status_name(s) for s in r["status"]]
    df["method"] = r["method"]
    df.to_csv(args.output, index=False)
    print(f"wrote {len(df)} rows to {args.output} ({int((r['method'] == 'exact').sum())} "
          f"by the exact solver: theta2 != theta)", file=sys.stderr)
    return 0


#: lookup doublet --bond: force vectors on grain 1 and grain 2
DOUBLET_VECTOR_COLUMNS = tuple(f"F{g}{c}" for g in (1, 2) for c in "xyz")


def _lookup_doublet_gravity(args, sur, columns, x, bond, direction):
    """``lookup doublet --bond``: force vectors from :meth:`DoubletSurrogate.predict_vectors`
    (frame: grain 1 at the origin, grain 2 on +x)."""
    import pandas as pd

    if "theta2" in x and np.any(x["theta2"] != x["theta"]):
        raise CapbridgeInputError(
            "--bond with theta2 != theta: mixed angles with gravity are not in the doublet "
            "table; use `capbridge solve doublet --bond --theta2` per point")
    r = sur.predict_vectors(x["d"], x["V"], x["theta"], x.get("ratio", 1.0), bond=bond,
                            gravity=direction)
    df = pd.DataFrame(columns)
    df[COL["force"]] = r["force"]
    for g, key in ((1, "F1"), (2, "F2")):
        for k, c in enumerate("xyz"):
            df[f"F{g}{c}"] = r[key][:, k]
    df[COL["rupture_gap"]] = r["rupture_gap"]
    df["status"] = [status_name(s) for s in r["status"]]
    df["method"] = "table"
    df.to_csv(args.output, index=False)
    st = r["status"]
    gap_only = int((st == Status.OUT_OF_RANGE).sum())
    print(f"wrote {len(df)} rows to {args.output} (Bo = {bond:g}, gravity along "
          f"{np.round(direction, 6).tolist()}; F = the attraction without gravity)",
          file=sys.stderr)
    if gap_only:
        print(f"capbridge: warning: {gap_only} rows are beyond the rupture distance without "
              "gravity but inside the one with gravity: the table has no bridge there "
              "(status out_of_range, no number)", file=sys.stderr)
    return 0


def cmd_generate_doublet(args):
    from capbridge.tables.doublet import (DoubletGrid, build_doublet_table,
                                                   save_doublet_table, table_axes)
    from capbridge.surrogate.doublet import (DoubletSurrogate, gravity_holdout_errors,
                                             holdout_errors)

    from capbridge.tables.netcdf_io import check_table_target
    from capbridge.surrogate.doublet import DEFAULT_REFINE, DEFAULT_THETA_STEP

    ratios = None if args.ratios is None else sorted(set(args.ratios))
    grid = DoubletGrid.shipped(args.quick, ratios=ratios)
    # before hours of work: can the table be written, and would it replace another grid?
    check_table_target(args.output, table_axes(grid), overwrite=args.overwrite,
                       flag="--overwrite")
    command = args.command or _command_line(args)
    ds = build_doublet_table(grid, checkpoint_dir=args.checkpoint_dir, n_jobs=args.jobs,
                             scheduler=args.scheduler, progress=not args.no_progress,
                             command=command, worker_timeout=args.worker_timeout)
    sur = DoubletSurrogate(DEFAULT_REFINE, DEFAULT_THETA_STEP).fit(ds)
    ds.attrs["holdout_refine"] = DEFAULT_REFINE
    ds.attrs["holdout_theta_step"] = DEFAULT_THETA_STEP
    r = np.asarray(grid.ratio)
    between = np.sqrt(r[1:] * r[:-1])  # halfway (in log) between tabulated ratios
    checks = [(1.0, 0.0)] if 1.0 in grid.ratio else []
    checks += [(float(x), HOLDOUT_BAND) for x in np.sort(np.concatenate([r, between]))]
    for ratio, band in checks:
        h = holdout_errors(sur, n=args.holdout, seed=1, ratio=ratio, exclude_band=band)
        _holdout_attrs(ds.attrs, h, "force", f"ratio{ratio:.4g}_band{band:g}")
    ds.attrs["holdout_description"] = (
        "relative error of the surrogate force against the exact solver at random points "
        "uniform in theta, log V*, and s = sqrt(1 - d*/d*_rupt) in [band, 1]; band 0.2 leaves "
        "out d* > 0.96 d*_rupt, where dF/dd* diverges at the fold; ratios on the grid and "
        "halfway between (cubic spline across ratio slices)")
    if sur.has_gravity_:
        _gravity_holdout_attrs(ds.attrs, gravity_holdout_errors(
            sur, n=args.gravity_holdout, progress=not args.no_progress))
    save_doublet_table(ds, args.output, command=command, overwrite=args.overwrite)
    print(f"wrote {args.output}", file=sys.stderr)
    return cmd_info_table(argparse.Namespace(table=args.output))


HOLDOUT_BAND = 0.2


def cmd_info_table(args):
    """Describe one table, or every shipped table when no --table is given."""
    from capbridge.tables.netcdf_io import checksum_state, read_table

    if args.table is None:
        for path in (DEFAULT_TABLE, DEFAULT_TRIPLET_TABLE, DEFAULT_COALESCENCE_TABLE):
            if path.exists():
                cmd_info_table(argparse.Namespace(table=path))
        return 0
    ds = read_table(args.table)
    if "f12" in ds:
        return _info_triplet(ds, args.table)
    if "ratio" not in ds.dims:
        return _info_generic(ds, args.table)
    from capbridge.tables.doublet import validate_doublet_table

    ds = validate_doublet_table(ds, args.table)
    print(f"table: {args.table}")
    print(f"  made by: {ds.attrs.get('capbridge_command')}")
    print(f"  source commit: {ds.attrs.get('git_commit', 'not recorded')}; table checksum: "
          f"{checksum_state(ds)}")
    for name in ("ratio", "theta", "volume", "s"):
        c = ds[name].values
        print(f"  {name:7s} {len(c):3d} values in [{c.min():g}, {c.max():g}]  "
              f"({ds[name].attrs.get('long_name', '')})")
    st = ds["status"].values
    print(f"  points: {st.size}, converged: {int((st == 0).sum())}")
    _print_holdout(ds)
    _info_doublet_gravity(ds)
    return 0


def _info_doublet_gravity(ds):
    """The gravity content of a doublet table (response variables, rupture with
    gravity, their attributes), or one line saying there is none."""
    from capbridge.surrogate.doublet import BOND_MAX, GRAVITY_VARIABLES

    names = [n for n in GRAVITY_VARIABLES + ("weight_share_transverse", "gravity_status",
                                             "rupture_gap_gravity") if n in ds]
    if not all(n in ds for n in GRAVITY_VARIABLES):
        print("  gravity: none (the lookups answer Bo = 0 only; `capbridge solve doublet "
              "--bond` solves with gravity)")
        return
    print(f"  gravity (Bo up to {BOND_MAX:g} in the lookups):")
    for n in names:
        dims = ", ".join(f"{d} {ds.sizes[d]}" for d in ds[n].dims)
        print(f"    {n} ({dims}): {ds[n].attrs.get('long_name', '')}")
    for d in sorted({d for n in names for d in ds[n].dims if d.startswith(("gravity_",
                                                                             "rupture_"))}):
        if d in ds.coords:
            c = np.asarray(ds[d].values)
            print(f"    {d}: {np.round(c, 6).tolist()}" if c.size <= 8 else
                  f"    {d}: {c.size} values in [{c.min():g}, {c.max():g}]")
    if "gravity_status" in ds:
        st = np.asarray(ds["gravity_status"].values)
        print(f"    response points: {st.size}, with a result: "
              f"{int(np.isin(st, [int(x) for x in HAS_RESULT]).sum())} "
              f"({int((st == Status.ABOVE_TOLERANCE).sum())} above_tolerance: own error "
              "estimate response_error above gravity_response_rtol)")
    if "gravity_holdout_bonds" in ds.attrs:
        from capbridge.surrogate.doublet import validated_axial_bond

        a = ds.attrs
        print("    held-out exact solutions with gravity along the axis (error relative to "
              "the attraction; effect: of the gravity part alone); validated up to "
              f"|Bo g_hat.n| = {validated_axial_bond(a):g}, above it lookups are "
              "approximate:")
        for k, b in enumerate(np.atleast_1d(a["gravity_holdout_bonds"])):
            print(f"      Bo = {b:<5g} max {np.atleast_1d(a['gravity_holdout_max_error'])[k]:.3g}"
                  f", effect max {np.atleast_1d(a['gravity_holdout_max_effect_error'])[k]:.3g}"
                  " (converged lookups "
                  f"{np.atleast_1d(a['gravity_holdout_max_effect_error_converged'])[k]:.3g}), "
                  f"{np.atleast_1d(a['gravity_holdout_n'])[k]} lookups, "
                  f"{np.atleast_1d(a['gravity_holdout_n_approximate'])[k]} approximate")
    for k, v in sorted(ds.attrs.items()):
        if "gravity" in k and not k.startswith("gravity_holdout_") or \
                k == "gravity_holdout_description":
            print(f"    {k}: {v:.3g}" if isinstance(v, float) else f"    {k}: {v}")


def _info_triplet_gravity(ds, path):
    """The gravity content of a triplet table: the response's grid and the held-out
    errors of the surrogate with gravity (:func:`gravity_holdout_errors`)."""
    if "force_gravity_gradient" not in ds:
        print("  gravity: none (the lookups answer Bo = 0 only; `capbridge solve triplet "
              "--bond` solves with gravity)")
        return
    sur = _load_triplet_surrogate(path)
    g = sur.gravity_summary()
    print(f"  gravity: response on v = {g['gravity_v']} ({g['nodes']['with_response']} of "
          f"{g['nodes']['total']} nodes with a result); Bo supported [0, "
          f"{g['bond_max_supported']:g}], validated [0, {g['bond_max_validated']:g}] "
          "(above: status approximate)")
    h = g.get("holdout")
    if h:
        print(f"    held-out direct Evolver points with gravity ({h['n_cases']} cases); "
              f"threshold {h['threshold']:.3g} "
              f"({h['threshold_source']}):")
        for b, e, f, n in zip(h["bonds"], h["max_error_by_bond"],
                              h["max_effect_error_by_bond"], h["n_cases_by_bond"]):
            print(f"      Bo = {b:<5g} max error {e:.3g}, of the gravity effect alone {f:.3g}"
                  f" (relative to the largest grain force; {n} cases answered)")
    skipped = int(ds.attrs.get("gravity_holdout_cases_skipped", 0))
    if skipped:
        print(f"    {skipped} held-out gravity case(s) outside the table's grid: skipped "
              "(not computed, not in the error model)")


def _print_header(ds, path, axes):
    from capbridge.tables.netcdf_io import checksum_state

    print(f"table: {path}")
    print(f"  {ds.attrs.get('title', '')}")
    print(f"  made by: {ds.attrs.get('capbridge_command')}")
    print(f"  source commit: {ds.attrs.get('git_commit', 'not recorded')}; table checksum: "
          f"{checksum_state(ds)}")
    for name in axes:
        c = ds[name].values
        print(f"  {name:7s} {len(c):3d} values in [{c.min():g}, {c.max():g}]  "
              f"({ds[name].attrs.get('long_name', '')})")


def _print_holdout(ds):
    print("  error model (held-out points):")
    for k, v in sorted(ds.attrs.items()):
        if k.startswith("holdout_") and k not in ("holdout_description",
                                                  "holdout_evolver_settings"):
            print(f"    {k}: {v:.3g}" if isinstance(v, float) else f"    {k}: {v}")
    if "holdout_description" in ds.attrs:
        print(f"    ({ds.attrs['holdout_description']})")


def _info_triplet(ds, path):
    _print_header(ds, path, ("d12", "d13", "d23", "theta", "v"))
    st = ds["status"].values
    counts = ", ".join(f"{status_name(c)} {int((st == c).sum())}" for c in np.unique(st))
    print(f"  points: {st.size} ({counts}); Evolver settings: "
          f"{ds.attrs.get('evolver_settings')}")
    ok = np.isin(st, (Status.CONVERGED, Status.ABOVE_TOLERANCE))
    if ok.any():
        cpu = ds["cpu_time"].values[ok]
        err = ds["force_error_rel"].values[ok]
        print(f"  per point: median {np.median(cpu):.1f} CPU s; estimated force error "
              f"median {np.nanmedian(err):.2%}, max {np.nanmax(err):.2%}")
    _print_holdout(ds)
    _info_triplet_gravity(ds, path)
    return 0


def _info_generic(ds, path):
    _print_header(ds, path, [d for d in ds.dims if d in ds.coords
                             and not d.startswith("heldout")])
    for k, v in sorted(ds.attrs.items()):
        if "error" in k and not isinstance(v, str) or k.startswith("interpolation_error"):
            print(f"    {k}: {v}")
    return 0


def _holdout_attrs(attrs, h, quantity, tag):
    """Write one holdout check (median, max relative error of ``quantity``, n) as
    table attributes ``holdout_{median,max}_rel_error_{quantity}_{tag}``,
    ``holdout_n_{tag}``."""
    attrs[f"holdout_median_rel_error_{quantity}_{tag}"] = h["median_rel_error"]
    attrs[f"holdout_max_rel_error_{quantity}_{tag}"] = h["max_rel_error"]
    attrs[f"holdout_n_{tag}"] = h["n"]


def _gravity_holdout_attrs(attrs, h):
    """The doublet table's held-out check with gravity (:func:`~capbridge.surrogate.
    doublet.gravity_holdout_errors`) as ``gravity_holdout_*`` attributes, one value per
    Bo of ``gravity_holdout_bonds``."""
    for k in ("bonds", "max_error", "median_error", "max_effect_error",
              "max_effect_error_converged", "n", "n_approximate", "n_exact_failed"):
        attrs[f"gravity_holdout_{k}"] = np.asarray(h[k], int if k.startswith("n") else float)
    attrs["gravity_holdout_estimate_ratio_max"] = float(h["estimate_ratio_max"])
    attrs["gravity_holdout_description"] = (
        f"{h['n_points']} random points (theta, log V* over the response's sub-grid, "
        f"s in [{h['exclude_band']:g}, 1], every ratio in turn), gravity along the axis "
        "both ways, against the exact axisymmetric solver: largest error over the two "
        "grains relative to the exact attraction at Bo = 0; effect: of the gravity part "
        "F(b) - F(0) alone; converged: lookups whose own estimate gravity_error is below "
        "gravity_response_rtol; estimate_ratio_max: the largest effect error over that "
        "estimate (interpolation between the response's nodes is not in the estimate)")


def _command_line(args):
    import shlex

    words = getattr(args, "argv", sys.argv[1:])
    return "capbridge " + " ".join(shlex.quote(w) for w in words)


def _load_triplet_surrogate(path, coalescence_table=None, out_of_range="raise"):
    from capbridge.surrogate.triplet import TripletSurrogate

    path = Path(path)
    if not path.exists():
        raise CapbridgeInputError(f"triplet table {path} not found; make it with "
                                  "`capbridge generate triplet`")
    coal = coalescence_table
    if coal is None and DEFAULT_COALESCENCE_TABLE.exists():
        coal = DEFAULT_COALESCENCE_TABLE
    return TripletSurrogate(out_of_range=out_of_range, clip_hint="--clip").fit(
        path, coalescence_table=coal)


#: lookup triplet: CSV columns read and written
TRIPLET_INPUTS = ("d12", "d13", "d23", "V", "theta")
TRIPLET_OUTPUTS = csv_columns(TRIPLET_SURROGATE_OUTPUTS)
TRIPLET_RESERVED = tuple(TRIPLET_OUTPUTS.values()) + ("status", "lower_energy_state")


#: lookup triplet --bond: force vectors on grains 1, 2, 3 (table frame of the gaps)
TRIPLET_VECTOR_COLUMNS = tuple(f"F{g}{c}" for g in (1, 2, 3) for c in "xyz")


def _triplet_vectors(sur, x, bond, direction):
    """Force vectors with gravity for CSV rows of gaps: the centres of each row in the
    table frame (:func:`capbridge.solvers.triplet.triplet_geometry`: grains 2 and 3 on
    the x axis, grain 1 at z > 0), gravity given in that frame."""
    from capbridge.solvers.triplet import triplet_geometry

    centres = np.stack([triplet_geometry(a, b, c).centres
                        for a, b, c in zip(x["d12"], x["d13"], x["d23"])])
    return sur.predict_vectors(centres, x["V"], x["theta"], bond=bond, gravity=direction)


def cmd_lookup_triplet(args):
    import pandas as pd

    from capbridge.surrogate.triplet import LOWER_ENERGY_STATES
    from capbridge.tabular_io import check_new_output, read_points_csv

    from capbridge.surrogate.triplet import BOND_MAX

    bond, direction = parse_gravity(args.bond, args.gravity, BOND_MAX,
                                    "the surrogates' range")
    reserved = TRIPLET_RESERVED + (TRIPLET_VECTOR_COLUMNS if args.bond is not None else ())
    columns, x = read_points_csv(args.input, TRIPLET_INPUTS, (), reserved)
    check_new_output(args.output, inputs=[args.input], overwrite=args.overwrite)
    sur = _load_triplet_surrogate(args.table, args.coalescence_table,
                                  "clip" if args.clip else "raise")
    if args.bond is not None:
        r = _triplet_vectors(sur, x, bond, direction)
    else:
        r = sur.predict(x["d12"], x["d13"], x["d23"], x["V"], x["theta"])
    df = pd.DataFrame(columns)
    if args.bond is not None:
        for g in range(3):
            for k, c in enumerate("xyz"):
                df[f"F{g + 1}{c}"] = r["forces"][:, g, k]
    for key, col in TRIPLET_OUTPUTS.items():
        df[col] = r[key]
    df["lower_energy_state"] = [LOWER_ENERGY_STATES[int(c)] for c in r["lower_energy_state"]]
    df["status"] = [status_name(c) for c in r["status"]]
    df.to_csv(args.output, index=False)
    print(f"wrote {len(df)} rows to {args.output}", file=sys.stderr)
    return 0


def cmd_solve_triplet(args):
    from capbridge.solvers.triplet import triplet_geometry
    from capbridge.solvers.triplet_evolver import evolver_triplet

    geom = triplet_geometry(args.d12, args.d13, args.d23)
    V = float(check_range("--V", args.V, 0.0, np.inf, low_open=True,
                          hint="total liquid volume V* = V/r^3"))
    from capbridge.solvers.young_laplace_gravity import BOND_MAX as SOLVER_BOND_MAX

    theta = float(check_range("--theta", args.theta, 0.0, 90.0, high_open=True,
                              units=" deg"))
    bond, direction = parse_gravity(args.bond, args.gravity, SOLVER_BOND_MAX,
                                    "the solvers' range")
    kw = {} if args.bond is None else {"bond": bond, "gravity_dir": tuple(direction)}
    r = evolver_triplet(V, geom, theta, "coalesced", max_refine=args.max_refine,
                        inspect_mesh=False, **kw)
    out = {"d12": geom.d12, "d13": geom.d13, "d23": geom.d23, "V": V, "theta": theta,
           "bond": bond, "gravity": None if direction is None else direction.tolist(),
           "status": r["status"], "reason": r["reason"],
           "centres": np.round(geom.centres, 12).tolist(),
           "frame": "grains 2 and 3 on the x axis symmetric about x = 0, grain 1 at z > 0"
                    " (gravity: the direction it pulls, in this frame)",
           "forces": r["forces"], "force_error": r["force_error"],
           "force_error_rel": r["force_error_rel"],
           "pair_forces": r["pair_forces"], "pair_residual": r["pair_residual"],
           "pressure": r["pressure"], "energy": r["energy_extrapolated"],
           "energy_error": r["energy_error"], "refinement": r["refinement"],
           "n_facets": r["n_facets"], "cpu_time": r["cpu_time"], "warnings": r["warnings"],
           "units": "dimensionless by r and gamma: F* = F/(2 pi gamma r) (attraction > 0 "
                    "for pair forces), P* = dp r/gamma, E* = E/(gamma r^2)"}
    print(json.dumps(_json_tree(out), indent=1))
    return 0 if r["status_code"] in (Status.CONVERGED, Status.ABOVE_TOLERANCE) else 3


#: held-out Evolver points of `generate triplet` by default (full, --quick)
TRIPLET_HOLDOUT = {False: 12, True: 2}


def cmd_generate_triplet(args):
    from capbridge.tables.netcdf_io import check_table_target
    from capbridge.tables.triplet_gravity import GravityPlan
    from capbridge.tables.triplet import (EvolverPlan, TripletGrid,
                                                   build_triplet_table, save_triplet_table,
                                                   table_axes)
    from capbridge.surrogate.triplet import TripletSurrogate, holdout_errors

    grid = TripletGrid.shipped(args.quick)
    plan = EvolverPlan.shipped(args.quick)
    gravity = GravityPlan.shipped(args.quick)
    if args.holdout is None:
        args.holdout = TRIPLET_HOLDOUT[bool(args.quick)]
    # before hours of Evolver: can the table be written, would it replace another grid?
    check_table_target(args.output, table_axes(grid, args.holdout, gravity),
                       overwrite=args.overwrite, flag="--overwrite")
    command = args.command or _command_line(args)
    ds = build_triplet_table(grid, plan=plan, n_holdout=args.holdout,
                             checkpoint_dir=args.checkpoint_dir, n_jobs=args.jobs,
                             scheduler=args.scheduler, progress=not args.no_progress,
                             command=command, gravity=gravity,
                             worker_timeout=args.worker_timeout)
    coal = args.coalescence_table
    if coal is None and DEFAULT_COALESCENCE_TABLE.exists() and not args.quick:
        coal = DEFAULT_COALESCENCE_TABLE
    if args.holdout:
        sur = TripletSurrogate().fit(ds, coalescence_table=coal)
        for by in ("volume", "v"):
            _holdout_attrs(ds.attrs, holdout_errors(sur, by=by), "pair_force", f"by_{by}")
        ds.attrs["holdout_description"] = (
            "relative error of the surrogate's pair forces f12, f13, f23 (cubic refinement, "
            "default settings) against held-out Surface Evolver points one refinement level "
            "finer than the table, at random canonical geometries, theta and v inside the "
            "grid; by_volume: looked up at the total volume (includes the error of V_coal), "
            "by_v: at the volume ratio (the force interpolation alone)")
    save_triplet_table(ds, args.output, command=command, overwrite=args.overwrite)
    print(f"wrote {args.output}", file=sys.stderr)
    return cmd_info_table(argparse.Namespace(table=args.output))


def cmd_generate_coalescence(args):
    from capbridge.tables.coalescence import run_from_args

    if args.output is None and not args.quick:
        args.output = str(DEFAULT_COALESCENCE_TABLE)
    return run_from_args(args, command=_command_line(args))


def cmd_export_yade(args):
    from capbridge.yade.yade_export import export_from_solver

    out = Path(args.directory)
    if out.exists() and not out.is_dir():
        raise CapbridgeInputError(f"--directory {out} is a file, not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CapbridgeInputError(f"--directory {out} cannot be made: {exc.strerror or exc}") from None
    from capbridge.tabular_io import check_output_path

    check_output_path(out / "probe", what="--directory")
    for theta in args.theta:
        _, paths = export_from_solver(out, theta, n_gaps=args.n_gaps)
        for p in (paths if isinstance(paths, (list, tuple)) else [paths]):
            print(p)
    return 0


def cmd_demo(args):
    from capbridge.cli.demo import run_demo

    table = Path(args.table)
    if not table.exists():
        raise CapbridgeInputError(f"table {table} not found; make it with `capbridge generate doublet`")
    triplet = None if args.triplet_table in ("", "none") else Path(args.triplet_table)
    if triplet is not None and not triplet.exists():
        raise CapbridgeInputError(f"triplet table {triplet} not found; make it with "
                                  "`capbridge generate triplet` or give --triplet-table none")
    coal = DEFAULT_COALESCENCE_TABLE if DEFAULT_COALESCENCE_TABLE.exists() else None
    out = Path(args.output_dir)
    if out.exists() and not out.is_dir():
        raise CapbridgeInputError(f"--output-dir {out} is a file, not a directory")
    return run_demo(args.table, args.output_dir, triplet_table=triplet,
                    coalescence_table=coal, packing=not args.no_yade)


def cmd_coalescence(args):
    from capbridge.solvers.triplet import (CRITERIA, find_coalescence, parse_bridges,
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
    if args.radius is not None:
        from capbridge.surrogate.doublet import SI_RADIUS_RANGE

        check_range("--radius", args.radius, *SI_RADIUS_RANGE, units=" m",
                    hint="the grain radius in metres (1 mm is 1e-3)")
    geom = triplet_geometry(args.d12, args.d13, args.d23)
    try:
        r = find_coalescence(geom, theta, bridges, fractions,
                             v_max=V_MAX_DEFAULT if args.v_max is None else args.v_max)
    except CapbridgeInputError as exc:
        if "v_max" not in str(exc):
            raise
        if args.v_max is None:
            raise CapbridgeInputError(
                f"at these gaps the bridges first exist at volumes above the default search "
                f"limit --v-max {V_MAX_DEFAULT:g} ({exc}); give a larger --v-max") from None
        raise CapbridgeInputError(str(exc).replace("v_max", "--v-max")) from None
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
        from capbridge.solvers.triplet_evolver import energy_comparison

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

    study = importlib.import_module(f"capbridge.studies.{args.study}")
    ck = args.checkpoint_dir
    if ck is None and not args.quick:
        ck = f".sweep-checkpoints/{args.study}"
    s = study.run(args.output_dir, quick=args.quick, checkpoint_dir=ck,
                     progress=not args.no_progress, max_refine=args.max_refine)
    print(json.dumps({"output_dir": args.output_dir, "files": s.get("files", []),
                      "claims": str(Path(args.output_dir) / "CLAIMS.md"),
                      "timings_s": s.get("timings_s", {})}, indent=1))
    return 0


V_MAX_DEFAULT = 2.5
#: global option (anywhere on the line, like --debug): use unverified tables
ALLOW_UNVERIFIED_OPTION = "--allow-unverified-table"

# a negative number in any float notation (argparse's own pattern misses "-1e6")
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$"
                              # or a vector x,y,z that starts with one (--gravity -1,0,0)
                              r"|^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(,[-+]?[\d.eE+-]*)+$",
                              re.IGNORECASE)


class _Parser(argparse.ArgumentParser):
    """argparse with negative numbers in exponent form as values, and one-line errors."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self._negative_number_matcher = _NEGATIVE_NUMBER

    def error(self, message):
        print(f"capbridge: error: {self.prog}: {message} (see `{self.prog} --help`)",
              file=sys.stderr)
        sys.exit(2)


def _number(low=-np.inf, high=np.inf, low_open=False, integer=False, hint=""):
    """argparse type: a finite number in [low, high] (``low_open``: (low, high]);
    ``hint`` ends the message of a value outside the range (why the range)."""
    def parse(text):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            kind = "an integer" if integer else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {kind}") from None
        if not np.isfinite(v) or v < low or v > high or (low_open and v == low):
            raise argparse.ArgumentTypeError(
                f"{v!r} is outside the allowed range {interval_text(low, high, low_open)}"
                + (f" ({hint})" if hint else ""))
        return v
    return parse


#: --max-refine of the Evolver solves: level 2 at least (below, no error estimate)
EVOLVER_REFINE = (2, 6)
_REFINE_HINT = ("Surface Evolver results need level 2 at least: the error estimate "
                "compares the forces of levels 1 and 2")


def _add_triplet_gaps(parser):
    """The three gaps of a triplet (--d12, --d13, --d23), as every triplet command takes them."""
    for i, j in ((1, 2), (1, 3), (2, 3)):
        parser.add_argument(f"--d{i}{j}", type=float, required=True,
                            help=f"gap between grains {i} and {j}, d/r")


def build_parser():
    p = _Parser(prog="capbridge", description=__doc__,
                epilog="--debug (anywhere): show the traceback of an error; "
                       "--allow-unverified-table (anywhere): use tables without a table "
                       "checksum (older capbridge, or edited) with a warning instead of "
                       "refusing them (their physical checks still apply)")
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
    sd.add_argument("--bond", type=float, default=None, metavar="BO",
                    help="gravity on the liquid: Bond number Bo = drho g R1^2/gamma in [0, 5]"
                         " (needs --V); the output then has the force vectors F1, F2 on "
                         "both grains")
    sd.add_argument("--gravity", default=None, metavar="X,Y,Z",
                    help="direction along which gravity pulls (default 0,0,-1), frame: "
                         "grain 1 at the origin, grain 2 on +x.  Along the axis (+-1,0,0): "
                         "the exact axisymmetric solver; any other direction: Surface "
                         "Evolver (much slower)")
    sd.add_argument("--max-refine", type=_number(*EVOLVER_REFINE, integer=True,
                                                 hint=_REFINE_HINT), default=3,
                    help="Evolver refinement level in [2, 6] (only for --gravity off the "
                         "axis; below 2 there is no error estimate, so it is refused)")
    sd.set_defaults(func=cmd_solve_doublet)
    st = solve.add_parser("triplet", help="one Surface Evolver minimisation of a coalesced "
                          "liquid body on three equal spheres (JSON out)")
    _add_triplet_gaps(st)
    st.add_argument("--V", type=float, required=True, help="total volume V* = V/r^3")
    st.add_argument("--theta", type=float, required=True, help="contact angle [deg], in [0, 90)")
    st.add_argument("--max-refine", type=_number(*EVOLVER_REFINE, integer=True,
                                                 hint=_REFINE_HINT), default=3,
                    help="finest Evolver refinement level in [2, 6] (default 3, as the "
                         "table); level 1 alone has no error estimate (forces ~5 %% off), "
                         "so it is refused")
    st.add_argument("--bond", type=float, default=None, metavar="BO",
                    help="gravity on the liquid: Bond number Bo = drho g r^2/gamma in [0, 5]")
    st.add_argument("--gravity", default=None, metavar="X,Y,Z",
                    help="direction along which gravity pulls (default 0,0,-1) in the "
                         "table frame: grains 2 and 3 on the x axis, grain 1 at z > 0")
    st.set_defaults(func=cmd_solve_triplet)

    look = sub.add_parser("lookup", help="surrogate lookups").add_subparsers(dest="what", required=True)
    ld = look.add_parser("doublet", help="interpolate forces for the rows of a CSV")
    ld.add_argument("--input", required=True, help="CSV with columns d, V, theta [, ratio]")
    ld.add_argument("--output", required=True)
    ld.add_argument("--table", default=str(DEFAULT_TABLE))
    ld.add_argument("--clip", action="store_true",
                    help="volumes outside the table: answer at its edge, same d*/d*_rupt "
                         "(status extrapolated, or ruptured) instead of failing")
    ld.add_argument("--overwrite", action="store_true", help="replace an existing --output")
    ld.add_argument("--bond", type=float, default=None, metavar="BO",
                    help="gravity on the liquid: Bond number Bo = drho g R1^2/gamma in "
                         "[0, 2.5] (the table needs its gravity response); the columns are "
                         "then the force vectors F1x..F2z on grain 1 and 2, F (the attraction "
                         "without gravity), d_rupt (with gravity) and status: P, beta1, "
                         "beta2, which gravity changes, are not given")
    ld.add_argument("--gravity", default=None, metavar="X,Y,Z",
                    help="direction along which gravity pulls (default 0,0,-1), frame: "
                         "grain 1 at the origin, grain 2 on +x")
    ld.set_defaults(func=cmd_lookup_doublet)
    lt = look.add_parser("triplet", help="coalesced-triplet pair forces for the rows of a CSV")
    lt.add_argument("--input", required=True, help="CSV with columns d12, d13, d23, V, theta "
                    "(gaps d/r, V* = V/r^3, theta in degrees)")
    lt.add_argument("--output", required=True)
    lt.add_argument("--table", default=str(DEFAULT_TRIPLET_TABLE))
    lt.add_argument("--coalescence-table", default=None,
                    help=f"exact V_coal over the geometry (default {DEFAULT_COALESCENCE_TABLE.name} "
                         "if present)")
    lt.add_argument("--clip", action="store_true",
                    help="volumes above the table: answer at its largest V/V_coal (status "
                         "extrapolated); below it: no number (no_equilibrium or out_of_range)")
    lt.add_argument("--overwrite", action="store_true", help="replace an existing --output")
    lt.add_argument("--bond", type=float, default=None, metavar="BO",
                    help="gravity on the liquid: Bond number Bo = drho g r^2/gamma in [0, 2.5]"
                         " (the table needs its gravity response); adds the force vectors "
                         "F1x..F3z on the three grains (f12, f13, f23 stay without gravity)")
    lt.add_argument("--gravity", default=None, metavar="X,Y,Z",
                    help="direction along which gravity pulls (default 0,0,-1) in the table "
                         "frame of each row: grains 2 and 3 on the x axis (3 at +x), grain 1 "
                         "at z > 0, centres in the plane y = 0")
    lt.set_defaults(func=cmd_lookup_triplet)

    gen = sub.add_parser("generate", help="regenerate tables").add_subparsers(dest="what", required=True)
    gd = gen.add_parser("doublet", help="sweep the exact solver into a netCDF table")
    gd.add_argument("--output", default=str(DEFAULT_TABLE))
    gd.add_argument("--quick", action="store_true", help="small grid (tests)")
    gd.add_argument("--overwrite", action="store_true",
                    help="replace an existing --output of another grid")
    gd.add_argument("--ratios", type=_number(1.0, 1e3), nargs="+", default=None,
                    help="radius ratios R2/R1 >= 1")
    gd.add_argument("--jobs", type=_number(1, 4096, integer=True), default=None,
                    help="worker processes (default: all cores)")
    gd.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    gd.add_argument("--worker-timeout", type=_number(0, np.inf, low_open=True), default=600.0,
                    help="Dask: seconds without any worker before the sweep fails (default 600)")
    gd.add_argument("--checkpoint-dir", default=None, help="resumable checkpoints here")
    gd.add_argument("--holdout", type=_number(10, 10**7, integer=True), default=600,
                    help="held-out exact points for the error model (>= 10)")
    gd.add_argument("--gravity-holdout", type=_number(2, 10**5, integer=True), default=40,
                    help="held-out points for the check of the gravity response (each at 5 "
                         "Bond numbers, gravity along the axis both ways; exact solver)")
    gd.add_argument("--no-progress", action="store_true")
    gd.add_argument("--command", default=None, help=argparse.SUPPRESS)
    gd.set_defaults(func=cmd_generate_doublet)
    gt = gen.add_parser("triplet", help="Surface Evolver sweep of coalesced triplets into a "
                        "netCDF table (hours; resumable)")
    gt.add_argument("--output", default=str(DEFAULT_TRIPLET_TABLE))
    gt.add_argument("--quick", action="store_true",
                    help="small grid (tests; ~4.5 CPU minutes, 2-4 minutes on 2 cores): "
                         "16 points at Evolver level 2 (status above_tolerance: ~3 %% "
                         "estimated force error), the gravity response at level 1, 2 "
                         "held-out points, one held-out gravity case")
    gt.add_argument("--overwrite", action="store_true",
                    help="replace an existing --output of another grid")
    gt.add_argument("--jobs", type=_number(1, 4096, integer=True), default=None,
                    help="worker processes (default: all cores)")
    gt.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    gt.add_argument("--worker-timeout", type=_number(0, np.inf, low_open=True), default=600.0,
                    help="Dask: seconds without any worker before the sweep fails (default 600)")
    gt.add_argument("--checkpoint-dir", default=None, help="resumable checkpoints here")
    gt.add_argument("--holdout", type=_number(0, 10**5, integer=True), default=None,
                    help="held-out Evolver points one level finer, for the error model "
                         f"(default {TRIPLET_HOLDOUT[False]}, with --quick "
                         f"{TRIPLET_HOLDOUT[True]})")
    gt.add_argument("--coalescence-table", default=None,
                    help="exact V_coal table for the error model (default the shipped one)")
    gt.add_argument("--no-progress", action="store_true")
    gt.add_argument("--command", default=None, help=argparse.SUPPRESS)
    gt.set_defaults(func=cmd_generate_triplet)
    from capbridge.tables.coalescence import add_arguments

    gc = add_arguments(gen.add_parser(
        "coalescence", help="exact coalescence volumes of three equal spheres over the "
                            "geometry and theta into a netCDF table (minutes)"))
    gc.set_defaults(func=cmd_generate_coalescence)

    ex = sub.add_parser("export-yade", help="write YADE's native capillary files (M(r=...) sets, "
                        "CapillarityEngine input) from the exact suction-controlled solver")
    ex.add_argument("--directory", required=True)
    ex.add_argument("--theta", type=_number(0.0, 90.0), nargs="+", default=[0.0],
                    help="contact angles [deg]")
    ex.add_argument("--n-gaps", type=_number(3, 10**5, integer=True), default=61)
    ex.set_defaults(func=cmd_export_yade)

    info = sub.add_parser("info", help="describe a table and its error model")
    info.add_argument("--table", default=None,
                      help="a table (default: every shipped table in data/)")
    info.set_defaults(func=cmd_info_table)

    demo = sub.add_parser("demo", help="the main job on the shipped tables: doublets beside "
                          "the exact solution, the paper's coalesced triplet, a wet packing "
                          "in YADE (figures and CSV in --output-dir)")
    demo.add_argument("--table", default=str(DEFAULT_TABLE), help="doublet table")
    demo.add_argument("--triplet-table", default=str(DEFAULT_TRIPLET_TABLE),
                      help="triplet table ('none': skip the triplets)")
    demo.add_argument("--no-yade", action="store_true",
                      help="skip the wet packing in YADE (skipped anyway without YADE)")
    demo.add_argument("--output-dir", default="out")
    demo.set_defaults(func=cmd_demo)

    co = sub.add_parser("coalescence", help="volume at which separate bridges in a triplet of "
                        "equal spheres coalesce (exact shapes; JSON out)")
    _add_triplet_gaps(co)
    co.add_argument("--theta", type=float, required=True, help="contact angle [deg], in [0, 90)")
    co.add_argument("--theta2", type=float, default=None, help="contact angle on grain 2 [deg]")
    co.add_argument("--theta3", type=float, default=None, help="contact angle on grain 3 [deg]")
    co.add_argument("--bridges", default="12,13",
                    help="bridge layout: grain pairs, e.g. 12,13 (default) or 12,13,23")
    co.add_argument("--fractions", default=None,
                    help="share of the total volume held by each bridge, e.g. 0.5,0.5 (default equal)")
    co.add_argument("--v-max", type=float, default=None,
                    help=f"largest total V* searched (default {V_MAX_DEFAULT:g})")
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
    rep.add_argument("--max-refine", type=_number(0, 8, integer=True), default=None,
                     help="Evolver refinement level")
    rep.add_argument("--no-progress", action="store_true")
    rep.set_defaults(func=cmd_reproduce)
    return p


def main(argv=None):
    """Run the command line; return the exit status (0 ok, 1 internal error, 2 user error,
    3 not converged or failed chunks, 130 interrupted)."""
    from capbridge.tables.sweep import SweepFailedError

    from capbridge.tables.netcdf_io import allow_unverified_tables

    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    allow = ALLOW_UNVERIFIED_OPTION in argv
    argv = [a for a in argv if a not in ("--debug", ALLOW_UNVERIFIED_OPTION)]
    _configure_logging(debug)
    args = build_parser().parse_args(argv)
    args.argv = argv + ([ALLOW_UNVERIFIED_OPTION] if allow else [])
    try:
        with allow_unverified_tables(allow):
            return args.func(args)
    except Exception as exc:
        if debug:
            raise
        if isinstance(exc, (CapbridgeInputError, OSError)):
            code, text = 2, _one_line(exc)
        elif isinstance(exc, SweepFailedError):
            code, text = 3, _one_line(exc)
        else:
            code, text = 1, (f"internal error ({type(exc).__name__}: {_one_line(exc)}); "
                             f"rerun with --debug for the traceback")
        print(f"capbridge: error: {text}", file=sys.stderr)
        return code
    except KeyboardInterrupt:
        if debug:
            raise
        print("capbridge: interrupted (finished chunks are kept in the checkpoint directory, "
              "if any: rerun to continue)", file=sys.stderr)
        return 130


class _LowerLevelFormatter:
    """``capbridge: warning: ...`` (lower-case level, like the error line)."""

    def __init__(self, fmt):
        import logging

        self._fmt = logging.Formatter(fmt)

    def format(self, record):
        import copy

        record = copy.copy(record)
        record.levelname = record.levelname.lower()
        return self._fmt.format(record)


def _configure_logging(debug):
    """Warnings of the library as ``capbridge: warning: ...`` lines (tracebacks of failed
    chunks only with ``--debug``); left alone if the caller configured logging."""
    import logging

    root, lib = logging.getLogger(), logging.getLogger("capbridge")
    if root.handlers or lib.handlers:
        return
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_LowerLevelFormatter("capbridge: %(levelname)s: %(message)s"))
    lib.addHandler(handler)
    lib.setLevel(logging.DEBUG if debug else logging.WARNING)
    lib.propagate = False


def _one_line(exc):
    text = str(exc) or type(exc).__name__
    if isinstance(exc, OSError) and exc.filename is not None:
        text = f"{exc.filename}: {exc.strerror or text}"
    return " ".join(text.split())


if __name__ == "__main__":
    sys.exit(main())
