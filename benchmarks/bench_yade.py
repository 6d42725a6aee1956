"""ms per step of YADE scenes: dry, YADE's native capillary law, capbridge's engine.

    .venv/bin/python benchmarks/bench_yade.py [--sizes 1000 10000] [--rounds 3]

One run times every variant on the same settled packing (generated once, dry, under
gravity, and cached in ``out/bench_yade/``), each in a fresh YADE process (one thread),
in rounds: round k runs every variant once, so all variants share the machine's state;
the figure is the median over the rounds.  Variants:

``dry``          FrictPhys + Cundall-Strack, no liquid.
``law2``         YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` fed with capbridge's
                 exported ``M(r=...)`` files (exact solver, theta = 30 deg), suction
                 chosen so that bridges at contact hold about the volume of the
                 capbridge variants; detection range enlarged to cover rupture
                 (YADE needs interactions beyond contact).
``native``       capbridge's fixed-volume bridges (V* per bridge) through YADE's compiled
                 Law2 (:class:`capbridge.yade.native_volume.NativeVolumeBridges`).
``capbridge``    :class:`capbridge.yade.engine.CapbridgeEngine`, volume-controlled
                 bridges (fixed V* per bridge, same theta), refresh every step.
``capbridge10``  the same, bridges and forces refreshed every 10 steps.
``capeng``       YADE's ``CapillarityEngine`` in volume mode (imposePressure=False) on
                 capbridge's exported Delaunay file: the compiled alternative for
                 volume control (forces only; it forms no new bridge by itself).

Prints a markdown section (command, machine, table); ``--write`` also writes it to
``benchmarks/RESULTS_yade.md``.

``--wet-poly N`` (issue 9's benchmark) is a separate run: N polydisperse grains (radius
1 mm +-30 %, uniform), deposited dry, then one run each of YADE's
``Law2_ScGeom_CapillaryPhys_Capillarity`` (capbridge's theta = 30 deg suction files,
suction giving V* = 0.02 at contact for two mean grains) and of ``CapbridgeEngine`` at a
1 % water content (conserved liquid on films, theta = 30 deg, defaults), on the same
packing; then the cost of a restart (``O.saveTmp`` with the engine's state, ``O.loadTmp``,
the first step, which restores it) and of ``O.save`` to a file.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CACHE = ROOT / "out" / "bench_yade"
THETA = 30.0
GAMMA = 0.073
R_SMALL, R_LARGE = 0.9e-3, 1.125e-3     # bidisperse, 50/50 by number: ratio 1.25
R_MEAN = 0.5 * (R_SMALL + R_LARGE)
VSTAR = 0.02          # volume of a capbridge bridge, V / r_small^3
VARIANTS = ("dry", "law2", "native", "capbridge", "capbridge10", "capeng")


# --------------------------------------------------------------------------------------
# Inside YADE
# --------------------------------------------------------------------------------------

def _yade_env():
    from capbridge.yade import yade_runtime
    yade_runtime.ensure_yade_importable()
    import yade  # noqa: F401
    from yade import wrapper, utils
    return yade, wrapper, utils


def scene_engines(w, extra, ip2=None, law=None, factor=None):
    """The wet packings' engine list: contacts (``ip2``/``law``, default frictional
    Cundall-Strack; ``factor``: the Aabb enlargement and interaction detection factor
    for Law2's capillary reach), the ``extra`` engines (capbridge's PyRunner), then
    NewtonIntegrator (damping 0.4, gravity -9.81 m/s^2 along z)."""
    aabb = {} if factor is None else {"aabbEnlargeFactor": factor}
    detect = {} if factor is None else {"interactionDetectionFactor": factor}
    return ([w.ForceResetter(),
             w.InsertionSortCollider([w.Bo1_Sphere_Aabb(**aabb), w.Bo1_Box_Aabb()]),
             w.InteractionLoop([w.Ig2_Sphere_Sphere_ScGeom(**detect), w.Ig2_Box_Sphere_ScGeom()],
                               [w.Ip2_FrictMat_FrictMat_FrictPhys() if ip2 is None else ip2],
                               [w.Law2_ScGeom_FrictPhys_CundallStrack() if law is None else law])]
            + list(extra) + [w.NewtonIntegrator(damping=0.4, gravity=(0, 0, -9.81))])


def _deposit(O, w, utils, max_steps):
    """Dry settling under gravity in a box (the packings' common engines and stop rule:
    unbalanced force < 0.05 after 5,000 steps, or max_steps); returns the spheres."""
    O.engines = [w.ForceResetter(), w.InsertionSortCollider([w.Bo1_Sphere_Aabb(), w.Bo1_Box_Aabb()]),
                 w.InteractionLoop([w.Ig2_Sphere_Sphere_ScGeom(), w.Ig2_Box_Sphere_ScGeom()],
                                   [w.Ip2_FrictMat_FrictMat_FrictPhys()],
                                   [w.Law2_ScGeom_FrictPhys_CundallStrack()]),
                 w.NewtonIntegrator(damping=0.6, gravity=(0, 0, -9.81))]
    O.dt = 0.5 * utils.PWaveTimeStep()
    while O.iter < max_steps:
        O.run(500, True)
        if O.iter > 5000 and utils.unbalancedForce() < 0.05:
            break
    return [b for b in O.bodies if isinstance(b.shape, w.Sphere)]


def make_packing(n, out, max_steps=25000):
    """Dry deposition of n spheres (half 0.9 mm, half 1.125 mm) in a box; saves positions."""
    yade, w, utils = _yade_env()
    from yade import pack

    O = yade.Omega()
    v_grains = n / 2 * 4 / 3 * np.pi * (R_SMALL**3 + R_LARGE**3)
    side = (v_grains / 0.6) ** (1 / 3)
    sp = pack.SpherePack()
    sp.makeCloud((0, 0, 0), (side, side, 2.2 * side), rMean=R_LARGE, rRelFuzz=0, num=n // 2, seed=1)
    sp.makeCloud((0, 0, 0), (side, side, 2.2 * side), rMean=R_SMALL, rRelFuzz=0,
                 num=n - n // 2, seed=2)
    mat = O.materials.append(w.FrictMat(young=1e7, poisson=0.3, density=2600, frictionAngle=0.3))
    O.bodies.append(utils.aabbWalls([(0, 0, 0), (side, side, 2.2 * side)], thickness=0, material=mat))
    sp.toSimulation(material=mat)
    if len(sp) != n:
        raise RuntimeError(f"makeCloud placed {len(sp)} of {n} spheres")
    t0 = time.time()
    sph = _deposit(O, w, utils, max_steps)
    pos = np.array([tuple(b.state.pos) for b in sph])
    rad = np.array([b.shape.radius for b in sph])
    np.savez(out, pos=pos, rad=rad, side=side, iters=O.iter, seconds=time.time() - t0,
             unbalanced=utils.unbalancedForce())
    print(json.dumps({"n": len(sph), "iters": O.iter, "seconds": time.time() - t0}))


def make_poly_packing(n, out, max_steps=20000, r_mean=1e-3, fuzz=0.3):
    """Dry deposition of n spheres, radius uniform in r_mean (1 +- fuzz), in a box."""
    yade, w, utils = _yade_env()
    from yade import pack

    O = yade.Omega()
    side = (n * 4 / 3 * np.pi * r_mean**3 * (1 + fuzz**2) / 0.6) ** (1 / 3)
    sp = pack.SpherePack()
    sp.makeCloud((0, 0, 0), (side, side, 2.5 * side), rMean=r_mean, rRelFuzz=fuzz, num=n, seed=5)
    if len(sp) != n:
        raise RuntimeError(f"makeCloud placed {len(sp)} of {n} spheres")
    mat = O.materials.append(w.FrictMat(young=1e7, poisson=0.3, density=2600, frictionAngle=0.3))
    O.bodies.append(utils.aabbWalls([(0, 0, 0), (side, side, 2.5 * side)], thickness=0, material=mat))
    sp.toSimulation(material=mat)
    t0 = time.time()
    sph = _deposit(O, w, utils, max_steps)
    np.savez(out, pos=np.array([tuple(b.state.pos) for b in sph]),
             rad=np.array([b.shape.radius for b in sph]), side=side, height=2.5 * side,
             iters=O.iter, seconds=time.time() - t0, unbalanced=utils.unbalancedForce())


def load_packing(O, w, utils, packing):
    """A saved packing (``make_packing`` / ``make_poly_packing``) into the scene: its box
    (height recorded, else 2.2 x side) and spheres, one ``FrictMat``; returns the file."""
    d = np.load(packing)
    side = float(d["side"])
    height = float(d["height"]) if "height" in d.files else 2.2 * side
    mat = O.materials.append(w.FrictMat(young=1e7, poisson=0.3, density=2600, frictionAngle=0.3))
    O.bodies.append(utils.aabbWalls([(0, 0, 0), (side, side, height)], thickness=0, material=mat))
    for p, r in zip(d["pos"], d["rad"]):
        O.bodies.append(utils.sphere(tuple(p), float(r), material=mat))
    return d


def run_wet_poly(variant, packing, files, steps, warmup, suction, factor):
    """Issue 9's benchmark, one variant (``law2`` or ``capbridge``); prints the result."""
    yade, w, utils = _yade_env()
    from capbridge.yade import yade_runtime
    from capbridge.yade.engine import CapbridgeEngine

    O = yade.Omega()
    d = load_packing(O, w, utils, packing)
    f, cap = 1.0, None
    ip2, law = w.Ip2_FrictMat_FrictMat_FrictPhys(), w.Law2_ScGeom_FrictPhys_CundallStrack()
    if variant == "law2":
        f = factor
        ip2 = w.Ip2_FrictMat_FrictMat_CapillaryPhys()
        law = w.Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)
        os.chdir(files)
        extra = [w.Law2_ScGeom_CapillaryPhys_Capillarity(
            capillaryPressure=suction, surfaceTension=GAMMA, suffCapFiles="_theta30", label="cap")]
    else:
        kw = {"capbridge": {}, "capbridge_held": {"force_tolerance": 1e-3},
              "capbridge10": {"refresh_every": 10}}[variant]
        cap = CapbridgeEngine(theta=THETA, gamma=GAMMA, water_content=0.01, label="bench", **kw)
        extra = [cap.pyrunner()]
    O.engines = scene_engines(w, extra, ip2, law, factor=f)
    O.dt = 0.5 * utils.PWaveTimeStep()
    t0 = time.perf_counter()
    O.run(warmup, True)
    first = time.perf_counter() - t0
    if cap is not None:
        c_eng0, n_eng0 = cap.timings["cpu_seconds"], cap.timings["steps"]
    t0, c0 = time.perf_counter(), time.process_time()
    O.run(steps, True)
    out = {"variant": variant, "n": int(len(d["rad"])), "steps": steps,
           "ms_per_step": (time.process_time() - c0) / steps * 1e3,
           "wall_ms_per_step": (time.perf_counter() - t0) / steps * 1e3,
           "warmup_seconds": first, "real_interactions": int(O.interactions.countReal()),
           "radius_range": [float(d["rad"].min()), float(d["rad"].max())]}
    if cap is None:
        nm = sum(1 for i in O.interactions if i.isReal and i.phys.meniscus)
        out["bridges"] = nm
        yade_runtime.emit_result(out)
        return
    st = cap.state()
    out.update(bridges=st["n_bridges"], liquid=st["liquid"], budget_error=st["budget"]["balance_error"],
               setup_seconds=cap.timings["setup_seconds"],
               formations_short_of_liquid=st["budget"]["formations_short_of_liquid"],
               formed=st["events"]["formed"], ruptured=st["events"]["ruptured"],
               engine_cpu_ms_per_call=(cap.timings["cpu_seconds"] - c_eng0)
               / max(cap.timings["steps"] - n_eng0, 1) * 1e3)
    if variant != "capbridge":
        yade_runtime.emit_result(out)
        return
    # restart cost: save (the engine's state goes into O.tags), load, the first step
    # (restores the state), against an ordinary step
    t0 = time.perf_counter()
    O.saveTmp("bench")
    out["save_tmp_seconds"] = time.perf_counter() - t0
    out["state_kbytes"] = len(O.tags["capbridge:bench:state"]) / 1e3
    t0 = time.perf_counter()
    O.loadTmp("bench")
    out["load_tmp_seconds"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    O.step()
    out["first_step_after_load_seconds"] = time.perf_counter() - t0
    out["restore_seconds"] = cap.timings.get("restore_seconds", float("nan"))
    out["bridges_after_load"] = cap.model.n_bridges
    t0 = time.perf_counter()
    O.save(str(Path(files).parent / "wet_poly.yade.gz"))
    out["save_file_seconds"] = time.perf_counter() - t0
    yade_runtime.emit_result(out)


def run_variant(variant, packing, files, steps, warmup, suction, factor):
    """Time one variant; prints the result line."""
    yade, w, utils = _yade_env()
    from capbridge.yade import yade_runtime
    from capbridge.yade.engine import CapbridgeEngine

    O = yade.Omega()
    d = load_packing(O, w, utils, packing)
    f = 1.0
    extra = []
    cap = None
    ip2 = w.Ip2_FrictMat_FrictMat_FrictPhys()
    law = w.Law2_ScGeom_FrictPhys_CundallStrack()
    if variant == "law2":
        f = factor
        ip2 = w.Ip2_FrictMat_FrictMat_CapillaryPhys()
        law = w.Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)
        os.chdir(files)
        extra = [w.Law2_ScGeom_CapillaryPhys_Capillarity(
            capillaryPressure=suction, surfaceTension=GAMMA, suffCapFiles="_theta30", label="cap")]
    elif variant == "capeng":
        f = factor
        ip2 = w.Ip2_FrictMat_FrictMat_CapillaryPhysDelaunay()
        law = w.Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)
        os.chdir(files)
        extra = [w.CapillarityEngine(inputFilename="capillaryfile_theta30.txt",
                                     capillaryPressure=suction, liquidTension=GAMMA,
                                     imposePressure=False, totalVolumeConstant=False,
                                     interactionDetectionFactor=f, label="cap")]
    elif variant == "native":
        from capbridge.yade.native_volume import NativeVolumeBridges

        nb = NativeVolumeBridges(Path(files).parent / "native_files", THETA, d["rad"],
                                 bridge_volume_star=VSTAR, gamma=GAMMA)
        f = nb.detection_factor
        ip2 = w.Ip2_FrictMat_FrictMat_CapillaryPhys()
        law = w.Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)
        extra = [nb.law2()]
    elif variant.startswith("capbridge"):
        every = int(variant[len("capbridge"):] or 1)
        cap = CapbridgeEngine(theta=THETA, gamma=GAMMA, bridge_volume_star=VSTAR,
                              refresh_every=every, coalescence_every=100, label="bench")
        extra = [cap.pyrunner()]
    elif variant != "dry":
        raise SystemExit(f"unknown variant {variant}")
    O.engines = scene_engines(w, extra, ip2, law, factor=f)
    O.dt = 0.5 * utils.PWaveTimeStep()
    O.run(warmup, True)
    if cap is not None:
        t_eng0, n_eng0 = cap.timings["seconds"], cap.timings["steps"]
        c_eng0, p_eng0 = cap.timings["cpu_seconds"], cap.timings.get("perm_updates", 0)
    t0, c0 = time.perf_counter(), time.process_time()
    O.run(steps, True)
    ms = (time.perf_counter() - t0) / steps * 1e3
    cpu_ms = (time.process_time() - c0) / steps * 1e3
    out = {"variant": variant, "n": int(len(d["rad"])), "ms_per_step": cpu_ms,
           "wall_ms_per_step": ms, "steps": steps,
           "real_interactions": int(O.interactions.countReal()),
           "all_interactions": int(len(O.interactions)), "detection_factor": f}
    if cap is not None:
        st = cap.state()
        out.update(bridges=st["n_bridges"], engine_wall_ms_per_call=(cap.timings["seconds"] - t_eng0)
                   / max(cap.timings["steps"] - n_eng0, 1) * 1e3,
                   engine_cpu_ms_per_call=(cap.timings["cpu_seconds"] - c_eng0)
                   / max(cap.timings["steps"] - n_eng0, 1) * 1e3,
                   perm_updates_per_call=(cap.timings.get("perm_updates", 0) - p_eng0)
                   / max(cap.timings["steps"] - n_eng0, 1),
                   coalescence=st["coalescence"], verlet_rebuilds=st["verlet_rebuilds"],
                   budget_error=st["budget"]["balance_error"])
    elif variant in ("law2", "capeng", "native"):
        nm, vol = 0, 0.0
        for i in O.interactions:
            if i.isReal and i.phys.meniscus:
                nm += 1
                vol += i.phys.vMeniscus
        out.update(bridges=nm, mean_vstar_rmean=vol / max(nm, 1) / R_MEAN**3)
    yade_runtime.emit_result(out)


# --------------------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------------------

def ensure_packing(n):
    CACHE.mkdir(parents=True, exist_ok=True)
    path = CACHE / f"packing_{n}.npz"
    if not path.exists():
        print(f"# making the {n}-grain packing (once, cached in {path})", file=sys.stderr)
        subprocess.run([sys.executable, __file__, "--make-packing", str(n), str(path)],
                       check=True, env=_env())
    return path


def ensure_files():
    """capbridge's export for theta = 30 deg (exact solver), cached."""
    from capbridge.yade import yade_export as ye

    d = CACHE / "files_theta30"
    if not (d / "capillaryfile_theta30.txt").exists():
        print("# exporting capbridge's suction tables for YADE (once)", file=sys.stderr)
        suctions = np.concatenate([[0.0], np.geomspace(0.05, 50.0, 23)])
        ye.export_from_solver(d, THETA, suctions=suctions, n_gaps=41)
    return d


def choose_suction(r_mean=R_MEAN, r_min=R_SMALL, r_max=R_LARGE):
    """Suction [Pa] whose contact bridge between mean grains holds V* = VSTAR, and the
    detection factor covering the largest rupture gap at that suction."""
    from capbridge.solvers.young_laplace import solve_doublet, suction_rupture_distance

    p = solve_doublet(0.0, VSTAR, THETA)["pressure"]          # P* < 0: suction = -P*
    s_star = -float(p)
    suction = s_star * GAMMA / r_mean
    # largest rupture gap / (R1 + R2) over the pairs of the packing (smallest grains)
    worst = 0.0
    for r1, r2 in ((r_min, r_min), (r_min, r_max), (r_max, r_max)):
        g = suction_rupture_distance(-suction * r1 / GAMMA, THETA, ratio=r2 / r1)["gap"]
        worst = max(worst, float(g) * r1 / (r1 + r2))
    return suction, 1.0 + 1.2 * worst, s_star


def _env():
    env = dict(os.environ)
    env["OMP_NUM_THREADS"] = "1"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    return env


def wet_poly_main(argv):
    """Driver of ``--wet-poly N [--steps S] [--json PATH]``: prints the markdown section."""
    ap = argparse.ArgumentParser(prog="bench_yade.py --wet-poly")
    ap.add_argument("n", type=int)
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    from capbridge.yade import yade_runtime as yr

    mach = machine()
    t_start = time.time()
    CACHE.mkdir(parents=True, exist_ok=True)
    packing = CACHE / f"poly_packing_{a.n}.npz"
    if not packing.exists():
        subprocess.run([sys.executable, __file__, "--make-poly-packing", str(a.n), str(packing)],
                       check=True, env=_env())
    rad = np.load(packing)["rad"]
    suction, factor, s_star = choose_suction(1e-3, float(rad.min()), float(rad.max()))
    files = ensure_files()
    res = {}
    for v in ("law2", "capbridge", "capbridge_held", "capbridge10"):
        args = ["--run-wet-poly", v, str(packing), str(files), str(a.steps),
                str(max(50, a.steps // 5)), repr(suction), repr(factor)]
        res[v] = yr.run_yade_script(__file__, args, timeout=3600).result
        print(f"# {v}: {res[v]['ms_per_step']:.3f} ms/step", file=sys.stderr)
    mach["load_after"] = [round(x, 2) for x in os.getloadavg()]
    if a.json:
        Path(a.json).write_text(json.dumps({"machine": mach, "results": res, "suction": suction,
                                            "factor": factor}, indent=1))
    law, cb = res["law2"], res["capbridge"]
    held, c10 = res["capbridge_held"], res["capbridge10"]
    lq = cb["liquid"]
    text = f"""### YADE, issue 9: 2,000 polydisperse grains at 1 % water content ({_dt.date.today()})

Command: `.venv/bin/python benchmarks/bench_yade.py --wet-poly {a.n} --steps {a.steps}`;
machine: {mach['cpu']}, {mach['cores']} cores shared with other jobs (load average
{mach['load_before'][0]} before, {mach['load_after'][0]} after: the absolute figures are
inflated, the ratio is taken from runs made back to back); one YADE thread per process;
YADE {mach['yade']}; one run per variant, whole run {(time.time() - t_start) / 60:.1f} min.

Packing: {cb['n']:,} spheres, radius uniform in 1 mm +-30 % ({cb['radius_range'][0] * 1e3:.3f}-{cb['radius_range'][1] * 1e3:.3f} mm), deposited dry under gravity in a box,
then both variants start from the same positions (gravity on, damping 0.4, dt = 0.5 x
P-wave step); {a.steps} timed steps after {max(50, a.steps // 5)} warm-up steps; ms/step is CPU
time of the YADE process.

| variant | ms/step (CPU) | wall | bridges | real interactions |
|---|---:|---:|---:|---:|
| YADE `Law2_ScGeom_CapillaryPhys_Capillarity`, capbridge's theta = 30 deg files, suction {suction:.1f} Pa (V* = {VSTAR:g} at contact for mean grains), detection factor {factor:.3f} | {law['ms_per_step']:.2f} | {law['wall_ms_per_step']:.2f} | {law['bridges']:,} | {law['real_interactions']:,} |
| `CapbridgeEngine(theta=30, water_content=0.01)`, defaults (conserved liquid on films, exact `addF` every step) | {cb['ms_per_step']:.2f} | {cb['wall_ms_per_step']:.2f} | {cb['bridges']:,} | {cb['real_interactions']:,} |
| the same, `force_tolerance=1e-3` (held permanent forces) | {held['ms_per_step']:.2f} | {held['wall_ms_per_step']:.2f} | {held['bridges']:,} | {held['real_interactions']:,} |
| the same, `refresh_every=10` | {c10['ms_per_step']:.2f} | {c10['wall_ms_per_step']:.2f} | {c10['bridges']:,} | {c10['real_interactions']:,} |

- Ratio capbridge / YADE Law2: defaults **{cb['ms_per_step'] / law['ms_per_step']:.2f}x** (target <= 1.3x),
  `force_tolerance=1e-3` {held['ms_per_step'] / law['ms_per_step']:.2f}x, `refresh_every=10` {c10['ms_per_step'] / law['ms_per_step']:.2f}x.
  The engine's CPU per call: {cb['engine_cpu_ms_per_call']:.2f} ms (defaults), {held['engine_cpu_ms_per_call']:.2f} ms (held), {c10['engine_cpu_ms_per_call']:.2f} ms (every 10 steps).
- Liquid at the end: {lq['bridges']:.4g} m^3 in bridges, {lq['films']:.4g} m^3 on films
  ({lq['wet_grains']:,} wet grains); bridges formed {cb['formed']:,}, ruptured
  {cb['ruptured']:,}; contacts refused for lack of liquid {cb['formations_short_of_liquid']:,}
  (never retried until a film grows); ledger balance error {cb['budget_error']:.1e}.
- Engine set-up (table slices for the scene's ratios 1-{cb['radius_range'][1] / cb['radius_range'][0]:.2f}): {cb['setup_seconds']:.2f} s, once.
- Restart: `O.saveTmp` with the engine's state {cb['save_tmp_seconds'] * 1e3:.0f} ms (state
  {cb['state_kbytes']:.0f} kB of text in `O.tags`), `O.loadTmp` {cb['load_tmp_seconds'] * 1e3:.0f} ms,
  first step after the load {cb['first_step_after_load_seconds'] * 1e3:.0f} ms of which the
  restore {cb['restore_seconds'] * 1e3:.0f} ms (an ordinary step: {cb['wall_ms_per_step']:.1f} ms);
  {cb['bridges_after_load']:,} bridges after the load; `O.save` to a .yade.gz file
  {cb['save_file_seconds']:.2f} s.
- Wall bridges: not measured (no wall bridges in this engine yet).
"""
    print(text)
    return 0


def run_one(variant, packing, files, steps, warmup, suction, factor, timeout=3600):
    from capbridge.yade import yade_runtime as yr

    args = ["--run-variant", variant, str(packing), str(files), str(steps), str(warmup),
            repr(suction), repr(factor)]
    return yr.run_yade_script(__file__, args, timeout=timeout).result


def machine():
    cpu = "unknown"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    from capbridge.yade import yade_runtime as yr
    inst = yr.find_yade()
    load = os.getloadavg()
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "yade": inst.version if inst else None,
            "load_before": [round(x, 2) for x in load]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--steps", type=int, nargs="+", default=None,
                    help="timed steps per size (default 1000 for <= 2000 grains, 200 above)")
    ap.add_argument("--write", action="store_true", help="write benchmarks/RESULTS_yade.md")
    ap.add_argument("--json", default=None, help="also dump the raw results here")
    ap.add_argument("--from-json", default=None,
                    help="re-write the report from a --json dump of an earlier run (no run)")
    a = ap.parse_args(argv)
    if a.from_json:
        doc = json.loads(Path(a.from_json).read_text())
        results = {(int(k.split(":")[0]), k.split(":")[1]): v for k, v in doc["results"].items()}
        a.sizes = sorted({n for n, _ in results})
        a.variants = [v for v in VARIANTS if any(k[1] == v for k in results)]
        a.rounds = max(len(v) for v in results.values())
        text = report(a, doc["machine"], results, doc["suction"], doc["factor"], doc["s_star"],
                      doc["seconds"], doc["command"])
        print(text)
        if a.write:
            (ROOT / "benchmarks" / "RESULTS_yade.md").write_text(text)
        return 0
    mach = machine()
    suction, factor, s_star = choose_suction()
    files = ensure_files() if any(v in ("law2", "capeng") for v in a.variants) else CACHE
    results = {}
    t_start = time.time()
    for k, n in enumerate(a.sizes):
        packing = ensure_packing(n)
        steps = a.steps[k] if a.steps else (1000 if n <= 2000 else 200)
        warmup = max(50, steps // 5)
        for rnd in range(a.rounds):
            for v in a.variants:
                res = run_one(v, packing, files, steps, warmup, suction, factor)
                results.setdefault((n, v), []).append(res)
                print(f"# n={n} round {rnd} {v}: {res['ms_per_step']:.3f} ms/step", file=sys.stderr)
    mach["load_after"] = [round(x, 2) for x in os.getloadavg()]
    command = " ".join(sys.argv[1:]).replace("--write", "").strip()
    seconds = time.time() - t_start
    text = report(a, mach, results, suction, factor, s_star, seconds, command)
    print(text)
    if a.write:
        (ROOT / "benchmarks" / "RESULTS_yade.md").write_text(text)
    if a.json:
        Path(a.json).write_text(json.dumps(
            {"machine": mach, "suction": suction, "factor": factor, "s_star": s_star,
             "seconds": seconds, "command": command,
             "results": {f"{n}:{v}": r for (n, v), r in results.items()}}, indent=1))
    return 0


def notes(results, sizes):
    """The notes under the table, every figure taken from this run's ``results``."""
    med = {k: statistics.median(r["ms_per_step"] for r in rs) for k, rs in results.items()}

    def last(n, v, key):
        return results[(n, v)][-1].get(key, 0) or 0

    def both(fmt, f):
        return " / ".join(fmt.format(f(n)) for n in sizes)

    vs_law = lambda v: (lambda n: med[(n, v)] / med[(n, "law2")])      # noqa: E731
    ms = {n: statistics.median(r["engine_cpu_ms_per_call"] for r in results[(n, "capbridge")])
          for n in sizes}
    wall = [r["wall_ms_per_step"] / r["ms_per_step"] for rs in results.values() for r in rs]
    return f"""Notes on this run:
- Target, capbridge's path for doublets <= 1.5x YADE's native capillary law on the same
  scene ({both("{:,}", lambda n: n)} grains): native fixed-volume path (capbridge's
  volume-controlled bridges in YADE's compiled Law2) {both("{:.2f}x", vs_law("native"))}; it
  needs the detection range to cover the rupture distance of volume-controlled bridges,
  {both("{:.2f}x", lambda n: last(n, "native", "real_interactions")
        / last(n, "law2", "real_interactions"))} the interactions of the suction run.
  CapbridgeEngine refreshing every step {both("{:.2f}x", vs_law("capbridge"))}, every 10 steps
  {both("{:.2f}x", vs_law("capbridge10"))}. The engine's CPU per call is
  {both("{:.2f} ms", lambda n: ms[n])}, i.e. {both("{:.2f} us",
  lambda n: 1e3 * ms[n] / last(n, "capbridge", "bridges"))} per bridge.
- CapbridgeEngine's defaults (refresh every step, force_tolerance 1e-3: a grain's force
  is handed to YADE only when a bridge force on it moved by > 0.1 %) hand
  {both("{:.0f}", lambda n: last(n, "capbridge", "perm_updates_per_call"))} grain forces per
  step to YADE here instead of every wet grain's.
- YADE's CapillarityEngine in volume mode (the compiled alternative for volume control)
  costs {both("{:.2f}x", vs_law("capeng"))} Law2 and holds
  {both("{:.0%}", lambda n: last(n, "capeng", "bridges") / last(n, "law2", "bridges"))} of
  its bridges: in volume mode it gives no volume to bridges formed after its first step
  (Python would have to), and its stale tetrahedron cache made a two-sphere lookup hang
  where re-creating the interaction avoided it; not used.
- Wall clock / CPU per step over all runs: {min(wall):.2f}-{max(wall):.2f}.
- Accuracy of the same paths (tests/test_yade_engine.py, their tolerances):
  CapbridgeEngine = capbridge's lookup to 1e-9 (forces not held) or 0.5 % (held) along a
  pull-apart to rupture; the native fixed-volume files within 0.5 %; zero past rupture
  for both."""


def report(a, mach, results, suction, factor, s_star, seconds, command):
    date = _dt.date.today().isoformat()
    lines = [f"### YADE: ms per step, dry / native capillary law / capbridge engine ({date})", "",
             "Command: `.venv/bin/python benchmarks/bench_yade.py " + command + "`; machine: "
             f"{mach['cpu']}, {mach['cores']} cores, one YADE thread per process "
             f"(OMP_NUM_THREADS=1), YADE {mach['yade']}, Python {mach['python']}, numpy "
             f"{mach['numpy']}; load average {mach['load_before'][0]} before, "
             f"{mach['load_after'][0]} after; "
             f"{a.rounds} rounds, every variant once per round, median shown; whole run "
             f"{seconds / 60:.1f} min.", "",
             f"Packings: bidisperse spheres, half R = {R_SMALL * 1e3:g} mm, half "
             f"{R_LARGE * 1e3:g} mm (ratio {R_LARGE / R_SMALL:g}, one of YADE's file ratios), "
             "dropped in a box and deposited dry under gravity for 25,000 steps, then "
             "every variant starts from the same positions (gravity on, damping 0.4, "
             "dt = 0.5 x P-wave step). ms/step is the CPU time of the YADE process per "
             "step (wall-clock times are listed below). Liquid: theta = "
             f"{THETA:g} deg; capbridge bridges V* = {VSTAR:g} (fixed volume per bridge, "
             f"by the smaller radius); YADE's Law2 at suction {suction:.1f} Pa (s* = "
             f"{s_star:.3f}: V* = {VSTAR:g} at contact for two mean grains), detection "
             f"factor {factor:.3f} (covers its rupture distance).", "",
             "| grains | variant | ms/step | vs dry | vs native Law2 | bridges | real interactions |",
             "|---:|---|---:|---:|---:|---:|---:|"]
    names = {"dry": "dry (no liquid)", "law2": "YADE Law2_ScGeom_CapillaryPhys_Capillarity + capbridge files",
             "native": "capbridge fixed-volume bridges through YADE's Law2 (native)",
             "capbridge": "capbridge engine, volume-controlled, refresh every step",
             "capbridge10": "capbridge engine, refresh every 10 steps",
             "capeng": "YADE CapillarityEngine, volume mode, capbridge file"}
    for n in a.sizes:
        med = {v: statistics.median(r["ms_per_step"] for r in results[(n, v)])
               for v in a.variants if (n, v) in results}
        for v in a.variants:
            if v not in med:
                continue
            last = results[(n, v)][-1]
            vs_dry = med[v] / med["dry"] if "dry" in med else float("nan")
            vs_law = med[v] / med["law2"] if "law2" in med else float("nan")
            lines.append(f"| {n:,} | {names[v]} | {med[v]:.2f} | {vs_dry:.2f} | {vs_law:.2f} | "
                         f"{last.get('bridges', 0):,} | {last['real_interactions']:,} |")
    lines += ["", notes(results, a.sizes), "", "All rounds (ms per step, CPU time of the YADE process, then wall clock):", ""]
    for (n, v), rs in sorted(results.items()):
        extra = ""
        if v.startswith("capbridge"):
            extra = (f"; engine {statistics.median(r['engine_cpu_ms_per_call'] for r in rs):.3f} "
                     f"ms CPU per call, {rs[-1]['perm_updates_per_call']:.1f} grains' forces "
                     "handed to YADE per call")
        lines.append(f"- {n:,} {v}: CPU " + ", ".join(f"{r['ms_per_step']:.3f}" for r in rs)
                     + "; wall " + ", ".join(f"{r['wall_ms_per_step']:.3f}" for r in rs) + extra)
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--make-packing":
        make_packing(int(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) > 1 and sys.argv[1] == "--make-poly-packing":
        make_poly_packing(int(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) > 1 and sys.argv[1] == "--run-wet-poly":
        v, packing, files, steps, warmup, suction, factor = sys.argv[2:9]
        run_wet_poly(v, packing, files, int(steps), int(warmup), float(suction), float(factor))
    elif len(sys.argv) > 1 and sys.argv[1] == "--wet-poly":
        sys.exit(wet_poly_main(sys.argv[2:]))
    elif len(sys.argv) > 1 and sys.argv[1] == "--run-variant":
        v, packing, files, steps, warmup, suction, factor = sys.argv[2:9]
        run_variant(v, packing, files, int(steps), int(warmup), float(suction), float(factor))
    else:
        sys.exit(main())
