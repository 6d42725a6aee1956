"""Writing and reading capbridge tables as CF-1.8 netCDF files.

Every table is an :class:`xarray.Dataset` whose variables and coordinates all carry
``units`` and ``long_name``; the file records how it was made in global attributes:
``Conventions``, ``title``, ``institution``, ``source``, ``history``, ``date_created``,
``capbridge_version``, ``capbridge_command`` (absolute local paths reduced to file
names), ``solver_settings`` (a JSON string; :func:`table_solver_settings` decodes it),
``git_commit`` (of the capbridge source, ``+dirty`` if modified), ``library_versions``
(JSON), ``grid`` (JSON: the values of every dimension coordinate) and
``data_sha256``, a checksum of every variable's values that :func:`read_table`
verifies: a table edited by hand or by another tool is refused, not used.

Coordinates carry no ``_FillValue`` (CF: coordinates have no missing values), and
:func:`read_table` checks that they are finite and strictly increasing and that every
variable has ``units``; a caller can also pass the units it expects (``expect_units``).
:func:`check_table_target` refuses to replace an existing table of another grid
unless ``overwrite=True``; :func:`write_table` applies it, and a command line checks it
before computing.

Status variables (named ``status``, ``*_status`` or ``status_*``, or carrying
``flag_values``) are stored as int8 with the CF flag attributes of
:func:`capbridge.status.cf_flag_attributes` (``units`` defaults to ``"1"``).
Floating-point variables are zlib-compressed (level 4).
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import shlex
import subprocess
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import xarray as xr

from capbridge.tables.atomic import atomic_target
from capbridge.version import __version__
from capbridge.status import Status, cf_flag_attributes
from capbridge.validation import CapbridgeInputError

__all__ = ["write_table", "read_table", "table_solver_settings", "capbridge_version",
           "is_status_variable", "REQUIRED_ATTRS", "CONVENTIONS", "TableError",
           "TableExistsError", "check_table_target", "data_checksum", "table_grid",
           "validate_table", "portable_command"]

CONVENTIONS = "CF-1.8"
REQUIRED_ATTRS = ("units", "long_name")
COMPLEVEL = 4


class TableError(CapbridgeInputError):
    """A table file that cannot be used: unreadable, foreign, damaged or edited."""


class TableExistsError(CapbridgeInputError):
    """Writing would replace an existing table of another grid."""


def capbridge_version() -> str:
    """The version of capbridge that writes the table."""
    return __version__


def is_status_variable(name: str, var: xr.DataArray) -> bool:
    """Whether a variable holds :class:`capbridge.status.Status` codes."""
    name = str(name)
    return (name == "status" or name.endswith("_status") or name.startswith("status_")
            or "flag_values" in var.attrs)


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (Path, _dt.date, _dt.datetime)):
        return str(obj)
    if isinstance(obj, (set, frozenset)):
        return sorted(obj)
    return repr(obj)


def _attr_value(value):
    """A value netCDF can store as an attribute (dicts and None become JSON text)."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (str, int, float, np.number, np.ndarray)):
        return value
    if isinstance(value, (list, tuple)) and all(
            isinstance(v, (int, float, np.number)) and not isinstance(v, bool)
            for v in value) and value:
        return np.asarray(value)
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, str) for v in value):
        return ", ".join(value)
    return json.dumps(value, sort_keys=True, default=_json_default)


def _utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat() \
        .replace("+00:00", "Z")


def _prepare_status(name, var: xr.DataArray) -> xr.DataArray:
    values = var.values
    if values.dtype.kind == "f":
        if np.isnan(values).any():
            raise ValueError(f"status variable {name!r} contains NaN; every point needs "
                             f"a status code (capbridge.status.Status)")
        if not np.array_equal(values, np.round(values)):
            raise ValueError(f"status variable {name!r} has non-integer values")
    elif values.dtype.kind not in "iub":
        raise ValueError(f"status variable {name!r} has dtype {values.dtype}; "
                         f"expected integer codes")
    codes = values.astype(np.int64)
    valid = np.array(sorted(int(s) for s in Status))
    bad = ~np.isin(codes, valid)
    if bad.any():
        raise ValueError(f"status variable {name!r} has codes outside "
                         f"capbridge.status.Status: {sorted(set(codes[bad].tolist()))}")
    out = var.copy(data=codes.astype(np.int8))
    flags = cf_flag_attributes()
    attrs = dict(var.attrs)
    attrs["flag_values"] = np.asarray(flags["flag_values"], dtype=np.int8)
    attrs["flag_meanings"] = flags["flag_meanings"]
    attrs.setdefault("long_name", flags["long_name"])
    attrs.setdefault("units", "1")
    out.attrs = attrs
    out.encoding = {}
    return out


def _git_commit() -> str:
    """Commit of the capbridge source tree (``+dirty`` if tracked files changed)."""
    src = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "-C", str(src), "rev-parse", "HEAD"],
                              capture_output=True, text=True, timeout=10)
        if head.returncode != 0:
            return "unknown (not a git checkout)"
        dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain",
                                "--untracked-files=no"],
                               capture_output=True, text=True, timeout=30)
        return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown (git not available)"


def _library_versions() -> dict:
    import platform
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "xarray", "netCDF4", "pandas"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "absent"
    return out


def portable_command(command: str) -> str:
    """``command`` with absolute local paths replaced by paths relative to the working
    directory (inside it) or by their file names (outside): the provenance of a table
    must not carry a user's directory layout."""
    try:
        words = shlex.split(command)
    except ValueError:
        words = command.split()
    cwd = Path.cwd()

    def fix(word):
        key, eq, value = word.partition("=") if word.startswith("-") else ("", "", word)
        if not os.path.isabs(value):
            return word
        p = Path(value)
        try:
            value = str(p.relative_to(cwd)) or "."
        except ValueError:
            value = p.name or "."
        return f"{key}{eq}{value}"

    return " ".join(shlex.quote(fix(w)) for w in words)


def _canonical(values: np.ndarray) -> np.ndarray:
    """Values in a byte form that survives a netCDF round trip (one NaN pattern)."""
    a = np.asarray(values)
    if a.dtype.kind == "f":
        a = a.astype(np.float64)
        a = np.where(np.isnan(a), np.nan, a)
    elif a.dtype.kind in "iub":
        a = a.astype(np.int64)
    return np.ascontiguousarray(a)


def data_checksum(ds: xr.Dataset) -> str:
    """SHA-256 of every numeric variable and coordinate (names, shapes, values)."""
    h = hashlib.sha256()
    for name in sorted(map(str, ds.variables)):
        a = ds[name].values
        if a.dtype.kind not in "fiub":
            continue
        c = _canonical(a)
        h.update(f"{name}\0{c.dtype.str}\0{c.shape}\0".encode())
        h.update(c.tobytes())
    return h.hexdigest()


def table_grid(ds: xr.Dataset) -> dict:
    """The dimension coordinates of a table as ``{name: [values]}``."""
    return {str(d): np.asarray(ds[d].values).tolist() for d in ds.dims if d in ds.coords}


def _same_grid(a: Mapping, b: Mapping) -> bool:
    if set(a) != set(b):
        return False
    for k in a:
        x, y = np.asarray(a[k], float), np.asarray(b[k], float)
        if x.shape != y.shape or not np.allclose(x, y, rtol=1e-12, atol=0.0):
            return False
    return True


def _grid_summary(grid: Mapping) -> str:
    return ", ".join(f"{k}: {len(v)}" for k, v in grid.items())


def check_table_target(path, grid: Mapping, *, overwrite: bool = False,
                       flag: str = "overwrite=True") -> Path:
    """Check that a table can be written to ``path``, before computing it.

    The directory must exist and accept files; ``path`` must not be a directory; an
    existing file is replaced only if it is a capbridge table of the same ``grid``
    (dimension -> coordinate values, see :func:`table_grid`) or if ``overwrite``.
    ``flag`` names the option that allows it in messages (e.g. ``--overwrite``).

    Raises
    ------
    CapbridgeInputError
        The directory is missing or not writable, or ``path`` is a directory.
    TableExistsError
        ``path`` holds something else (another grid, not a capbridge table).
    """
    from capbridge.tabular_io import check_output_path

    path = check_output_path(path, what="table")
    if overwrite or not path.exists():
        return path
    try:
        old = read_table(path, verify=False)
    except (TableError, OSError) as exc:
        raise TableExistsError(
            f"{path} exists and is not a readable capbridge table ({exc}); "
            f"give another output path, or {flag} to replace it") from None
    old_grid = table_grid(old)
    if not _same_grid(old_grid, grid):
        raise TableExistsError(
            f"{path} exists with another grid ({_grid_summary(old_grid)} values) than "
            f"this one ({_grid_summary(grid)}); give another output path, or {flag} "
            f"to replace it")
    return path


def write_table(ds: xr.Dataset, path, *, command: str, solver_settings: Mapping,
                extra_attrs: Mapping[str, Any] | None = None,
                overwrite: bool = False) -> Path:
    """Write a table to ``path`` as CF-1.8 netCDF-4, atomically.

    Parameters
    ----------
    ds : xarray.Dataset
        Every data variable and coordinate must have ``units`` and ``long_name``
        attributes (status variables get defaults, see the module docstring).
    path : str or path-like
        Destination; written to a temporary file in the same directory, then
        ``os.replace``-d, so readers never see a partial file.
    command : str
        The command that made the table (``capbridge_command`` and ``history``).
    solver_settings : dict
        Stored as the JSON string ``solver_settings``.
    extra_attrs : dict, optional
        Further global attributes (dicts/None are stored as JSON text).
    overwrite : bool
        Replace an existing file even if it is not a table of the same grid
        (:func:`check_table_target`; default False).

    Returns
    -------
    pathlib.Path
        ``path``.  ``ds`` itself is not modified.

    Raises
    ------
    ValueError
        Variables or coordinates lack ``units``/``long_name`` (all listed), or a status
        variable has codes outside :class:`capbridge.status.Status`.
    TableExistsError
        ``path`` holds another grid or another file, and ``overwrite`` is False.
    """
    if not isinstance(ds, xr.Dataset):
        raise TypeError(f"write_table expects an xarray.Dataset, got {type(ds).__name__}")
    if not isinstance(command, str) or not command.strip():
        raise ValueError("write_table needs the command that made the table")
    if not isinstance(solver_settings, Mapping):
        raise TypeError("solver_settings must be a dict")
    path = Path(path)

    ds = ds.copy(deep=False)
    for name in list(ds.variables):
        if is_status_variable(name, ds[name]):
            if name in ds.dims:
                raise ValueError(f"status variable {name!r} cannot be a dimension")
            ds[name] = _prepare_status(name, ds[name])

    missing = []
    for kind, names in (("coordinate", ds.coords), ("variable", ds.data_vars)):
        for name in names:
            lack = [a for a in REQUIRED_ATTRS
                    if not str(ds[name].attrs.get(a, "")).strip()]
            if lack:
                missing.append(f"{kind} {name!r}: {', '.join(lack)}")
    if missing:
        raise ValueError(f"cannot write {path}: missing CF attributes on "
                         + "; ".join(missing))

    bad_axes = [f"{d!r}" for d in ds.dims if d in ds.coords and not _increasing(ds[d].values)]
    if bad_axes:
        raise ValueError(f"cannot write {path}: coordinate(s) {', '.join(bad_axes)} must "
                         f"be finite and strictly increasing")
    grid = table_grid(ds)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CapbridgeInputError(f"cannot make the directory of {path}: "
                                  f"{exc.strerror or exc}") from None
    check_table_target(path, grid, overwrite=overwrite)
    command = portable_command(command)

    version = capbridge_version()
    now = _utc_now()
    attrs = dict(ds.attrs)
    attrs["Conventions"] = CONVENTIONS
    attrs.setdefault("title", f"capbridge table {path.stem}")
    attrs.setdefault("institution", f"capbridge {version}")
    attrs.setdefault("source", f"capbridge {version}")
    line = f"{now}: {command}"
    old = str(attrs.get("history", "")).strip()
    attrs["history"] = f"{line}\n{old}" if old else line
    attrs["capbridge_version"] = version
    attrs["capbridge_command"] = command
    attrs["solver_settings"] = json.dumps(dict(solver_settings), sort_keys=True,
                                          default=_json_default)
    attrs["date_created"] = now
    attrs["git_commit"] = _git_commit()
    attrs["library_versions"] = json.dumps(_library_versions(), sort_keys=True)
    attrs["grid"] = json.dumps(grid)
    for key, value in dict(extra_attrs or {}).items():
        attrs[str(key)] = value
    attrs["data_sha256"] = data_checksum(ds)
    ds.attrs = {k: _attr_value(v) for k, v in attrs.items()}

    encoding = {}
    for name, var in ds.variables.items():
        enc = {}
        if var.dtype.kind == "f":
            enc.update(zlib=True, complevel=COMPLEVEL)
        elif is_status_variable(name, var):
            enc.update(dtype="int8", _FillValue=None, zlib=True, complevel=COMPLEVEL)
        # drop stale on-disk encodings (e.g. from a table read back) except fill values
        keep = {k: v for k, v in var.encoding.items() if k in ("_FillValue",)}
        if name in ds.coords:
            keep["_FillValue"] = None   # CF: coordinates have no missing values
        encoding[name] = {**keep, **enc}

    with atomic_target(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4", encoding=encoding)
    return path


def _increasing(values) -> bool:
    v = np.asarray(values)
    if v.ndim != 1 or v.dtype.kind not in "fiu":
        return v.ndim == 1
    v = v.astype(float)
    return bool(np.all(np.isfinite(v)) and np.all(np.diff(v) > 0))


def read_table(path, *, expect_units: Mapping[str, str] | None = None,
               verify: bool = True) -> xr.Dataset:
    """Open a capbridge table, load it into memory, close the file and validate it.

    Parameters
    ----------
    path : str or path-like
    expect_units : dict name -> units, optional
        Units the caller relies on (e.g. ``{"theta": "degree"}``); see
        :func:`validate_table`.
    verify : bool
        Check coordinates, units and the data checksum (default).  ``False`` only
        identifies the file (used to compare grids before replacing it).

    Raises
    ------
    FileNotFoundError
        No such file.
    TableError
        (a ``ValueError``) naming the file when it is unreadable, truncated, not CF
        (``Conventions``), not written by capbridge (``capbridge_command``), or fails
        :func:`validate_table`.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"capbridge table {path} does not exist")
    if path.is_dir():
        raise TableError(f"{path} is a directory, not a capbridge table")
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = ds.load()
    except Exception as exc:
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise TableError(f"cannot read capbridge table {path}: {type(exc).__name__}: "
                         f"{first} (truncated, damaged or not netCDF)") from None
    conv = str(ds.attrs.get("Conventions", ""))
    if "CF-" not in conv:
        raise TableError(f"{path} is not a capbridge table: global attribute "
                         f"'Conventions' is {conv!r}, expected {CONVENTIONS!r}")
    if "capbridge_command" not in ds.attrs:
        raise TableError(f"{path} is not a capbridge table: no 'capbridge_command' "
                         f"global attribute (write tables with write_table)")
    if verify:
        validate_table(ds, path, expect_units)
    return ds


def validate_table(ds: xr.Dataset, source="table",
                   expect_units: Mapping[str, str] | None = None) -> xr.Dataset:
    """Refuse a table whose structure or data cannot be trusted.

    Checks: dimension coordinates finite and strictly increasing; ``units`` on every
    coordinate and variable; the units in ``expect_units`` (name -> units) where the
    variable exists; the ``data_sha256`` checksum when the file has one (tables
    written before it was introduced have none and are checked otherwise only).

    Raises :class:`TableError` naming ``source`` and the first problem.
    """
    for d in ds.dims:
        if d in ds.coords and not _increasing(ds[d].values):
            v = np.asarray(ds[d].values)
            raise TableError(f"{source}: coordinate {d!r} is not finite and strictly "
                             f"increasing ({v[:4].tolist()}...); the table is damaged "
                             f"or was not made by capbridge")
    no_units = [str(n) for n in ds.variables if not is_status_variable(n, ds[n])
                and not str(ds[n].attrs.get("units", "")).strip()]
    if no_units:
        raise TableError(f"{source}: no 'units' attribute on {sorted(no_units)}")
    for name, units in dict(expect_units or {}).items():
        if name in ds.variables and str(ds[name].attrs.get("units")) != units:
            raise TableError(f"{source}: {name!r} has units {ds[name].attrs.get('units')!r}, "
                             f"expected {units!r}; capbridge tables are dimensionless by "
                             f"R1 and gamma with angles in degrees")
    stored = ds.attrs.get("data_sha256")
    if stored is not None and str(stored) != data_checksum(ds):
        raise TableError(f"{source}: data checksum mismatch: the values were changed after "
                         f"the table was written (edited or damaged); regenerate it")
    return ds


def table_solver_settings(ds: xr.Dataset) -> dict:
    """The ``solver_settings`` global attribute decoded from JSON (``{}`` if absent)."""
    text = ds.attrs.get("solver_settings")
    return json.loads(text) if text else {}
