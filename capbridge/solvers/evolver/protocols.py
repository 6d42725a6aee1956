"""Fixed-schedule protocols on the same driver, for benchmarks and convergence studies.

:func:`minimise` converges by criteria (refinement levels with Newton steps, central
virtual work, Richardson extrapolation).  This module runs the *paper's* protocol
(Miot et al. 2021, section 2 and Appendix A) with the same datafile, runner, parser and
failure checks, so that the two can be compared point for point:

* starting body relaxed by ``ngrad_between`` gradient steps, then ``n_refine`` times:
  refine (``r``), mesh upkeep (``cb_groom``: equiangulation, tiny-edge deletion,
  long-edge division, vertex averaging) and ``ngrad_between`` gradient steps; after the
  last refinement ``ngrad_after`` gradient steps (paper: 6 refinements, 36 steps between,
  ~1400 after);
* force component by a *forward* difference between two independent minimisations
  (paper: delta d* = 0.06): ``F . u = -(E(x + delta u) - E(x)) / delta`` for the grain
  moved along ``u``.

``final="newton"`` replaces the final gradient phase by ``ngrad_between`` gradient steps
and then Newton steps (``hessian_seek``, with one gradient step after any that pushed a
vertex into a grain, to re-impose the one-sided constraints); this is the
iteration study of the Appendix (gradient steps against Hessian steps at the same mesh).

Energies are printed at checkpoints of the final phase (``@K step energy cpu``), so one
run gives the whole energy-against-iterations curve.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from . import checks, forces, parse, runner, script
from .datafile import mesh_problem, write_datafile


@dataclass
class ScheduleResult:
    """Outcome of one fixed-schedule minimisation."""

    ok: bool
    reason: str
    energy: float = np.nan                  # at the end of the schedule
    checkpoints: np.ndarray = None          # (m, 3): iterations of the final phase,
                                            # energy, Evolver CPU clock (s)
    n_facets: int = 0
    cpu_time: float = 0.0                   # Evolver CPU seconds
    wall_time: float = 0.0
    failures: list = field(default_factory=list)
    snapshot: object = None


def default_checkpoints(n, final="gradient"):
    """Iteration counts at which the energy is printed (roughly log-spaced, ends at n)."""
    if n <= 0:
        return []
    if final == "newton":
        return list(range(1, n + 1))
    pts = {1, 2, 5, n}
    k = 10
    while k < n:
        pts.update({k, 2 * k, 5 * k})
        k *= 10
    return sorted(p for p in pts if p <= n)


def schedule_commands(mp, n_refine=6, ngrad_between=36, ngrad_after=1400, final="gradient",
                      n_newton=6, checkpoints=None, etol=1e-11):
    """Evolver command text for the fixed schedule (ends with a report and ``quit``)."""
    contact = list(mp.contact_constraints.values())
    outside = list(mp.outside_constraints.values())
    c = [script.prelude(mp.grain_contacts(), etol=etol)]
    c.append(f"g {ngrad_between};")
    for k in range(1, n_refine + 1):
        c.append("r; cb_groom();")
        if k < n_refine:
            c.append(f"g {ngrad_between};")
    if final != "gradient":
        c.append(f"g {ngrad_between};")     # no Newton step straight after a refinement
    n_final = ngrad_after if final == "gradient" else n_newton
    cps = default_checkpoints(n_final, final) if checkpoints is None else sorted(checkpoints)
    c.append('printf "@K 0 %.17g %.6f\\n", total_energy, clock;')
    done = 0
    for cp in cps:
        steps = cp - done
        if steps <= 0:
            continue
        if final == "gradient":
            c.append(f"g {steps};")
        else:
            c.append(f"for (cb_k := 1; cb_k <= {steps}; cb_k += 1) {{ hessian_seek; "
                     "if cb_viol() > 0 then g 1; };")
        done = cp
        c.append(f'printf "@K {cp} %.17g %.6f\\n", total_energy, clock;')
    c.append(script.report("final", contact, outside))
    c.append("quit")
    return "\n".join(c) + "\n"


def run_schedule(problem, n_refine=6, ngrad_between=36, ngrad_after=1400, final="gradient",
                 n_newton=6, checkpoints=None, n_ring=8, timeout=7200.0, check=True):
    """Minimise ``problem`` with the fixed schedule; returns a :class:`ScheduleResult`.

    The final shape is checked as in :func:`.minimise.minimise` (volume, penetration,
    folds, pinch, ...); a failed shape gives ``ok=False`` with the reasons.
    """
    t0 = time.monotonic()
    try:
        mp = mesh_problem(problem, n_ring=n_ring)
    except ValueError as exc:
        return ScheduleResult(False, f"no valid starting body: {exc}")
    with runner.Workdir() as wd:
        write_datafile(mp, os.path.join(wd, "start.fe"))
        cmd = schedule_commands(mp, n_refine, ngrad_between, ngrad_after, final, n_newton,
                                checkpoints)
        out = runner.run_evolver("start.fe", cmd, wd, timeout=timeout, name="schedule")
    res = ScheduleResult(False, "", cpu_time=out.cpu if np.isfinite(out.cpu) else 0.0,
                         wall_time=time.monotonic() - t0)
    if out.timed_out:
        res.reason = f"timed out after {timeout:.0f} s"
        return res
    cps = []
    for line in out.stdout.splitlines():
        if line.startswith("@K "):
            p = line.split()
            cps.append((int(p[1]), float(p[2]), float(p[3])))
    res.checkpoints = np.array(cps, float).reshape(-1, 3)
    snap = parse.parse_reports(out.stdout).get("final")
    if snap is None:
        res.reason = "no report (" + "; ".join(out.error_lines[:3]) + ")"
        return res
    res.snapshot = snap
    res.energy = snap.energy
    res.n_facets = snap.n_facets
    if check:
        direct = forces.direct_forces(snap, mp)
        fails, _ = checks.analyse(snap, mp, None, direct)
        res.failures = [str(f) for f in fails]
        if fails:
            res.reason = "; ".join(res.failures[:3])
            return res
    res.ok = True
    res.reason = "completed"
    return res


@dataclass
class FDForce:
    """Force component by a forward difference of two fixed-schedule minimisations."""

    ok: bool
    reason: str
    force: float                     # F* . u on the moved grain (F = -dE/dx / 2 pi)
    base: ScheduleResult
    moved: ScheduleResult
    delta: float
    cpu_time: float
    wall_time: float

    def force_at(self):
        """(iterations, F* . u) along the final phase (common checkpoints)."""
        a, b = self.base.checkpoints, self.moved.checkpoints
        if a is None or b is None or not len(a) or not len(b):
            return np.zeros(0), np.zeros(0)
        n = min(len(a), len(b))
        k = a[:n, 0]
        return k, -(b[:n, 1] - a[:n, 1]) / self.delta / (2 * np.pi)


def forward_difference_force(problem, grain, direction, delta=0.06, **kw):
    """Paper's virtual work: F* . u on ``grain`` from two independent runs (x, x + delta u).

    ``kw`` go to :func:`run_schedule` (defaults: the paper's schedule).  Runs the two
    minimisations one after the other.
    """
    u = np.asarray(direction, float)
    u = u / np.linalg.norm(u)
    t0 = time.monotonic()
    base = run_schedule(problem, **kw)
    moved = run_schedule(problem.moved(grain, delta * u), **kw)
    ok = base.ok and moved.ok
    reason = "ok" if ok else "; ".join(f"{n}: {r.reason}" for n, r in
                                       (("base", base), ("moved", moved)) if not r.ok)
    F = -(moved.energy - base.energy) / delta / (2 * np.pi) if ok else np.nan
    return FDForce(ok, reason, F, base, moved, delta, base.cpu_time + moved.cpu_time,
                   time.monotonic() - t0)


def reported_component(problem):
    """(grain, unit vector u) of the force component the paper reports: F[grain] . u.

    Two grains: the attraction of grain 0 towards grain 1 (along the centre line).
    Three grains: the pull on grain 0 (the top grain of the paper's triplet) towards the
    midpoint of grains 1 and 2.
    """
    c = np.asarray(problem.centres, float)
    u = (c[1] if len(c) == 2 else 0.5 * (c[1] + c[2])) - c[0]
    return 0, u / np.linalg.norm(u)


def paper_stretch(problem):
    """(grain, direction, sign) of the paper's stretching displacement: a doublet is pulled
    apart by moving grain 1 away from grain 0, a triplet by moving the top grain 0 away
    from the others.  The reported component is ``sign * F[grain] . direction``."""
    _, u = reported_component(problem)
    if len(problem.centres) == 2:
        return 1, u, -1.0          # F_0 . u = -F_1 . u
    return 0, -u, -1.0
