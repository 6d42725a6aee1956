"""The suction-controlled doublet table YADE's files are written from (:class:`SuctionTable`).

Pure numpy, in capbridge's convention (the smaller radius r normalises everything); its
checks are the constraints of YADE's two file formats (suction >= 0, a gap axis that
starts at 0 for the ``M(r=...)`` files, only converged points exported).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from capbridge.status import Status


@dataclasses.dataclass
class SuctionTable:
    """Suction-controlled doublet solutions on a grid, in capbridge's convention.

    Grid axes (1-D, strictly increasing):

    ``ratio``   R2/R1 >= 1 (R1 = r, the smaller radius, normalises everything)
    ``suction`` s* = -P* = (p_gas - p_liquid) r / gamma >= 0
    ``gap``     d* = d / r >= 0 (must start at 0 for the M(r=...) files)

    Values, shape ``(len(ratio), len(suction), len(gap))``:

    ``volume`` V* = V / r^3;  ``force`` F* = F / (2 pi gamma r), attraction > 0;
    ``beta1``, ``beta2`` half filling angles [deg] on the smaller / larger sphere;
    ``status`` (:class:`capbridge.status.Status`, 0 = converged; only converged points
    are exported); optional ``area`` (liquid-gas area / r^2), ``nn11``, ``nn33``
    (/ r^2).  ``theta`` is the contact angle [deg] of the whole table.

    Optional ``edge``: bridges *at rupture* (the end of the stable branch at fixed
    suction), a dict of arrays of shape ``(len(ratio), n)`` (NaN = no point) with keys
    ``suction``, ``gap``, ``volume``, ``force``, ``beta1``, ``beta2`` (and ``area``).
    Points whose gap is a gap of the grid end that gap's block of the ``M(r=...)``
    file at the exact suction where the bridge ruptures, so YADE's Law2 keeps bridges
    up to the grid gap just past rupture instead of cutting them at the next tabulated
    suction; points whose suction is a grid suction end that line of the
    ``CapillarityEngine`` file at the exact rupture gap.  :func:`export_from_solver`
    computes both kinds.  Without them, a bridge near rupture loses its force early
    (Law2: from the rupture gap of the next tabulated suction on).
    """

    ratio: np.ndarray
    suction: np.ndarray
    gap: np.ndarray
    volume: np.ndarray
    force: np.ndarray
    beta1: np.ndarray
    beta2: np.ndarray
    status: np.ndarray | None = None
    theta: float | None = None
    area: np.ndarray | None = None
    nn11: np.ndarray | None = None
    nn33: np.ndarray | None = None
    edge: dict | None = None
    attrs: dict = dataclasses.field(default_factory=dict)

    EDGE_KEYS = ("suction", "gap", "volume", "force", "beta1", "beta2")

    _VALUES = ("volume", "force", "beta1", "beta2", "area", "nn11", "nn33")

    def __post_init__(self):
        for name in ("ratio", "suction", "gap"):
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                raise ValueError(f"SuctionTable.{name} must be a non-empty finite 1-D array")
            if arr.size > 1 and np.any(np.diff(arr) <= 0):
                raise ValueError(f"SuctionTable.{name} must be strictly increasing")
            setattr(self, name, arr)
        if self.ratio[0] < 1.0:
            raise ValueError(f"ratio = R2/R1 must be >= 1 (got {self.ratio[0]:g})")
        if self.suction[0] < 0.0:
            raise ValueError(f"suction must be >= 0 (got {self.suction[0]:g}); YADE's "
                             "engines only take u_gas - u_liquid >= 0")
        if self.gap[0] < 0.0:
            raise ValueError(f"gap must be >= 0 (got {self.gap[0]:g})")
        shape = self.shape
        for name in self._VALUES:
            val = getattr(self, name)
            if val is None:
                continue
            arr = np.broadcast_to(np.asarray(val, dtype=float), shape).copy()
            setattr(self, name, arr)
        finite = (np.isfinite(self.force) & np.isfinite(self.volume)
                  & np.isfinite(self.beta1) & np.isfinite(self.beta2))
        if self.status is None:
            self.status = np.where(finite, int(Status.CONVERGED), int(Status.RUPTURED))
        self.status = np.broadcast_to(np.asarray(self.status, dtype=int), shape).copy()
        conv = self.status == int(Status.CONVERGED)
        if np.any(conv & ~finite):
            raise ValueError("converged points must have finite force, volume, beta1, beta2")
        if np.any(conv & ~(self.volume > 0)):
            raise ValueError("converged points must have a positive volume")
        for name in ("area", "nn11", "nn33"):
            val = getattr(self, name)
            if val is not None and np.any(conv & ~np.isfinite(val)):
                raise ValueError(f"{name} is given but not finite at every converged point")
        if self.edge is not None:
            edge = {k: np.atleast_2d(np.asarray(v, dtype=float)) for k, v in self.edge.items()}
            missing = [k for k in self.EDGE_KEYS if k not in edge]
            if missing:
                raise ValueError(f"edge lacks {missing}")
            n = edge["suction"].shape
            if n[0] != self.ratio.size or any(v.shape != n for v in edge.values()):
                raise ValueError("edge arrays must all have shape (len(ratio), n)")
            ok = np.all([np.isfinite(edge[k]) for k in self.EDGE_KEYS], axis=0)
            if "area" in edge:
                ok &= np.isfinite(edge["area"])
            for k in edge:                      # a point is all there or not at all
                edge[k] = np.where(ok, edge[k], np.nan)
            if np.any(ok & ~((edge["volume"] > 0) & (edge["suction"] >= 0) & (edge["gap"] >= 0))):
                raise ValueError("edge points need volume > 0, suction >= 0, gap >= 0")
            self.edge = edge

    def edge_points(self, ratio_index):
        """Finite rupture points of one ratio: dict of 1-D arrays (empty if none)."""
        if self.edge is None:
            return {k: np.empty(0) for k in self.EDGE_KEYS}
        ok = np.isfinite(self.edge["suction"][ratio_index])
        return {k: v[ratio_index][ok] for k, v in self.edge.items()}

    @property
    def shape(self):
        return (self.ratio.size, self.suction.size, self.gap.size)

    @property
    def converged(self):
        """Boolean mask of the points that are exported."""
        return self.status == int(Status.CONVERGED)

    def ratio_index(self, ratio, rtol=1e-9):
        """Index of ``ratio`` on the ratio axis, or ``None``."""
        hit = np.flatnonzero(np.isclose(self.ratio, ratio, rtol=rtol, atol=0.0))
        return int(hit[0]) if hit.size else None

    @classmethod
    def from_dataset(cls, ds, theta=None):
        """Build from an xarray Dataset with dims ``ratio``, ``suction`` (or ``pressure``,
        then suction = -pressure) and ``gap`` and variables named as the fields."""
        pdim = "suction" if "suction" in ds.dims else "pressure"
        sign = 1.0 if pdim == "suction" else -1.0
        ds = ds.transpose("ratio", pdim, "gap", ...)
        suction = sign * np.asarray(ds[pdim].values, float)
        order = np.argsort(suction)

        def get(name):
            if name not in ds:
                return None
            return np.asarray(ds[name].values)[:, order, :]

        return cls(ratio=ds["ratio"].values, suction=suction[order], gap=ds["gap"].values,
                   volume=get("volume"), force=get("force"), beta1=get("beta1"),
                   beta2=get("beta2"), status=get("status"), area=get("area"),
                   nn11=get("nn11"), nn33=get("nn33"),
                   theta=theta if theta is not None else ds.attrs.get("theta"),
                   attrs=dict(ds.attrs))


def as_suction_table(solutions, theta=None):
    """``solutions`` as a :class:`SuctionTable`: a table, an xarray Dataset
    (:meth:`SuctionTable.from_dataset`) or a dict of its fields."""
    if isinstance(solutions, SuctionTable):
        return solutions
    if hasattr(solutions, "data_vars") and hasattr(solutions, "dims"):
        return SuctionTable.from_dataset(solutions, theta=theta)
    if isinstance(solutions, dict):
        return SuctionTable(**solutions)
    raise TypeError("solutions must be a SuctionTable, an xarray Dataset or a dict of its fields")
