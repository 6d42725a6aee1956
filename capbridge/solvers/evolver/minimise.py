"""Energy minimisation of liquid bodies on spheres with Surface Evolver, by criteria.

Procedure (:func:`minimise`):

1. Starting body (convex hull of circular contact rings, volume close to the target),
   relaxed at level 0.
2. Level by level: uniform refinement, mesh upkeep (equiangulation, tiny-edge deletion,
   long-edge division, vertex averaging), a few gradient steps, then Newton steps
   (``hessian_seek``; rejected and replaced by gradient steps if the energy rises while
   the volume is already on target) until a Newton step changes the energy by less than
   ``etol_newton``.  Each level runs in its own Evolver process from the previous
   level's dump, so a failed or timed-out level can be retried or dropped.
3. After every level the shape is checked (:mod:`.checks`).  A failed level is retried
   with safer settings (gradient descent only, then also without grooming); if it still
   fails, the previous level is the final one when it is at least ``min_refine``,
   otherwise the result is ``Status.NOT_CONVERGED`` with the reason.
4. Forces by virtual work at each level from 1 on (central differences, one Evolver run
   per grain, direction and sign, run in parallel) and directly from the shape.
5. Stop when the estimated error of the energy and of the virtual-work forces are below
   ``etol`` and ``ftol`` (relative), or at ``max_refine``.  The error estimate is
   Richardson's, with the convergence order measured from three levels when they show
   a consistent order (clamped to [1, 2]); otherwise the last level-to-level change.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from capbridge.solvers.shapes import LiquidShape
from capbridge.status import HAS_RESULT, Status
from capbridge.validation import CapbridgeInputError

from . import checks, forces, parse, runner, script
from .datafile import mesh_problem, write_datafile
from .problem import make_problem


@dataclass
class Settings:
    """Numerical settings of :func:`minimise` (defaults: small meshes, ~0.5 % forces)."""

    n_ring: int = 8               # vertices per starting contact ring
    min_refine: int = 2           # never stop before this refinement level
    max_refine: int = 4           # never refine beyond this level
    etol: float = 2e-3            # tolerance on the estimated relative energy error
    ftol: float = 3e-3            # tolerance on the estimated relative force error
    etol_newton: float = 1e-11    # absolute energy change ending the Newton loop
    ngrad: int = 20               # gradient steps after each refinement
    ngrad_first: int = 40         # gradient steps on the starting body
    maxhess: int = 20             # Newton steps at most per level
    groom: bool = True
    virtual_work: bool = True
    delta: float = 0.01           # virtual displacement (units of r)
    vw_delta_edges: float = 0.0   # if > 0: delta at most this many mean edge lengths of
                                  # the level (fine theta = 0 meshes: a large displacement
                                  # can push the meniscus out of its basin)
    vw_abort_indefinite: bool = False   # stop a displaced run at its first indefinite
                                  # Hessian and redo it with delta/2 (off: hessian_seek
                                  # copes with indefinite steps on coalesced bodies)
    vw_ngrad: int = 0             # gradient steps before the Newton steps of a displaced
                                  # run; > 0 makes the end state path-dependent (force
                                  # sums off by 1e-2 at level 2), so 0 unless needed
    vw_from_level: int = 1        # first level at which virtual work is computed
    vw_components: tuple | None = None   # ((grain, (ux, uy, uz)), ...): compute only these
                                  # force components by virtual work (e.g. one grain of a
                                  # doublet, the vertical force on one grain); the rows of
                                  # ``forces`` of other grains are then NaN and a listed
                                  # grain's row is its component times u
    level_timeout: float = 300.0  # seconds per Evolver run
    total_timeout: float = 3600.0
    workers: int | None = None    # Evolver processes at once (default min(2, cores))
    keep_files: bool = False      # keep the temporary directory (path in result)
    keep_shape: bool = False      # keep the final surface as ``BridgeResult.shape``
                                  # (a LiquidShape, for capbridge.solvers.shapes.
                                  # write_shape); off by default: sweeps hold many results
    flag_above_tolerance: bool = True    # status ABOVE_TOLERANCE (not CONVERGED) for a
                                  # result whose own error estimate exceeds etol/ftol at
                                  # the last level; off until every caller accepts it
                                  # (they test status == CONVERGED for "has a result")
    one_sided: bool = True        # keep free vertices outside the grains (never switch off
                                  # except to see the failure checks at work)
    tolerances: checks.Tolerances = field(default_factory=checks.Tolerances)


@dataclass
class LevelRecord:
    level: int
    energy: float
    area: float
    pressure: np.ndarray
    volume: np.ndarray
    n_facets: int
    forces_direct: np.ndarray          # best direct estimate (cut if available)
    forces_direct_contact: np.ndarray  # pressure over cap + tension on contact line
    forces_direct_facet: np.ndarray
    forces_vw: np.ndarray | None
    neck_radius: np.ndarray
    measured_contact_angle_deg: dict
    newton_steps: int
    bond: float
    wall_time: float
    cpu_time: float
    attempt: str
    diagnostics: dict


@dataclass
class BridgeResult:
    """Outcome of :func:`minimise`.  Forces are F* = F / (2 pi gamma r) on each grain
    (the force the liquid exerts; shape (N, 3)); energies E* = E / (gamma r^2) including
    gravitational potential energy Bo \\int h dV (h = up . x, from the input origin);
    pressures P* per body (with gravity: at height h = 0)."""

    status: Status
    reason: str
    energy: float = np.nan
    energy_extrapolated: float = np.nan
    pressure: np.ndarray = None
    volume: np.ndarray = None
    forces: np.ndarray = None               # best estimate (see force_method)
    force_method: str = ""
    forces_vw: np.ndarray = None            # virtual work, finest level
    forces_vw_extrapolated: np.ndarray = None
    forces_direct: np.ndarray = None        # direct, finest level: shell-averaged cut when
                                            # available (Bo = 0), else contact-line formula
    direct_method: str = ""
    forces_direct_contact: np.ndarray = None  # pressure over cap + tension on the contact
                                              # line (Young conormal), finest level
    forces_direct_facet: np.ndarray = None  # same with the facet conormal (diagnostic)
    force_error: np.ndarray = None          # estimated error of ``forces`` (N, 3)
    disagreement: np.ndarray = None         # forces_vw - forces_direct (N, 3)
    refinement: int = -1
    n_facets: int = 0
    cpu_time: float = 0.0                   # Evolver CPU seconds (all runs)
    wall_time: float = 0.0
    error_estimate: dict = field(default_factory=dict)
    neck_radius: np.ndarray = None          # per body (two-grain bodies), else nan
    neck_force: np.ndarray = None           # y0 - P y0^2/2 per two-grain body (no gravity)
    measured_contact_angle_deg: dict = field(default_factory=dict)
    levels: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    workdir: str = ""
    problem: object = None
    shape: object = None                    # LiquidShape of the finest level, with
                                            # Settings.keep_shape and a result (else None)

    @property
    def converged(self):
        """A result is there: CONVERGED, or ABOVE_TOLERANCE (its estimated error is
        above ``etol``/``ftol``; see ``status`` and ``error_estimate``)."""
        return self.status in HAS_RESULT

    @property
    def within_tolerance(self):
        """The result's own error estimates are within ``etol`` and ``ftol``."""
        return self.status == Status.CONVERGED

    def axial_force(self, i=0, j=1, which="forces"):
        """Attraction F* between grains i and j along their centre line (doublets)."""
        F = getattr(self, which)
        if F is None or self.problem is None:
            return np.nan
        u = forces.doublet_axis(self.problem, i, j)
        if np.all(np.isnan(F[i])):          # only grain j computed (vw_components)
            return float(-F[j] @ u)
        return float(F[i] @ u)

    def summary(self):
        out = {"status": self.status.name.lower(), "reason": self.reason,
               "energy": self.energy, "refinement": self.refinement,
               "n_facets": self.n_facets, "cpu_time": round(self.cpu_time, 3),
               "wall_time": round(self.wall_time, 3)}
        if self.forces is not None:
            out["forces"] = np.round(self.forces, 6).tolist()
        return out


# --------------------------------------------------------------------------------------


def vw_directions(pb):
    """Directions along which forces are non-zero by symmetry (orthonormal rows).

    All wetted grain centres (and gravity, if Bo > 0) on a line: that line only
    (axisymmetry).  In a plane: the two in-plane directions (mirror symmetry).
    Otherwise x, y, z.
    """
    g = pb.wetted_grains()
    vecs = [pb.centres[k] - pb.centres[g[0]] for k in g[1:]]
    if pb.bond > 0:
        vecs.append(pb.gravity_dir)
    A = np.array(vecs, float).reshape(-1, 3)
    if len(A) == 0:
        return np.eye(3)
    _, s, vt = np.linalg.svd(A)
    rank = int(np.sum(s > 1e-9 * max(s.max(), 1.0)))
    if rank >= 3:
        return np.eye(3)
    return vt[:rank]


def vw_component_list(pb, components):
    """``Settings.vw_components`` checked: list of (grain, unit vector), or None (all).

    A grain may appear once (one direction per grain: its row of ``forces`` is then the
    component times the unit vector)."""
    if components is None:
        return None
    out = []
    seen = set()
    wet = set(pb.wetted_grains())
    for g, u in components:
        g = int(g)
        u = np.asarray(u, float)
        if g not in wet:
            raise ValueError(f"vw_components: grain {g} is not wetted (wetted grains, "
                             f"0-based: {sorted(wet)})")
        if g in seen:
            raise ValueError(f"vw_components: grain {g} listed twice (one direction per "
                             "grain)")
        if u.shape != (3,) or not np.linalg.norm(u) > 0:
            raise ValueError(f"vw_components: direction {u.tolist()} of grain {g} must be a "
                             "non-zero 3-vector")
        seen.add(g)
        out.append((g, u / np.linalg.norm(u)))
    if not out:
        raise ValueError("vw_components is empty")
    return out


def vw_delta(pb, delta):
    """Virtual displacement: ``delta``, but at most 1/20 of the smallest gap between
    grains wetted by a common body (and at least 2e-4)."""
    gaps = []
    for b in pb.bodies:
        for m, i in enumerate(b.grains):
            for j in b.grains[m + 1:]:
                gaps.append(np.linalg.norm(pb.centres[i] - pb.centres[j])
                            - pb.radii[i] - pb.radii[j])
    if gaps:
        delta = min(delta, max(min(gaps) / 20.0, 2e-4))
    return delta


def _order_estimate(values):
    """Richardson order from the last three values of a sequence, or None.

    r = (F_{L-1} - F_{L-2}) / (F_L - F_{L-1}).  r >= 1.5: p = log2 r clamped to [1, 2];
    0.6 <= r < 1.5 (no acceleration yet, typical of theta = 0 where the contact-line
    singularity makes the force converge like h): p = 1; otherwise (sign change, growing
    differences) no extrapolation.
    """
    if len(values) < 3:
        return None
    d1 = values[-2] - values[-3]
    d2 = values[-1] - values[-2]
    if d2 == 0 or d1 == 0 or np.sign(d1) != np.sign(d2):
        return None
    r = d1 / d2
    if r >= 1.5:
        return float(np.clip(np.log2(r), 1.0, 2.0))
    if r >= 0.6:
        return 1.0
    return None


def _richardson(seq, scale):
    """(extrapolated, error estimate, order) for a list of scalars at levels 0..L."""
    seq = [v for v in seq if v is not None and np.isfinite(v)]
    if len(seq) < 2:
        return (seq[-1] if seq else np.nan), np.inf, None
    p = _order_estimate(seq)
    d = seq[-1] - seq[-2]
    if p is None:
        return seq[-1], abs(d), None
    corr = d / (2.0 ** p - 1.0)
    return seq[-1] + corr, abs(corr), p


def _richardson_array(arrays):
    """Richardson extrapolation of a sequence of arrays with one common order (so that
    linear relations such as the balance of forces are kept).

    The order comes from the ratio of the norms of the last two differences (as in
    :func:`_order_estimate`, and only if those differences point the same way).
    Returns (extrapolated, error estimate (same shape), order or None).
    """
    A = [np.asarray(a, float) for a in arrays]
    if len(A) < 2:
        return A[-1], np.full(A[-1].shape, np.inf), None
    d2 = A[-1] - A[-2]
    p = None
    if len(A) >= 3:
        d1 = A[-2] - A[-3]
        n1, n2 = np.linalg.norm(d1), np.linalg.norm(d2)
        if n1 > 0 and n2 > 0 and float(np.sum(d1 * d2)) > 0.5 * n1 * n2:
            p = _order_estimate([0.0, n1, n1 + n2])
    if p is None:
        return A[-1], np.abs(d2), None
    corr = d2 / (2.0 ** p - 1.0)
    return A[-1] + corr, np.abs(corr), p


class _Runner:
    """State of one minimisation: work directory, settings, timing."""

    def __init__(self, mp, settings, workdir):
        self.mp = mp
        self.s = settings
        self.wd = workdir
        self.contact = list(mp.contact_constraints.values())
        self.outside = list(mp.outside_constraints.values())
        self.pre = script.prelude(mp.grain_contacts(), etol=settings.etol_newton)
        self.cpu = 0.0
        self.t0 = time.monotonic()
        self.final_snap = None        # report of the finest level that passed its checks

    def remaining(self):
        return self.s.total_timeout - (time.monotonic() - self.t0)

    def run(self, src, commands, name):
        timeout = max(0.05, min(self.s.level_timeout, self.remaining()))
        out = runner.run_evolver(src, self.pre + commands, self.wd, timeout=timeout, name=name)
        if np.isfinite(out.cpu):
            self.cpu += out.cpu
        return out

    # ---- one level -------------------------------------------------------------------
    def level(self, L, src, bond=None):
        """Run level L from ``src``; returns (snapshot, direct, failures, diag, attempt)."""
        attempts = [("newton", dict()),
                    ("gradient", dict(newton=False)),
                    ("gradient-nogroom", dict(newton=False, groom=False))]
        last = None
        for name, kw in attempts:
            kw = dict(dict(ngrad=self.s.ngrad, maxhess=self.s.maxhess, groom=self.s.groom,
                           ngrad_first=self.s.ngrad_first), **kw)
            cmd = script.converge_level(L, self.contact, self.outside,
                                        dumpfile=f"L{L}.dmp", bond=bond, **kw)
            out = self.run(src, cmd, f"level{L}-{name}")
            if out.timed_out:
                last = (None, None, [checks.Failure("timeout", f"level {L} ({name}) timed out")],
                        {}, name)
                continue
            if out.error_lines and not out.ok:
                last = (None, None, [checks.Failure("evolver", "; ".join(out.error_lines[:3]))],
                        {}, name)
                continue
            snaps = parse.parse_reports(out.stdout)
            snap = snaps.get(f"level{L}")
            if snap is None:
                last = (None, None, [checks.Failure("evolver", f"no report from level {L} "
                                                               f"(exit {out.returncode})")],
                        {}, name)
                continue
            mp = self.mp
            if bond is not None and bond != mp.problem.bond:
                pb2 = mp.problem.copy()
                pb2.bond = bond
                mp = _with_problem(mp, pb2)
            direct = forces.direct_forces(snap, mp)
            fails, diag = checks.analyse(snap, mp, self.s.tolerances, direct)
            diag["wall"] = out.elapsed
            diag["cpu"] = out.cpu
            if not fails:
                return snap, direct, [], diag, name
            last = (snap, direct, fails, diag, name)
            if any(f.kind in ("coalesced", "contact") for f in fails):
                break          # physical outcome: safer settings will not change it
        return last

    # ---- virtual work ----------------------------------------------------------------
    def virtual_work(self, L, delta, halvings=2):
        """Forces (N, 3) by central differences from the dump of level L, and failures.

        A (grain, direction) pair whose displaced runs fail is redone with half the
        displacement, up to ``halvings`` times; the failures returned are those left.
        """
        pb = self.mp.problem
        comps = vw_component_list(pb, self.s.vw_components)
        if comps is None:
            dirs = vw_directions(pb)
            pairs = [(g, d) for g in pb.wetted_grains() for d in range(len(dirs))]
            dvec = {(g, d): dirs[d] for g, d in pairs}
        else:
            pairs = [(g, m) for m, (g, _) in enumerate(comps)]
            dvec = {(g, m): u for m, (g, u) in enumerate(comps)}

        def job(item):
            g, d, sgn, dl = item
            shift = sgn * dl * dvec[(g, d)]
            cmd = script.displaced(g, shift, pb.n_grains, self.contact, self.outside,
                                   ngrad=self.s.vw_ngrad, maxhess=self.s.maxhess,
                                   abort_indefinite=self.s.vw_abort_indefinite)
            out = self.run(f"L{L}.dmp", cmd, f"vw{L}-{g}-{d}-{sgn}")
            snap = None if out.timed_out else parse.parse_reports(out.stdout).get("moved")
            if snap is None:
                kind = "timeout" if out.timed_out else "evolver"
                return np.nan, [checks.Failure(kind, f"virtual-work run (grain {g + 1}) failed")]
            mp2 = _with_problem(self.mp, pb.moved(g, shift))
            direct = forces.direct_forces(snap, mp2)
            fails, _ = checks.analyse(snap, mp2, self.s.tolerances, direct)
            if snap.indefinite and self.s.vw_abort_indefinite:
                fails.append(checks.Failure("newton", f"virtual-work run (grain {g + 1}): "
                                                      "indefinite Hessian (displacement too "
                                                      "large for this mesh)"))
            if (snap.newton_steps >= self.s.maxhess
                    and abs(snap.last_newton_de) > 1e3 * self.s.etol_newton):
                fails.append(checks.Failure("newton", f"virtual-work run (grain {g + 1}) did "
                                                      "not converge"))
            return (snap.energy if not fails else np.nan), fails

        F = np.zeros((pb.n_grains, 3))
        todo = {pr: delta for pr in pairs}
        left = []
        self.vw_halved = 0
        for attempt in range(halvings + 1):
            jobs = [(g, d, sgn, dl) for (g, d), dl in todo.items() for sgn in (1, -1)]
            results = runner.parallel_map(job, jobs, self.s.workers)
            E = {}
            fails = {}
            for (g, d, sgn, dl), (e, f) in zip(jobs, results):
                E[(g, d, sgn)] = e
                fails.setdefault((g, d), []).extend(f)
            retry = {}
            for (g, d), dl in todo.items():
                if fails[(g, d)]:
                    retry[(g, d)] = dl / 2
                    continue
                comp = -(E[(g, d, 1)] - E[(g, d, -1)]) / (2 * dl)
                F[g] += comp * dvec[(g, d)] / (2 * np.pi)
            if not retry:
                return F, []
            left = [f for pr in retry for f in fails[pr]]
            if attempt < halvings:
                self.vw_halved += len(retry)
            todo = retry
        return F, left


def _with_problem(mp, problem):
    from .datafile import MeshedProblem
    return MeshedProblem(problem, mp.meshes, mp.contact_constraints, mp.outside_constraints,
                         mp.body_near_grains)


def minimise(problem, settings=None):
    """Minimise the surface energy of ``problem`` (a :class:`.problem.Problem`).

    Returns a :class:`BridgeResult`; its ``status`` is ``Status.CONVERGED`` only when every
    check passed at the final level and the estimated errors are within tolerance;
    ``Status.ABOVE_TOLERANCE`` (with ``Settings.flag_above_tolerance``; otherwise still
    CONVERGED) when the maximum refinement (or the last level passing the checks) was
    reached with an estimate above ``etol``/``ftol``; a warning and ``reason`` say so.
    """
    s = settings or Settings()
    t_start = time.monotonic()
    try:
        vw_component_list(problem, s.vw_components)
    except ValueError as exc:
        raise CapbridgeInputError(str(exc)) from None
    res = BridgeResult(status=Status.NOT_CONVERGED, reason="", problem=problem)
    if not runner.available():
        res.reason = "Surface Evolver ('evolver') is not installed"
        return res
    try:
        mp = mesh_problem(problem, n_ring=s.n_ring, one_sided=s.one_sided)
    except ValueError as exc:
        res.reason = f"no valid starting body: {exc}"
        return res
    wd_ctx = runner.Workdir(keep=s.keep_files or None)
    with wd_ctx as wd:
        res.workdir = wd if wd_ctx.keep else ""
        write_datafile(mp, os.path.join(wd, "L0.fe"))
        R = _Runner(mp, s, wd)
        try:
            _levels(R, res)
        except Exception as exc:     # never let one problem crash a sweep: flag it
            res.status = Status.NOT_CONVERGED
            res.reason = f"driver error: {type(exc).__name__}: {exc}"
            res.forces = None
        finally:
            res.cpu_time = R.cpu
            res.wall_time = time.monotonic() - t_start
        if s.keep_shape and res.converged and R.final_snap is not None:
            res.shape = _final_shape(R.final_snap, mp, res)
    return res


def _final_shape(snap, mp, res):
    """The surface of the finest level (the one the result's numbers come from) with its
    grains and case, in the problem's frame and units."""
    triangles, body, contact = snap.triangle_mesh(mp.contact_constraints)
    pb = res.problem
    return LiquidShape(points=snap.vertices.copy(), triangles=triangles, body=body,
                       contact_grain=contact, centres=pb.centres.copy(),
                       radii=pb.radii.copy(), contact_angles=pb.contact_angles_deg.copy(),
                       volumes=tuple(float(b.volume) for b in pb.bodies),
                       status=res.status.name.lower(),
                       method=f"Surface Evolver, refinement level {res.refinement}",
                       bond=float(pb.bond),
                       gravity_dir=tuple(map(float, pb.gravity_dir)) if pb.bond else None,
                       wetted=tuple(pb.wetted_grains()))


def _levels(R, res):
    s = R.s
    mp = R.mp
    pb = mp.problem
    src = "L0.fe"
    records = []
    final_fail = None
    fatal = False          # failure that invalidates the whole result (not just a level)
    for L in range(0, s.max_refine + 1):
        if R.remaining() <= 0:
            final_fail = f"total time-out ({s.total_timeout:.0f} s) before level {L}"
            break
        # gravity from level 1 on (the coarse starting mesh folds under strong gravity)
        bond = pb.bond if (L > 0 or pb.bond == 0) else 0.0
        snap, direct, fails, diag, attempt = R.level(L, src, bond=bond)
        if L < s.min_refine and fails and all(f.kind == "coalesced" for f in fails):
            # a coarse ring polygon misplaces the contact lines by a sizeable fraction
            # of an edge: caps met at level 0 for separate bridges at 0.55 V_coal (stress
            # run).  Refine and decide at min_refine, where a meeting is final.
            res.warnings.append(f"level {L}: {fails[0]} on the coarse mesh; refined to check")
            fails = []
        if fails:
            final_fail = f"level {L}: " + "; ".join(str(f) for f in fails)
            fatal = any(f.kind in _FATAL for f in fails)
            if any(f.kind == "coalesced" for f in fails):
                res.status = Status.COALESCED
                res.reason = final_fail
                res.levels = records
                return
            break
        if attempt != "newton":
            res.warnings.append(f"level {L} needed safer settings ({attempt})")
        cut = forces.cut_forces(snap, mp) if bond == pb.bond else None
        necks = np.full(len(pb.bodies), np.nan)
        for bi in range(len(pb.bodies)):
            necks[bi] = forces.neck(snap, mp, bi)[0]
        rec = LevelRecord(
            level=L, energy=snap.energy, area=snap.area,
            pressure=np.array([snap.body_pressure[b + 1] for b in range(len(pb.bodies))]),
            volume=np.array([snap.body_volume[b + 1] for b in range(len(pb.bodies))]),
            n_facets=snap.n_facets,
            forces_direct=direct.young if cut is None else cut,
            forces_direct_contact=direct.young,
            forces_direct_facet=direct.facet, forces_vw=None, neck_radius=necks,
            measured_contact_angle_deg=direct.measured_angle_deg,
            newton_steps=snap.newton_steps, bond=bond, wall_time=diag.get("wall", np.nan),
            cpu_time=diag.get("cpu", np.nan), attempt=attempt, diagnostics=diag)
        # pinch across levels: the neck of a converging shape changes little
        prev = records[-1].neck_radius if records else necks
        ok = np.isfinite(necks) & np.isfinite(prev)
        if np.any(ok):
            shrink = (prev[ok] - necks[ok]) / prev[ok]
            if np.max(shrink) > 0.3:
                fatal = True
                final_fail = (f"level {L}: neck radius fell from {np.nanmin(prev):.3g} to "
                              f"{np.nanmin(necks):.3g}: bridge pinching off")
                break
        # energy running away across levels
        full = [r for r in records if r.bond == pb.bond]
        if len(full) >= 2 and bond == pb.bond:
            d1 = abs(full[-1].energy - full[-2].energy)
            d2 = abs(snap.energy - full[-1].energy)
            if d2 > 2.0 * d1 + 1e-3 * max(abs(snap.energy), snap.area):
                fatal = True
                final_fail = (f"level {L}: energy change grew from {d1:.3g} to {d2:.3g} "
                              "between levels (energy falling without bound?)")
                break
        if s.virtual_work and L >= s.vw_from_level:
            cpu0 = R.cpu
            delta = vw_delta(pb, s.delta)
            h = rec.diagnostics.get("mean_edge", np.nan)
            if s.vw_delta_edges and np.isfinite(h):
                delta = min(delta, max(s.vw_delta_edges * h, 1e-5))
            rec.diagnostics["vw_delta"] = delta
            F, vfails = R.virtual_work(L, delta)
            rec.diagnostics["vw_cpu"] = R.cpu - cpu0
            if vfails and all(f.kind == "coalesced" for f in vfails):
                if L >= s.min_refine:       # a displaced grain made the caps meet
                    res.status = Status.COALESCED
                    res.reason = f"level {L} virtual work: {vfails[0]}"
                    res.levels = records
                    return
                res.warnings.append(f"level {L} virtual work: {vfails[0]} on the coarse "
                                    "mesh; no forces from this level")
                F, vfails = None, []
            if vfails:
                final_fail = f"level {L} virtual work: " + "; ".join(str(f) for f in vfails[:3])
                break
            if R.vw_halved:
                res.warnings.append(f"level {L}: virtual work needed smaller displacements "
                                    f"for {R.vw_halved} grain-direction pair(s)")
            rec.forces_vw = F
        rec.diagnostics["cpu_cumulative"] = R.cpu   # Evolver CPU of all runs so far
        records.append(rec)
        R.final_snap = snap
        src = f"L{L}.dmp"
        if L >= s.min_refine and _converged(records, s, res):
            break
    res.levels = records
    with_gravity = [r for r in records if r.bond == pb.bond]   # level 0 runs without it
    if not with_gravity or records[-1].level < s.min_refine:
        res.status = Status.NOT_CONVERGED
        res.reason = final_fail or "no level reached the minimum refinement"
        _fill(res, records, s)
        return
    _fill(res, records, s)
    if fatal:
        res.status = Status.NOT_CONVERGED
        res.reason = final_fail
        return
    if final_fail:
        res.warnings.append(f"stopped at level {records[-1].level}: {final_fail}")
    _set_final_status(res, s, final_fail)


def _set_final_status(res, s, final_fail=None):
    """CONVERGED when the result's own error estimates are within ``etol``/``ftol``;
    otherwise (finest level allowed, or the last level that passed the checks)
    ABOVE_TOLERANCE with ``s.flag_above_tolerance`` (else CONVERGED, as before), with the
    estimates in ``reason`` and ``warnings`` either way.  A single level
    (``max_refine=0``) has no estimate (infinite): never within tolerance."""
    ok_e = res.error_estimate.get("energy_rel", np.inf) <= s.etol
    ok_f = res.error_estimate.get("force_rel", np.inf) <= s.ftol
    if ok_e and ok_f:
        res.status = Status.CONVERGED
        res.reason = "converged"
    else:
        res.status = Status.ABOVE_TOLERANCE if s.flag_above_tolerance else Status.CONVERGED
        res.reason = ("maximum refinement reached, error estimate above tolerance"
                      if final_fail is None else
                      "finest level that passed all checks, error estimate above tolerance")
        res.warnings.append(
            f"error estimates (energy {res.error_estimate.get('energy_rel', np.nan):.2g}, "
            f"force {res.error_estimate.get('force_rel', np.nan):.2g}) above tolerance "
            f"(etol {s.etol:g}, ftol {s.ftol:g})")


#: failures that make the whole computation invalid (physical breakdown of the shape)
_FATAL = ("pinch", "energy", "penetration", "contact")


def _force_scale(F):
    return max(float(np.max(np.linalg.norm(F, axis=1))), 1e-3)


def _converged(records, s, res):
    """Stopping test after a level (estimated errors within tolerances)."""
    records = [r for r in records if r.bond == res.problem.bond]
    if not records:
        return False
    E = [r.energy for r in records]
    escale = max(abs(E[-1]), records[-1].area)
    _, eerr, _ = _richardson(E, escale)
    if eerr / escale > s.etol:
        return False
    if s.virtual_work:
        Fs = [r.forces_vw for r in records if r.forces_vw is not None]
    else:
        Fs = [r.forces_direct for r in records]
    if len(Fs) < 2:
        return False
    scale = _force_scale(Fs[-1])
    _, Fe, _ = _richardson_array(Fs)
    return float(Fe.max()) / scale <= s.ftol


def _fill(res, records, s):
    if not records:
        return
    last = records[-1]
    res.refinement = last.level
    res.n_facets = last.n_facets
    res.energy = last.energy
    res.pressure = last.pressure
    res.volume = last.volume
    res.forces_direct = last.forces_direct
    res.forces_direct_contact = last.forces_direct_contact
    res.direct_method = ("pressure and tension through spheres around each grain, "
                         "shell-averaged" if last.forces_direct is not last.forces_direct_contact
                         else "pressure over the wetted cap and tension along the contact "
                              "line (Young conormal)" + (", hydrostatic term" if
                                                         res.problem.bond > 0 else ""))
    res.forces_direct_facet = last.forces_direct_facet
    res.measured_contact_angle_deg = last.measured_contact_angle_deg
    res.neck_radius = last.neck_radius
    pb = res.problem
    records = [r for r in records if r.bond == pb.bond]
    if not records:
        # only the gravity-free level 0 of a problem with gravity passed: nothing to
        # extrapolate (the result is NOT_CONVERGED; its caller sets the reason)
        res.error_estimate = {"energy": np.inf, "energy_rel": np.inf, "force": np.inf,
                              "force_rel": np.inf}
        return
    if pb.bond == 0:
        res.neck_force = np.array([forces.neck_force(r, p) if np.isfinite(r) else np.nan
                                   for r, p in zip(last.neck_radius, last.pressure)])
    E = [r.energy for r in records]
    escale = max(abs(E[-1]), last.area)
    ex, eerr, ep = _richardson(E, escale)
    res.energy_extrapolated = ex
    res.error_estimate = {"energy": eerr, "energy_rel": eerr / escale, "energy_order": ep}
    Fs = [r.forces_vw for r in records if r.forces_vw is not None]
    if Fs:
        res.forces_vw = Fs[-1]
        Fx, Fe, p = _richardson_array(Fs)
        comps = vw_component_list(pb, s.vw_components)
        if comps is not None:
            # grains whose force was not computed: NaN, never a silent zero
            skip = np.array([g not in {c[0] for c in comps} for g in range(pb.n_grains)])
            res.forces_vw, Fx, Fe = Fs[-1].copy(), Fx.copy(), Fe.copy()
            for A in (res.forces_vw, Fx, Fe):
                A[skip] = np.nan
        res.forces_vw_extrapolated = Fx
        res.forces = Fx
        res.force_method = ("virtual work, Richardson-extrapolated over levels" if p else
                            "virtual work, finest level")
        res.force_error = Fe
        res.disagreement = res.forces_vw - last.forces_direct
        scale = _force_scale(Fs[-1])
        res.error_estimate.update({
            "force": float(np.nanmax(Fe)), "force_rel": float(np.nanmax(Fe)) / scale,
            "force_order": p,
            "direct_vs_vw": float(np.nanmax(np.abs(res.disagreement))),
            "direct_vs_vw_rel": float(np.nanmax(np.abs(res.disagreement))) / scale})
    else:
        Fd = [r.forces_direct for r in records]
        _, Fe, _ = _richardson_array(Fd)
        res.forces = Fd[-1]
        res.force_method = "direct (pressure + contact-line tension), finest level"
        res.force_error = Fe
        scale = _force_scale(Fd[-1])
        res.error_estimate.update({"force": float(Fe.max()),
                                   "force_rel": float(Fe.max()) / scale})


# --------------------------------------------------------------------------------------
# public convenience API
# --------------------------------------------------------------------------------------


def minimise_bridge(centres, radii, contact_angles_deg, volume, topology="doublet",
                    pairs=None, bond=0.0, gravity_dir=(0.0, 0.0, -1.0), tol=3e-3,
                    max_refine=4, settings=None, **kw):
    """Minimise liquid bodies on N spheres; see :func:`.problem.make_problem` for the
    geometry arguments and :class:`Settings` for ``kw`` (``tol`` sets ``ftol``)."""
    pb = make_problem(centres, radii, contact_angles_deg, volume, topology, pairs, bond,
                      gravity_dir)
    s = settings or Settings(ftol=tol, max_refine=max_refine, **kw)
    return minimise(pb, s)


def minimise_many(problems, settings=None, workers=None):
    """:func:`minimise` for several problems, ``workers`` at once (default min(2, cores));
    each problem's own virtual-work runs are then sequential."""
    import dataclasses
    s = settings or Settings()
    workers = runner.default_workers() if workers is None else max(1, int(workers))
    inner = dataclasses.replace(s, workers=1) if workers > 1 else s
    return runner.parallel_map(lambda pb: minimise(pb, inner), list(problems), workers)


def doublet_problem(gap, volume, theta, ratio=1.0, theta2=None, bond=0.0,
                    gravity_dir=(0.0, 0.0, -1.0)):
    """Two spheres on the x axis: radius 1 at the origin, radius ``ratio`` at x = 1+ratio+gap."""
    t2 = theta if theta2 is None else theta2
    centres = [[0.0, 0.0, 0.0], [1.0 + ratio + gap, 0.0, 0.0]]
    return make_problem(centres, [1.0, ratio], [theta, t2], volume, "doublet", bond=bond,
                        gravity_dir=gravity_dir)


def doublet_force(gap, volume, theta, ratio=1.0, theta2=None, settings=None, **kw):
    """Axial force F* (attraction > 0) of a liquid bridge between two spheres.

    Radius 1 (normalising) and ``ratio``; gap d*, volume V*, contact angles in degrees.
    Returns (F*, BridgeResult); F* is NaN unless the result has one (``res.converged``:
    CONVERGED or ABOVE_TOLERANCE).
    """
    pb = doublet_problem(gap, volume, theta, ratio, theta2)
    s = settings or Settings(**kw)
    res = minimise(pb, s)
    F = res.axial_force() if res.converged else np.nan
    return F, res
