"""Spot checks quoted in capbridge/solvers/evolver/README.md (about 2 min on 2 cores).

    .venv/bin/python benchmarks/evolver_spot_checks.py
"""
import time, numpy as np
from capbridge.dimensionless import triplet_centres
from capbridge.solvers.evolver import doublet_force, minimise_bridge
F, r = doublet_force(gap=0.1, volume=0.05, theta=30)
print("doublet d=0.1 V=0.05 th=30: F=%.4f" % F, r.status.name)
C = triplet_centres(0.175, 0.175, 0.075)
for L in (3, 4):
    t = time.monotonic()
    r = minimise_bridge(C, 1.0, 0.0, 16 / 64, topology="coalesced", max_refine=L, min_refine=L, tol=0.0, etol=0.0)
    F = r.forces
    print(f"trimer 16/64 th0 L{L}: {r.status.name} facets {r.n_facets} wall {time.monotonic()-t:.0f}s "
          f"sum {np.abs(F.sum(0)).max():.1e} vw-vs-direct {r.error_estimate.get('direct_vs_vw_rel'):.2%} "
          f"est err {r.error_estimate.get('force_rel'):.2%}")
# gravity: from the top grain (0) towards the midpoint of the bottom pair
g = 0.5 * (C[1] + C[2]) - C[0]; g /= np.linalg.norm(g)
t = time.monotonic()
r = minimise_bridge(C, 1.0, 0.0, 16 / 64, topology="coalesced", bond=2.14, gravity_dir=g, max_refine=3, min_refine=3, tol=0.0, etol=0.0)
W = 2.14 * 0.25 / (2 * np.pi) * g
print(f"gravity L3: {r.status.name} wall {time.monotonic()-t:.0f}s sum-weight {np.abs(r.forces.sum(0) - W).max():.1e}")
for V in (0.25, 0.45):
    t = time.monotonic()
    r = minimise_bridge(C, 1.0, 60.0, V, topology="coalesced", max_refine=3)
    print(f"th60 V={V}: {r.status.name} L{r.refinement} wall {time.monotonic()-t:.0f}s {r.reason[:80]}")
from capbridge.solvers.young_laplace import solve_doublet
for V, d in ((0.05, 0.1), (0.2, 0.02), (0.008, 0.1)):
    for th in (0.0, 30.0, 60.0):
        F, r = doublet_force(d, V, th)
        ex = float(solve_doublet(d, V, th)["force"])
        u = np.array([1.0, 0, 0])
        fc = float(r.forces_direct_contact[0] @ u) if r.forces_direct_contact is not None else np.nan
        print(f"V={V} d={d} th={th}: L{r.refinement} contact-line direct {fc/ex-1:+.2%}, order {r.error_estimate.get('force_order')}")
