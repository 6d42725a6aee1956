"""``capbridge coalescence``: the volume at which the separate bridges of a triplet of
equal spheres coalesce, JSON out.

:func:`capbridge.solvers.triplet.find_coalescence` answers from exact doublets; with
``--energy`` the coalesced body (Surface Evolver) is also compared with the separate
bridges around that volume (:func:`capbridge.solvers.triplet_evolver.
energy_comparison`).  Exit status 0 when the bridges coalesce, 3 when they do not.
"""
from __future__ import annotations

import numpy as np

from capbridge.cli.output import print_json
from capbridge.validation import CapbridgeInputError, check_range

#: largest total volume V* searched by default (--v-max)
V_MAX_DEFAULT = 2.5


def cmd_coalescence(args):
    """V_coal of the triplet and the bridges at that volume (and the energy comparison)."""
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
        out["energy"] = _energy(args, geom, theta, bridges, fractions, r.V_coal)
    print_json(out)
    return 0 if r.status == "coalescence" else 3


def _energy(args, geom, theta, bridges, fractions, V_coal):
    """``--energy``: the coalesced body against the separate bridges at
    ``--energy-fractions`` of V_coal, and the volume where their energies cross."""
    from capbridge.solvers.triplet_evolver import energy_comparison

    if not np.isfinite(V_coal):
        return {"error": "no coalescence volume to compare around"}
    fr = [float(x) for x in args.energy_fractions.split(",")]
    e = energy_comparison(geom, theta, [V_coal * f for f in fr], bridges, fractions,
                          max_refine=args.max_refine)
    return {"V_cross": e["crossing"], "note": e["crossing_note"],
            "volumes": e["volume"], "E_uncoalesced": e["E_uncoalesced"],
            "E_coalesced": e["E_coalesced"], "E_coalesced_error": e["E_coalesced_error"],
            "coalesced_status": e["coalesced_status"],
            "method": "coalesced: Surface Evolver (Richardson-extrapolated energy, max "
                      f"refinement {args.max_refine}); separate bridges: exact doublets"}
