"""The paper's Figs. 6 and 11 after coalescence: the triplet table beside the direct
Evolver points, without and with gravity.

Reads the coalesced-body points of ``capbridge reproduce miot2021`` (no gravity, the
paper's triplet: gaps 0.175, 0.175, 0.075, r = 4 mm, so V* = V[ul] / 64) from
``triplet_forces.csv``, looks the same states up in the shipped triplet table
(``TripletSurrogate``, volumes above the table answered at its edge and marked
``extrapolated``), and writes ``table_vs_evolver.csv``, ``fig06_table_vs_evolver.png`` and
``TABLE_VS_EVOLVER.md`` (the differences) next to this script.

With gravity (Fig. 11 and its gamma = 0.0693 N/m variant: Bo = 2.14 and 2.26, gravity
pulling down across the bottom pair, the paper's orientation): the same states looked up
with the table's gravity response (``bond``, ``gravity`` = (0, 0, -1) in the frame of
``triplet_geometry``), written to ``table_vs_evolver_gravity.csv``,
``fig11_table_vs_evolver_gravity.png`` and a second section of ``TABLE_VS_EVOLVER.md``.

Usage: ``.venv/bin/python examples/miot2021/table_vs_evolver.py``
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from capbridge.solvers.triplet import triplet_geometry
from capbridge.status import status_name
from capbridge.surrogate.triplet import TripletSurrogate

HERE = Path(__file__).resolve().parent
DATA = HERE.parent.parent / "data"
RADIUS_MM = 4.0


def main():
    df = pd.read_csv(HERE / "triplet_forces.csv")
    ev = df[(df.regime == "coalesced") & (df.bond == 0) & (df.gamma_N_m == 0.073)
            & df.status.isin(["converged", "above_tolerance"])].copy()
    geom = triplet_geometry(0.175, 0.175, 0.075)
    sur = TripletSurrogate(out_of_range="clip").fit(DATA / "triplet_table.nc",
                                                    coalescence_table=DATA / "triplet_coalescence.nc")
    lines = no_gravity(ev, geom, sur)
    lines += [""] + with_gravity(df, geom, sur)
    (HERE / "TABLE_VS_EVOLVER.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def no_gravity(ev, geom, sur):
    V = ev.V_ul.to_numpy() / RADIUS_MM ** 3
    r = sur.predict_vectors(np.broadcast_to(geom.centres, (len(ev), 3, 3)), V,
                            ev.theta_deg.to_numpy())
    ev["F_top_table"] = -r["forces"][:, 0, 2]        # downward pull on the top grain
    for name in ("f12", "f23"):
        ev[f"{name}_table"] = r[name]
    ev["v"] = r["v"]
    ev["table_status"] = [status_name(s) for s in r["status"]]
    ev["rel_diff_F_top"] = ev.F_top_table / ev.F_top_star - 1
    cols = ["theta_deg", "V_ul", "v", "F_top_star", "F_top_table", "rel_diff_F_top",
            "f12_star", "f12_table", "f23_star", "f23_table", "level", "force_err_rel",
            "table_status"]
    ev[cols].to_csv(HERE / "table_vs_evolver.csv", index=False)

    inside = ev.table_status.isin(["converged", "above_tolerance"])
    lines = ["# The triplet table against the direct Evolver points (Fig. 6, coalesced, "
             "no gravity)", "",
             "Command: `.venv/bin/python examples/miot2021/table_vs_evolver.py`. Direct points: "
             "`triplet_forces.csv` (Evolver level 3, the reproduction's settings); table: "
             "`data/triplet_table.nc` through `TripletSurrogate` (cubic refinement, exact "
             "V_coal from `data/triplet_coalescence.nc`).", "",
             "| theta [deg] | points in the table's range | median rel. diff. F_top | max "
             "abs. rel. diff. F_top | points above the table's v (extrapolated) |",
             "|---:|---:|---:|---:|---:|"]
    for t, g in ev.groupby("theta_deg"):
        gi = g[inside.loc[g.index]]
        med = f"{gi.rel_diff_F_top.median():+.2%}" if len(gi) else "-"
        mx = f"{gi.rel_diff_F_top.abs().max():.2%}" if len(gi) else "-"
        lines.append(f"| {t:g} | {len(gi)} | {med} | {mx} | "
                     f"{int((g.table_status == 'extrapolated').sum())} |")
    d = ev[inside].rel_diff_F_top.abs()
    lines += ["", f"Over all {len(d)} points inside the table: median |diff| {d.median():.2%}, "
              f"max {d.max():.2%}. The direct points carry their own estimated force error "
              f"(median {ev[inside].force_err_rel.median():.2%})."]
    _figure(ev, "coalesced body: triplet table (lines) vs direct Evolver (dots)",
            "fig06_table_vs_evolver.png")
    return lines


def with_gravity(df, geom, sur):
    """Fig. 11 and its variant: direct Evolver points with gravity beside the table."""
    ev = df[(df.regime == "coalesced") & (df.bond > 0)
            & df.status.isin(["converged", "above_tolerance"])
            & df.method.str.contains("level 3")].copy()
    flat = df[(df.regime == "coalesced") & (df.bond == 0)
              & df.status.isin(["converged", "above_tolerance"])]
    n = len(ev)
    centres = np.broadcast_to(geom.centres, (n, 3, 3))
    V = ev.V_ul.to_numpy() / RADIUS_MM ** 3
    t = ev.theta_deg.to_numpy()
    r = sur.predict_vectors(centres, V, t, bond=ev.bond.to_numpy(), gravity=(0.0, 0.0, -1.0))
    r0 = sur.predict_vectors(centres, V, t)
    ev["v"] = r["v"]
    ev["F_top_table"] = -r["forces"][:, 0, 2]
    ev["F_top_table_nogravity"] = -r0["forces"][:, 0, 2]
    ev["table_status"] = [status_name(s) for s in r["status"]]
    ev["rel_diff_F_top"] = ev.F_top_table / ev.F_top_star - 1
    # the direct point without gravity at the same (theta, V, gamma): the gravity effect
    key = flat.set_index(["theta_deg", "V_ul"]).F_top_star
    key = key[~key.index.duplicated()]
    ev["F_top_star_nogravity"] = [key.get((a, b), np.nan) for a, b in zip(ev.theta_deg, ev.V_ul)]
    ev["gravity_effect_star"] = ev.F_top_star - ev.F_top_star_nogravity
    ev["gravity_effect_table"] = ev.F_top_table - ev.F_top_table_nogravity
    cols = ["theta_deg", "gamma_N_m", "bond", "V_ul", "v", "F_top_star", "F_top_table",
            "rel_diff_F_top", "F_top_star_nogravity", "gravity_effect_star",
            "gravity_effect_table", "level", "force_err_rel", "table_status"]
    ev[cols].to_csv(HERE / "table_vs_evolver_gravity.csv", index=False)
    inside = ev.table_status.isin(["converged", "above_tolerance", "approximate"])
    lines = ["# With gravity (Fig. 11: Bo = 2.14, gamma = 0.073 N/m; Bo = 2.26, gamma = 0.0693 "
             "N/m), gravity pulling down across the bottom pair", "",
             "Table: `data/triplet_table.nc` with its gravity response (first order and "
             "diagonal second order in b = Bo g_hat, `force_gravity_gradient`, "
             "`force_gravity_curvature`) through `TripletSurrogate.predict_vectors(..., bond, "
             "gravity=(0, 0, -1))`; direct: `triplet_forces.csv` (Evolver level 3 with gravity).",
             "",
             "| theta [deg] | Bo | points in the table's range | median rel. diff. F_top | "
             "max abs. rel. diff. F_top | gravity effect table / direct (median) |",
             "|---:|---:|---:|---:|---:|---:|"]
    for (th, bo), g in ev.groupby(["theta_deg", "bond"]):
        gi = g[inside.loc[g.index]]
        ratio = (gi.gravity_effect_table / gi.gravity_effect_star).median()
        med = f"{gi.rel_diff_F_top.median():+.2%}" if len(gi) else "-"
        mx = f"{gi.rel_diff_F_top.abs().max():.2%}" if len(gi) else "-"
        lines.append(f"| {th:g} | {bo:.2f} | {len(gi)} | {med} | {mx} | "
                     f"{ratio:.2f} |" if np.isfinite(ratio) else
                     f"| {th:g} | {bo:.2f} | {len(gi)} | {med} | {mx} | - |")
    d = ev[inside].rel_diff_F_top.abs()
    if len(d):
        lines += ["", f"Over all {len(d)} points with gravity inside the table: median |diff| "
                  f"{d.median():.2%}, max {d.max():.2%}."]
    _figure(ev, "with gravity: table + gravity response (lines) vs direct "
            "Evolver (dots)", "fig11_table_vs_evolver_gravity.png")
    return lines


def _figure(ev, title, name):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for k, (t, g) in enumerate(ev.groupby("theta_deg")):
        c = f"C{k}"
        ax.plot(g.V_ul, g.F_top_star, "o", color=c, ms=4, label=f"Evolver, {t:g} deg")
        gi = g[g.table_status != "extrapolated"]
        ax.plot(gi.V_ul, gi.F_top_table, "-", color=c, lw=1.2)
    ax.set_xlabel("liquid volume V [ul] (r = 4 mm)")
    ax.set_ylabel("vertical force on the top grain F* = F/(2 pi gamma r)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(HERE / name, dpi=120)


if __name__ == "__main__":
    main()
