"""Per-call cost of the triplet surrogate's vector lookup, the DEM step's triplet kernel.

    .venv/bin/python benchmarks/bench_triplet_lookup.py [--k 1,60,600] [--calls 3000]

``TripletSurrogate.predict_vectors`` on k equal-radius triplets inside the shipped table
(two bridge gaps 0-0.05 and 0, open side 0-0.15, V* = 0.05, theta = 30 deg), as
``LiquidClusters.lookup`` calls it once per DEM step: without gravity and with a Bond
number of 0.13 (water on 1 mm grains); CPU ms per call over ``--calls`` / k calls
(at least 3).  Prints one line per k; compare commits by running it interleaved with
each on PYTHONPATH.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from capbridge.dem.triplet_clusters import load_surrogate, triangle_centres


def per_call_ms(fn, n):
    fn()
    c0 = time.process_time()
    for _ in range(n):
        fn()
    return (time.process_time() - c0) / n * 1e3


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--k", default="1,60,600", help="numbers of triplets per call")
    ap.add_argument("--calls", type=int, default=3000)
    a = ap.parse_args(argv)
    sur = load_surrogate()
    rng = np.random.default_rng(0)
    for k in (int(x) for x in a.k.split(",")):
        g = np.column_stack([rng.uniform(0, 0.05, k), np.zeros(k), rng.uniform(0, 0.15, k)])
        C = triangle_centres(2 + g[:, 0], 2 + g[:, 1], 2 + g[:, 2])
        V, t, R = np.full(k, 0.05), np.full(k, 30.0), np.ones((k, 3))
        n = max(3, a.calls // k)
        plain = per_call_ms(lambda: sur.predict_vectors(C, V, t, radii=R), n)
        grav = per_call_ms(lambda: sur.predict_vectors(C, V, t, radii=R, bond=np.full(k, 0.13),
                                                       gravity=np.array([0, 0, -9.81])), n)
        print(f"k = {k}: {plain:.3f} ms per call without gravity, {grav:.3f} with gravity")


if __name__ == "__main__":
    main()
