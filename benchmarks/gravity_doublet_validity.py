"""Doublet with gravity in any direction: the surrogate's representation against Surface Evolver.

    nice -n 10 .venv/bin/python benchmarks/gravity_doublet_validity.py [--max-refine 3]
        [--check-refine 4] [--analyse-only]

Writes ``benchmarks/gravity_doublet_validity.json``, checkpointed after every Evolver run
(a rerun with the same settings resumes; other settings are refused).

Representation under test (:func:`capbridge.physics.gravity.doublet_gravity_forces`),
per doublet, n the unit vector from grain 1 to grain 2, b = Bo g_hat (g_hat: the direction
along which gravity pulls), b_n = b . n, b_perp = b - b_n n, W = V*/(2 pi), forces in
F* = F / (2 pi gamma r) units (the force of the liquid on each grain):

    F1(b) = F0 n + W [w b_n n + u b_perp] + c b_n^2 n / 2
    F2(b) = -F0 n - c b_n^2 n / 2 + W [(1 - w) b_n n + (1 - u) b_perp]

F0: exact zero-gravity attraction (:func:`capbridge.solvers.young_laplace.solve_doublet`);
w (first-order share of the weight on grain 1, gravity along the axis) and c (second
derivative of the attraction in b_n) from the exact axisymmetric solver with gravity
(:func:`capbridge.solvers.young_laplace_gravity.solve_doublet_gravity`) by central
differences at b_n = +-h, h = 0.5:

    w = [F1(+h) - F1(-h)] / (2 h W)          (w = 1/2 exactly for equal grains and angles)
    c = [F(+h) + F(-h) - 2 F(0)] / h^2       (F the mean of the two axial forces)

and u (share of the transverse weight on grain 1) the lever rule 1 - x_c/D of the Bo = 0
bridge (:func:`capbridge.physics.gravity.transverse_weight_share`; runs analysed before
it entered the model had u = 1/2).

Reference: direct Surface Evolver minimisations with gravity
(:func:`capbridge.solvers.evolver.minimise_bridge`, topology "doublet", virtual-work
forces Richardson-extrapolated over levels 1..L with ``min_refine = max_refine = L`` so
every run of a state ends on the same level).  Evolver's discretisation error is removed
by comparing gravity *effects*:

    dF_ev,i = F_ev,i(b) - F_ev,i(0),     dF_mod,i = F_mod,i(b) - F_mod,i(0)

(same settings, same level), and per case

    err_F0 = max_i |dF_ev,i - dF_mod,i| / |F0|      (the force error the model makes)
    err_dF = max_i |dF_ev,i - dF_mod,i| / max_i |dF_ev,i|   (error of the correction)

for the full model and for the first-order model (c = 0).  Also recorded: the axial
component of dF_ev with gravity across the axis (the model has none: second-order change
of the attraction), the transverse share of grain 1 (model u), the sum rule
F1 + F2 = W b of Evolver, and for gravity along the axis the exact axisymmetric gravity
effect (separates the model's truncation from Evolver's error in the effect).
Level check: the gravity effect at levels L and ``--check-refine`` for CHECK_CASES.
Exact scan: with gravity along the axis the exact axial solver is the reference itself;
the model's error against it on Bo = 0.1, 0.2, ..., 2.5 (w and c are fitted at b_n = +-0.5,
so the model is exact there by construction: Bo = 0.5 along is no test of it).

Gravity directions (grain 1 at the origin, grain 2 on +x): along (-1, 0, 0) (grain 1
below) and for unequal grains also (+1, 0, 0); across (0, 0, -1); oblique at 45 deg,
(-1, 0, -1)/sqrt 2 and for unequal grains also (+1, 0, -1)/sqrt 2.

References
----------
Brakke, K. A. (1992), The Surface Evolver, Experimental Mathematics 1(2):141-165.
Miot et al. (2021), Granular Matter 23:66 (liquid bridges with gravity, Bo = 2.14).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys
import time

import numpy as np

from capbridge.solvers.young_laplace import rupture_distance, solve_doublet
from capbridge.solvers.young_laplace_gravity import solve_doublet_gravity
from capbridge.dimensionless import centre_distance
from capbridge.physics.gravity import (doublet_gravity_forces, liquid_weight,
                                         transverse_weight_share)

OUT = pathlib.Path(__file__).with_name("gravity_doublet_validity.json")
BONDS = [0.05, 0.5, 2.14, 2.5]
H_FD = 0.5          # step in b_n of the central differences giving w and c
#: name -> (d* or None for 0.8 x the zero-gravity rupture gap, V*, theta [deg], ratio)
STATES = {
    "r1": (0.1, 0.05, 30.0, 1.0),
    "r1_near_rupture": (None, 0.1, 60.0, 1.0),
    "r2": (0.1, 0.05, 20.0, 2.0),
    "r1_small_volume": (0.05, 0.005, 30.0, 1.0),
}
NEAR_RUPTURE_FRACTION = 0.8
S2 = 1.0 / np.sqrt(2.0)
#: name -> (direction class, g_hat); "_up" senses only for unequal grains
DIRECTIONS = {
    "along": ("along", (-1.0, 0.0, 0.0)),
    "along_up": ("along", (1.0, 0.0, 0.0)),
    "across": ("across", (0.0, 0.0, -1.0)),
    "oblique": ("oblique", (-S2, 0.0, -S2)),
    "oblique_up": ("oblique", (S2, 0.0, -S2)),
}
#: level check (state, direction, Bo), rerun at ``--check-refine``: the largest errors
#: (near rupture: the near-rupture state converges with gravity across and oblique only
#: up to Bo = 0.5, see EXTRA), the transverse share of unequal grains, and the
#: Evolver error of the transverse share for equal grains
CHECK_CASES = [("r1_near_rupture", "along", 2.14), ("r1_near_rupture", "across", 0.5),
               ("r1_near_rupture", "oblique", 0.5), ("r2", "across", 2.14),
               ("r2", "oblique", 2.14), ("r1", "across", 0.05), ("r1", "oblique", 2.14),
               ("r1_small_volume", "across", 0.05), ("r1_small_volume", "across", 2.5)]
#: Bo grid of the exact scan (model against the exact axial solver, gravity along)
SCAN_BONDS = np.round(np.arange(0.1, 2.51, 0.1), 2)
#: extra Bo where the Evolver bridge of a state pinched off at Bo = 2.14 (brackets it)
EXTRA = {"r1_near_rupture": [("across", 1.0), ("across", 1.5), ("oblique", 1.0),
                             ("oblique", 1.5)]}
N_AXIS = np.array([1.0, 0.0, 0.0])
TABLE_ACCURACY = 1e-3


def directions_for(ratio):
    return [k for k in DIRECTIONS if ratio != 1.0 or not k.endswith("_up")]


def state_geometry(name):
    d, V, th, ratio = STATES[name]
    if d is None:
        d = NEAR_RUPTURE_FRACTION * float(rupture_distance(V, th, ratio)["gap"])
    return float(d), V, th, ratio


def model_parameters(d, V, th, ratio):
    """F0, w and c of the representation (see the module docstring)."""
    F0 = float(solve_doublet(d, V, th, ratio)["force"])
    W = float(liquid_weight(V))
    gp = solve_doublet_gravity(d, V, th, H_FD, ratio, gravity_axis=1.0)    # b_n = +h
    gm = solve_doublet_gravity(d, V, th, H_FD, ratio, gravity_axis=-1.0)   # b_n = -h
    w_fd = float(gp["force1"] - gm["force1"]) / (2 * H_FD * W)
    c = float(gp["force"] + gm["force"] - 2 * F0) / H_FD**2
    return {"F0": F0, "W": W, "w_finite_difference": w_fd,
            "w": 0.5 if ratio == 1.0 else w_fd, "c": c,
            "u": transverse_share(d, V, th, ratio),
            "status_fd": [int(gp["status"]), int(gm["status"])]}


def transverse_share(d, V, th, ratio):
    """u of the representation: the lever rule 1 - x_c/D of the Bo = 0 bridge."""
    r = solve_doublet_gravity(d, V, th, 0.0, ratio)
    return float(transverse_weight_share(r["moment"], r["volume"], centre_distance(d, ratio)))


def exact_axial(d, V, th, ratio, bond, g_axis):
    r = solve_doublet_gravity(d, V, th, bond, ratio, gravity_axis=g_axis)
    return {"status": int(r["status"]), "force1": float(r["force1"]),
            "force2": float(r["force2"])}


def evolver(d, V, th, ratio, bond, g_hat, level):
    """Forces on both grains (F* vectors) by minimise_bridge, ending on ``level``."""
    from capbridge.solvers.evolver import minimise_bridge

    centres = [[0.0, 0.0, 0.0], [1.0 + ratio + d, 0.0, 0.0]]
    t = time.monotonic()
    res = minimise_bridge(centres, [1.0, ratio], [th, th], V, "doublet", bond=bond,
                          gravity_dir=tuple(g_hat), max_refine=level, min_refine=level,
                          workers=1)
    out = {"status": res.status.name.lower(), "reason": res.reason,
           "refinement": int(res.refinement), "cpu_s": round(float(res.cpu_time), 2),
           "wall_s": round(time.monotonic() - t, 1), "warnings": list(res.warnings)}
    if res.converged:
        out.update(forces=np.asarray(res.forces, float).tolist(),
                   force_error=np.asarray(res.force_error, float).tolist(),
                   force_method=res.force_method,
                   levels={str(r.level): np.asarray(r.forces_vw, float).tolist()
                           for r in res.levels if r.forces_vw is not None
                           and r.bond == bond},
                   error_estimate={k: float(v) for k, v in res.error_estimate.items()
                                   if v is not None})
    return out


def case_key(state, direction, bond, level):
    return f"{state}|{direction if bond > 0 else 'none'}|{bond:g}|L{level}"


def planned_cases(max_refine, check_refine):
    cases = []
    for st in STATES:
        ratio = STATES[st][3]
        cases.append((st, "none", 0.0, max_refine))
        for bo in BONDS:
            for dn in directions_for(ratio):
                cases.append((st, dn, bo, max_refine))
    for st, extra in EXTRA.items():
        cases += [(st, dn, bo, max_refine) for dn, bo in extra]
    if check_refine:
        for st in dict.fromkeys(c[0] for c in CHECK_CASES):
            cases.append((st, "none", 0.0, check_refine))
        cases += [(st, dn, bo, check_refine) for st, dn, bo in CHECK_CASES]
    return cases


def save(result):
    tmp = OUT.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(result, indent=1) + "\n")
    tmp.replace(OUT)


def run_cases(result, cases):
    runs = result["runs"]
    for st, dn, bo, level in cases:
        key = case_key(st, dn, bo, level)
        if key in runs:
            continue
        d, V, th, ratio = state_geometry(st)
        g_hat = DIRECTIONS[dn][1] if bo > 0 else (0.0, 0.0, -1.0)
        ev = evolver(d, V, th, ratio, bo, g_hat, level)
        runs[key] = {"state": st, "direction": dn, "bond": bo, "level": level,
                     "g_hat": list(g_hat), "evolver": ev}
        save(result)
        print(json.dumps({"case": key, "status": ev["status"], "cpu_s": ev["cpu_s"],
                          "wall_s": ev["wall_s"]}), flush=True)


def _effect(runs, st, dn, bo, level, which=None):
    """dF_ev (2, 3) of a case and its Bo = 0 reference at the same level, or None."""
    a = runs.get(case_key(st, dn, bo, level), {}).get("evolver", {})
    r0 = runs.get(case_key(st, "none", 0.0, level), {}).get("evolver", {})
    if which is None:
        if "forces" not in a or "forces" not in r0:
            return None
        return np.array(a["forces"]) - np.array(r0["forces"])
    if which not in a.get("levels", {}) or which not in r0.get("levels", {}):
        return None
    return np.array(a["levels"][which]) - np.array(r0["levels"][which])


def analyse(result):
    runs, params = result["runs"], result["model"]
    L = result["settings"]["max_refine"]
    rows = []
    for st in STATES:
        d, V, th, ratio = state_geometry(st)
        p = params[st]
        if "u" not in p:                # runs stored before the lever rule was in the model
            p["u"] = transverse_share(d, V, th, ratio)
        F0, W = p["F0"], p["W"]
        todo = [(bo, dn) for bo in BONDS for dn in directions_for(ratio)]
        todo += [(bo, dn) for dn, bo in EXTRA.get(st, [])]
        for bo, dn in todo:
            cls, g_hat = DIRECTIONS[dn]
            run = runs.get(case_key(st, dn, bo, L))
            if run is None:
                continue
            row = {"state": st, "direction": dn, "class": cls, "bond": bo,
                   "evolver_status": run["evolver"]["status"]}
            dF = _effect(runs, st, dn, bo, L)
            if dF is None:
                rows.append(row)
                continue
            b = bo * np.asarray(g_hat)
            bn = float(b @ N_AXIS)
            b_perp = b - bn * N_AXIS
            mods = {}
            for label, c in (("full", p["c"]), ("first_order", 0.0)):
                F1, F2 = doublet_gravity_forces(F0, N_AXIS, V, b, p["w"], c, p["u"])
                dM = np.array([F1 - F0 * N_AXIS, F2 + F0 * N_AXIS])
                dev = np.linalg.norm(dF - dM, axis=1)
                mods[label] = {
                    "dF_model": dM.tolist(),
                    "abs_error": dev.tolist(),
                    "err_F0": float(dev.max() / abs(F0)),
                    "err_dF": float(dev.max() / np.linalg.norm(dF, axis=1).max())}
            row.update(dF_evolver=dF.tolist(), model=mods,
                       dF_abs=np.linalg.norm(dF, axis=1).tolist(),
                       dF_over_F0=float(np.linalg.norm(dF, axis=1).max() / abs(F0)),
                       sum_rule_residual=float(np.linalg.norm(dF.sum(0) - W * b)),
                       sum_rule_rel=float(np.linalg.norm(dF.sum(0) - W * b)
                                          / np.linalg.norm(W * b)),
                       force_error_estimate=float(np.max(
                           run["evolver"]["force_error"])))
            # change of the attraction (axial, attraction > 0): grain 1 along +n,
            # grain 2 along -n; minus the weight's axial share for the along parts
            att1 = float(dF[0] @ N_AXIS) - W * p["w"] * bn
            att2 = -float(dF[1] @ N_AXIS) + W * (1 - p["w"]) * bn
            row["attraction_change"] = {"grain1": att1, "grain2": att2,
                                        "over_F0": max(abs(att1), abs(att2)) / abs(F0),
                                        "model": 0.5 * p["c"] * bn**2}
            if np.linalg.norm(b_perp) > 0:
                u = b_perp / np.linalg.norm(b_perp)
                row["transverse_share1"] = float(dF[0] @ u) / (W * np.linalg.norm(b_perp))
                row["transverse_share2"] = float(dF[1] @ u) / (W * np.linalg.norm(b_perp))
            if cls == "along":
                ex = result["exact_axial"].get(f"{st}|{dn}|{bo:g}")
                if ex and ex["status"] == 0:
                    ex0 = p["F0"]
                    dE = np.array([[ex["force1"] - ex0, 0, 0], [-(ex["force2"] - ex0), 0, 0]])
                    row["exact_axial_effect"] = dE.tolist()
                    row["evolver_vs_exact_over_F0"] = float(
                        np.linalg.norm(dF - dE, axis=1).max() / abs(F0))
                    F1, F2 = doublet_gravity_forces(F0, N_AXIS, V, b, p["w"], p["c"], p["u"])
                    dM = np.array([F1 - F0 * N_AXIS, F2 + F0 * N_AXIS])
                    row["model_vs_exact_over_F0"] = float(
                        np.linalg.norm(dM - dE, axis=1).max() / abs(F0))
            rows.append(row)
    summary = {}
    all_bonds = sorted(set(BONDS) | {bo for ex in EXTRA.values() for _, bo in ex})
    for cls in ("along", "across", "oblique"):
        for bo in all_bonds:
            sel = [r for r in rows if r["class"] == cls and r["bond"] == bo and "model" in r]
            if not sel:
                continue
            ent = {"n": len(sel),
                   "failed": [f"{r['state']}|{r['direction']}" for r in rows
                              if r["class"] == cls and r["bond"] == bo and "model" not in r]}
            for m in ("full", "first_order"):
                for e in ("err_F0", "err_dF"):
                    v = np.array([r["model"][m][e] for r in sel])
                    ent[f"{m}_{e}_median"] = float(np.median(v))
                    ent[f"{m}_{e}_max"] = float(v.max())
                    ent[f"{m}_{e}_max_at"] = sel[int(v.argmax())]["state"]
            ent["dF_over_F0_max"] = float(max(r["dF_over_F0"] for r in sel))
            summary[f"{cls}|{bo:g}"] = ent
    # per state and direction class: largest measured Bo with err_F0 <= TABLE_ACCURACY
    # at it and at every smaller measured Bo
    valid = {}
    for st in STATES:
        for cls in ("along", "across", "oblique"):
            best = 0.0
            for bo in all_bonds:
                sel = [r for r in rows if r["state"] == st and r["class"] == cls
                       and r["bond"] == bo]
                if not sel:
                    continue
                if any("model" not in r or r["model"]["full"]["err_F0"] > TABLE_ACCURACY
                       for r in sel):
                    break
                best = bo
            valid[f"{st}|{cls}"] = best
    result["cases"] = rows
    result["summary"] = summary
    result["valid_up_to_bond"] = valid
    result["level_check"] = level_check(result)


def level_check(result):
    """Gravity effect at two levels (and per raw level of the finer run)."""
    runs = result["runs"]
    L, L2 = result["settings"]["max_refine"], result["settings"]["check_refine"]
    if not L2:
        return None
    out = []
    for st, dn, bo in CHECK_CASES:
        F0 = result["model"][st]["F0"]
        a, b = _effect(runs, st, dn, bo, L), _effect(runs, st, dn, bo, L2)
        if a is None or b is None:
            continue
        row = {"state": st, "direction": dn, "bond": bo,
               f"dF_L{L}": a.tolist(), f"dF_L{L2}": b.tolist(),
               "change_over_F0": float(np.linalg.norm(a - b, axis=1).max() / abs(F0)),
               "axial_change_over_F0": float(np.abs((a - b) @ N_AXIS).max() / abs(F0)),
               "transverse_change_over_F0": float(np.linalg.norm(
                   (a - b) - np.outer((a - b) @ N_AXIS, N_AXIS), axis=1).max() / abs(F0)),
               "dF_over_F0": float(np.linalg.norm(a, axis=1).max() / abs(F0))}
        # raw (not extrapolated) virtual-work levels of the finer run
        raw = {}
        for lev in map(str, range(1, L2 + 1)):
            e = _effect(runs, st, dn, bo, L2, which=lev)
            if e is not None:
                raw[lev] = float(np.linalg.norm(e - b, axis=1).max() / abs(F0))
        row["raw_level_minus_extrapolated_over_F0"] = raw
        p = result["model"][st]
        bvec = bo * np.asarray(DIRECTIONS[dn][1])
        bn = float(bvec @ N_AXIS)
        bp = bvec - bn * N_AXIS
        for lev, e in ((L, a), (L2, b)):
            row[f"sum_rule_residual_L{lev}"] = float(np.linalg.norm(
                e.sum(0) - p["W"] * bvec))
            row[f"attraction_change_over_F0_L{lev}"] = max(
                abs(float(e[0] @ N_AXIS) - p["W"] * p["w"] * bn),
                abs(-float(e[1] @ N_AXIS) + p["W"] * (1 - p["w"]) * bn)) / abs(F0)
            if np.linalg.norm(bp) > 0:
                u = bp / np.linalg.norm(bp)
                row[f"transverse_share1_L{lev}"] = float(e[0] @ u) / (
                    p["W"] * np.linalg.norm(bp))
        ex = result["exact_axial"].get(f"{st}|{dn}|{bo:g}")
        if ex and ex["status"] == 0:
            F0x = result["model"][st]["F0"]
            dE = np.array([[ex["force1"] - F0x, 0, 0], [-(ex["force2"] - F0x), 0, 0]])
            row[f"evolver_vs_exact_over_F0_L{L}"] = float(
                np.linalg.norm(a - dE, axis=1).max() / abs(F0))
            row[f"evolver_vs_exact_over_F0_L{L2}"] = float(
                np.linalg.norm(b - dE, axis=1).max() / abs(F0))
        # the model error at this case, for comparison
        for r in result.get("cases", []):
            if r["state"] == st and r["direction"] == dn and r["bond"] == bo \
                    and "model" in r:
                row["model_err_F0_full"] = r["model"]["full"]["err_F0"]
                row["model_err_F0_first_order"] = r["model"]["first_order"]["err_F0"]
        out.append(row)
    return {"levels": [L, L2], "rows": out}


def table(result):
    L = ["| direction | Bo | n | full: median / max err/F0 | first order: median / max "
         "err/F0 | full: median / max err/dF | max dF/F0 |", "|---|---|---|---|---|---|---|"]
    for k, e in result["summary"].items():
        cls, bo = k.split("|")
        L.append(f"| {cls} | {bo} | {e['n']} | {e['full_err_F0_median']:.2g} / "
                 f"{e['full_err_F0_max']:.2g} | {e['first_order_err_F0_median']:.2g} / "
                 f"{e['first_order_err_F0_max']:.2g} | {e['full_err_dF_median']:.2g} / "
                 f"{e['full_err_dF_max']:.2g} | {e['dF_over_F0_max']:.2g} |")
    return "\n".join(L)


def exact_scan(result):
    """Model against the exact axial solver on a fine Bo grid, gravity along the axis:
    err/F0 of the full and the first-order model, and the first Bo of the grid where
    each exceeds TABLE_ACCURACY (None: not within the grid)."""
    out = {}
    for st in STATES:
        d, V, th, ratio = state_geometry(st)
        p = result["model"][st]
        for dn in directions_for(ratio):
            if DIRECTIONS[dn][0] != "along":
                continue
            ga = DIRECTIONS[dn][1][0]
            r = solve_doublet_gravity(d, V, th, SCAN_BONDS, ratio, gravity_axis=ga)
            ent = {"bonds": SCAN_BONDS.tolist(), "status": r["status"].astype(int).tolist()}
            for label, c in (("full", p["c"]), ("first_order", 0.0)):
                err = []
                for i, bo in enumerate(SCAN_BONDS):
                    if r["status"][i] != 0:
                        err.append(None)
                        continue
                    bn = bo * ga
                    m1 = p["F0"] + p["W"] * p["w"] * bn + 0.5 * c * bn**2
                    m2 = p["F0"] + 0.5 * c * bn**2 - p["W"] * (1 - p["w"]) * bn
                    err.append(max(abs(m1 - float(r["force1"][i])),
                                   abs(m2 - float(r["force2"][i]))) / abs(p["F0"]))
                ent[f"err_F0_{label}"] = err
                over = [bo for bo, e in zip(SCAN_BONDS, err) if e is None or e > TABLE_ACCURACY]
                ent[f"first_bond_above_{label}"] = float(over[0]) if over else None
            out[f"{st}|{dn}"] = ent
    return out


def case_table(result):
    """One line per case: errors of the full and first-order model, dF, extras."""
    L = ["| state | gravity | Bo | dF/F0 | err/F0 full | err/F0 1st order | err/dF full | "
         "attraction change/F0 (Evolver; model) | transverse share 1 | Evolver-exact/F0 |",
         "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["cases"]:
        if "model" not in r:
            L.append(f"| {r['state']} | {r['direction']} | {r['bond']:g} | Evolver: "
                     f"{r['evolver_status']} | | | | | | |")
            continue
        m, F0 = r["model"], result["model"][r["state"]]["F0"]
        a = r["attraction_change"]
        ts = r.get("transverse_share1")
        ev = r.get("evolver_vs_exact_over_F0")
        L.append(f"| {r['state']} | {r['direction']} | {r['bond']:g} | {r['dF_over_F0']:.2g} | "
                 f"{m['full']['err_F0']:.2g} | {m['first_order']['err_F0']:.2g} | "
                 f"{m['full']['err_dF']:.2g} | {a['over_F0']:.2g}; "
                 f"{abs(a['model']) / abs(F0):.2g} | "
                 f"{'' if ts is None else f'{ts:.4f}'} | {'' if ev is None else f'{ev:.2g}'} |")
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-refine", type=int, default=3)
    ap.add_argument("--check-refine", type=int, default=4,
                    help="finer level of the level check (0: none)")
    ap.add_argument("--analyse-only", action="store_true",
                    help="recompute the analysis from the stored runs")
    args = ap.parse_args(argv)
    settings = {"max_refine": args.max_refine, "min_refine": args.max_refine,
                "check_refine": args.check_refine,
                "bonds": BONDS, "extra": EXTRA, "check_cases": CHECK_CASES,
                "fd_step_bn": H_FD, "workers": 1,
                "force_method": "virtual work, Richardson-extrapolated over levels 1..L",
                "states": {k: dict(zip(("gap", "volume", "theta", "ratio"),
                                       state_geometry(k))) for k in STATES},
                "directions": {k: v[1] for k, v in DIRECTIONS.items()}}
    if OUT.exists():
        result = json.loads(OUT.read_text())
        # the runs are keyed by state, direction, Bo and level: only the settings that
        # change a run's result must match (extra cases and level checks only add runs)
        fixed = ("max_refine", "min_refine", "bonds", "fd_step_bn", "workers", "states",
                 "directions")
        new = json.loads(json.dumps(settings))
        if any(result["settings"].get(k) != new[k] for k in fixed):
            sys.exit(f"gravity_doublet_validity: error: {OUT} was made with other settings; "
                     "move it away to start again")
        result["settings"] = new
    else:
        result = {"settings": settings, "runs": {}}
    result["command"] = ("nice -n 10 .venv/bin/python benchmarks/gravity_doublet_validity.py "
                         + " ".join(argv if argv is not None else sys.argv[1:])).strip()
    result["git_commit"] = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True,
                                          text=True, cwd=OUT.parent).stdout.strip()
    result.setdefault("invocations", []).append(
        {"command": result["command"], "git_commit": result["git_commit"],
         "utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())})
    result["conventions"] = (
        "F* = F/(2 pi gamma r) force vectors of the liquid on grain 1 (radius 1, centre at "
        "the origin) and grain 2 (radius ratio, centre (1+ratio+d*, 0, 0)); n = +x; "
        "g_hat the direction gravity pulls; b = Bo g_hat; attraction > 0")
    t = time.monotonic()
    if "model" not in result:
        result["model"] = {st: model_parameters(*state_geometry(st)) for st in STATES}
        ex = {}
        for st in STATES:
            d, V, th, ratio = state_geometry(st)
            for dn in directions_for(ratio):
                if DIRECTIONS[dn][0] != "along":
                    continue
                for bo in BONDS:
                    ex[f"{st}|{dn}|{bo:g}"] = exact_axial(d, V, th, ratio, bo,
                                                          DIRECTIONS[dn][1][0])
        result["exact_axial"] = ex
        save(result)
    if not args.analyse_only:
        run_cases(result, planned_cases(args.max_refine,
                                        args.check_refine))
    analyse(result)
    result["exact_scan"] = exact_scan(result)
    result["evolver_cpu_s_total"] = round(sum(r["evolver"]["cpu_s"]
                                              for r in result["runs"].values()), 1)
    save(result)
    print(table(result))
    print(case_table(result))
    print(json.dumps(result["valid_up_to_bond"], indent=1))
    print(json.dumps(result["level_check"], indent=1))
    print(json.dumps({k: {kk: v[kk] for kk in ("first_bond_above_full",
                                                "first_bond_above_first_order")}
                      for k, v in result["exact_scan"].items()}, indent=1))
    print("wrote", OUT, f"({time.monotonic() - t:.0f} s; Evolver CPU "
          f"{result['evolver_cpu_s_total']} s)")


if __name__ == "__main__":
    main()
