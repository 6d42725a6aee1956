"""Import paths of capbridge before its layered layout (issue 17), kept working.

The modules moved in version 0.2 (``capbridge.generator`` -> ``capbridge.solvers`` and
``capbridge.tables``, ``capbridge.dem_plugin`` -> ``capbridge.dem`` and ``capbridge.yade``,
``capbridge.reproduce`` -> ``capbridge.studies``, the pure functions of
``capbridge.surrogate`` -> ``capbridge.physics``).  Scenes, scripts and YADE restart files
that name the old paths (a saved PyRunner's command, for one) still import them: the
finder below answers an old name with the module now at the new one (the same module
object, so classes and functions are identical) and warns once with a
``DeprecationWarning`` naming the new path.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings

#: old dotted name -> new dotted name (packages map their submodules by prefix)
MOVED = {
    "capbridge.surrogate.closed_forms": "capbridge.physics.closed_forms",
    "capbridge.surrogate.coalescence_fit": "capbridge.physics.coalescence_fit",
    "capbridge.surrogate.gravity": "capbridge.physics.gravity",
    "capbridge.generator.young_laplace_gravity": "capbridge.solvers.young_laplace_gravity",
    "capbridge.generator.young_laplace": "capbridge.solvers.young_laplace",
    "capbridge.generator.sphere_wall": "capbridge.solvers.sphere_wall",
    "capbridge.generator.triplet_evolver": "capbridge.solvers.triplet_evolver",
    "capbridge.generator.triplet_table": "capbridge.tables.triplet",
    "capbridge.generator.triplet_gravity": "capbridge.tables.triplet_gravity",
    "capbridge.generator.triplet_coalescence": "capbridge.tables.coalescence",
    "capbridge.generator.triplet": "capbridge.solvers.triplet",
    "capbridge.generator.evolver": "capbridge.solvers.evolver",
    "capbridge.generator.atomic": "capbridge.tables.atomic",
    "capbridge.generator.netcdf_io": "capbridge.tables.netcdf_io",
    "capbridge.generator.table_checks": "capbridge.tables.checks",
    "capbridge.generator.sweep": "capbridge.tables.sweep",
    "capbridge.generator.doublet_table": "capbridge.tables.doublet",
    "capbridge.generator.doublet_gravity": "capbridge.tables.doublet_gravity",
    "capbridge.surrogate.demo": "capbridge.cli.demo",
    "capbridge.dem_plugin.bridges": "capbridge.dem.bridges",
    "capbridge.dem_plugin.coalescence_detect": "capbridge.dem.coalescence_detect",
    "capbridge.dem_plugin.liquid_gravity": "capbridge.dem.liquid_gravity",
    "capbridge.dem_plugin.mixed_angles": "capbridge.dem.mixed_angles",
    "capbridge.dem_plugin.periodic": "capbridge.dem.periodic",
    "capbridge.dem_plugin.scene_geometry": "capbridge.dem.scene_geometry",
    "capbridge.dem_plugin.triplet_clusters": "capbridge.dem.triplet_clusters",
    "capbridge.dem_plugin.wall_bridges": "capbridge.dem.wall_bridges",
    "capbridge.dem_plugin.vtk_output": "capbridge.dem.vtk_output",
    "capbridge.dem_plugin.engine_options": "capbridge.yade.engine_options",
    "capbridge.dem_plugin.engine_vtk": "capbridge.yade.engine_vtk",
    "capbridge.dem_plugin.engine": "capbridge.yade.engine",
    "capbridge.dem_plugin.native_volume": "capbridge.yade.native_volume",
    "capbridge.dem_plugin.state_io": "capbridge.yade.state_io",
    "capbridge.dem_plugin.yade_export": "capbridge.yade.yade_export",
    "capbridge.dem_plugin.yade_runtime": "capbridge.yade.yade_runtime",
    "capbridge.reproduce.miot2021": "capbridge.studies.miot2021",
    "capbridge.generator.evolver": "capbridge.solvers.evolver",
    "capbridge.reproduce": "capbridge.studies",
}
#: old packages that have no single new home: empty namespaces whose submodules move
LEGACY_PACKAGES = ("capbridge.generator", "capbridge.dem_plugin")


def new_name(name: str) -> str | None:
    """The current module path of an old one (``None`` if ``name`` did not move)."""
    if name in MOVED:
        return MOVED[name]
    for old, new in MOVED.items():
        if name.startswith(old + "."):
            return new + name[len(old):]
    return None


class _Alias(importlib.abc.Loader):
    def __init__(self, target):
        self.target = target

    def create_module(self, spec):
        if self.target is None:                       # a legacy package: a namespace
            module = types.ModuleType(spec.name, f"capbridge before 0.2; see {__name__}")
            module.__path__ = []
            return module
        return importlib.import_module(self.target)

    def exec_module(self, module):
        pass


class LegacyFinder(importlib.abc.MetaPathFinder):
    """Finds the modules of :data:`MOVED` and :data:`LEGACY_PACKAGES` by their old names."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname in LEGACY_PACKAGES:
            return importlib.machinery.ModuleSpec(fullname, _Alias(None), is_package=True)
        new = new_name(fullname)
        if new is None:
            return None
        warnings.warn(f"{fullname} moved to {new}; import it from there",
                      DeprecationWarning, stacklevel=3)
        return importlib.machinery.ModuleSpec(fullname, _Alias(new))


def install():
    """Put the finder first on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, LegacyFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, LegacyFinder())
