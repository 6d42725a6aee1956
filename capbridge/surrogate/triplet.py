"""Fast coalesced-triplet lookup: interpolation in a capbridge triplet table.

One liquid body wetting three equal spheres (radius r; lengths / r, V* = V/r^3,
F* = F/(2 pi gamma r), P* = dp r/gamma, E* = E/(gamma r^2), angles in degrees) is
tabulated by :mod:`capbridge.tables.triplet` on a full cube of the three gaps
(d12, d13, d23), the contact angle theta and the volume ratio v = V*/V*_coal, where
V*_coal(d12, d13, d23, theta) is the exact coalescence volume of the two bridges on the
grain shared by the two smallest gaps.  :class:`TripletSurrogate` follows
:class:`~capbridge.surrogate.doublet.DoubletSurrogate`:

* ``fit`` averages the cube over the 6 relabellings of the grains (a no-op away from
  equal gaps; at equal gaps it averages the Evolver noise between pair forces that are
  equal by symmetry), then refines it once to a fine grid by splines along each axis
  (cubic where the axis has >= 4 nodes, quadratic with 3) in the physical coordinates
  (gaps, theta, v); ``method="linear"`` keeps the raw grid (multilinear, for
  comparison);
* ``predict`` looks up V*_coal (4-D), forms v = V*/V*_coal, then the pair forces, P*
  and E* (5-D), by piecewise-linear interpolation on the Kuhn simplices of the fine
  grid (6 corners instead of the 32 of multilinear; exact at the nodes, continuous),
  with precomputed strides and no search (a linear index map on the non-uniform v
  axis).  Its error against the spline interpolant it stands for and the held-out
  errors are in ``benchmarks/RESULTS.md`` ("Triplet surrogate").

Permutation symmetry (relabelling the grains permutes the pair forces) holds to
round-off: the symmetrised cube, one refinement operator for the three gap axes, and a
triangulation invariant under permutations of the axes.

Statuses (:class:`~capbridge.status.Status`) per point, from the table nodes of the
coarse cell the point falls in:

* a node without an equilibrium of the coalesced body (failure kind ``no_equilibrium``)
  -> ``NO_EQUILIBRIUM``, no number (the body's existence boundary crosses the cell:
  the separate bridges apply);
* any other failed node -> ``NOT_CONVERGED``, no number;
* a node above the Evolver tolerance -> ``ABOVE_TOLERANCE``, with the number;
* otherwise ``CONVERGED``;
* v above the table with ``out_of_range="clip"`` -> ``EXTRAPOLATED`` (answered at
  the table's largest v: the same coalesced body with less liquid); v below the table
  with ``"clip"`` -> ``NO_EQUILIBRIUM`` if the table has no equilibrium at its lowest
  v there (less liquid cannot hold it together either), else ``OUT_OF_RANGE`` (no
  number);
* unequal radii (:meth:`TripletSurrogate.predict_vectors` with ``radii``) ->
  ``APPROXIMATE`` where the equal-sphere answer was a result.

Gaps and theta outside the table are always errors (another geometry or angle is
another body: use Surface Evolver, ``capbridge solve triplet``); so is bad input
(negative or NaN gaps, centres that do not form a triangle, theta outside [0, 90),
V* <= 0): one :class:`~capbridge.validation.CapbridgeInputError` line naming the value
and the allowed range.

Unequal radii (documented approximation, status ``APPROXIMATE``)
-----------------------------------------------------------------
The table is for equal spheres; for radii R1, R2, R3 the triplet is looked up at their
harmonic mean radius and each pair force scaled by that pair's Derjaguin radius.  The
approximation, the other schemes and their errors against Surface Evolver:
:mod:`capbridge.surrogate.triplet_unequal` (:data:`UNEQUAL_RADII_ERROR`).

Where the parts live
--------------------
:mod:`capbridge.surrogate.triplet_nodes` reads the table's nodes (values, statuses,
failed nodes filled, symmetrised over the grain relabellings);
:mod:`capbridge.surrogate.grid` is the fine grid (refinement, axes, simplex kernel);
:mod:`capbridge.surrogate.triplet_gravity` the response to gravity (a mixin of
:class:`TripletSurrogate`); :mod:`capbridge.surrogate.triplet_holdout` the held-out
errors (:func:`holdout_errors`, :func:`gravity_holdout_errors`);
:func:`~capbridge.solvers.triplet.table_frame` the table frame of a triangle of centres.

References
----------
Miot et al. (2021), Granular Matter 23:66 (coalesced triplets, Eq. 8 for the linear law
V_coal = V0 + (theta/90 deg) dV); Derjaguin (1934) for the effective radius.
"""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from capbridge.status import Status, status_in
from capbridge.surrogate.base import SurrogateBase
from capbridge.surrogate.doublet import SI_RADIUS_RANGE, SI_SURFACE_TENSION_RANGE, si_bond
from capbridge.surrogate.grid import Descending as _Descending
from capbridge.surrogate.grid import FineAxis as _FineAxis
from capbridge.surrogate.grid import Grid as _Grid
from capbridge.surrogate.grid import refine_axis
from capbridge.surrogate.triplet_gravity import TripletGravityResponse
from capbridge.surrogate.triplet_holdout import holdout_errors, holdout_points
from capbridge.surrogate.triplet_nodes import (GRID_VARIABLES, PAIR_NAMES, PAIRS, cell_max,
                                               fill_failed, node_data, symmetrise)
from capbridge.surrogate.triplet_unequal import combine_status, unequal_scales
from capbridge.tables import TRIPLET_TABLE, TRIPLET_TABLE_PACKINGS
from capbridge.tables.description import describe_evolver_points, describe_table
from capbridge.validation import (CONTACT_OVERLAP_MAX, CapbridgeInputError, check_choice,
                                  check_gap, check_int, check_range)
# this module's public names from before its parts had their own modules (issue 17)
from capbridge.physics.gravity import BOND_MAX
from capbridge.solvers.triplet import table_frame
from capbridge.status import HAS_RESULT
from capbridge.surrogate.triplet_holdout import gravity_holdout_errors
from capbridge.surrogate.triplet_open_side import (OPEN_SIDE_ERROR, OPEN_SIDE_LINEAR_MAX,
                                                   OPEN_SIDES, beyond_open_side)
from capbridge.surrogate.triplet_unequal import UNEQUAL_RADII_ERROR, UNEQUAL_SCHEMES

__all__ = ["TripletSurrogate", "holdout_errors", "gravity_holdout_errors",
           "LOWER_ENERGY_STATES", "PAIR_NAMES", "UNEQUAL_RADII_ERROR", "UNEQUAL_SCHEMES",
           "default_table", "engine_table", "table_frame", "BOND_MAX"]

#: codes of ``lower_energy_state``
LOWER_ENERGY_STATES = {
    0: "coalesced",      # E_coalesced < E_separated by more than their error estimates,
                         # or no separated state exists (the only state)
    1: "separated",      # E_separated < E_coalesced by more than their error estimates
    2: "undecided",      # |E_coalesced - E_separated| within the energy error estimate,
                         # or the separated states stop existing inside the table cell
    3: "unknown",        # no separated-state energy in the fit inputs (or no result here)
}
_UNKNOWN = 3

#: default fine-grid nodes per table interval: gaps, theta, v (chosen from the
#: refinement error measured by benchmarks/bench_triplet.py)
DEFAULT_REFINE = (4, 12, 6)
MAX_REFINE = 16
#: memory bound of the fine grid (values), bytes
MAX_GRID_BYTES = 400e6
#: ``refine="auto"``: the first of these whose fine grid stays within AUTO_GRID_BYTES
#: (the shipped table: DEFAULT_REFINE, 53 MB; the packings grid's 6 x 6 x 6 gaps, 5 angles
#: and 10 volume ratios: (2, 12, 6), 172 MB, where DEFAULT_REFINE would take 1.2 GB; its
#: held-out max error is 1.9 % there against 3.3 % with (2, 6, 3), 45 MB)
AUTO_REFINE = (DEFAULT_REFINE, (2, 12, 6), (2, 6, 3), (1, 6, 3), (1, 3, 2), (1, 1, 1))
AUTO_GRID_BYTES = 200e6

_TOL = 1e-12          # relative slack at the table's edges (round-off, not range)


def default_table():
    """``data/triplet_table.nc`` of this checkout (the CLI's and the API's default)."""
    return TRIPLET_TABLE


def engine_table():
    """``data/triplet_table_packings.nc`` of this checkout: the DEM engine's default, the
    table of the domain that coalesced triplets of real packings reach (contacts on two
    sides, the open side up to 0.6, v up to 5; the first table covers 4.5-79 % of them)."""
    return TRIPLET_TABLE_PACKINGS


# --------------------------------------------------------------------------------------
# fine axes and grids
# --------------------------------------------------------------------------------------


#: interpolation methods: spline degree along the gap axes and along theta, v
#: (None: cubic where the axis has >= 4 nodes, else the highest degree the nodes allow)
METHODS = {
    "cubic": "splines along every axis (quadratic through 3 gap nodes), simplex lookup "
             "on the fine grid",
    "cubic_tv": "linear in the gaps, cubic splines in theta and v, simplex lookup on the "
                "fine grid",
    "linear": "multilinear on the raw table grid (32 corners per lookup)",
    "auto": "cubic for a table computed over its whole cube, cubic_tv for one computed "
            "only where its two smaller gaps are small (TripletGrid.max_bridge_gap: "
            "splines across the gaps would run through the not-computed nodes)",
}


def _degree(method, axis):
    """Spline degree of ``method`` along table axis ``axis`` (0-2 gaps, 3 theta, 4 v)."""
    if method == "linear" or (method == "cubic_tv" and axis < 3):
        return 1
    return None


def _refine(values, axes, fine_axes, method):
    """Values on the coarse axes (leading dims) -> values on the fine axes.

    Splines along each axis in turn, of the degree :func:`_degree` gives, in the
    physical coordinate; ``method="linear"`` gives the raw grid (fine axes then
    coincide with the coarse ones).
    """
    out = values
    if method == "linear":
        return np.ascontiguousarray(out)
    for a, (c, f) in enumerate(zip(axes, fine_axes)):
        if len(c) > 1 and f.refine > 1:
            out = refine_axis(out, a, c, f.nodes, _degree(method, a))
    return np.ascontiguousarray(out)


def _refine3(refine):
    """``refine`` of :class:`TripletSurrogate` checked, as three integers."""
    r = (refine,) * 3 if np.ndim(refine) == 0 else tuple(refine)
    if len(r) != 3:
        raise CapbridgeInputError(f"refine={refine!r}: give one integer or three "
                                  "(gaps, theta, v)")
    return tuple(check_int("refine", x, 1, MAX_REFINE,
                           hint="fine-grid steps per table interval") for x in r)


class TripletSurrogate(TripletGravityResponse, SurrogateBase):
    """Interpolating surrogate of a coalesced-triplet table (fit / predict).

    Follows the surrogate contract of :mod:`capbridge.surrogate.base` (NotFittedError,
    ``has_gravity_``, :meth:`summary`, statuses, the no-result rule: no triplet status
    is RUPTURED, a point without a result has NaN numbers).

    Parameters
    ----------
    method : {"cubic", "cubic_tv", "linear"}
        How the table is interpolated (:data:`METHODS`): ``"cubic"`` (default) splines
        along every axis (quadratic through the 3 gap nodes), ``"cubic_tv"`` linear in
        the gaps and cubic in theta and v, both evaluated once on a fine grid read by
        the simplex kernel (:class:`_Grid`); ``"linear"`` multilinear on the raw grid
        (32 corners per lookup, slower).  Held-out errors of each:
        ``benchmarks/RESULTS.md``, "Triplet surrogate".
    refine : "auto", int or (int, int, int)
        Fine-grid steps per table interval along the gaps, theta and v; ``"auto"``
        (default): :data:`DEFAULT_REFINE`, or the first of :data:`AUTO_REFINE` whose
        fine grid fits in :data:`AUTO_GRID_BYTES` for a larger table (the one used is
        ``refine_``); ignored for ``method="linear"``.
    out_of_range : {"raise", "clip"}
        V* outside the table's range of v = V*/V*_coal: ``"raise"`` (default) a
        CapbridgeInputError naming the value and the range; ``"clip"`` answers above
        the range at its edge (status EXTRAPOLATED) and below it with no number
        (NO_EQUILIBRIUM where the table has no equilibrium at its lowest v,
        OUT_OF_RANGE elsewhere).  Gaps and theta outside the table are always errors.
    clip_hint : str
        How the user turns clipping on, named in messages (the CLI passes ``"--clip"``).
    open_side : {"refuse", "linear"}
        A table with an open side (``max_bridge_gap``, the second table): an open side
        beyond its last gap node is outside the table (``"refuse"``, default), or is
        answered by continuing the table linearly in it at fixed v, up to
        :data:`~capbridge.surrogate.triplet_open_side.OPEN_SIDE_LINEAR_MAX`, status
        APPROXIMATE (``"linear"``, the DEM engine's; measured error
        :data:`~capbridge.surrogate.triplet_open_side.OPEN_SIDE_ERROR`).
    """

    def __init__(self, method="cubic", refine="auto", out_of_range="raise",
                 clip_hint="out_of_range='clip'", open_side="refuse"):
        check_choice("method", method, tuple(METHODS))
        check_choice("out_of_range", out_of_range, ("raise", "clip"))
        check_choice("open_side", open_side, tuple(OPEN_SIDES))
        if isinstance(refine, str):
            if refine != "auto":
                raise CapbridgeInputError(f"refine={refine!r}: give 'auto', one integer or "
                                          "three (gaps, theta, v)")
        else:
            _refine3(refine)    # checked here, stored as given (scikit-learn's clone)
        self.refine = refine
        self.method = method
        self.out_of_range = out_of_range
        self.clip_hint = clip_hint
        self.open_side = open_side

    # ----------------------------------------------------------------------------- fit
    def fit(self, table, coalescence_table=None, separated_energy=None, *,
            allow_unverified=None):
        """Load a triplet table, check it and build the fine grids.

        Parameters
        ----------
        table : path or xarray.Dataset
            A triplet table (:mod:`capbridge.tables.triplet`).
        coalescence_table : path or xarray.Dataset, optional
            The exact coalescence volumes over the geometry
            (:mod:`capbridge.tables.coalescence`: ``V_coal_pair``, ``V0_pair``,
            ``dV_pair``).  If given, V*_coal between the triplet table's nodes follows
            its smooth V_coal_pair at the sorted gaps (the triplet table's own values
            are kept at its nodes), and V0, dV are its linear law; otherwise V*_coal
            is interpolated from the triplet table's nodes (splines across the kinks
            of V*_coal where two gaps are equal) and V0, dV are fitted per geometry
            to its V*_coal over theta.  Measured against exact V*_coal at 16 random
            geometries (``benchmarks/RESULTS.md``): median 0.38 %, max 2.6 % from
            the triplet table alone; 0.033 %, 0.12 % with the coalescence table.
            Since v = V*/V*_coal, that error enters the forces through df/dv: give
            the coalescence table whenever it exists.
        separated_energy : path, xarray.Dataset or xarray.DataArray, optional
            ``energy_separated`` (E* of the lowest separated state at the same total
            volume, on the table's (d12, d13, d23, theta, v) grid; NaN where no
            separated state exists).  Default: the table's own ``energy_separated``
            if it has one; without either, ``lower_energy_state`` is "unknown".
        allow_unverified : bool, optional
            Use table files without the table checksum ``table_sha256`` (one warning
            line each) instead of refusing them
            (:func:`~capbridge.tables.netcdf_io.read_table`); default: refused,
            unless inside :func:`~capbridge.tables.netcdf_io.allow_unverified_tables`.
        """
        self._allow_unverified = allow_unverified
        ds = self._load(table, allow_unverified)
        self.table_ = ds
        gaps = np.asarray(ds["d12"].values, float)
        self.gaps_ = gaps
        self.theta_ = np.asarray(ds["theta"].values, float)
        self.v_ = np.asarray(ds["v"].values, float)
        # a table computed only where the two smaller gaps (the bridges on the shared
        # grain) are small (TripletGrid.max_bridge_gap): the rest of the cube is
        # outside the table as much as a gap beyond the axis is
        grid = json.loads(ds.attrs.get("grid", "{}"))
        self.max_bridge_gap_ = grid.get("max_bridge_gap")
        self.method_ = self.method
        if self.max_bridge_gap_ is not None:
            if self.method == "cubic":
                raise CapbridgeInputError(
                    f"method='cubic' on a table computed only where its two smaller gaps "
                    f"are <= {self.max_bridge_gap_:g}: splines across the gaps would run "
                    "through its not-computed nodes (measured up to 3 % off inside); use "
                    "method='cubic_tv' (linear in the gaps) or 'auto'")
        if self.method == "auto":
            self.method_ = "cubic" if self.max_bridge_gap_ is None else "cubic_tv"
        sizes = (gaps.size, gaps.size, gaps.size, self.theta_.size, self.v_.size)

        def grid_bytes(r):
            steps = (r[0],) * 3 + tuple(r[1:])
            return np.prod([(n - 1) * k + 1 for n, k in zip(sizes, steps)]) * \
                (len(GRID_VARIABLES) + 1) * 8

        if isinstance(self.refine, str) and self.refine == "auto":
            self.refine_ = next((r for r in AUTO_REFINE if grid_bytes(r) <= AUTO_GRID_BYTES),
                                AUTO_REFINE[-1])
        else:
            self.refine_ = _refine3(self.refine)
        rg, rt, rv = self.refine_ if self.method_ != "linear" else (1, 1, 1)
        self.axes_ = [_FineAxis(gaps, rg), _FineAxis(gaps, rg), _FineAxis(gaps, rg),
                      _FineAxis(self.theta_, rt), _FineAxis(self.v_, rv)]
        coarse = [gaps, gaps, gaps, self.theta_, self.v_]
        n_fine = np.prod([a.n for a in self.axes_])
        if n_fine * (len(GRID_VARIABLES) + 1) * 8 > MAX_GRID_BYTES:
            raise CapbridgeInputError(
                f"refine={self.refine_} makes a fine grid of {n_fine:,} nodes "
                f"(> {MAX_GRID_BYTES / 1e6:g} MB); use a smaller refine")

        vals, has, code = node_data(ds)
        status = np.asarray(ds["status"].values)
        ferr = np.where(has, np.nan_to_num(np.asarray(ds["force_error"].values, float)), 0.0)
        extra = [ferr]
        # the separated-state energy, if any: interpolated as E_coal - E_sep
        esep = self._separated(ds, separated_energy)
        self.has_separated_energy_ = esep is not None
        if esep is not None:
            eerr = np.asarray(ds["energy_error"].values, float) if "energy_error" in ds \
                else np.zeros(status.shape)
            extra += [np.where(has, np.nan_to_num(eerr), 0.0),
                      (~np.isfinite(esep)).astype(float)]
            vals = np.concatenate([vals, (vals[..., 4] - esep)[..., None]], -1)
        nv = vals.shape[-1]
        pv, sv, code = symmetrise(np.moveaxis(vals[..., :3], -1, 0),
                                   np.concatenate([np.moveaxis(vals[..., 3:], -1, 0),
                                                   np.stack(extra)]), code)
        self.asymmetry_ = float(np.nanmax(np.abs(pv - np.moveaxis(vals[..., :3], -1, 0))))
        vals = np.concatenate([np.moveaxis(pv, 0, -1), np.moveaxis(sv[:nv - 3], 0, -1)], -1)
        extra = sv[nv - 3:]
        has = code <= 1
        self.node_code_ = code.astype(np.int8)
        self.cell_code_ = np.ascontiguousarray(cell_max(self.node_code_))
        self.cell_force_error_ = np.ascontiguousarray(cell_max(np.where(has, extra[0], 0.0)))
        masks = [has] * len(GRID_VARIABLES)
        if esep is not None:
            self.cell_energy_error_ = np.ascontiguousarray(cell_max(extra[1]))
            # NaN energy_separated: no separated state exists at that node.  A cell
            # where none exists at any node: the coalesced body is the only state; at
            # some nodes only: the boundary crosses the cell, "undecided"
            none = extra[2] > 0
            self.cell_no_separated_ = np.ascontiguousarray(
                np.where(-cell_max(-none.astype(np.int8)) > 0, 2,
                         np.where(cell_max(none.astype(np.int8)) > 0, 1, 0)).astype(np.int8))
            masks.append(has & ~none)                  # E_coal - E_sep: its own mask
        filled = np.stack([fill_failed(vals[..., k], m, (4, 3)) for k, m in
                           enumerate(masks)], -1)
        self._coarse = (coarse, filled)
        self.kernel_ = "simplex" if self.method_ != "linear" else "multilinear"
        self.grid_ = _Grid(_refine(filled, coarse, self.axes_, self.method_), self.kernel_)
        self._coalescence(ds, coarse, coalescence_table)
        self.holdout_ = holdout_points(ds)
        self.interpolation_error_ = None
        if self.holdout_ is not None and self.holdout_["n"]:
            e = holdout_errors(self)
            self.interpolation_error_ = {k: e[k] for k in (
                "median_rel_error", "max_rel_error", "max_rel_to_largest", "relative",
                "absolute", "n_small", "small_force", "n")}
        self._fit_gravity(ds)
        return self

    @staticmethod
    def _load(table, allow_unverified=None):
        from capbridge.tables.netcdf_io import TableError, read_table, validate_table

        if isinstance(table, xr.Dataset):
            ds, src = validate_table(table, "triplet table (Dataset)"), "triplet table"
        else:
            ds, src = read_table(table, allow_unverified=allow_unverified), str(table)
        need = ("f12", "f13", "f23", "pressure", "energy_extrapolated", "status",
                "force_error", "volume_coalescence")
        missing = [n for n in need if n not in ds]
        dims = ("d12", "d13", "d23", "theta", "v")
        if missing or tuple(ds["f12"].dims) != dims:
            raise TableError(f"{src} is not a triplet table: missing {missing} or dims "
                             f"{tuple(ds['f12'].dims) if 'f12' in ds else None} != {dims}")
        g = [np.asarray(ds[d].values, float) for d in dims[:3]]
        if not (np.array_equal(g[0], g[1]) and np.array_equal(g[0], g[2])):
            raise TableError(f"{src}: the three gap axes differ; a triplet table is a "
                             "full cube on one gap axis")
        for d, lo, hi in (("d12", 0.0, 10.0), ("theta", 0.0, 90.0), ("v", 0.0, 100.0)):
            x = np.asarray(ds[d].values, float)
            if x.size < 2 or x[0] < lo or x[-1] >= hi:
                raise TableError(f"{src}: axis {d} = {x.tolist()} needs >= 2 nodes in "
                                 f"[{lo:g}, {hi:g})")
        if str(ds["theta"].attrs.get("units")) not in ("degree", "degrees"):
            raise TableError(f"{src}: theta must be in degrees")
        Vc = np.asarray(ds["volume_coalescence"].values, float)
        if np.any(Vc[np.isfinite(Vc)] <= 0):
            raise TableError(f"{src}: non-positive coalescence volume")
        f = np.stack([ds[n].values for n in PAIR_NAMES])
        if np.any(np.abs(f[np.isfinite(f)]) > 5.0):
            raise TableError(f"{src}: |f_ij| > 5 (2 pi gamma r): not a capillary force "
                             "table or damaged")
        return ds

    def _separated(self, ds, separated_energy):
        """E_separated on the grid: the ``separated_energy`` argument, else the
        table's own ``energy_separated``, else None."""
        if separated_energy is None:
            return np.asarray(ds["energy_separated"].values, float) \
                if "energy_separated" in ds else None
        src = separated_energy
        if not isinstance(src, (xr.Dataset, xr.DataArray)):
            from capbridge.tables.netcdf_io import read_table
            src = read_table(src, allow_unverified=self._allow_unverified)
        if isinstance(src, xr.Dataset):
            src = src["energy_separated"]
        da = src.transpose("d12", "d13", "d23", "theta", "v")
        for d in ("d12", "d13", "d23", "theta", "v"):
            if not np.allclose(da[d].values, ds[d].values, rtol=1e-12, atol=1e-12):
                raise CapbridgeInputError(f"separated_energy: axis {d} differs from the "
                                          "triplet table's")
        return np.asarray(da.values, float)

    def _coalescence(self, ds, coarse, coalescence_table):
        """Fine grids of V*_coal (gaps, theta) and of V0, dV (gaps)."""
        Vc = np.asarray(ds["volume_coalescence"].values, float)      # (g, g, g, t)
        ok = np.isfinite(Vc)
        Vc_f = fill_failed(Vc, ok, (3,))
        fine_axes, c4 = self.axes_[:4], coarse[:4]
        Vfine = _refine(Vc_f, c4, fine_axes, self.method_)
        theta = self.theta_
        if coalescence_table is None:
            # the paper's line per geometry, least squares over the table's theta nodes
            A = np.stack([np.ones_like(theta), theta / 90.0], 1)
            coef = np.linalg.lstsq(A, Vc_f.reshape(-1, theta.size).T, rcond=None)[0]
            lin = coef.T.reshape(Vc.shape[:3] + (2,))
            lin_fine = _refine(lin, coarse[:3], self.axes_[:3], self.method_)
            self.coalescence_source_ = "triplet table (volume_coalescence)"
        else:
            Vfine, lin_fine = self._dense_coalescence(coalescence_table, Vc_f, c4)
        self.coal_grid_ = _Grid(Vfine[..., None], self.kernel_)
        self.law_grid_ = _Grid(lin_fine, self.kernel_)

    def _dense_coalescence(self, table, Vc_nodes, c4):
        """V*_coal from a coalescence table: its V_coal_pair W(a, b, c) (the bridges on
        gaps a and b, third gap c) is smooth; the triplet table's reference is W at the
        sorted gaps, kinked where two gaps are equal.  So V*_coal = W(sorted gaps) by
        cubic interpolation in the coalescence table, plus the residual of that
        interpolation at the triplet table's nodes (refined like the table), which
        keeps the triplet table's own values at its nodes.  The kinks then lie on the
        planes of equal gaps, which the fine grid's simplices never cross.  V0, dV: the
        coalescence table's linear law at the sorted gaps."""
        from capbridge.tables.netcdf_io import read_table

        dc = table if isinstance(table, xr.Dataset) else \
            read_table(table, allow_unverified=self._allow_unverified)
        src = "coalescence table" if isinstance(table, xr.Dataset) else str(table)
        for n in ("V_coal_pair", "V0_pair", "dV_pair"):
            if n not in dc:
                raise CapbridgeInputError(f"{src} has no {n}: not a coalescence table "
                                          "(capbridge.tables.coalescence)")
        g = np.asarray(dc["d12"].values, float)
        t = np.asarray(dc["theta"].values, float)
        if g[0] > self.gaps_[0] + 1e-12 or g[-1] < self.gaps_[-1] - 1e-12 or \
                t[0] > self.theta_[0] + 1e-12 or t[-1] < self.theta_[-1] - 1e-12:
            raise CapbridgeInputError(
                f"{src} covers gaps [{g[0]:g}, {g[-1]:g}] and theta [{t[0]:g}, {t[-1]:g}]"
                f", not the triplet table's [{self.gaps_[0]:g}, {self.gaps_[-1]:g}] and "
                f"[{self.theta_[0]:g}, {self.theta_[-1]:g}]")
        V = np.asarray(dc["V_coal_pair"].values, float)
        if not np.isfinite(V).all():
            raise CapbridgeInputError(f"{src}: V_coal_pair has missing values")
        method = "cubic" if min(g.size, t.size) >= 4 else "linear"

        def W_at(values, gaps_axis, theta_axis=None):
            # the sorted gaps of a node are node values of the same axis: the values
            # on the tensor grid (splines along each axis, as RegularGridInterpolator's
            # "cubic"), then read at the sorted indices
            axes = [(g, gaps_axis)] * 3 + ([] if theta_axis is None else [(t, theta_axis)])
            Wt = values
            for a, (c, x) in enumerate(axes):
                Wt = refine_axis(Wt, a, c, x, None if method == "cubic" else 1)
            n = gaps_axis.size
            I = np.sort(np.stack(np.meshgrid(*(np.arange(n),) * 3, indexing="ij"), -1), -1)
            return Wt[I[..., 0], I[..., 1], I[..., 2]]

        resid = Vc_nodes - W_at(V, c4[0], c4[3])
        self.coalescence_residual_ = float(np.max(np.abs(resid) / Vc_nodes))
        Vfine = W_at(V, self.axes_[0].nodes, self.axes_[3].nodes) + \
            _refine(resid, c4, self.axes_[:4], self.method_)
        lin_fine = W_at(np.stack([dc["V0_pair"].values, dc["dV_pair"].values], -1),
                        self.axes_[0].nodes)
        self.coalescence_source_ = f"{src} (V_coal_pair, V0_pair, dV_pair; {method})"
        return Vfine, lin_fine

    def summary(self):
        """What the surrogate was fitted on and its error model (JSON-friendly dict),
        for ``capbridge info``: ``table`` (what the table says about itself, its stored
        error model included: :func:`~capbridge.tables.description.describe_table`),
        ``evolver`` (the cost and estimated error of its points:
        :func:`~capbridge.tables.description.describe_evolver_points`), the fit
        (method, refinement, axes, cells of the fine grid, coalescence volumes), the
        error measured at fit on the held-out points (``holdout_error``) and the
        gravity response (:meth:`gravity_summary`)."""
        self._check_fitted()
        cells = np.bincount(self.cell_code_.ravel(), minlength=4)
        return {"table": describe_table(self.table_, ("d12", "d13", "d23", "theta", "v")),
                "evolver": describe_evolver_points(self.table_),
                "method": self.method_, "kernel": self.kernel_, "refine": list(self.refine_),
                "gaps": self.gaps_.tolist(), "theta": self.theta_.tolist(),
                "v": self.v_.tolist(), "coalescence_volume": self.coalescence_source_,
                "cells": {"converged": int(cells[0]), "above_tolerance": int(cells[1]),
                          "not_converged": int(cells[2]), "no_equilibrium": int(cells[3])},
                "symmetrisation_max_change": self.asymmetry_,
                "separated_energy": bool(self.has_separated_energy_),
                "holdout_error": self.interpolation_error_,
                "max_bridge_gap": self.max_bridge_gap_,
                "unequal_radii": dict(UNEQUAL_RADII_ERROR),
                "open_side": {"mode": self.open_side, "limit": OPEN_SIDE_LINEAR_MAX,
                              **OPEN_SIDE_ERROR},
                "gravity": self.gravity_summary()}

    def spline_at(self, d12, d13, d23, theta, v):
        """The refined interpolant itself (splines along each axis, no fine grid) at
        points given by their volume ratio v: (n, 5) values of
        :data:`GRID_VARIABLES`.  Slow (a few splines per point); it measures the error
        of the fine-grid lookup (benchmark and tests), nothing else uses it."""
        self._check_fitted()
        coarse, vals = self._coarse
        pts = np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, float))
                                    for x in (d12, d13, d23, theta, v)))
        out = np.empty((pts[0].size, len(GRID_VARIABLES)))
        for n in range(pts[0].size):
            y = vals
            for a, (c, x) in enumerate(zip(coarse, pts)):
                y = refine_axis(y, 0, c, np.array([x.flat[n]]), _degree(self.method_, a))[0]
            out[n] = y[:len(GRID_VARIABLES)]
        return out

    @property
    def bounds_(self):
        """Table ranges: gaps, theta [deg], v (dict of (low, high))."""
        self._check_fitted()
        return {"gap": (self.gaps_[0], self.gaps_[-1]),
                "theta": (self.theta_[0], self.theta_[-1]), "v": (self.v_[0], self.v_[-1])}

    def covers(self, d12, d13, d23, theta, radii=None, unequal="harmonic_pair"):
        """True where the geometry and angle lie inside the table (any volume ratio).

        With ``radii`` (..., 3) (in the unit of the gaps), the gaps are first scaled as
        :meth:`predict_vectors` scales them for the ``unequal`` scheme (for the
        default, by the harmonic mean radius; the "pair" scheme: by every pair's
        Derjaguin radius, all three lookups must be covered)."""
        self._check_fitted()
        if radii is not None:
            return self._scaled(lambda g: self.covers(*g, theta), (d12, d13, d23), radii,
                                unequal, np.logical_and)
        lo, hi = self.gaps_[0] * (1 - _TOL) - _TOL, self.gaps_[-1] * (1 + _TOL)
        ok = np.ones(np.broadcast_shapes(*(np.shape(x) for x in (d12, d13, d23, theta))),
                     bool)
        for d in (d12, d13, d23):
            d = np.asarray(d, float)
            ok &= (d >= lo) & (d <= hi)
        ok |= self._beyond((d12, d13, d23)) & np.all(
            [x >= lo for x in np.broadcast_arrays(*(np.asarray(d, float)
                                                    for d in (d12, d13, d23)))], axis=0)
        t = np.asarray(theta, float)
        ok &= self._in_domain(*(np.asarray(d, float) for d in (d12, d13, d23)))
        return ok & (t >= self.theta_[0] - _TOL) & (t <= self.theta_[-1] * (1 + _TOL))

    def continues(self, d12, d13, d23, radii=None, unequal="harmonic_pair"):
        """True where an open side beyond the table is answered by its continuation
        (``open_side="linear"``, :mod:`~capbridge.surrogate.triplet_open_side`), the
        gaps scaled as in :meth:`covers`."""
        self._check_fitted()
        if radii is not None:
            return self._scaled(self._beyond, (d12, d13, d23), radii, unequal,
                                np.logical_or)
        return self._beyond((d12, d13, d23))

    @staticmethod
    def _scaled(test, gaps, radii, unequal, combine):
        """``test`` (of three gap arrays) on the gaps scaled as :meth:`predict_vectors`
        scales them for the ``unequal`` scheme, its lookups joined by ``combine``."""
        R = np.asarray(radii, float)
        equal = np.all(np.abs(R - R[..., :1]) <= 1e-12 * R[..., :1], axis=-1)
        out = None
        for lk, _ in {id(a): (a, b) for a, b in unequal_scales(R, equal, unequal)}.values():
            r = test([np.asarray(d, float) / lk for d in gaps])
            out = r if out is None else combine(out, r)
        return out

    def _beyond(self, gaps):
        """Where ``open_side="linear"`` continues the table (:func:`beyond_open_side`)."""
        if self.open_side != "linear":
            return np.zeros(np.broadcast_shapes(*(np.shape(x) for x in gaps)), bool)
        return beyond_open_side(gaps, float(self.gaps_[-1]), self.max_bridge_gap_)

    def _in_domain(self, d12, d13, d23):
        """True where the middle gap is at most the table's ``max_bridge_gap`` (always,
        for a table computed over its whole cube)."""
        if self.max_bridge_gap_ is None:
            return np.ones(np.broadcast_shapes(np.shape(d12), np.shape(d13), np.shape(d23)),
                           bool)
        mid = np.median(np.stack(np.broadcast_arrays(d12, d13, d23)), axis=0)
        return mid <= self.max_bridge_gap_ * (1 + _TOL) + _TOL

    def coalescence_volume(self, d12, d13, d23, theta):
        """V*_coal and its linear law (V0, dV) at a geometry and angle: dict of arrays.

        The volume scale of the table (v = V*/V*_coal); gaps and theta are checked as
        in :meth:`predict`.
        """
        self._check_fitted()
        g, _, t, shape = self._validate(d12, d13, d23, 1.0, theta)
        far = self._beyond(g)
        if not far.any():
            return {k: x.reshape(shape) for k, x in self._coalescence_at(g, t).items()}
        (edge, prev), w = self._open_side_nodes(g, far)
        ge = [x.copy() for x in g]
        for k in range(3):
            ge[k][far] = edge[k]
        out = self._coalescence_at(ge, t)
        inner = self._coalescence_at(prev, t[far])
        for k, x in out.items():
            x[far] += w * (x[far] - inner[k])
        return {k: x.reshape(shape) for k, x in out.items()}

    def _coalescence_at(self, g, t):
        """V*_coal, V0, dV at gaps g (three arrays) inside the table and angles t."""
        loc = [self.axes_[k].locate(x) for k, x in enumerate(list(g) + [t])]
        idx, fr = [a[0] for a in loc], [a[1] for a in loc]
        law = self.law_grid_(idx[:3], fr[:3])
        return {"volume_coalescence": self.coal_grid_(idx, fr)[:, 0], "V0": law[:, 0],
                "dV": law[:, 1]}

    def _open_side_nodes(self, g, far):
        """The points ``far`` with their open side at the table's last gap node and at
        the one before ((edge, prev): three arrays each), and the weight w of the
        continuation (:mod:`~capbridge.surrogate.triplet_open_side`)."""
        G = np.stack([x[far] for x in g])
        m = np.argmax(G, axis=0)
        d_max, d_prev = float(self.gaps_[-1]), float(self.gaps_[-2])
        rows = np.arange(G.shape[1])
        edge, prev = G.copy(), G.copy()
        edge[m, rows], prev[m, rows] = d_max, d_prev
        return (list(edge), list(prev)), (G[m, rows] - d_max) / (d_max - d_prev)

    # ------------------------------------------------------------------------- predict
    def _validate(self, d12, d13, d23, volume, theta):
        # DEM contacts (gap 0 or a small overlap) are answered at gap 0
        gaps = [check_gap(f"gap {n}", x) for n, x in (("d12", d12), ("d13", d13), ("d23", d23))]
        volume = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
        theta = check_range("theta", theta, 0.0, 90.0, high_open=True, units=" deg")
        shape = np.broadcast_shapes(*(x.shape for x in gaps), volume.shape, theta.shape)
        g = [np.broadcast_to(x, shape).ravel() for x in gaps]
        # equal spheres: centre distances 2 + d; a triangle needs each < sum of the others
        for (a, b, c), (na, nb, nc) in zip(((0, 1, 2), (1, 0, 2), (2, 0, 1)),
                                           (("d12", "d13", "d23"), ("d13", "d12", "d23"),
                                            ("d23", "d12", "d13"))):
            bad = g[a] >= 2.0 + g[b] + g[c]
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise CapbridgeInputError(
                    f"gaps d12={g[0][k]!r}, d13={g[1][k]!r}, d23={g[2][k]!r} do not form a "
                    f"triangle of centres: {na} must be < 2 + {nb} + {nc} (equal spheres "
                    f"of radius 1)")
        names = ("d12", "d13", "d23")
        far = self._beyond(g)
        for n, x in zip(names, g):
            self._range(f"gap {n}", np.where(far, np.minimum(x, self.gaps_[-1]), x),
                        self.gaps_, " (gap / r)")
        out = ~self._in_domain(*g)
        if out.any():
            k = int(np.flatnonzero(out)[0])
            raise CapbridgeInputError(
                f"gaps d12={g[0][k]!r}, d13={g[1][k]!r}, d23={g[2][k]!r}: two of them are "
                f"above the triplet table's max_bridge_gap {self.max_bridge_gap_:g} (the "
                "table covers triplets whose two bridges on the shared grain have gaps up "
                "to it); solve it with Surface Evolver (capbridge solve triplet)")
        self._range("theta", np.broadcast_to(theta, shape).ravel(), self.theta_, " deg")
        return g, np.broadcast_to(volume, shape).ravel(), \
            np.broadcast_to(theta, shape).ravel(), shape

    def _range(self, name, x, axis, units):
        lo, hi = axis[0], axis[-1]
        outside = (x < lo - _TOL * max(1.0, abs(lo))) | (x > hi + _TOL * max(1.0, abs(hi)))
        if outside.any():
            beyond = "" if not (units.startswith(" (gap") and self.open_side == "linear"
                                and self.max_bridge_gap_ is not None) else \
                f" (open_side='linear' continues an open side up to {OPEN_SIDE_LINEAR_MAX:g})"
            raise CapbridgeInputError(
                f"{name}={x[outside][0]!r}{units.split(' (')[0]} is outside the triplet "
                f"table's range [{lo:g}, {hi:g}]{beyond}; another geometry or angle is "
                "another body: solve it with Surface Evolver (capbridge solve triplet)")

    def predict(self, d12, d13, d23, volume, theta):
        """The coalesced body on three equal spheres: dict of arrays (broadcast shape).

        Parameters
        ----------
        d12, d13, d23 : array_like
            Gaps between the sphere surfaces d* = d/r [-], forming a triangle; contacts
            of a DEM (overlaps down to -:data:`~capbridge.validation.CONTACT_OVERLAP_MAX`)
            are looked up at 0.
        volume : array_like
            Total liquid volume V* = V/r^3 [-], > 0.
        theta : array_like
            Contact angle [deg] on the three grains, in [0, 90) and inside the table.

        Returns
        -------
        dict
            ``f12``, ``f13``, ``f23``: effective pair forces F* along the centre lines
            (attraction > 0); ``pressure`` P*; ``energy`` E* (Richardson-extrapolated
            surface energy); ``volume_coalescence`` V*_coal; ``v`` = V*/V*_coal (the
            table coordinate; clipped values are the ones looked up); ``V0``, ``dV``
            (V*_coal = V0 + (theta/90) dV per geometry); ``energy_difference``
            E_coalesced - E_separated (NaN if unknown); ``lower_energy_state`` (codes
            :data:`LOWER_ENERGY_STATES`); ``force_error`` (estimated absolute error of
            the pair forces, F*: the largest Evolver estimate of the cell's table nodes
            plus the held-out interpolation error a max |f_ij| + b,
            ``interpolation_error_["relative"]``, ``["absolute"]``:
            :func:`~capbridge.surrogate.triplet_holdout.holdout_errors`);
            ``status`` (int8 :class:`~capbridge.status.Status`).  Points without a
            result have NaN forces, pressure and energy.
        """
        self._check_fitted()
        g, V, t, shape = self._validate(d12, d13, d23, volume, theta)
        far = self._beyond(g)
        out = self._lookup(g, V, t) if not far.any() else self._lookup_open_side(g, V, t, far)
        return {k: v.reshape(shape) for k, v in out.items()}

    def _lookup_open_side(self, g, V, t, far):
        """:meth:`_lookup` where the points ``far`` have an open side beyond the table:
        the continuation of :mod:`~capbridge.surrogate.triplet_open_side` (two lookups
        at fixed v), status APPROXIMATE where both have a result."""
        (edge, prev), w = self._open_side_nodes(g, far)
        tf = t[far]
        ce, cp = self._coalescence_at(edge, tf), self._coalescence_at(prev, tf)
        vc = ce["volume_coalescence"] + w * (ce["volume_coalescence"] -
                                             cp["volume_coalescence"])
        v = V[far] / vc
        # a volume outside the table is named with the asked gaps, V* and V*_coal
        self._raise_out_of_range({"_v_asked": v, "volume_coalescence": vc},
                                 [x[far] for x in g], V[far], tf)
        e = self._lookup(edge, v * ce["volume_coalescence"], tf)
        p = self._lookup(prev, v * cp["volume_coalescence"], tf)
        out = {k: np.empty(V.size, x.dtype) for k, x in e.items()}
        near = ~far
        if near.any():
            for k, x in self._lookup([x[near] for x in g], V[near], t[near]).items():
                out[k][near] = x
        for k, x in e.items():
            if x.dtype.kind == "f" and k not in ("v", "force_error"):
                x = x + w * (x - p[k])
            out[k][far] = x
        out["volume_coalescence"][far] = vc
        out["v"][far] = e["v"]
        # the continuation's own measured error on top of the two lookups' estimates
        fmax = np.max(np.abs(np.stack([out[n][far] for n in PAIR_NAMES])), axis=0)
        out["force_error"][far] = np.maximum(e["force_error"], p["force_error"]) + \
            OPEN_SIDE_ERROR["max"] * fmax
        st = combine_status(e["status"], p["status"])
        has = status_in(st, (Status.CONVERGED, Status.ABOVE_TOLERANCE))
        out["status"][far] = np.where(has, np.int8(Status.APPROXIMATE), st)
        lower = e["lower_energy_state"]
        out["lower_energy_state"][far] = np.where(lower == p["lower_energy_state"], lower,
                                                  np.int8(2))   # undecided
        return out

    def _lookup(self, g, V, t, chunk=16384):
        n = V.size
        out = {k: np.empty(n) for k in GRID_VARIABLES + (
            "volume_coalescence", "v", "V0", "dV", "energy_difference", "force_error")}
        out["_v_asked"] = np.empty(n)
        out["status"] = np.empty(n, np.int8)
        out["lower_energy_state"] = np.empty(n, np.int8)
        for s in range(0, n, chunk):
            sl = slice(s, min(s + chunk, n))
            part = self._lookup_chunk([x[sl] for x in g], V[sl], t[sl])
            for k, v in part.items():
                out[k][sl] = v
        self._raise_out_of_range(out, g, V, t)
        return out

    def _lookup_chunk(self, g, V, t):
        ax = self.axes_
        loc = [ax[k].locate(x) for k, x in zip(range(4), g + [t])]
        idx4 = [a[0] for a in loc]
        frac4 = [a[1] for a in loc]
        order = _Descending()
        for a, f in enumerate(frac4[:3]):
            order = order.insert(f, a)
        law = self.law_grid_(idx4[:3], frac4[:3], order)
        order = order.insert(frac4[3], 3)
        Vc = self.coal_grid_(idx4, frac4, order)[:, 0]
        v = V / Vc
        lo, hi = self.v_[0], self.v_[-1]
        below, above = v < lo * (1 - _TOL), v > hi * (1 + _TOL)
        vq = np.clip(v, lo, hi)
        iv, fv = ax[4].locate(vq)
        vals = self.grid_(idx4 + [iv], frac4 + [fv], order.insert(fv, 4))
        cidx = 0
        cshape = self.cell_code_.shape
        for k, i in enumerate(idx4 + [iv]):
            c = np.minimum(i // ax[k].refine, cshape[k] - 1)
            cidx = cidx * cshape[k] + c
        code = self.cell_code_.ravel()[cidx]
        status = np.array([Status.CONVERGED, Status.ABOVE_TOLERANCE, Status.NOT_CONVERGED,
                           Status.NO_EQUILIBRIUM], np.int8)[code]
        status = np.where(above & (code <= 1), np.int8(Status.EXTRAPOLATED), status)
        status = np.where(below & (code <= 2), np.int8(Status.OUT_OF_RANGE), status)
        res = {name: vals[:, k] for k, name in enumerate(GRID_VARIABLES)}
        fmax = np.max(np.abs(vals[:, :3]), axis=1)
        ie = self.interpolation_error_ or {"relative": 0.0, "absolute": 0.0}
        # the held-out error model: relative to the largest pair force, plus an
        # absolute part measured where the body barely pulls (triplet_holdout)
        res["force_error"] = self.cell_force_error_.ravel()[cidx] + \
            ie["relative"] * fmax + ie["absolute"]
        nores = ~status_in(status, (Status.CONVERGED, Status.ABOVE_TOLERANCE,
                                    Status.EXTRAPOLATED))
        for name in GRID_VARIABLES + ("force_error",):
            res[name] = np.where(nores, np.nan, res[name])
        lower = np.full(V.size, _UNKNOWN, np.int8)
        if self.has_separated_energy_:
            dE = np.where(nores, np.nan, vals[:, len(GRID_VARIABLES)])
            err = self.cell_energy_error_.ravel()[cidx]
            lower = np.where(dE < -err, 0, np.where(dE > err, 1, 2)).astype(np.int8)
            nosep = self.cell_no_separated_.ravel()[cidx]      # 0 all, 1 some, 2 none
            lower = np.where(nosep == 2, 0, np.where(nosep == 1, 2, lower)).astype(np.int8)
            lower[nores] = _UNKNOWN
            dE = np.where(nores | (nosep > 0), np.nan, dE)
            res["energy_difference"] = dE
        else:
            res["energy_difference"] = np.full(V.size, np.nan)
        res.update({"volume_coalescence": Vc, "v": np.where(below | above, vq, v),
                    "V0": law[:, 0], "dV": law[:, 1], "status": status.astype(np.int8),
                    "lower_energy_state": lower, "_v_asked": v})
        return res

    def _raise_out_of_range(self, out, g, V, t):
        v = out.pop("_v_asked")
        lo, hi = self.v_[0], self.v_[-1]
        outside = (v < lo * (1 - _TOL)) | (v > hi * (1 + _TOL))
        if self.out_of_range == "raise" and outside.any():
            k = int(np.flatnonzero(outside)[0])
            raise CapbridgeInputError(
                f"volume V*={V[k]!r} gives v = V*/V*_coal = {v[k]:.6g} (V*_coal = "
                f"{out['volume_coalescence'][k]:.6g} at d12={g[0][k]:g}, d13={g[1][k]:g}, "
                f"d23={g[2][k]:g}, theta={t[k]:g}), outside the triplet table's range "
                f"[{lo:g}, {hi:g}] ({int(outside.sum())} of {v.size} points); use "
                f"{self.clip_hint} (above the range: answered at its edge, status "
                "'extrapolated'; below it: no number) or Surface Evolver (capbridge "
                "solve triplet)")

    # ---------------------------------------------------------------------- vectors
    def predict_vectors(self, centres, volume, theta, radii=None, unequal="harmonic_pair",
                        bond=0.0, gravity=None):
        """Force vectors on the three grains in the caller's frame, from the centres.

        Parameters
        ----------
        centres : array_like (..., 3, 3)
            Centres of grains 1, 2, 3 (rows), in units of the normalising radius r
            (radius 1 for equal spheres).  Grains in contact may overlap (a DEM
            contact) by up to :data:`~capbridge.validation.CONTACT_OVERLAP_MAX` of the
            pair's smaller radius: that pair is looked up at gap 0 (forces still along
            the actual centre lines); deeper overlaps are an error.
        volume : array_like (...)
            Total liquid volume V* = V/r^3.
        theta : array_like (...)
            Contact angle [deg].
        radii : array_like (..., 3), optional
            Grain radii / r.  Unequal radii use the approximation of the module
            docstring (status APPROXIMATE); equal radii R scale the equal-sphere
            answer exactly (lengths / R, forces * R).
        unequal : {"harmonic_pair", "pair", "harmonic", "arithmetic"}
            The unequal-radii approximation (:data:`UNEQUAL_SCHEMES`, compared in
            ``benchmarks/bench_triplet.py``); the default has the smallest error.
        bond : array_like (...), default 0
            Bond number Bo = drho g r^2 / gamma of the normalising radius r, in
            [0, :data:`BOND_MAX`].  Bo = 0 gives exactly the answer without gravity.
        gravity : array_like (..., 3), optional
            Direction along which gravity pulls, in the frame of ``centres`` (any
            length > 0); default (0, 0, -1).

        Returns
        -------
        dict
            ``forces`` (..., 3, 3): F_i = sum_j f_ij u_ij on each grain (u_ij the unit
            vector from i to j; F* = F/(2 pi gamma r)); without gravity they sum to zero
            and have no torque about the grain centres.  Also the pair forces ``f12``,
            ``f13``, ``f23`` (F*, without gravity), ``gaps`` (..., 3) = (d12, d13, d23)
            / r from the centres (negative for an overlap), and the other keys of :meth:`predict` (pressure in gamma/r, energy in
            gamma r^2, volumes in r^3; for unequal radii those of the lookup at R_h,
            status APPROXIMATE).

            With gravity (Bo > 0), b = Bo g_hat and, per grain (table frame of the
            gaps, :func:`table_frame`, rotated into the caller's by Q)

                F_i(b) = F_i(0) + Q (G_i b_t + C_i b_t^2 / 2),   b_t = Q^T b

            (:func:`~capbridge.physics.gravity.triplet_gravity_forces`, G and C the
            table's response interpolated on (gaps, theta, v)); ``forces`` then sum to
            V*/(2 pi) b (the liquid's weight) up to ``gravity_sum_residual`` (relative,
            the largest of the cell's nodes) and the second-order terms.  Extra keys:
            ``gravity`` (..., 3) = b, ``gravity_first_order`` and
            ``gravity_second_order`` (..., 3, 3) the two terms added to F_i(0),
            ``gravity_sum_residual``, ``status_without_gravity`` (the status of
            F_i(0)).  Statuses: a cell of the response without a result
            -> NOT_CONVERGED, no number; v outside the response's ``gravity_v`` range ->
            the response at the nearest v, APPROXIMATE; Bo above the validated
            ``gravity_bond_max_`` -> APPROXIMATE.  Bo above :data:`BOND_MAX` or a table
            without a gravity response: CapbridgeInputError.
        """
        self._check_fitted()
        C = check_range("centres", centres)
        if C.shape[-2:] != (3, 3):
            raise CapbridgeInputError(f"centres must have shape (..., 3, 3) (three grains, "
                                      f"x y z), got {C.shape}")
        R = np.ones(C.shape[:-1]) if radii is None else \
            check_range("radii", radii, 0.0, np.inf, low_open=True)
        R = np.broadcast_to(R, C.shape[:-1])
        V = check_range("volume V*", volume, 0.0, np.inf, low_open=True)
        t = check_range("theta", theta, units=" deg")
        shapes = [C.shape[:-2], V.shape, t.shape, np.shape(bond)]
        if gravity is not None:
            shapes.append(np.shape(gravity)[:-1])
        try:
            shape = np.broadcast_shapes(*shapes)
        except ValueError:
            raise CapbridgeInputError(
                f"centres {C.shape}, volume {V.shape}, theta {t.shape}, bond "
                f"{np.shape(bond)}" + ("" if gravity is None else
                                       f", gravity {np.shape(gravity)}")
                + " do not broadcast to one shape (centres (..., 3, 3), gravity (..., 3), "
                  "the others (...))") from None
        C = np.broadcast_to(C, shape + (3, 3))
        R = np.broadcast_to(R, shape + (3,))
        V = np.broadcast_to(V, shape)
        t = np.broadcast_to(t, shape)
        u, dist = {}, {}
        for p in PAIRS:
            d = C[..., p[1], :] - C[..., p[0], :]
            dist[p] = np.linalg.norm(d, axis=-1)
            u[p] = d / np.where(dist[p] > 0, dist[p], 1.0)[..., None]
        gaps = np.stack([dist[(i, j)] - R[..., i] - R[..., j] for i, j in PAIRS], -1)
        # contacts rebuilt from centres come back as -1e-16, DEM contacts overlap a little:
        # both are gap 0 for the lookup; deeper overlaps are refused (per grain pair,
        # relative to the pair's smaller radius)
        limit = np.stack([CONTACT_OVERLAP_MAX * np.minimum(R[..., i], R[..., j])
                          + 1e-12 * dist[(i, j)] for i, j in PAIRS], -1)   # + round-off
        deep = gaps < -limit
        if np.any(deep):
            k = np.argwhere(deep)[0]
            i, j = PAIRS[k[-1]]
            raise CapbridgeInputError(
                f"grains {i + 1} and {j + 1} overlap by {-gaps[tuple(k)]:.6g} (gap "
                f"{gaps[tuple(k)]:.6g}), more than {CONTACT_OVERLAP_MAX:g} of the smaller "
                f"radius; overlaps up to that are DEM contacts (gap 0), deeper ones are not "
                f"supported")
        lookup_gaps = np.maximum(gaps, 0.0)
        equal = np.all(np.abs(R - R[..., :1]) <= 1e-12 * R[..., :1], axis=-1)
        looks = []                 # per pair: (lookup scale, force scale, lookup)
        cache = {}
        for k, (lk, fk) in enumerate(unequal_scales(R, equal, unequal)):
            if id(lk) not in cache:
                cache[id(lk)] = self.predict(*(lookup_gaps[..., m] / lk for m in range(3)),
                                             V / lk**3, t)
            looks.append((lk, fk, cache[id(lk)]))
        s, _, r = looks[0]
        res = dict(r)
        res["pressure"] = r["pressure"] / s
        res["energy"] = r["energy"] * s**2
        for name in ("volume_coalescence", "V0", "dV"):
            res[name] = r[name] * s**3
        f = [look[PAIR_NAMES[k]] * fk for k, (_, fk, look) in enumerate(looks)]
        res["force_error"] = np.max([look["force_error"] * fk for _, fk, look in looks], 0)
        status = r["status"]
        for _, _, look in looks[1:]:
            status = combine_status(status, look["status"])
        if not np.all(equal):
            has = status_in(status, (Status.CONVERGED, Status.ABOVE_TOLERANCE))
            status = np.where(has & ~equal, np.int8(Status.APPROXIMATE), status)
        res["status"] = np.asarray(status, np.int8)
        for k, name in enumerate(PAIR_NAMES):
            res[name] = f[k]
        F = np.zeros(shape + (3, 3))
        for k, (i, j) in enumerate(PAIRS):
            F[..., i, :] += f[k][..., None] * u[(i, j)]
            F[..., j, :] -= f[k][..., None] * u[(i, j)]
        res["forces"] = F
        res["gaps"] = gaps
        if np.any(np.asarray(bond, float) != 0) or gravity is not None:
            self._add_gravity(res, C, V, t, lookup_gaps, s, shape, bond, gravity)
        return res


    def predict_si(self, radius, surface_tension, centres, volume, theta,
                   density_difference=None, gravity=None):
        """Force vectors in newtons from SI inputs.

        Parameters
        ----------
        radius : float or array_like (..., 3)
            Grain radius [m] (one for equal spheres, or one per grain: unequal radii
            are approximated, status APPROXIMATE).
        surface_tension : float
            gamma [N/m].
        centres : array_like (..., 3, 3)
            Grain centres [m].
        volume : array_like (...)
            Total liquid volume [m^3].
        theta : array_like (...)
            Contact angle [deg].
        density_difference : float, optional
            drho = rho_liquid - rho_gas [kg/m^3]: gravity on the liquid.
        gravity : array_like (3,), optional
            Acceleration of gravity [m/s^2] in the frame of ``centres`` (default
            (0, 0, -9.81) when ``density_difference`` is given).  Bo = drho |g| R_min^2
            / gamma (:func:`capbridge.dimensionless.bond_number`), passed to
            :meth:`predict_vectors`.

        Returns
        -------
        dict
            ``forces`` (..., 3, 3) [N] on each grain (with gravity if asked),
            ``f12``, ``f13``, ``f23`` [N] (attraction > 0, without gravity),
            ``pressure`` [Pa], ``volume_coalescence`` [m^3], ``gaps`` [m],
            ``force_error`` [N], ``status``; with gravity also ``bond``.
        """
        from capbridge.dimensionless import force_scale, pressure_scale

        self._check_fitted()
        slip = "SI units expected: radii in m, surface_tension in N/m (a unit slip?)"
        R = check_range("predict_si radius", radius, *SI_RADIUS_RANGE, units=" m",
                        hint=slip)
        gamma = check_range("predict_si surface_tension", surface_tension,
                            *SI_SURFACE_TENSION_RANGE, units=" N/m", hint=slip)
        C = check_range("predict_si centres", centres, units=" m")
        Vm = check_range("predict_si volume", volume, 0.0, np.inf, low_open=True,
                         units=" m^3")
        # a last axis of length 3 is one radius per grain; anything else one per triplet
        Rg = R if (R.ndim and R.shape[-1] == 3) else np.repeat(R[..., None], 3, -1)
        r = np.min(Rg, axis=-1)                              # normalising radius
        kw = {}
        if density_difference is not None or gravity is not None:
            bond, direction = si_bond(r, gamma, 0.0 if density_difference is None
                                      else density_difference,
                                      (0.0, 0.0, -9.81) if gravity is None else gravity)
            kw = {"bond": bond, "gravity": direction}
        try:
            res = self.predict_vectors(C / r[..., None, None], Vm / r**3, theta,
                                       radii=Rg / r[..., None], **kw)
        except CapbridgeInputError as exc:
            raise CapbridgeInputError(
                f"predict_si: {exc} (lengths / R_min, V* = volume [m^3] / R_min^3, R_min "
                "the smallest radius [m]; theta in degrees)") from None
        fs = force_scale(r, gamma)
        out = {"forces": res["forces"] * fs[..., None, None], "status": res["status"],
               "pressure": res["pressure"] * pressure_scale(r, gamma),
               "volume_coalescence": res["volume_coalescence"] * r**3,
               "gaps": res["gaps"] * r[..., None], "force_error": res["force_error"] * fs}
        for name in PAIR_NAMES:
            out[name] = res[name] * fs
        if kw:
            out["bond"] = np.asarray(kw["bond"])
        return out
