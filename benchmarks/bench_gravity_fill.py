"""Filled gravity-response nodes of the triplet tables: leave-one-out error of the fill.

    .venv/bin/python benchmarks/bench_gravity_fill.py [--write]

A node whose six gravity runs did not all converge is filled by the surrogate from its
neighbours (:func:`capbridge.surrogate.triplet_gravity.fill_response`: linear in v,
else in theta), and lookups in the cells touching it are ``approximate``.  Here every
canonical node with a response is left out in turn and filled the same way from the
others; the error of its first-order response G (per unit weight W = V*/(2 pi): a grain's
share of the weight and the change of the capillary forces, in units of the weight) is
the largest entry |G_fill - G| / W.  At Bo = b the force error is about that times b W,
reported relative to the node's largest grain force at Bo = 1 and at the Bo of a 1 mm
water-wetted glass bead (0.136).  Section "Gravity response: filled nodes" of RESULTS.md.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from results_file import report  # noqa: E402

SECTION = "### Gravity response: filled nodes"
TABLES = ("triplet_table.nc", "triplet_table_packings.nc")
BO_BEAD = 0.136          # water, r = 1 mm: 1000 * 9.81 * 1e-6 / 0.072


def leave_one_out(path):
    """Per canonical node with a response: (share error, error / max|F| at Bo = 1)."""
    import xarray as xr

    from capbridge.status import HAS_RESULT, Status, status_in
    from capbridge.surrogate.triplet_gravity import fill_response

    ds = xr.open_dataset(path)
    dims = ("d12", "d13", "d23", "theta", "gravity_v")
    tdims = dims + ("grain", "component", "gravity_component")
    G = ds["force_gravity_gradient"].transpose(*tdims).values
    st = ds["gravity_status"].transpose(*dims).values
    gv = ds["gravity_v"].values
    Vc = ds["volume_coalescence"].transpose(*dims[:4]).values
    W = Vc[..., None] * gv / (2 * np.pi)
    ok = status_in(st, HAS_RESULT) & np.isfinite(G).all((-3, -2, -1))
    vals = np.where(ok[..., None], (G / np.where(ok, W, 1.0)[..., None, None, None])
                    .reshape(ok.shape + (27,)), 0.0)
    F = ds["force"].transpose("d12", "d13", "d23", "theta", "v", "grain", "component")
    iv = [int(np.argmin(np.abs(ds["v"].values - x))) for x in gv]
    Fmax = np.linalg.norm(F.values[..., iv, :, :], axis=-1).max(-1)
    d = ds["d12"].values
    canon = (d[:, None, None] <= d[None, :, None]) & (d[None, :, None] <= d[None, None, :])
    theta = ds["theta"].values.astype(float)
    share, rel, eq = [], [], []
    equal = np.tile(np.eye(3).ravel() / 3.0, 3)        # the engine's fallback: W / 3 each
    for idx in np.argwhere(ok & canon[..., None, None]):
        t = tuple(idx)
        mask = np.zeros(ok.shape, bool)
        mask[t] = True
        out, filled = fill_response(vals, ok & ~mask, mask, (theta, gv))
        if not filled[t]:
            continue
        e = float(np.max(np.abs(out[t] - vals[t])))
        share.append(e)
        eq.append(float(np.max(np.abs(equal - vals[t]))) * W[t] / Fmax[t])
        rel.append(e * W[t] / Fmax[t])
    return np.array(share), np.array(rel), np.array(eq), \
        int((~ok & (st != Status.NOT_COMPUTED)).sum())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    lines = [SECTION, "", "Command: `python benchmarks/bench_gravity_fill.py --write`.  Every "
             "canonical node with a gravity response left out and filled from the others "
             "as the surrogate fills a failed one (linear in v, else theta).  Share error: "
             "the largest |G_fill - G| / W; force error: that times W, relative to the "
             "node's largest grain force, at Bo = 1 and at Bo = 0.136 (water, r = 1 mm).",
             "  Beside it the engine's former fallback at such cells, the weight shared "
             "equally by the three grains (no change of the capillary forces).",
             "", "| table | failed nodes filled | nodes left out | share error median / "
             "p90 / max | force error at Bo = 1: median / p90 / max | equal shares at Bo = 1: "
             "median / p90 / max |", "|---|---|---|---|---|---|"]
    for name in TABLES:
        share, rel, eq, n_failed = leave_one_out(ROOT / "data" / name)
        lines.append(f"| {name} | {n_failed} | {share.size} | {np.median(share):.3f} / "
                     f"{np.percentile(share, 90):.3f} / {share.max():.3f} | "
                     f"{np.median(rel):.2%} / {np.percentile(rel, 90):.2%} / {rel.max():.2%} | "
                     f"{np.median(eq):.2%} / {np.percentile(eq, 90):.2%} / {eq.max():.2%} |")
    report(SECTION, "\n".join(lines) + "\n", a.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
