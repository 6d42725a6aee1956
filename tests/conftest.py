"""Markers and fixtures shared by the tests.

Markers (declared in pyproject.toml):

``yade``
    the test starts Debian's YADE (a scene in a subprocess, or ``import yade``).  It is
    skipped when YADE is not found, here and nowhere else.  A test that takes the
    ``yade`` fixture (the :class:`~capbridge.yade.yade_runtime.YadeInstallation`) gets
    the marker automatically.
``evolver``
    the test runs Surface Evolver; skipped when ``capbridge.solvers.evolver.available()``
    is false.  Taking the ``evolver`` fixture (the executable's path) adds the marker.
``slow``
    a long check (measured >= ~2.5 s on 2 busy cores, or a fixture that takes that long),
    still part of ``make test``; ``make test-fast`` leaves it out, with the two above.
    The package's slow doctests are marked here (``_SLOW_DOCTESTS``).

Those skips say "not installed": under ``make test`` (``CAPBRIDGE_NO_DEPENDENCY_SKIPS=1``)
they fail instead, see :func:`pytest_runtest_makereport`.

The shipped tables (``doublet_table``, ``triplet_table``, ``coalescence_table``
fixtures, paths) are part of the checkout: a missing one fails the tests that need it,
naming the file, instead of skipping them.  ``$CAPBRIDGE_TRIPLET_TABLE`` replaces the
shipped triplet table (a table of one's own, e.g. a ``--quick`` one) for the tests that
take ``triplet_table``.
"""
import functools
import os
import re
from pathlib import Path

import numpy as np
import pytest

# Scene scripts run inside YADE (as subprocesses), never imported by pytest.
collect_ignore_glob = ["yade_scenes/*"]

#: skip reasons that say an installable dependency is missing (Debian's yade, Surface
#: Evolver, python3-vtk9, dask's distributed, ...): `make test` installs every one of
#: them, so there such a skip is a broken set-up and fails instead of checking nothing.
_MISSING_DEPENDENCY = re.compile(r"not installed|could not import|no module named", re.I)

_SKIP_REASON = {"yade": "Debian's yade is not installed",
                "evolver": "Surface Evolver not installed"}

#: doctests of the package (capbridge/, not editable as tests) that take seconds: slow.
_SLOW_DOCTESTS = {"capbridge.solvers.triplet.find_coalescence",
                  "capbridge.solvers.young_laplace_gravity.rupture_distance_gravity",
                  "capbridge.tables.coalescence.separated_state"}


@functools.lru_cache(maxsize=None)
def _yade_installation():
    """The one place the tests look for YADE (None if it is not installed)."""
    from capbridge.yade import yade_runtime
    return yade_runtime.find_yade()


@functools.lru_cache(maxsize=None)
def _evolver_path():
    from capbridge.solvers.evolver import runner
    return runner.evolver_path()


def _installed(name):
    return (_yade_installation() if name == "yade" else _evolver_path()) is not None


@pytest.hookimpl(tryfirst=True)      # before `-m` selects on the markers added here
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.name in _SLOW_DOCTESTS:
            item.add_marker(pytest.mark.slow)
        used = set(getattr(item, "fixturenames", ()))
        for name in ("yade", "evolver"):
            if name in used and item.get_closest_marker(name) is None:
                item.add_marker(getattr(pytest.mark, name))
            if item.get_closest_marker(name) is not None and not _installed(name):
                item.add_marker(pytest.mark.skip(reason=_SKIP_REASON[name]))


@pytest.fixture(scope="session")
def yade():
    """Debian's YADE (``YadeInstallation``); the test is marked ``yade``."""
    inst = _yade_installation()
    if inst is None:                     # normally skipped by the marker already
        pytest.skip(_SKIP_REASON["yade"])
    return inst


@pytest.fixture(scope="session")
def evolver():
    """Path of the Surface Evolver executable; the test is marked ``evolver``."""
    path = _evolver_path()
    if path is None:
        pytest.skip(_SKIP_REASON["evolver"])
    return path


def _shipped(path, what, override=None):
    """``path`` (or ``$override`` if set) as a Path; fails (never skips) if it is missing."""
    if override and os.environ.get(override):
        path = Path(os.environ[override])
        if not path.is_file():
            pytest.fail(f"${override} = {path}: no such table", pytrace=False)
        return path
    path = Path(path)
    if not path.is_file():
        pytest.fail(f"the shipped {what} {path} is missing: the checkout is broken "
                    f"(restore it with `git checkout -- {path.parent.name}/{path.name}`, "
                    f"or regenerate it with `make data`)", pytrace=False)
    return path


@pytest.fixture(scope="session")
def doublet_table():
    """Path of the shipped doublet table ``data/doublet_table.nc``."""
    from capbridge.cli import DEFAULT_TABLE
    return _shipped(DEFAULT_TABLE, "doublet table")


@pytest.fixture(scope="session")
def triplet_table():
    """Path of the triplet table: ``$CAPBRIDGE_TRIPLET_TABLE``, else the shipped
    ``data/triplet_table.nc``."""
    from capbridge.cli import DEFAULT_TRIPLET_TABLE
    return _shipped(DEFAULT_TRIPLET_TABLE, "triplet table", override="CAPBRIDGE_TRIPLET_TABLE")


@pytest.fixture(scope="session")
def shipped_triplet_table():
    """Path of the shipped ``data/triplet_table.nc`` (no override: tests of the file
    itself and of the CLI's default)."""
    from capbridge.cli import DEFAULT_TRIPLET_TABLE
    return _shipped(DEFAULT_TRIPLET_TABLE, "triplet table")


@pytest.fixture(scope="session")
def packings_triplet_table():
    """Path of the shipped second triplet table ``data/triplet_table_packings.nc`` (the
    DEM engine's default)."""
    from capbridge.tables import TRIPLET_TABLE_PACKINGS
    return _shipped(TRIPLET_TABLE_PACKINGS, "triplet table of the packings grid")


@pytest.fixture(scope="session")
def coalescence_table():
    """Path of the shipped coalescence table ``data/triplet_coalescence.nc``."""
    from capbridge.cli import DEFAULT_COALESCENCE_TABLE
    return _shipped(DEFAULT_COALESCENCE_TABLE, "coalescence table")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    if not (rep.skipped and os.environ.get("CAPBRIDGE_NO_DEPENDENCY_SKIPS") == "1"):
        return
    if hasattr(rep, "wasxfail"):
        return
    reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
    if _MISSING_DEPENDENCY.search(reason):
        rep.outcome = "failed"
        rep.longrepr = (f"skipped for a missing dependency, which `make test` installs "
                        f"(CAPBRIDGE_NO_DEPENDENCY_SKIPS=1): {reason}")


@pytest.fixture(scope="session")
def vtk_read():
    """VTK's own reader, as ParaView loads a file: ``vtk_read(path)`` -> (polydata, cell
    arrays, point arrays, the points as an array).  Debian's python3-vtk9 (installed by
    ``make``); a missing module skips (a failure under CAPBRIDGE_NO_DEPENDENCY_SKIPS)."""
    vtk = pytest.importorskip("vtk", reason="VTK's Python module not installed "
                                            "(Debian python3-vtk9)")
    from vtk.util.numpy_support import vtk_to_numpy

    def arrays(data):
        return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i))
                for i in range(data.GetNumberOfArrays())}

    def read(path):
        path = Path(path)
        reader = vtk.vtkXMLPolyDataReader() if path.suffix == ".vtp" else \
            vtk.vtkPolyDataReader()
        reader.SetFileName(str(path))
        reader.Update()
        out = reader.GetOutput()
        pts = out.GetPoints()
        xyz = vtk_to_numpy(pts.GetData()) if pts is not None else np.empty((0, 3))
        return out, arrays(out.GetCellData()), arrays(out.GetPointData()), xyz

    return read
