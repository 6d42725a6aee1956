"""``capbridge generate doublet|triplet|coalescence``: build a table, check it, save it.

Each command first checks that the table can be written and would not replace a table
of another grid (before hours of work), then sweeps the solver (resumable with
``--checkpoint-dir``, on local processes or a Dask cluster), stores the table's error
model (:mod:`capbridge.surrogate.error_model`), saves it and describes it as
``capbridge info`` does.  The command line is recorded in the table.
"""
from __future__ import annotations

import argparse
import shlex
import sys

from capbridge.cli.info import cmd_info_table
from capbridge.tables import COALESCENCE_TABLE, TRIPLET_TABLE
from capbridge.validation import CapbridgeInputError

#: held-out Evolver points of `generate triplet` by default (full, --quick)
TRIPLET_HOLDOUT = {False: 12, True: 2}
#: ``generate triplet --grid packings``: held-out points (the issue's floor: 40) and the
#: default output (the first table stays where it is)
PACKINGS_HOLDOUT = 40
PACKINGS_OUTPUT = "triplet_table_packings.nc"


def command_line(args):
    """The command line that made a table, for its provenance (``capbridge ...``)."""
    words = getattr(args, "argv", sys.argv[1:])
    return "capbridge " + " ".join(shlex.quote(w) for w in words)


def cmd_generate_doublet(args):
    """The exact solver swept into a doublet table (with its gravity response)."""
    from capbridge.surrogate.error_model import store_doublet_error_model
    from capbridge.tables.doublet import (DoubletGrid, build_doublet_table, save_doublet_table,
                                          table_axes)
    from capbridge.tables.netcdf_io import check_table_target

    ratios = None if args.ratios is None else sorted(set(args.ratios))
    grid = DoubletGrid.shipped(args.quick, ratios=ratios)
    # before hours of work: can the table be written, and would it replace another grid?
    check_table_target(args.output, table_axes(grid), overwrite=args.overwrite,
                       flag="--overwrite")
    command = args.command or command_line(args)
    ds = build_doublet_table(grid, checkpoint_dir=args.checkpoint_dir, n_jobs=args.jobs,
                             scheduler=args.scheduler, progress=not args.no_progress,
                             command=command, worker_timeout=args.worker_timeout)
    store_doublet_error_model(ds, n_holdout=args.holdout,
                              n_gravity_holdout=args.gravity_holdout,
                              progress=not args.no_progress)
    save_doublet_table(ds, args.output, command=command, overwrite=args.overwrite)
    print(f"wrote {args.output}", file=sys.stderr)
    return cmd_info_table(argparse.Namespace(table=args.output))


def cmd_generate_triplet(args):
    """Surface Evolver swept into a coalesced-triplet table (with its gravity response
    and held-out points)."""
    from capbridge.surrogate.error_model import store_triplet_error_model
    from capbridge.tables.netcdf_io import check_table_target
    from capbridge.tables.triplet import (EvolverPlan, TripletGrid, build_triplet_table,
                                          save_triplet_table, table_axes)
    from capbridge.tables.triplet_gravity import GravityPlan

    packings = args.grid == "packings"
    if packings and args.quick:
        raise CapbridgeInputError("--quick is a small shipped grid: give it without "
                                  "--grid packings")
    grid = TripletGrid.packings() if packings else TripletGrid.shipped(args.quick)
    plan = EvolverPlan.shipped(args.quick)
    gravity = GravityPlan.shipped(args.quick)
    if args.output is None:
        args.output = str(TRIPLET_TABLE.with_name(PACKINGS_OUTPUT) if packings
                          else TRIPLET_TABLE)
    if args.holdout is None:
        args.holdout = PACKINGS_HOLDOUT if packings else TRIPLET_HOLDOUT[bool(args.quick)]
    # before hours of Evolver: can the table be written, would it replace another grid?
    check_table_target(args.output, table_axes(grid, args.holdout, gravity),
                       overwrite=args.overwrite, flag="--overwrite")
    command = args.command or command_line(args)
    ds = build_triplet_table(grid, plan=plan, n_holdout=args.holdout,
                             checkpoint_dir=args.checkpoint_dir, n_jobs=args.jobs,
                             scheduler=args.scheduler, progress=not args.no_progress,
                             command=command, gravity=gravity,
                             worker_timeout=args.worker_timeout)
    coal = args.coalescence_table
    # the shipped coalescence table's gaps end at 0.3: the packings grid's error model
    # uses the triplet table's own V_coal nodes unless a covering table is given
    if coal is None and COALESCENCE_TABLE.exists() and not args.quick and not packings:
        coal = COALESCENCE_TABLE
    if args.holdout:
        store_triplet_error_model(ds, coalescence_table=coal)
    save_triplet_table(ds, args.output, command=command, overwrite=args.overwrite)
    print(f"wrote {args.output}", file=sys.stderr)
    return cmd_info_table(argparse.Namespace(table=args.output))


def cmd_generate_coalescence(args):
    """The exact coalescence volumes of three equal spheres into a table
    (:func:`capbridge.tables.coalescence.run_from_args`)."""
    from capbridge.tables.coalescence import run_from_args

    if args.output is None and not args.quick:
        args.output = str(COALESCENCE_TABLE)
    return run_from_args(args, command=command_line(args))
