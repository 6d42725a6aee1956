"""Writing and reading capbridge tables as CF-1.8 netCDF files.

Every table is an :class:`xarray.Dataset` whose variables and coordinates all carry
``units`` and ``long_name``; the file records how it was made in global attributes:
``Conventions``, ``title``, ``institution``, ``source``, ``history``, ``date_created``,
``capbridge_version``, ``capbridge_command`` (absolute local paths reduced to file
names), ``solver_settings`` (a JSON string; :func:`table_solver_settings` decodes it),
``git_commit`` (of the capbridge source, ``+dirty`` if modified), ``library_versions``
(JSON), ``grid`` (JSON: the values of every dimension coordinate), ``data_sha256`` (a checksum
of every variable's values, as older capbridge versions wrote it) and ``table_sha256``,
a checksum of everything that gives the numbers their meaning: every variable's name,
dimensions, values and attributes (units, long names, flags) and every global
attribute but itself (error model, grid, provenance).  :func:`read_table` verifies
both; a table edited by hand or by another tool is refused, not used.  ``table_sha256``
is computed from the file as read back (so that the netCDF round trip of attribute
types cannot break it) and added to the temporary file before the atomic replace.

A file without ``table_sha256`` (older capbridge, or a checksum deleted) is
*unverified*: :func:`read_table` refuses it unless the caller allows it explicitly
(``allow_unverified=True``, or inside :func:`allow_unverified_tables`; the command line's
``--allow-unverified-table``), and then logs one warning line.  Whatever the checksum,
a table read from a file also goes through the checks of what its generator guarantees
(:mod:`capbridge.tables.checks`: units, physical bounds, sum rules, symmetry);
a Dataset built or edited in memory is the caller's (:func:`validate_table`).

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

import contextlib
import contextvars
import datetime as _dt
import hashlib
import logging
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
           "validate_table", "portable_command", "table_checksum", "TABLE_CHECKSUM",
           "allow_unverified_tables", "unverified_allowed", "checksum_state"]

CONVENTIONS = "CF-1.8"
REQUIRED_ATTRS = ("units", "long_name")
COMPLEVEL = 4
#: the global attribute holding :func:`table_checksum`
TABLE_CHECKSUM = "table_sha256"
#: the values-only checksum of older capbridge versions (still written and verified)
DATA_CHECKSUM = "data_sha256"
#: what turns the refusal of an unverified table off, named in messages
ALLOW_HINT = ("--allow-unverified-table on the command line, allow_unverified=True in "
              "Python")

log = logging.getLogger("capbridge.tables")
_ALLOW_UNVERIFIED = contextvars.ContextVar("capbridge_allow_unverified", default=False)
_WARNED = set()


# The checks of what each table's generator guarantees (capbridge.tables.checks, which
# needs the builders' schemas, which need this module) register here when
# capbridge.tables is imported: reading a file runs them without importing them.
_TABLE_CHECKS: list = []


def register_table_checks(check_table, table_kind):
    """Install the per-kind checks that :func:`read_table` runs on every file."""
    _TABLE_CHECKS[:] = [check_table, table_kind]


class TableError(CapbridgeInputError):
    """A table file that cannot be used: unreadable, foreign, damaged or edited."""


class TableExistsError(CapbridgeInputError):
    """Writing would replace an existing table of another grid."""


def capbridge_version() -> str:
    """The version of capbridge that writes the table."""
    return __version__


def is_status_variable(name: str, var: xr.DataArray) -> bool:
    """Whether a variable holds :class:`capbridge.status.Status` codes: by its name, or
    by CF flags that are the statuses' (a variable with flags of its own, such as a
    triplet table's ``failure`` kinds, keeps them)."""
    name = str(name)
    if name == "status" or name.endswith("_status") or name.startswith("status_"):
        return True
    if "flag_values" not in var.attrs:
        return False
    meanings = var.attrs.get("flag_meanings")
    return meanings is None or str(meanings) == cf_flag_attributes()["flag_meanings"]


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


def _canonical_attr(value):
    """An attribute value in a JSON form that does not depend on how it was stored."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if isinstance(value, str):
        return ["s", value]
    if isinstance(value, (np.ndarray, list, tuple)):
        a = np.asarray(value)
        if a.dtype.kind in "fiub":
            return ["a", a.dtype.kind, [_canonical_attr(x)[1] for x in a.ravel().tolist()]]
        return ["a", "s", [str(x) for x in a.ravel().tolist()]]
    if isinstance(value, (bool, np.bool_)):
        return ["i", int(value)]
    if isinstance(value, (int, np.integer)):
        return ["i", int(value)]
    if isinstance(value, (float, np.floating)):
        return ["f", float(value).hex()]
    return ["r", repr(value)]


def _attrs_text(attrs: Mapping) -> bytes:
    items = sorted((str(k), _canonical_attr(v)) for k, v in attrs.items())
    return json.dumps(items, separators=(",", ":")).encode()


def table_checksum(ds: xr.Dataset) -> str:
    """SHA-256 of the table as it means something: every variable and coordinate (name,
    dimensions, values, attributes) and every global attribute except ``table_sha256``
    itself.  A change of units, of the stored error model, of the grid or of the
    provenance changes it as a change of values does."""
    h = hashlib.sha256(b"capbridge table_sha256 v1\0")
    for name in sorted(map(str, ds.variables)):
        var = ds.variables[name]
        a = np.asarray(var.values)
        head = [name, [str(d) for d in var.dims], list(a.shape)]
        if a.dtype.kind in "fiub":
            c = _canonical(a)
            h.update(json.dumps(head + [c.dtype.str]).encode() + b"\0")
            h.update(c.tobytes())
        else:
            text = [str(x) for x in a.ravel().tolist()]
            h.update(json.dumps(head + ["text", text]).encode() + b"\0")
        h.update(_attrs_text(var.attrs) + b"\0")
    h.update(b"global\0" + _attrs_text({k: v for k, v in ds.attrs.items()
                                        if k != TABLE_CHECKSUM}))
    return h.hexdigest()


@contextlib.contextmanager
def allow_unverified_tables(allow: bool = True):
    """Within this block, tables without ``table_sha256`` are used (with one warning
    line each) where a loader is not told otherwise: what ``--allow-unverified-table``
    does for a whole command, e.g. around code that loads tables indirectly (the YADE
    engine)."""
    token = _ALLOW_UNVERIFIED.set(bool(allow))
    try:
        yield
    finally:
        _ALLOW_UNVERIFIED.reset(token)


def unverified_allowed(allow_unverified: bool | None = None) -> bool:
    """``allow_unverified`` if given, else whether :func:`allow_unverified_tables` is on."""
    return _ALLOW_UNVERIFIED.get() if allow_unverified is None else bool(allow_unverified)


def checksum_state(ds: xr.Dataset) -> str:
    """How a table read by :func:`read_table` was verified (for ``capbridge info``)."""
    if TABLE_CHECKSUM in ds.attrs:
        return "verified (values and attributes, table_sha256)"
    if DATA_CHECKSUM in ds.attrs:
        return ("NOT verified: values only (data_sha256 of older capbridge versions), "
                "units, error model and provenance unchecked; used because unverified "
                "tables were allowed")
    return "NOT verified: no checksum; used because unverified tables were allowed"


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
    attrs["grid"] = json.dumps({**_grid_settings(ds.attrs.get("grid")), **grid})
    for key, value in dict(extra_attrs or {}).items():
        attrs[str(key)] = value
    attrs.pop(TABLE_CHECKSUM, None)            # added below, from the written file
    attrs[DATA_CHECKSUM] = data_checksum(ds)
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
        _add_table_checksum(tmp)
    return path


def _read_back(path) -> xr.Dataset:
    with xr.open_dataset(path, engine="netcdf4", cache=False) as back:
        return back.load()


def _add_table_checksum(tmp):
    """Compute :func:`table_checksum` from the file as read back and add it as a global
    attribute (nothing else in the file changes); checked once more after adding."""
    import netCDF4

    digest = table_checksum(_read_back(tmp))
    with netCDF4.Dataset(tmp, "r+") as nc:
        nc.setncattr(TABLE_CHECKSUM, digest)
    again = _read_back(tmp)
    if str(again.attrs.get(TABLE_CHECKSUM)) != digest or table_checksum(again) != digest:
        raise RuntimeError(f"{tmp}: the table checksum does not survive adding it to the "
                           "file (a bug: report it)")


def _increasing(values) -> bool:
    v = np.asarray(values)
    if v.ndim != 1 or v.dtype.kind not in "fiu":
        return v.ndim == 1
    v = v.astype(float)
    return bool(np.all(np.isfinite(v)) and np.all(np.diff(v) > 0))


def read_table(path, *, expect_units: Mapping[str, str] | None = None,
               verify: bool = True, allow_unverified: bool | None = None) -> xr.Dataset:
    """Open a capbridge table, load it into memory, close the file and validate it.

    Parameters
    ----------
    path : str or path-like
    expect_units : dict name -> units, optional
        Units the caller relies on (e.g. ``{"theta": "degree"}``); see
        :func:`validate_table`.
    verify : bool
        Check the checksums, coordinates, units, the ``grid`` attribute and what the
        table's generator guarantees (default; :func:`validate_table`).  ``False`` only
        identifies the file (used to compare grids before replacing it).
    allow_unverified : bool, optional
        Use a table without ``table_sha256`` (older capbridge, or a checksum deleted):
        one warning line instead of a refusal.  Default: refused, unless inside
        :func:`allow_unverified_tables` (``--allow-unverified-table``).  A checksum
        that is present and wrong is refused either way.

    Raises
    ------
    FileNotFoundError
        No such file.
    TableError
        (a ``ValueError``) naming the file when it is unreadable, truncated, not CF
        (``Conventions``), not written by capbridge (``capbridge_command``), fails
        :func:`validate_table`, or is unverified and not allowed.
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
        validate_table(ds, path, expect_units, file=True,
                       allow_unverified=allow_unverified)
    return ds


def validate_table(ds: xr.Dataset, source="table",
                   expect_units: Mapping[str, str] | None = None, *, file: bool = False,
                   allow_unverified: bool | None = None) -> xr.Dataset:
    """Refuse a table whose structure or data cannot be trusted.

    Checks, in this order: the checksums present (``table_sha256`` over values and
    attributes, ``data_sha256`` over values; a mismatch means an edited or damaged
    file); dimension coordinates finite and strictly increasing; ``units`` on every
    coordinate and variable; the units in ``expect_units`` (name -> units) where the
    variable exists.  For a file (``file=True``, as :func:`read_table` does): what the
    table's generator guarantees (:func:`capbridge.tables.checks.check_table`:
    the units of every variable the code reads, physical bounds, sum rules, symmetry),
    the ``grid`` attribute against the coordinates, and a table without
    ``table_sha256`` is refused unless ``allow_unverified`` (:func:`unverified_allowed`),
    then logged in one warning line.  A Dataset built or edited in memory
    (``file=False``: the surrogates' ``fit`` of a Dataset, the generators' own tables
    before they are written) is the caller's: it needs no checksum (one it carries is
    verified) and gets the structural checks only; it is checked in full once written
    and read back.

    Raises :class:`TableError` naming ``source`` and the first problem.
    """
    stored = ds.attrs.get(TABLE_CHECKSUM)
    if stored is not None and str(stored) != table_checksum(ds):
        raise TableError(f"{source}: table checksum mismatch (table_sha256): its values or "
                         f"attributes (units, error model, grid, provenance) were changed "
                         f"after the table was written (edited or damaged); regenerate it, "
                         f"or use the original file")
    stored = ds.attrs.get(DATA_CHECKSUM)
    if stored is not None and str(stored) != data_checksum(ds):
        raise TableError(f"{source}: data checksum mismatch: the values were changed after "
                         f"the table was written (edited or damaged); regenerate it")
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
    if file and _TABLE_CHECKS:
        try:
            _TABLE_CHECKS[0](ds, source)
        except TableError:
            raise
        except (KeyError, IndexError, ValueError, TypeError) as exc:
            # a layout no generator writes (odd dimensions, types): damaged, not a bug
            raise TableError(f"{source}: cannot be checked ({type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else ''}); the table "
                             f"is damaged or was not made by capbridge") from None
        _check_grid_attribute(ds, source)
        if TABLE_CHECKSUM not in ds.attrs:
            _unverified(ds, source, allow_unverified)
    return ds


def _grid_settings(text):
    """The scalar settings of a ``grid`` attribute (JSON), e.g. the triplet grid's
    ``max_bridge_gap`` (the part of the cube that was computed): kept when the axes
    are written from the coordinates; lists (axes, under any name) are not."""
    try:
        grid = json.loads(str(text))
    except (TypeError, ValueError):
        return {}
    if not isinstance(grid, dict):
        return {}
    return {k: v for k, v in grid.items() if isinstance(v, (int, float, str, bool))}


def _check_grid_attribute(ds, source):
    """The ``grid`` attribute (JSON, written by :func:`write_table` from the
    coordinates) must give every dimension it names the table's coordinate values.
    A ``grid`` that is not such a mapping (a caller's own ``extra_attrs``) is not
    compared."""
    try:
        grid = json.loads(str(ds.attrs.get("grid")))
    except ValueError:
        return
    if not isinstance(grid, dict):
        return
    axes = table_grid(ds)
    named = {k: v for k, v in grid.items() if k in axes}
    try:
        same = _same_grid(named, {k: axes[k] for k in named})
    except (TypeError, ValueError):
        same = False
    if not same:
        raise TableError(f"{source}: global attribute 'grid' does not match the table's "
                         f"coordinates ({_grid_summary(axes)} values): edited or damaged; "
                         f"regenerate it, or use the original file")


def _unverified(ds, source, allow_unverified):
    table_kind = _TABLE_CHECKS[1] if _TABLE_CHECKS else (lambda ds: None)
    what = ("only the values-only checksum data_sha256 of older capbridge versions"
            if DATA_CHECKSUM in ds.attrs else "no checksum at all")
    if not unverified_allowed(allow_unverified):
        raise TableError(
            f"{source}: unverified table: no table_sha256 ({what}), so its units, error "
            f"model and provenance cannot be checked; regenerate it with this capbridge "
            f"(`capbridge generate {table_kind(ds) or '...'}`), or use it anyway with "
            f"{ALLOW_HINT}")
    key = str(source)
    if key not in _WARNED:
        _WARNED.add(key)
        log.warning("%s: unverified table used (no table_sha256: %s; allowed explicitly); "
                    "its units, error model and provenance are not checked", source, what)


def table_solver_settings(ds: xr.Dataset) -> dict:
    """The ``solver_settings`` global attribute decoded from JSON (``{}`` if absent)."""
    text = ds.attrs.get("solver_settings")
    return json.loads(text) if text else {}
