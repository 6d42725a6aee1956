"""The error model a new table carries: its surrogate checked on held-out points.

A table is only as useful as the trust its lookups deserve, so a table just built
(:func:`~capbridge.tables.doublet.build_doublet_table`,
:func:`~capbridge.tables.triplet.build_triplet_table`) gets, before it is saved, the
errors of its own surrogate against exact answers it was not built from, as attributes
(``holdout_*``, ``gravity_holdout_*``) that ``capbridge info`` and the surrogates'
``summary()`` report.  The surrogate lives above the tables, so this step is here and
not in the builders.
"""
from __future__ import annotations

import numpy as np

from capbridge.surrogate.doublet import (DEFAULT_REFINE, DEFAULT_THETA_STEP, DoubletSurrogate,
                                         gravity_holdout_errors)
from capbridge.surrogate.doublet import holdout_errors as doublet_holdout_errors
from capbridge.surrogate.triplet import TripletSurrogate
from capbridge.surrogate.triplet_holdout import SMALL_FORCE
from capbridge.surrogate.triplet_holdout import holdout_errors as triplet_holdout_errors

#: the doublet check leaves out s < HOLDOUT_BAND (d* > 0.96 d*_rupt), where dF/dd*
#: diverges at the fold (one check at ratio 1 keeps it, band 0)
HOLDOUT_BAND = 0.2


def store_doublet_error_model(ds, n_holdout=600, n_gravity_holdout=40, progress=False):
    """Check a new doublet table's surrogate on held-out exact solutions and store the
    errors in ``ds.attrs``.

    Parameters
    ----------
    ds : xarray.Dataset
        A doublet table (:func:`~capbridge.tables.doublet.build_doublet_table`).
    n_holdout : int
        Random points per check (:func:`~capbridge.surrogate.doublet.holdout_errors`):
        at every tabulated ratio and halfway (in log) between them, with the band
        :data:`HOLDOUT_BAND` left out, and at ratio 1 with nothing left out.
    n_gravity_holdout : int
        Points of the check with gravity along the axis
        (:func:`~capbridge.surrogate.doublet.gravity_holdout_errors`), if the table has
        a gravity response.
    progress : bool
        Progress bar of the check with gravity.

    Returns
    -------
    xarray.Dataset
        ``ds``, with the attributes ``holdout_*`` (refinement settings, then per check
        the median and max relative error of the force and the number of points) and
        ``gravity_holdout_*``.
    """
    sur = DoubletSurrogate(DEFAULT_REFINE, DEFAULT_THETA_STEP).fit(ds)
    ds.attrs["holdout_refine"] = DEFAULT_REFINE
    ds.attrs["holdout_theta_step"] = DEFAULT_THETA_STEP
    r = np.asarray(ds["ratio"].values)
    between = np.sqrt(r[1:] * r[:-1])  # halfway (in log) between tabulated ratios
    checks = [(1.0, 0.0)] if 1.0 in r else []
    checks += [(float(x), HOLDOUT_BAND) for x in np.sort(np.concatenate([r, between]))]
    for ratio, band in checks:
        h = doublet_holdout_errors(sur, n=n_holdout, seed=1, ratio=ratio, exclude_band=band)
        _store_holdout(ds.attrs, h, "force", f"ratio{ratio:.4g}_band{band:g}")
    ds.attrs["holdout_description"] = (
        "relative error of the surrogate force against the exact solver at random points "
        "uniform in theta, log V*, and s = sqrt(1 - d*/d*_rupt) in [band, 1]; band 0.2 leaves "
        "out d* > 0.96 d*_rupt, where dF/dd* diverges at the fold; ratios on the grid and "
        "halfway between (cubic spline across ratio slices)")
    if sur.has_gravity_:
        _store_gravity_holdout(ds.attrs, gravity_holdout_errors(
            sur, n=n_gravity_holdout, progress=progress))
    return ds


def store_triplet_error_model(ds, coalescence_table=None):
    """Check a new triplet table's surrogate on its held-out Surface Evolver points and
    store the errors in ``ds.attrs``.

    Parameters
    ----------
    ds : xarray.Dataset
        A triplet table with held-out points
        (:func:`~capbridge.tables.triplet.build_triplet_table`, ``n_holdout`` > 0).
    coalescence_table : path or xarray.Dataset, optional
        The coalescence volumes the surrogate is fitted with (as the users' lookups
        will be).

    Returns
    -------
    xarray.Dataset
        ``ds``, with the attributes ``holdout_*`` of the pair forces looked up at the
        total volume (``by_volume``) and at the volume ratio (``by_v``).
    """
    sur = TripletSurrogate(method="auto").fit(ds, coalescence_table=coalescence_table)
    for by in ("volume", "v"):
        h = triplet_holdout_errors(sur, by=by)
        _store_holdout(ds.attrs, h, "pair_force", f"by_{by}")
        # the error model the surrogate applies: a max|f| + b
        ds.attrs[f"holdout_error_relative_to_largest_by_{by}"] = h["relative"]
        ds.attrs[f"holdout_error_absolute_by_{by}"] = h["absolute"]
        ds.attrs[f"holdout_n_small_force_by_{by}"] = h["n_small"]
    ds.attrs["holdout_description"] = (
        "relative error of the surrogate's pair forces f12, f13, f23 (method auto: cubic, "
        "linear in the gaps on a table computed over part of its cube; "
        "default settings) against held-out Surface Evolver points one refinement level "
        "finer than the table, at random canonical geometries, theta and v inside the "
        "grid; by_volume: looked up at the total volume (includes the error of V_coal), "
        "by_v: at the volume ratio (the force interpolation alone); error_relative_to_"
        "largest: max |f - f_held| / max|f| over the points whose largest held-out pair "
        f"force is at least {SMALL_FORCE:g} F*, error_absolute: max |f - f_held| (F*) over "
        "the others "
        "(n_small_force of them): |f - f_held| <= relative max|f| + absolute at every "
        "held-out pair force")
    return ds


def _store_holdout(attrs, h, quantity, tag):
    """Write one holdout check (median, max relative error of ``quantity``, n) as
    table attributes ``holdout_{median,max}_rel_error_{quantity}_{tag}``,
    ``holdout_n_{tag}``."""
    attrs[f"holdout_median_rel_error_{quantity}_{tag}"] = h["median_rel_error"]
    attrs[f"holdout_max_rel_error_{quantity}_{tag}"] = h["max_rel_error"]
    attrs[f"holdout_n_{tag}"] = h["n"]


def _store_gravity_holdout(attrs, h):
    """The doublet table's held-out check with gravity (:func:`~capbridge.surrogate.
    doublet.gravity_holdout_errors`) as ``gravity_holdout_*`` attributes, one value per
    Bo of ``gravity_holdout_bonds``."""
    for k in ("bonds", "max_error", "median_error", "max_effect_error",
              "max_effect_error_converged", "n", "n_approximate", "n_exact_failed"):
        attrs[f"gravity_holdout_{k}"] = np.asarray(h[k], int if k.startswith("n") else float)
    attrs["gravity_holdout_estimate_ratio_max"] = float(h["estimate_ratio_max"])
    attrs["gravity_holdout_description"] = (
        f"{h['n_points']} random points (theta, log V* over the response's sub-grid, "
        f"s in [{h['exclude_band']:g}, 1], every ratio in turn), gravity along the axis "
        "both ways, against the exact axisymmetric solver: largest error over the two "
        "grains relative to the exact attraction at Bo = 0; effect: of the gravity part "
        "F(b) - F(0) alone; converged: lookups whose own estimate gravity_error is below "
        "gravity_response_rtol; estimate_ratio_max: the largest effect error over that "
        "estimate (interpolation between the response's nodes is not in the estimate)")
