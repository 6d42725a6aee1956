"""``capbridge info``: describe a table and its error model, or every shipped table.

A doublet or triplet table is described by its surrogate's ``summary()`` (the contract
of :mod:`capbridge.surrogate.base`: what the surrogate was fitted on and its error
model), so what this prints is what a Python user gets; the coalescence table, which
has no surrogate of its own, by :func:`capbridge.tables.description.describe_table`.
This module only lays the dicts out as lines.
"""
from __future__ import annotations

import argparse

import numpy as np

from capbridge.tables import COALESCENCE_TABLE, DOUBLET_TABLE, TRIPLET_TABLE


def cmd_info_table(args):
    """Describe one table, or every shipped table when no --table is given."""
    from capbridge.surrogate.load import load_doublet_surrogate, load_triplet_surrogate
    from capbridge.tables.description import describe_table
    from capbridge.tables.netcdf_io import read_table

    if args.table is None:
        for path in (DOUBLET_TABLE, TRIPLET_TABLE, COALESCENCE_TABLE):
            if path.exists():
                cmd_info_table(argparse.Namespace(table=path))
        return 0
    ds = read_table(args.table)
    if "f12" in ds:
        print_triplet_summary(load_triplet_surrogate(args.table).summary(), args.table)
    elif "ratio" in ds.dims:
        print_doublet_summary(load_doublet_surrogate(args.table).summary(), args.table)
    else:
        table = describe_table(ds, [d for d in ds.dims if d in ds.coords
                                    and not d.startswith("heldout")])
        print_header(table, args.table)
        print_error_model(table["error_model"])
    return 0


def print_header(table, path):
    """Provenance, checksum and axes of a table (:func:`~capbridge.tables.description.
    describe_table`)."""
    print(f"table: {path}")
    if table["title"]:
        print(f"  {table['title']}")
    print(f"  made by: {table['command']}")
    print(f"  source commit: {table['git_commit']}; table checksum: {table['checksum']}")
    for name, a in table["axes"].items():
        print(f"  {name:7s} {a['n']:3d} values in [{a['min']:g}, {a['max']:g}]  "
              f"({a['long_name']})")


def print_error_model(model):
    """The stored error model: one attribute a line (numbers to 3 digits), then the
    description of the held-out points."""
    if not model:
        return
    print("  error model (held-out points):")
    for k, v in sorted(model.items()):
        if k not in ("holdout_description", "holdout_evolver_settings"):
            print(f"    {k}: {_short(v)}")
    if "holdout_description" in model:
        print(f"    ({model['holdout_description']})")


def print_doublet_summary(s, path):
    """:meth:`DoubletSurrogate.summary() <capbridge.surrogate.doublet.DoubletSurrogate.
    summary>` as lines."""
    print_header(s["table"], path)
    print(f"  points: {s['points']}, converged: {s['converged']}")
    print_error_model(s["table"]["error_model"])
    g = s["gravity"]
    if g is None:
        print("  gravity: none (the lookups answer Bo = 0 only; `capbridge solve doublet "
              "--bond` solves with gravity)")
        return
    print(f"  gravity (Bo up to {g['bond_max_supported']:g} in the lookups):")
    for name, a in g["arrays"].items():
        dims = ", ".join(f"{d} {n}" for d, n in a["dims"].items())
        print(f"    {name} ({dims}): {a['long_name']}")
    for d, c in g["grids"].items():
        c = np.asarray(c)
        print(f"    {d}: {np.round(c, 6).tolist()}" if c.size <= 8 else
              f"    {d}: {c.size} values in [{c.min():g}, {c.max():g}]")
    p = g["response_points"]
    if p is not None:
        print(f"    response points: {p['total']}, with a result: {p['with_result']} "
              f"({p['above_tolerance']} above_tolerance: own error estimate "
              "response_error above gravity_response_rtol)")
    h = g["holdout"] or {}
    if "bonds" in h:
        print("    held-out exact solutions with gravity along the axis (error relative to "
              "the attraction; effect: of the gravity part alone); validated up to "
              f"|Bo g_hat.n| = {g['bond_max_validated']:g}, above it lookups are "
              "approximate:")
        rows = zip(*(np.atleast_1d(h[k]) for k in (
            "bonds", "max_error", "max_effect_error", "max_effect_error_converged", "n",
            "n_approximate")))
        for b, err, effect, effect_converged, n, n_approximate in rows:
            print(f"      Bo = {b:<5g} max {err:.3g}, effect max {effect:.3g} (converged "
                  f"lookups {effect_converged:.3g}), {n} lookups, {n_approximate} "
                  "approximate")
    if "description" in h:
        print(f"    gravity_holdout_description: {h['description']}")
    for k, v in sorted(g["settings"].items()):
        print(f"    {k}: {_short(v)}")


def print_triplet_summary(s, path):
    """:meth:`TripletSurrogate.summary() <capbridge.surrogate.triplet.TripletSurrogate.
    summary>` as lines."""
    table, ev = s["table"], s["evolver"]
    print_header(table, path)
    counts = ", ".join(f"{name} {n}" for name, n in table["statuses"].items())
    print(f"  points: {sum(table['statuses'].values())} ({counts}); Evolver settings: "
          f"{ev['settings']}")
    if ev["cpu_time_median"] is not None:
        print(f"  per point: median {ev['cpu_time_median']:.1f} CPU s; estimated force "
              f"error median {ev['force_error_rel_median']:.2%}, max "
              f"{ev['force_error_rel_max']:.2%} of the point's largest force, "
              f"{ev['force_error_max']:.3g} F* absolute")
    if s.get("max_bridge_gap") is not None:
        print(f"  computed domain: the two smaller gaps up to {s['max_bridge_gap']:g} (the "
              "rest of the cube: not computed, outside the table)")
    print_error_model(table["error_model"])
    ie = s.get("holdout_error")
    if ie and "relative" in ie:
        print(f"  force_error of a lookup: its cell's Evolver estimate + {ie['relative']:.2%} "
              f"of its largest pair force + {ie['absolute']:.2g} F* (held-out: the largest "
              f"error relative to the point's largest pair force where it is >= "
              f"{ie['small_force']:g}, and "
              f"the largest absolute error over the {ie['n_small']} points that pull less)")
    o = s.get("open_side")
    if o and s.get("max_bridge_gap") is not None:
        print(f"  open side beyond the table ({o['mode']!r}; 'linear': continued to "
              f"{o['limit']:g}, status approximate): pair forces against {o['n_triplets']} Surface Evolver "
              f"triplets, median {o['median']:.1%}, max {o['max']:.1%} of the largest "
              f"({o['source']})")
    u = s.get("unequal_radii")
    if u:
        print(f"  unequal radii (approximation '{u['scheme']}', status approximate): "
              f"pair forces against {u['n_triplets']} Surface Evolver triplets with radius "
              f"ratios up to 2, median {u['median']:.1%}, max {u['max']:.1%} "
              f"({u['source']})")
    g = s["gravity"]
    if g is None:
        print("  gravity: none (the lookups answer Bo = 0 only; `capbridge solve triplet "
              "--bond` solves with gravity)")
        return
    n = g["nodes"]
    filled = f", {n['filled']} filled from their neighbours" if n.get("filled") else ""
    print(f"  gravity: response on v = {g['gravity_v']} ({n['with_response']} of "
          f"{n['total']} nodes with a result{filled}); Bo supported [0, "
          f"{g['bond_max_supported']:g}], validated [0, {g['bond_max_validated']:g}] "
          "(above: status approximate)")
    h = g.get("holdout")
    if h:
        print(f"    held-out direct Evolver points with gravity ({h['n_cases']} cases); "
              f"threshold {h['threshold']:.3g} ({h['threshold_source']}):")
        for b, e, f, n in zip(h["bonds"], h["max_error_by_bond"],
                              h["max_effect_error_by_bond"], h["n_cases_by_bond"]):
            print(f"      Bo = {b:<5g} max error {e:.3g}, of the gravity effect alone {f:.3g}"
                  f" (relative to the largest grain force; {n} cases answered)")
    if g["holdout_cases_skipped"]:
        print(f"    {g['holdout_cases_skipped']} held-out gravity case(s) outside the "
              "table's grid: skipped (not computed, not in the error model)")


def _short(value):
    """A number to 3 significant digits, anything else as it is."""
    return f"{value:.3g}" if isinstance(value, float) else f"{value}"
