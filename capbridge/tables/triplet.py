"""Coalesced-triplet force tables: Surface Evolver swept over (d12, d13, d23, theta, v).

One liquid body wetting three equal spheres (radius r, lengths / r) is minimised by
Surface Evolver (:func:`capbridge.solvers.triplet_evolver.evolver_triplet`) on a grid
of

* the three gaps d12, d13, d23 between the sphere surfaces,
* the contact angle theta (the same on the three grains),
* the volume ratio v = V* / V*_coal, where V*_coal(d12, d13, d23, theta) is the exact
  coalescence volume of the two bridges on the shared grain of the two smallest gaps
  (equal volume shares; :func:`capbridge.solvers.triplet.find_coalescence`).

Why these coordinates: the coalesced body exists from somewhat below V_coal (drying:
it stops being an equilibrium there, flagged by status) upwards, and V_coal varies by a
factor of ~3 over the geometries and angles; scaling the volume by it keeps the table
rectangular and puts the physically equivalent states (just coalesced, well coalesced)
on the same rows.

Permutation symmetry: a triplet and its relabelled copies are one physical state.  Only
the canonical geometries d12 <= d13 <= d23 are computed
(:func:`capbridge.dimensionless.canonical_triplet`), each once; the stored table is the
full cube, every other point a relabelled copy (pair forces permuted, force vectors
rotated into the frame of :func:`capbridge.solvers.triplet.triplet_geometry` of that
point).

Per point: the force vector on each grain (frame: grains 2 and 3 on the x axis symmetric
about x = 0, grain 1 at z > 0, plane y = 0), the effective pair forces f12, f13, f23
along the centre lines (exact decomposition without gravity, residual stored), P*, E*,
an error estimate of the forces (Richardson over the refinement levels), the refinement
level, Evolver CPU time, status and, for points that failed, the kind of failure (a
pinching or folding body well below V_coal is a coalesced body that does not exist).

Held-out points (random geometries, angles and volumes off the grid, solved one
refinement level finer than the table) are stored in the same file for the surrogate's
error model.
"""
from __future__ import annotations

import dataclasses
import functools
import json
import logging
import shlex
import sys

import numpy as np
import xarray as xr

from capbridge.dimensionless import TRIPLET_PAIR_NAMES, TRIPLET_PAIRS, canonical_triplet
from capbridge.tables.netcdf_io import write_table
from capbridge.tables.sweep import DASK_WORKER_TIMEOUT, run_sweep
from capbridge.tables.triplet_gravity import (GravityPlan, gravity_chunk,
                                                 gravity_holdout_chunk,
                                                 rotate_gravity_tensor, stack_tensors,
                                                 sum_rule_status)
from capbridge.status import HAS_RESULT, Status, cf_flag_attributes, status_in

__all__ = ["TripletGrid", "EvolverPlan", "build_triplet_table", "save_triplet_table",
           "table_axes",
           "reference_chunk", "separated_chunk", "coalesced_chunk", "FAILURE_KINDS", "failure_kind"]

log = logging.getLogger(__name__)

PAIRS, PAIR_NAMES = TRIPLET_PAIRS, TRIPLET_PAIR_NAMES
COMPONENTS = ("x", "y", "z")

#: failure kinds of a point (stored as flags in ``failure``); the order is the code
FAILURE_KINDS = {
    "none": "computed",
    "no_equilibrium": "the body pinched off, lost a contact line or ran away: no "
                      "coalesced equilibrium at this volume",
    "mesh": "degenerate, folded or penetrating mesh at every starting ring",
    "timeout": "an Evolver run exceeded its time limit",
    "other": "any other failure (reason in the sweep log)",
    "no_reference": "no coalescence volume of the separate bridges was found",
    "not_computed": "outside the computed domain of the grid (two gaps above its "
                    "max_bridge_gap)",
}
_FAILURE_WORDS = (("no_equilibrium", ("pinch", "contact line", "vanished", "energy below",
                                      "runaway", "neck")),
                  ("timeout", ("timed out", "timeout", "time limit")),
                  ("mesh", ("fold", "degenerate", "penetration", "inside", "orientation",
                            "no facets", "mesh")))

ATTRS = {
    "theta": dict(units="degree", long_name="contact angle on the three grains"),
    "v": dict(units="1", long_name="volume ratio v = V*/V*_coal (total liquid volume over "
                                   "the coalescence volume of the separate bridges)"),
    "grain": dict(units="1", long_name="grain number (1 is the grain shared by the two "
                                       "smallest gaps in the canonical order)"),
    "component": dict(units="1", long_name="Cartesian component in the table frame "
                                           "(grains 2, 3 on the x axis symmetric about "
                                           "x = 0, grain 1 at z > 0, plane y = 0)"),
    "volume": dict(units="1", long_name="total liquid volume V* = V/r^3"),
    "volume_coalescence": dict(
        units="1", long_name="exact coalescence volume V*_coal of the two separate bridges "
                             "on the grain shared by the two smallest gaps, equal volume "
                             "shares (capbridge.solvers.triplet.find_coalescence)"),
    "energy_separated": dict(units="1", long_name="energy E* of the lowest separated state "
                             "(exact bridges at equal pressure) at the same total volume; "
                             "NaN where no separated state exists"),
    "force": dict(units="1", long_name="force of the liquid on each grain F* = F/(2 pi "
                                       "gamma r), Richardson-extrapolated virtual work"),
    "pair_residual": dict(units="1", long_name="residual |A f - F| / max|F_i| of the pair "
                                               "force decomposition"),
    "pressure": dict(units="1", long_name="capillary pressure P* = (p_liquid - p_gas) "
                                          "r/gamma"),
    "energy": dict(units="1", long_name="surface energy E* = (A_lg - cos(theta) A_wet)/"
                                        "r^2 at the finest level"),
    "energy_extrapolated": dict(units="1", long_name="surface energy E*, Richardson-"
                                                     "extrapolated over the levels"),
    "energy_error": dict(units="1", long_name="estimated error of the energy E*"),
    "force_error": dict(units="1", long_name="estimated error of the forces: largest "
                                             "component, F*"),
    "force_error_rel": dict(units="1", long_name="estimated error of the forces relative "
                                                 "to the largest grain force"),
    "direct_vs_virtual_work": dict(units="1", long_name="largest difference between the "
                                                        "forces from the shape and by "
                                                        "virtual work at the finest "
                                                        "level, F*"),
    "refinement": dict(units="1", long_name="Surface Evolver refinement level of the "
                                            "finest mesh used"),
    "n_facets": dict(units="1", long_name="facets of the finest mesh"),
    "cpu_time": dict(units="s", long_name="Surface Evolver CPU time of the point"),
}
for (_i, _j), _f in zip(PAIRS, PAIR_NAMES):
    ATTRS[f"d{_i + 1}{_j + 1}"] = dict(units="1", long_name=f"gap between the surfaces of "
                                       f"grains {_i + 1} and {_j + 1}, d*/r")
    ATTRS[_f] = dict(units="1", long_name=f"effective pair force between grains {_i + 1} and "
                                          f"{_j + 1} along their centre line, F*, attraction > 0")


@dataclasses.dataclass(frozen=True)
class TripletGrid:
    """Axes of a coalesced-triplet table (gaps / r, theta in degrees, v = V*/V*_coal).

    ``max_bridge_gap``: only geometries whose two smaller gaps (the two bridges on the
    shared grain) are at most this are computed; the largest gap, the open side of the
    triangle, runs over the whole gap axis.  That is the domain packings reach (issue
    18: the bridge gaps are contacts, the third side opens up to ~0.6 r); the stored
    cube's other nodes are ``not_computed``.  None: every geometry of the cube.
    """

    gaps: tuple = (0.0, 0.1, 0.2)
    theta: tuple = (0.0, 20.0, 40.0, 60.0, 80.0)
    v: tuple = (0.7, 0.85, 1.0, 1.25, 1.6, 2.0)
    max_bridge_gap: float | None = None

    @classmethod
    def shipped(cls, quick=False):
        """The grid of ``data/triplet_table.nc`` (``quick``: two nodes per axis, the
        smallest grid the surrogate accepts: 4 canonical geometries x 2 x 2 = 16 points;
        theta 0 and 30 deg, where the exact separated states cost least)."""
        if quick:
            return cls((0.05, 0.15), (0.0, 30.0), (1.0, 1.3))
        return cls()

    @classmethod
    def packings(cls):
        """The grid of the second triplet table (issue 18): bridge gaps 0-0.2, the open
        side up to 0.6, theta 0-80 deg, v up to 5 (the p99 of v at 5 % water in 1,000-grain
        packings is 4.6).  Axes continue the first table's spacing: gaps by 0.1 to
        0.3, then 0.15 (the open side's pull decays smoothly); v geometric, ratio ~1.25."""
        return cls(gaps=(0.0, 0.1, 0.2, 0.3, 0.45, 0.6),
                   v=(0.7, 0.85, 1.0, 1.25, 1.6, 2.0, 2.5, 3.2, 4.0, 5.0),
                   max_bridge_gap=0.2)

    def as_dict(self):
        out = {k: [float(x) for x in v] for k, v in dataclasses.asdict(self).items()
               if k != "max_bridge_gap"}
        if self.max_bridge_gap is not None:
            out["max_bridge_gap"] = float(self.max_bridge_gap)
        return out

    def computed(self, sorted_gaps):
        """True where sorted gap triples (..., 3) lie in the computed domain."""
        g = np.asarray(sorted_gaps, float)
        if self.max_bridge_gap is None:
            return np.ones(g.shape[:-1], bool)
        return g[..., 1] <= self.max_bridge_gap + 1e-12

    def canonical_geometries(self):
        """Sorted gap triples (d12 <= d13 <= d23) from the gap axis, (n, 3): those of
        the computed domain (``max_bridge_gap``)."""
        g = np.asarray(self.gaps, float)
        idx = [(a, b, c) for a in range(g.size) for b in range(a, g.size)
               for c in range(b, g.size)]
        canon = g[np.array(idx)]
        return canon[self.computed(canon)]


@dataclasses.dataclass(frozen=True)
class EvolverPlan:
    """Surface Evolver settings of a table (chosen from measured time against error:
    ``benchmarks/RESULTS.md``, "Triplet table").

    Level 3 with virtual work, Richardson-extrapolated from levels 1-3, costs ~10 CPU s
    per point and lands within 0.4 % of level 4 at theta = 0 (0.15 % at 30 deg); forces
    from the shape alone at level 3 (1.5 CPU s) were 3 % low at theta = 0 and do not
    converge monotonically over the levels, so they are kept as a diagnostic only.
    """

    max_refine: int = 3
    ftol: float = 1e-2            # relative force error allowed (estimate, Richardson)
    etol: float = 1e-2            # relative energy error allowed
    level_timeout: float = 150.0
    total_timeout: float = 300.0
    retry_rings: tuple = (8, 12)

    @classmethod
    def shipped(cls, quick=False):
        """The settings of ``data/triplet_table.nc`` (``quick``: level 2, the coarsest
        with an error estimate: virtual work at levels 1 and 2; its estimates, ~3 %,
        are above ``ftol``, so the quick table's points are ``above_tolerance``, and
        its held-out points are at level 3)."""
        if quick:
            return cls(max_refine=2)
        return cls()

    def settings(self):
        return dataclasses.asdict(self)

    def finer(self):
        """Settings of the held-out points: exactly one level finer (tolerances 0, so
        that no point stops early at the table's own level)."""
        return dataclasses.replace(self, max_refine=self.max_refine + 1, ftol=0.0, etol=0.0,
                                   level_timeout=4 * self.level_timeout,
                                   total_timeout=4 * self.total_timeout)


GRAVITY_ATTRS = {
    "force_gravity_gradient": dict(units="1", long_name="first-order response of the force "
                                   "on each grain to gravity, dF*_i/db_k with b = Bo g_hat "
                                   "(central differences at Bo = bond_step)"),
    "force_gravity_curvature": dict(units="1", long_name="diagonal second-order response "
                                    "d2F*_i/db_k2 (F(b) = F(0) + G b + C b^2 / 2 per "
                                    "component of b; mixed terms not computed)"),
    "gravity_sum_residual": dict(units="1", long_name="residual of the sum rule sum_i "
                                 "dF_i/db = V*/(2 pi) (the grains carry the weight), "
                                 "relative to V*/(2 pi)"),
    "gravity_cpu_time": dict(units="s", long_name="Surface Evolver CPU time of the gravity "
                                                  "response of the point"),
    "bond": dict(units="1", long_name="Bond number Bo = drho g r^2 / gamma"),
    "direction": dict(units="1", long_name="unit vector along which gravity pulls, table "
                                           "frame"),
}


def failure_kind(status, reason):
    """Code of :data:`FAILURE_KINDS` for an Evolver result's status and reason."""
    if status != Status.NOT_CONVERGED:
        return 0
    text = reason.lower()
    for kind, words in _FAILURE_WORDS:
        if any(w in text for w in words):
            return list(FAILURE_KINDS).index(kind)
    return list(FAILURE_KINDS).index("other")


# Module-level chunk solvers: picklable for worker processes and Dask.

def reference_chunk(d12, d13, d23, theta):
    """Exact coalescence volume of the two bridges on grain 1 (canonical geometries)."""
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry

    out = np.full(d12.size, np.nan)
    status = np.full(d12.size, int(Status.CONVERGED), np.int8)
    for n in range(d12.size):
        r = find_coalescence(triplet_geometry(d12[n], d13[n], d23[n]), theta[n])
        if r.status == "coalescence":
            out[n] = r.V_coal
        else:
            status[n] = Status.NOT_CONVERGED
    return {"volume_coalescence": out, "status": status}


def separated_chunk(d12, d13, d23, theta, volume):
    """Energy of the lowest separated state (exact bridges at equal pressure) at the
    same total volume (:func:`capbridge.tables.coalescence.lowest_separated_energy`)."""
    from capbridge.tables.coalescence import lowest_separated_energy

    energy = np.full(d12.size, np.nan)
    status = np.full(d12.size, int(Status.NOT_CONVERGED), np.int8)
    for n in range(d12.size):
        if np.isfinite(volume[n]):
            r = lowest_separated_energy(d12[n], d13[n], d23[n], volume[n], theta[n])
            energy[n], status[n] = r["energy"], r["status"]
    return {"energy_separated": energy, "status": status}


_FORCE_COLUMNS = [f"force_{g + 1}{c}" for g in range(3) for c in COMPONENTS]
_POINT_OUTPUTS = (["pressure", "energy", "energy_extrapolated", "energy_error",
                   "force_error", "force_error_rel", "direct_vs_virtual_work",
                   "pair_residual", "cpu_time"] + list(PAIR_NAMES) + _FORCE_COLUMNS)


def coalesced_chunk(d12, d13, d23, theta, volume, *, plan):
    """One Evolver minimisation of the coalesced body per point (canonical frame)."""
    from capbridge.solvers.triplet import triplet_geometry
    from capbridge.solvers.triplet_evolver import evolver_triplet

    m = d12.size
    out = {k: np.full(m, np.nan) for k in _POINT_OUTPUTS}
    out |= {"refinement": np.full(m, -1, np.int16), "n_facets": np.zeros(m, np.int32),
            "failure": np.zeros(m, np.int8), "status": np.zeros(m, np.int8)}
    for n in range(m):
        if not np.isfinite(volume[n]):
            out["status"][n] = Status.NOT_CONVERGED
            out["failure"][n] = list(FAILURE_KINDS).index("no_reference")
            continue
        geom = triplet_geometry(d12[n], d13[n], d23[n])
        r = evolver_triplet(float(volume[n]), geom, float(theta[n]), "coalesced",
                            max_refine=plan.max_refine, tol=plan.ftol, inspect_mesh=False,
                            etol=plan.etol, flag_above_tolerance=True, workers=1,
                            retry_rings=plan.retry_rings,
                            level_timeout=plan.level_timeout,
                            total_timeout=plan.total_timeout)
        st = Status(r["status_code"])
        out["status"][n] = st
        out["failure"][n] = failure_kind(st, r["reason"])
        out["cpu_time"][n] = r["cpu_time"]
        out["refinement"][n] = r["refinement"]
        out["n_facets"][n] = r["n_facets"]
        if r["forces"] is None:
            continue
        F = np.asarray(r["forces"], float)
        for g in range(3):
            for c, name in enumerate(COMPONENTS):
                out[f"force_{g + 1}{name}"][n] = F[g, c]
        for key, name in zip(("12", "13", "23"), PAIR_NAMES):
            out[name][n] = r["pair_forces"][key]
        out["pair_residual"][n] = r["pair_residual"]
        out["force_error"][n] = np.nanmax(np.abs(r["force_error"]))
        out["force_error_rel"][n] = r["force_error_rel"]
        out["direct_vs_virtual_work"][n] = r.get("direct_vs_vw", np.nan)
        out["energy"][n] = r["energy"]
        out["energy_extrapolated"][n] = r["energy_extrapolated"]
        out["energy_error"][n] = r["energy_error"]
        out["pressure"][n] = r["pressure"]
    return out


def _frame_rotation(canonical_centres, centres):
    """2-D orthogonal map (x, z) taking the relabelled canonical centres onto ``centres``
    (Procrustes, reflections allowed: both lie in the plane y = 0)."""
    A = canonical_centres[:, [0, 2]] - canonical_centres[:, [0, 2]].mean(axis=0)
    B = centres[:, [0, 2]] - centres[:, [0, 2]].mean(axis=0)
    U, _, Vt = np.linalg.svd(A.T @ B)
    return U @ Vt


def _expand_to_cube(grid, canon, values):
    """Full cube (d12, d13, d23, ...) from per-canonical-geometry arrays.

    ``values``: name -> array (n_canonical, ...).  Pair forces are permuted, force
    vectors relabelled and rotated; everything else is copied."""
    from capbridge.solvers.triplet import triplet_geometry

    g = np.asarray(grid.gaps, float)
    ng = g.size
    index = {tuple(np.round(c, 12)): k for k, c in enumerate(canon)}
    out = {name: np.empty((ng, ng, ng) + v.shape[1:], v.dtype) for name, v in values.items()}
    for a in range(ng):
        for b in range(ng):
            for c in range(ng):
                gaps = (g[a], g[b], g[c])
                srt, perm = canonical_triplet(*gaps)
                k = index.get(tuple(np.round(srt, 12)))
                if k is None:                  # outside the computed domain
                    for name in out:
                        out[name][a, b, c] = _not_computed(name, out[name].dtype)
                    continue
                # pair (i, j) of this point is pair (inv[i], inv[j]) of the canonical one
                inv = np.argsort(perm)
                for name, v in values.items():
                    if name in PAIR_NAMES:
                        continue
                    if name.startswith("force_gravity"):
                        Q = _frame_rotation(triplet_geometry(*srt).centres[inv],
                                            triplet_geometry(*gaps).centres)
                        out[name][a, b, c] = rotate_gravity_tensor(v[k][..., inv, :, :], Q)
                    elif name == "force":
                        Fc = v[k]                      # (..., grain, component)
                        Q = _frame_rotation(triplet_geometry(*srt).centres[inv],
                                            triplet_geometry(*gaps).centres)
                        F = Fc[..., inv, :].copy()
                        F[..., [0, 2]] = F[..., [0, 2]] @ Q
                        out[name][a, b, c] = F
                    else:
                        out[name][a, b, c] = v[k]
                for (i, j), name in zip(PAIRS, PAIR_NAMES):
                    if name not in values:
                        continue
                    p, q = sorted((inv[i], inv[j]))
                    out[name][a, b, c] = values[PAIR_NAMES[PAIRS.index((p, q))]][k]
    return out


def _not_computed(name, dtype):
    """The stored value of a cube node outside the computed domain."""
    if name in ("status", "gravity_status"):
        return Status.NOT_COMPUTED
    if name == "failure":
        return list(FAILURE_KINDS).index("not_computed")
    if name == "refinement":
        return -1
    return 0 if np.issubdtype(dtype, np.integer) else np.nan


def _holdout_points(grid, n, seed):
    """Random canonical geometries, angles and volume ratios inside the grid's box
    (and its computed domain: the two smaller gaps up to ``max_bridge_gap``)."""
    rng = np.random.default_rng(seed)
    lo, hi = min(grid.gaps), max(grid.gaps)
    if grid.max_bridge_gap is None:
        g = np.sort(rng.uniform(lo, hi, (n, 3)), axis=1)
    else:
        pair = np.sort(rng.uniform(lo, grid.max_bridge_gap, (n, 2)), axis=1)
        g = np.column_stack([pair, rng.uniform(pair[:, 1], hi)])
    t = rng.uniform(min(grid.theta), max(grid.theta), n)
    v = rng.uniform(min(grid.v), max(grid.v), n)
    return g, t, v


def table_axes(grid: TripletGrid, n_holdout=0, gravity: GravityPlan | None = None):
    """The dimension coordinates of the table :func:`build_triplet_table` makes (for
    the check of the output before the sweep): dimensions of length 0 are absent."""
    axes = {"d12": grid.gaps, "d13": grid.gaps, "d23": grid.gaps, "theta": grid.theta,
            "v": grid.v, "grain": (1, 2, 3), "component": (0, 1, 2)}
    if n_holdout:
        axes["holdout"] = range(n_holdout)
    if gravity is not None:
        axes |= {"gravity_v": gravity.v, "gravity_component": (0, 1, 2)}
        n = len(gravity.cases_inside(grid)[0]) * len(gravity.bonds)
        if n:
            axes["gravity_holdout"] = range(n)
    return {k: [float(x) for x in v] for k, v in axes.items()}


def build_triplet_table(grid: TripletGrid, *, plan: EvolverPlan | None = None,
                        n_holdout=0, checkpoint_dir=None, n_jobs=None, scheduler=None,
                        progress=True, command=None, seed=1,
                        exact_only=False, gravity: GravityPlan | None = None,
                        worker_timeout=DASK_WORKER_TIMEOUT) -> xr.Dataset | None:
    """Run the sweep (resumable) and return the table as a labelled Dataset.

    Phases: exact coalescence volumes of the canonical geometries; the coalesced body
    at every canonical (geometry, theta, v) point; ``n_holdout`` held-out points one
    level finer.  Each phase is its own checkpointed sweep; a phase with failed chunks
    stops the build (rerun to retry) instead of computing on placeholders.
    ``gravity``: also the response of the forces to gravity on the liquid on the
    plan's sub-grid of v, and its held-out checks against direct minimisations with
    gravity (:mod:`capbridge.tables.triplet_gravity`); held-out cases outside the
    grid's box cannot check it and are skipped (logged, counted in the attribute
    ``gravity_holdout_cases_skipped``).
    ``worker_timeout``: Dask, see :func:`~capbridge.tables.sweep.run_sweep`.
    ``exact_only``: run the exact phases (coalescence volumes, separated-state
    energies) into the checkpoints and return None, e.g. beside a running Evolver
    sweep on the same checkpoint directory.
    """
    plan = plan or EvolverPlan()
    canon = grid.canonical_geometries()
    theta = np.asarray(grid.theta, float)
    v = np.asarray(grid.v, float)
    nc, nt, nv = len(canon), theta.size, v.size

    def phase(name, fn, inputs, chunk_size, settings):
        ck = None if checkpoint_dir is None else f"{checkpoint_dir}/{name}"
        res = run_sweep(fn, inputs, checkpoint_dir=ck, chunk_size=chunk_size, n_jobs=n_jobs,
                        scheduler=scheduler, progress=progress, desc=name,
                        settings=settings, worker_timeout=worker_timeout)
        return res.raise_if_failed()

    G, T = np.repeat(canon, nt, axis=0), np.tile(theta, nc)
    ref = phase("coalescence_volumes", reference_chunk,
                {"d12": G[:, 0], "d13": G[:, 1], "d23": G[:, 2], "theta": T}, 8, {})
    vref = ref["volume_coalescence"].reshape(nc, nt)
    vol = vref[..., None] * v                               # (nc, nt, nv)
    Gp = np.repeat(canon, nt * nv, axis=0)
    pts = {"d12": Gp[:, 0], "d13": Gp[:, 1], "d23": Gp[:, 2],
           "theta": np.tile(np.repeat(theta, nv), nc), "volume": vol.ravel()}
    if exact_only:
        # the exact separated states: hours for a large grid, so they can run in their
        # own process beside the full build (whose Evolver phase comes first and which
        # then finds these chunks done)
        phase("separated_energies", separated_chunk, pts, 4, {})
        return None
    res = phase("coalesced_bodies", functools.partial(coalesced_chunk, plan=plan), pts, 1,
                plan.settings())
    sep = phase("separated_energies", separated_chunk, pts, 4, {})
    shape = (nc, nt, nv)
    per = {name: res[name].reshape(shape) for name in _POINT_OUTPUTS
           if name not in _FORCE_COLUMNS}
    per["force"] = np.stack([np.stack([res[f"force_{g + 1}{c}"] for c in COMPONENTS], -1)
                             for g in range(3)], -2).reshape(shape + (3, 3))
    for name in ("refinement", "n_facets", "failure", "status"):
        per[name] = res[name].reshape(shape)
    per["volume"] = vol
    per["energy_separated"] = sep["energy_separated"].reshape(shape)
    per["volume_coalescence"] = vref
    cube = _expand_to_cube(grid, canon, per)

    dims = ("d12", "d13", "d23", "theta", "v")
    data = {}
    for name, arr in cube.items():
        if name == "force":
            data[name] = (dims + ("grain", "component"), arr, ATTRS[name])
        elif name == "volume_coalescence":
            data[name] = (dims[:4], arr, ATTRS[name])
        elif name == "status":
            data[name] = (dims, arr.astype(np.int8), cf_flag_attributes())
        elif name == "failure":
            data[name] = (dims, arr.astype(np.int8), {
                "units": "1", "long_name": "kind of failure of the point",
                "flag_values": np.arange(len(FAILURE_KINDS), dtype=np.int8),
                "flag_meanings": " ".join(FAILURE_KINDS)})
        else:
            data[name] = (dims, arr, ATTRS[name])
    coords = {"d12": ("d12", np.asarray(grid.gaps, float), ATTRS["d12"]),
              "d13": ("d13", np.asarray(grid.gaps, float), ATTRS["d13"]),
              "d23": ("d23", np.asarray(grid.gaps, float), ATTRS["d23"]),
              "theta": ("theta", theta, ATTRS["theta"]), "v": ("v", v, ATTRS["v"]),
              "grain": ("grain", np.arange(1, 4, dtype=np.int8), ATTRS["grain"]),
              "component": ("component", np.arange(3, dtype=np.int8),
                            ATTRS["component"] | {"flag_meanings": "x y z"})}
    ds = xr.Dataset(data, coords=coords)
    if n_holdout:
        ds = ds.merge(_holdout_dataset(grid, plan.finer(), n_holdout, seed, phase))
    if gravity is not None:
        gds = _gravity_dataset(grid, gravity, canon, vref, per["status"], phase)
        ds = ds.merge(gds)
        ds.attrs.update(gds.attrs)            # merge keeps only the first one's attributes
    ds.attrs.update({
        "title": "capbridge coalesced-triplet capillary-force table (Surface Evolver, "
                 "three equal spheres, " + ("no gravity)" if gravity is None else
                                            "response to gravity on the liquid)"),
        "normalising_radius": "r, the radius of the three equal grains",
        "grid": json.dumps(grid.as_dict()),
        "evolver_settings": json.dumps(plan.settings()),
        "failure_kinds": json.dumps(FAILURE_KINDS),
        "capbridge_command": command or _this_command()})
    return ds


def _holdout_dataset(grid, plan, n, seed, phase):
    g, t, v = _holdout_points(grid, n, seed)
    ref = phase("holdout_coalescence_volumes", reference_chunk,
                {"d12": g[:, 0], "d13": g[:, 1], "d23": g[:, 2], "theta": t}, 8, {})
    vol = ref["volume_coalescence"] * v
    res = phase(f"holdout_bodies_level{plan.max_refine}",
                functools.partial(coalesced_chunk, plan=plan),
                {"d12": g[:, 0], "d13": g[:, 1], "d23": g[:, 2], "theta": t,
                 "volume": vol}, 1, plan.settings())
    dim = ("holdout",)
    hv = {"holdout_d12": (dim, g[:, 0], ATTRS["d12"]),
          "holdout_d13": (dim, g[:, 1], ATTRS["d13"]),
          "holdout_d23": (dim, g[:, 2], ATTRS["d23"]),
          "holdout_theta": (dim, t, ATTRS["theta"]),
          "holdout_v": (dim, v, ATTRS["v"]),
          "holdout_volume": (dim, vol, ATTRS["volume"]),
          "holdout_status": (dim, res["status"].astype(np.int8), cf_flag_attributes()),
          "holdout_refinement": (dim, res["refinement"], ATTRS["refinement"]),
          "holdout_force_error": (dim, res["force_error"], ATTRS["force_error"]),
          "holdout_pressure": (dim, res["pressure"], ATTRS["pressure"]),
          "holdout_energy": (dim, res["energy_extrapolated"], ATTRS["energy_extrapolated"])}
    for name in PAIR_NAMES:
        hv[f"holdout_{name}"] = (dim, res[name], ATTRS[name])
    ds = xr.Dataset(hv, coords={"holdout": ("holdout", np.arange(n), dict(
        units="1", long_name="held-out point (random canonical geometry, theta, v; "
                             f"Evolver level {plan.max_refine})"))})
    ds.attrs["holdout_evolver_settings"] = json.dumps(plan.settings())
    return ds


def _gravity_dataset(grid, gplan, canon, vref, status, phase):
    """The gravity response on the sub-grid ``gplan.v`` (nodes of the table's v axis;
    nodes where the table has no result are skipped) and its held-out checks."""
    v_all = np.asarray(grid.v, float)
    gv = np.asarray(gplan.v, float)
    iv = [int(np.argmin(np.abs(v_all - x))) for x in gv]
    if not np.allclose(v_all[iv], gv):
        raise ValueError(f"gravity volume ratios {list(gv)} must be nodes of v {list(v_all)}")
    theta = np.asarray(grid.theta, float)
    nc, nt, nv = len(canon), theta.size, gv.size
    ok = status_in(status[:, :, iv], HAS_RESULT)
    vol = np.where(ok, vref[..., None] * gv, np.nan)
    Gp = np.repeat(canon, nt * nv, axis=0)
    res = phase("gravity_response", functools.partial(gravity_chunk, plan=gplan),
                {"d12": Gp[:, 0], "d13": Gp[:, 1], "d23": Gp[:, 2],
                 "theta": np.tile(np.repeat(theta, nv), nc), "volume": vol.ravel()},
                1, gplan.settings())
    shape = (nc, nt, nv)
    per = {"force_gravity_gradient": stack_tensors(res, "G", shape),
           "force_gravity_curvature": stack_tensors(res, "C", shape),
           "gravity_status": sum_rule_status(res["status"],
                                             res["gravity_sum_residual"]).reshape(shape),
           "gravity_sum_residual": res["gravity_sum_residual"].reshape(shape),
           "gravity_cpu_time": res["gravity_cpu_time"].reshape(shape)}
    cube = _expand_to_cube(grid, canon, per)
    dims = ("d12", "d13", "d23", "theta", "gravity_v")
    tdims = dims + ("grain", "component", "gravity_component")
    data = {name: (tdims if arr.ndim == 8 else dims, arr, GRAVITY_ATTRS[name])
            for name, arr in cube.items() if name != "gravity_status"}
    data["gravity_status"] = (dims, cube["gravity_status"].astype(np.int8),
                              cf_flag_attributes())
    coords = {"gravity_v": ("gravity_v", gv, ATTRS["v"] | {
                  "long_name": "volume ratio v = V*/V*_coal of the gravity response"}),
              "gravity_component": ("gravity_component", np.arange(3, dtype=np.int8), {
                  "units": "1", "flag_meanings": "x y z",
                  "long_name": "component of the gravity vector b = Bo g_hat in the "
                               "table frame (g_hat: the direction gravity pulls)"})}
    ds = xr.Dataset(data, coords=coords)
    ds.attrs["gravity_settings"] = json.dumps(gplan.settings() | {"v": list(gv)})
    hds = _gravity_holdout_dataset(grid, gplan, phase)
    out = ds.merge(hds)
    out.attrs.update(ds.attrs | hds.attrs)
    return out


def _gravity_holdout_dataset(grid, gplan, phase):
    """Direct minimisations with gravity one level finer than the response, at the
    cases of ``gplan`` (default :data:`HOLDOUT_CASES`) that lie inside ``grid`` and the
    Bond numbers of ``gplan`` (default :data:`HOLDOUT_BONDS`).  Cases outside the grid
    are skipped: their number is the attribute ``gravity_holdout_cases_skipped``."""
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry

    cases, outside = gplan.cases_inside(grid)
    skipped = {"gravity_holdout_cases_skipped": len(outside)}
    if outside:
        log.warning("%d of %d gravity held-out cases lie outside the table's grid (gaps "
                    "%g-%g, theta %g-%g deg, v %g-%g) and are skipped: %s",
                    len(outside), len(gplan.cases), min(grid.gaps), max(grid.gaps),
                    min(grid.theta), max(grid.theta), min(grid.v), max(grid.v),
                    "; ".join(f"gaps {c[0]}, theta {c[1]:g}, v {c[2]:g}" for c in outside))
    if not cases:
        return xr.Dataset(attrs=skipped)
    rows = []
    for gaps, theta, v, _, direction in cases:
        vc = find_coalescence(triplet_geometry(*gaps), theta).V_coal
        rows += [(*gaps, theta, v, v * vc, bo, *direction) for bo in gplan.bonds]
    a = np.array(rows, float)
    fine = gplan.finer()
    res = phase(f"gravity_holdout_level{fine.max_refine}",
                functools.partial(gravity_holdout_chunk, plan=fine),
                {"d12": a[:, 0], "d13": a[:, 1], "d23": a[:, 2], "theta": a[:, 3],
                 "volume": a[:, 5], "bond": a[:, 6], "gx": a[:, 7], "gy": a[:, 8],
                 "gz": a[:, 9]}, 1, fine.settings())
    dim = ("gravity_holdout",)
    F = np.stack([np.stack([res[f"force_{g + 1}{c}"] for c in COMPONENTS], -1)
                  for g in range(3)], -2)
    names = [case[3] for case in cases for _ in gplan.bonds]
    hv = {"gravity_holdout_d12": (dim, a[:, 0], ATTRS["d12"]),
          "gravity_holdout_d13": (dim, a[:, 1], ATTRS["d13"]),
          "gravity_holdout_d23": (dim, a[:, 2], ATTRS["d23"]),
          "gravity_holdout_theta": (dim, a[:, 3], ATTRS["theta"]),
          "gravity_holdout_v": (dim, a[:, 4], ATTRS["v"]),
          "gravity_holdout_volume": (dim, a[:, 5], ATTRS["volume"]),
          "gravity_holdout_bond": (dim, a[:, 6], GRAVITY_ATTRS["bond"]),
          "gravity_holdout_direction": (dim + ("component",), a[:, 7:10],
                                        GRAVITY_ATTRS["direction"]),
          "gravity_holdout_orientation": (dim, np.array(names, dtype=object), {
              "units": "1", "long_name": "orientation of gravity in the held-out check"}),
          "gravity_holdout_force": (dim + ("grain", "component"), F, ATTRS["force"] | {
              "long_name": "force of the liquid on each grain with gravity, F*, direct "
                           f"Evolver minimisation at level {fine.max_refine}"}),
          "gravity_holdout_status": (dim, res["status"].astype(np.int8),
                                     cf_flag_attributes())}
    ds = xr.Dataset(hv, coords={"gravity_holdout": ("gravity_holdout", np.arange(len(a)), {
        "units": "1", "long_name": "held-out check of the gravity response"})})
    ds.attrs["gravity_holdout_settings"] = json.dumps(fine.settings())
    ds.attrs.update(skipped)
    return ds


def _this_command():
    return " ".join(shlex.quote(a) for a in ["capbridge"] + sys.argv[1:])


def save_triplet_table(ds: xr.Dataset, path, command=None, **kw):
    """Write the table with CF attributes and provenance (netcdf_io.write_table)."""
    return write_table(ds, path, command=command or ds.attrs.get("capbridge_command",
                                                                 _this_command()),
                       solver_settings=json.loads(ds.attrs["evolver_settings"]), **kw)
