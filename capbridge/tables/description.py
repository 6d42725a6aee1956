"""What a table says about itself, as JSON-friendly dicts.

Provenance (the command and the commit that made it), how its checksum was verified,
its axes, how many points ended in each status, the error model stored with it, and
for the two tables whose points are costly, the cost and the estimated error of each
point.  The surrogates' ``summary()`` gathers these for the table it was fitted on
(:mod:`capbridge.surrogate.base`), and ``capbridge info`` prints them; nothing here
reads more than the Dataset in hand.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from capbridge.status import HAS_RESULT, Status, status_in, status_name
from capbridge.tables.netcdf_io import checksum_state

#: prefixes of the attributes that hold a table's stored error model: held-out
#: checks (doublet, triplet) and the interpolation error (coalescence volumes)
ERROR_MODEL_PREFIXES = ("holdout_", "interpolation_error")


def json_friendly(value):
    """A table attribute as plain Python: arrays to lists, numpy scalars to Python
    numbers; anything else unchanged."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def describe_axes(ds: xr.Dataset, names) -> dict:
    """``{name: {n, min, max, long_name}}`` of the coordinates ``names``."""
    out = {}
    for name in names:
        c = np.asarray(ds[name].values)
        out[str(name)] = {"n": int(c.size), "min": float(c.min()), "max": float(c.max()),
                          "long_name": str(ds[name].attrs.get("long_name", ""))}
    return out


def describe_table(ds: xr.Dataset, axes=None) -> dict:
    """What a table read by :func:`~capbridge.tables.netcdf_io.read_table` says about
    itself.

    Parameters
    ----------
    ds : xarray.Dataset
        The table.
    axes : sequence of str, optional
        The coordinates to describe (default: every dimension with a coordinate).

    Returns
    -------
    dict
        ``title``; ``command`` (the capbridge command that made it, None if not
        recorded); ``git_commit``; ``checksum`` (how it was verified:
        :func:`~capbridge.tables.netcdf_io.checksum_state`); ``axes``
        (:func:`describe_axes`); ``statuses`` ({status name: points}, in the order of
        the codes; empty without a ``status`` variable); ``error_model`` (the
        attributes named by :data:`ERROR_MODEL_PREFIXES`, plain Python).
    """
    if axes is None:
        axes = [d for d in ds.dims if d in ds.coords]
    statuses = {}
    if "status" in ds:
        codes, counts = np.unique(np.asarray(ds["status"].values), return_counts=True)
        statuses = {status_name(c): int(n) for c, n in zip(codes, counts)}
    return {"title": str(ds.attrs.get("title", "")),
            "command": ds.attrs.get("capbridge_command"),
            "git_commit": ds.attrs.get("git_commit", "not recorded"),
            "checksum": checksum_state(ds), "axes": describe_axes(ds, axes),
            "statuses": statuses,
            "error_model": {k: json_friendly(v) for k, v in ds.attrs.items()
                            if k.startswith(ERROR_MODEL_PREFIXES)}}


def describe_evolver_points(ds: xr.Dataset) -> dict:
    """Cost and estimated error of the Surface Evolver points of a table (the triplet
    table): ``settings`` (the ``evolver_settings`` attribute), and over the points with
    a result (CONVERGED or ABOVE_TOLERANCE) ``cpu_time_median`` [CPU s],
    ``force_error_rel_median``, ``force_error_rel_max`` and ``force_error_max`` (the
    largest absolute estimate, F*: relative estimates explode where a body barely
    pulls) (None without such points)."""
    st = np.asarray(ds["status"].values)
    ok = status_in(st, (Status.CONVERGED, Status.ABOVE_TOLERANCE))
    out = {"settings": ds.attrs.get("evolver_settings"), "cpu_time_median": None,
           "force_error_rel_median": None, "force_error_rel_max": None,
           "force_error_max": None}
    if ok.any():
        err = np.asarray(ds["force_error_rel"].values)[ok]
        out.update(cpu_time_median=float(np.median(np.asarray(ds["cpu_time"].values)[ok])),
                   force_error_rel_median=float(np.nanmedian(err)),
                   force_error_rel_max=float(np.nanmax(err)),
                   force_error_max=float(np.nanmax(np.asarray(ds["force_error"].values)[ok])))
    return out


def describe_doublet_gravity(ds: xr.Dataset, names) -> dict:
    """The gravity response stored in a doublet table
    (:mod:`capbridge.tables.doublet_gravity`).

    Parameters
    ----------
    ds : xarray.Dataset
        A doublet table with a gravity response.
    names : sequence of str
        The response's variables to describe (those absent from ``ds`` are skipped).

    Returns
    -------
    dict
        ``arrays`` ({name: {dims: {dim: size}, long_name}}); ``grids`` ({dim: values}
        of the response's own axes, ``gravity_*`` and ``rupture_*``);
        ``response_points`` (``total``, ``with_result``, ``above_tolerance`` of
        ``gravity_status``; None without it); ``holdout`` (the held-out check with
        gravity: the ``gravity_holdout_*`` attributes without their prefix, one value
        per Bond number of ``bonds``; None without one); ``settings`` (the other
        attributes of the response).
    """
    names = [n for n in names if n in ds]
    arrays = {n: {"dims": {str(d): int(ds.sizes[d]) for d in ds[n].dims},
                  "long_name": str(ds[n].attrs.get("long_name", ""))} for n in names}
    grids = {str(d): json_friendly(np.asarray(ds[d].values))
             for d in sorted({d for n in names for d in ds[n].dims})
             if str(d).startswith(("gravity_", "rupture_")) and d in ds.coords}
    points = None
    if "gravity_status" in ds:
        st = np.asarray(ds["gravity_status"].values)
        points = {"total": int(st.size),
                  "with_result": int(status_in(st, HAS_RESULT).sum()),
                  "above_tolerance": int((st == Status.ABOVE_TOLERANCE).sum())}
    prefix = "gravity_holdout_"
    holdout = {k[len(prefix):]: json_friendly(v) for k, v in ds.attrs.items()
               if k.startswith(prefix)} or None
    settings = {k: json_friendly(v) for k, v in ds.attrs.items()
                if "gravity" in k and not k.startswith(prefix)}
    return {"arrays": arrays, "grids": grids, "response_points": points,
            "holdout": holdout, "settings": settings}
