"""The input file of YADE's ``CapillarityEngine`` (``capillaryfile.txt``): written from a
:class:`~capbridge.yade.suction_table.SuctionTable`, and read back.

``CapillarityEngine`` (with ``Ip2_FrictMat_FrictMat_CapillaryPhysDelaunay``, physics
``CapillaryPhysDelaunay``) reads one unstructured file (attribute ``inputFilename``,
default ``capillaryfile.txt``), triangulates it and interpolates linearly in the
tetrahedra; with ``imposePressure=False`` it keeps the volume of every bridge
constant.  Written by :func:`write_delaunay_file`.

Format (read from YADE's source, pkg/dem/CapillarityEngine.cpp, and checked by loading
the files in YADE 2023.02a; units: :mod:`capbridge.yade.yade_units`)
--------------------------------------------------------------------------------------
``capillaryfile.txt`` (read by ``CapillarityEngine::triangulateData``): records of ten
whitespace-separated numbers, no header::

    succion  force  distance  volume  surface  arcLength  delta1  delta2  R  ending

with ``R = r/R`` in (0, 1] (the engine queries ``min/max`` radius), ``succion = uc R/gamma``,
``distance = d/R``, ``volume = V/R^3``, ``force = F/(gamma R)`` (no 2 pi here!),
``surface = (liquid-gas area + dry areas of both spheres)/R^2`` (the engine's
``SInterface``; it sets 4 pi (r^2 + R^2) when there is no bridge), ``arcLength``
(unused by the engine), ``delta1``/``delta2`` half filling angles (degrees, see
:data:`~capbridge.yade.export_manifest.FORMAT_NOTES`), ``ending`` 1 for points that mark
the end of the bridge domain.  The engine triangulates the points (R, succion, distance)
and (R, volume, distance); a query outside the convex hull, or in a tetrahedron whose four vertices all have ``ending=1``,
gets no bridge.  capbridge therefore ends every (ratio, suction) line with one marker
point (force 0, ``ending=1``) just past its last bridge, and pads the hull (see
:func:`delaunay_records`).
"""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from capbridge.yade.export_manifest import write_manifest
from capbridge.yade.suction_table import as_suction_table
from capbridge.yade.yade_units import FLOAT_FORMAT, to_yade_units

#: Columns of a record of ``CapillarityEngine``'s input file, in file order.
DELAUNAY_COLUMNS = ("succion", "force", "distance", "volume", "surface", "arcLength",
                    "delta1", "delta2", "R", "ending")

#: End markers of the CapillarityEngine file sit this fraction of the local gap step
#: past a line's rupture point.  Hugging the rupture keeps the tetrahedra beyond it made
#: of markers only (checked in YADE: 0.02 leaves no force past rupture on the tested
#: lines, 0.1 leaves up to 12 % of the contact force, a whole step up to 65 %).
_MARKER_FRAC = 0.02


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
    t = as_suction_table(solutions, theta)
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
    table = as_suction_table(solutions, theta)
    rec = delaunay_records(table, overlap_pad=overlap_pad, ratio_pad=ratio_pad,
                           angle_unit=angle_unit)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(str(path) + ".tmp")
    fmt = [FLOAT_FORMAT] * 9 + ["%d"]
    with open(tmp, "w") as fh:
        np.savetxt(fh, rec, fmt=fmt, delimiter="\t")
    os.replace(tmp, path)
    paths = [path]
    if manifest:
        paths.append(write_manifest(
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
