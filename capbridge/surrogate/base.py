"""The contract every capbridge surrogate follows (doublet, triplet, sphere-wall).

A surrogate is a scikit-learn estimator (:class:`sklearn.base.BaseEstimator`: its
constructor only stores its settings, ``get_params``/``set_params``/``repr`` work) that
is fitted on a table of exact solutions and then looked up:

* ``fit(table, ...)`` loads and checks the table and returns ``self``; every fitted
  attribute ends in ``_`` (``table_``, ``has_gravity_``, ...).
* Every method, and every fitted attribute, of a surrogate that is not fitted raises
  :class:`SurrogateNotFittedError`: a :class:`sklearn.exceptions.NotFittedError` (so a
  ``ValueError`` and an ``AttributeError``) that is also a ``RuntimeError``, the error
  raised before this contract (old ``except RuntimeError`` clauses keep working).
* ``has_gravity_`` (bool): the table carries a response to gravity on the liquid.
  (``DoubletSurrogate.has_gravity()``, the old spelling, is a deprecated alias.)
* ``summary()``: what the surrogate was fitted on and its error model, a JSON-friendly
  dict (what ``capbridge info`` prints); fitted on a table file, it holds under
  ``table`` what the table says about itself
  (:func:`capbridge.tables.description.describe_table`).
* Output names: the API's dict keys (``force``, ``pressure``, ``rupture_gap``, ...)
  and the CSV columns of ``capbridge lookup`` (``F``, ``P``, ``d_rupt``, ...) are mapped
  in one place, :data:`CSV_COLUMNS`; :data:`DOUBLET_OUTPUTS`, :data:`TRIPLET_OUTPUTS`
  and :data:`WALL_OUTPUTS` list the numbers each lookup writes (:func:`csv_columns`).
* Bad input: :class:`~capbridge.validation.CapbridgeInputError`, naming the value and
  the allowed range, never a number.
* A status per point (:class:`~capbridge.status.Status`, int8) wherever a lookup reports
  a state, including the internal lookups of the gravity response: CONVERGED (a
  number), APPROXIMATE (a number outside the validated range, e.g. clipped to the edge
  of a sub-grid or from a node ABOVE_TOLERANCE), NOT_CONVERGED (no number: a node has
  no result).  :func:`worst_status` combines them.

The no-result rule (:func:`apply_no_result_rule`)
---------------------------------------------------
It applies to the numbers that describe the liquid body at the point: forces (scalar
and vectors), pressure, filling angles, energy and their error estimates.  Only points
whose status is in :data:`WITH_NUMBER` (CONVERGED, ABOVE_TOLERANCE, APPROXIMATE,
EXTRAPOLATED) carry them.  A RUPTURED bridge (a doublet or a sphere-wall bridge beyond
its rupture distance) really has no force: its forces are 0, its other numbers
(pressure, angles) NaN.  Every other status (NOT_CONVERGED, OUT_OF_RANGE,
NO_EQUILIBRIUM, COALESCED, NOT_COMPUTED) has no number: NaN.  Quantities of the
geometry and the volume rather than of the body at this point (``rupture_gap``,
``volume_coalescence``, ``v``, ``V0``, ``dV``) and the interpolated inputs reported
for diagnosis (``share``, ``curvature``, ...) are kept.  Never a silent NaN: the status
says why.  (Before the contract the doublet and triplet already agreed on this; it is
now stated once, here, and checked for both and for the sphere-wall surrogate.)
"""
from __future__ import annotations

import warnings

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.exceptions import NotFittedError

from capbridge.status import HAS_RESULT, Status, status_in
from capbridge.surrogate.names import (CSV_COLUMNS, DOUBLET_OUTPUTS, OUTPUT_NAMES,
                                      TRIPLET_OUTPUTS, WALL_OUTPUTS, csv_columns)

__all__ = ["SurrogateBase", "SurrogateNotFittedError", "OUTPUT_NAMES", "CSV_COLUMNS",
           "DOUBLET_OUTPUTS", "TRIPLET_OUTPUTS", "WALL_OUTPUTS", "csv_columns",
           "WITH_NUMBER", "apply_no_result_rule", "worst_status", "has_number"]


class SurrogateNotFittedError(NotFittedError, RuntimeError):
    """A surrogate used before ``fit``: a scikit-learn ``NotFittedError`` (ValueError,
    AttributeError) that is also the ``RuntimeError`` raised before."""


#: statuses whose outputs are numbers (the rest: see the module's no-result rule)
WITH_NUMBER = HAS_RESULT + (Status.EXTRAPOLATED,)

# severity of a status when several lookups answer one point: a number first, then a
# number outside the validated range, then none
_SEVERITY = np.full(max(Status) + 1, 3, np.int8)
_SEVERITY[[Status.CONVERGED, Status.ABOVE_TOLERANCE, Status.EXTRAPOLATED,
           Status.APPROXIMATE]] = (0, 1, 1, 2)


def worst_status(a, *others):
    """Elementwise the most severe of the statuses: CONVERGED < ABOVE_TOLERANCE,
    EXTRAPOLATED < APPROXIMATE < any status without a number (int8 arrays)."""
    out = np.asarray(a, np.int8)
    for b in others:
        b = np.asarray(b, np.int8)
        out = np.where(_SEVERITY[b] > _SEVERITY[out], b, out).astype(np.int8)
    return out


def has_number(status):
    """True where the status carries numbers (:data:`WITH_NUMBER`)."""
    return status_in(status, WITH_NUMBER)


def apply_no_result_rule(out, status, forces=("force",), keep=("rupture_gap",)):
    """Apply the no-result rule in place to the arrays of ``out`` (shape of ``status``
    or with trailing dims): RUPTURED -> ``forces`` 0, other outputs NaN; no number ->
    NaN; names in ``keep`` and ``status`` are left alone.  Returns ``out``."""
    status = np.asarray(status)
    ruptured = status == Status.RUPTURED
    nores = ~has_number(status) & ~ruptured
    for name, arr in out.items():
        if name == "status" or name in keep or not isinstance(arr, np.ndarray) \
                or arr.dtype.kind != "f":
            continue
        arr[ruptured] = 0.0 if name in forces else np.nan
        arr[nores] = np.nan
    return out


class SurrogateBase(BaseEstimator):
    """Base of the capbridge surrogates: the contract of the module docstring
    (:mod:`capbridge.surrogate.base`), in particular the no-result rule."""

    #: the attribute ``fit`` sets; its absence means "not fitted"
    _fitted_marker = "table_"

    def __sklearn_is_fitted__(self):
        return self._fitted_marker in self.__dict__

    def _check_fitted(self):
        if self._fitted_marker not in self.__dict__:
            raise SurrogateNotFittedError(
                f"{type(self).__name__} is not fitted: call fit(table) first")

    def __getattr__(self, name):
        # only called when normal lookup fails: a fitted attribute of an unfitted
        # surrogate is a NotFittedError (an AttributeError: hasattr() stays False)
        if name.endswith("_") and not name.startswith("_") and \
                self._fitted_marker not in self.__dict__:
            raise SurrogateNotFittedError(
                f"{type(self).__name__} is not fitted (no {name}): call fit(table) first")
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def summary(self):
        """What the surrogate was fitted on and its error model (JSON-friendly dict)."""
        raise NotImplementedError

    def has_gravity(self):
        """Deprecated alias of the attribute :attr:`has_gravity_`."""
        warnings.warn(f"{type(self).__name__}.has_gravity() is deprecated: use the "
                      "attribute has_gravity_", DeprecationWarning, stacklevel=2)
        self._check_fitted()
        return bool(self.has_gravity_)
