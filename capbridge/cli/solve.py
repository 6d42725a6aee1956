"""``capbridge solve doublet``, ``solve triplet`` and ``solve cluster``: one solve, JSON out.

The exact Young-Laplace solver for a doublet (Surface Evolver for gravity off its axis),
Surface Evolver for a coalesced triplet and for one liquid body on the N grains of a CSV
file (:func:`capbridge.solvers.cluster.solve_cluster`).  Exit status 0 with a result, 3 without one
(not converged, or no equilibrium).  ``--shape out.vtp`` also writes the liquid surface
and the grains (:mod:`capbridge.solvers.shapes`) for ParaView.
"""
from __future__ import annotations

import sys

import numpy as np

from capbridge.cli.output import print_json
from capbridge.cli.parser import parse_gravity
from capbridge.status import Status, status_name
from capbridge.surrogate.names import CSV_COLUMNS as COL
from capbridge.validation import CapbridgeInputError, check_range


def cmd_solve_doublet(args):
    """One bridge between two spheres by the exact Young-Laplace solver, at given volume
    (``--V``) or suction (``--P``); with ``--bond``, the force vectors with gravity."""
    from capbridge.solvers.young_laplace import solve_doublet, solve_doublet_suction
    from capbridge.solvers.young_laplace_gravity import BOND_MAX as SOLVER_BOND_MAX

    bond, direction = parse_gravity(args.bond, args.gravity, SOLVER_BOND_MAX,
                                    "the exact solver's range")
    if (args.V is None) == (args.P is None):
        raise CapbridgeInputError("give exactly one of --V (volume control) or --P (suction control)")
    _check_shape_target(args)
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
    if args.shape and int(np.asarray(r["status"])) == Status.CONVERGED:
        from capbridge.solvers.shapes import doublet_shape
        out["shape"] = _write_shape(args, doublet_shape(args.d, float(volume), args.theta,
                                                        args.ratio, args.theta2, result=r))
    print_json(out)
    return 0 if out["status"] in ("converged", "ruptured") else 3


def _check_shape_target(args):
    """``--shape``: the two files it will write are checked before any solve (one line
    if they exist without ``--overwrite`` or cannot be written)."""
    if args.shape:
        from capbridge.solvers.shapes import shape_paths
        shape_paths(args.shape, overwrite=args.overwrite, flag="--overwrite")


def _write_shape(args, shape):
    """Write ``--shape`` (the surface and its grains file); their paths, or None with
    a warning when the solve kept no surface."""
    from capbridge.solvers.shapes import write_shape

    if shape is None:
        print("capbridge: warning: no surface written (--shape): the solve has no result",
              file=sys.stderr)
        return None
    return [str(p) for p in write_shape(shape, args.shape, overwrite=args.overwrite)]


#: the JSON names of :func:`~capbridge.solvers.doublet_in_gravity.solve_doublet_in_gravity`'s
#: outputs (F, the attraction, as everywhere in the command line); the rest keep theirs
GRAVITY_JSON_NAMES = {"force": COL["force"], "pressure_centre1": "P_centre1"}


def _solve_doublet_gravity(args, bond, direction):
    """``solve doublet --bond``: :func:`~capbridge.solvers.doublet_in_gravity.
    solve_doublet_in_gravity` (the exact solver along the axis, else Surface Evolver)."""
    from capbridge.solvers.doublet_in_gravity import (along_axis, check_inputs,
                                                      solve_doublet_in_gravity)

    if args.V is None:
        raise CapbridgeInputError("--bond needs --V (volume control): suction control "
                                  "(--P) with gravity is not available")
    check_range("gap d* (--d)", args.d, 0.0, np.inf)      # the message names the option
    # a bad value is one error line, never after the note below
    check_inputs(args.d, args.V, args.theta, bond, args.ratio, args.theta2)
    if not along_axis(direction, bond):
        print("capbridge: gravity not along the axis: Surface Evolver (minutes, not "
              "milliseconds)", file=sys.stderr)
    off_axis = not along_axis(direction, bond)
    r = solve_doublet_in_gravity(args.d, args.V, args.theta, bond, direction, args.ratio,
                                 args.theta2, max_refine=args.max_refine,
                                 keep_shape=bool(args.shape) and (off_axis or bond > 0))
    st = r["status"]
    shape = r.pop("shape", None)
    F1, F2 = r.pop("forces")
    out = {"d": args.d, "V": args.V, "theta": args.theta,
           "theta2": args.theta if args.theta2 is None else args.theta2,
           "ratio": args.ratio, "bond": bond, "gravity": direction.tolist(),
           "frame": "grain 1 (radius 1) at the origin, grain 2 (radius ratio) on +x; "
                    "gravity: the direction it pulls",
           "method": r.pop("method"), "F1": F1, "F2": F2}
    out.update({GRAVITY_JSON_NAMES.get(k, k): v for k, v in r.items()})
    out["status"] = status_name(st)
    out["units"] = ("dimensionless by R1 and gamma: F* = F/(2 pi gamma R1) (force vectors "
                    "on each grain; F1 + F2 = weight * gravity), P* = dp R1/gamma")
    if args.shape:
        if not off_axis and st == Status.CONVERGED:        # Bo = 0: the exact profile
            from capbridge.solvers.shapes import doublet_shape
            shape = doublet_shape(args.d, args.V, args.theta, args.ratio, args.theta2)
        out["shape"] = _write_shape(args, shape)
    print_json(out)
    return 0 if st in (Status.CONVERGED, Status.ABOVE_TOLERANCE) else 3


def _evolver_inputs(args, volume_hint):
    """``--V``, ``--theta``, ``--bond``/``--gravity`` of the Surface Evolver solves,
    checked: (V*, theta, Bo, direction or None)."""
    from capbridge.solvers.young_laplace_gravity import BOND_MAX as SOLVER_BOND_MAX

    V = float(check_range("--V", args.V, 0.0, np.inf, low_open=True, hint=volume_hint))
    theta = float(check_range("--theta", args.theta, 0.0, 90.0, high_open=True,
                              units=" deg"))
    bond, direction = parse_gravity(args.bond, args.gravity, SOLVER_BOND_MAX,
                                    "the solvers' range")
    return V, theta, bond, direction


def cmd_solve_triplet(args):
    """One Surface Evolver minimisation of a coalesced body on three equal spheres."""
    from capbridge.solvers.triplet import triplet_geometry
    from capbridge.solvers.triplet_evolver import evolver_triplet

    geom = triplet_geometry(args.d12, args.d13, args.d23)
    V, theta, bond, direction = _evolver_inputs(args, "total liquid volume V* = V/r^3")
    kw = {} if args.bond is None else {"bond": bond, "gravity_dir": tuple(direction)}
    _check_shape_target(args)
    r = evolver_triplet(V, geom, theta, "coalesced", max_refine=args.max_refine,
                        inspect_mesh=False, keep_shape=bool(args.shape), **kw)
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
    if args.shape:
        out["shape"] = _write_shape(args, r if r.get("shape") is not None else None)
    print_json(out)
    return 0 if r["status_code"] in (Status.CONVERGED, Status.ABOVE_TOLERANCE) else 3


#: the columns of ``solve cluster --grains``
CLUSTER_COLUMNS = ("x", "y", "z", "radius")


def cmd_solve_cluster(args):
    """One Surface Evolver minimisation of one liquid body wetting the grains of a CSV
    file (columns x, y, z, radius in units of the smallest radius)."""
    from capbridge.solvers.cluster import solve_cluster
    from capbridge.tabular_io import read_points_csv

    _, cols = read_points_csv(args.grains, CLUSTER_COLUMNS)
    n = len(cols["x"])
    if n < 2:
        raise CapbridgeInputError(f"{args.grains}: {n} grain; a cluster needs at least 2 "
                                  "rows (one per grain)")
    centres = np.column_stack([cols[c] for c in CLUSTER_COLUMNS[:3]])
    V, theta, bond, direction = _evolver_inputs(
        args, "total liquid volume V* = V/r^3, r the smallest radius")
    _check_shape_target(args)
    try:
        r = solve_cluster(centres, cols["radius"], V, theta, bond=bond, gravity=direction,
                          max_refine=args.max_refine, keep_shape=bool(args.shape))
    except CapbridgeInputError as exc:                   # name the file (grains = rows)
        raise CapbridgeInputError(f"{args.grains}: {exc}") from None
    pairs = r["pairs"] or {}
    pf, pe = pairs.get("pair_forces"), pairs.get("pair_force_error")
    out = {"grains": str(args.grains), "n_grains": n, "V": V, "theta": theta,
           "bond": bond, "gravity": None if direction is None else direction.tolist(),
           "r_min": r["r"], "status": status_name(r["status"]), "reason": r["reason"],
           "frame": "the file's: grain k is row k (from 1), lengths / the smallest radius"
                    " (gravity: the direction it pulls)",
           "forces": r["forces"], "force_error": r["force_error"],
           "force_error_rel": r["force_error_rel"], "force_sum": r["force_sum"],
           "pressure": r["pressure"], "energy": r["energy"],
           "energy_error": r["energy_error"],
           "pair_forces_determined": bool(pairs.get("determined", False)),
           "pair_forces": None if pf is None else _by_pair_name(pf),
           "pair_force_error": None if pe is None else _by_pair_name(pe),
           "pair_rank": pairs.get("rank"), "pair_residual": pairs.get("residual"),
           "pair_note": pairs.get("note", ""), "refinement": r["refinement"],
           "n_facets": r["n_facets"], "cpu_time": r["cpu_time"], "warnings": r["warnings"],
           "units": "dimensionless by r (the smallest radius) and gamma: F* = F/(2 pi gamma "
                    "r) (attraction > 0 for pair forces), P* = dp r/gamma, E* = E/(gamma "
                    "r^2)"}
    if args.shape:
        out["shape"] = _write_shape(args, r["shape"])
    print_json(out)
    return 0 if r["status"] in (Status.CONVERGED, Status.ABOVE_TOLERANCE) else 3


def _by_pair_name(values):
    """{(i, j): x} (0-based grains) as {"i+1-j+1": x}: grains numbered as the rows of
    the file."""
    return {f"{i + 1}-{j + 1}": v for (i, j), v in values.items()}
