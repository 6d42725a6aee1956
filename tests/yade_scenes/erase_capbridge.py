"""Every wet grain of CapbridgeEngine erased in a real YADE scene: the engine idles.

    python erase_capbridge.py --case all|resume|both

``all``: four wet glass grains in a row (radius 1 mm, touching) on a fixed steel
``Wall`` with a permanent force of the user's, 1 % water content, wall bridges,
``refresh_every=2`` (forces held as permanent forces), gravity.  After 4 steps every
sphere is erased; 6 more steps, ``O.saveTmp``, 4 steps, ``O.loadTmp``, 4 steps.  Reports
the engine's state before and after the erasure and after the reload, and the wall's
permanent force before and after (ours held there, then the user's alone).

``resume``: the same row plus two glass grains far from it and from each other (every
grain wet: films at 1 % water content).  After 3 steps the four bridged grains are
erased (the engine idles, no bridge); 3 steps later the two far grains are put 0.5 um
apart (``formation_gap`` 1 um) and 2 more steps run: a bridge forms from their films.  Reports the states and
the bridge's force on the two grains.

Prints one JSON line {case: result}; ``both`` runs the two cases in this process.
"""
import argparse
import sys

from capbridge.yade import yade_runtime

yade_runtime.ensure_yade_importable()
from yade import *  # noqa: E402,F401,F403
from yade import utils  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402

from capbridge.yade.engine import CapbridgeEngine  # noqa: E402

cli = argparse.ArgumentParser()
cli.add_argument("--case", required=True, choices=("all", "resume", "both"))
cfg = cli.parse_args(sys.argv[1:])

R = 1e-3
USER_PERM = 1e-4


def scene(label, far=0, wall=False, **kw):
    O.reset()
    glass = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600,
                                        frictionAngle=0.4, label="glass"))
    steel = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=7800,
                                        frictionAngle=0.4, label="steel"))
    row = [O.bodies.append(utils.sphere((2 * R * k * (1 - 1e-4), 0, 0), R, material=glass))
           for k in range(4)]
    others = [O.bodies.append(utils.sphere((0, 10 * R, 4 * R * k), R, material=glass))
              for k in range(far)]
    w = O.bodies.append(utils.wall((0, 0, -R * (1 - 1e-4)), axis=2, material=steel)) \
        if wall else None
    cap = CapbridgeEngine(theta={"glass": 20.0, "steel": 40.0}, water_content=0.01,
                          label=label, walls=wall, **kw)
    O.engines = [ForceResetter(),
                 InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                                 [Ip2_FrictMat_FrictMat_FrictPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack()]),
                 cap.pyrunner(),
                 NewtonIntegrator(damping=0.3, gravity=(0, 0, -9.81))]
    O.dt = 1e-6
    return cap, row, others, w


def case_all():
    out = {"user_perm": USER_PERM}
    try:
        cap, row, _, w = scene("erase_all", wall=True, refresh_every=2)
        O.forces.setPermF(w, (0, 0, USER_PERM))
        O.run(4, True)
        out.update(before=cap.state(), wall_perm_before=list(O.forces.permF(w)),
                   iter_before=int(O.iter))
        for i in row:
            O.bodies.erase(i)
        O.run(6, True)
        # (the wall's permanent force is read here only: YADE drops permanent forces on
        # load, and reading permF then may crash YADE 2023.02a)
        out.update(after=cap.state(), wall_perm_after=list(O.forces.permF(w)),
                   iter_after=int(O.iter))
        O.saveTmp()
        O.run(4, True)
        O.loadTmp()
        O.run(4, True)
        out.update(reloaded=cap.state(), messages=list(cap.messages), error=None)
    except Exception as exc:  # the scene reports what the user sees
        out["error"] = {"type": type(exc).__name__, "message": str(exc)}
    return out


def case_resume():
    out = {}
    try:
        # bridges form within 1 um, so that the two far grains meet without a contact
        # (YADE's force on them is then the bridge's alone)
        # (and no weight of the liquid: the two forces are then exactly opposite)
        cap, row, far, _ = scene("erase_resume", far=2, formation_gap=1e-6,
                                 gravity_correction="off")
        O.run(3, True)
        out["before"] = cap.state()
        for i in row:
            O.bodies.erase(i)
        O.run(3, True)
        out["idle"] = cap.state()
        a, b = far
        O.bodies[b].state.pos = O.bodies[a].state.pos + Vector3(0, 0, 2 * R + 0.5e-6)
        O.run(2, True)
        out["met"] = cap.state()
        br = cap.bridges()
        out["bridge_force"] = float(br["force"][0]) if len(br["force"]) else 0.0
        d = O.bodies[b].state.pos - O.bodies[a].state.pos
        out["axis"] = list(d / d.norm())
        out["forces"] = [list(O.forces.f(a)), list(O.forces.f(b))]
        out["error"] = None
    except Exception as exc:
        out["error"] = {"type": type(exc).__name__, "message": str(exc)}
    return out


cases = {"all": case_all, "resume": case_resume}
run = list(cases) if cfg.case == "both" else [cfg.case]
yade_runtime.emit_result({c: cases[c]() for c in run})
