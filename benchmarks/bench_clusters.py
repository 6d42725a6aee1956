"""Surface Evolver clusters of four grains: the reference set of the cluster force model.

    .venv/bin/python benchmarks/bench_clusters.py [--max-refine 3] [--write]
    .venv/bin/python benchmarks/bench_clusters.py --packing [--water 0.05] [--theta 30]
        [--max-refine 2] [--count 12] [--write]

Issue 19 validates a cluster force model against >= 12 Evolver clusters of four grains:
the filled tetrahedron, the rhombus (two triangles sharing an edge), a chain of four
(straight, and bent at right angles) and a square, each at two volumes and two contact
angles (20 clusters), equal unit grains
with surface gaps 0.05.  Each is one liquid body wetting the four grains
(:func:`capbridge.solvers.cluster.solve_cluster`, virtual work, Richardson over the
levels).  Results are kept in ``benchmarks/evolver_out/clusters.json`` (one entry per
cluster, keyed by its name and settings; a rerun computes only the missing ones) and
summarised as a table: status, |F_i| (max), the sum of the forces (must vanish), the
force error estimate, P*, the pair decomposition (determined or not), CPU seconds.
``--write`` puts the table in ``benchmarks/RESULTS.md``.

``--packing``: clusters cut out of a real packing instead (the 1,000 equal grains of
``bench_triplet_packings.py``, wetted at ``--water`` and ``--theta`` by the engine with
triplet forces on, 100 steps; the detector's clusters of 4 and 5 grains, each one liquid
body of its bridges' volume).  Contacts of the DEM overlap a little; the centres are
pushed apart along the centre lines to gap 0 (a few 1e-4 r at most, reported) before the
solve.  Beside Evolver's forces, the forces the engine gives those grains today (the
cluster's doublet bridges, each at its own volume): their error against Evolver is what
clusters of four grains and more are about (issue 19).  Clusters are kept in
``out/bench_clusters/`` and the results in ``benchmarks/evolver_out/clusters_packing.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import bench_yade as by  # noqa: E402  (packing, engine list, environment)
from capbridge.solvers.cluster import solve_cluster  # noqa: E402
from capbridge.status import status_name  # noqa: E402
from results_file import write_section  # noqa: E402

CACHE = HERE / "evolver_out" / "clusters.json"
SECTION = "### Surface Evolver clusters of four grains"
GAP = 0.05
D = 2.0 + GAP                                     # centre distance of touching-ish grains


def shapes():
    """Centres (4, 3) of the four configurations (unit radii, gaps GAP)."""
    h = D * np.sqrt(3) / 2
    return {
        "tetrahedron": np.array([[0, 0, 0], [D, 0, 0], [D / 2, h, 0],
                                 [D / 2, h / 3, D * np.sqrt(2 / 3)]]),
        "rhombus": np.array([[0, 0, 0], [D, 0, 0], [D / 2, h, 0], [D / 2, -h, 0]]),
        "chain": np.array([[0, 0, 0], [D, 0, 0], [2 * D, 0, 0], [3 * D, 0, 0]]),
        "bent chain": np.array([[0, 0, 0], [D, 0, 0], [D, D, 0], [2 * D, D, 0]]),
        "square": np.array([[0, 0, 0], [D, 0, 0], [D, D, 0], [0, D, 0]]),
    }


#: liquid volumes V* per configuration: a body that wets all four grains (the chain's
#: is long, the tetrahedron's pore is small)
VOLUMES = {"tetrahedron": (0.4, 0.8), "rhombus": (0.5, 1.0), "chain": (0.8, 1.6),
           "bent chain": (0.8, 1.6), "square": (0.6, 1.2)}
THETAS = (0.0, 30.0)

#: grains that the configuration's symmetries map onto each other (equal |F_i|)
SYMMETRIC = {"tetrahedron": [[0, 1, 2, 3]], "rhombus": [[0, 1], [2, 3]],
             "chain": [[0, 3], [1, 2]], "bent chain": [[0, 3], [1, 2]],
             "square": [[0, 1, 2, 3]]}


def run_case(name, centres, V, theta, max_refine):
    t0 = time.process_time()
    r = solve_cluster(centres, 1.0, V, theta, max_refine=max_refine)
    F = np.asarray(r["forces"], float) if r["forces"] is not None else None
    pf = r.get("pairs") or {}
    return {"name": name, "V": V, "theta": theta, "max_refine": max_refine,
            "status": status_name(r["status"]), "reason": r.get("reason", ""),
            "forces": None if F is None else F.tolist(),
            "force_error": None if r.get("force_error") is None
            else np.asarray(r["force_error"], float).tolist(),
            "pressure": r.get("pressure"), "refinement": r.get("refinement"),
            "pairs_determined": bool(pf.get("determined", False)) if isinstance(pf, dict)
            else False,
            "cpu_s": float(r.get("cpu_time") or 0.0) + (time.process_time() - t0)}


def row(c):
    if c["forces"] is None:
        return (f"| {c['name']} | {c['V']:g} | {c['theta']:g} | {c['status']} | - | - | - "
                f"| - | - | - | {c['cpu_s']:.0f} |")
    F = np.asarray(c["forces"])
    err = np.asarray(c["force_error"]) if c["force_error"] is not None else np.full(1, np.nan)
    mag = np.linalg.norm(F, axis=1)
    return (f"| {c['name']} | {c['V']:g} | {c['theta']:g} | {c['status']} | "
            f"{mag.max():.4f} | {mag.min():.4f} | {np.abs(F.sum(0)).max():.1e} | "
            f"{np.nanmax(np.abs(err)):.1e} | {c['pressure']:.3f} | "
            f"{'yes' if c['pairs_determined'] else 'no'} | {c['cpu_s']:.0f} |")


def summary(cases):
    """What the table shows, computed: answered cases, the largest force sum, the
    largest relative spread of |F_i| over symmetric grains, the reasons of the others."""
    done = [c for c in cases if c["forces"] is not None]
    worst_sum = max((np.abs(np.sum(c["forces"], axis=0)).max() for c in done), default=0.0)
    spread = 0.0
    for c in done:
        mag = np.linalg.norm(np.asarray(c["forces"]), axis=1)
        for group in SYMMETRIC[c["name"]]:
            spread = max(spread, np.ptp(mag[group]) / mag[group].max())
    reasons = sorted({f"{c['name']}: {c['reason']}" for c in cases if c["forces"] is None})
    return (f"{len(done)} of {len(cases)} answered.  Every answered cluster's forces sum to "
            f"<= {worst_sum:.1e}; |F_i| of symmetric grains agree to {spread:.1e} "
            "(relative).  Not answered: " + ("; ".join(reasons) if reasons else "none") + ".")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--max-refine", type=int, default=None,
                    help="Evolver refinement levels (default 3; 2 with --packing)")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--packing", action="store_true",
                    help="clusters cut out of a wetted packing (see the docstring)")
    ap.add_argument("--water", type=float, default=0.05)
    ap.add_argument("--theta", type=float, default=30.0)
    ap.add_argument("--count", type=int, default=12, help="clusters of 4 grains")
    a = ap.parse_args(argv)
    if a.packing:
        a.max_refine = a.max_refine or 2
        return packing_main(a)
    a.max_refine = a.max_refine or 3
    cache = json.loads(CACHE.read_text(encoding="utf-8")) if CACHE.exists() else {}
    cases = [(n, c, V, t) for n, c in shapes().items() for V in VOLUMES[n] for t in THETAS]
    for k, (name, centres, V, theta) in enumerate(cases, 1):
        key = f"{name}|V={V:g}|theta={theta:g}|level={a.max_refine}"
        if key not in cache:
            cache[key] = run_case(name, centres, V, theta, a.max_refine)
            CACHE.parent.mkdir(parents=True, exist_ok=True)
            CACHE.write_text(json.dumps(cache, indent=1), encoding="utf-8")
        print(f"[{k}/{len(cases)}] {row(cache[key])}", file=sys.stderr, flush=True)
    rows = [row(cache[f"{n}|V={V:g}|theta={t:g}|level={a.max_refine}"])
            for n, _, V, t in cases]
    text = "\n".join([
        SECTION, "",
        f"Command: `python benchmarks/bench_clusters.py --max-refine {a.max_refine}` "
        f"(`capbridge.solvers.cluster.solve_cluster`, one liquid body on four unit grains, "
        f"surface gaps {GAP:g}; cache `benchmarks/evolver_out/clusters.json`).  |F_i|: "
        "force on a grain, F* = F/(2 pi gamma r); sum: largest component of the sum of the "
        "four forces (zero for an isolated body); error: the largest force error estimate "
        "(Richardson over the levels).", "",
        "| cluster | V* | θ° | status | max \\|F_i\\| | min \\|F_i\\| | \\|sum\\| | error "
        "| P* | pairs determined | CPU s |", "|" + "---|" * 11] + rows
        + ["", summary([cache[f"{n}|V={V:g}|theta={t:g}|level={a.max_refine}"]
                        for n, _, V, t in cases])]) + "\n"
    print(text)
    if a.write:
        write_section(SECTION, text)
    return 0


# --------------------------------------------------------------------------------------
# clusters cut out of a packing
# --------------------------------------------------------------------------------------

PACKING_CACHE = HERE / "evolver_out" / "clusters_packing.json"
PACKING_SECTION = "### Surface Evolver clusters cut out of a packing"


def extract_main(packing, water, theta, steps, out):
    """Inside YADE: the packing wetted by the engine; writes its 4- and 5-grain liquid
    clusters (grains, centres and radii [m], volume [m^3], the bridges' doublet forces
    on the grains [N]) to ``out``."""
    yade, w, utils = by._yade_env()
    from capbridge.dem.coalescence_detect import find_coalescence
    from capbridge.yade.engine import CapbridgeEngine

    O = yade.Omega()
    by.load_packing(O, w, utils, packing)
    cap = CapbridgeEngine(theta=theta, gamma=by.GAMMA, water_content=water,
                          coalescence_every=10, triplet_forces=True, label="clusters")
    O.engines = by.scene_engines(w, [cap.pyrunner()])
    O.dt = 0.5 * utils.PWaveTimeStep()
    O.run(steps, True)
    m, pos = cap.model, cap.positions()
    geom = m.update(pos, form=False)
    rep = find_coalescence(pos, m.bi, m.bj, *m.filling_angles(geom["gap"]), m.vol, m.n)
    found = []
    for c in rep.clusters:
        g = np.unique(np.concatenate([m.bi[c], m.bj[c]]))
        if not 4 <= g.size <= 5:
            continue
        F = np.zeros((g.size, 3))
        for b in c:
            fv = geom["d"][b] * (geom["force"][b] / geom["dist"][b])
            F[g == m.bi[b]] += fv
            F[g == m.bj[b]] -= fv
        found.append({"grains": g.tolist(), "centres": pos[g].tolist(),
                      "radii": m.radii[g].tolist(), "volume": float(m.vol[c].sum()),
                      "doublet_forces": F.tolist(),
                      "bridges": [[int(m.bi[b]), int(m.bj[b])] for b in c]})
    Path(out).write_text(json.dumps({"water": water, "theta": theta, "steps": steps,
                                     "gamma": by.GAMMA, "clusters": found}),
                         encoding="utf-8")


def separate_contacts(C, R, sweeps=200):
    """Centres pushed apart along the centre lines until no pair overlaps (gap >= 0):
    DEM contacts overlap a little, the solver takes touching grains.  Returns the new
    centres and the largest displacement."""
    C0, C = C, C.copy()
    for _ in range(sweeps):
        moved = False
        for i in range(len(C)):
            for j in range(i + 1, len(C)):
                d = C[j] - C[i]
                dist = np.linalg.norm(d)
                over = R[i] + R[j] - dist
                if over > 0:
                    step = 0.5 * (over + 1e-12) * d / dist
                    C[i] -= step
                    C[j] += step
                    moved = True
        if not moved:
            return C, float(np.linalg.norm(C - C0, axis=1).max())
    raise RuntimeError("contacts could not be separated")


def packing_main(a):
    """Extract (once, cached) and solve the packing's clusters; print / write the table."""
    tag = f"mono_w{a.water:g}_t{a.theta:g}"
    found = ROOT_OUT / f"packing_clusters_{tag}.json"
    if not found.exists():
        ROOT_OUT.mkdir(parents=True, exist_ok=True)
        packing = by.CACHE / "mono_packing_1000.npz"
        if not packing.exists():
            sys.path.insert(0, str(HERE))
            import bench_triplet_packings as bp
            packing = bp.packing_path("equal", 1000)
        import subprocess
        subprocess.run([sys.executable, __file__, "--extract", str(packing), str(a.water),
                        str(a.theta), "100", str(found)], check=True, env=by._env())
    data = json.loads(found.read_text(encoding="utf-8"))
    cache = json.loads(PACKING_CACHE.read_text(encoding="utf-8")) \
        if PACKING_CACHE.exists() else {}
    four = [c for c in data["clusters"] if len(c["grains"]) == 4][:a.count]
    five = [c for c in data["clusters"] if len(c["grains"]) == 5][:max(a.count // 3, 1)]
    rows, errs = [], []
    for k, c in enumerate(four + five, 1):
        key = f"{tag}|{'-'.join(map(str, c['grains']))}|level={a.max_refine}"
        R = np.asarray(c["radii"])
        r = float(R.min())
        C, moved = separate_contacts(np.asarray(c["centres"]) / r, R / r)
        if key not in cache:
            t0 = time.process_time()
            res = solve_cluster(C, R / r, c["volume"] / r**3, data["theta"],
                                max_refine=a.max_refine)
            cache[key] = {"status": status_name(res["status"]),
                          "reason": res.get("reason", ""),
                          "forces": None if res["forces"] is None
                          else np.asarray(res["forces"], float).tolist(),
                          "force_error": None if res.get("force_error") is None
                          else np.asarray(res["force_error"], float).tolist(),
                          "pressure": res.get("pressure"),
                          "cpu_s": float(res.get("cpu_time") or 0.0)
                          + (time.process_time() - t0)}
            PACKING_CACHE.write_text(json.dumps(cache, indent=1), encoding="utf-8")
        e = cache[key]
        n, V = len(c["grains"]), c["volume"] / r**3
        fd = np.asarray(c["doublet_forces"]) / (2 * np.pi * data["gamma"] * r)
        if e["forces"] is None:
            rows.append(f"| {n} | {V:.3f} | {moved:.1e} | {e['status']} | - | - | - | - "
                        f"| {e['cpu_s']:.0f} |")
        else:
            F = np.asarray(e["forces"])
            mag = np.linalg.norm(F, axis=1)
            rel = np.linalg.norm(fd - F, axis=1) / mag.max()
            errs.append(rel.max())
            rows.append(f"| {n} | {V:.3f} | {moved:.1e} | {e['status']} | {mag.max():.3f} | "
                        f"{np.nanmax(np.abs(e['force_error'])):.1e} | {e['pressure']:.3f} | "
                        f"{np.median(rel):.2f} / {rel.max():.2f} | {e['cpu_s']:.0f} |")
        print(f"[{k}/{len(four) + len(five)}] {rows[-1]}", file=sys.stderr, flush=True)
    answered = len(errs)
    # why the others have no answer: the driver's failure checks named in their reasons
    why = {}
    for c in four + five:
        e = cache[f"{tag}|{'-'.join(map(str, c['grains']))}|level={a.max_refine}"]
        if e["forces"] is None:
            for word in ("no valid starting body", "fold", "degenerate", "pole", "newton"):
                if word in e["reason"]:
                    why[word] = why.get(word, 0) + 1
    text = "\n".join([
        PACKING_SECTION, "",
        f"Command: `python benchmarks/bench_clusters.py --packing --water {a.water:g} "
        f"--theta {a.theta:g} --max-refine {a.max_refine} --count {a.count}`: the "
        f"1,000 equal grains (r = 1 mm) of the packing benchmark, wetted at {a.water:g} "
        f"water content, theta = {a.theta:g} deg, 100 steps; of its {len(data['clusters'])} "
        "liquid clusters of 4-5 grains, the first ones of each size, each solved as one "
        "body of its bridges' liquid.  moved: largest displacement that separated the DEM "
        "contacts (/ r); |F|: largest force on a grain (F* = F/(2 pi gamma r)); doublets: "
        "the engine's forces today (the cluster's bridges, each at its own volume) against "
        "Evolver, |F_doublets - F_evolver| / max |F_evolver| per grain, median / max.", "",
        "| grains | V* | moved | status | max \|F_i\| | error | P* | doublets off by "
        "| CPU s |", "|" + "---|" * 9] + rows + [
        "", f"{answered} of {len(rows)} answered; over them the doublet forces are off by "
        f"a median {np.median(errs) if errs else float('nan'):.2f} and at most "
        f"{max(errs) if errs else float('nan'):.2f} of the largest force (per cluster, the "
        "worst grain).  The others, by the failure checks named in their reasons (one "
        "cluster may name several): " + (", ".join(f"{k} {v}" for k, v in why.items())
                                         or "none") + "."]) + "\n"
    print(text)
    if a.write:
        write_section(PACKING_SECTION, text)
    return 0


ROOT_OUT = by.ROOT / "out" / "bench_clusters"


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--extract":
        extract_main(sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5]),
                     sys.argv[6])
        sys.exit(0)
    sys.exit(main())
