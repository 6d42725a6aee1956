"""Writing and reading capbridge tables as CF-1.8 netCDF files.

Every table is an :class:`xarray.Dataset` whose variables and coordinates all carry
``units`` and ``long_name``; the file records how it was made in global attributes:
``Conventions``, ``title``, ``institution``, ``source``, ``history``, ``date_created``,
``capbridge_version``, ``capbridge_command`` and ``solver_settings`` (a JSON string;
:func:`table_solver_settings` decodes it).

Status variables (named ``status``, ``*_status`` or ``status_*``, or carrying
``flag_values``) are stored as int8 with the CF flag attributes of
:func:`capbridge.status.cf_flag_attributes` (``units`` defaults to ``"1"``).
Floating-point variables are zlib-compressed (level 4).
"""
from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import xarray as xr

from capbridge.generator.atomic import atomic_target
from capbridge.status import Status, cf_flag_attributes

__all__ = ["write_table", "read_table", "table_solver_settings", "capbridge_version",
           "is_status_variable", "REQUIRED_ATTRS", "CONVENTIONS"]

CONVENTIONS = "CF-1.8"
REQUIRED_ATTRS = ("units", "long_name")
COMPLEVEL = 4


def capbridge_version() -> str:
    """``capbridge.__version__``, else the installed distribution's, else ``"0.1.0"``."""
    try:
        import capbridge

        v = getattr(capbridge, "__version__", None)
        if v:
            return str(v)
    except Exception:  # pragma: no cover - capbridge is importable here
        pass
    try:
        from importlib.metadata import version

        return version("capbridge")
    except Exception:
        return "0.1.0"


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


def write_table(ds: xr.Dataset, path, *, command: str, solver_settings: Mapping,
                extra_attrs: Mapping[str, Any] | None = None) -> Path:
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

    Returns
    -------
    pathlib.Path
        ``path``.  ``ds`` itself is not modified.

    Raises
    ------
    ValueError
        Variables or coordinates lack ``units``/``long_name`` (all listed), or a status
        variable has codes outside :class:`capbridge.status.Status`.
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
    for key, value in dict(extra_attrs or {}).items():
        attrs[str(key)] = value
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
        encoding[name] = {**keep, **enc}

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_target(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4", encoding=encoding)
    return path


def read_table(path) -> xr.Dataset:
    """Open a capbridge table, load it into memory and close the file.

    Raises ``FileNotFoundError`` or ``ValueError`` naming the file when it is missing,
    unreadable, not CF (``Conventions``) or not written by capbridge
    (``capbridge_command``).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"capbridge table {path} does not exist")
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = ds.load()
    except Exception as exc:
        raise ValueError(f"cannot read capbridge table {path}: "
                         f"{type(exc).__name__}: {exc}") from exc
    conv = str(ds.attrs.get("Conventions", ""))
    if "CF-" not in conv:
        raise ValueError(f"{path} is not a capbridge table: global attribute "
                         f"'Conventions' is {conv!r}, expected {CONVENTIONS!r}")
    if "capbridge_command" not in ds.attrs:
        raise ValueError(f"{path} is not a capbridge table: no 'capbridge_command' "
                         f"global attribute (write tables with write_table)")
    return ds


def table_solver_settings(ds: xr.Dataset) -> dict:
    """The ``solver_settings`` global attribute decoded from JSON (``{}`` if absent)."""
    text = ds.attrs.get("solver_settings")
    return json.loads(text) if text else {}
