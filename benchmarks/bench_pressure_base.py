"""A base model under the triplet table: doublets at the coalesced body's own pressure.

    .venv/bin/python benchmarks/bench_pressure_base.py [--table data/triplet_table.nc]
        [--write]

Issue 18 asks for a physical model under the triplet table, cheap and defined
everywhere, so that the table stores a small, smooth correction.  The first candidate is
the one a DEM code can build from what it has: each pair of the triplet a doublet bridge
at the coalesced body's Laplace pressure P* (the table's), on the doublet's stable
branch (volumes above its pressure minimum), from the doublet table; nothing else.

At every table node with a result this measures, against the Surface Evolver pair forces
f_ij of the node:

* the share of pairs that have such a doublet at all (a doublet at gap d has a pressure
  minimum: a body's P* below it has none, e.g. across the open side);
* the relative error of the doublet force against f_ij where it exists;
* the share of the body's liquid the doublets hold (the rest is the pore body);
* smoothness: the error of predicting a node from its two neighbours along v (linear in
  log v), for the raw f_ij and for the residual f_ij - F_doublet (relative to |f_ij|):
  a base worth tabulating against makes the second smaller.

Prints a markdown section; ``--write`` puts it in ``benchmarks/RESULTS.md`` (replacing
its own section).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

from results_file import write_section  # noqa: E402

from capbridge.status import HAS_RESULT, Status  # noqa: E402
from capbridge.surrogate.doublet import DoubletSurrogate  # noqa: E402
from capbridge.tables.netcdf_io import read_table  # noqa: E402

SECTION = "### Triplet pressure base model: doublets at the body's pressure"
PAIRS = ("f12", "f13", "f23")
GAPS = ("d12", "d13", "d23")


class DoubletsAtPressure:
    """Doublet volume and force at a given P* on the stable branch, per (gap, theta)."""

    def __init__(self, doublet, n=400):
        self.doublet = doublet
        vol = np.asarray(doublet.volume_, float)            # the table's V* axis
        self.grid = np.geomspace(vol.min(), vol.max(), n)
        self.branches = {}

    def __call__(self, gap, theta, P):
        key = (round(float(gap), 9), float(theta))
        if key not in self.branches:
            r = self.doublet.predict(np.full(self.grid.size, gap), self.grid, theta)
            ok = r["status"] == Status.CONVERGED
            Pb, Fb, Vb = r["pressure"][ok], r["force"][ok], self.grid[ok]
            k = int(np.argmin(Pb)) if Pb.size else 0
            Pb, Fb, Vb = Pb[k:], Fb[k:], Vb[k:]
            self.branches[key] = (Pb, Fb, Vb, Pb.size > 1 and bool(np.all(np.diff(Pb) > 0)))
        Pb, Fb, Vb, mono = self.branches[key]
        if not mono or not Pb[0] <= P <= Pb[-1]:
            return np.nan, np.nan
        return float(np.interp(P, Pb, Vb)), float(np.interp(P, Pb, Fb))


def measure(table):
    ds = read_table(table)
    dbl = DoubletsAtPressure(DoubletSurrogate().fit(ROOT / "data" / "doublet_table.nc"))
    st = ds["status"].values
    has = np.isin(st, HAS_RESULT)
    f = np.stack([ds[p].values for p in PAIRS], -1)                 # (..., 3)
    Fb = np.full(f.shape, np.nan)
    Vb = np.full(f.shape, np.nan)
    for idx in np.argwhere(has):
        i = tuple(idx)
        th = float(ds.theta.values[idx[3]])
        P = float(ds.pressure.values[i])
        for m, g in enumerate(GAPS):
            gap = float(ds[g].values[idx[m]])
            Vb[i + (m,)], Fb[i + (m,)] = dbl(gap, th, P)
    V = ds.volume.values
    exists = np.isfinite(Fb) & has[..., None]
    rel = (Fb - f) / np.abs(f)
    share = np.nansum(Vb, axis=-1)[has] / V[has]
    # smoothness along v (axis 4), interior nodes with both neighbours with a result
    lv = np.log(ds.v.values)
    w = (lv[1:-1] - lv[:-2]) / (lv[2:] - lv[:-2])
    def loo(x):
        pred = x[..., :-2, :] * (1 - w)[:, None] + x[..., 2:, :] * w[:, None]
        return np.abs(x[..., 1:-1, :] - pred)
    ok3 = has[..., :-2] & has[..., 1:-1] & has[..., 2:]
    both = ok3[..., None] & exists[..., :-2, :] & exists[..., 1:-1, :] & exists[..., 2:, :]
    scale = np.abs(f[..., 1:-1, :])
    raw = (loo(f) / scale)[both]
    res = (loo(f - Fb) / scale)[both]
    return {"nodes": int(has.sum()), "pairs": int(has.sum() * 3),
            "pairs_with_doublet": int(exists.sum()),
            "rel_error": np.percentile(rel[exists], [10, 50, 90]),
            "f_without": np.percentile(np.abs(f[has[..., None] & ~exists]), [50, 100]),
            "share": np.percentile(share, [10, 50, 90]),
            "loo_raw": np.percentile(raw, [50, 90]), "loo_res": np.percentile(res, [50, 90]),
            "loo_n": int(raw.size)}


def section(r, table):
    e, s = r["rel_error"], r["share"]
    return "\n".join([
        SECTION, "",
        f"Command: `python benchmarks/bench_pressure_base.py` (table `{Path(table).name}`, "
        "the doublet table for the doublets).  At each of the table's "
        f"{r['nodes']} nodes with a result, each pair a doublet at the body's P* (stable "
        "branch), nothing else:", "",
        "| measure | value |", "|---|---|",
        f"| pairs with a doublet at the body's P* | {r['pairs_with_doublet']} of {r['pairs']} "
        f"({100 * r['pairs_with_doublet'] / r['pairs']:.0f} %) |",
        f"| doublet force against f_ij, relative (p10 / median / p90) | {e[0]:+.3f} / "
        f"{e[1]:+.3f} / {e[2]:+.3f} |",
        f"| f_ij of the pairs without a doublet (median / max, F*) | {r['f_without'][0]:.3f} / "
        f"{r['f_without'][1]:.3f} |",
        f"| liquid held by the doublets / the body's (p10 / median / p90) | {s[0]:.2f} / "
        f"{s[1]:.2f} / {s[2]:.2f} |",
        f"| node from its v neighbours, raw f_ij (median / p90, relative) | "
        f"{r['loo_raw'][0]:.3f} / {r['loo_raw'][1]:.3f} |",
        f"| the same for the residual f_ij - F_doublet ({r['loo_n']} node-pairs) | "
        f"{r['loo_res'][0]:.3f} / {r['loo_res'][1]:.3f} |", "",
        "Verdict: not a base.  Two pairs in three have no doublet at the body's pressure "
        "(the body's suction is beyond what a bridge at that gap can hold, the open side "
        "above all), where the body still pulls; where a doublet exists it is short of the "
        "pair force and holds a small part of the liquid (the pore body carries the "
        "rest), and the residual is hardly smoother than the raw force along v (last two "
        "rows).  A base has to "
        "carry the pore body (its volume, and its pressure and tension on each grain's "
        "wetted region); the next candidate.", ""])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--table", default=str(ROOT / "data" / "triplet_table.nc"))
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    text = section(measure(a.table), a.table)
    print(text)
    if a.write:
        write_section(SECTION, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
