"""Exact (Young-Laplace) companion data of the triplet table: separated states and V_coal.

Three equal unit spheres, one contact angle.  Everything here is made of exact
axisymmetric doublets (:mod:`capbridge.solvers.young_laplace`); no Surface Evolver.

Separated state at equal pressure
---------------------------------
Separate bridges that exchange liquid (through wetting films, slowly) share a total
volume V at one Laplace pressure P*.  With E_b(V_b) the energy of bridge b at its gap
(dE_b/dV_b = P_b), the equilibria are the stationary points of sum_b E_b(V_b) at
sum_b V_b = V, i.e. equal pressures, and they are stable when the Hessian
diag(dP_b/dV_b) is positive on the plane sum_b dV_b = 0.  With the compliances
c_b = dV_b/dP_b (at fixed gap) that is: either every c_b > 0 (every bridge on its
*suction-stable* branch, the one :func:`~capbridge.solvers.young_laplace.solve_doublet_suction`
returns), or exactly one c_k < 0 and sum_b c_b < 0.  The second case is not exotic:
at fixed gap the volume-controlled family runs from rupture (V_min) through a minimum
of P* (the pressure fold, V_pf) before the suction-stable branch; at d* = 0.175,
theta = 0 V_min = 0.0052 and V_pf = 0.023.  On drying, the bridge with the widest gap
reaches its pressure fold first; past it the pair stays stable while that bridge drains
into the others (P* rises again as V falls), down to the smallest total volume of the
configuration, where sum_b c_b = 0 (or the draining bridge reaches its rupture volume).
Stopping at the pressure fold would call states RUPTURED that exist.

:func:`separated_state` therefore parametrises the equilibria by the volume V_k of the
bridge with the widest gap ("master", on its whole volume-stable branch, solved at fixed
volume) and puts the others on their suction-stable branch at the master's pressure:

    V_tot(V_k) = V_k + sum_{j != k} V_j^+(P_k(V_k)).

A wider gap needs less suction, so P_k >= P_min(d_k) >= P_min(d_j) and V_j^+ exists for
every V_k.  Along this curve the stability condition above is exactly dV_tot/dV_k > 0,
so the stable equilibrium at total V is the ascending crossing V_tot(V_k) = V (found on a
scan, refined by Brent's method).  This is the state continuously connected to the wet,
all-suction-stable one; other stable equilibria with a *narrower* bridge nearly drained
near its pressure fold are not searched.  Coalescence is not checked here: above V_coal
the separated state is a reference energy, not a state the bridges can hold.

Coalescence volumes over the geometry
-------------------------------------
:func:`build_coalescence_table` sweeps
:func:`capbridge.solvers.triplet.find_coalescence` (equal volume shares, the paper's
convention and the volume reference of the Evolver triplet table) over sorted gaps
d12 <= d13 <= d23 and theta, for (a) the two bridges on the grain shared by the two
smallest gaps (bridges 12 and 13 in canonical order) and (b) the closed three-bridge
ring; it stores the full cube by permutation symmetry, the linear law
V_coal = V0 + (theta/90) dV fitted per geometry with its residual, and the interpolation
error measured on held-out geometries.

Conventions (:mod:`capbridge.dimensionless`): lengths / r, V* = V/r^3, P* = dp r/gamma,
E* = E/(gamma r^2) (E* = sum of A - cos(theta) A_wet, as in
:func:`capbridge.solvers.triplet.uncoalesced_state`), F* = F/(2 pi gamma r),
angles in degrees; grains 1, 2, 3 in text, 0, 1, 2 in arrays.
"""
from __future__ import annotations

import argparse
import dataclasses
import functools
import itertools
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import brentq, minimize_scalar

from capbridge.tables.netcdf_io import write_table
from capbridge.tables.sweep import DASK_WORKER_TIMEOUT, run_sweep
from capbridge.solvers.triplet import (CRITERIA, find_coalescence, parse_bridges,
                                         triplet_geometry, uncoalesced_state)
from capbridge.solvers.young_laplace import (SolverSettings, solve_doublet,
                                               solve_doublet_suction)
from capbridge.status import Status, cf_flag_attributes
from capbridge.physics.coalescence_fit import CoalescenceVolumeFit
from capbridge.validation import CapbridgeInputError, check_range, interval_text

__all__ = [
    "separated_state",
    "lowest_separated_energy",
    "SEPARATED_CONFIGURATIONS",
    "COALESCENCE_CONFIGURATIONS",
    "CoalescenceGrid",
    "coalescence_chunk",
    "build_coalescence_table",
    "save_coalescence_table",
    "interpolation_errors",
    "fit_errors",
    "add_arguments",
    "run_from_args",
]

#: separated configurations of a triplet: name -> bridges (0-based grain pairs)
SEPARATED_CONFIGURATIONS = {
    "12,13": ((0, 1), (0, 2)),        # two bridges on grain 1
    "12,23": ((0, 1), (1, 2)),        # ... on grain 2
    "13,23": ((0, 2), (1, 2)),        # ... on grain 3
    "12,13,23": ((0, 1), (0, 2), (1, 2)),   # closed ring
}
#: coalescence configurations of the table, in canonical order d12 <= d13 <= d23
COALESCENCE_CONFIGURATIONS = {
    "pair": ((0, 1), (0, 2)),
    "ring": ((0, 1), (0, 2), (1, 2)),
}
#: criterion codes stored in the table (-1: none found)
CRITERION_CODES = {name: k for k, name in enumerate(CRITERIA)}
_NO_CRITERION = -1


def _bridge_name(b):
    return f"{b[0] + 1}{b[1] + 1}"


def _theta(theta):
    return float(check_range("contact angle theta", theta, 0.0, 90.0, high_open=True,
                             units=" deg", hint="the exact doublet solver covers "
                             "0 <= theta < 90 deg"))


# --------------------------------------------------------------------------------------
# separated state at equal pressure
# --------------------------------------------------------------------------------------


class _Family:
    """V_tot(V_k) of one separated configuration (see the module docstring)."""

    def __init__(self, geom, theta, bridges):
        self.theta = theta
        gaps = [geom.gap(*b) for b in bridges]
        self.k = int(np.argmax(gaps))                  # master: the widest gap
        self.gap_k = gaps[self.k]
        self.others = [(n, gaps[n]) for n in range(len(bridges)) if n != self.k]
        self.n = len(bridges)

    def evaluate(self, Vk):
        """Per-bridge volumes (n, m), master pressure (m,), master status (m,)."""
        Vk = np.atleast_1d(np.asarray(Vk, float))
        r = solve_doublet(self.gap_k, Vk, self.theta)
        P = np.asarray(r["pressure"], float)
        vols = np.full((self.n, Vk.size), np.nan)
        ok = np.asarray(r["status"]) == Status.CONVERGED
        vols[self.k, ok] = Vk[ok]
        if ok.any():
            for n, d in self.others:
                s = solve_doublet_suction(d, P[ok], self.theta)
                vols[n, ok] = np.where(np.asarray(s["status"]) == Status.CONVERGED,
                                       s["volume"], np.nan)
        return vols, P, np.asarray(r["status"])

    def residual(self, Vk, V):
        """V_tot(V_k) - V (NaN where the master or another bridge does not exist)."""
        vols, _, _ = self.evaluate(Vk)
        return vols.sum(axis=0) - V


def _scan_volumes(fam, V, n_scan):
    """Master volumes of the scan: geometric from below its rupture volume to V."""
    lian = (fam.gap_k / (1.0 + 0.5 * np.radians(fam.theta))) ** 3   # Lian et al. (1993)
    lo = min(max(0.25 * lian, 1e-6 * V), 0.5 * V)
    return np.geomspace(lo, V, int(n_scan))


def _ascending_root(fam, V, n_scan, xtol):
    """(V_k, status) of the ascending crossing V_tot(V_k) = V (module docstring)."""
    Vk = _scan_volumes(fam, V, n_scan)
    vols, _, st = fam.evaluate(Vk)
    r = vols.sum(axis=0) - V
    fin = np.isfinite(r)
    if not fin.any():
        # nothing exists at any share: the master ruptures (or a solve failed)
        bad = np.any(st == Status.NOT_CONVERGED)
        return np.nan, Status.NOT_CONVERGED if bad else Status.RUPTURED
    f = functools.partial(_scalar_residual, fam, V)
    idx = np.flatnonzero(fin)
    # the last finite sign change from < 0 to >= 0 (V_tot has one minimum on the family)
    for a, b in zip(idx[-2::-1], idx[:0:-1]):
        if b == a + 1 and r[a] < 0 <= r[b]:
            return _brent(f, Vk[a], Vk[b], xtol)
    # no negative residual on the scan: is the minimum of V_tot between scan points?
    i = idx[np.argmin(r[idx])]
    lo, hi = Vk[max(i - 1, 0)], Vk[min(i + 1, len(Vk) - 1)]
    try:
        minimize_scalar(functools.partial(_stop_below_zero, f), bounds=(lo, hi),
                        method="bounded", options={"xatol": 1e-7 * V})
    except _BelowZero as hit:
        return _brent(f, hit.at, hi, xtol)
    # the smallest total volume of this configuration is above V: no separated state
    return np.nan, Status.RUPTURED


def _scalar_residual(fam, V, Vk):
    return float(fam.residual(Vk, V)[0])


class _BelowZero(Exception):
    """Raised by :func:`_stop_below_zero` at the first negative residual."""

    def __init__(self, at):
        super().__init__(at)
        self.at = at


def _stop_below_zero(f, v):
    """f(v), +inf where it is not finite; stops the minimisation once f < 0 is found."""
    x = f(v)
    if np.isfinite(x) and x < 0:
        raise _BelowZero(v)
    return x if np.isfinite(x) else np.inf


def _brent(f, a, b, xtol):
    try:
        return brentq(f, a, b, xtol=xtol, rtol=1e-15, maxiter=200), Status.CONVERGED
    except (ValueError, RuntimeError):
        return np.nan, Status.NOT_CONVERGED


def _separated_one(geom, theta, bridges, V, n_scan):
    """:func:`separated_state` for one total volume (float)."""
    fam = _Family(geom, theta, bridges)
    out = {"bridges": bridges, "master": bridges[fam.k], "total_volume": V}
    if fam.n == 1:
        Vk, status = V, Status.CONVERGED
    else:
        Vk, status = _ascending_root(fam, V, n_scan, xtol=1e-15 * V)
    if status != Status.CONVERGED:
        return out | {"status": int(status), "volumes": {b: np.nan for b in bridges},
                      "pressure": np.nan, "pressure_spread": np.nan, "energy": np.nan,
                      "forces": np.full((3, 3), np.nan), "bridge": {},
                      "pressure_stable": {b: False for b in bridges}}
    vols, P, _ = fam.evaluate([Vk * (1 - 1e-6), Vk, Vk * (1 + 1e-6)])
    v = vols[:, 1]
    # the final state: every bridge solved at its own volume (same convention and
    # solver as uncoalesced_state), so that the pressures are an independent check
    st = uncoalesced_state(V, geom, theta, bridges, fractions=v / V)
    press = np.array([float(st["bridge"][b]["pressure"]) for b in bridges])
    status = int(st["status"])
    if not np.all(np.isfinite(v)):
        status = int(Status.NOT_CONVERGED)
    dP = P[2] - P[0]           # master's dP/dV_k sign at fixed gap: pressure branch
    stable = {b: True for b in bridges}
    stable[bridges[fam.k]] = bool(dP > 0) if fam.n > 1 else True
    return out | {"status": status, "volumes": dict(zip(bridges, v.tolist())),
                  "pressure": float(np.mean(press)),
                  "pressure_spread": float(np.ptp(press)),
                  "energy": float(st["energy"]), "forces": np.asarray(st["forces"]),
                  "bridge": st["bridge"], "pressure_stable": stable}


def separated_state(d12, d13, d23, volume, theta, bridges=((0, 1), (0, 2)), n_scan=24):
    """Separate bridges sharing a total volume at equal Laplace pressure (exact doublets).

    The liquid has re-distributed between the bridges ``bridges`` of the triplet of
    unit spheres with gaps d12, d13, d23 until their pressures are equal; the stable
    equilibrium connected to the all-suction-stable state is returned (module
    docstring: the bridge with the widest gap may be past its pressure fold, draining).

    Parameters
    ----------
    d12, d13, d23 : float
        Gaps between the sphere surfaces d* = d/r [-] (grains 1-2, 1-3, 2-3).
    volume : float or array_like
        Total liquid volume V* = V/r^3 [-] of the bridges, > 0 (arrays: one state each).
    theta : float
        Contact angle on every grain [deg], 0 <= theta < 90.
    bridges : str or sequence of pairs
        Bridge layout, e.g. ``"12,13"`` or ``((0, 1), (0, 2))`` (1 to 3 bridges).
    n_scan : int
        Points of the scan of the master bridge's volume that brackets the root.

    Returns
    -------
    dict (for array ``volume``: a list of such dicts, in ``volume``'s flat order)
        ``status`` (CONVERGED; RUPTURED: the configuration does not exist at this total
        volume; NOT_CONVERGED: a solve failed), ``volumes`` {(i, j): V_b} as solved
        (their sum is the total to round-off), ``pressure`` P* (mean of the per-bridge
        pressures of the final volume-controlled solves) and ``pressure_spread`` (their
        range, a check), ``energy`` E* = sum_b (A - cos(theta) A_wet), ``forces``
        (3, 3) vector forces on the grains (frame of
        :func:`~capbridge.solvers.triplet.triplet_geometry`), ``bridge`` the per-bridge
        doublet results, ``pressure_stable`` {(i, j): bool} (False for a bridge past its
        pressure fold), ``master`` the widest-gap bridge the family is parametrised by.

    Examples
    --------
    Equal gaps share the liquid equally (above the pressure fold):

    >>> s = separated_state(0.175, 0.175, 0.075, 0.2, 30.0)
    >>> [round(v, 12) for v in s["volumes"].values()]
    [0.1, 0.1]
    """
    geom = triplet_geometry(d12, d13, d23)
    t = _theta(theta)
    bridges = parse_bridges(bridges)
    V = check_range("total volume V*", volume, 0.0, np.inf, low_open=True)
    res = [_separated_one(geom, t, bridges, float(v), n_scan) for v in V.ravel()]
    return res[0] if V.ndim == 0 else res


def lowest_separated_energy(d12, d13, d23, volume, theta, n_scan=24):
    """Lowest energy among the separated configurations that exist at total volume V*.

    Candidates: the two bridges on each of the three grains ("12,13", "12,23",
    "13,23") and the closed ring ("12,13,23"), each at equal pressure
    (:func:`separated_state`); only if none of them exists, the single bridges
    ("12", "13", "23") holding the whole volume.  This is the energy the triplet
    surrogate compares to the coalesced body's (the paper's proposed rupture criterion
    on drying).

    Parameters
    ----------
    d12, d13, d23, volume, theta, n_scan
        As in :func:`separated_state` (``volume`` a scalar).

    Returns
    -------
    dict
        ``energy`` E* (NaN if nothing exists), ``configuration`` (name of the lowest,
        "" if none), ``status`` (CONVERGED, or RUPTURED if no configuration exists,
        NOT_CONVERGED if none exists but a solve failed), ``candidates`` {name:
        (energy, status)} for every configuration tried, ``state`` the lowest state.

    On the paper's triplet (gaps 0.175, 0.175, 0.075) at V* = 0.2, theta = 0 the two
    bridges on a bottom grain (using the narrow bottom gap) are lowest
    (tests/test_triplet_coalescence.py).
    """
    V = float(check_range("total volume V*", volume, 0.0, np.inf, low_open=True))
    cands, states = {}, {}
    for name, bridges in SEPARATED_CONFIGURATIONS.items():
        s = separated_state(d12, d13, d23, V, theta, bridges, n_scan)
        cands[name], states[name] = (s["energy"], s["status"]), s
    if not any(st == Status.CONVERGED for _, st in cands.values()):
        for b in COALESCENCE_CONFIGURATIONS["ring"]:
            s = separated_state(d12, d13, d23, V, theta, (b,), n_scan)
            name = _bridge_name(b)
            cands[name], states[name] = (s["energy"], s["status"]), s
    ok = {n: e for n, (e, st) in cands.items() if st == Status.CONVERGED}
    if not ok:
        failed = any(st == Status.NOT_CONVERGED for _, st in cands.values())
        return {"energy": np.nan, "configuration": "", "candidates": cands, "state": None,
                "status": int(Status.NOT_CONVERGED if failed else Status.RUPTURED)}
    best = min(ok, key=ok.get)
    return {"energy": ok[best], "configuration": best, "status": int(Status.CONVERGED),
            "candidates": cands, "state": states[best]}


# --------------------------------------------------------------------------------------
# coalescence volumes over the geometry
# --------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CoalescenceGrid:
    """Axes of the coalescence table and its held-out points.

    ``gaps`` are the nodes of each of d12, d13, d23 (the same axis three times),
    ``theta`` [deg]; ``n_heldout`` random geometries at random theta inside the grid
    (seeded by ``seed``, per configuration) measure the interpolation error.
    """

    gaps: tuple = tuple(np.round(np.linspace(0.0, 0.3, 5), 12))
    theta: tuple = tuple(np.arange(0.0, 80.1, 20.0))
    n_heldout: int = 36
    seed: int = 20210666
    configurations: tuple = ("pair", "ring")

    def __post_init__(self):
        g = check_range("grid gap", self.gaps, 0.0, 10.0)
        check_range("grid theta", self.theta, 0.0, 90.0, high_open=True, units=" deg")
        if g.size < 1 or np.any(np.diff(g) <= 0):
            raise CapbridgeInputError(f"grid gaps {list(self.gaps)} must increase")
        if len(self.theta) < 2 or np.any(np.diff(self.theta) <= 0):
            raise CapbridgeInputError(f"grid theta {list(self.theta)} needs >= 2 "
                                      "increasing angles (for the linear fit)")
        bad = set(self.configurations) - set(COALESCENCE_CONFIGURATIONS)
        if bad or not self.configurations:
            raise CapbridgeInputError(f"configurations {list(self.configurations)}: "
                                      f"choose among {list(COALESCENCE_CONFIGURATIONS)}")

    @classmethod
    def shipped(cls, quick=False):
        """The grid of ``data/triplet_coalescence.nc`` (``quick``: a tiny one for tests).

        Gaps 0-0.3 by 0.075 (5 nodes), theta 0-80 deg by 20, chosen from the held-out
        errors measured on this grid and its halves (36 random points each):
        multilinear interpolation of V_coal has median / max relative error 0.52 % /
        1.9 % (pair) and 0.63 % / 3.1 % (ring), cubic 0.014 % / 0.17 % and 0.24 % /
        1.6 %; with the gap step doubled to 0.15 the multilinear max grows to 5.1 % /
        7.2 %, with the theta step doubled to 40 deg to 3.7 % / 4.9 %.  The ring is
        rougher because its first coalescence moves between its three shared grains.
        Cost (CPU s per point, median / max): pair 0.75 / 2.9, ring 1.8 / 8.4.
        """
        if quick:
            return cls(gaps=(0.075, 0.175), theta=(0.0, 60.0), n_heldout=2,
                       configurations=("pair",))
        return cls()

    def nodes(self, configuration):
        """Node index triples computed for a configuration, (m, 3).

        ``pair`` (bridges 12 and 13 on grain 1) is symmetric under d12 <-> d13 only:
        every d12 <= d13 and any d23.  ``ring`` is symmetric under every permutation:
        d12 <= d13 <= d23.
        """
        n = len(self.gaps)
        if configuration == "ring":
            t = list(itertools.combinations_with_replacement(range(n), 3))
        else:
            t = [(i, j, k) for i, j in itertools.combinations_with_replacement(range(n), 2)
                 for k in range(n)]
        return np.array(t, dtype=int).reshape(-1, 3)

    def heldout(self, configuration):
        """(d12, d13, d23, theta) of the held-out points, shape (4, n_heldout).

        Uniform in the grid's box, ordered as :meth:`nodes` (d12 <= d13 for ``pair``,
        all sorted for ``ring``).
        """
        rng = np.random.default_rng([self.seed, list(COALESCENCE_CONFIGURATIONS)
                                     .index(configuration)])
        g = rng.uniform(self.gaps[0], self.gaps[-1], (self.n_heldout, 3))
        g[:, :2] = np.sort(g[:, :2], axis=1)
        if configuration == "ring":
            g = np.sort(g, axis=1)
        t = rng.uniform(self.theta[0], self.theta[-1], self.n_heldout)
        return np.vstack([g.T, t])

    def as_dict(self):
        d = dataclasses.asdict(self)
        d["gaps"], d["theta"] = list(map(float, self.gaps)), list(map(float, self.theta))
        d["configurations"] = list(self.configurations)
        return d


def coalescence_chunk(d12, d13, d23, theta, configuration="pair"):
    """Chunk solver of the sweep: :func:`find_coalescence` (defaults) per point.

    ``configuration`` names the bridges (:data:`COALESCENCE_CONFIGURATIONS`).  Returns
    ``V_coal`` (total volume, equal shares; NaN where none is found), ``criterion``
    (code of :data:`CRITERION_CODES`, -1 none), ``cpu`` (CPU seconds of the point) and
    ``status`` (CONVERGED, or NOT_CONVERGED where no coalescence was found or the solve
    raised).
    """
    n = len(d12)
    V = np.full(n, np.nan)
    crit = np.full(n, _NO_CRITERION, np.int8)
    st = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    cpu = np.zeros(n)
    bridges = COALESCENCE_CONFIGURATIONS[configuration]
    for m in range(n):
        t0 = time.process_time()
        try:
            r = find_coalescence(triplet_geometry(d12[m], d13[m], d23[m]), theta[m],
                                 bridges=bridges)
        except (CapbridgeInputError, ValueError, RuntimeError):
            r = None          # flagged NOT_CONVERGED, never a number
        cpu[m] = time.process_time() - t0
        if r is not None and r.status == "coalescence":
            V[m], crit[m], st[m] = r.V_coal, CRITERION_CODES[r.criterion], 0
    return {"V_coal": V, "criterion": crit, "cpu": cpu, "status": st}


COALESCENCE_ATTRS = {
    "d12": dict(units="1", long_name="gap between the surfaces of grains 1 and 2, d*12 = d12/r"),
    "d13": dict(units="1", long_name="gap between the surfaces of grains 1 and 3, d*13 = d13/r"),
    "d23": dict(units="1", long_name="gap between the surfaces of grains 2 and 3, d*23 = d23/r"),
    "theta": dict(units="degree", long_name="contact angle on the three grains"),
    "V_coal_pair": dict(units="1", long_name=(
        "total liquid volume V* = V/r^3 at which the two bridges 12 and 13 on grain 1 "
        "coalesce (configuration (a); in the canonical order d12 <= d13 <= d23 these are "
        "the bridges on the two smallest gaps, and any two bridges on a shared grain are "
        "this variable at the permuted gaps: shared grain's gaps as d12, d13, the third "
        "as d23), equal volume shares, exact Young-Laplace; "
        "= find_coalescence(triplet_geometry(d12, d13, d23), theta).V_coal")),
    "V_coal_ring": dict(units="1", long_name=(
        "total liquid volume V* = V/r^3 at which the closed ring of bridges 12, 13, 23 "
        "first coalesces, equal volume shares, exact Young-Laplace (symmetric under "
        "every permutation of the gaps)")),
    "V0": dict(units="1", long_name="V0 of the least-squares line V_coal = V0 + (theta/90 deg) dV"),
    "dV": dict(units="1", long_name="dV of the least-squares line V_coal = V0 + (theta/90 deg) dV"),
    "fit_rms": dict(units="1", long_name="rms residual of the linear fit over the theta nodes"),
    "fit_max": dict(units="1", long_name="largest |residual| of the linear fit over the theta nodes"),
    "criterion": dict(units="1", long_name="coalescence criterion met first"),
}


def _criterion_attrs(c):
    codes = ", ".join(f"{k}: {name}" for name, k in CRITERION_CODES.items())
    return {"units": "1", "long_name": f"{COALESCENCE_ATTRS['criterion']['long_name']} ({c})",
            "criterion_codes": f"{_NO_CRITERION}: none found, {codes}",
            "criteria": "; ".join(f"{k}: {v}" for k, v in CRITERIA.items())}


def _cube_index(nodes, n, configuration):
    """Row of ``nodes`` that holds every cube index (a, b, c), by symmetry, (n, n, n)."""
    row = {tuple(t): m for m, t in enumerate(nodes.tolist())}
    idx = np.empty((n, n, n), int)
    for a, b, c in itertools.product(range(n), repeat=3):
        key = tuple(sorted((a, b, c))) if configuration == "ring" else \
            (min(a, b), max(a, b), c)
        idx[a, b, c] = row[key]
    return idx


def fit_rows(theta, V, status):
    """Linear law per geometry: (V0, dV, rms, max) arrays over the rows of V."""
    res = np.full((4, V.shape[0]), np.nan)
    for m in range(V.shape[0]):
        ok = status[m] == Status.CONVERGED
        if ok.sum() >= 2:
            f = CoalescenceVolumeFit(dtheta=90.0).fit(np.asarray(theta)[ok], V[m, ok])
            res[:, m] = f.V0, f.dV, f.rms_residual, f.max_abs_residual
    return res


def interpolation_errors(ds, config, points, values, method="linear"):
    """Relative errors of interpolating ``V_coal_<config>`` of table ``ds`` at points.

    ``points`` (4, n): d12, d13, d23, theta; ``values`` the exact V_coal there.
    Multilinear (``"linear"``) or cubic (``"cubic"``, >= 4 nodes per axis) interpolation
    of the full cube (:class:`scipy.interpolate.RegularGridInterpolator`).  Returns the
    (n,) array (interpolated - exact) / exact, NaN where either is missing.
    """
    from scipy.interpolate import RegularGridInterpolator

    axes = [ds[a].values for a in ("d12", "d13", "d23", "theta")]
    cube = ds[f"V_coal_{config}"].values
    interp = RegularGridInterpolator(axes, cube, method=method, bounds_error=True)
    return interp(np.asarray(points).T) / np.asarray(values) - 1.0


def fit_errors(ds, config, points, values):
    """Relative errors of the linear law at points: V0, dV multilinear in the gaps."""
    from scipy.interpolate import RegularGridInterpolator

    axes = [ds[a].values for a in ("d12", "d13", "d23")]
    pts = np.asarray(points)
    V0, dV = (RegularGridInterpolator(axes, ds[f"{n}_{config}"].values)(pts[:3].T)
              for n in ("V0", "dV"))
    return (V0 + pts[3] / 90.0 * dV) / np.asarray(values) - 1.0


def error_summary(err):
    e = np.abs(err[np.isfinite(err)])
    return {"median": float(np.median(e)) if e.size else np.nan,
            "max": float(np.max(e)) if e.size else np.nan, "n": int(e.size)}


def build_coalescence_table(grid=None, checkpoint_dir=None, n_jobs=None, scheduler=None,
                            progress=True, command=None, chunk_size=4,
                            worker_timeout=DASK_WORKER_TIMEOUT):
    """Coalescence volumes V_coal(d12, d13, d23, theta) over a grid, as a Dataset.

    Per configuration (``pair``: bridges 12 and 13 on grain 1, ``ring``: 12, 13, 23),
    every geometry that symmetry does not give (:meth:`CoalescenceGrid.nodes`) is solved
    once per theta by :func:`coalescence_chunk` through
    :func:`~capbridge.tables.sweep.run_sweep` (parallel, resumable from
    ``checkpoint_dir/<configuration>``, on a Dask cluster with ``scheduler``); the
    held-out points go in the same sweep.  The cube is filled by symmetry.

    Parameters
    ----------
    grid : CoalescenceGrid, optional
        Default: :meth:`CoalescenceGrid.shipped`.
    checkpoint_dir, n_jobs, scheduler, progress, worker_timeout
        As in :func:`~capbridge.tables.sweep.run_sweep`.
    command : str, optional
        The command recorded in the table.
    chunk_size : int
        Points per chunk (unit of checkpointing; a point costs ~0.5-5 CPU s for "pair"
        and ~1.5-9 CPU s for "ring").

    Returns
    -------
    xarray.Dataset
        Per configuration c: ``V_coal_c``, ``criterion_c``, ``status_c`` on (d12, d13,
        d23, theta); ``V0_c``, ``dV_c``, ``fit_rms_c``, ``fit_max_c`` on (d12, d13,
        d23); held-out points on ``heldout_c`` with their exact values and the relative
        errors of linear and cubic interpolation and of the linear law.  Global
        attributes ``interpolation_error_c`` (median, max) and
        ``cpu_seconds_per_point_c``.
    """
    grid = grid or CoalescenceGrid.shipped()
    gaps, theta = np.asarray(grid.gaps, float), np.asarray(grid.theta, float)
    nt, ng = len(theta), len(gaps)
    dims4, dims3 = ("d12", "d13", "d23", "theta"), ("d12", "d13", "d23")
    ds = xr.Dataset(
        coords={n: (n, gaps if n != "theta" else theta, COALESCENCE_ATTRS[n]) for n in dims4},
        attrs={"title": "capbridge coalescence volumes of three equal spheres (exact "
                        "Young-Laplace doublets, equal volume shares, no gravity)",
               "normalising_radius": "r, the radius of the three equal spheres",
               "coalescence_grid": _json(grid.as_dict()),
               "capbridge_command": command or _this_command(),
               "configurations": _json({c: [_bridge_name(b) for b in
                                            COALESCENCE_CONFIGURATIONS[c]]
                                        for c in grid.configurations}),
               "linear_law": "V_coal = V0 + (theta / 90 deg) dV (Miot et al. 2021, Eq. 8), "
                             "least squares over the converged theta nodes"})
    failed = 0
    for c in grid.configurations:
        nodes = grid.nodes(c)
        G = gaps[nodes]                                     # (m, 3)
        held = grid.heldout(c)
        nn = len(nodes) * nt
        inputs = {"d12": np.concatenate([np.repeat(G[:, 0], nt), held[0]]),
                  "d13": np.concatenate([np.repeat(G[:, 1], nt), held[1]]),
                  "d23": np.concatenate([np.repeat(G[:, 2], nt), held[2]]),
                  "theta": np.concatenate([np.tile(theta, len(nodes)), held[3]])}
        res = run_sweep(functools.partial(coalescence_chunk, configuration=c), inputs,
                        checkpoint_dir=None if checkpoint_dir is None
                        else Path(checkpoint_dir) / c,
                        chunk_size=chunk_size, n_jobs=n_jobs, scheduler=scheduler,
                        progress=progress, desc=f"V_coal {c}", settings=_settings(grid, c),
                        worker_timeout=worker_timeout)
        # as every generator: nothing is computed from the placeholders of failed
        # chunks (SweepFailedError: "N of M chunks failed ...; rerun", exit 3)
        res.raise_if_failed()
        failed += len(res.failures)
        ds.attrs[f"chunks_{c}"] = _json({"computed": len(res.computed),
                                         "reused_from_checkpoints": len(res.reused),
                                         "failed": len(res.failures)})
        cube = _cube_index(nodes, ng, c)
        V = res["V_coal"][:nn].reshape(-1, nt)
        st = res["status"][:nn].reshape(-1, nt).astype(np.int8)
        crit = res["criterion"][:nn].reshape(-1, nt).astype(np.int8)
        ds[f"V_coal_{c}"] = (dims4, V[cube], COALESCENCE_ATTRS[f"V_coal_{c}"])
        ds[f"criterion_{c}"] = (dims4, crit[cube], _criterion_attrs(c))
        ds[f"status_{c}"] = (dims4, st[cube], cf_flag_attributes() | {
            "long_name": f"status of V_coal_{c} (not_converged: no coalescence found)"})
        for name, row in zip(("V0", "dV", "fit_rms", "fit_max"), fit_rows(theta, V, st)):
            ds[f"{name}_{c}"] = (dims3, row[cube], {
                "units": "1", "long_name": f"{COALESCENCE_ATTRS[name]['long_name']} ({c})"})
        hd = f"heldout_{c}"
        ds.coords[hd] = (hd, np.arange(held.shape[1]),
                         {"units": "1", "long_name": f"index of the held-out point ({c})"})
        for a, name in enumerate(dims4):
            ds[f"{hd}_{name}"] = (hd, held[a], {"units": COALESCENCE_ATTRS[name]["units"],
                                                "long_name": f"held-out point ({c}): "
                                                f"{COALESCENCE_ATTRS[name]['long_name']}"})
        Vh = res["V_coal"][nn:]
        ds[f"{hd}_V_coal"] = (hd, Vh, {"units": "1",
                                       "long_name": f"exact V_coal ({c}) at the held-out point"})
        ds[f"{hd}_status"] = (hd, res["status"][nn:].astype(np.int8), cf_flag_attributes()
                              | {"long_name": f"status of {hd}_V_coal"})
        errs = {}
        for method in ("linear", "cubic"):
            if min(ng, nt) >= (4 if method == "cubic" else 2):
                e = interpolation_errors(ds, c, held, Vh, method)
                ds[f"{hd}_error_{method}"] = (hd, e, {
                    "units": "1", "long_name": f"relative error of {method} interpolation "
                    f"of V_coal_{c} at the held-out point"})
                errs[method] = error_summary(e)
        if ng >= 2:
            e = fit_errors(ds, c, held, Vh)
            ds[f"{hd}_error_fit"] = (hd, e, {
                "units": "1", "long_name": "relative error of the linear law (V0, dV "
                f"multilinear in the gaps) for V_coal_{c} at the held-out point"})
            errs["linear_law"] = error_summary(e)
        ds.attrs[f"interpolation_error_{c}"] = _json(errs)
        cpu = res["cpu"][res["cpu"] > 0]
        ds.attrs[f"cpu_seconds_per_point_{c}"] = _json({
            "median": float(np.median(cpu)) if cpu.size else np.nan,
            "mean": float(np.mean(cpu)) if cpu.size else np.nan,
            "max": float(np.max(cpu)) if cpu.size else np.nan, "n": int(cpu.size),
            "note": "CPU seconds of find_coalescence per point (process time, so a shared "
                    "machine inflates it little)"})
    ds.attrs["n_failed_chunks"] = failed
    return ds


def _json(obj):
    return json.dumps(obj, sort_keys=True)


def _settings(grid, configuration=None):
    return {"solver": SolverSettings().as_dict(), "grid": grid.as_dict(),
            "configuration": configuration,
            "find_coalescence": "defaults (equal volume shares, n_scan=48, v_max=2.5, "
                                "xtol=1e-9)"}


def _this_command():
    return " ".join(shlex.quote(a) for a in [Path(sys.argv[0]).name] + sys.argv[1:])


def save_coalescence_table(ds, path, command=None, overwrite=False):
    """Write the coalescence table with CF attributes and provenance.

    ``command`` is recorded in the file (default: the table's ``capbridge_command``).
    As for every capbridge table (:func:`~capbridge.tables.netcdf_io.write_table`),
    an existing file is replaced only if it is a table of the same grid, or with
    ``overwrite=True`` (:class:`~capbridge.tables.netcdf_io.TableExistsError`
    otherwise).
    """
    grid = CoalescenceGrid(**{k: tuple(v) if isinstance(v, list) else v for k, v in
                              json.loads(ds.attrs["coalescence_grid"]).items()})
    return write_table(ds, path, command=command or ds.attrs.get("capbridge_command",
                                                                 _this_command()),
                       solver_settings=_settings(grid), overwrite=overwrite)


# --------------------------------------------------------------------------------------
# command line (to be wired into `capbridge generate coalescence`)
# --------------------------------------------------------------------------------------


def add_arguments(p):
    """Options of ``capbridge generate coalescence`` on an argparse parser."""
    p.add_argument("--quick", action="store_true", help="tiny grid (tests)")
    p.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    p.add_argument("--worker-timeout", type=_seconds, default=DASK_WORKER_TIMEOUT,
                   help="Dask: seconds without any worker before the sweep fails (default "
                        f"{DASK_WORKER_TIMEOUT:g})")
    p.add_argument("--checkpoint-dir", default=None, help="resumable checkpoints here")
    p.add_argument("--output", default=None,
                   help="netCDF file (default data/triplet_coalescence.nc, "
                        "or triplet_coalescence_quick.nc with --quick)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing --output of another grid")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def _seconds(text):
    """argparse type of ``--worker-timeout``: a finite number of seconds > 0."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not np.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(
            f"{v!r} is outside the allowed range {interval_text(0, np.inf, low_open=True)}")
    return v


def _table_grid(grid):
    """Dimension coordinates of the table ``grid`` makes (for the target check)."""
    axes = {a: list(map(float, grid.gaps)) for a in ("d12", "d13", "d23")}
    axes["theta"] = list(map(float, grid.theta))
    for c in grid.configurations:
        axes[f"heldout_{c}"] = list(range(grid.n_heldout))
    return axes


def run_from_args(args, command=None):
    """Build and write the table from parsed :func:`add_arguments` options.

    The output is checked before computing (directory, and no other file or table of
    another grid replaced without ``--overwrite``).  Returns the exit code 0; if some
    chunks failed, :class:`~capbridge.tables.sweep.SweepFailedError` (no table is
    written; rerun with the same ``--checkpoint-dir`` to retry them).
    """
    from capbridge.tables.netcdf_io import check_table_target

    if args.jobs is not None and args.jobs < 1:
        raise CapbridgeInputError(f"--jobs={args.jobs} is outside the allowed range [1, inf)")
    grid = CoalescenceGrid.shipped(quick=args.quick)
    out = Path(args.output or ("triplet_coalescence_quick.nc" if args.quick
                               else "data/triplet_coalescence.nc"))
    check_table_target(out, _table_grid(grid), overwrite=args.overwrite, flag="--overwrite")
    command = command or _this_command()
    t0 = time.perf_counter()
    ds = build_coalescence_table(grid, checkpoint_dir=args.checkpoint_dir, n_jobs=args.jobs,
                                 scheduler=args.scheduler, progress=not args.no_progress,
                                 command=command, worker_timeout=args.worker_timeout)
    # with chunks reused from checkpoints (attributes chunks_<configuration>) this is
    # the time of the last run only; cpu_seconds_per_point_<configuration> is the cost
    ds.attrs["wall_seconds_of_this_run"] = round(time.perf_counter() - t0, 1)
    save_coalescence_table(ds, out, command=command, overwrite=args.overwrite)
    print(f"wrote {out}")
    for c in grid.configurations:
        print(f"{c}: CPU s per point {ds.attrs[f'cpu_seconds_per_point_{c}']}")
        print(f"{c}: interpolation error {ds.attrs[f'interpolation_error_{c}']}")
    return 0


def main(argv=None):
    p = add_arguments(argparse.ArgumentParser(
        prog="python -m capbridge.tables.coalescence",
        description="Coalescence volumes of three equal spheres over the geometry"))
    argv = sys.argv[1:] if argv is None else list(argv)
    args = p.parse_args(argv)
    command = " ".join([p.prog] + [shlex.quote(a) for a in argv])
    from capbridge.tables.sweep import SweepFailedError

    try:
        return run_from_args(args, command=command)
    except CapbridgeInputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except SweepFailedError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 3


if __name__ == "__main__":
    # run the module's own copy (not __main__'s), so that the sweep's solver is named
    # capbridge.tables.coalescence.coalescence_chunk whichever way it starts
    # and checkpoints are shared with `capbridge generate coalescence`
    from capbridge.tables.coalescence import main as _main

    sys.exit(_main())
