"""The main job on the shipped data: F*(d*) from the table beside the exact solution."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from capbridge.status import Status

DEMO_VOLUMES = (0.008, 0.05, 0.156)
DEMO_THETAS = (0.0, 30.0, 60.0)


def run_demo(table, output_dir, n_gap=40):
    """Print and plot F*(d*) for a few V*, theta: surrogate lines, exact markers."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from capbridge.solvers.young_laplace import solve_doublet
    from capbridge.surrogate.doublet import DoubletSurrogate

    sur = DoubletSurrogate().fit(table)
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, len(DEMO_THETAS), figsize=(4.2 * len(DEMO_THETAS), 3.6), sharey=True)
    rows = []
    print(f"{'theta':>6} {'V*':>7} {'d*':>7} {'F* table':>10} {'F* exact':>10} {'rel.err':>9}")
    for ax, theta in zip(axes, DEMO_THETAS):
        for vol in DEMO_VOLUMES:
            d_r = float(sur.predict(0.0, vol, theta)["rupture_gap"])
            gap = np.linspace(0.0, d_r * 1.05, n_gap)
            f_tab = sur.predict(gap, vol, theta)["force"]
            exact = solve_doublet(gap[::4], vol, theta)
            ok = exact["status"] == Status.CONVERGED
            line, = ax.plot(gap, f_tab, label=f"V*={vol:g} (table)")
            ax.plot(gap[::4][ok], exact["force"][ok], "o", mfc="none", color=line.get_color())
            for g, ft, fe, st in zip(gap[::4], f_tab[::4], exact["force"], exact["status"]):
                err = abs(ft / fe - 1) if st == Status.CONVERGED and fe else float("nan")
                rows.append((theta, vol, g, ft, fe, err))
                print(f"{theta:6.0f} {vol:7.3f} {g:7.4f} {ft:10.5f} {fe:10.5f} {err:9.2e}")
        ax.set_title(f"theta = {theta:g} deg")
        ax.set_xlabel("d* = d/r")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("F* = F/(2 pi gamma r)")
    axes[0].legend(fontsize=8, title="lines: table, circles: exact", title_fontsize=8)
    fig.tight_layout()
    png = out / "doublet_force_vs_gap.png"
    fig.savefig(png, dpi=120)
    np.savetxt(out / "doublet_force_vs_gap.csv", np.array(rows), delimiter=",",
               header="theta_deg,V,d,F_table,F_exact,rel_err", comments="")
    errs = np.array([r[-1] for r in rows])
    errs = errs[np.isfinite(errs)]
    print(f"\nmedian relative error {np.median(errs):.2e}, max {np.max(errs):.2e} "
          f"over {errs.size} converged points; figure: {png}")
    return 0
