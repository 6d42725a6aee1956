"""``capbridge lookup doublet`` and ``capbridge lookup triplet``: the surrogates on the
rows of a CSV file, into another.

Input columns are read by name (:func:`~capbridge.tabular_io.read_points_csv`: one line
naming the row and the column of a bad cell); the output keeps them and adds the
answers, a status per row, and with ``--bond`` the force vectors with gravity.
"""
from __future__ import annotations

import sys

import numpy as np

from capbridge.cli.parser import parse_gravity
from capbridge.status import Status, status_name
from capbridge.surrogate.names import CSV_COLUMNS as COL
from capbridge.surrogate.names import DOUBLET_OUTPUTS, csv_columns
from capbridge.surrogate.names import TRIPLET_OUTPUTS as TRIPLET_SURROGATE_OUTPUTS
from capbridge.validation import CapbridgeInputError

#: lookup doublet: CSV columns read and written (an input column may not be an output)
LOOKUP_INPUTS = ("d", "V", "theta")
LOOKUP_OPTIONAL = ("ratio", "theta2")
LOOKUP_OUTPUTS = csv_columns(DOUBLET_OUTPUTS)
LOOKUP_RESERVED = tuple(LOOKUP_OUTPUTS.values()) + ("status", "method")
#: lookup doublet --bond: force vectors on grain 1 and grain 2
DOUBLET_VECTOR_COLUMNS = tuple(f"F{g}{c}" for g in (1, 2) for c in "xyz")

#: lookup triplet: CSV columns read and written
TRIPLET_INPUTS = ("d12", "d13", "d23", "V", "theta")
TRIPLET_OUTPUTS = csv_columns(TRIPLET_SURROGATE_OUTPUTS)
TRIPLET_RESERVED = tuple(TRIPLET_OUTPUTS.values()) + ("status", "lower_energy_state")
#: lookup triplet --bond: force vectors on grains 1, 2, 3 (table frame of the gaps)
TRIPLET_VECTOR_COLUMNS = tuple(f"F{g}{c}" for g in (1, 2, 3) for c in "xyz")


def cmd_lookup_doublet(args):
    """The doublet table (the exact solver where theta2 != theta) at each CSV row."""
    import pandas as pd

    from capbridge.surrogate.doublet import BOND_MAX
    from capbridge.surrogate.doublet_points import lookup_points
    from capbridge.surrogate.load import load_doublet_surrogate
    from capbridge.tabular_io import check_new_output, read_points_csv

    bond, direction = parse_gravity(args.bond, args.gravity, BOND_MAX,
                                    "the surrogates' range")
    reserved = LOOKUP_RESERVED + (DOUBLET_VECTOR_COLUMNS if args.bond is not None else ())
    columns, x = read_points_csv(args.input, LOOKUP_INPUTS, LOOKUP_OPTIONAL, reserved)
    check_new_output(args.output, inputs=[args.input], overwrite=args.overwrite)
    sur = load_doublet_surrogate(args.table, "clip" if args.clip else "raise", "--clip")
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


def cmd_lookup_triplet(args):
    """The coalesced-triplet table at each CSV row (with ``--bond``, the force vectors
    with gravity too)."""
    import pandas as pd

    from capbridge.surrogate.load import load_triplet_surrogate
    from capbridge.surrogate.triplet import BOND_MAX, LOWER_ENERGY_STATES
    from capbridge.tabular_io import check_new_output, read_points_csv

    bond, direction = parse_gravity(args.bond, args.gravity, BOND_MAX,
                                    "the surrogates' range")
    reserved = TRIPLET_RESERVED + (TRIPLET_VECTOR_COLUMNS if args.bond is not None else ())
    columns, x = read_points_csv(args.input, TRIPLET_INPUTS, (), reserved)
    check_new_output(args.output, inputs=[args.input], overwrite=args.overwrite)
    sur = load_triplet_surrogate(args.table, args.coalescence_table,
                                 "clip" if args.clip else "raise", "--clip")
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


def _triplet_vectors(sur, x, bond, direction):
    """Force vectors with gravity for CSV rows of gaps: the centres of each row in the
    table frame (:func:`capbridge.solvers.triplet.triplet_geometry`: grains 2 and 3 on
    the x axis, grain 1 at z > 0), gravity given in that frame."""
    from capbridge.solvers.triplet import triplet_geometry

    centres = np.stack([triplet_geometry(a, b, c).centres
                        for a, b, c in zip(x["d12"], x["d13"], x["d23"])])
    return sur.predict_vectors(centres, x["V"], x["theta"], bond=bond, gravity=direction)
