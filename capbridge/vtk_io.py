"""VTK PolyData files for ParaView, written and read with numpy only.

Every VTK file capbridge writes goes through this module: the DEM's bridges (line
cells) and clusters (vertices), :mod:`capbridge.dem.vtk_output`, and the minimised
liquid surfaces of the solvers (triangles), :mod:`capbridge.solvers.shapes`.  One file
holds points, cells of one kind (``"verts"``: one point each, ``"lines"``: two,
``"polys"``: polygons of a fixed number of points, three for triangles), and named
cell and point data arrays (Float64, or Int32 for integer input; one or more
components).

Two formats, chosen by the file's suffix: ``.vtp`` (VTK XML PolyData, ASCII; ParaView's
native format) or ``.vtk`` (legacy ASCII, version 3.0, readable by every VTK tool).
Floats are written as Python's shortest round-trip repr, so reading a file back gives
the arrays bit for bit.  VTK files carry no units: the title (a comment in ``.vtp``,
the header line in ``.vtk``, cut at 255 characters there) states them.

Nothing is overwritten unless ``overwrite=True``: an existing file is an error naming
it.  Non-finite values are refused (a NaN force in ParaView would be a silent wrong
number).  Files are written to a temporary name and renamed, so a reader never sees
half a file and a failed write leaves nothing behind.

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

__all__ = ["FORMATS", "CELL_KINDS", "write_polydata", "read_vtk", "write_collection",
           "checked_array", "check_array_name", "check_vtk_path"]

#: file suffixes written and read: XML PolyData, legacy
FORMATS = (".vtp", ".vtk")
#: cell kinds: points per cell (polygons: any fixed number >= 3, one per file)
CELL_KINDS = {"verts": 1, "lines": 2, "polys": 3}

# numpy dtype kind -> (XML type name, legacy type name, dtype written)
_FLOAT = ("Float64", "double", np.float64)
_INT = ("Int32", "int", np.int32)
_XML_TO_DTYPE = {"Float64": np.float64, "Float32": np.float32, "Int32": np.int32,
                 "Int64": np.int64, "Int8": np.int8, "UInt8": np.uint8, "UInt64": np.uint64}
_LEGACY_TO_DTYPE = {"double": np.float64, "float": np.float32, "int": np.int32,
                    "long": np.int64, "vtkIdType": np.int64, "char": np.int8,
                    "unsigned_char": np.uint8}
# section names of each cell kind: XML element, legacy keyword
_XML_TAG = {"verts": "Verts", "lines": "Lines", "polys": "Polys"}
_LEGACY_TAG = {"verts": "VERTICES", "lines": "LINES", "polys": "POLYGONS"}


# --------------------------------------------------------------------------------------
# Input checks (public: the writers built on this module check their own arrays first,
# so that a message names the user's argument, not an internal array)
# --------------------------------------------------------------------------------------


def checked_array(name, value, shape, kind=float):
    """``value`` as a finite array of the given shape ((N,), (N, k), ...).

    Parameters
    ----------
    name : str
        Name of the argument, used in the message.
    value : array_like
    shape : tuple
        Expected shape; None for a free length (e.g. ``(None, 3)``).
    kind : {float, int}
        float: returned as float64, non-finite values refused; int: integral values
        that fit in 32 bits, returned as int32.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    CapbridgeInputError
        One line naming the array, its shape and the expected one, or its first
        offending value.
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


def check_array_name(name, what="array name"):
    """Refuse a data array name VTK's readers would split (empty, or with white space)."""
    if not isinstance(name, str) or not name or any(c.isspace() for c in name):
        raise CapbridgeInputError(f"{what} {name!r} must be a non-empty string without "
                                  "spaces")
    return name


def check_vtk_path(path, overwrite=False, flag="overwrite=True"):
    """Checked output path: a known suffix, an existing folder, no silent overwrite.

    Parameters
    ----------
    path : str or Path
        ``.vtp`` or ``.vtk`` file to be written.
    overwrite : bool
        Accept an existing file (it will be replaced).
    flag : str
        How the caller asks for a replacement, named in the message (the command line
        passes its option).

    Returns
    -------
    Path

    Raises
    ------
    CapbridgeInputError
        Unknown suffix, or a folder that does not exist.
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    """
    path = Path(path)
    if path.suffix not in FORMATS:
        raise CapbridgeInputError(f"VTK file name {str(path)!r} must end in .vtp (XML) "
                                  "or .vtk (legacy)")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass {flag} to replace it")
    if not path.parent.is_dir():
        raise CapbridgeInputError(f"folder {str(path.parent)!r} for the VTK file does not exist")
    return path


def _data_arrays(data, n, where):
    """Named data arrays, checked: one entry per point or per cell, finite, typed."""
    out = {}
    for name, value in (data or {}).items():
        check_array_name(name, f"{where} array name")
        a = np.asarray(value)
        kind = int if np.issubdtype(a.dtype, np.integer) else float
        shape = (n,) if a.ndim <= 1 else (n, a.shape[1])
        out[name] = checked_array(f"{where} array {name!r}", a, shape, kind)
    return out


def _connectivity(cells, kind, n_points):
    """Point indices of the cells, (C, per) int64, each in [0, n_points)."""
    if kind not in CELL_KINDS:
        raise CapbridgeInputError(f"cell kind {kind!r} is not one of "
                                  f"{', '.join(map(repr, CELL_KINDS))}")
    c = np.asarray(cells)
    if c.ndim == 1 and kind == "verts":
        c = c[:, None]
    per = CELL_KINDS[kind]
    if c.ndim != 2 or (c.shape[1] != per if kind != "polys" else c.shape[1] < per):
        raise CapbridgeInputError(f"{kind} cells have shape {c.shape}; expected (C, "
                                  f"{per}{' or more' if kind == 'polys' else ''})")
    if c.size and (not np.issubdtype(c.dtype, np.integer)
                   or c.min() < 0 or c.max() >= n_points):
        raise CapbridgeInputError(f"{kind} cells must hold point indices in [0, "
                                  f"{n_points - 1}]")
    return c.astype(np.int64)


# --------------------------------------------------------------------------------------
# Writers
# --------------------------------------------------------------------------------------


def write_polydata(path, points, cells, kind, *, cell_data=None, point_data=None,
                   title="", overwrite=False):
    """Write points, cells of one kind and their data as VTK PolyData.

    Parameters
    ----------
    path : str or Path
        Output file; the suffix chooses the format (``.vtp`` XML, ``.vtk`` legacy).
    points : array_like, shape (P, 3)
        Point coordinates (units as the caller states in ``title``).
    cells : array_like of int, shape (C, k)
        Point indices of every cell: k = 1 for ``"verts"`` (shape (C,) accepted), 2 for
        ``"lines"``, k >= 3 (the same for every cell) for ``"polys"``.  A triangle's
        points run counter-clockwise seen from the side its normal points to.
    kind : {"verts", "lines", "polys"}
    cell_data, point_data : dict of name -> array (C,) or (C, m), (P,) or (P, m), optional
        Integer arrays are written as Int32, the others as Float64.
    title : str
        One line describing the file and its units.
    overwrite : bool
        Replace an existing file (default: refuse).

    Returns
    -------
    Path of the file written.
    """
    path = check_vtk_path(path, overwrite)
    points = checked_array("points", points, (None, 3))
    conn = _connectivity(cells, kind, points.shape[0])
    cells_ = _data_arrays(cell_data, conn.shape[0], "cell data")
    points_ = _data_arrays(point_data, points.shape[0], "point data")
    text = (_xml if path.suffix == ".vtp" else _legacy)(points, kind, conn, cells_,
                                                         points_, str(title))
    _atomic(path, lambda tmp: tmp.write_text(text))
    return path


def _atomic(path, write):
    """``write(tmp)`` to a temporary file next to ``path``, then renamed to ``path``."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


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


def _xml_array(name, a, indent):
    typ = _types(a)[0]
    ncomp = 1 if a.ndim == 1 else a.shape[1]
    head = (f'{indent}<DataArray type="{typ}" Name="{name}" NumberOfComponents="{ncomp}" '
            f'format="ascii">\n')
    return head + _text(a, ncomp) + f"{indent}</DataArray>\n"


def _xml(points, kind, conn, cell_data, point_data, title):
    n_cells, per = conn.shape
    counts = dict.fromkeys(CELL_KINDS, 0)
    counts[kind] = n_cells
    comment = title.replace("--", "- -")       # "--" is not allowed inside an XML comment
    out = ['<?xml version="1.0"?>\n', f"<!-- {comment} -->\n",
           '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" '
           'header_type="UInt64">\n', "  <PolyData>\n",
           f'    <Piece NumberOfPoints="{points.shape[0]}" NumberOfVerts="{counts["verts"]}" '
           f'NumberOfLines="{counts["lines"]}" NumberOfStrips="0" '
           f'NumberOfPolys="{counts["polys"]}">\n',
           "      <Points>\n", _xml_array("Points", points, "        "), "      </Points>\n"]
    for section, data in (("PointData", point_data), ("CellData", cell_data)):
        if data:
            out.append(f"      <{section}>\n")
            out += [_xml_array(k, v, "        ") for k, v in data.items()]
            out.append(f"      </{section}>\n")
    tag = _XML_TAG[kind]
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
    cells = np.hstack([np.full((n_cells, 1), per), conn])
    out = ["# vtk DataFile Version 3.0\n", title.replace("\n", " ")[:255] + "\n", "ASCII\n",
           "DATASET POLYDATA\n", f"POINTS {points.shape[0]} double\n", _text(points, 3),
           f"{_LEGACY_TAG[kind]} {n_cells} {cells.size}\n", _text(cells, per + 1)]
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
        t = float(checked_array("time", t, ()))
        rel = os.path.relpath(Path(f), path.parent)
        ET.SubElement(coll, "DataSet", timestep=repr(t), group="", part="0", file=rel)
    ET.indent(root)
    _atomic(path, lambda tmp: ET.ElementTree(root).write(tmp, xml_declaration=True,
                                                         encoding="utf-8"))
    return path


# --------------------------------------------------------------------------------------
# Reader (the files this module writes: ASCII PolyData, one fixed cell size per kind)
# --------------------------------------------------------------------------------------


def read_vtk(path):
    """Read a PolyData file written by this module back into numpy arrays.

    Parameters
    ----------
    path : str or Path
        ASCII ``.vtp`` or legacy ASCII ``.vtk`` file.

    Returns
    -------
    dict
        ``points`` (P, 3); point indices ``verts`` (V,), ``lines`` (L, 2) and ``polys``
        (C, k) (empty when the file has none); ``cell_data`` and ``point_data`` (dicts
        name -> array); ``title``.

    Notes
    -----
    Not every VTK file: binary and appended encodings, triangle strips and polygons of
    mixed sizes are not read (each is refused with a message).
    """
    path = Path(path)
    if path.suffix == ".vtp":
        return _read_xml(path)
    if path.suffix == ".vtk":
        return _read_legacy(path)
    raise CapbridgeInputError(f"cannot read {str(path)!r}: expected a .vtp or .vtk file")


def _empty(title):
    return {"points": np.empty((0, 3)), "verts": np.empty(0, np.int64),
            "lines": np.empty((0, 2), np.int64), "polys": np.empty((0, 3), np.int64),
            "cell_data": {}, "point_data": {}, "title": title}


def _numbers(text, dtype):
    return np.array(text.split(), dtype=np.float64 if np.issubdtype(dtype, np.floating)
                    else np.int64).astype(dtype)


def _fixed_cells(key, sizes, conn, path):
    """Connectivity of cells of one size: (V,) vertices, (L, 2) lines, (C, k) polygons."""
    per = CELL_KINDS[key]
    if sizes.size and (np.any(sizes != sizes[0]) or (sizes[0] != per and key != "polys")
                       or sizes[0] < per):
        raise CapbridgeInputError(f"{path}: only {key} of one fixed size "
                                  f"({per}{' or more' if key == 'polys' else ''} points) "
                                  "are read")
    k = int(sizes[0]) if sizes.size else per
    rows = conn.reshape(-1, k)
    return rows[:, 0] if key == "verts" else rows


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

    out = _empty(_xml_comment(text))
    points = arrays(piece.find("Points"))
    if points:
        out["points"] = next(iter(points.values())).reshape(-1, 3)
    out["cell_data"] = arrays(piece.find("CellData"))
    out["point_data"] = arrays(piece.find("PointData"))
    if int(piece.get("NumberOfStrips", "0")):
        raise CapbridgeInputError(f"{path}: triangle strips are not read")
    for key, tag in _XML_TAG.items():
        node = piece.find(tag)
        if node is not None:
            c = arrays(node)
            sizes = np.diff(np.concatenate([[0], c["offsets"]]))
            out[key] = _fixed_cells(key, sizes, c["connectivity"], path)
    return out


def _xml_comment(text):
    i, j = text.find("<!--"), text.find("-->")
    return text[i + 4:j].strip() if 0 <= i < j else ""


def _read_legacy(path):
    lines = path.read_text().splitlines()
    if (len(lines) < 3 or not lines[0].startswith("# vtk DataFile")
            or lines[2].strip() != "ASCII"):
        raise CapbridgeInputError(f"{path} is not a legacy ASCII VTK file")
    tokens = " ".join(lines[3:]).split()
    out = _empty(lines[1])
    kinds = {tag: key for key, tag in _LEGACY_TAG.items()}
    i, section = 0, None

    def take(n, dtype):
        nonlocal i
        a = np.array(tokens[i:i + n], dtype=np.float64 if np.issubdtype(dtype, np.floating)
                     else np.int64).astype(dtype)
        i += n
        return a

    while i < len(tokens):
        key = tokens[i]
        if key == "DATASET":
            i += 2
        elif key == "POINTS":
            n = int(tokens[i + 1])
            dtype = _LEGACY_TO_DTYPE[tokens[i + 2]]
            i += 3
            out["points"] = take(3 * n, dtype).astype(np.float64).reshape(n, 3)
        elif key in kinds:
            n, size = int(tokens[i + 1]), int(tokens[i + 2])
            i += 3
            raw = take(size, np.int64)
            # every row is "k p1 .. pk"; rows of one size k only (see the Notes)
            k = int(raw[0]) if n else CELL_KINDS[kinds[key]]
            if n * (k + 1) != size:
                raise CapbridgeInputError(f"{path}: only {kinds[key]} of one fixed size "
                                          "are read")
            rows = raw.reshape(n, k + 1)
            out[kinds[key]] = _fixed_cells(kinds[key], rows[:, 0], rows[:, 1:], path)
        elif key in ("CELL_DATA", "POINT_DATA"):
            section = "cell_data" if key == "CELL_DATA" else "point_data"
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
