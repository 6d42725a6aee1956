"""Solvers and gridded sweeps that generate the capillary-force tables."""
