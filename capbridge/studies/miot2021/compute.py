"""Running the solves of the study: the exact triplet (Young-Laplace), and the Evolver
points, stage by stage, through resumable sweeps.

Each stage's points are listed by a ``*_points`` function of the :class:`Plan` (and of
the results the stage depends on: V_coal without and with gravity); :func:`sweep` solves
them with :func:`solve_points`, reusing the points an earlier run has finished.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np

from capbridge.status import Status, status_name
from capbridge.studies.miot2021.experiment import D12, D13, D23, ul, vstar
from capbridge.studies.miot2021.paper import FIG3_VOLUMES
from capbridge.studies.miot2021.points import BRIDGES, COALESCED, DOUBLET, point_key


# --------------------------------------------------------------------------------------
# one Evolver point (module level: run_sweep checkpoints it)
# --------------------------------------------------------------------------------------

_OUT_NAMES = ("F_top", "F1x", "F1z", "F2x", "F2z", "F3x", "F3z", "f12", "f13", "f23",
              "pair_residual", "force_sum", "energy", "energy_ex", "energy_err",
              "force_err_rel", "cap_gap", "z_low", "refinement", "n_facets", "cpu",
              "wall", "F_axial", "F_direct")


def solve_points(kind, theta, volume, bond, gap, level, shapes_dir=None):
    """run_sweep solver: one or more Evolver points (see :data:`_OUT_NAMES`)."""
    from capbridge.solvers.evolver import doublet_force
    from capbridge.solvers.triplet import triplet_geometry
    from capbridge.solvers.triplet_evolver import evolver_triplet

    n = len(kind)
    out = {k: np.full(n, np.nan) for k in _OUT_NAMES}
    status = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    geom = triplet_geometry(D12, D13, D23)
    for m in range(n):
        k, t, v, bo, d, L = (int(kind[m]), float(theta[m]), float(volume[m]), float(bond[m]),
                             float(gap[m]), int(level[m]))
        if k == DOUBLET:
            F, res = doublet_force(d, v, t, max_refine=L)
            status[m] = int(res.status)
            out["F_axial"][m] = F
            if res.converged:
                out["F_direct"][m] = res.axial_force(which="forces_direct")
                out["force_err_rel"][m] = res.error_estimate.get("force_rel", np.nan)
                out["energy"][m] = res.energy
                out["energy_ex"][m] = res.energy_extrapolated
            out["refinement"][m] = res.refinement
            out["n_facets"][m] = res.n_facets
            out["cpu"][m] = res.cpu_time
            out["wall"][m] = res.wall_time
            continue
        topo = "coalesced" if k == COALESCED else "bridges"
        r = evolver_triplet(v, geom, t, topo, bond=bo, max_refine=L)
        status[m] = r["status_code"]
        for key, name in (("energy", "energy"), ("energy_extrapolated", "energy_ex"),
                          ("energy_error", "energy_err"), ("force_error_rel", "force_err_rel"),
                          ("lower_meniscus_z", "z_low"), ("refinement", "refinement"),
                          ("n_facets", "n_facets"), ("cpu_time", "cpu"),
                          ("wall_time", "wall"), ("F_top_vertical", "F_top"),
                          ("pair_residual", "pair_residual"), ("force_sum", "force_sum")):
            out[name][m] = r[key]
        if r["cap_gaps"]:
            out["cap_gap"][m] = r["cap_gaps"].get("grain 1", np.nan)
        if r["forces"] is not None:
            F = np.asarray(r["forces"])
            for g in range(3):
                out[f"F{g + 1}x"][m] = F[g, 0]
                out[f"F{g + 1}z"][m] = F[g, 2]
            for p in ("12", "13", "23"):
                out[f"f{p}"][m] = r["pair_forces"][p]
        if shapes_dir is not None and r["section"] is not None:
            os.makedirs(shapes_dir, exist_ok=True)
            np.savez_compressed(os.path.join(shapes_dir, point_key(k, t, v, bo, d, L) + ".npz"),
                                section=r["section"], status=r["status_code"])
    out["status"] = status
    return out


_IN_NAMES = ("kind", "theta", "volume", "bond", "gap", "level")


def _cache_key(values):
    """Inputs of a point rounded to 12 digits: a V_coal that moved by round-off (another
    order of the same operations) finds its finished point instead of a new Evolver run."""
    return tuple(float(f"{float(x):.12g}") for x in values)


def _cached_points(stage, ckroot):
    """Finished points of earlier sweeps of ``stage`` (any plan): input key -> outputs."""
    out = {}
    if ckroot is None:
        return out
    for d in sorted(Path(ckroot).glob(f"{stage}-*")):
        for f in d.glob("chunk_*.npz"):
            try:
                with np.load(f) as z:
                    for m in range(len(z["in__kind"])):
                        key = _cache_key(z[f"in__{n}"][m] for n in _IN_NAMES)
                        out[key] = {k[5:]: z[k][m] for k in z.files if k.startswith("out__")}
            except (OSError, KeyError, ValueError):
                continue
    return out


def sweep(stage, points, ckroot, shapes_dir, progress):
    """Run ``points`` (list of dicts) through :func:`solve_points`; returns a DataFrame.

    Points already finished by an earlier sweep of the same stage (another plan) are
    reused; the rest run through :func:`run_sweep`, checkpointed under
    ``ckroot/<stage>-<hash of their inputs>``.
    """
    import pandas as pd

    from capbridge.tables.sweep import run_sweep

    cols = [*_IN_NAMES, "status", *_OUT_NAMES]
    if not points:
        return pd.DataFrame(columns=cols)
    cache = _cached_points(stage, ckroot)
    keys = [_cache_key(p[n] for n in _IN_NAMES) for p in points]
    todo = [p for p, k in zip(points, keys) if k not in cache]
    if todo:
        inputs = {name: np.array([p[name] for p in todo], dtype=np.int64 if name in
                                 ("kind", "level") else float) for name in _IN_NAMES}
        ck = None
        if ckroot is not None:
            h = hashlib.sha256(json.dumps({k: v.tolist() for k, v in inputs.items()},
                                          sort_keys=True).encode()).hexdigest()[:10]
            ck = Path(ckroot) / f"{stage}-{h}"
        solver = functools.partial(solve_points, shapes_dir=None if shapes_dir is None
                                   else str(shapes_dir))
        res = run_sweep(solver, inputs, checkpoint_dir=ck, chunk_size=1, n_jobs=1,
                        progress=progress, desc=f"miot2021 {stage}",
                        settings={"stage": stage})
        for m in range(len(todo)):
            key = _cache_key(res[n][m] for n in _IN_NAMES)
            cache[key] = {k: res[k][m] for k in res if k not in _IN_NAMES}
    rows = []
    for p, k in zip(points, keys):
        r = {n: float(p[n]) for n in _IN_NAMES}
        r.update({n: cache[k].get(n, np.nan) for n in ("status", *_OUT_NAMES)})
        rows.append(r)
    df = pd.DataFrame(rows, columns=cols)
    df["kind"] = df["kind"].astype(int)
    df["level"] = df["level"].astype(int)
    df["status"] = df["status"].astype(int)
    df["V_ul"] = ul(df["volume"])
    df["status_name"] = [status_name(s) for s in df["status"]]
    return df

# --------------------------------------------------------------------------------------
# the exact parts
# --------------------------------------------------------------------------------------


def exact_stage(plan, log):
    """V_coal(theta), its fit, and the uncoalesced curves (no gravity)."""
    import pandas as pd

    from capbridge.solvers.triplet import (find_coalescence, triplet_geometry,
                                             uncoalesced_state)
    from capbridge.physics.coalescence_fit import CoalescenceVolumeFit

    geom = triplet_geometry(D12, D13, D23)
    alpha = geom.angle_at(0, 1, 2) / 2
    rows = []
    vc = {}
    thetas = sorted(set(plan.thetas_fit) | set(plan.thetas)
                    | {t for ts in plan.gravity.values() for t in ts})
    t0 = time.monotonic()
    for t in thetas:
        r = find_coalescence(geom, t)
        vc[t] = r.V_coal
        crit = {c["criterion"] + ": " + c["where"]: c["V"] for c in r.criteria}
        rows.append({"theta_deg": t, "V_coal_star": r.V_coal, "V_coal_ul": ul(r.V_coal),
                     "criterion": r.criterion, "where": r.where,
                     "beta_top_deg": r.beta["12"]["grain 1"], "alpha_deg": alpha,
                     "F_bridge_star": r.forces["12"], "P_star": r.pressure["12"],
                     "F_top_star": -r.grain_forces[0][2],
                     "E_uncoalesced_star": r.energy,
                     "V_menisci_ul": ul(crit.get("menisci: bridges 12 and 13", np.nan)),
                     "V_grain_ul": ul(crit.get("grain: bridge 12 reaching grain 3", np.nan))})
    log(f"exact V_coal for {len(thetas)} angles in {time.monotonic() - t0:.1f} s")
    dfv = pd.DataFrame(rows)
    fit_sel = dfv["theta_deg"].isin(plan.thetas_fit)
    fit = CoalescenceVolumeFit(90.0).fit(dfv.loc[fit_sel, "theta_deg"],
                                         dfv.loc[fit_sel, "V_coal_ul"])
    fit_low = None
    lo = dfv["theta_deg"].isin([t for t in plan.thetas_fit if t >= 15])
    if lo.sum() >= 3:
        fit_low = CoalescenceVolumeFit(90.0).fit(dfv.loc[lo, "theta_deg"],
                                                 dfv.loc[lo, "V_coal_ul"])
    dfv["fit_residual_ul"] = np.nan
    dfv.loc[fit_sel, "fit_residual_ul"] = fit.residuals
    # uncoalesced curves up to V_coal (plus the point at V_coal)
    curves = []
    for t in thetas:
        V = np.arange(plan.exact_step_ul, ul(vc[t]), plan.exact_step_ul)
        V = np.append(V, ul(vc[t]))
        st = uncoalesced_state(vstar(V), geom, t)
        F = -st["forces"][:, 0, 2]
        for v, f, s, e, b in zip(V, F, st["status"], st["energy"],
                                 st["bridge"][(0, 1)]["beta_i"]):
            curves.append({"theta_deg": t, "V_ul": v, "F_top_star": f if s == 0 else np.nan,
                           "status": status_name(s), "E_star": e,
                           "beta_top_deg": b, "at_coalescence": bool(v == ul(vc[t]))})
    return dfv, fit, fit_low, pd.DataFrame(curves), vc, alpha


def doublet_exact():
    import pandas as pd

    from capbridge.solvers.young_laplace import rupture_distance, solve_doublet
    from capbridge.physics import closed_forms as cf

    rows = []
    for V in FIG3_VOLUMES:
        dr = float(rupture_distance(V, 0.0)["gap"])
        d = np.linspace(0.0, min(dr * 0.999, 0.6), 121)
        ex = solve_doublet(d, V, 0.0)
        pit = cf.pitois_cylindrical_force(d, V, 0.0)
        ric = cf.richefeu_force(d, V, 0.0)
        wil = cf.willett_numeric_force(d, V, 0.0)
        for i in range(d.size):
            rows.append({"V_star": V, "d_star": d[i], "F_exact": ex["force"][i],
                         "F_pitois": pit[i] if V < 0.01 else np.nan,
                         "F_richefeu": ric[i], "F_willett": wil[i] if V < 0.1 else np.nan,
                         "F_willett_outside_range": wil[i], "d_rupture": dr})
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------
# the Evolver points of each stage
# --------------------------------------------------------------------------------------


def _grid_above(plan, v_ul):
    return [g for g in plan.grid_ul if g > v_ul + 0.25]


def _grid_below(plan, v_ul):
    """Grid volumes for separate bridges: up to 1 ul past ``v_ul`` (V_coal)."""
    return [g for g in plan.grid_ul if g <= v_ul + 1.0]


def doublet_points(plan):
    """Stage ``doublets`` (Fig. 3): the Evolver doublets at theta = 0."""
    return [dict(kind=DOUBLET, theta=0.0, volume=V, bond=0.0, gap=d, level=plan.doublet_refine)
            for V, ds in plan.doublet_points for d in ds]


def coalesced_points(plan, vc):
    """Stage ``coalesced-nogravity``: the coalesced body from V_coal (``vc``: theta ->
    V*) up the volume grid, and the energy probes below V_coal."""
    L = plan.max_refine
    pts = []
    for t in plan.thetas:
        for v in [ul(vc[t])] + _grid_above(plan, ul(vc[t])):
            pts.append(dict(kind=COALESCED, theta=t, volume=float(vstar(v)), bond=0.0, gap=0.0,
                            level=L))
        for f in plan.energy_fractions:
            pts.append(dict(kind=COALESCED, theta=t, volume=float(vc[t] * f), bond=0.0,
                            gap=0.0, level=L))
    return pts


def energy_low_points(plan, vc):
    """Stage ``energy-low``: coalesced bodies further below V_coal (:attr:`Plan.energy_low`)."""
    L = plan.max_refine
    return [dict(kind=COALESCED, theta=t, volume=float(vc[t] * f), bond=0.0, gap=0.0, level=L)
            for t in plan.energy_low[0] if t in vc for f in plan.energy_low[1]]


def bridge_points(plan, vc, bonds):
    """Stage ``bridges``: separate bridges by Evolver up to V_coal, without gravity (mesh
    bias of V_coal, refinement levels at theta = 0) and with gravity (``bonds``: gamma ->
    Bond number)."""
    L = plan.max_refine
    pts = []
    for t in plan.thetas:
        below = _grid_below(plan, ul(vc[t]))
        # theta = 0: every volume (the gravity-free baseline of Figs. 11/13 at the same
        # mesh level); other angles: the last few (mesh bias of V_coal)
        n_b = len(below) if (t == 0 and plan.bias_points) else plan.bias_points
        for v in below[-n_b:] if n_b else []:
            pts.append(dict(kind=BRIDGES, theta=t, volume=float(vstar(v)), bond=0.0, gap=0.0,
                            level=L))
    for lev in plan.bias_levels:
        pts.append(dict(kind=BRIDGES, theta=0.0, volume=float(vc[0.0]), bond=0.0, gap=0.0,
                        level=lev))
    for gam, ts in plan.gravity.items():
        for t in ts:
            below = _grid_below(plan, ul(vc[t]))
            if t not in plan.gravity_dense:
                below = sorted(set(g for g in below if g % 4 == 0) | set(below[-3:]))
            for v in below:
                pts.append(dict(kind=BRIDGES, theta=t, volume=float(vstar(v)),
                                bond=bonds[gam], gap=0.0, level=L))
    return pts


def coalesced_gravity_points(plan, vc, vc_grav, bonds):
    """Stage ``coalesced-gravity``: the coalesced body with gravity from its V_coal
    (``vc_grav``: (gamma, theta) -> ul, from the cap gaps; the exact no-gravity V_coal
    where that is not finite) up the volume grid."""
    L = plan.max_refine
    pts = []
    for gam, ts in plan.gravity.items():
        for t in ts:
            v0 = vc_grav[(gam, t)]
            if not np.isfinite(v0):
                v0 = ul(vc[t])
            v0 = round(float(v0), 3)
            above = _grid_above(plan, v0)
            if t not in plan.gravity_dense:
                above = [g for g in above if g % 4 == 0]
            for v in [v0] + above:
                pts.append(dict(kind=COALESCED, theta=t, volume=float(vstar(v)),
                                bond=bonds[gam], gap=0.0, level=L))
    return pts
