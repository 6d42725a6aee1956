"""The ``capbridge`` command line: its grammar (:func:`build_parser`) and :func:`main`.

The commands, their options and the function that runs each are declared here; each
command is a thin module of its own that reads its options, calls the library and
prints (:mod:`~capbridge.cli.solve`, :mod:`~capbridge.cli.lookup`,
:mod:`~capbridge.cli.generate`, :mod:`~capbridge.cli.info`, :mod:`~capbridge.cli.export`,
:mod:`~capbridge.cli.demo`, :mod:`~capbridge.cli.coalescence`,
:mod:`~capbridge.cli.reproduce`); the parser's pieces are in :mod:`~capbridge.cli.parser`.
The names those modules define that were defined here before are imported here too:
users import them from here.  What the command line promises is :data:`DESCRIPTION`.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from capbridge.cli.coalescence import V_MAX_DEFAULT, cmd_coalescence
from capbridge.cli.demo import cmd_demo
from capbridge.cli.export import cmd_export_yade
from capbridge.cli.generate import (TRIPLET_HOLDOUT, cmd_generate_coalescence,
                                    cmd_generate_doublet, cmd_generate_triplet)
from capbridge.cli.info import cmd_info_table
from capbridge.cli.lookup import (DOUBLET_VECTOR_COLUMNS, LOOKUP_INPUTS, LOOKUP_OPTIONAL,
                                  LOOKUP_OUTPUTS, LOOKUP_RESERVED, TRIPLET_INPUTS,
                                  TRIPLET_OUTPUTS, TRIPLET_RESERVED, TRIPLET_VECTOR_COLUMNS,
                                  cmd_lookup_doublet, cmd_lookup_triplet)
from capbridge.cli.messages import configure_logging, one_line
from capbridge.cli.parser import (ALLOW_UNVERIFIED_OPTION, CommandLineParser,
                                  add_evolver_gravity_options, add_shape_options,
                                  add_triplet_gaps, evolver_refine_level,
                                  number_in_range, parse_gravity)
from capbridge.cli.reproduce import cmd_reproduce
from capbridge.cli.solve import cmd_solve_cluster, cmd_solve_doublet, cmd_solve_triplet
from capbridge.status import HAS_RESULT
from capbridge.studies import STUDIES
from capbridge.surrogate.doublet_points import lookup_points
from capbridge.surrogate.error_model import HOLDOUT_BAND
from capbridge.tables import COALESCENCE_TABLE as DEFAULT_COALESCENCE_TABLE
from capbridge.tables import DOUBLET_TABLE as DEFAULT_TABLE
from capbridge.tables import TRIPLET_TABLE as DEFAULT_TRIPLET_TABLE
from capbridge.tables.coalescence import add_arguments as add_coalescence_arguments
from capbridge.tables.netcdf_io import allow_unverified_tables
from capbridge.tables.sweep import SweepFailedError
from capbridge.validation import CapbridgeInputError

#: the opening of ``capbridge --help``
DESCRIPTION = """``capbridge`` command line: solve, lookup, generate, info, demo.

Every user error ends in one line ``capbridge: error: ...`` and exit status 2 (``--debug``
anywhere on the line shows the traceback instead); a sweep with failed chunks exits 3
("N chunks failed, rerun to retry"), an internal error 1.  ``--allow-unverified-table``
anywhere on the line uses tables without a table checksum (older or edited files), with
one warning line each, instead of refusing them.
"""

__all__ = ["main", "build_parser", "DEFAULT_TABLE", "DEFAULT_TRIPLET_TABLE",
           "DEFAULT_COALESCENCE_TABLE", "ALLOW_UNVERIFIED_OPTION", "parse_gravity",
           "lookup_points", "HAS_RESULT", "STUDIES", "HOLDOUT_BAND", "TRIPLET_HOLDOUT",
           "V_MAX_DEFAULT", "LOOKUP_INPUTS", "LOOKUP_OPTIONAL", "LOOKUP_OUTPUTS",
           "LOOKUP_RESERVED", "DOUBLET_VECTOR_COLUMNS", "TRIPLET_INPUTS", "TRIPLET_OUTPUTS",
           "TRIPLET_RESERVED", "TRIPLET_VECTOR_COLUMNS", "cmd_solve_doublet",
           "cmd_solve_triplet", "cmd_solve_cluster", "cmd_lookup_doublet",
           "cmd_lookup_triplet", "cmd_generate_doublet", "cmd_generate_triplet", "cmd_generate_coalescence",
           "cmd_info_table", "cmd_export_yade", "cmd_demo", "cmd_coalescence",
           "cmd_reproduce"]


def build_parser():
    """The ``capbridge`` parser: every command, its options, and (``func``) the function
    that runs it.  The table defaults and the functions are read from this module when
    it is called, so that pointing one of its names elsewhere (a test, a wrapper) is
    enough."""
    p = CommandLineParser(prog="capbridge", description=DESCRIPTION,
                          epilog="--debug (anywhere): show the traceback of an error; "
                                 "--allow-unverified-table (anywhere): use tables without "
                                 "a table checksum (older capbridge, or edited) with a "
                                 "warning instead of refusing them (their physical checks "
                                 "still apply)")
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
    sd.add_argument("--max-refine", type=evolver_refine_level(), default=3,
                    help="Evolver refinement level in [2, 6] (only for --gravity off the "
                         "axis; below 2 there is no error estimate, so it is refused)")
    add_shape_options(sd, "R1", "exact profile revolved; Surface Evolver's surface with "
                      "gravity off the axis; not with gravity along the axis")
    sd.set_defaults(func=cmd_solve_doublet)
    st = solve.add_parser("triplet", help="one Surface Evolver minimisation of a coalesced "
                          "liquid body on three equal spheres (JSON out)")
    add_triplet_gaps(st)
    st.add_argument("--V", type=float, required=True, help="total volume V* = V/r^3")
    st.add_argument("--theta", type=float, required=True, help="contact angle [deg], in [0, 90)")
    st.add_argument("--max-refine", type=evolver_refine_level(), default=3,
                    help="finest Evolver refinement level in [2, 6] (default 3, as the "
                         "table); level 1 alone has no error estimate (forces ~5 %% off), "
                         "so it is refused")
    add_evolver_gravity_options(st, "the table frame: grains 2 and 3 on the x axis, "
                                    "grain 1 at z > 0")
    add_shape_options(st, "r")
    st.set_defaults(func=cmd_solve_triplet)
    sc = solve.add_parser("cluster", help="one Surface Evolver minimisation of one liquid "
                          "body wetting N grains read from a CSV file (JSON out)")
    sc.add_argument("--grains", required=True, metavar="GRAINS.csv",
                    help="CSV, one row per grain, columns x, y, z, radius in units of the "
                         "smallest radius (at least 2 grains, not overlapping)")
    sc.add_argument("--V", type=float, required=True,
                    help="liquid volume V* = V/r^3, r the smallest radius")
    sc.add_argument("--theta", type=float, required=True,
                    help="contact angle [deg], in [0, 90)")
    sc.add_argument("--max-refine", type=evolver_refine_level(), default=3,
                    help="finest Evolver refinement level in [2, 6] (default 3)")
    add_evolver_gravity_options(sc, "the file's frame")
    add_shape_options(sc, "r")
    sc.set_defaults(func=cmd_solve_cluster)

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
    gd.add_argument("--ratios", type=number_in_range(1.0, 1e3), nargs="+", default=None,
                    help="radius ratios R2/R1 >= 1")
    gd.add_argument("--jobs", type=number_in_range(1, 4096, integer=True), default=None,
                    help="worker processes (default: all cores)")
    gd.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    gd.add_argument("--worker-timeout", type=number_in_range(0, np.inf, low_open=True),
                    default=600.0,
                    help="Dask: seconds without any worker before the sweep fails (default 600)")
    gd.add_argument("--checkpoint-dir", default=None, help="resumable checkpoints here")
    gd.add_argument("--holdout", type=number_in_range(10, 10**7, integer=True), default=600,
                    help="held-out exact points for the error model (>= 10)")
    gd.add_argument("--gravity-holdout", type=number_in_range(2, 10**5, integer=True), default=40,
                    help="held-out points for the check of the gravity response (each at 5 "
                         "Bond numbers, gravity along the axis both ways; exact solver)")
    gd.add_argument("--no-progress", action="store_true")
    gd.add_argument("--command", default=None, help=argparse.SUPPRESS)
    gd.set_defaults(func=cmd_generate_doublet)
    gt = gen.add_parser("triplet", help="Surface Evolver sweep of coalesced triplets into a "
                        "netCDF table (hours; resumable)")
    gt.add_argument("--output", default=None,
                    help=f"the table (default {DEFAULT_TRIPLET_TABLE}; with --grid packings "
                         "triplet_table_packings.nc beside it)")
    gt.add_argument("--grid", choices=("shipped", "packings"), default="shipped",
                    help="shipped: the grid of data/triplet_table.nc (gaps 0-0.2, v "
                         "0.7-2); packings: the domain coalesced triplets of real packings "
                         "reach (bridge gaps 0-0.2, the open side to 0.6, v 0.7-5; ~1,400 "
                         "Evolver points, ~10 CPU hours with its gravity response; "
                         "checkpoints in sweeps/triplet_packings)")
    gt.add_argument("--quick", action="store_true",
                    help="small grid (tests; ~4.5 CPU minutes, 2-4 minutes on 2 cores): "
                         "16 points at Evolver level 2 (status above_tolerance: ~3 %% "
                         "estimated force error), the gravity response at level 1, 2 "
                         "held-out points, one held-out gravity case")
    gt.add_argument("--overwrite", action="store_true",
                    help="replace an existing --output of another grid")
    gt.add_argument("--jobs", type=number_in_range(1, 4096, integer=True), default=None,
                    help="worker processes (default: all cores)")
    gt.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    gt.add_argument("--worker-timeout", type=number_in_range(0, np.inf, low_open=True),
                    default=600.0,
                    help="Dask: seconds without any worker before the sweep fails (default 600)")
    gt.add_argument("--checkpoint-dir", default=None, help="resumable checkpoints here")
    gt.add_argument("--holdout", type=number_in_range(0, 10**5, integer=True), default=None,
                    help="held-out Evolver points one level finer, for the error model "
                         f"(default {TRIPLET_HOLDOUT[False]}, with --quick "
                         f"{TRIPLET_HOLDOUT[True]})")
    gt.add_argument("--coalescence-table", default=None,
                    help="exact V_coal table for the error model (default the shipped one)")
    gt.add_argument("--no-progress", action="store_true")
    gt.add_argument("--command", default=None, help=argparse.SUPPRESS)
    gt.set_defaults(func=cmd_generate_triplet)
    gc = add_coalescence_arguments(gen.add_parser(
        "coalescence", help="exact coalescence volumes of three equal spheres over the "
                            "geometry and theta into a netCDF table (minutes)"))
    gc.set_defaults(func=cmd_generate_coalescence)

    ex = sub.add_parser("export-yade", help="write YADE's native capillary files (M(r=...) sets, "
                        "CapillarityEngine input) from the exact suction-controlled solver")
    ex.add_argument("--directory", required=True)
    ex.add_argument("--theta", type=number_in_range(0.0, 90.0), nargs="+", default=[0.0],
                    help="contact angles [deg]")
    ex.add_argument("--n-gaps", type=number_in_range(3, 10**5, integer=True), default=61)
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
    add_triplet_gaps(co)
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
    rep.add_argument("--max-refine", type=number_in_range(0, 8, integer=True), default=None,
                     help="Evolver refinement level")
    rep.add_argument("--no-progress", action="store_true")
    rep.set_defaults(func=cmd_reproduce)
    return p




def main(argv=None):
    """Run the command line; return the exit status (0 ok, 1 internal error, 2 user error,
    3 not converged or failed chunks, 130 interrupted)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    allow = ALLOW_UNVERIFIED_OPTION in argv
    argv = [a for a in argv if a not in ("--debug", ALLOW_UNVERIFIED_OPTION)]
    configure_logging(debug)
    args = build_parser().parse_args(argv)
    args.argv = argv + ([ALLOW_UNVERIFIED_OPTION] if allow else [])
    try:
        with allow_unverified_tables(allow):
            return args.func(args)
    except Exception as exc:
        if debug:
            raise
        if isinstance(exc, (CapbridgeInputError, OSError)):
            code, text = 2, one_line(exc)
        elif isinstance(exc, SweepFailedError):
            code, text = 3, one_line(exc)
        else:
            code, text = 1, (f"internal error ({type(exc).__name__}: {one_line(exc)}); "
                             f"rerun with --debug for the traceback")
        print(f"capbridge: error: {text}", file=sys.stderr)
        return code
    except KeyboardInterrupt:
        if debug:
            raise
        print("capbridge: interrupted (finished chunks are kept in the checkpoint directory, "
              "if any: rerun to continue)", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
