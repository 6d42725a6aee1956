"""One liquid body wetting N grains (a cluster), by Surface Evolver energy minimisation.

Four grains and more have no table: the liquid body is computed case by case.
:func:`solve_cluster` checks the grains, normalises every length by the smallest radius
r, minimises one coalesced body wetting all of them
(:func:`capbridge.solvers.evolver.minimise_bridge`, topology ``"coalesced"``, retried
from finer starting rings after a failure on the mesh as for triplets) and returns the
force vector on every grain in the caller's order and frame (only rescaled by r), the
pressure, the energy, their error estimates over the refinement levels, the status, and
the decomposition of the forces into pair forces along the centre lines
(:func:`cluster_pair_forces`) where that decomposition is determined.

Dimensionless as the Evolver driver (Miot et al. 2021, section 2): F* = F/(2 pi gamma r),
P* = dp r/gamma, E* = E/(gamma r^2), V* = V/r^3, Bo = drho g r^2/gamma, r the smallest
grain radius.
"""
from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from capbridge.physics.gravity import gravity_vector
from capbridge.solvers.triplet import pair_direction_matrix, pair_forces
from capbridge.solvers.triplet_evolver import minimise_with_ring_retries
from capbridge.solvers.young_laplace_gravity import BOND_MAX
from capbridge.status import HAS_RESULT
from capbridge.validation import (CONTACT_OVERLAP_MAX, CapbridgeInputError, check_int,
                                  check_range)

__all__ = ["solve_cluster", "cluster_pair_forces", "check_cluster", "PAIR_RANK_RTOL",
           "REFINE_RANGE"]

#: A pair decomposition counts as determined when the smallest singular value of the
#: pair-direction matrix is at least this fraction of the largest: below it, a nearly
#: planar or nearly collinear cluster would amplify the force errors into arbitrary
#: pair forces (a planar square gives exactly 0).
PAIR_RANK_RTOL = 1e-6

#: finest refinement level allowed: level 2 at least (the error estimate compares
#: levels), 6 at most (~65 000 facets per body, hours)
REFINE_RANGE = (2, 6)

# gaps below 0 by this fraction of the pair's radii are round-off (touching grains whose
# centres were computed), not an overlap
_GAP_ROUND_OFF = 1e-12


def check_cluster(centres, radii):
    """Check N grains and normalise them by the smallest radius.

    Parameters
    ----------
    centres : array_like, shape (N, 3)
        Grain centres, any length unit, N >= 2.
    radii : array_like, shape (N,) or scalar
        Grain radii, same unit, > 0.

    Returns
    -------
    centres : numpy.ndarray, shape (N, 3)
        Centres / r, r the smallest radius.
    radii : numpy.ndarray, shape (N,)
        Radii / r (the smallest is 1).
    r : float
        The smallest radius, in the input unit.

    Raises
    ------
    CapbridgeInputError
        Fewer than two grains, a non-finite centre, a radius <= 0, or two grains that
        overlap (gap between their surfaces < 0 beyond round-off; grains are numbered
        from 1, in input order).  A DEM contact overlap (up to
        :data:`~capbridge.validation.CONTACT_OVERLAP_MAX` r) is refused too: moving
        one pair apart moves the other pairs of the cluster, so it is left to the
        caller.
    """
    C = check_range("grain centres", centres)
    if C.ndim != 2 or C.shape[1] != 3:
        raise CapbridgeInputError(f"grain centres must have shape (N, 3), got {C.shape}")
    n = len(C)
    if n < 2:
        raise CapbridgeInputError(f"a cluster needs at least 2 grains, got {n}")
    R = np.broadcast_to(check_range("grain radius", radii, 0.0, np.inf, low_open=True),
                        (n,)).astype(float)
    r = float(R.min())
    C, R = C / r, R / r
    for i, j in itertools.combinations(range(n), 2):
        gap = float(np.linalg.norm(C[i] - C[j]) - R[i] - R[j])
        if gap < -_GAP_ROUND_OFF * (R[i] + R[j]):
            contact = (" (a DEM contact overlap: move the centres apart to gap 0 first)"
                       if gap >= -CONTACT_OVERLAP_MAX else "")
            raise CapbridgeInputError(
                f"grains {i + 1} and {j + 1} overlap: gap d*={gap:.6g} (lengths / smallest "
                f"radius) is outside the allowed range [0, inf){contact}")
    return C, R, r


def cluster_pair_forces(centres, forces, force_error=None, rtol=PAIR_RANK_RTOL):
    """Pair forces f_ij along the centre lines from the grain forces, where determined.

    Solves F_i = sum_j f_ij u_ij (u_ij the unit vector from grain i to grain j,
    attraction f_ij > 0) over every pair of grains by least squares
    (:func:`capbridge.solvers.triplet.pair_forces`).  The pair forces are determined
    when the 3N x M pair-direction matrix A (M = N(N-1)/2 pairs,
    :func:`~capbridge.solvers.triplet.pair_direction_matrix`) has full column rank:
    a filled tetrahedron (6 pairs, rank 6) does, a planar square (6 pairs, rank 5) or
    any cluster of 5 grains or more (M > 3N - 6) does not.

    Parameters
    ----------
    centres : array_like, shape (N, 3)
    forces : array_like, shape (N, 3)
        Force on each grain, F* (without gravity: balanced, torque-free).
    force_error : array_like, shape (N, 3), optional
        Error estimate of ``forces``; propagated linearly (pseudo-inverse of A).
    rtol : float
        Rank tolerance on the singular values relative to the largest
        (:data:`PAIR_RANK_RTOL`).

    Returns
    -------
    dict
        ``determined`` (bool), ``rank``, ``n_pairs``, ``pair_forces`` {(i, j): f_ij}
        (0-based, i < j) or None when not determined, ``pair_force_error``
        {(i, j): error} or None, ``residual`` = |A f - F| / max_i |F_i| of the least
        squares (small for a balanced, torque-free force set), ``note`` (why not
        determined).

    >>> c = [[1., 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]
    >>> A, p = pair_direction_matrix(c)
    >>> r = cluster_pair_forces(c, (A @ np.full(6, 0.2)).reshape(4, 3))
    >>> r["determined"], r["rank"], round(r["pair_forces"][(0, 1)], 12)
    (True, 6, 0.2)
    >>> sq = [[0., 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]]
    >>> cluster_pair_forces(sq, np.zeros((4, 3)))["determined"]
    False
    """
    A, pairs = pair_direction_matrix(centres)
    s = np.linalg.svd(A, compute_uv=False)
    rank = int(np.sum(s >= rtol * s.max()))
    f, resid = pair_forces(centres, forces, pairs)
    out = {"determined": rank == len(pairs), "rank": rank, "n_pairs": len(pairs),
           "residual": resid, "pair_forces": None, "pair_force_error": None, "note": ""}
    if not out["determined"]:
        n = len(A) // 3
        out["note"] = (f"pair forces not determined: the {len(pairs)} pair directions have "
                       f"rank {rank} < {len(pairs)} (balanced, torque-free forces on {n} "
                       f"grains fix at most {max(3 * n - 6, 1)} pair forces, fewer when "
                       "the grains are planar or collinear)")
        return out
    out["pair_forces"] = f
    if force_error is not None:
        e = np.asarray(force_error, float).ravel()
        err = np.sqrt((np.linalg.pinv(A) ** 2) @ (e ** 2))
        out["pair_force_error"] = {p: float(v) for p, v in zip(pairs, err)}
    return out


def solve_cluster(centres, radii, volume, theta, bond=0.0, gravity=None, max_refine=3,
                  keep_shape=False, tol=3e-3, retry_rings=(8, 12, 16)):
    """Forces of one liquid body wetting N grains, by Surface Evolver.

    Minimises the surface energy E = gamma (A_lg - sum_k cos(theta_k) A_wet,k)
    (+ drho g int h dV with gravity) of one liquid body of volume V wetting every grain
    (Miot et al. 2021, section 2); the force on each grain is the virtual work -dE/dx_k,
    Richardson-extrapolated over the refinement levels
    (:mod:`capbridge.solvers.evolver`).

    Parameters
    ----------
    centres : array_like, shape (N, 3)
        Grain centres, any length unit, N >= 2; grains must not overlap.
    radii : array_like, shape (N,) or scalar
        Grain radii, same unit, > 0.  Lengths are divided by the smallest, r.
    volume : float
        Liquid volume V* = V / r^3, > 0.
    theta : float or array_like, shape (N,)
        Contact angle [deg] in [0, 90), one for all grains or one per grain.
    bond : float, default 0
        Bond number Bo = drho g r^2 / gamma, in [0, 5].
    gravity : array_like, shape (3,), optional
        Direction along which gravity pulls, in the frame of ``centres`` (default
        (0, 0, -1)); only with ``bond`` > 0.
    max_refine : int, default 3
        Finest refinement level, in [2, 6] (each level has 4 times the facets).
    keep_shape : bool, default False
        Keep the minimised surface (``shape``) for
        :func:`capbridge.solvers.shapes.write_shape`.
    tol : float, default 3e-3
        Tolerance on the estimated relative force error (``ftol``).
    retry_rings : sequence of int
        Starting contact rings tried after failures on the mesh
        (:func:`~capbridge.solvers.triplet_evolver.minimise_with_ring_retries`).

    Returns
    -------
    dict
        ``status`` (:class:`capbridge.status.Status`: a result with CONVERGED or
        ABOVE_TOLERANCE, none otherwise) and ``reason``; ``forces`` (N, 3), F* =
        F/(2 pi gamma r) on each grain in the order and frame of ``centres``, and
        ``force_error`` (N, 3), its estimate from the refinement levels; ``force_sum``
        (sum of the forces: 0 without gravity, the weight Bo V*/(2 pi) along gravity
        with it); ``pressure`` P* (with gravity: at height 0 of the frame of
        ``centres`` / r), ``energy`` E* (extrapolated) and ``energy_error``;
        ``refinement``, ``n_facets``, ``cpu_time`` (Evolver CPU s), ``wall_time``,
        ``warnings``, ``attempts``; ``pairs`` (:func:`cluster_pair_forces`; without
        gravity, else not determined); ``centres``, ``radii`` (/ r), ``r`` (smallest
        radius, input unit), ``volume``, ``theta``, ``bond``, ``gravity``; ``shape``
        (a :class:`~capbridge.solvers.shapes.LiquidShape`, lengths / r) with
        ``keep_shape`` and a result, else None.  Without a result the numbers are None.

    Raises
    ------
    CapbridgeInputError
        One line naming a bad value and its allowed range (:func:`check_cluster` for
        the grains).

    References
    ----------
    Miot, M. et al. (2021), Numerical analysis of capillary bridges and coalescence in
    a triplet of spheres, Granular Matter 23:66.
    """
    from capbridge.solvers.evolver import Settings, minimise_bridge

    C, R, r = check_cluster(centres, radii)
    n = len(C)
    V = float(check_range("volume V*", volume, 0.0, np.inf, low_open=True,
                          hint="V* = V/r^3, r the smallest radius"))
    t = np.broadcast_to(check_range("contact angle theta", theta, 0.0, 90.0, high_open=True,
                                    units=" deg"), (n,)).astype(float)
    bo = float(check_range("Bond number Bo", bond, 0.0, BOND_MAX,
                           hint="Bo = drho g r^2/gamma, r the smallest radius"))
    if gravity is not None and bo == 0.0:
        raise CapbridgeInputError(f"gravity={gravity!r} needs a Bond number bond > 0")
    g = np.array([0.0, 0.0, -1.0]) if gravity is None else gravity_vector(1.0, gravity)
    level = check_int("max_refine", max_refine, *REFINE_RANGE,
                      hint="the error estimate needs levels 0-2")
    settings = Settings(ftol=float(tol), max_refine=level, min_refine=REFINE_RANGE[0],
                        keep_shape=bool(keep_shape))
    res, attempts = minimise_with_ring_retries(
        lambda n_ring: minimise_bridge(
            C, R, t, V, "coalesced", bond=bo, gravity_dir=tuple(g),
            settings=dataclasses.replace(settings, n_ring=n_ring)),
        retry_rings)
    has = res.status in HAS_RESULT and res.forces is not None
    out = {"status": res.status, "reason": res.reason, "centres": C, "radii": R, "r": r,
           "volume": V, "theta": t, "bond": bo, "gravity": None if bo == 0 else g,
           "refinement": int(res.refinement), "n_facets": int(res.n_facets),
           "cpu_time": float(res.cpu_time), "wall_time": float(res.wall_time),
           "warnings": list(res.warnings), "attempts": attempts,
           "shape": res.shape if has else None,
           "forces": None, "force_error": None, "force_error_rel": None, "force_sum": None,
           "pressure": None, "energy": None, "energy_error": None, "pairs": None}
    if not has:
        return out
    F = np.asarray(res.forces, float)
    Ferr = np.asarray(res.force_error, float)
    out.update({"forces": F, "force_error": Ferr,
                "force_error_rel": float(res.error_estimate.get("force_rel", np.nan)),
                "force_sum": F.sum(axis=0),
                "pressure": float(np.asarray(res.pressure, float)[0]),
                "energy": float(res.energy_extrapolated),
                "energy_error": float(res.error_estimate.get("energy", np.nan))})
    if bo == 0.0:
        out["pairs"] = cluster_pair_forces(C, F, Ferr)
    else:
        # with gravity the forces carry the liquid's weight: no balance of pair forces
        out["pairs"] = {"determined": False, "rank": None, "n_pairs": n * (n - 1) // 2,
                        "residual": None, "pair_forces": None, "pair_force_error": None,
                        "note": "pair forces not determined with gravity (the grain "
                                "forces carry the liquid's weight)"}
    return out
