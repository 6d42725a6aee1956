"""The window model as a base under the triplet table: held-out Evolver bodies, the
residual's smoothness at the table's nodes, and the pressure from the volume (issue 18
item 2, issue 19 item 2).

    .venv/bin/python benchmarks/bench_base_residual.py [--collect] [--write]

The window model (:func:`capbridge.physics.wetted_region.predict_regions`) was chosen
on the bodies of ``bench_wetted_region.py``.  This benchmark measures it where it was not
chosen:

1. held-out Surface Evolver bodies (level 2, one Evolver process at a time): triplets at
   random points of the packing domain (bridge gaps 0-0.2, third gap 0.2-0.6, theta
   0-60 deg, v = V / V_coal 1-4; fixed seed) and clusters of four grains (a distorted
   tetrahedron, a square, a skewed rhombus); the window model's grain forces at
   Evolver's P* against Evolver's, per grain relative to the body's max |F_i|, split by
   the sign of P*.  Cached in ``benchmarks/evolver_out/base_heldout.json`` (``--collect``
   computes the missing bodies);
2. at every node of the triplet table with a result, the window model's pair forces at
   the node's own P* (the table's decomposition: least-squares pair forces
   :func:`capbridge.solvers.triplet.pair_forces` of the grain forces, checked against the
   table's f_ij from its own grain forces), their error against f_ij, and the
   smoothness of the raw f_ij and of the residual f_ij - f_base: the error of predicting
   a node from its two neighbours along v (linear in log v) and along each gap;
3. the pressure from the volume: P* solved from the body's volume with
   :func:`~capbridge.physics.wetted_region.body_volume` (the window model's volume) and
   with :func:`~capbridge.physics.wetted_region.pore_volume_model` variants, and the
   resulting force error.

``--write`` puts the section in RESULTS.md.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

from capbridge.physics import wetted_region as wr  # noqa: E402
from bench_wetted_region import _q, bridged_pairs, level3_pairs  # noqa: E402
from bench_wetted_region import key as case_key  # noqa: E402

CACHE = HERE / "evolver_out" / "base_heldout.json"
SECTION = "### The window model as a base: held-out bodies and the triplet table's residual"
SEED = 18
N_TRIPLETS = 30
MAX_REFINE = 2


def heldout_triplets(n=N_TRIPLETS, seed=SEED):
    """Random points of the packing domain: (d12, d13, d23, theta, v)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d12, d13 = rng.uniform(0.0, 0.2, 2)
        d23 = rng.uniform(0.2, 0.6)
        th = rng.uniform(0.0, 60.0)
        v = rng.uniform(1.0, 4.0)
        out.append(tuple(round(float(x), 3) for x in (d12, d13, d23, th, v)))
    return out


def heldout_clusters(seed=SEED):
    """Four-grain bodies: name -> (centres (4, 3), [(theta, V*), ...])."""
    rng = np.random.default_rng(seed + 1)
    D = 2.08
    h = D * np.sqrt(3) / 2
    tet = np.array([[0, 0, 0], [D, 0, 0], [D / 2, h, 0], [D / 2, h / 3, D * np.sqrt(2 / 3)]])
    while True:                          # every gap in [0.01, 0.16]
        t = tet + rng.uniform(-0.05, 0.05, tet.shape)
        g = [np.linalg.norm(t[i] - t[j]) - 2 for i in range(4) for j in range(i + 1, 4)]
        if 0.01 <= min(g) and max(g) <= 0.16:
            break
    D4 = 2.05
    sq = np.array([[0, 0, 0], [D4, 0, 0], [D4, D4, 0], [0, D4, 0]], float)
    a = np.radians(70.0)                 # a rhombus with a 70 deg angle, sides gap 0.06
    s = 2.06
    rh = np.array([[0, 0, 0], [s, 0, 0], [s + s * np.cos(a), s * np.sin(a), 0],
                   [s * np.cos(a), s * np.sin(a), 0]])
    return {"distorted tetrahedron": (np.round(t, 4), [(0.0, 0.6), (20.0, 0.5), (40.0, 0.9),
                                                       (30.0, 1.2)]),
            "square": (sq, [(20.0, 0.8), (40.0, 1.0), (0.0, 0.6)]),
            "rhombus 70": (rh, [(20.0, 0.7), (40.0, 1.0)])}


def case_list():
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry
    cases = []
    for d12, d13, d23, th, v in heldout_triplets():
        g = triplet_geometry(d12, d13, d23)
        vc = float(find_coalescence(g, th).V_coal)
        cases.append({"kind": "triplet", "name": f"random {d12:g}/{d13:g}/{d23:g}",
                      "gaps": [d12, d13, d23], "theta": th, "v": v, "V_coal": vc,
                      "V": v * vc})
    for name, (C, runs) in heldout_clusters().items():
        for th, V in runs:
            cases.append({"kind": "cluster", "name": name, "centres": np.asarray(C).tolist(),
                          "theta": th, "V": V, "v": None, "V_coal": None})
    return cases


def key(c, level=MAX_REFINE):
    """The cache key of a held-out body (bench_wetted_region's, at ``level``)."""
    return case_key(c, level)


def collect(budget_s=None, level3=()):
    """Solve the missing held-out bodies (one Evolver at a time), caching each; the
    bodies whose level-2 key is in ``level3`` also at level 3 (a check)."""
    from bench_wetted_region import solve_into
    cache = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    spent = sum(c.get("cpu_s", 0.0) for c in cache.values())
    todo = [(c, MAX_REFINE) for c in case_list()]
    todo += [(c, 3) for c in case_list() if key(c) in level3]
    for case, level in todo:
        k = key(case, level)
        if k in cache:
            continue
        if budget_s is not None and spent > budget_s:
            print(f"budget {budget_s} s spent; stop", flush=True)
            break
        spent += solve_into(cache, CACHE, case, level)["cpu_s"]
    return cache


# ---------------------------------------------------------------------------------------
# the window model's forces
# ---------------------------------------------------------------------------------------

def model_forces(C, theta, P, **kw):
    """The window model's grain forces F*_i (equal unit radii) at pressure P*."""
    C = np.asarray(C, float)
    n = len(C)
    S, L, _ = wr.predict_regions(C, np.ones(n), theta, P, bridged_pairs(C, np.ones(n)), **kw)
    return wr.region_force(P, theta, S, L)


#: model variants (``predict_regions`` options) measured side by side: the continuous
#: model (the defaults since 2026-11-27), the window model before it, and each of its two
#: changes alone
NEW, OLD = "continuous model", "old window model"
VARIANTS = {NEW: {},
            OLD: {"missing_bridge": "minimum", "positive_pressure": "hull"},
            "continuous caps only": {"positive_pressure": "hull"},
            "flat windows at P* >= 0 only": {"missing_bridge": "minimum"}}


def heldout_rows(cache, variants=VARIANTS):
    """Per grain and variant: error of the model at Evolver's P* (and of its balanced
    variant, the mean force removed) relative to the body's max |F_i|."""
    rows = []
    for k, c in sorted(cache.items()):
        if c.get("forces") is None:
            continue
        C = np.asarray(c["centres"], float)
        F = np.asarray(c["forces"], float)
        P, th = float(c["pressure"]), float(c["theta"])
        scale = float(np.linalg.norm(F, axis=1).max())
        for vname, kw in variants.items():
            Fm = model_forces(C, th, P, **kw)
            Fb = Fm - Fm.mean(axis=0)
            for g in range(len(C)):
                rows.append({"key": k, "kind": c["kind"], "name": c["name"], "P": P,
                             "theta": th, "grain": g, "variant": vname,
                             "err": float(np.linalg.norm(Fm[g] - F[g]) / scale),
                             "err_bal": float(np.linalg.norm(Fb[g] - F[g]) / scale),
                             "sum": float(np.linalg.norm(Fm.sum(axis=0)) / scale)})
    return rows


# ---------------------------------------------------------------------------------------
# 2. the triplet table: window pair forces at the nodes' P*, residual smoothness
# ---------------------------------------------------------------------------------------

PAIRS = ("f12", "f13", "f23")
GAPS = ("d12", "d13", "d23")


def table_base(table, kw=None):
    """Per node with a result: f_ij (table), f_base (the model with options ``kw`` at
    the node's P*, least-squares pair forces of its grain forces as the table's), and
    the grain-force error relative to the node's max |F_i|."""
    from capbridge.solvers.triplet import pair_forces, triplet_geometry
    from capbridge.status import HAS_RESULT
    from capbridge.tables.netcdf_io import read_table
    ds = read_table(table)
    has = np.isin(ds["status"].values, HAS_RESULT)
    f = np.stack([ds[p].values for p in PAIRS], -1)
    fb = np.full(f.shape, np.nan)
    gerr = np.full(has.shape + (3,), np.nan)
    exists = np.zeros(has.shape, bool)
    check = 0.0
    for idx in np.argwhere(has):
        i = tuple(idx)
        g = triplet_geometry(*(float(ds[d].values[idx[m]]) for m, d in enumerate(GAPS)))
        th = float(ds.theta.values[idx[3]])
        P = float(ds.pressure.values[i])
        F = np.asarray(ds.force.values[i], float)
        ft, _ = pair_forces(g.centres, F, [(0, 1), (0, 2), (1, 2)])
        check = max(check, float(np.max(np.abs(
            np.array([ft[(0, 1)], ft[(0, 2)], ft[(1, 2)]]) - f[i]))))
        exists[i] = all(wr.toroidal_half_angles(2.0 + float(ds[d].values[idx[m]]), 1.0, 1.0,
                                                th, P)[2] for m, d in enumerate(GAPS))
        Fm = model_forces(g.centres, th, P, **(kw or {}))
        fm, _ = pair_forces(g.centres, Fm, [(0, 1), (0, 2), (1, 2)])
        fb[i] = [fm[(0, 1)], fm[(0, 2)], fm[(1, 2)]]
        gerr[i] = np.linalg.norm(Fm - F, axis=1) / np.linalg.norm(F, axis=1).max()
    return {"ds": ds, "has": has, "f": f, "fb": fb, "gerr": gerr, "check": check,
            "P": ds.pressure.values, "exists": exists}


def smoothness_subset(t, mask):
    """:func:`smoothness` with only the nodes of ``mask`` counted as having a result."""
    return smoothness(dict(t, has=t["has"] & mask))


def loo(x, coord, axis, has, log=False):
    """|x_node - linear interpolation of its two neighbours along ``axis``| at interior
    nodes whose three nodes have a result; x has a trailing pair axis.  Returns the
    error and the node's value and node scale (max_ij |x|) arrays, flattened over the
    valid entries."""
    c = np.log(coord) if log else np.asarray(coord, float)
    w = (c[1:-1] - c[:-2]) / (c[2:] - c[:-2])
    sh = [1] * x.ndim
    sh[axis] = len(w)
    w = w.reshape(sh)
    n = x.shape[axis]
    lo = np.take(x, range(0, n - 2), axis=axis)
    mid = np.take(x, range(1, n - 1), axis=axis)
    hi = np.take(x, range(2, n), axis=axis)
    hm = [np.take(has, range(a, n - 2 + a), axis=axis) for a in range(3)]
    ok = (hm[0] & hm[1] & hm[2])[..., None] & np.isfinite(lo + mid + hi)
    return np.abs(mid - (lo * (1 - w) + hi * w)), ok


def smoothness(t):
    """LOO interpolation error of raw f and of the residual f - f_base along each axis,
    relative to |f_ij| (as bench_pressure_base) and to the node's max_ij |f_ij|."""
    ds, has, f, fb = t["ds"], t["has"], t["f"], t["fb"]
    out = {}
    for axis, name in enumerate(GAPS + ("theta", "v")):
        coord = ds[name].values
        if len(coord) < 3:
            continue
        er, ok = loo(f, coord, axis, has, log=(name == "v"))
        es, _ = loo(f - fb, coord, axis, has, log=(name == "v"))
        ok = ok & np.isfinite(es)
        mid = np.take(f, range(1, f.shape[axis] - 1), axis=axis)
        s_pair = np.abs(mid)
        s_node = np.broadcast_to(np.max(np.abs(mid), axis=-1, keepdims=True), mid.shape)
        out[name] = {"n": int(ok.sum()),
                     "raw_pair": _q((er / s_pair)[ok], (50, 90)),
                     "res_pair": _q((es / s_pair)[ok], (50, 90)),
                     "raw_node": _q((er / s_node)[ok], (50, 90)),
                     "res_node": _q((es / s_node)[ok], (50, 90)),
                     "ratio": _q((es / np.maximum(er, 1e-12))[ok], (50,))[0]}
    return out


# ---------------------------------------------------------------------------------------
# 3. the pressure from the volume
# ---------------------------------------------------------------------------------------

#: (window_kappa of the regions, window_kappa of the volume)
VOLUME_VARIANTS = {"balls 2/|P*| (regions and volume)": (2.0, 2.0),
                   "regions 2/|P*|, volume 1.5/|P*|": (2.0, 1.5),
                   "balls 1.5/|P*| (regions and volume)": (1.5, 1.5)}
N_SAMPLES = 200_000


def pressure_rows(cache, variants=VOLUME_VARIANTS, n_samples=N_SAMPLES):
    """Per body and variant: P* solved from the body's volume with the model's
    ``body_volume``, its error, and the force error with that P* and with Evolver's."""
    out = []
    for k, c in sorted(cache.items()):
        if not k.endswith(f"L{MAX_REFINE}") or c.get("forces") is None:
            continue
        C = np.asarray(c["centres"], float)
        n = len(C)
        pairs = bridged_pairs(C, np.ones(n))
        F = np.asarray(c["forces"], float)
        sc = float(np.linalg.norm(F, axis=1).max())
        for name, (ka, kv) in variants.items():
            Pm = wr.pressure_from_volume(C, np.ones(n), c["theta"], c["V"], pairs,
                                         window_kappa=kv, n_samples=n_samples)
            row = {"key": k, "variant": name, "P": float(c["pressure"]), "Pm": Pm,
                   "err_model_P": None, "err_true_P": None}
            Ft = model_forces(C, c["theta"], c["pressure"], window_kappa=ka)
            row["err_true_P"] = (np.linalg.norm(Ft - F, axis=1) / sc).tolist()
            if np.isfinite(Pm):
                Fm = model_forces(C, c["theta"], Pm, window_kappa=ka)
                row["err_model_P"] = (np.linalg.norm(Fm - F, axis=1) / sc).tolist()
            out.append(row)
    return out


# ---------------------------------------------------------------------------------------
# the section
# ---------------------------------------------------------------------------------------

def _fmt(q, f="{:.3f}"):
    return " / ".join(f.format(x) for x in q)


def heldout_family(r):
    return "triplets (random)" if r["kind"] == "triplet" else r["name"]


def section(a):
    cache = json.loads(CACHE.read_text())
    l2 = {k: c for k, c in cache.items() if k.endswith(f"L{MAX_REFINE}")}
    n_ok = sum(c["forces"] is not None for c in l2.values())
    failed = [k for k, c in l2.items() if c["forces"] is None]
    cpu = sum(c["cpu_s"] for c in cache.values())
    rows = heldout_rows(l2)
    out = [SECTION, "",
           f"Command: `python benchmarks/bench_base_residual.py{' --write' if a.write else ''}` "
           "(Evolver bodies from `--collect`, one Evolver process at a time beside a "
           f"two-process sweep; {len(l2)} held-out bodies at level {MAX_REFINE}, {n_ok} with "
           f"a result, {cpu / 60:.1f} Evolver CPU min with the level-3 checks; cached in "
           "`benchmarks/evolver_out/base_heldout.json`, no new Evolver run here).  Models "
           "(`predict_regions` options): continuous model = the defaults "
           "(`missing_bridge=\"reach\"`: a bridged pair whose toroidal bridge does not exist "
           "at the body's P* gets the caps of the bridge's fold, no wider than the reach of a "
           "gas torus of the body's curvature 2/|P*| about the line of centres, so that they "
           "shrink to zero where that torus passes through the gap; "
           "`positive_pressure=\"flat\"`: at P* >= 0 the window pieces of the suction "
           "continue as flat windows, their limit as P* -> 0-); old window model = "
           "`missing_bridge=\"minimum\", positive_pressure=\"hull\"` (the model of the "
           "section \"Wetted regions of coalesced bodies\", chosen there on other bodies: caps "
           "at the least pressure of the pair's scanned toroidal family, hulls at P* >= 0); "
           "and each change alone.  Bridged pairs: gap <= 0.2.  "
           f"Held-out bodies: {N_TRIPLETS} triplets at random points (seed {SEED}) of bridge "
           "gaps d12, d13 in 0-0.2, third gap d23 in 0.2-0.6, theta 0-60 deg, v = V/V_coal "
           "1-4 (V_coal from `find_coalescence`); four grains: a distorted tetrahedron "
           "(gaps 0.03-0.12), a square (sides 0.05, diagonals 0.9), a 70 deg rhombus "
           "(sides 0.06, short diagonal 0.36), theta 0-40."
           + (f"  No result: {'; '.join(failed)}." if failed else ""), "",
           "1. Held-out bodies: the model's grain forces at Evolver's P* against Evolver's, "
           "|F_model - F_Evolver| / max_k |F_Evolver,k| per grain (median / max); balanced: "
           "the continuous model's mean force removed from each grain; net force: the "
           "continuous model's.", "",
           "| family | P* | bodies | grains | " + " | ".join(VARIANTS) + " | balanced | net "
           "force |sum F_i| / max |F_i| |", "|---|---|---|---|" + "---|" * (len(VARIANTS) + 2)]
    fams = sorted({heldout_family(r) for r in rows})
    groups = [(f, sg) for f in fams for sg in ("< 0", ">= 0")] + [("all", "< 0"),
                                                                   ("all", ">= 0")]
    for f, sg in groups:
        def pick(r, f=f, sg=sg):
            return ((f == "all" or heldout_family(r) == f)
                    and ((r["P"] < 0) == (sg == "< 0")))
        d = [r for r in rows if pick(r) and r["variant"] == NEW]
        if not d:
            continue
        cols = [_fmt(_q([r["err"] for r in rows if pick(r) and r["variant"] == v]))
                for v in VARIANTS]
        out.append(f"| {f} | {sg} | {len({r['key'] for r in d})} | {len(d)} | "
                   + " | ".join(cols) + f" | {_fmt(_q([r['err_bal'] for r in d]))} | "
                   f"{_fmt(_q([r['sum'] for r in d if r['grain'] == 0]))} |")
    # level-3 checks
    l3 = []
    l3num = []
    for k3, c2, c3, moved in level3_pairs(cache, MAX_REFINE):
        k2 = k3[:-3] + f" L{MAX_REFINE}"
        r2, r3 = heldout_rows({k2: c2}), heldout_rows({k3: c3})
        e = {v: (max(r["err"] for r in r2 if r["variant"] == v),
                 max(r["err"] for r in r3 if r["variant"] == v)) for v in (NEW, OLD)}
        l3num.append((moved, e[NEW][1]))
        l3.append(f"| {k3[:-3]} | {c2['pressure']:.3f} / {c3['pressure']:.3f} | "
                  f"{moved:.3f} | "
                  f"{e[NEW][0]:.3f} / {e[NEW][1]:.3f} | {e[OLD][0]:.3f} / {e[OLD][1]:.3f} | "
                  f"{c3['cpu_s']:.0f} |")
    if l3:
        out += ["", "Level-3 checks of two of the worst bodies (`--collect --level3 KEY`): P* "
                "at levels 2 / 3, Evolver's level-2 forces against level 3 (max over grains, "
                "relative to max |F_i|), the models' max error against level 2 / 3, "
                "CPU s of the level-3 run.", "",
                "| body | P* | L2 vs L3 | continuous model | old window model | CPU s |",
                "|---|---|---|---|---|---|"] + l3
    # where the error is: magnitude and direction
    mags, angs = {"clusters": [], "triplets, grain 1": [], "triplets, grains 2-3": []}, {}
    for k, c in sorted(l2.items()):
        if c["forces"] is None or not c["pressure"] < 0:
            continue
        C = np.asarray(c["centres"], float)
        F = np.asarray(c["forces"], float)
        Fm = model_forces(C, c["theta"], c["pressure"])
        for g in range(len(C)):
            grp = ("clusters" if c["kind"] == "cluster" else
                   "triplets, grain 1" if g == 0 else "triplets, grains 2-3")
            cs = Fm[g] @ F[g] / (np.linalg.norm(Fm[g]) * np.linalg.norm(F[g]))
            mags[grp].append(np.linalg.norm(Fm[g]) / np.linalg.norm(F[g]))
            angs.setdefault(grp, []).append(np.degrees(np.arccos(np.clip(cs, -1, 1))))
    out += ["", "Where the error is (held-out bodies in suction, the continuous model): "
            "|F_model| / |F_Evolver| and the angle between them.", "",
            "| grains | n | magnitude ratio (min / median / max) | angle, deg (median / max) |",
            "|---|---|---|---|"]
    for grp, m in mags.items():
        if m:
            out.append(f"| {grp} | {len(m)} | {_fmt(_q(m, (0, 50, 100)), '{:.2f}')} | "
                       f"{_fmt(_q(angs[grp]), '{:.1f}')} |")
    # 2. the table
    t_run = time.process_time()
    tabs = {name: table_base(a.table, kw) for name, kw in VARIANTS.items()}
    t_run = time.process_time() - t_run
    t0 = tabs[NEW]
    has, P = t0["has"], t0["P"]
    out += ["", f"2. The models under the triplet table `{Path(a.table).name}`: at each "
            f"of its {int(has.sum())} nodes with a result ({int((has & (P < 0)).sum())} in "
            f"suction, {int((has & (P >= 0)).sum())} at P* >= 0; all three gaps <= 0.2, so "
            "every node is a closed triangle), the model's grain forces at the node's own "
            "P*, decomposed into pair forces as the table is (least-squares `pair_forces` of "
            "the grain forces; the table's f_ij are reproduced from its grain forces to "
            f"{t0['check']:.0e}; {t_run / len(tabs):.0f} CPU s per model for all nodes).  "
            "Error of f_base against f_ij, (f_base - f_ij) / |f_ij|, "
            "and of the grain forces, relative to the node's max |F_i|:", "",
            "| model | nodes | pair force, relative (p10 / median / p90) | grain force "
            "(median / p90 / max) |", "|---|---|---|---|"]
    ex = t0["exists"]
    for name, t in tabs.items():
        for sg, m in (("P* < 0", t["has"] & (P < 0)), ("P* >= 0", t["has"] & (P >= 0)),
                      ("P* < 0, every pair's toroidal bridge exists at P*",
                       t["has"] & (P < 0) & ex)):
            rel = (t["fb"] - t["f"]) / np.abs(t["f"])
            out.append(f"| {name}, {sg} | {int(m.sum())} | "
                       f"{_fmt(np.percentile(rel[m], [10, 50, 90]), '{:+.3f}')} | "
                       f"{_fmt(np.percentile(t['gerr'][m], [50, 90, 100]))} |")
    out += ["", "Smoothness: the error of predicting a node's f_ij from its two neighbours "
            "along one axis (linear; in log v along v), median / p90, relative to the "
            "node's max_ij |f_ij| (in brackets, raw and continuous model: relative to "
            "|f_ij|, as `bench_pressure_base.py`), for the raw f_ij and for the residual "
            "f_ij - f_base of each model; node-pairs whose three nodes have a result "
            "(suction: whose three nodes are in suction; bridges exist: and every pair of "
            "each of them has a toroidal bridge at its P*, where the models' caps agree).  "
            "Grid: gaps 0 / 0.1 / 0.2, theta 0-80 step 20, v 0.7-2 (6 values).  Bold: a "
            "residual smoother than the raw f_ij in both median and p90.", "",
            "| axis | nodes | pairs | raw f_ij | " + " | ".join(
                f"residual, {v}" for v in VARIANTS) + " |",
            "|---|---|---|---|" + "---|" * len(VARIANTS)]
    smooth = {}
    for sub, mask in (("all", np.ones_like(has)), ("suction", P < 0),
                      ("P* >= 0", P >= 0), ("suction, bridges exist", (P < 0) & ex)):
        sm = {name: smoothness_subset(t, mask) for name, t in tabs.items()}
        smooth[sub] = sm
        for ax in GAPS + ("theta", "v"):
            s0 = sm[NEW][ax]
            if s0["n"] == 0:
                out.append(f"| {ax} | {sub} | 0 | - |" + " - |" * len(VARIANTS))
                continue
            cells = []
            for v in VARIANTS:
                x = sm[v][ax]
                c = _fmt(x["res_node"])
                if x["res_node"][0] < x["raw_node"][0] and x["res_node"][1] < x["raw_node"][1]:
                    c = f"**{c}**"
                if v == NEW:
                    c += f" ({_fmt(x['res_pair'])})"
                cells.append(c)
            out.append(f"| {ax} | {sub} | {s0['n']} | {_fmt(s0['raw_node'])} "
                       f"({_fmt(s0['raw_pair'])}) | " + " | ".join(cells) + " |")
    # 3. pressure from the volume
    old = json.loads((HERE / "evolver_out" / "wetted_region.json").read_text())
    sets = {"choosing set (`wetted_region.json`)": old, "held-out set": l2}
    out += ["", "3. The pressure from the volume: P* solved from the body's volume with "
            "`pressure_from_volume` (the model's `body_volume`, unchanged: its bridges are "
            "those of the old caps rule, Monte Carlo with "
            f"{a.samples:.0e} samples, fixed seed; suction bracket -60 to -0.02), bodies "
            "whose Evolver P* < 0; P* error (P_model - P_Evolver) / |P_Evolver| (negative: "
            "too much suction); force error per grain of the continuous model with the "
            "model's P* and with Evolver's (median / max).  Variants: the window balls' radius kappa / |P*| in "
            "the regions and in the volume (kappa = 2: spherical windows, the default).  "
            "No P*: the body's volume is outside the model's volumes over the bracket; last "
            "column: bodies whose Evolver P* >= 0 to which the model gives a suction P*.", "",
            "| set | variant | bodies | no P* | P* error (p10 / median / p90) | force, "
            "model's P* | force, Evolver's P* | P* >= 0 given suction |",
            "|---|---|---|---|---|---|---|---|"]
    pres = {}
    for sname, cs in sets.items():
        pr = pressure_rows(cs, n_samples=a.samples)
        pres[sname] = pr
        for vname in VOLUME_VARIANTS:
            sel = [r for r in pr if r["variant"] == vname and r["P"] < 0]
            ok = [r for r in sel if r["err_model_P"] is not None]
            pe = [(r["Pm"] - r["P"]) / abs(r["P"]) for r in ok]
            em = [e for r in ok for e in r["err_model_P"]]
            et = [e for r in sel for e in r["err_true_P"]]
            pos = [r for r in pr if r["variant"] == vname and r["P"] >= 0]
            out.append(f"| {sname} | {vname} | {len(sel)} | {len(sel) - len(ok)} | "
                       f"{_fmt(_q(pe, (10, 50, 90)), '{:+.3f}')} | {_fmt(_q(em))} | "
                       f"{_fmt(_q(et))} | "
                       f"{sum(np.isfinite(r['Pm']) for r in pos)} of {len(pos)} |")
    chosen = heldout_rows({k: c for k, c in old.items() if k.endswith(f"L{MAX_REFINE}")},
                          {v: VARIANTS[v] for v in (NEW, OLD)})
    out += ["", verdict(rows, tabs, smooth, pres, chosen, mags, angs, l3num), ""]
    return "\n".join(out)


def verdict(rows, tabs, smooth, pres, chosen, mags, angs, l3num):
    def q(v, neg, src=rows):
        return _q([r["err"] for r in src if r["variant"] == v and (r["P"] < 0) == neg])
    hn, ho = q(NEW, True), q(OLD, True)
    hpn, hpo = q(NEW, False), q(OLD, False)
    cn, co = q(NEW, True, chosen), q(OLD, True, chosen)
    cpn, cpo = q(NEW, False, chosen), q(OLD, False, chosen)
    t0, t1 = tabs[NEW], tabs[OLD]
    P, has = t0["P"], t0["has"]

    def g(t, m):
        return np.percentile(t["gerr"][m], [50, 100])
    gn, go = g(t0, has & (P < 0)), g(t1, has & (P < 0))
    gpn, gpo = g(t0, has & (P >= 0)), g(t1, has & (P >= 0))
    axes = GAPS + ("theta", "v")

    def smoother(sm):
        return [ax for ax in axes if sm[ax]["n"] and sm[ax]["res_node"][0] < sm[ax]["raw_node"][0]
                and sm[ax]["res_node"][1] < sm[ax]["raw_node"][1]]

    def ratios(sm):
        return ", ".join(f"{ax} {sm[ax]['res_node'][0] / sm[ax]['raw_node'][0]:.1f}x"
                         for ax in axes if sm[ax]["n"])

    parts = []
    for sub in ("all", "suction", "P* >= 0"):
        sn, so = smooth[sub][NEW], smooth[sub][OLD]
        parts.append(f"{sub}: continuous model smoother along "
                     f"{', '.join(smoother(sn)) or 'no axis'} of {len([a for a in axes if sn[a]['n']])} "
                     f"(residual / raw median: {ratios(sn)}), old model along "
                     f"{', '.join(smoother(so)) or 'no axis'} ({ratios(so)})")
    every = all(set(smoother(smooth[sub][NEW])) == {a for a in axes if smooth[sub][NEW][a]["n"]}
                for sub in ("all", "suction", "P* >= 0"))
    g90 = {v: np.percentile(tabs[v]["gerr"][has & (P >= 0)], 90) for v in (NEW, OLD)}
    ho_ = [r for r in pres["held-out set"] if r["P"] < 0 and r["variant"] == list(VOLUME_VARIANTS)[0]]
    pe = _q([(r["Pm"] - r["P"]) / abs(r["P"]) for r in ho_ if r["err_model_P"] is not None])
    em = _q([e for r in ho_ if r["err_model_P"] is not None for e in r["err_model_P"]])
    return (
        "Verdict.  (1) Continuity: the continuous model's caps follow the toroidal bridge "
        "to its fold and shrink beyond it (no switch where the bridge stops existing; "
        "`tests/test_wetted_region.py` bounds the force step per 0.005 of gap across that "
        "limit by 3.5 % of the largest force, against > 6 % for no cap and > 30 % for the "
        "old caps at theta = 60), and its pore pieces are continuous through P* = 0 (jump "
        "< 0.1 % between P* = -1e-4 and +1e-4, against > 10 % with the old hulls).  What "
        "is left: the stable toroidal branch itself rises like the square root of "
        "P* - P_fold just inside the fold (continuous, not smooth), and where the fold is "
        "at P* > 0 the caps jump there.  (2) Accuracy, per grain relative to the body's "
        "largest force (median / max): held-out bodies in suction "
        f"{100 * hn[0]:.1f} / {100 * hn[1]:.1f} % (old {100 * ho[0]:.1f} / "
        f"{100 * ho[1]:.1f} %), at P* >= 0 {100 * hpn[0]:.1f} / {100 * hpn[1]:.1f} % (old "
        f"{100 * hpo[0]:.1f} / {100 * hpo[1]:.1f} %); choosing set in suction "
        f"{100 * cn[0]:.1f} / {100 * cn[1]:.1f} % (old {100 * co[0]:.1f} / {100 * co[1]:.1f} %), "
        f"at P* >= 0 {100 * cpn[0]:.1f} / {100 * cpn[1]:.1f} % (old {100 * cpo[0]:.1f} / "
        f"{100 * cpo[1]:.1f} %); the table's nodes in suction {100 * gn[0]:.1f} / "
        f"{100 * gn[1]:.0f} % (old {100 * go[0]:.1f} / {100 * go[1]:.0f} %), at P* >= 0 "
        f"{100 * gpn[0]:.0f} / {100 * gpn[1]:.0f} % (old {100 * gpo[0]:.0f} / "
        f"{100 * gpo[1]:.0f} %).  In suction the continuous caps change the table's "
        "nodes (where gaps of 0.1-0.2 lose their bridge) and not the held-out bodies; at "
        "P* >= 0 the flat windows improve the medians but not the tails (held-out max "
        f"{100 * hpo[1]:.1f} -> {100 * hpn[1]:.1f} %, the table's p90 {g90[OLD]:.2f} -> "
        f"{g90[NEW]:.2f} of the node's largest force, nodes whose forces nearly cancel).  "
        "(3) Is the residual f_ij - f_base smoother than the raw "
        f"f_ij along every axis?  {'Yes' if every else 'No'}.  " + "; ".join(parts)
        + ".  (4) P* from the model's volume (spherical windows, `body_volume` unchanged), "
        f"held out in suction: P* off by a median {100 * pe[0]:+.0f} %, the continuous "
        f"model's forces from it {100 * em[0]:.1f} / {100 * em[1]:.1f} % (median / max).  "
        "Next: the gaps.  The raw f_ij are nearly linear across the table's three gaps "
        "(0 / 0.1 / 0.2), the base is not, and no node-pair along a gap keeps all its "
        "bridges in suction; evaluate f_base between the grid's gaps, caps and pore pieces "
        "apart, to find what bends (the square-root onset inside the fold, the contact "
        "pair's caps); then a convex window (liquid spheres of radius 2/P*) for P* > 0 in "
        "place of the flat limit, continuous at 0.")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--collect", action="store_true")
    ap.add_argument("--budget", type=float, default=1200.0, help="Evolver CPU s cap")
    ap.add_argument("--level3", action="append", default=[],
                    help="with --collect: also solve this body (its level-2 key) at level 3")
    ap.add_argument("--table", default=str(ROOT / "data" / "triplet_table.nc"))
    ap.add_argument("--samples", type=int, default=N_SAMPLES,
                    help="Monte Carlo samples of body_volume in (3)")
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    if a.collect:
        collect(a.budget, a.level3)
        return 0
    from results_file import report
    report(SECTION, section(a), a.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
