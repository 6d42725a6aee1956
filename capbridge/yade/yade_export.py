"""Write capbridge's suction-controlled doublet tables in YADE's own input formats.

Two compiled YADE engines (2023.02a) read precomputed liquid-bridge solutions:

1. ``Law2_ScGeom_CapillaryPhys_Capillarity`` (with ``Ip2_FrictMat_FrictMat_CapillaryPhys``
   or the Mindlin variant) reads ten files ``M(r=1)``, ``M(r=1.1)``, ``M(r=1.25)``,
   ``M(r=1.5)``, ``M(r=1.75)``, ``M(r=2)``, ``M(r=3)``, ``M(r=4)``, ``M(r=5)``,
   ``M(r=10)``, each name followed by the engine's ``suffCapFiles`` string, opened
   relative to the working directory of the YADE process.  One set holds one contact
   angle; sets for several angles live side by side with different suffixes
   (:func:`theta_suffix`).  Written by :func:`write_capillary_files`.
2. ``CapillarityEngine`` (with ``Ip2_FrictMat_FrictMat_CapillaryPhysDelaunay``, physics
   ``CapillaryPhysDelaunay``) reads one unstructured file (attribute ``inputFilename``,
   default ``capillaryfile.txt``), triangulates it and interpolates linearly in the
   tetrahedra; with ``imposePressure=False`` it keeps the volume of every bridge
   constant.  Written by :func:`write_delaunay_file`.

Formats (read from YADE's source, pkg/dem/Law2_ScGeom_CapillaryPhys_Capillarity.cpp and
pkg/dem/CapillarityEngine.cpp, and checked by loading the files in YADE 2023.02a)
----------------------------------------------------------------------------------------
In both, lengths are scaled by the **larger** radius ``R`` of the pair (capbridge uses
the smaller one, ``r``; ``ratio = R/r``), and the capillary pressure is the suction
``uc = u_gas - u_liquid >= 0``.

``M(r=...)`` (read by ``Tableau``/``TableauD``, whitespace-separated)::

    line 1      the radius ratio R/r of the file (compared with the pair's R/r)
    line 2      n_D, the number of distance blocks that follow
    n_D blocks, by increasing distance, the first at D = 0:
      header    n_rows, then anything up to the end of the line (ignored; we write
                seven zeros, as Duriez's writesCapFile.m does)
      n_rows    D  P  V  F  delta1  delta2  nn11  nn33
                rows by increasing P; D is the same in every row of a block (YADE
                takes the block's distance from its last row)

with ``D = d/R``, ``P = uc R/gamma``, ``V = V/R^3``, ``F = F/(2 pi gamma R)`` (attraction
> 0), ``delta1``/``delta2`` the half filling angles on the smaller/larger sphere in
**degrees**, ``nn11``/``nn33`` the integrals of n_i n_j over the liquid-gas surface over
``R^2`` (only copied to ``CapillaryPhys.nn11/nn33``; capbridge writes 0 unless the table
has them).  YADE interpolates linearly in P within a block, then in D between the
blocks around the pair's distance, then in R/r between the two files around the pair's
ratio.  Beyond a block's largest P the block contributes zeros (so the force fades to
zero between the last block holding that P and the next one); beyond the last block
there is no bridge and the interaction is erased.  All ten files must exist (a missing
file leaves an uninitialised ratio in YADE, not an error); a block with no row makes
YADE crash, one with a single row gives no bridge.

``capillaryfile.txt`` (read by ``CapillarityEngine::triangulateData``): records of ten
whitespace-separated numbers, no header::

    succion  force  distance  volume  surface  arcLength  delta1  delta2  R  ending

with ``R = r/R`` in (0, 1] (the engine queries ``min/max`` radius), ``succion = uc R/gamma``,
``distance = d/R``, ``volume = V/R^3``, ``force = F/(gamma R)`` (no 2 pi here!),
``surface = (liquid-gas area + dry areas of both spheres)/R^2`` (the engine's
``SInterface``; it sets 4 pi (r^2 + R^2) when there is no bridge), ``arcLength``
(unused by the engine), ``delta1``/``delta2`` half filling angles (degrees, see
:data:`FORMAT_NOTES`), ``ending`` 1 for points that mark the end of the bridge domain.  The engine
triangulates the points (R, succion, distance) and (R, volume, distance); a query
outside the convex hull, or in a tetrahedron whose four vertices all have ``ending=1``,
gets no bridge.  capbridge therefore ends every (ratio, suction) line with one marker
point (force 0, ``ending=1``) just past its last bridge, and pads the hull (see
:func:`delaunay_records`).

Accuracy (measured in YADE with the exact solver's export, theta = 30 deg): at
tabulated ratios and suctions both engines reproduce the solver to 1e-4 up to 80 % of
the rupture gap; between tabulated suctions Law2 stays within 0.2 %, CapillarityEngine
within 0.5-3 % (its tetrahedra span neighbouring suctions and ratios in very
anisotropic coordinates).  Near rupture the force is resolved to one grid cell: Law2
fades it linearly to zero over the gap step that contains the rupture gap (with the
table's rupture points, :class:`SuctionTable` ``edge``; without them it drops bridges
already where the next tabulated suction ruptures).

Using the files in YADE (both engines read relative to the working directory)::

    os.chdir(export_dir)
    O.engines = [ForceResetter(),
                 InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=1.5)]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=1.5)],
                                 [Ip2_FrictMat_FrictMat_CapillaryPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)]),
                 Law2_ScGeom_CapillaryPhys_Capillarity(capillaryPressure=uc,  # Pa
                                                       surfaceTension=gamma,
                                                       suffCapFiles=theta_suffix(30)),
                 NewtonIntegrator()]

(or ``Ip2_FrictMat_FrictMat_CapillaryPhysDelaunay()`` and ``CapillarityEngine(
inputFilename="capillaryfile_theta30.txt", capillaryPressure=uc, liquidTension=gamma)``).
Bridges form at contact; ``createDistantMeniscii=True`` (one step) also wets the
pairs already within the detection range.  ``tests/yade_scenes/`` holds runnable scenes.

Uncertain points and YADE quirks are listed in :data:`FORMAT_NOTES`.
"""
from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np

from capbridge.status import Status
from capbridge.version import __version__

__all__ = [
    "YADE_RATIOS", "LAW2_COLUMNS", "DELAUNAY_COLUMNS", "FORMAT_NOTES",
    "SuctionTable", "synthetic_suction_table", "synthetic_bridge", "theta_suffix",
    "capillary_file_name",
    "to_yade_units", "from_yade_units",
    "capillary_file_blocks", "write_capillary_files", "read_capillary_file",
    "read_capillary_files", "law2_interpolate", "law2_force",
    "delaunay_records", "write_delaunay_file", "read_delaunay_file",
    "rupture_edge", "export_from_solver",
]

#: Radius ratios R/r of the ten files ``Law2_ScGeom_CapillaryPhys_Capillarity`` loads, in
#: the order it loads them (hard-coded in YADE's ``postLoad``).
YADE_RATIOS = (1.0, 1.1, 1.25, 1.5, 1.75, 2.0, 3.0, 4.0, 5.0, 10.0)

#: Columns of a row of an ``M(r=...)`` file.
LAW2_COLUMNS = ("D", "P", "V", "F", "delta1", "delta2", "nn11", "nn33")

#: Columns of a record of ``CapillarityEngine``'s input file, in file order.
DELAUNAY_COLUMNS = ("succion", "force", "distance", "volume", "surface", "arcLength",
                    "delta1", "delta2", "R", "ending")

#: What is not settled by YADE's source, and what capbridge chose.
FORMAT_NOTES = (
    "CapillarityEngine: delta1/delta2 units.  The engine compares (Delta1+Delta2)*DEG_TO_RAD "
    "with an angle in its fusion check (degrees) but takes cos(Delta) in swInterface/"
    "wnInterface (radians).  capbridge writes degrees (as the M(r=...) files), so fusion "
    "detection is right and those two diagnostics are not; angle_unit='rad' flips it.",
    "CapillarityEngine: 'surface' is taken as liquid-gas area plus the dry areas of both "
    "spheres, the only reading consistent with intEnergy/wnInterface and with the value "
    "4 pi (R1^2 + R2^2) the engine sets without a bridge.  0 is written when the table has "
    "no liquid-gas area (YADE skips SInterface == 0 in intEnergy/wnInterface).",
    "CapillarityEngine: the distance of an overlapping contact is negative and not "
    "clamped (unlike Law2, which uses D = max(D, 0)); capbridge copies the contact "
    "(gap 0) solutions to distance -overlap_pad so contacts keep their bridge.",
    "CapillarityEngine: the triangulation is static: one input file per YADE process "
    "(a second engine's file is ignored with a warning).",
    "nn11/nn33 (M files) and arcLength (Delaunay file) are not computed by capbridge's "
    "solver: 0 is written.",
    "Law2: within a distance block a suction above the block's largest tabulated suction "
    "gives no bridge, and YADE's P = uc R/gamma can round one ulp above the written value. "
    "At the table's largest suction this can drop bridges even at contact (YADE logs 'No "
    "meniscus found at a contact'): keep scene suctions strictly inside the table.",
    "CapillarityEngine, volume control (imposePressure=False): YADE 2023.02a keeps one "
    "cached tetrahedron (and its normals) per bridge for both triangulations and does not "
    "reset it when the engine switches from its first, pressure-based step to the "
    "volume-based ones, so bridges present at that switch are first looked up with a "
    "tetrahedron of the pressure triangulation (wrong force and suction until the walk "
    "relocates).  Bridges whose interaction is created after the switch are fine; the "
    "test scene re-creates the interaction (utils.createInteraction) before setting "
    "vMeniscus.",
)

_FLOAT_FMT = "%.15g"

#: End markers of the CapillarityEngine file sit this fraction of the local gap step
#: past a line's rupture point.  Hugging the rupture keeps the tetrahedra beyond it made
#: of markers only (checked in YADE: 0.02 leaves no force past rupture on the tested
#: lines, 0.1 leaves up to 12 % of the contact force, a whole step up to 65 %).
_MARKER_FRAC = 0.02


# ------------------------------------------------------------------------------------
# The table handed to the writers
# ------------------------------------------------------------------------------------


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


def _synthetic_fields(rr, ss, gg, theta):
    """The made-up smooth fields of :func:`synthetic_suction_table` (capbridge units)."""
    c = math.cos(math.radians(theta))
    a = 0.12 * (1.0 + 0.5 * np.log(rr)) * (0.6 + 0.4 * c)        # g_rupt = a (1 + 2/(1+0.2 s))
    g_rupt = a * (1.0 + 2.0 / (1.0 + 0.2 * ss))
    volume = 0.02 * rr**0.5 * (1.0 + 1.5 * gg) / (1.0 + 0.15 * ss) ** 1.2
    force = c * (1.0 + 0.04 * np.sqrt(ss)) * (1.0 + 0.3 * (1 - 1 / rr)) * (1.0 - 0.55 * gg / g_rupt)
    beta1 = (25.0 + 10.0 / (1.0 + 0.1 * ss)) * (1.0 - 0.3 * gg / g_rupt)
    return {"volume": volume, "force": force, "beta1": beta1, "beta2": beta1 / rr**0.7,
            "area": 0.5 * volume ** (2.0 / 3.0) * (1.0 + gg), "g_rupt": g_rupt, "a": a}


def synthetic_suction_table(ratios=YADE_RATIOS, suctions=None, gaps=None, theta=0.0,
                            edge=True):
    """A smooth, made-up table with the layout of a real one (for format tests only).

    Its numbers are *not* liquid-bridge solutions: smooth positive functions with a
    rupture gap g_rupt(ratio, suction) that shrinks with suction and grows with the
    radius ratio, so every code path of the writers (rupture inside the grid, all ten
    ratios, rupture points in ``edge``) is exercised.  Evaluate the same functions
    anywhere with :func:`synthetic_bridge`.
    """
    ratios = np.asarray(ratios, float)
    suctions = np.asarray(suctions if suctions is not None
                          else np.concatenate([[0.0], np.geomspace(0.05, 200.0, 24)]), float)
    gaps = np.asarray(gaps if gaps is not None else np.linspace(0.0, 0.8, 41), float)
    rr, ss, gg = np.meshgrid(ratios, suctions, gaps, indexing="ij")
    f = _synthetic_fields(rr, ss, gg, theta)
    status = np.where(gg <= f["g_rupt"], int(Status.CONVERGED), int(Status.RUPTURED))
    bad = status != int(Status.CONVERGED)
    for k in ("volume", "beta1", "beta2", "area"):
        f[k][bad] = np.nan
    f["force"][bad] = 0.0
    edge_pts = None
    if edge:
        # rupture at every grid suction (gap off the grid) ...
        r2, s2 = np.meshgrid(ratios, suctions, indexing="ij")
        g_a = _synthetic_fields(r2, s2, 0.0 * s2, theta)["g_rupt"]
        # ... and at every grid gap (suction off the grid), inside the suction range
        r3, g3 = np.meshgrid(ratios, gaps, indexing="ij")
        a = _synthetic_fields(r3, 0.0 * g3, g3, theta)["a"]
        with np.errstate(divide="ignore", invalid="ignore"):
            s_b = (2.0 / (g3 / a - 1.0) - 1.0) / 0.2
        s_b = np.where((g3 > a) & (s_b >= suctions[0]) & (s_b <= suctions[-1]), s_b, np.nan)
        r_e = np.concatenate([r2, r3], axis=1)
        s_e = np.concatenate([s2, s_b], axis=1)
        g_e = np.concatenate([g_a, g3], axis=1)
        fe = _synthetic_fields(r_e, np.nan_to_num(s_e), g_e, theta)
        edge_pts = {"suction": s_e, "gap": g_e, "area": fe["area"],
                    **{k: fe[k] for k in ("volume", "force", "beta1", "beta2")}}
    return SuctionTable(ratio=ratios, suction=suctions, gap=gaps, volume=f["volume"],
                        force=f["force"], beta1=f["beta1"], beta2=f["beta2"], status=status,
                        theta=theta, area=f["area"], edge=edge_pts,
                        attrs={"source": "capbridge.yade.yade_export.synthetic_suction_table"})


def synthetic_bridge(ratio, suction, gap, theta=0.0):
    """The synthetic table's fields at any (ratio, suction, gap); force 0 past rupture."""
    f = _synthetic_fields(*np.broadcast_arrays(*(np.asarray(x, float) for x in (ratio, suction, gap))),
                          theta)
    alive = np.asarray(gap) <= f["g_rupt"]
    return {"force": np.where(alive, f["force"], 0.0), "volume": np.where(alive, f["volume"], np.nan),
            "g_rupt": f["g_rupt"]}


# ------------------------------------------------------------------------------------
# Unit conversion
# ------------------------------------------------------------------------------------


def to_yade_units(ratio, suction=None, gap=None, volume=None, force=None, area=None,
                  nn=None, delaunay=False):
    """Convert capbridge's dimensionless values (radius r) to YADE's (radius R = ratio r).

    Returns a dict with the keys given: ``P`` (uc R/gamma), ``D``, ``V``, ``F``
    (``F/(2 pi gamma R)``, or ``F/(gamma R)`` when ``delaunay``), ``area`` and ``nn``
    (over R^2).

    >>> out = to_yade_units(2.0, suction=3.0, gap=0.2, volume=0.8, force=1.0)
    >>> [round(float(out[k]), 6) for k in ("P", "D", "V", "F")]
    [6.0, 0.1, 0.1, 0.5]
    """
    rho = np.asarray(ratio, float)
    out = {}
    if suction is not None:
        out["P"] = np.asarray(suction, float) * rho
    if gap is not None:
        out["D"] = np.asarray(gap, float) / rho
    if volume is not None:
        out["V"] = np.asarray(volume, float) / rho**3
    if force is not None:
        out["F"] = np.asarray(force, float) / rho * (2.0 * np.pi if delaunay else 1.0)
    if area is not None:
        out["area"] = np.asarray(area, float) / rho**2
    if nn is not None:
        out["nn"] = np.asarray(nn, float) / rho**2
    return out


def from_yade_units(ratio, P=None, D=None, V=None, F=None, delaunay=False):
    """Inverse of :func:`to_yade_units`: YADE's dimensionless values back to capbridge's.

    Returns a dict with ``suction``, ``gap``, ``volume``, ``force`` for the keys given.
    """
    rho = np.asarray(ratio, float)
    out = {}
    if P is not None:
        out["suction"] = np.asarray(P, float) / rho
    if D is not None:
        out["gap"] = np.asarray(D, float) * rho
    if V is not None:
        out["volume"] = np.asarray(V, float) * rho**3
    if F is not None:
        out["force"] = np.asarray(F, float) * rho / (2.0 * np.pi if delaunay else 1.0)
    return out


def theta_suffix(theta, theta2=None):
    """``suffCapFiles`` value capbridge uses for contact angle ``theta`` [deg] (and
    ``theta2`` on the larger grain when it differs).

    >>> theta_suffix(30), theta_suffix(27.5), theta_suffix(0), theta_suffix(0, 60)
    ('_theta30', '_theta27.5', '_theta0', '_theta0-60')
    """
    out = "_theta" + _fmt_number(float(theta))
    if theta2 is not None and float(theta2) != float(theta):
        out += "-" + _fmt_number(float(theta2))
    return out


def _fmt_number(x):
    return ("%.10g" % x).replace("+", "")


def capillary_file_name(ratio, suffix=""):
    """Name YADE opens for ``ratio``: ``M(r=1.25)`` + ``suffix``.

    >>> capillary_file_name(1.0), capillary_file_name(10.0, "_theta30")
    ('M(r=1)', 'M(r=10)_theta30')
    """
    return f"M(r={_fmt_number(float(ratio))}){suffix}"


def _as_table(solutions, theta=None):
    if isinstance(solutions, SuctionTable):
        return solutions
    if hasattr(solutions, "data_vars") and hasattr(solutions, "dims"):
        return SuctionTable.from_dataset(solutions, theta=theta)
    if isinstance(solutions, dict):
        return SuctionTable(**solutions)
    raise TypeError("solutions must be a SuctionTable, an xarray Dataset or a dict of its fields")


# ------------------------------------------------------------------------------------
# Law2_ScGeom_CapillaryPhys_Capillarity: the M(r=...) files
# ------------------------------------------------------------------------------------


def capillary_file_blocks(table, ratio_index):
    """The distance blocks of the ``M(r=...)`` file of one ratio of ``table``.

    Returns ``(blocks, report)``: ``blocks`` is a list of ``(D, rows)`` with ``rows`` an
    ``(n, 8)`` array in :data:`LAW2_COLUMNS` order (YADE units, P increasing);
    ``report`` counts what was left out.  A block holds the converged suctions of one
    gap, then the table's rupture point at that gap if it has one (see
    :class:`SuctionTable`); the file ends before the first gap with fewer than two rows
    (YADE needs two rows to interpolate and crashes on an empty block).
    """
    t = table
    rho = float(t.ratio[ratio_index])
    if t.gap[0] != 0.0:
        raise ValueError(f"the gap axis must start at 0 for YADE's M(r=...) files "
                         f"(first gap {t.gap[0]:g}); YADE indexes block -1 below the first")
    conv = t.converged[ratio_index]           # (suction, gap)
    y = to_yade_units(rho, suction=t.suction, gap=t.gap)
    edge = t.edge_points(ratio_index)
    blocks, interior_dropped, edge_rows = [], 0, 0
    for k in range(t.gap.size):
        keep = np.flatnonzero(conv[:, k])
        rows = np.empty((keep.size, 8))
        rows[:, 0] = y["D"][k]
        if keep.size:
            # non-converged suctions between converged ones: YADE will interpolate across
            interior_dropped += int(keep[-1] - keep[0] + 1 - keep.size) + int(keep[0])
            v = to_yade_units(rho, volume=t.volume[ratio_index, keep, k],
                              force=t.force[ratio_index, keep, k])
            rows[:, 1] = y["P"][keep]
            rows[:, 2] = v["V"]
            rows[:, 3] = v["F"]
            rows[:, 4] = t.beta1[ratio_index, keep, k]
            rows[:, 5] = t.beta2[ratio_index, keep, k]
            for col, name in ((6, "nn11"), (7, "nn33")):
                arr = getattr(t, name)
                rows[:, col] = 0.0 if arr is None else arr[ratio_index, keep, k] / rho**2
        # the bridge that ruptures exactly at this gap closes the block
        at_k = np.flatnonzero(np.isclose(edge["gap"], t.gap[k], rtol=1e-12, atol=1e-15))
        s_last = t.suction[keep[-1]] if keep.size else -np.inf
        at_k = [e for e in at_k if edge["suction"][e] > s_last * (1 + 1e-9) + 1e-300]
        if at_k:
            e = max(at_k, key=lambda e: edge["suction"][e])
            ve = to_yade_units(rho, suction=edge["suction"][e], volume=edge["volume"][e],
                               force=edge["force"][e])
            rows = np.vstack([rows, [y["D"][k], ve["P"], ve["V"], ve["F"],
                                     edge["beta1"][e], edge["beta2"][e], 0.0, 0.0]])
            edge_rows += 1
        if len(rows) < 2:
            break
        blocks.append((float(y["D"][k]), rows))
    if not blocks:
        raise ValueError(f"ratio {rho:g}: fewer than two converged suctions at gap 0; "
                         "nothing YADE could interpolate")
    n_conv = int(conv.sum())
    n_written = sum(len(r) for _, r in blocks) - edge_rows
    report = {"ratio": rho, "blocks": len(blocks), "rows": n_written + edge_rows,
              "rupture_rows": edge_rows,
              "max_D": blocks[-1][0], "max_gap": blocks[-1][0] * rho,
              "converged_points_not_written": n_conv - n_written,
              "interior_points_missing": interior_dropped,
              # suctions whose bridge still exists at the last gap written: YADE breaks
              # them there, before their true rupture distance
              "suctions_cut_before_rupture": int(conv[:, len(blocks) - 1].sum())
              if len(blocks) == t.gap.size else 0}
    return blocks, report


def _write_law2_file(path, ratio, blocks):
    tmp = Path(str(path) + ".tmp")
    with open(tmp, "w") as fh:
        fh.write(_fmt_number(ratio) + "\n")
        fh.write(f"{len(blocks)}\n")
        for _, rows in blocks:
            fh.write(f"{len(rows)}\t0\t0\t0\t0\t0\t0\t0\n")
            np.savetxt(fh, rows, fmt=_FLOAT_FMT, delimiter="\t")
    os.replace(tmp, path)


def _stub_blocks():
    """One block at D = 0 with two zero rows: a file YADE parses, holding no bridge."""
    rows = np.zeros((2, 8))
    rows[1, 1] = 1.0
    return [(0.0, rows)]


def write_capillary_files(solutions, directory, suffix="", *, theta=None, missing="error",
                          manifest=True):
    """Write the ``M(r=1)``..``M(r=10)`` set read by ``Law2_ScGeom_CapillaryPhys_Capillarity``.

    Parameters
    ----------
    solutions : :class:`SuctionTable` (or an xarray Dataset / dict of its fields)
        Must hold the ten ratios of :data:`YADE_RATIOS` and gap 0.
    directory : where to write; YADE must run with this as working directory.
    suffix : appended to every file name; give the same string to the engine's
        ``suffCapFiles`` (e.g. :func:`theta_suffix`).
    missing : ``"error"`` (default) if a ratio of :data:`YADE_RATIOS` is not in the table;
        ``"stub"`` writes a parseable file with no bridge for it instead (a warning is
        issued): pairs whose ratio is not exactly a tabulated one then get wrong forces,
        so only use it for scenes whose ratios are all in the table (e.g. equal spheres).
    manifest : also write ``M<suffix>.capbridge.json`` describing the export.

    Returns the list of written paths (the ten files, then the manifest).
    """
    table = _as_table(solutions, theta)
    if missing not in ("error", "stub"):
        raise ValueError("missing must be 'error' or 'stub'")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    idx = {r: table.ratio_index(r) for r in YADE_RATIOS}
    absent = [r for r, i in idx.items() if i is None]
    if absent and missing == "error":
        raise ValueError(f"the table lacks radius ratios {absent} needed by YADE's "
                         f"M(r=...) set {list(YADE_RATIOS)} (missing='stub' writes "
                         "bridge-free placeholders)")
    if absent:
        warnings.warn(f"writing bridge-free placeholder files for ratios {absent}: pairs "
                      "with other ratios than the tabulated ones get wrong forces",
                      stacklevel=2)
    paths, reports = [], []
    for r in YADE_RATIOS:
        path = directory / capillary_file_name(r, suffix)
        if idx[r] is None:
            _write_law2_file(path, r, _stub_blocks())
            reports.append({"ratio": r, "stub": True})
        else:
            blocks, rep = capillary_file_blocks(table, idx[r])
            if rep["interior_points_missing"]:
                warnings.warn(f"ratio {r:g}: {rep['interior_points_missing']} non-converged "
                              "points inside the bridge domain were left out; YADE "
                              "interpolates across them", stacklevel=2)
            if rep["suctions_cut_before_rupture"]:
                warnings.warn(f"ratio {r:g}: {rep['suctions_cut_before_rupture']} suctions "
                              f"still hold a bridge at the last gap ({rep['max_gap']:g} r); "
                              "YADE will break them there: extend the gap axis",
                              stacklevel=2)
            _write_law2_file(path, r, blocks)
            reports.append(rep)
        paths.append(path)
    if manifest:
        paths.append(_write_manifest(
            directory / f"M{suffix}.capbridge.json", table,
            {"format": "YADE Law2_ScGeom_CapillaryPhys_Capillarity M(r=...) files",
             "engine_attributes": {"suffCapFiles": suffix},
             "files": [p.name for p in paths], "columns": list(LAW2_COLUMNS),
             "normalisation": "larger radius R: D=d/R, P=(u_gas-u_liquid)R/gamma, V/R^3, "
                              "F/(2 pi gamma R), delta1/delta2 [deg] on smaller/larger sphere",
             "per_ratio": reports}))
    return paths


def read_capillary_file(path):
    """Parse one ``M(r=...)`` file the way YADE does.

    Returns ``(ratio, blocks)`` with ``blocks`` a list of ``(D, rows)``, ``D`` taken from
    the block's last row as YADE does and ``rows`` an ``(n, 8)`` array.
    """
    with open(path) as fh:
        tokens_first = fh.readline().split()
        ratio = float(tokens_first[0])
        n_d = int(fh.readline().split()[0])
        blocks = []
        for _ in range(n_d):
            header = fh.readline().split()
            while not header:            # tolerate blank lines as YADE's >> does
                header = fh.readline().split()
            n = int(float(header[0]))
            if n <= 0:
                raise ValueError(f"{path}: empty block (YADE would crash on it)")
            vals = []
            while len(vals) < 8 * n:
                line = fh.readline()
                if not line:
                    raise ValueError(f"{path}: file ends inside a block")
                vals.extend(float(x) for x in line.split())
            if len(vals) != 8 * n:
                raise ValueError(f"{path}: rows of a block must have 8 columns")
            rows = np.array(vals).reshape(n, 8)
            blocks.append((float(rows[-1, 0]), rows))
    return ratio, blocks


def read_capillary_files(directory, suffix=""):
    """Read the ten files of a set; returns a list of ``(ratio, blocks)`` in YADE's order."""
    return [read_capillary_file(Path(directory) / capillary_file_name(r, suffix))
            for r in YADE_RATIOS]


_ZERO = np.zeros(6)  # V, F, delta1, delta2, nn11, nn33


def _interp_block(rows, P):
    """``TableauD::Interpolate3``: linear in P; zeros beyond the largest P."""
    p = rows[:, 1]
    for k in range(1, len(rows)):
        if p[k] > P:
            w = (P - p[k - 1]) / (p[k] - p[k - 1])
            lo, hi = rows[k - 1, 2:], rows[k, 2:]
            return lo + (hi - lo) * w
        if p[k] == P:
            return rows[k, 2:].copy()
    return _ZERO.copy()


def _interp_file(blocks, D, P):
    """``Tableau::Interpolate2``: linear in D between consecutive blocks."""
    if D < blocks[0][0]:
        raise ValueError(f"D={D} below the first block (YADE reads out of bounds)")
    for i, (d_i, rows) in enumerate(blocks):
        if d_i > D:
            d_lo, rows_lo = blocks[i - 1]
            w = (D - d_lo) / (d_i - d_lo)
            return _interp_block(rows_lo, P) * (1 - w) + _interp_block(rows, P) * w
        if d_i == D:
            return _interp_block(rows, P)
    return _ZERO.copy()


def law2_interpolate(files, ratio, D, P):
    """What ``Law2_ScGeom_CapillaryPhys_Capillarity`` reads from ``files`` (YADE units).

    ``files``: list of ``(ratio, blocks)`` as from :func:`read_capillary_files`;
    ``ratio`` = R/r >= 1, ``D`` = d/R >= 0, ``P`` = uc R/gamma > 0.
    Returns a dict ``V, F, delta1, delta2, nn11, nn33`` (all zero = no bridge), following
    YADE's ``capillarylaw::interpolate`` step by step (same branches, same order).
    """
    out = _ZERO.copy()
    for i, (r_i, blocks) in enumerate(files):
        if r_i > ratio:
            if i == 0:
                raise ValueError("ratio below the first file's ratio")
            r_lo, blocks_lo = files[i - 1]
            w = (ratio - r_lo) / (r_i - r_lo)
            out = _interp_file(blocks_lo, D, P) * (1 - w) + _interp_file(blocks, D, P) * w
            break
        if r_i == ratio:
            out = _interp_file(blocks, D, P)
            break
    return dict(zip(("V", "F", "delta1", "delta2", "nn11", "nn33"), map(float, out)))


def law2_force(files, radius1, radius2, distance, suction, surface_tension):
    """Capillary force [N] YADE's Law2 applies to two spheres (SI inputs).

    ``distance`` is the gap between the surfaces [m] (negative = overlap, treated as 0),
    ``suction`` = u_gas - u_liquid [Pa] > 0.  Returns ``(force, volume)`` with the force
    positive for attraction and the bridge volume [m^3] (0 = no bridge).
    """
    r_small, r_large = sorted((float(radius1), float(radius2)))
    res = law2_interpolate(files, r_large / r_small, max(distance, 0.0) / r_large,
                           suction * r_large / surface_tension)
    return (res["F"] * 2.0 * np.pi * r_large * surface_tension, res["V"] * r_large**3)


# ------------------------------------------------------------------------------------
# CapillarityEngine + CapillaryPhysDelaunay: one unstructured file
# ------------------------------------------------------------------------------------


def _delaunay_rows(rho, suction, gap, volume, force, beta1, beta2, area, ang):
    """Records (ending 0) for bridges given in capbridge units (1-D arrays)."""
    n = np.size(gap)
    y = to_yade_units(rho, suction=suction, gap=gap, volume=volume, force=force, delaunay=True)
    if area is not None:
        dry = 2 * np.pi * ((1 + np.cos(np.radians(beta1))) + rho**2 * (1 + np.cos(np.radians(beta2))))
        surface = (np.asarray(area, float) + dry) / rho**2
    else:
        surface = np.zeros(n)
    return np.column_stack([np.broadcast_to(y["P"], (n,)), y["F"], y["D"], y["V"], surface,
                            np.zeros(n), np.asarray(beta1) * ang, np.asarray(beta2) * ang,
                            np.full(n, 1.0 / rho), np.zeros(n)])


def delaunay_records(solutions, *, overlap_pad=0.05, ratio_pad=0.01, angle_unit="deg",
                     theta=None):
    """Records of ``CapillarityEngine``'s input file, as an ``(n, 10)`` array.

    Columns in :data:`DELAUNAY_COLUMNS` order, YADE units (larger radius).  For every
    (ratio, suction) line of the table: one record per converged gap, then the bridge
    at rupture if the table's ``edge`` has it for that suction; then, if the table goes
    on, one end marker (the last bridge's values with force 0 and ``ending = 1``) just
    past the end of the line (2 % of a gap step past the rupture point, or at the next
    gap of the grid without one), so that queries beyond rupture fall in tetrahedra of
    markers only and get no bridge.  The table's rupture points at grid gaps (made for
    the ``M(r=...)`` files) are left out: between the lines they put bridge vertices
    among the markers, and YADE then found forces past rupture.  With
    ``overlap_pad > 0`` the gap-0
    record of every line is copied to distance ``-overlap_pad`` (in units of R) so that
    overlapping contacts, whose distance YADE does not clamp, keep the contact solution.
    With ``ratio_pad > 0`` the records of the two extreme ratios are copied just outside
    the range: ratio 1 (R = 1) to R = 1 + ratio_pad (never queried) and the largest
    ratio (smallest R) to R (1 - ratio_pad), so pairs up to ratio/(1 - ratio_pad) get
    the largest ratio's bridges instead of none.  This keeps the triangulation
    three-dimensional even for one ratio and puts queries at the extreme ratios inside
    it (on the hull, YADE may pick a tetrahedron reaching into the neighbouring ratio,
    or an infinite one: no bridge).
    """
    t = _as_table(solutions, theta)
    if angle_unit not in ("deg", "rad"):
        raise ValueError("angle_unit must be 'deg' or 'rad'")
    ang = 1.0 if angle_unit == "deg" else math.pi / 180.0
    recs = []
    for i, rho in enumerate(t.ratio):
        y = to_yade_units(rho, gap=t.gap)
        edge = t.edge_points(i)
        for j in range(t.suction.size):
            conv = np.flatnonzero(t.converged[i, j])
            if conv.size == 0:
                continue
            block = _delaunay_rows(rho, t.suction[j], t.gap[conv], t.volume[i, j, conv],
                                   t.force[i, j, conv], t.beta1[i, j, conv], t.beta2[i, j, conv],
                                   None if t.area is None else t.area[i, j, conv], ang)
            last = conv[-1]
            # this line's rupture point, if the table has it beyond the last grid bridge
            e = np.flatnonzero(np.isclose(edge["suction"], t.suction[j], rtol=1e-12, atol=1e-15)
                               & (edge["gap"] > t.gap[last]))
            if e.size:
                e = e[0]
                block = np.vstack([block, _delaunay_rows(
                    rho, edge["suction"][e], [edge["gap"][e]], [edge["volume"][e]],
                    [edge["force"][e]], [edge["beta1"][e]], [edge["beta2"][e]],
                    None if (t.area is None or "area" not in edge) else [edge["area"][e]],
                    ang)])
            recs.append(block)
            if last + 1 < t.gap.size:
                marker = block[-1].copy()
                marker[1] = 0.0
                marker[9] = 1.0
                if e.size:
                    marker[2] = block[-1, 2] + _MARKER_FRAC * (y["D"][last + 1] - y["D"][last])
                else:
                    marker[2] = y["D"][last + 1]
                recs.append(marker[None, :])
            if overlap_pad > 0 and conv[0] == 0 and t.gap[0] == 0.0:
                pad = block[0].copy()
                pad[2] = -float(overlap_pad)
                recs.append(pad[None, :])
    if not recs:
        raise ValueError("the table holds no converged point")
    rec = np.vstack(recs)
    if ratio_pad > 0:
        extra = []
        top = rec[np.isclose(rec[:, 8], 1.0, rtol=0, atol=1e-12)]
        if top.size:
            up = top.copy()
            up[:, 8] = 1.0 + ratio_pad
            extra.append(up)
        r_min = rec[:, 8].min()
        bottom = rec[np.isclose(rec[:, 8], r_min, rtol=1e-12, atol=0)]
        down = bottom.copy()
        down[:, 8] = r_min * (1.0 - ratio_pad)
        extra.append(down)
        rec = np.vstack([rec] + extra)
    if np.unique(rec[:, 8]).size < 2:
        raise ValueError("CapillarityEngine needs a 3-D point set: give several ratios "
                         "or ratio_pad > 0 with ratio 1 in the table")
    return rec


def write_delaunay_file(solutions, path, *, overlap_pad=0.05, ratio_pad=0.01,
                        angle_unit="deg", theta=None, manifest=True):
    """Write the input file of ``CapillarityEngine`` (``inputFilename``).

    See :func:`delaunay_records` for the content and the padding options.  Returns the
    list of written paths (the file, then ``<path>.capbridge.json`` when ``manifest``).
    """
    table = _as_table(solutions, theta)
    rec = delaunay_records(table, overlap_pad=overlap_pad, ratio_pad=ratio_pad,
                           angle_unit=angle_unit)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(str(path) + ".tmp")
    fmt = [_FLOAT_FMT] * 9 + ["%d"]
    with open(tmp, "w") as fh:
        np.savetxt(fh, rec, fmt=fmt, delimiter="\t")
    os.replace(tmp, path)
    paths = [path]
    if manifest:
        paths.append(_write_manifest(
            Path(str(path) + ".capbridge.json"), table,
            {"format": "YADE CapillarityEngine input file (CapillaryPhysDelaunay)",
             "engine_attributes": {"inputFilename": path.name},
             "files": [path.name], "columns": list(DELAUNAY_COLUMNS),
             "normalisation": "larger radius R: distance=d/R, succion=(u_gas-u_liquid)R/gamma, "
                              "volume/R^3, force/(gamma R) (no 2 pi), surface/R^2, "
                              f"R=r_small/r_large, delta [{angle_unit}]",
             "records": int(rec.shape[0]), "end_markers": int(rec[:, 9].sum()),
             "overlap_pad": overlap_pad, "ratio_pad": ratio_pad}))
    return paths


def read_delaunay_file(path):
    """Read a ``CapillarityEngine`` input file into a dict of column arrays."""
    data = np.loadtxt(path, ndmin=2)
    if data.shape[1] != len(DELAUNAY_COLUMNS):
        raise ValueError(f"{path}: expected {len(DELAUNAY_COLUMNS)} columns, got {data.shape[1]}")
    return {name: data[:, k] for k, name in enumerate(DELAUNAY_COLUMNS)}


# ------------------------------------------------------------------------------------
# Manifest and the glue to the exact solver
# ------------------------------------------------------------------------------------


def _write_manifest(path, table, info):
    conv = table.converged
    doc = {
        "generator": f"capbridge {__version__} (capbridge.yade.yade_export)",
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "theta_deg": table.theta,
        "grid": {"ratio": table.ratio.tolist(), "suction": table.suction.tolist(),
                 "gap": table.gap.tolist(),
                 "axes_convention": "capbridge: smaller radius r; suction = -P* = "
                                    "(p_gas - p_liquid) r / gamma; gap d/r"},
        "points": {"total": int(conv.size), "converged": int(conv.sum())},
        "table_attrs": {k: (v if isinstance(v, (str, int, float, bool, type(None))) else str(v))
                        for k, v in table.attrs.items()},
        "format_notes": list(FORMAT_NOTES),
    }
    doc.update(info)
    path = Path(path)
    path.write_text(json.dumps(doc, indent=1, default=str) + "\n")
    return path


_BRIDGE_KEYS = ("volume", "force", "beta1", "beta2", "area")


def rupture_edge(theta, ratios, suctions, gaps, *, solver_kwargs=None, tol=1e-10,
                 max_iter=60, theta2=None):
    """Bridges at rupture for :attr:`SuctionTable.edge`, from the exact solver.

    For every ratio: the rupture of every grid suction (``suction_rupture_distance``),
    and, for every grid gap inside the range of those rupture gaps, the suction whose
    bridge ruptures exactly at that gap (bracketed between grid suctions, Illinois
    iterations on the rupture gap to ``tol``); ``theta2`` the angle on the larger grain
    (default ``theta``).  Returns the ``edge`` dict (capbridge
    units, shape ``(len(ratios), len(suctions) + len(gaps))``, NaN = no point).
    """
    from capbridge.solvers.young_laplace import suction_rupture_distance

    kw = dict(solver_kwargs or {})
    if theta2 is not None:          # only when given: equal angles keep the plain call
        kw["theta2"] = theta2
    ratios, suctions, gaps = (np.asarray(a, float) for a in (ratios, suctions, gaps))
    n_s, n_g = suctions.size, gaps.size
    out = {k: np.full((ratios.size, n_s + n_g), np.nan)
           for k in ("suction", "gap") + _BRIDGE_KEYS}

    def rupture(s, rho):
        r = suction_rupture_distance(-np.asarray(s, float), theta, ratio=float(rho), **kw)
        ok = np.asarray(r["status"]) == int(Status.CONVERGED)
        return {k: np.where(ok, np.asarray(r[k], float), np.nan) for k in ("gap",) + _BRIDGE_KEYS
                if k in r}

    for i, rho in enumerate(ratios):
        a = rupture(suctions, rho)
        out["suction"][i, :n_s] = np.where(np.isfinite(a["gap"]), suctions, np.nan)
        for k in a:
            out[k][i, :n_s] = a[k]
        d_r = a["gap"]
        # brackets [s_j, s_j+1] with d_r(s_j) >= g > d_r(s_j+1) for the grid gaps g
        lo, hi, f_lo, f_hi, idx = [], [], [], [], []
        for k, g in enumerate(gaps):
            if g <= 0:
                continue
            j = np.flatnonzero((d_r[:-1] >= g) & (d_r[1:] < g))
            if j.size:
                j = j[0]
                lo.append(suctions[j]); hi.append(suctions[j + 1])
                f_lo.append(d_r[j] - g); f_hi.append(d_r[j + 1] - g); idx.append(k)
        if not idx:
            continue
        lo, hi, f_lo, f_hi = map(np.array, (lo, hi, f_lo, f_hi))
        idx = np.array(idx)
        target = gaps[idx]
        side = np.zeros(idx.size, int)
        x, b = lo.copy(), None
        for _ in range(max_iter):                 # Illinois (modified regula falsi)
            x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
            b = rupture(x, rho)                   # the bridges at x, kept for the result
            bad = ~np.isfinite(b["gap"])
            if bad.any():                         # no rupture found there: bisect instead
                x[bad] = 0.5 * (lo[bad] + hi[bad])
                b_bad = rupture(x[bad], rho)
                for k in b:
                    b[k][bad] = b_bad[k]
            f = b["gap"] - target
            done = np.abs(f) <= tol * np.maximum(target, 1.0)
            if np.all(done | ~np.isfinite(f)):
                break
            left = f > 0                          # root lies above x
            lo = np.where(left, x, lo); f_lo = np.where(left, f, f_lo)
            hi = np.where(left, hi, x); f_hi = np.where(left, f_hi, f)
            f_hi = np.where(left & (side == 1), f_hi / 2, f_hi)
            f_lo = np.where(~left & (side == -1), f_lo / 2, f_lo)
            side = np.where(left, 1, -1)
        if b is None:
            b = rupture(x, rho)
        good = np.isfinite(b["gap"]) & (np.abs(b["gap"] - target) <= 1e3 * tol * np.maximum(target, 1.0))
        cols = n_s + idx[good]
        out["suction"][i, cols] = x[good]
        out["gap"][i, cols] = target[good]       # exactly the grid gap (within tol)
        for k in _BRIDGE_KEYS:
            if k in b:
                out[k][i, cols] = b[k][good]
    if not np.isfinite(out["area"]).any():
        del out["area"]
    return out


def export_from_solver(directory, theta, ratios=YADE_RATIOS, suctions=None, gaps=None, *,
                       n_gaps=61, suffix=None, law2=True, delaunay=True, edge=True,
                       delaunay_name="capillaryfile{suffix}.txt", solver_kwargs=None,
                       missing="error", theta2=None):
    """Solve the suction-controlled doublets with capbridge's exact solver and write them.

    Calls ``capbridge.solvers.young_laplace.solve_doublet_suction(gap, pressure, theta,
    ratio)`` on the grid ``ratios x suctions x gaps`` (pressure P* = -suction, capbridge
    units: smaller radius), adds the bridges at rupture (:func:`rupture_edge`) unless
    ``edge=False``, then writes :func:`write_capillary_files` (suffix
    :func:`theta_suffix` unless given) and :func:`write_delaunay_file`.

    ``theta2``: contact angle on the larger grain of every pair (default ``theta``).
    YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` reads one set of files for every
    pair of a scene and knows nothing of materials, so mixed angles in these formats
    are right only for a scene whose bridges all join a grain at ``theta`` (the smaller,
    or either when equal) to one at ``theta2``; capbridge's own engine
    (``CapbridgeEngine``) handles any mixture.

    Default grids: 48 suctions, 0 then geometric from 0.02 to 500; ``n_gaps`` gaps from
    0 to 2 % past the largest rupture gap (that of zero suction and the largest ratio).
    YADE's historical files used 350 suctions and 80 distances; the cost here is about
    8 ms per point.  Returns ``(table, paths)``.
    """
    try:
        from capbridge.solvers.young_laplace import solve_doublet_suction
    except ImportError as exc:  # the solver is not there (yet)
        raise RuntimeError("capbridge.solvers.young_laplace.solve_doublet_suction is "
                           f"not available: {exc}") from exc
    kw = dict(solver_kwargs or {})
    if theta2 is not None:          # only when given: equal angles keep the plain call
        kw["theta2"] = theta2
    ratios = np.asarray(ratios, float)
    suctions = np.asarray(suctions if suctions is not None
                          else np.concatenate([[0.0], np.geomspace(0.02, 500.0, 47)]), float)
    if gaps is None:
        from capbridge.solvers.young_laplace import suction_rupture_distance
        r0 = suction_rupture_distance(np.zeros(ratios.size), theta, ratio=ratios, **kw)
        g_max = np.nanmax(np.where(np.asarray(r0["status"]) == 0, r0["gap"], np.nan))
        if not np.isfinite(g_max):
            raise RuntimeError("no rupture distance at zero suction: give the gaps")
        gaps = np.linspace(0.0, 1.02 * float(g_max), int(n_gaps))
    gaps = np.asarray(gaps, float)
    shape = (ratios.size, suctions.size, gaps.size)
    fields = {k: np.full(shape, np.nan) for k in _BRIDGE_KEYS}
    status = np.full(shape, int(Status.NOT_COMPUTED))
    gg, ss = np.meshgrid(gaps, suctions)                     # (suction, gap)
    for i, rho in enumerate(ratios):
        res = solve_doublet_suction(gg, -ss, theta, ratio=float(rho), **kw)
        for k in fields:
            if k in res:
                fields[k][i] = np.broadcast_to(np.asarray(res[k], float), gg.shape)
        status[i] = np.broadcast_to(np.asarray(res["status"], int), gg.shape)
    conv = status == int(Status.CONVERGED)
    area = fields["area"] if np.all(np.isfinite(fields["area"][conv])) else None
    table = SuctionTable(ratio=ratios, suction=suctions, gap=gaps, status=status, theta=theta,
                         area=area, volume=fields["volume"], force=fields["force"],
                         beta1=fields["beta1"], beta2=fields["beta2"],
                         edge=rupture_edge(theta, ratios, suctions, gaps, solver_kwargs=kw)
                         if edge else None,
                         attrs={"source": "capbridge.solvers.young_laplace.solve_doublet_suction",
                                "rupture_edge": "suction_rupture_distance" if edge else "none",
                                "theta2": float(theta if theta2 is None else theta2)})
    suffix = theta_suffix(theta, theta2) if suffix is None else suffix
    paths = []
    if law2:
        paths += write_capillary_files(table, directory, suffix, missing=missing)
    if delaunay:
        paths += write_delaunay_file(table, Path(directory) / delaunay_name.format(suffix=suffix))
    return table, paths
