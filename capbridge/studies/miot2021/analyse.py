"""Reducing the study's results to the paper's quantities: V_coal from the Evolver cap
gaps, the force on the top grain along every curve and across coalescence, energies,
and the summary (``summary.json``) the claims are read from.

The results travel in one dict ``R`` (built by :func:`~capbridge.studies.miot2021.
pipeline.run`): the exact stage (``dfv``, ``fit``, ``fit_low``, ``curves``, ``vc``,
``alpha``, ``dfd``), the Evolver stages (``dfdv``, ``dfc0``, ``dfb``, ``dfcg``), V_coal
with gravity (``dfg``, ``vc_grav``), the Bond numbers (``bonds``) and the shapes
directory (``shapes``).
"""
from __future__ import annotations

import collections

import numpy as np

from capbridge.dimensionless import force_scale
from capbridge.studies.miot2021.experiment import D12, D13, D23, GAMMAS, RADIUS, ul, vstar
from capbridge.studies.miot2021.paper import FIG3_VOLUMES, paper_line
from capbridge.studies.miot2021.points import (BRIDGES, DOUBLET, HAS_RESULT_CODES,
                                               HAS_RESULT_NAMES)


def add_exact_doublet_forces(dfdv):
    """The exact force beside each Evolver doublet of Fig. 3 and their relative
    differences (columns ``F_exact``, ``rel_err_pct``, ``rel_err_direct_pct``, added to
    ``dfdv`` in place; it is returned)."""
    from capbridge.solvers.young_laplace import solve_doublet

    if len(dfdv):
        ex = solve_doublet(dfdv["gap"].to_numpy(), dfdv["volume"].to_numpy(), 0.0)
        dfdv["F_exact"] = ex["force"]
        dfdv["rel_err_pct"] = 100 * (dfdv["F_axial"] / dfdv["F_exact"] - 1)
        dfdv["rel_err_direct_pct"] = 100 * (dfdv["F_direct"] / dfdv["F_exact"] - 1)
    return dfdv


def coalescence_from_bridges(plan, dfb, vc, alpha, bonds):
    """V_coal where the Evolver cap gap on the top grain closes, without and with gravity.

    Without gravity the difference to the exact V_coal (``vc``: theta -> V*) is the
    mesh's bias; it is removed from the values with gravity.  Returns ``(dfg, vc_grav)``:
    one row per angle (and Bond number), and (gamma, theta) -> V_coal with gravity [ul].
    """
    import pandas as pd

    from capbridge.solvers.triplet_evolver import coalescence_from_cap_gaps

    L = plan.max_refine
    vrows = []
    mesh_bias = {}
    for t in plan.thetas:
        sel = dfb[(dfb["kind"] == BRIDGES) & (dfb["theta"] == t) & (dfb["bond"] == 0)
                  & (dfb["level"] == L) & (dfb["status"].isin(HAS_RESULT_CODES))]
        if len(sel) >= 2:
            c = coalescence_from_cap_gaps(sel["V_ul"], sel["cap_gap"], 2 * alpha)
            mesh_bias[t] = c["V_coal"] - ul(vc[t])
            vrows.append({"theta_deg": t, "bond": 0.0, "gamma": np.nan,
                          "V_coal_mesh_ul": c["V_coal"], "V_coal_exact_ul": ul(vc[t]),
                          "mesh_bias_ul": mesh_bias[t], "V_coal_corrected_ul": ul(vc[t]),
                          "method": c["method"], "n_points": len(sel)})
    vc_grav = {}
    for gam, ts in plan.gravity.items():
        for t in ts:
            sel = dfb[(dfb["theta"] == t) & (dfb["bond"] == bonds[gam]) & (dfb["status"].isin(HAS_RESULT_CODES))]
            c = coalescence_from_cap_gaps(sel["V_ul"], sel["cap_gap"], 2 * alpha)
            bias = mesh_bias.get(t, 0.0 if t > 0 else np.nan)
            corr = c["V_coal"] - (bias if np.isfinite(bias) else 0.0)
            vc_grav[(gam, t)] = corr
            vrows.append({"theta_deg": t, "bond": bonds[gam], "gamma": gam,
                          "V_coal_mesh_ul": c["V_coal"], "V_coal_exact_ul": np.nan,
                          "mesh_bias_ul": bias, "V_coal_corrected_ul": corr,
                          "method": c["method"], "n_points": len(sel),
                          "V_coal_nogravity_exact_ul": ul(vc[t])})
    dfg = pd.DataFrame(vrows)
    return dfg, vc_grav


def _mN(Fstar, gamma):
    """F* -> mN on the experiment's beads at surface tension ``gamma`` [N/m]."""
    return np.asarray(Fstar, float) * float(force_scale(RADIUS, gamma)) * 1e3


def force_table(R):
    """One long table of the vertical force on the top grain (every curve)."""
    import pandas as pd

    rows = []
    for _, c in R["curves"].iterrows():
        for gam in GAMMAS:
            rows.append({"regime": "uncoalesced", "method": "exact (Young-Laplace doublets)",
                         "gravity": False, "gamma_N_m": gam, "bond": 0.0,
                         "theta_deg": c["theta_deg"], "V_ul": c["V_ul"],
                         "F_top_star": c["F_top_star"],
                         "F_top_mN": _mN(c["F_top_star"], gam), "status": c["status"],
                         "energy_star": c["E_star"], "beta_top_deg": c["beta_top_deg"]})
    frames = [(R["dfc0"], "coalesced", False), (R["dfb"], "uncoalesced", None),
              (R["dfcg"], "coalesced", True)]
    for df, regime, grav in frames:
        for _, p in df.iterrows():
            if p["kind"] == DOUBLET:
                continue
            g = p["bond"] > 0
            if grav is not None and g != grav:
                continue
            gams = [gm for gm in GAMMAS if abs(R["bonds"][gm] - p["bond"]) < 1e-9] if g \
                else list(GAMMAS)
            for gam in gams:
                # below its V_coal a coalesced body is a probe (energies), not the curve;
                # with gravity V_coal is that found from the Evolver cap gaps
                v_coal = (R["vc_grav"].get((gam, p["theta"]), np.nan) if g
                          else ul(R["vc"].get(p["theta"], 0.0)))
                reg = regime
                if regime == "coalesced" and p["V_ul"] < v_coal - 1e-3:   # v0 rounded to 1e-3
                    reg = "coalesced_below_V_coal"
                rows.append({"regime": reg, "method": f"Surface Evolver (level "
                             f"{int(p['refinement']) if np.isfinite(p['refinement']) else -1})",
                             "gravity": bool(g), "gamma_N_m": gam, "bond": p["bond"],
                             "theta_deg": p["theta"], "V_ul": p["V_ul"],
                             "F_top_star": p["F_top"], "F_top_mN": _mN(p["F_top"], gam),
                             "status": p["status_name"], "energy_star": p["energy_ex"],
                             "energy_err": p["energy_err"],
                             "force_err_rel": p["force_err_rel"], "f12_star": p["f12"],
                             "f13_star": p["f13"], "f23_star": p["f23"],
                             "pair_residual": p["pair_residual"],
                             "force_sum_star": p["force_sum"], "cap_gap_deg": p["cap_gap"],
                             "lower_meniscus_z_mm": p["z_low"] * RADIUS * 1e3,
                             "level": p["level"], "cpu_s": p["cpu"], "wall_s": p["wall"]})
    return pd.DataFrame(rows)


def _exact_force_at_coalescence(curves, theta):
    """F* on the top grain from the exact separate bridges at V_coal(theta)."""
    return float(curves[(curves["theta_deg"] == theta)
                        & curves["at_coalescence"]]["F_top_star"].iloc[0])


def force_jumps(R):
    """Force on the top grain just before / after coalescence."""
    import pandas as pd

    rows = []
    vc = R["vc"]
    for t, v in vc.items():
        c0 = R["dfc0"]
        after = c0[(c0["theta"] == t) & (np.isclose(c0["volume"], v)) & (c0["status"].isin(HAS_RESULT_CODES))]
        if not len(after):
            continue
        before = _exact_force_at_coalescence(R["curves"], t)
        fa = float(after["F_top"].iloc[0])
        rows.append({"theta_deg": t, "gravity": False, "gamma_N_m": np.nan, "bond": 0.0,
                     "V_coal_ul": ul(v), "F_before_star": before, "F_after_star": fa,
                     "change_pct": 100 * (fa / before - 1),
                     "after_force_err_rel": float(after["force_err_rel"].iloc[0])})
    for (gam, t), v in R["vc_grav"].items():
        bo = R["bonds"][gam]
        b = R["dfb"]
        sel = b[(b["theta"] == t) & (b["bond"] == bo) & (b["status"].isin(HAS_RESULT_CODES))].sort_values("V_ul")
        c = R["dfcg"]
        after = c[(c["theta"] == t) & (c["bond"] == bo) & (c["status"].isin(HAS_RESULT_CODES))].sort_values("V_ul")
        if len(sel) < 2 or not len(after) or not np.isfinite(v):
            continue
        # before: the separate bridges' force extrapolated linearly to V_coal
        x, y = sel["V_ul"].to_numpy()[-2:], sel["F_top"].to_numpy()[-2:]
        before = float(y[-1] + (y[-1] - y[-2]) / (x[-1] - x[-2]) * (v - x[-1]))
        fa = float(after["F_top"].iloc[0])
        rows.append({"theta_deg": t, "gravity": True, "gamma_N_m": gam, "bond": bo,
                     "V_coal_ul": v, "F_before_star": before, "F_after_star": fa,
                     "change_pct": 100 * (fa / before - 1),
                     "after_force_err_rel": float(after["force_err_rel"].iloc[0]),
                     "V_after_ul": float(after["V_ul"].iloc[0]),
                     "V_before_last_ul": float(x[-1])})
    return pd.DataFrame(rows)


def energy_table(R):
    """Surface energies of the coalesced body (Evolver) and of the separate bridges
    (exact) at the same volumes, no gravity; returns ``(table, crossing)`` with, per
    angle, where the two cross and where the coalesced body was found."""
    import pandas as pd

    from capbridge.solvers.triplet import triplet_geometry, uncoalesced_state

    geom = triplet_geometry(D12, D13, D23)
    c0 = R["dfc0"]
    rows, cross = [], {}
    for t in sorted(set(c0["theta"])):
        sel = c0[c0["theta"] == t].sort_values("volume")
        unc = uncoalesced_state(sel["volume"].to_numpy(), geom, t)
        for (_, p), eu in zip(sel.iterrows(), unc["energy"]):
            rows.append({"theta_deg": t, "V_ul": p["V_ul"], "V_coal_ul": ul(R["vc"][t]),
                         "E_uncoalesced_star": eu,
                         "E_coalesced_star": p["energy_ex"] if p["status"] in HAS_RESULT_CODES else np.nan,
                         "E_coalesced_err": p["energy_err"] if p["status"] in HAS_RESULT_CODES else np.nan,
                         "coalesced_status": p["status_name"]})
        df = pd.DataFrame([r for r in rows if r["theta_deg"] == t])
        d = (df["E_coalesced_star"] - df["E_uncoalesced_star"]).to_numpy()
        V = df["V_ul"].to_numpy()
        ok = np.flatnonzero(np.isfinite(d))
        x = np.nan
        for a, b in zip(ok[:-1], ok[1:]):
            if np.sign(d[a]) != np.sign(d[b]):
                x = V[a] + (V[b] - V[a]) * d[a] / (d[a] - d[b])
                break
        cross[t] = {"crossing_ul": x,
                    "lowest_coalesced_ul": float(V[ok].min()) if ok.size else np.nan,
                    "coalesced_lower_everywhere": bool(ok.size and np.all(d[ok] < 0)),
                    "dE_at_V_coal": float(d[np.argmin(np.abs(V - ul(R["vc"][t])))])
                    if ok.size else np.nan,
                    "failed_below_ul": [float(v) for v, s in zip(V, df["coalesced_status"])
                                        if s != "converged"]}
    return pd.DataFrame(rows), cross


def build_summary(plan, R, ft, jumps, cross):
    """The numbers of ``summary.json``: what the claims table reads, from the results
    ``R``, the force table ``ft``, the force jumps and the energy crossings."""
    from capbridge.solvers.triplet_evolver import coalescence_from_cap_gaps

    fit, fit_low = R["fit"], R["fit_low"]
    vc = R["vc"]
    s = {"quick": plan.quick, "max_refine": plan.max_refine, "alpha_deg": R["alpha"],
         "geometry": {"r_mm": RADIUS * 1e3, "d12": D12, "d13": D13, "d23": D23},
         "bond_numbers": R["bonds"],
         "V_coal_exact_ul": {float(t): ul(v) for t, v in vc.items()},
         "V_coal_fit": fit.as_dict(),
         "V_coal_fit_theta_ge_15": None if fit_low is None else fit_low.as_dict(),
         "V_coal_gravity": R["dfg"].to_dict(orient="records"),
         "force_jumps": jumps.to_dict(orient="records"),
         "energy_crossing": cross}
    dv = R["dfdv"]
    if len(dv):
        s["doublet_evolver_vs_exact_max_abs_pct"] = float(np.nanmax(np.abs(dv["rel_err_pct"])))
        s["doublet_evolver_vs_exact"] = dv[["volume", "gap", "F_axial", "F_exact",
                                            "rel_err_pct", "status_name"]].to_dict(
            orient="records")
    dd = R["dfd"]
    for V in FIG3_VOLUMES:
        sel = dd[(dd["V_star"] == V) & (dd["d_star"] <= 0.8 * dd["d_rupture"])]
        for name in ("willett_outside_range", "richefeu", "pitois"):
            col = f"F_{name}"
            e = np.abs(sel[col] / sel["F_exact"] - 1) * 100
            s[f"closed_form_{name}_max_abs_pct_V{V}"] = float(np.nanmax(e)) if \
                np.isfinite(e).any() else None
    # mesh bias at theta = 0: cap gap against refinement at the exact V_coal
    b = R["dfb"]
    bias = b[(b["theta"] == 0) & (b["bond"] == 0) & np.isclose(b["volume"], vc[0.0])]
    s["theta0_cap_gap_at_exact_V_coal_by_level"] = {
        int(r["level"]): r["cap_gap"] for _, r in bias.iterrows() if r["status"] in HAS_RESULT_CODES}
    ex_top = _exact_force_at_coalescence(R["curves"], 0.0)
    s["theta0_force_at_V_coal_by_level"] = {
        "exact": ex_top,
        **{int(r["level"]): {"F_top": r["F_top"], "err_vs_exact_pct":
                             100 * (r["F_top"] / ex_top - 1), "est_err_pct":
                             100 * r["force_err_rel"], "cpu_s": r["cpu"]}
           for _, r in bias.iterrows() if r["status"] in HAS_RESULT_CODES}}
    # beta at 20 ul, theta = 60, gamma = 0.0693, gravity
    bo = R["bonds"][0.0693]
    sel = b[(b["theta"] == 60) & (b["bond"] == bo) & (b["status"].isin(HAS_RESULT_CODES))]
    if len(sel):
        c = coalescence_from_cap_gaps(sel["V_ul"], sel["cap_gap"], 2 * R["alpha"])
        at20 = [(v, bta) for v, bta in zip(c["volumes"], c["beta_equivalent"]) if abs(v - 20) < 1e-6]
        s["beta_equivalent_theta60_0693_gravity"] = dict(zip(c["volumes"], c["beta_equivalent"]))
        if at20:
            s["alpha_minus_beta_at_20ul_theta60_0693_gravity"] = R["alpha"] - at20[0][1]
    # energy convention: Evolver doublet energies against the exact ones
    if len(dv):
        from capbridge.solvers.young_laplace import solve_doublet
        ok = dv[dv["status"].isin(HAS_RESULT_CODES)]
        ex = solve_doublet(ok["gap"].to_numpy(), ok["volume"].to_numpy(), 0.0)["energy"]
        s["energy_convention_check"] = [
            {"V_star": float(v), "d_star": float(d), "E_exact": float(e),
             "E_evolver_extrapolated": float(x), "abs_diff": float(abs(x - e)),
             "rel_diff_pct": float(100 * abs(x / e - 1))}
            for v, d, e, x in zip(ok["volume"], ok["gap"], ex, ok["energy_ex"])]
    # slope of beta against V at the theta = 0 coalescence (exact)
    cu = R["curves"][(R["curves"]["theta_deg"] == 0) & R["curves"]["status"].isin(HAS_RESULT_NAMES)]
    if len(cu) >= 3:
        x, y = cu["V_ul"].to_numpy()[-3:], cu["beta_top_deg"].to_numpy()[-3:]
        s["beta_slope_theta0_deg_per_ul"] = float(np.polyfit(x, y, 1)[0])
    line = {float(t): ul(v) - paper_line(t) for t, v in vc.items()}
    s["V_coal_minus_paper_line_ul"] = line
    # gravity effect on force, theta = 0, gamma = 0.073 (against Evolver without gravity
    # at the same mesh level where available, else the exact doublets)
    bo = R["bonds"][0.073]
    g = ft[(ft["theta_deg"] == 0) & (ft["gamma_N_m"] == 0.073)]
    ng_ev = g[(~g["gravity"]) & (g["regime"] == "uncoalesced")
              & g["method"].str.startswith("Surface")]
    ng = ng_ev if len(ng_ev) >= 2 else g[(~g["gravity"]) & (g["regime"] == "uncoalesced")]
    s["gravity_effect_baseline"] = "Evolver, same level" if len(ng_ev) >= 2 else "exact"
    wg = g[(g["gravity"]) & (g["regime"] == "uncoalesced")]
    rel, rel_bottom = [], []
    for _, r in wg.iterrows():
        m = ng[np.isclose(ng["V_ul"], r["V_ul"])]
        if len(m) and np.isfinite(r["F_top_star"]):
            rel.append((r["V_ul"], 100 * (r["F_top_star"] / m["F_top_star"].iloc[0] - 1)))
            # the bottom pair is pulled up by F_top - W* (the forces on the three grains
            # sum to the liquid's weight W* = Bo V* / 2 pi, downwards)
            w = r["bond"] * float(vstar(r["V_ul"])) / (2 * np.pi)
            rel_bottom.append((r["V_ul"], 100 * ((r["F_top_star"] - w)
                                                 / m["F_top_star"].iloc[0] - 1)))
    s["gravity_effect_uncoalesced_theta0_pct"] = dict(rel)
    s["gravity_effect_uncoalesced_theta0_bottom_pair_pct"] = dict(rel_bottom)
    ngc = g[(~g["gravity"]) & (g["regime"] == "coalesced")]
    wgc = g[(g["gravity"]) & (g["regime"] == "coalesced")]
    rel = []
    for _, r in wgc.iterrows():
        m = ngc[np.isclose(ngc["V_ul"], r["V_ul"])]
        if len(m) and np.isfinite(r["F_top_star"]) and np.isfinite(m["F_top_star"].iloc[0]):
            rel.append((r["V_ul"], 100 * (r["F_top_star"] / m["F_top_star"].iloc[0] - 1)))
    s["gravity_effect_coalesced_theta0_pct"] = dict(rel)
    # trimer / dimer
    c0 = R["dfc0"]
    cg = R["dfcg"]
    zl = []
    for df, grav in ((c0, False), (cg, True)):
        for _, r in df[df["status"].isin(HAS_RESULT_CODES)].iterrows():
            if r["volume"] >= vc.get(r["theta"], 0) * (1 - 1e-9):
                zl.append({"theta_deg": r["theta"], "V_ul": r["V_ul"], "bond": r["bond"],
                           "z_low_mm": r["z_low"] * RADIUS * 1e3})
    s["lower_meniscus"] = zl
    s["pair_residual_max_nogravity"] = float(np.nanmax(c0["pair_residual"])) if len(c0) else None
    s["force_sum_max_nogravity"] = float(np.nanmax(c0["force_sum"])) if len(c0) else None
    frames = (R["dfdv"], c0, b, cg)
    by_status = collections.Counter(n for df in frames for n in df.get("status_name", []))
    s["evolver_points"] = {
        "total": int(sum(len(df) for df in frames)),
        "converged": int(sum((df["status"] == 0).sum() for df in frames)),
        "by_status": dict(by_status),
        # time of every Evolver point, whichever run computed it (checkpoints are reused)
        "wall_h": float(sum(np.nansum(df["wall"]) for df in frames if len(df))) / 3600,
        "cpu_h": float(sum(np.nansum(df["cpu"]) for df in frames if len(df))) / 3600}
    return s
