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
native format) or ``.vtk`` (legacy ASCII, version 3.0, readable by every VTK tool).
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

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from capbridge.validation import CapbridgeInputError

__all__ = ["write_bridges", "write_clusters", "read_vtk", "write_collection",
           "BridgeVTKRecorder"]

DEFAULT_TITLE = "capbridge liquid bridges (units as given; the engine writes SI: m, m^3, N)"
_FORMATS = (".vtp", ".vtk")

# numpy dtype kind -> (XML type name, legacy type name, dtype written)
_FLOAT = ("Float64", "double", np.float64)
_INT = ("Int32", "int", np.int32)
_XML_TO_DTYPE = {"Float64": np.float64, "Float32": np.float32, "Int32": np.int32,
                 "Int64": np.int64, "Int8": np.int8, "UInt8": np.uint8, "UInt64": np.uint64}
_LEGACY_TO_DTYPE = {"double": np.float64, "float": np.float32, "int": np.int32,
                    "long": np.int64, "vtkIdType": np.int64, "char": np.int8,
                    "unsigned_char": np.uint8}


# --------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------


def _array(name, value, shape, kind=float):
    """``value`` as an array of the given trailing shape ((N,) or (N, k)), finite.

    ``shape`` uses None for the free leading length.  Raises CapbridgeInputError with
    one line naming the array, its shape and the expected one.
    """
    a = np.asarray(value)
    want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
    if a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape)):
        raise CapbridgeInputError(f"{name} has shape {a.shape}; expected {want}")
    if kind is int:
        if a.size and not np.issubdtype(a.dtype, np.integer):
            if not np.all(np.isfinite(a)) or np.any(a != np.round(a)):
                raise CapbridgeInputError(f"{name} must hold integers, got {a.ravel()[:3]}...")
        if a.size and (a.min() < np.iinfo(np.int32).min or a.max() > np.iinfo(np.int32).max):
            raise CapbridgeInputError(f"{name} values must fit in a 32-bit integer")
        return a.astype(np.int32)
    try:
        a = a.astype(np.float64)
    except (TypeError, ValueError):
        raise CapbridgeInputError(f"{name} must be numeric, got dtype {a.dtype}") from None
    bad = ~np.isfinite(a)
    if bad.any():
        raise CapbridgeInputError(f"{name} has {int(bad.sum())} non-finite value(s) "
                                  f"(first at index {np.argwhere(bad)[0].tolist()}); "
                                  "VTK output needs finite numbers")
    return a


def _same_length(n, arrays):
    for name, a in arrays.items():
        if a.shape[0] != n:
            raise CapbridgeInputError(f"{name} has {a.shape[0]} entries; expected {n} "
                                      "(one per bridge or cluster)")


def _extra_arrays(extra, n, reserved):
    """Extra per-item arrays, Float64 or Int32 by their dtype, checked."""
    out = {}
    for name, value in (extra or {}).items():
        if not isinstance(name, str) or not name or any(c.isspace() for c in name):
            raise CapbridgeInputError(f"extra array name {name!r} must be a non-empty "
                                      "string without spaces")
        if name in reserved:
            raise CapbridgeInputError(f"extra array name {name!r} is reserved "
                                      f"(reserved: {', '.join(sorted(reserved))})")
        a = np.asarray(value)
        shape = (None,) if a.ndim <= 1 else (None, a.shape[1])
        kind = int if np.issubdtype(a.dtype, np.integer) else float
        out[name] = _array(f"extra[{name!r}]", a, shape, kind)
    _same_length(n, out)
    return out


def _target(path, overwrite):
    """Checked output path: a known suffix, an existing folder, no silent overwrite."""
    path = Path(path)
    if path.suffix not in _FORMATS:
        raise CapbridgeInputError(f"VTK file name {str(path)!r} must end in .vtp (XML) "
                                  "or .vtk (legacy)")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
    if not path.parent.is_dir():
        raise CapbridgeInputError(f"folder {str(path.parent)!r} for the VTK file does not exist")
    return path


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
    path = _target(path, overwrite)
    ends = _array("ends", ends, (None, 2, 3))
    n = ends.shape[0]
    force = np.asarray(force)
    cells = {"volume": _array("volume", volume, (None,))}
    if force.ndim == 2:
        cells["force"] = _array("force", force, (None, 3))
        cells["force_magnitude"] = np.linalg.norm(cells["force"], axis=1)
    else:
        cells["force_magnitude"] = _array("force", force, (None,))
    cells["status"] = _array("status", status, (None,), int)
    if cluster is not None:
        cells["cluster"] = _array("cluster", cluster, (None,), int)
    _same_length(n, cells)
    cells |= _extra_arrays(extra, n, set(cells) | {"force"})
    points = ends.reshape(2 * n, 3)
    conn = np.arange(2 * n, dtype=np.int64).reshape(n, 2)
    _write(path, points, "lines", conn, cells, {}, title)
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
    path = _target(path, overwrite)
    centroid = _array("centroid", centroid, (None, 3))
    m = centroid.shape[0]
    pts = {"volume": _array("volume", volume, (None,)),
           "n_grains": _array("n_grains", n_grains, (None,), int),
           "cluster": (_array("cluster", cluster, (None,), int) if cluster is not None
                       else np.arange(m, dtype=np.int32))}
    _same_length(m, pts)
    pts |= _extra_arrays(extra, m, set(pts))
    _write(path, centroid, "verts", np.arange(m, dtype=np.int64)[:, None], {}, pts, title)
    return path


def _types(a):
    return _INT if np.issubdtype(a.dtype, np.integer) else _FLOAT


def _text(a, per_line):
    """Whitespace-separated numbers, ``per_line`` per line; floats by Python's shortest
    round-trip repr (exact when read back), 3-4x faster than ``np.savetxt``."""
    a = np.asarray(a)
    if not a.size:
        return ""
    vals = list(map(repr if a.dtype.kind == "f" else str, a.ravel().tolist()))
    return "\n".join(map(" ".join, zip(*[iter(vals)] * per_line))) + "\n"


def _write(path, points, kind, conn, cell_data, point_data, title):
    """Write the file atomically (a temporary file renamed), so that a reader never sees
    half a file and a failed write leaves nothing behind."""
    text = (_xml if path.suffix == ".vtp" else _legacy)(points, kind, conn, cell_data,
                                                         point_data, title)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _xml_array(name, a, indent):
    typ = _types(a)[0]
    ncomp = 1 if a.ndim == 1 else a.shape[1]
    head = (f'{indent}<DataArray type="{typ}" Name="{name}" NumberOfComponents="{ncomp}" '
            f'format="ascii">\n')
    return head + _text(a, ncomp) + f"{indent}</DataArray>\n"


def _xml(points, kind, conn, cell_data, point_data, title):
    n_cells, per = conn.shape
    counts = {"verts": 0, "lines": 0}
    counts[kind] = n_cells
    comment = title.replace("--", "- -")       # "--" is not allowed inside an XML comment
    out = ['<?xml version="1.0"?>\n', f"<!-- {comment} -->\n",
           '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" '
           'header_type="UInt64">\n', "  <PolyData>\n",
           f'    <Piece NumberOfPoints="{points.shape[0]}" NumberOfVerts="{counts["verts"]}" '
           f'NumberOfLines="{counts["lines"]}" NumberOfStrips="0" NumberOfPolys="0">\n',
           "      <Points>\n", _xml_array("Points", points, "        "), "      </Points>\n"]
    for section, data in (("PointData", point_data), ("CellData", cell_data)):
        if data:
            out.append(f"      <{section}>\n")
            out += [_xml_array(k, v, "        ") for k, v in data.items()]
            out.append(f"      </{section}>\n")
    tag = "Verts" if kind == "verts" else "Lines"
    out += [f"      <{tag}>\n",
            '        <DataArray type="Int64" Name="connectivity" format="ascii">\n',
            _text(conn.ravel(), per), "        </DataArray>\n",
            '        <DataArray type="Int64" Name="offsets" format="ascii">\n',
            _text(per * np.arange(1, n_cells + 1), 1), "        </DataArray>\n",
            f"      </{tag}>\n", "    </Piece>\n", "  </PolyData>\n", "</VTKFile>\n"]
    return "".join(out)


def _legacy_arrays(data):
    """Arrays as one FIELD block: every VTK reader loads all of them (separate SCALARS
    blocks are read only up to the first unless the reader is told otherwise)."""
    out = [f"FIELD attributes {len(data)}\n"]
    for name, a in data.items():
        ncomp = 1 if a.ndim == 1 else a.shape[1]
        out += [f"{name} {ncomp} {a.shape[0]} {_types(a)[1]}\n", _text(a, ncomp)]
    return out


def _legacy(points, kind, conn, cell_data, point_data, title):
    n_cells, per = conn.shape
    tag = "VERTICES" if kind == "verts" else "LINES"
    cells = np.hstack([np.full((n_cells, 1), per), conn])
    out = ["# vtk DataFile Version 3.0\n", title.replace("\n", " ")[:255] + "\n", "ASCII\n",
           "DATASET POLYDATA\n", f"POINTS {points.shape[0]} double\n", _text(points, 3),
           f"{tag} {n_cells} {cells.size}\n", _text(cells, per + 1)]
    # sections of zero length are left out (VTK's legacy reader rejects them)
    if cell_data and n_cells:
        out += [f"CELL_DATA {n_cells}\n"] + _legacy_arrays(cell_data)
    if point_data and points.shape[0]:
        out += [f"POINT_DATA {points.shape[0]}\n"] + _legacy_arrays(point_data)
    return "".join(out)


def write_collection(path, entries, *, overwrite=False):
    """Write a ParaView collection (``.pvd``) listing VTK files by time.

    ``entries``: iterable of (time, file) pairs; file paths are stored relative to the
    collection's folder.  ParaView opens the ``.pvd`` as a time series.
    """
    path = Path(path)
    if path.suffix != ".pvd":
        raise CapbridgeInputError(f"collection file name {str(path)!r} must end in .pvd")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, f in entries:
        t = float(_array("time", t, ()))
        rel = os.path.relpath(Path(f), path.parent)
        ET.SubElement(coll, "DataSet", timestep=repr(t), group="", part="0", file=rel)
    ET.indent(root)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


# --------------------------------------------------------------------------------------
# Reader (the files this module writes: ASCII PolyData with vertices or lines)
# --------------------------------------------------------------------------------------


def read_vtk(path):
    """Read a PolyData file written by this module back into numpy arrays.

    Returns a dict: ``points`` (P, 3), ``lines`` (L, 2) and ``verts`` (V,) point
    indices, ``cell_data`` and ``point_data`` (dicts name -> array), ``title``.
    Handles ASCII ``.vtp`` and legacy ASCII ``.vtk`` files with vertex or two-point
    line cells (not every VTK file: binary and appended encodings are not read).
    """
    path = Path(path)
    if path.suffix == ".vtp":
        return _read_xml(path)
    if path.suffix == ".vtk":
        return _read_legacy(path)
    raise CapbridgeInputError(f"cannot read {str(path)!r}: expected a .vtp or .vtk file")


def _numbers(text, dtype):
    return np.array(text.split(), dtype=np.float64 if np.issubdtype(dtype, np.floating)
                    else np.int64).astype(dtype)


def _read_xml(path):
    text = path.read_text()
    root = ET.fromstring(text)
    piece = root.find("PolyData/Piece")
    if root.get("type") != "PolyData" or piece is None:
        raise CapbridgeInputError(f"{path} is not a VTK XML PolyData file")

    def arrays(node):
        out = {}
        for da in (node.findall("DataArray") if node is not None else []):
            if da.get("format", "ascii") != "ascii":
                raise CapbridgeInputError(f"{path}: only ASCII data arrays are read")
            a = _numbers(da.text or "", _XML_TO_DTYPE[da.get("type")])
            ncomp = int(da.get("NumberOfComponents", "1"))
            out[da.get("Name")] = a.reshape(-1, ncomp) if ncomp > 1 else a
        return out

    points = arrays(piece.find("Points"))
    pts = next(iter(points.values())) if points else np.empty((0, 3))
    out = {"points": pts.reshape(-1, 3), "lines": np.empty((0, 2), np.int64),
           "verts": np.empty(0, np.int64), "cell_data": arrays(piece.find("CellData")),
           "point_data": arrays(piece.find("PointData")),
           "title": _xml_comment(text)}
    for tag, key in (("Lines", "lines"), ("Verts", "verts")):
        node = piece.find(tag)
        if node is not None:
            c = arrays(node)
            out[key] = _cells(c["connectivity"], c["offsets"], key, path)
    return out


def _xml_comment(text):
    i, j = text.find("<!--"), text.find("-->")
    return text[i + 4:j].strip() if 0 <= i < j else ""


def _cells(conn, offsets, key, path):
    """Connectivity of fixed-size cells (2 points per line, 1 per vertex)."""
    per = 2 if key == "lines" else 1
    if offsets.size and np.any(np.diff(np.concatenate([[0], offsets])) != per):
        raise CapbridgeInputError(f"{path}: only {per}-point {key} are read")
    return conn.reshape(-1, 2) if per == 2 else conn.ravel()


def _read_legacy(path):
    lines = path.read_text().splitlines()
    if not lines or not lines[0].startswith("# vtk DataFile") or lines[2].strip() != "ASCII":
        raise CapbridgeInputError(f"{path} is not a legacy ASCII VTK file")
    tokens = " ".join(lines[3:]).split()
    out = {"points": np.empty((0, 3)), "lines": np.empty((0, 2), np.int64),
           "verts": np.empty(0, np.int64), "cell_data": {}, "point_data": {},
           "title": lines[1]}
    i, section = 0, None

    def take(n, dtype):
        nonlocal i
        a = np.array(tokens[i:i + n], dtype=np.float64 if np.issubdtype(dtype, np.floating)
                     else np.int64).astype(dtype)
        i += n
        return a

    counts = {}
    while i < len(tokens):
        key = tokens[i]
        if key == "DATASET":
            i += 2
        elif key == "POINTS":
            n = int(tokens[i + 1])
            dtype = _LEGACY_TO_DTYPE[tokens[i + 2]]
            i += 3
            out["points"] = take(3 * n, dtype).astype(np.float64).reshape(n, 3)
        elif key in ("LINES", "VERTICES"):
            n, size = int(tokens[i + 1]), int(tokens[i + 2])
            i += 3
            raw = take(size, np.int64)
            per = 2 if key == "LINES" else 1
            rows = raw.reshape(n, per + 1) if n else raw.reshape(0, per + 1)
            if n and np.any(rows[:, 0] != per):
                raise CapbridgeInputError(f"{path}: only {per}-point cells are read")
            out["lines" if per == 2 else "verts"] = rows[:, 1:] if per == 2 else rows[:, 1]
        elif key in ("CELL_DATA", "POINT_DATA"):
            section = "cell_data" if key == "CELL_DATA" else "point_data"
            counts[section] = int(tokens[i + 1])
            i += 2
        elif key == "FIELD":
            n_arrays = int(tokens[i + 2])
            i += 3
            for _ in range(n_arrays):
                name, ncomp, ntup = tokens[i], int(tokens[i + 1]), int(tokens[i + 2])
                dtype = _LEGACY_TO_DTYPE[tokens[i + 3]]
                i += 4
                a = take(ncomp * ntup, dtype)
                out[section][name] = a.reshape(ntup, ncomp) if ncomp > 1 else a
        else:
            raise CapbridgeInputError(f"{path}: unexpected keyword {key!r} in a legacy VTK file")
    return out


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
