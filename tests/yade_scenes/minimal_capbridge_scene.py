"""Wet granular pile: 200 glass beads settle in a box with capillary bridges (capbridge)."""
from capbridge.yade import yade_runtime
yade_runtime.ensure_yade_importable()           # nothing to do under the yade launcher
from yade import *
from yade import pack, utils

from capbridge.yade.config import WaterContent
from capbridge.yade.engine import CapbridgeEngine

box = ((0, 0, 0), (0.012, 0.012, 0.02))         # [m]
sp = pack.SpherePack()
sp.makeCloud(box[0], box[1], rMean=1e-3, rRelFuzz=0.2, num=200, seed=1)
glass = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2600,
                                    frictionAngle=0.4, label="glass"))
O.bodies.append(utils.aabbWalls(box, thickness=0, material=glass))
sp.toSimulation(material=glass)

cap = CapbridgeEngine(theta={"glass": 20.0},    # contact angle per material [deg]
                      gamma=0.073,              # surface tension [N/m]
                      liquid=WaterContent(0.01))  # liquid mass / grain mass, conserved
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    cap.pyrunner(),                             # after the contacts, before Newton
    NewtonIntegrator(damping=0.3, gravity=(0, 0, -9.81)),
]
O.dt = 0.5 * utils.PWaveTimeStep()
O.run(4000, True)

s = cap.state()
print("bridges:", s["n_bridges"], "formed:", s["events"]["formed"],
      "ruptured:", s["events"]["ruptured"])
print("liquid in bridges + on grains:", s["budget"]["accounted"],
      "of", s["budget"]["expected"], "m^3")
print("coalesced bridge pairs:", s["coalescence"]["triplets"])
