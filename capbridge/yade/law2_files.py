"""The ``M(r=...)`` files of YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity``: written
from a :class:`~capbridge.yade.suction_table.SuctionTable`, read back as YADE parses them.

``Law2_ScGeom_CapillaryPhys_Capillarity`` (with ``Ip2_FrictMat_FrictMat_CapillaryPhys``
or the Mindlin variant) reads ten files ``M(r=1)``, ``M(r=1.1)``, ``M(r=1.25)``,
``M(r=1.5)``, ``M(r=1.75)``, ``M(r=2)``, ``M(r=3)``, ``M(r=4)``, ``M(r=5)``,
``M(r=10)``, each name followed by the engine's ``suffCapFiles`` string, opened
relative to the working directory of the YADE process.  One set holds one contact
angle; sets for several angles live side by side with different suffixes
(:func:`theta_suffix`).  Written by :func:`write_capillary_files`.

Format (read from YADE's source, pkg/dem/Law2_ScGeom_CapillaryPhys_Capillarity.cpp,
and checked by loading the files in YADE 2023.02a; units: :mod:`capbridge.yade.yade_units`)
-----------------------------------------------------------------------------------------
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

:func:`~capbridge.yade.law2_interpolation.law2_interpolate` replays YADE's interpolation
on the files :func:`read_capillary_files` reads.
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from capbridge.yade.export_manifest import write_manifest
from capbridge.yade.suction_table import as_suction_table
from capbridge.yade.yade_units import FLOAT_FORMAT, to_yade_units

#: Radius ratios R/r of the ten files ``Law2_ScGeom_CapillaryPhys_Capillarity`` loads, in
#: the order it loads them (hard-coded in YADE's ``postLoad``).
YADE_RATIOS = (1.0, 1.1, 1.25, 1.5, 1.75, 2.0, 3.0, 4.0, 5.0, 10.0)

#: Columns of a row of an ``M(r=...)`` file.
LAW2_COLUMNS = ("D", "P", "V", "F", "delta1", "delta2", "nn11", "nn33")


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
    """``x`` as file names and the ratio line print it: 10 significant digits, no '+'."""
    return ("%.10g" % x).replace("+", "")


def capillary_file_name(ratio, suffix=""):
    """Name YADE opens for ``ratio``: ``M(r=1.25)`` + ``suffix``.

    >>> capillary_file_name(1.0), capillary_file_name(10.0, "_theta30")
    ('M(r=1)', 'M(r=10)_theta30')
    """
    return f"M(r={_fmt_number(float(ratio))}){suffix}"


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
            np.savetxt(fh, rows, fmt=FLOAT_FORMAT, delimiter="\t")
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
    table = as_suction_table(solutions, theta)
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
        paths.append(write_manifest(
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
