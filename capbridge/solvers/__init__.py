"""Solvers: the exact axisymmetric Young-Laplace doublet (with gravity), the sphere-wall
bridge, triplet geometry and coalescence, and the Surface Evolver driver (``evolver``)."""
