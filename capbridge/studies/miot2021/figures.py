"""The study's figures: the paper's Figs. 3, 6/9, 10, 11/13, 14, 15, the energies and
the profiles of Figs. 7, 12, 16, drawn from the reduced results (PNG, 120 dpi)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from capbridge.studies.miot2021.experiment import D12, D13, D23, ul, vstar
from capbridge.studies.miot2021.paper import FIG3_VOLUMES, PAPER_LINE_TEXT, paper_line
from capbridge.studies.miot2021.points import (COALESCED, HAS_RESULT_CODES, HAS_RESULT_NAMES,
                                               point_key)


def _split_at_coalescence(rows, v_coal):
    """(rows up to V_coal, rows past it): separate bridges past V_coal (caps overlapping)
    are drawn as open markers, not as part of the curve."""
    if v_coal is None or not np.isfinite(v_coal):
        return rows, rows.iloc[:0]
    past = rows["V_ul"] > v_coal + 1e-9
    return rows[~past], rows[past]


def _save_figure(fig, out, name):
    """Lay out, write ``out/name`` (120 dpi) and close ``fig``; returns ``name``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(out / name, dpi=120)
    plt.close(fig)
    return name


def _volume_axes(ax, ylabel, title, title_size=None):
    """Total volume on x, ``ylabel`` on y, ``title``, legend."""
    ax.set_xlabel("total volume V [ul]")
    ax.set_ylabel(ylabel)
    ax.set_title(title, **({} if title_size is None else {"fontsize": title_size}))
    ax.legend(fontsize=7)


def make_figures(out, plan, R, ft, en):
    """Draw every figure into ``out`` from the results ``R``, the force table ``ft`` and
    the energy table ``en``; returns the names of the files written."""
    import matplotlib.pyplot as plt

    figs = []
    cmap = plt.get_cmap("viridis")
    thetas = list(plan.thetas)

    def col(t):
        return cmap(float(t) / 90.0)

    def by_theta(ax, t, two, y_two, coalesced, y_coalesced, label):
        """One angle: two bridges (line), coalesced body (circles), V_coal (dotted)."""
        ax.plot(two["V_ul"], two[y_two], "-", color=col(t), label=label)
        ax.plot(coalesced["V_ul"], coalesced[y_coalesced], "o--", mfc="none", color=col(t))
        ax.axvline(ul(R["vc"][t]), color=col(t), lw=0.5, ls=":")

    # Fig. 3: doublets
    dd, dv = R["dfd"], R["dfdv"]
    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    for ax, V in zip(axs, FIG3_VOLUMES):
        s = dd[dd["V_star"] == V]
        ax.plot(s["d_star"], s["F_exact"], "g--", label="exact Young-Laplace")
        if V < 0.01:
            ax.plot(s["d_star"], s["F_pitois"], "y-.", label="Pitois (cylindrical)")
        ax.plot(s["d_star"], s["F_richefeu"], "kx", ms=4, markevery=6, label="Richefeu")
        if V < 0.1:
            ax.plot(s["d_star"], s["F_willett"], "c:", label="Willett")
        else:
            ax.plot(s["d_star"], s["F_willett_outside_range"], "c:", alpha=0.4,
                    label="Willett (outside its range)")
        if len(dv):
            e = dv[np.isclose(dv["volume"], V) & (dv["status"].isin(HAS_RESULT_CODES))]
            ax.errorbar(e["gap"], e["F_axial"], yerr=e["F_axial"] * e["force_err_rel"],
                        fmt="bo", label="energy method (Surface Evolver)")
        ax.set_title(f"V* = {V}, theta = 0")
        ax.set_xlabel("d*")
        ax.set_ylabel("F* = F / (2 pi gamma r)")
        ax.legend(fontsize=7)
    figs.append(_save_figure(fig, out, "fig03_doublet.png"))

    # Figs. 6/9: force on the top grain against volume, no gravity, gamma = 0.073
    fig, ax = plt.subplots(figsize=(7, 5))
    g = ft[(ft["gamma_N_m"] == 0.073) & (~ft["gravity"])]
    for t in thetas:
        u = g[(g["theta_deg"] == t) & (g["regime"] == "uncoalesced")
              & g["method"].str.startswith("exact")]
        c = g[(g["theta_deg"] == t) & (g["regime"] == "coalesced") & g["status"].isin(HAS_RESULT_NAMES)
              & (g["V_ul"] >= ul(R["vc"][t]) - 1e-9)].sort_values("V_ul")
        by_theta(ax, t, u, "F_top_mN", c, "F_top_mN", f"theta = {t:g}")
    _volume_axes(ax, "vertical force on the top grain [mN]",
                 "no gravity, gamma = 0.073 N/m: two bridges (lines, exact), "
                 "coalesced (circles, Evolver)", title_size=8)
    figs.append(_save_figure(fig, out, "fig06_09_force_vs_volume.png"))

    # Fig. 10: V_coal against theta
    dfv, fit = R["dfv"], R["fit"]
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(dfv["theta_deg"], dfv["V_coal_ul"], "bo", label="exact, caps criterion")
    tt = np.linspace(0, 90, 50)
    ax.plot(tt, fit.predict(tt), "b-", label=f"fit: {fit.V0:.2f} + theta/90 x {fit.dV:.2f} ul")
    ax.plot(tt, paper_line(tt), "r--", label=f"paper: {PAPER_LINE_TEXT} ul")
    if R["fit_low"] is not None:
        fl = R["fit_low"]
        ax.plot(tt, fl.predict(tt), "b:", lw=1,
                label=f"fit theta >= 15: {fl.V0:.2f} + theta/90 x {fl.dV:.2f} ul")
    dg = R["dfg"]
    m0 = dg[dg["bond"] == 0] if len(dg) else dg
    if len(m0):
        ax.plot(m0["theta_deg"], m0["V_coal_mesh_ul"], "kx", ms=8,
                label=f"no gravity, beta from our Evolver mesh (level {plan.max_refine})")
    for gam, mk in ((0.073, "s"), (0.0693, "^")):
        s = dg[(dg["gamma"] == gam)]
        if len(s):
            ax.plot(s["theta_deg"], s["V_coal_corrected_ul"], mk, color="g", mfc="none",
                    label=f"gravity, gamma = {gam} (Evolver, mesh bias removed)")
    ax.set_xlabel("contact angle theta [deg]")
    ax.set_ylabel("V_coal [ul]")
    ax.legend(fontsize=7)
    figs.append(_save_figure(fig, out, "fig10_vcoal_theta.png"))

    # Figs. 11/13: theta = 0, gravity and surface tension
    fig, axs = plt.subplots(2, 1, figsize=(7, 8), sharex=True)
    g0 = ft[(ft["theta_deg"] == 0) & ft["status"].isin(HAS_RESULT_NAMES)]
    styles = {(0.073, False): ("b", "o", "-"), (0.0693, False): ("c", "o", "--"),
              (0.073, True): ("g", "*", "-"), (0.0693, True): ("m", "*", "--")}
    for (gam, grav), (c, mk, ls) in styles.items():
        s = g0[(g0["gamma_N_m"] == gam) & (g0["gravity"] == grav)]
        if not len(s):
            continue
        for regime, fill in (("uncoalesced", c), ("coalesced", "none")):
            r = s[s["regime"] == regime]
            if regime == "uncoalesced" and not grav:
                r = r[r["method"].str.startswith("exact")]
                axs[0].plot(r["V_ul"], r["F_top_mN"], ls, color=c,
                            label=f"gamma {gam}, no gravity")
                axs[1].plot(r["V_ul"], r["F_top_star"], ls, color=c)
                continue
            if regime == "coalesced" and not grav:
                r = r[r["V_ul"] >= ul(R["vc"][0.0]) - 1e-9]
            r = r.sort_values("V_ul")
            lab = f"gamma {gam}, {'gravity' if grav else 'no gravity'}, {regime}"
            if regime == "uncoalesced":
                r, past = _split_at_coalescence(r, R["vc_grav"].get((gam, 0.0)))
                axs[0].plot(past["V_ul"], past["F_top_mN"], mk, color=c, mfc="none")
                axs[1].plot(past["V_ul"], past["F_top_star"], mk, color=c, mfc="none")
            axs[0].plot(r["V_ul"], r["F_top_mN"], mk + ls, color=c, mfc=fill, label=lab)
            axs[1].plot(r["V_ul"], r["F_top_star"], mk + ls, color=c, mfc=fill)
    axs[0].set_ylabel("F on top grain [mN]")
    axs[1].set_ylabel("F* = F / (2 pi gamma r)")
    axs[1].set_xlabel("total volume V [ul]")
    axs[0].set_title("theta = 0: gravity and surface tension (Figs. 11, 13)")
    axs[0].legend(fontsize=6)
    figs.append(_save_figure(fig, out, "fig11_13_gravity_gamma.png"))

    # Fig. 14: gamma = 0.0693, gravity, theta = 55 and 60
    s14 = ft[(ft["gamma_N_m"] == 0.0693) & ft["gravity"] & ft["theta_deg"].isin([55.0, 60.0])
             & ft["status"].isin(HAS_RESULT_NAMES)]
    if len(s14):
        fig, ax = plt.subplots(figsize=(6, 4.5))
        for t, mk in ((60.0, "^"), (55.0, "s")):
            for regime, ls in (("uncoalesced", ":"), ("coalesced", "-")):
                r = s14[(s14["theta_deg"] == t) & (s14["regime"] == regime)].sort_values("V_ul")
                if regime == "uncoalesced":
                    r, past = _split_at_coalescence(r, R["vc_grav"].get((0.0693, t)))
                    ax.plot(past["V_ul"], past["F_top_mN"], mk, color="gray", mfc="none")
                ax.plot(r["V_ul"], r["F_top_mN"], mk + ls, label=f"theta {t:g}, {regime}")
                rough = r[r["force_err_rel"] > 0.03]
                ax.plot(rough["V_ul"], rough["F_top_mN"], mk, color="w", ms=4)
        ax.text(0.98, 0.02, "white centre: estimated force error > 3 %; gray: separate "
                "bridges past V_coal", transform=ax.transAxes, ha="right", fontsize=6)
        _volume_axes(ax, "F on top grain [mN]", "gamma = 0.0693 N/m, gravity (Fig. 14)")
        figs.append(_save_figure(fig, out, "fig14_calibration.png"))

    # Fig. 15: beta against volume, theta = 60, gamma = 0.0693, gravity
    b = R["dfb"]
    s15 = b[(b["theta"] == 60) & (b["bond"] == R["bonds"][0.0693]) & (b["status"].isin(HAS_RESULT_CODES))]
    if len(s15):
        fig, ax = plt.subplots(figsize=(6, 4))
        beta = R["alpha"] - 0.5 * s15["cap_gap"]
        ax.plot(s15["V_ul"], beta, "k^", label="gravity (Evolver): alpha - cap gap / 2")
        cu = R["curves"][R["curves"]["theta_deg"] == 60]
        ax.plot(cu["V_ul"], cu["beta_top_deg"], "b-", label="no gravity (exact)")
        ax.axhline(R["alpha"], color="r", label=f"alpha = {R['alpha']:.2f} deg")
        _volume_axes(ax, "half filling angle on the top grain [deg]",
                     "theta = 60, gamma = 0.0693 N/m (Fig. 15)")
        figs.append(_save_figure(fig, out, "fig15_beta.png"))

    # energies
    if len(en):
        fig, ax = plt.subplots(figsize=(7, 5))
        for t in sorted(set(en["theta_deg"])):
            s = en[en["theta_deg"] == t].sort_values("V_ul")
            cu = R["curves"][R["curves"]["theta_deg"] == t]
            by_theta(ax, t, cu, "E_star", s, "E_coalesced_star", f"theta {t:g}: two bridges")
        _volume_axes(ax, "E* = (A_lg - cos(theta) A_wet) / r^2",
                     "surface energy: two bridges (lines, exact) and coalesced body "
                     "(circles, Evolver)", title_size=8)
        figs.append(_save_figure(fig, out, "fig_energy.png"))

    # profiles in the plane of the centres (Figs. 7, 12, 16)
    f = _profiles_figure(out, plan, R)
    if f:
        figs.append(f)
    return figs


def _profiles_figure(out, plan, R):
    """Sections in the plane of the centres (exact bridges, kept Evolver shapes); ``None``
    when no shape was kept (no checkpoint directory) or none was found."""
    import matplotlib.pyplot as plt

    from capbridge.solvers.triplet import (bridge_meridian, triplet_geometry,
                                             uncoalesced_state)

    if R["shapes"] is None or not Path(R["shapes"]).is_dir():
        return None
    geom = triplet_geometry(D12, D13, D23)
    vc0 = R["vc"][0.0]
    panels = [("theta 0, no gravity: two bridges at V_coal (exact) and coalesced",
               [(COALESCED, 0.0, vc0, 0.0)], vc0),
              ("theta 0, V = 16 ul: no gravity / gravity (gamma 0.073)",
               [(COALESCED, 0.0, vstar(16.0), 0.0),
                (COALESCED, 0.0, vstar(16.0), R["bonds"][0.073])], None),
              ("theta 0, V = 30 ul: no gravity / gravity (gamma 0.073)",
               [(COALESCED, 0.0, vstar(30.0), 0.0),
                (COALESCED, 0.0, vstar(30.0), R["bonds"][0.073])], None)]
    if 55.0 in plan.gravity.get(0.0693, ()):
        v55 = R["vc_grav"].get((0.0693, 55.0), np.nan)
        panels.append(("theta 55, gamma 0.0693, gravity: after coalescence and 36 ul",
                       [(COALESCED, 55.0, vstar(round(float(v55), 3)), R["bonds"][0.0693]),
                        (COALESCED, 55.0, vstar(36.0), R["bonds"][0.0693])], None))
    fig, axs = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4.2))
    axs = np.atleast_1d(axs)
    any_drawn = False
    colors = ["b", "g", "m"]
    for ax, (title, items, exact_v) in zip(axs, panels):
        for c in geom.centres:
            ax.add_patch(plt.Circle((c[0], c[2]), 1.0, fill=False, color="0.5"))
        if exact_v is not None:
            st = uncoalesced_state(exact_v, geom, 0.0)
            for (i, j) in ((0, 1), (0, 2)):
                r = st["bridge"][(i, j)]
                x, y = bridge_meridian(geom.gap(i, j), r["pressure"], r["beta_i"],
                                       r["beta_j"], 0.0)
                u = geom.axis(i, j)
                nrm = np.array([-u[2], 0.0, u[0]])
                for sgn in (1, -1):
                    P = geom.centres[i] + x[:, None] * u + sgn * y[:, None] * nrm
                    ax.plot(P[:, 0], P[:, 2], "k-", lw=1)
        for n, (k, t, v, bo) in enumerate(items):
            key = point_key(k, t, float(v), bo, 0.0, plan.max_refine)
            f = Path(R["shapes"]) / (key + ".npz")
            if not f.exists():
                continue
            seg = np.load(f)["section"]
            for sg in seg:
                ax.plot(sg[:, 0], sg[:, 2], "-", color=colors[n % 3], lw=1)
            any_drawn = True
        ax.set_aspect("equal")
        ax.set_xlim(-2.3, 2.3)
        ax.set_ylim(-1.3, 3.1)
        ax.axhline(0.0, color="0.8", lw=0.5)
        ax.set_title(title, fontsize=7)
    if not any_drawn:
        plt.close(fig)
        return None
    return _save_figure(fig, out, "fig07_12_16_profiles.png")
