"""Solvers: the exact axisymmetric Young-Laplace doublet (with gravity), the sphere-wall
bridge, triplet geometry and coalescence, the Surface Evolver driver (``evolver``), and
the minimised liquid surfaces as VTK files for ParaView (``shapes``)."""
