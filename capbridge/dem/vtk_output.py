"""VTK files of capillary bridges and liquid clusters, for ParaView (numpy only).

Bridges are written as VTK PolyData: one *line* cell per bridge between its two ends
(a grain centre, or the contact point on a wall), with the bridge's data as cell data:

==================  =============  ==================================================
array               type           meaning
==================  =============  ==================================================
``volume``          Float64        liquid volume of the bridge (SI: m^3)
``force``           Float64 x 3    capillary force on the first end (SI: N); given as
                                   a magnitude, it is written as ``force_magnitude``
                                   only
``force_magnitude`` Float64        its norm (always written)
``status``          Int32          :class:`capbridge.status.Status` code (0 converged,
                                   1 ruptured, 4 coalesced, ...)
``cluster``         Int32          cluster id (optional; -1: in no cluster)
any ``extra``       Float64/Int32  more per-bridge arrays (gap, pressure, ...)
==================  =============  ==================================================

Clusters (liquid bodies bridging several grains) are a separate point set: one vertex
per cluster at its centroid, with point data ``volume``, ``n_grains``, ``cluster``.

Two formats, chosen by the file's suffix: ``.vtp`` (VTK XML PolyData, ASCII; ParaView's
native format) or ``.vtk`` (legacy ASCII, version 3.0, readable by every VTK tool), both
written and read by :mod:`capbridge.vtk_io` (shared with the solvers' liquid surfaces).
Floats are written as Python's shortest round-trip repr, so reading a file back
gives the arrays bit for bit.  :class:`BridgeVTKRecorder` writes one file per call and a ParaView
collection (``.pvd``) indexing them by time, so ParaView opens a run as a time series.

Units are whatever the caller passes (the engine passes SI); VTK files carry no units,
so the title (a comment in ``.vtp``, the header line in ``.vtk``) states them.

Nothing is overwritten unless ``overwrite=True``: an existing file is an error naming it.
Non-finite values are refused (a NaN force in ParaView would be a silent wrong number).

References
----------
VTK file formats (legacy and XML), Kitware, https://docs.vtk.org/en/latest/design_documents/VTKFileFormats.html
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from capbridge.validation import CapbridgeInputError
from capbridge.vtk_io import (check_array_name, check_vtk_path, checked_array, read_vtk,
                              write_collection, write_polydata)

__all__ = ["write_bridges", "write_clusters", "read_vtk", "write_collection",
           "BridgeVTKRecorder"]

DEFAULT_TITLE = "capbridge liquid bridges (units as given; the engine writes SI: m, m^3, N)"


# --------------------------------------------------------------------------------------
# Input checks (each array named as the caller passed it; the file itself is checked
# again by capbridge.vtk_io.write_polydata)
# --------------------------------------------------------------------------------------


def _same_length(n, arrays):
    for name, a in arrays.items():
        if a.shape[0] != n:
            raise CapbridgeInputError(f"{name} has {a.shape[0]} entries; expected {n} "
                                      "(one per bridge or cluster)")


def _extra_arrays(extra, n, reserved):
    """Extra per-item arrays, Float64 or Int32 by their dtype, checked."""
    out = {}
    for name, value in (extra or {}).items():
        check_array_name(name, "extra array name")
        if name in reserved:
            raise CapbridgeInputError(f"extra array name {name!r} is reserved "
                                      f"(reserved: {', '.join(sorted(reserved))})")
        a = np.asarray(value)
        shape = (None,) if a.ndim <= 1 else (None, a.shape[1])
        kind = int if np.issubdtype(a.dtype, np.integer) else float
        out[name] = checked_array(f"extra[{name!r}]", a, shape, kind)
    _same_length(n, out)
    return out


# --------------------------------------------------------------------------------------
# Writers
# --------------------------------------------------------------------------------------


def write_bridges(path, ends, volume, force, status, cluster=None, *, extra=None,
                  title=DEFAULT_TITLE, overwrite=False):
    """Write bridges as VTK line cells with their data (``.vtp`` or ``.vtk``).

    Parameters
    ----------
    path : str or Path
        Output file; the suffix chooses the format (``.vtp`` XML, ``.vtk`` legacy).
    ends : array_like, shape (N, 2, 3)
        The two ends of every bridge: grain centres, or the contact point on a wall
        (SI: m).
    volume : array_like, shape (N,)
        Liquid volume per bridge (SI: m^3).
    force : array_like, shape (N, 3) or (N,)
        Capillary force on the first end (vector, SI: N), or its magnitude.
    status : array_like of int, shape (N,)
        :class:`capbridge.status.Status` codes.
    cluster : array_like of int, shape (N,), optional
        Cluster id of every bridge (-1: none).
    extra : dict of name -> array (N,) or (N, k), optional
        More cell arrays (integer dtype -> Int32, else Float64).
    title : str
        One line describing the file (units); a comment in ``.vtp``, the header in ``.vtk``.
    overwrite : bool
        Replace an existing file (default: refuse).

    Returns
    -------
    Path of the file written.
    """
    path = check_vtk_path(path, overwrite)
    ends = checked_array("ends", ends, (None, 2, 3))
    n = ends.shape[0]
    force = np.asarray(force)
    cells = {"volume": checked_array("volume", volume, (None,))}
    if force.ndim == 2:
        cells["force"] = checked_array("force", force, (None, 3))
        cells["force_magnitude"] = np.linalg.norm(cells["force"], axis=1)
    else:
        cells["force_magnitude"] = checked_array("force", force, (None,))
    cells["status"] = checked_array("status", status, (None,), int)
    if cluster is not None:
        cells["cluster"] = checked_array("cluster", cluster, (None,), int)
    _same_length(n, cells)
    cells |= _extra_arrays(extra, n, set(cells) | {"force"})
    points = ends.reshape(2 * n, 3)
    conn = np.arange(2 * n, dtype=np.int64).reshape(n, 2)
    write_polydata(path, points, conn, "lines", cell_data=cells, title=title,
                   overwrite=overwrite)
    return path


def write_clusters(path, centroid, volume, n_grains, cluster=None, *, extra=None,
                   title=DEFAULT_TITLE, overwrite=False):
    """Write liquid clusters as VTK vertices at their centroids, with point data.

    Parameters
    ----------
    path : str or Path
        ``.vtp`` or ``.vtk``.
    centroid : array_like, shape (M, 3)
        Centroid of every cluster (SI: m).
    volume : array_like, shape (M,)
        Liquid volume of every cluster (SI: m^3).
    n_grains : array_like of int, shape (M,)
        Number of grains the cluster wets.
    cluster : array_like of int, shape (M,), optional
        Cluster ids (default 0 .. M-1), matching the bridges' ``cluster`` array.
    extra, title, overwrite
        As in :func:`write_bridges` (``extra`` arrays are point data here).

    Returns
    -------
    Path of the file written.
    """
    path = check_vtk_path(path, overwrite)
    centroid = checked_array("centroid", centroid, (None, 3))
    m = centroid.shape[0]
    pts = {"volume": checked_array("volume", volume, (None,)),
           "n_grains": checked_array("n_grains", n_grains, (None,), int),
           "cluster": (checked_array("cluster", cluster, (None,), int) if cluster is not None
                       else np.arange(m, dtype=np.int32))}
    _same_length(m, pts)
    pts |= _extra_arrays(extra, m, set(pts))
    write_polydata(path, centroid, np.arange(m), "verts", point_data=pts, title=title,
                   overwrite=overwrite)
    return path


# --------------------------------------------------------------------------------------
# Recorder: one file per call and a .pvd time series
# --------------------------------------------------------------------------------------


class BridgeVTKRecorder:
    """Write the bridges (and clusters) of successive steps, and a ParaView time series.

    Each :meth:`record` writes ``<prefix>_bridges_<step>.vtp`` (and, with clusters,
    ``<prefix>_clusters_<step>.vtp``) in ``directory`` and rewrites
    ``<prefix>_bridges.pvd`` (``<prefix>_clusters.pvd``) listing every file written so
    far by time: open the ``.pvd`` in ParaView.  Like YADE's ``VTKRecorder`` it is
    called from a ``PyRunner`` (or by the engine every N steps).

    Parameters
    ----------
    directory : str or Path
        Output folder (created if missing).
    prefix : str
        File name prefix.
    fmt : {"vtp", "vtk"}
        File format of the per-step files.
    overwrite : bool
        Replace files of an earlier run with the same prefix (default: refuse, naming
        the first such file).
    """

    def __init__(self, directory, prefix="capbridge", fmt="vtp", overwrite=False):
        if fmt not in ("vtp", "vtk"):
            raise CapbridgeInputError(f"fmt={fmt!r} is not one of 'vtp', 'vtk'")
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prefix, self.fmt, self.overwrite = prefix, fmt, bool(overwrite)
        self.series = {"bridges": [], "clusters": []}
        if not self.overwrite:
            old = sorted(self.directory.glob(f"{prefix}_bridges*")) + sorted(
                self.directory.glob(f"{prefix}_clusters*"))
            if old:
                raise FileExistsError(f"{old[0]} exists from an earlier run; choose another "
                                      "prefix or directory, or pass overwrite=True")

    def _file(self, what, step):
        return self.directory / f"{self.prefix}_{what}_{int(step):09d}.{self.fmt}"

    def record(self, step, time, ends, volume, force, status, cluster=None, *, extra=None,
               clusters=None, title=DEFAULT_TITLE):
        """Write the bridges of one step (arguments as :func:`write_bridges`).

        ``clusters``: optional dict with the keys of :func:`write_clusters`
        (``centroid``, ``volume``, ``n_grains`` [, ``cluster``]).  ``time`` [s] is the
        time stamp in the ``.pvd``.  Returns the list of files written.
        """
        written = [write_bridges(self._file("bridges", step), ends, volume, force, status,
                                 cluster, extra=extra, title=title, overwrite=self.overwrite)]
        self.series["bridges"].append((time, written[0]))
        if clusters is not None:
            written.append(write_clusters(self._file("clusters", step), title=title,
                                          overwrite=self.overwrite, **clusters))
            self.series["clusters"].append((time, written[1]))
        for what, entries in self.series.items():
            if entries:
                write_collection(self.directory / f"{self.prefix}_{what}.pvd", entries,
                                 overwrite=True)     # the recorder's own index, rewritten
        return written
