"""Held-out errors of the triplet surrogate: its answers against direct Evolver solutions.

A triplet table carries points the surrogate was not fitted on, solved directly:

* ``holdout_*``: random geometries, angles and volume ratios inside the grid, one
  Evolver level finer than the table (:func:`holdout_points`, :func:`holdout_errors`);
  :meth:`~capbridge.surrogate.triplet.TripletSurrogate.fit` stores their errors as the
  surrogate's interpolation error (``interpolation_error_``), which enters every
  ``force_error``;
* ``gravity_holdout_*``: cases minimised with gravity at every Bond number of the table
  (:func:`gravity_holdout_errors`), which set the Bond range the surrogate's gravity
  response is validated to (``gravity_bond_max_``).

The doublet surrogate measures its own held-out errors against the exact solvers
(:func:`capbridge.surrogate.doublet.holdout_errors`).
"""
from __future__ import annotations

import itertools

import numpy as np

from capbridge.physics.gravity import BOND_MAX
from capbridge.solvers.triplet import triplet_geometry
from capbridge.status import HAS_RESULT, Status, status_in
from capbridge.surrogate.triplet_nodes import PAIR_NAMES, PAIRS
from capbridge.validation import CapbridgeInputError

__all__ = ["holdout_points", "holdout_errors", "gravity_holdout_errors", "SMALL_FORCE"]

#: held-out points whose largest pair force is below this (F*) bound the absolute part
#: of the interpolation error, the others its relative part (:func:`holdout_errors`):
#: where a body barely pulls (theta -> 80 deg at large v, largest pair force 0.002-0.09
#: on the second table) a relative error says nothing (153 % there for 0.0034 F*)
SMALL_FORCE = 0.1


def holdout_points(ds):
    """The table's held-out Evolver points (``holdout_*``) as arrays, with ``ok`` (the
    point has a result) and ``n`` (how many have one); None without held-out points."""
    if "holdout_f12" not in ds:
        return None
    h = {k: np.asarray(ds[f"holdout_{k}"].values, float) for k in
         ("d12", "d13", "d23", "theta", "v", "volume", "f12", "f13", "f23")}
    h["status"] = np.asarray(ds["holdout_status"].values)
    h["ok"] = status_in(h["status"], (Status.CONVERGED, Status.ABOVE_TOLERANCE)) & \
        np.isfinite(np.stack([h[n] for n in PAIR_NAMES])).all(0)
    h["n"] = int(h["ok"].sum())
    return h


def holdout_errors(surrogate, by="volume", permute=False):
    """Relative error of the pair forces against the table's held-out Evolver points.

    The held-out points (random geometries, angles and volume ratios inside the grid,
    solved one Evolver level finer than the table) are looked up at their total volume
    V* (``by="volume"``, what a user does: includes the error of V*_coal) or at their
    volume ratio v (``by="v"``: the interpolation of the forces alone).  ``permute``:
    every point also under the 5 relabellings of its grains.

    Returns a dict: ``rel_error`` (n, 3) |f_sur / f_held - 1| per pair, ``used`` mask
    (both the held-out point and the lookup have a result), ``median_rel_error``,
    ``max_rel_error`` over the used pair forces, ``n`` points used; and the error model
    |f_sur - f_held| <= a max|f_sur| + b that holds at every used pair force:
    ``relative`` a, the largest |f_sur - f_held| / max|f_sur| over the points whose
    largest held-out pair force is at least :data:`SMALL_FORCE`, and ``absolute`` b
    (F*), the largest |f_sur - f_held| over the others (0 if none).
    """
    h = surrogate.holdout_
    if h is None:
        raise CapbridgeInputError("the table has no held-out points (holdout_*)")
    g = np.stack([h["d12"], h["d13"], h["d23"]], 1)
    f_ref = np.stack([h[n] for n in PAIR_NAMES], 1)
    perms = list(itertools.permutations(range(3))) if permute else [(0, 1, 2)]
    errs, used, refs, absolute, largest = [], [], [], [], []
    keep = surrogate.out_of_range
    surrogate.out_of_range = "clip"          # v of a held-out point may sit on the edge
    try:
        for p in perms:
            # grain k of the relabelled triplet is grain p[k] of the held-out one
            gap = {(i, j): g[:, PAIRS.index(tuple(sorted((i, j))))] for i, j in PAIRS}
            q = [gap[tuple(sorted((p[i], p[j])))] for i, j in PAIRS]
            if by == "v":
                Vc = surrogate.predict(*q, 1.0, h["theta"])["volume_coalescence"]
                vol = h["v"] * Vc
            else:
                vol = h["volume"]
            r = surrogate.predict(*q, vol, h["theta"])
            f_sur = np.stack([r[n] for n in PAIR_NAMES], 1)
            ref = np.stack([f_ref[:, PAIRS.index(tuple(sorted((p[i], p[j]))))]
                            for i, j in PAIRS], 1)
            ok = h["ok"] & status_in(r["status"], (Status.CONVERGED, Status.ABOVE_TOLERANCE))
            errs.append(np.abs(f_sur / ref - 1.0))
            refs.append(np.abs(ref))
            absolute.append(np.abs(f_sur - ref))
            largest.append(np.max(np.abs(f_sur), axis=1))
            used.append(ok)
    finally:
        surrogate.out_of_range = keep
    e = np.concatenate(errs)
    u = np.concatenate(used)
    sel = e[u]
    # the same errors relative to the largest pair force of the point (small pair
    # forces, e.g. at theta -> 80 deg and large v, make the plain relative error large)
    ref_all = np.concatenate(refs)
    e_max = e * ref_all / ref_all.max(axis=1, keepdims=True)
    a_err = np.max(np.concatenate(absolute), axis=1)
    f_sur_max = np.concatenate(largest)
    small = ref_all.max(axis=1) < SMALL_FORCE
    big = u & ~small
    return {"rel_error": e, "used": u,
            "median_rel_error": float(np.median(sel)) if sel.size else np.nan,
            "max_rel_error": float(np.max(sel)) if sel.size else np.nan,
            "max_rel_to_largest": float(np.max(e_max[u])) if sel.size else np.nan,
            "relative": float(np.max(a_err[big] / f_sur_max[big])) if big.any() else 0.0,
            "absolute": float(np.max(a_err[u & small])) if np.any(u & small) else 0.0,
            "n_small": int(np.sum(u & small)), "small_force": SMALL_FORCE,
            "n": int(u.sum()), "by": by}


def gravity_holdout_errors(surrogate, table=None):
    """Errors of the surrogate with gravity against the table's direct Evolver
    minimisations with gravity (``gravity_holdout_*``), and the validated Bond range.

    Each held-out case (gaps, theta, v, direction of gravity in the table frame) is
    solved directly at every Bond number of the table (Bo = 0 included).  At each point
    with a result:

    * ``error``: max_i |F_i,model(b) - F_i,direct(b)| / max_i |F_i,direct(b)|, the model
      being :meth:`TripletSurrogate.predict_vectors` at the case's total volume (table
      and response: what a user gets);
    * ``effect_error``: the same for the gravity effect alone, (F(b) - F(0)) of the
      model (its response terms, i.e. F(0) taken as the direct Bo = 0 point of the
      case on both sides) against F_direct(b) - F_direct(0), relative to the same
      largest grain force.

    ``threshold`` is the surrogate's own held-out error without gravity
    (``interpolation_error_['relative']``: pair forces relative to the largest pair
    force of the point, over the points that pull at least :data:`SMALL_FORCE`; NaN
    without held-out points, then nothing is validated); ``bond_max_validated`` the
    largest held-out Bo such that at every Bo up to it every used case has
    ``effect_error`` <= threshold: the response adds at most the table's own error
    (0 if none).

    Returns
    -------
    dict
        ``bond``, ``orientation``, ``case`` (index of the case), ``error``,
        ``effect_error``, ``used`` (arrays over the held-out points); ``bonds``,
        ``max_error_by_bond``, ``max_effect_error_by_bond`` (lists, NaN where no case
        answered), ``n_cases_by_bond`` (cases where both the direct minimisation and
        the surrogate have a result: a case the surrogate does not answer, e.g. a cell
        of the response without a result, is not counted against the range),
        ``threshold``, ``threshold_source``, ``bond_max_validated``, ``n_cases``,
        ``n_cases_used``.
    """
    ds = surrogate.table_ if table is None else table
    h = {k: np.asarray(ds[f"gravity_holdout_{k}"].values) for k in
         ("d12", "d13", "d23", "theta", "v", "volume", "bond", "status")}
    direction = np.asarray(ds["gravity_holdout_direction"].values, float)
    Fd = np.asarray(ds["gravity_holdout_force"].values, float)
    orient = np.asarray(ds["gravity_holdout_orientation"].values).astype(str)
    n = h["bond"].size
    key = [tuple(np.round([h["d12"][k], h["d13"][k], h["d23"][k], h["theta"][k], h["v"][k],
                           *direction[k]], 9)) for k in range(n)]
    cases = {k: i for i, k in enumerate(dict.fromkeys(key))}
    case = np.array([cases[k] for k in key])
    okd = status_in(h["status"], HAS_RESULT) & np.isfinite(Fd).all((1, 2))
    err = np.full(n, np.nan)
    eff = np.full(n, np.nan)
    keep = surrogate.out_of_range
    surrogate.out_of_range = "clip"
    try:
        for k in range(n):
            zero = np.flatnonzero((case == case[k]) & (h["bond"] == 0) & okd)
            if not okd[k]:
                continue
            cen = triplet_geometry(h["d12"][k], h["d13"][k], h["d23"][k]).centres
            bo = min(float(h["bond"][k]), BOND_MAX)
            r = surrogate.predict_vectors(cen, float(h["volume"][k]), float(h["theta"][k]),
                                          bond=bo, gravity=direction[k]
                                          if np.any(direction[k]) else None)
            if not status_in(r["status"], HAS_RESULT + (Status.EXTRAPOLATED,)):
                continue
            scale = np.max(np.linalg.norm(Fd[k], axis=-1))
            err[k] = np.max(np.abs(r["forces"] - Fd[k])) / scale
            if zero.size:
                model = r.get("gravity_first_order", 0.0) + r.get("gravity_second_order", 0.0)
                eff[k] = np.max(np.abs(model - (Fd[k] - Fd[zero[0]]))) / scale
    finally:
        surrogate.out_of_range = keep
    ie = surrogate.interpolation_error_
    thr = float(ie["relative"]) if ie else np.nan
    bonds = sorted(set(float(b) for b in h["bond"]))
    used = np.isfinite(err)
    by = [float(np.max(err[used & (h["bond"] == b)])) if np.any(used & (h["bond"] == b))
          else np.nan for b in bonds]
    nby = [int(len(set(case[used & (h["bond"] == b)].tolist()))) for b in bonds]
    eby = [float(np.nanmax(eff[used & (h["bond"] == b)]))
           if np.any(used & (h["bond"] == b) & np.isfinite(eff)) else np.nan for b in bonds]
    # validated while the response adds no more than the table's own error: the error
    # of the gravity effect alone (the error at Bo = 0 is the table's interpolation,
    # measured on grain force vectors; it may sit just above the pair-force threshold)
    bmax = 0.0
    for b, e in zip(bonds, eby):
        if not (np.isfinite(e) and e <= thr) and b > 0:
            break
        bmax = b
    return {"bond": h["bond"].astype(float), "orientation": orient, "case": case,
            "error": err, "effect_error": eff, "used": used, "bonds": bonds,
            "max_error_by_bond": by, "max_effect_error_by_bond": eby,
            "n_cases_by_bond": nby, "threshold": thr,
            "threshold_source": "held-out pair forces without gravity, max error relative "
                                "to the largest pair force, points pulling at least "
                                f"{SMALL_FORCE:g} F* (holdout_errors)",
            "bond_max_validated": float(bmax), "n_cases": len(cases),
            "n_cases_used": int(len(set(case[used].tolist())))}
