"""The main job on the shipped data, one part per layer.

1. doublets: F*(d*) from the doublet table beside the exact Young-Laplace solution;
2. coalesced triplets: the paper's triplet (Miot et al. 2021: bottom gap 0.075, top gaps
   0.175) from the triplet table at a few volumes and contact angles, with statuses;
3. a wet packing in YADE (if installed): a few hundred grains settled dry under gravity,
   then wetted by :class:`~capbridge.yade.engine.CapbridgeEngine` (scene:
   :mod:`capbridge.cli.demo_packing`, run in its own process).

Each part writes a figure and a CSV into the output directory; ``capbridge demo``
(:func:`cmd_demo`) checks the tables and that directory first.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from capbridge.status import Status
from capbridge.tables import COALESCENCE_TABLE
from capbridge.validation import CapbridgeInputError

DEMO_VOLUMES = (0.008, 0.05, 0.156)
DEMO_THETAS = (0.0, 30.0, 60.0)
#: the triplet of Miot et al. (2021): gaps d12 = d13 (top grain), d23 (bottom pair)
DEMO_TRIPLET = (0.175, 0.175, 0.075)
#: triplet volumes printed, as multiples v = V*/V*_coal of the coalescence volume
DEMO_TRIPLET_V = (0.7, 0.85, 1.0, 1.25, 1.6, 2.0)
#: the wet packing: grains, most dry settling steps, wet steps
DEMO_PACKING = (300, 20000, 500)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def cmd_demo(args):
    """``capbridge demo``: the tables and the output directory checked, then
    :func:`run_demo`."""
    table = Path(args.table)
    if not table.exists():
        raise CapbridgeInputError(f"table {table} not found; make it with `capbridge generate doublet`")
    triplet = None if args.triplet_table in ("", "none") else Path(args.triplet_table)
    if triplet is not None and not triplet.exists():
        raise CapbridgeInputError(f"triplet table {triplet} not found; make it with "
                                  "`capbridge generate triplet` or give --triplet-table none")
    coal = COALESCENCE_TABLE if COALESCENCE_TABLE.exists() else None
    out = Path(args.output_dir)
    if out.exists() and not out.is_dir():
        raise CapbridgeInputError(f"--output-dir {out} is a file, not a directory")
    return run_demo(args.table, args.output_dir, triplet_table=triplet,
                    coalescence_table=coal, packing=not args.no_yade)


def run_demo(table, output_dir, n_gap=40, triplet_table=None, coalescence_table=None,
             packing=True):
    """The three parts in order (tables are loaded and checked before anything is
    written); ``triplet_table=None`` skips the triplets, ``packing=False`` the YADE run
    (skipped with a line when YADE is not installed).  Returns the exit status."""
    from capbridge.surrogate.doublet import DoubletSurrogate

    sur = DoubletSurrogate().fit(table)
    tri = None
    if triplet_table is not None:
        from capbridge.surrogate.triplet import TripletSurrogate

        tri = TripletSurrogate(out_of_range="clip").fit(triplet_table,
                                                        coalescence_table=coalescence_table)
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    print("== 1. doublets: the doublet table beside the exact Young-Laplace solution")
    run_doublets(sur, out, n_gap)
    if tri is not None:
        print("\n== 2. coalesced triplets: the paper's triplet (Miot et al. 2021) from the "
              "triplet table")
        run_triplets(tri, out)
    if packing:
        print("\n== 3. a wet packing in YADE with CapbridgeEngine")
        run_packing(out)
    return 0


def run_doublets(sur, out, n_gap=40):
    """Print and plot F*(d*) for a few V*, theta: surrogate lines, exact markers."""
    plt = _pyplot()
    from capbridge.solvers.young_laplace import solve_doublet

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
    plt.close(fig)


def run_triplets(tri, out, n_v=41):
    """Pair forces of the paper's triplet against the liquid volume at theta = 0, 30,
    60 deg (top pairs f12 = f13, bottom pair f23), printed at a few volumes with their
    statuses, plotted over the table's range of v = V*/V*_coal."""
    from capbridge.status import status_name
    from capbridge.surrogate.triplet import LOWER_ENERGY_STATES

    plt = _pyplot()
    d12, d13, d23 = DEMO_TRIPLET
    print(f"gaps d12 = d13 = {d12:g}, d23 = {d23:g}; v = V*/V*_coal; f12 = f13 (top pairs), "
          "f23 (bottom pair), attraction > 0")
    print(f"{'theta':>6} {'V*_coal':>8} {'v':>5} {'V*':>7} {'f12':>8} {'f23':>8} {'P*':>8} "
          f"{'f_err':>7}  {'status':<16} lower-energy state")
    fig, axes = plt.subplots(1, len(DEMO_THETAS), figsize=(4.2 * len(DEMO_THETAS), 3.6),
                             sharey=True)
    rows = []
    for ax, theta in zip(axes, DEMO_THETAS):
        vc = float(tri.coalescence_volume(d12, d13, d23, theta)["volume_coalescence"])
        v_fine = np.linspace(tri.axes_[4].coarse[0], tri.axes_[4].coarse[-1], n_v)
        r = tri.predict(d12, d13, d23, v_fine * vc, theta)
        ax.plot(v_fine * vc, r["f12"], label="f12 = f13 (top)")
        ax.plot(v_fine * vc, r["f23"], label="f23 (bottom)")
        ax.axvline(vc, color="0.6", lw=0.8, ls="--")
        ax.set_title(f"theta = {theta:g} deg (dashed: V*_coal)")
        ax.set_xlabel("V* = V/r^3")
        ax.grid(alpha=0.3)
        r = tri.predict(d12, d13, d23, np.array(DEMO_TRIPLET_V) * vc, theta)
        for k, v in enumerate(DEMO_TRIPLET_V):
            st = status_name(int(r["status"][k]))
            low = LOWER_ENERGY_STATES[int(r["lower_energy_state"][k])]
            vals = [float(r[x][k]) for x in ("f12", "f23", "pressure", "force_error")]
            rows.append([theta, vc, v, v * vc, *vals, st, low])
            print(f"{theta:6.0f} {vc:8.4f} {v:5.2f} {v * vc:7.4f} {vals[0]:8.4f} {vals[1]:8.4f} "
                  f"{vals[2]:8.4f} {vals[3]:7.4f}  {st:<16} {low}")
    axes[0].set_ylabel("pair force F* = F/(2 pi gamma r)")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"coalesced triplet, gaps {d12:g}, {d13:g}, {d23:g} (no line: no "
                 "coalesced body in the table)", fontsize=9)
    fig.tight_layout()
    png = out / "triplet_force_vs_volume.png"
    fig.savefig(png, dpi=120)
    plt.close(fig)
    with open(out / "triplet_forces.csv", "w") as fh:
        fh.write("theta_deg,V_coal,v,V,f12,f23,P,f_error,status,lower_energy_state\n")
        for row in rows:
            fh.write(",".join(f"{x:.6g}" if isinstance(x, float) else str(x) for x in row) + "\n")
    n_num = sum(np.isfinite(row[4]) for row in rows)
    print(f"\n{n_num} of {len(rows)} points answered (the others: no coalesced body in the "
          f"table there, status given); figure: {png}")


def run_packing(out, grains=None, timeout=900.0):
    """The wet packing of :mod:`capbridge.cli.demo_packing` in a fresh process; prints
    its lines, draws the bridges coloured by force.  Skipped with a line without YADE."""
    from capbridge.yade import yade_runtime

    if yade_runtime.find_yade() is None:
        print("YADE is not installed (Debian package 'yade'): the wet packing is skipped")
        return None
    scene = Path(__file__).with_name("demo_packing.py")   # not imported: it runs YADE
    n, dry, wet = grains or DEMO_PACKING
    run = yade_runtime.run_yade_script(scene, (n, dry, wet), timeout=timeout,
                                       cwd=out)
    for line in run.stdout.splitlines():
        if line.startswith(("wet packing", "  ")):
            print(line)
    res = run.result
    plt = _pyplot()
    from matplotlib.collections import LineCollection

    pos = np.array(res["pos"])
    rad = np.array(res["radius"])
    ends = np.array(res["bridge_ends"], dtype=int).reshape(-1, 2)
    force = np.array(res["bridge_force"]) * 1e3
    fig, ax = plt.subplots(figsize=(5.2, 5.0))
    for (x, _, z), r in zip(pos, rad):
        ax.add_patch(plt.Circle((x * 1e3, z * 1e3), r * 1e3, fc="0.9", ec="0.6", lw=0.4))
    seg = np.stack([pos[ends[:, 0]][:, [0, 2]], pos[ends[:, 1]][:, [0, 2]]], axis=1) * 1e3
    lc = LineCollection(seg, array=force, cmap="viridis", linewidths=1.5)
    ax.add_collection(lc)
    fig.colorbar(lc, ax=ax, label="bridge force [mN]")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_title(f"{res['n_grains']} wet grains, {res['n_bridges']} capillary bridges "
                 "(side view)", fontsize=9)
    fig.tight_layout()
    png = out / "wet_packing.png"
    fig.savefig(png, dpi=120)
    plt.close(fig)
    np.savetxt(out / "wet_packing_bridges.csv",
               np.column_stack([ends, force]) if ends.size else np.empty((0, 3)),
               delimiter=",", header="grain1,grain2,force_mN", comments="", fmt=["%d", "%d", "%.6g"])
    print(f"figure: {png} (YADE run {run.elapsed:.0f} s)")
    return res
