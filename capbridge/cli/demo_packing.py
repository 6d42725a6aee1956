"""The demo's wet packing in YADE: grains settle dry under gravity, then get wet.

Run in a fresh process by :func:`capbridge.cli.demo.run_packing` (YADE is imported here,
never in the caller); usable alone with the project's interpreter::

    .venv/bin/python -m capbridge.cli.demo_packing [n_grains] [dry_steps] [wet_steps]

Prints a few lines and one JSON result line (:func:`~capbridge.yade.yade_runtime.
emit_result`): the bridges, the liquid clusters, the liquid ledger, the capillary force
against the grains' weight, and the positions and bridge forces for the figure.
"""
import sys
import time

import numpy as np

from capbridge.yade import yade_runtime


def main(argv):
    """The scene (YADE is imported here, so that importing this module does nothing)."""
    yade_runtime.ensure_yade_importable()       # nothing to do under the yade launcher
    from yade import O, pack, utils
    from yade.wrapper import (Bo1_Box_Aabb, Bo1_Sphere_Aabb, ForceResetter, FrictMat,
                              Ig2_Box_Sphere_ScGeom, Ig2_Sphere_Sphere_ScGeom,
                              InsertionSortCollider, InteractionLoop,
                              Ip2_FrictMat_FrictMat_FrictPhys,
                              Law2_ScGeom_FrictPhys_CundallStrack, NewtonIntegrator, Sphere)

    from capbridge.yade.engine import CapbridgeEngine

    N_GRAINS = int(argv[0]) if len(argv) > 0 else 300
    MAX_DRY_STEPS = int(argv[1]) if len(argv) > 1 else 30000
    WET_STEPS = int(argv[2]) if len(argv) > 2 else 400
    GAMMA, THETA, WATER = 0.073, 20.0, 0.02         # N/m, deg, liquid mass / grain mass

    t0 = time.perf_counter()
    box = ((0, 0, 0), (0.016, 0.016, 0.02))         # [m]
    sp = pack.SpherePack()
    sp.makeCloud(box[0], box[1], rMean=1e-3, rRelFuzz=0.2, num=N_GRAINS, seed=1)
    glass = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600,
                                        frictionAngle=0.4, label="glass"))
    O.bodies.append(utils.aabbWalls(box, thickness=0, material=glass))
    sp.toSimulation(material=glass)
    spheres = [b for b in O.bodies if isinstance(b.shape, Sphere)]

    cap = CapbridgeEngine(theta={"glass": THETA}, gamma=GAMMA, water_content=WATER,
                          initial_wet_gap=5e-5,     # the settled contacts get wet at once
                          coalescence_every=50)
    dry = [ForceResetter(),
           InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
           InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                           [Ip2_FrictMat_FrictMat_FrictPhys()],
                           [Law2_ScGeom_FrictPhys_CundallStrack()])]
    newton = NewtonIntegrator(damping=0.3, gravity=(0, 0, -9.81))
    O.engines = dry + [newton]
    O.dt = 0.5 * utils.PWaveTimeStep()
    while O.iter < MAX_DRY_STEPS:                   # settle dry (compiled, fast)
        O.run(2000, True)
        if O.iter >= 6000 and utils.unbalancedForce() < 0.01:
            break
    DRY_STEPS = O.iter
    t_dry = time.perf_counter() - t0
    z_dry = max(b.state.pos[2] + b.shape.radius for b in spheres)
    unbalanced_dry = utils.unbalancedForce()

    O.engines = dry + [cap.pyrunner(), newton]      # wet: the engine after the contacts
    O.run(WET_STEPS, True)
    t_wet = time.perf_counter() - t0 - t_dry

    s = cap.state()
    br = cap.bridges()
    budget = s["budget"]
    ledger_error = abs(budget["accounted"] - budget["expected"]) / budget["expected"]
    weight = np.mean([b.state.mass for b in spheres]) * 9.81
    force = np.abs(np.asarray(br["force"], dtype=float))
    coal = s["coalescence"]
    print(f"wet packing: {len(spheres)} glass beads (r = 1 mm +-20 %), theta = {THETA:g} deg, "
          f"water content {WATER:g}; {DRY_STEPS} dry steps then {WET_STEPS} wet steps "
          f"({t_dry:.1f} s + {t_wet:.1f} s)")
    print(f"  settled dry: top of the pile {z_dry * 1e3:.1f} mm, unbalanced force "
          f"{unbalanced_dry:.2g}; after wetting {utils.unbalancedForce():.2g}")
    print(f"  bridges: {s['n_bridges']} ({2 * s['n_bridges'] / len(spheres):.2f} per grain), "
          f"formed {s['events']['formed']}, ruptured {s['events']['ruptured']}")
    print(f"  bridge force: median {np.median(force) * 1e3:.3f} mN, max {force.max() * 1e3:.3f} mN"
          f" = {np.median(force) / weight:.1f} and {force.max() / weight:.1f} x a grain's "
          f"mean weight ({weight * 1e3:.3f} mN)")
    print(f"  liquid clusters (coalesced bridges): {coal.get('clusters', 0)} clusters, "
          f"{coal.get('triplets', 0)} coalesced bridge pairs")
    print(f"  liquid ledger: bridges + films = {budget['accounted']:.6e} of "
          f"{budget['expected']:.6e} m^3 (relative error {ledger_error:.1e})")
    print(f"  engine CPU {s['timings']['cpu_seconds']:.2f} s over the wet steps")

    idx = {b.id: k for k, b in enumerate(spheres)}
    yade_runtime.emit_result({
        "n_grains": len(spheres), "dry_steps": DRY_STEPS, "wet_steps": WET_STEPS,
        "n_bridges": s["n_bridges"], "events": s["events"], "coalescence": coal,
        "budget": budget, "ledger_error": ledger_error, "weight": weight,
        "wall_seconds": {"dry": t_dry, "wet": t_wet}, "z_dry": z_dry,
        "unbalanced": {"dry": unbalanced_dry, "wet": utils.unbalancedForce()},
        "pos": [list(b.state.pos) for b in spheres], "radius": [b.shape.radius for b in spheres],
        "bridge_ends": [[idx[int(i)], idx[int(j)]] for i, j in zip(br["id1"], br["id2"])],
        "bridge_force": force.tolist(),
    })


if __name__ == "__main__":
    main(sys.argv[1:])
