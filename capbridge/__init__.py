"""capbridge: precomputed capillary-force database for DEM simulations of wet granular media."""

from capbridge.version import __version__  # noqa: F401

from capbridge import _legacy

_legacy.install()      # old import paths (capbridge.generator, .dem_plugin, ...) still work
