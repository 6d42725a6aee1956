"""Surrogates fitted on a table file given by its path.

A missing file is one :class:`~capbridge.validation.CapbridgeInputError` line saying
which command makes it (not a traceback from the netCDF reader), and the triplet
surrogate gets the shipped coalescence volumes when no other are given and they exist
(its V*_coal between the table's nodes is then an order of magnitude more accurate:
:meth:`TripletSurrogate.fit <capbridge.surrogate.triplet.TripletSurrogate.fit>`).
"""
from __future__ import annotations

from pathlib import Path

from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.surrogate.triplet import TripletSurrogate
from capbridge.tables import COALESCENCE_TABLE, DOUBLET_TABLE, TRIPLET_TABLE
from capbridge.validation import CapbridgeInputError


def load_doublet_surrogate(path=DOUBLET_TABLE, out_of_range="raise",
                           clip_hint="out_of_range='clip'"):
    """A :class:`~capbridge.surrogate.doublet.DoubletSurrogate` fitted on the doublet
    table at ``path`` (default the shipped one).

    ``out_of_range`` and ``clip_hint`` are the surrogate's settings (``clip_hint``: how
    the caller's user asks for clipping, named in the message of a value outside the
    table).  Raises :class:`~capbridge.validation.CapbridgeInputError` if the file does
    not exist.
    """
    path = Path(path)
    if not path.exists():
        raise CapbridgeInputError(f"table {path} not found; make it with `capbridge "
                                  "generate doublet`")
    return DoubletSurrogate(out_of_range=out_of_range, clip_hint=clip_hint).fit(path)


def load_triplet_surrogate(path=TRIPLET_TABLE, coalescence_table=None, out_of_range="raise",
                           clip_hint="out_of_range='clip'"):
    """A :class:`~capbridge.surrogate.triplet.TripletSurrogate` fitted on the triplet
    table at ``path`` (default the shipped one) with the coalescence volumes of
    ``coalescence_table`` (default the shipped ones, if they exist).

    ``out_of_range`` and ``clip_hint`` as for :func:`load_doublet_surrogate`.  Raises
    :class:`~capbridge.validation.CapbridgeInputError` if the triplet table does not
    exist.
    """
    path = Path(path)
    if not path.exists():
        raise CapbridgeInputError(f"triplet table {path} not found; make it with "
                                  "`capbridge generate triplet`")
    if coalescence_table is None:
        coalescence_table = default_coalescence_table(path)
    return TripletSurrogate(method="auto", out_of_range=out_of_range,
                            clip_hint=clip_hint).fit(
        path, coalescence_table=coalescence_table)


def default_coalescence_table(triplet_table, candidate=COALESCENCE_TABLE):
    """The coalescence table a triplet table is fitted with when none is given:
    ``candidate`` (the shipped one) if it exists and its gap and angle axes cover the
    triplet table's, else None (the surrogate then interpolates the triplet table's own
    V*_coal nodes; e.g. the packings grid's open side reaches 0.6, the shipped
    coalescence table's gaps 0.3)."""
    import xarray as xr

    candidate = Path(candidate)
    if not candidate.exists():
        return None
    with xr.open_dataset(triplet_table) as t, xr.open_dataset(candidate) as c:
        covers = all(float(c[a].min()) <= float(t[b].min()) + 1e-12
                     and float(c[a].max()) >= float(t[b].max()) - 1e-12
                     for a, b in (("d12", "d12"), ("theta", "theta")))
    return candidate if covers else None
