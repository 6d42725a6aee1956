"""capbridge: precomputed capillary-force database for DEM simulations of wet granular media."""

__version__ = "0.1.0"
