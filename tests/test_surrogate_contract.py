"""The surrogate contract (capbridge.surrogate.base) on the doublet and triplet surrogates:
scikit-learn estimators, NotFittedError before fit, fit returns self, has_gravity_,
summary(), Status codes, one no-result rule, one set of output names."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import NotFittedError

from capbridge.status import Status
from capbridge.surrogate.base import (CSV_COLUMNS, OUTPUT_NAMES, SurrogateNotFittedError,
                                      apply_no_result_rule, worst_status)
from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.surrogate.doublet import default_table as doublet_table
from capbridge.surrogate.triplet import TripletSurrogate
from capbridge.surrogate.triplet import default_table as triplet_table

UNFITTED_CALLS = {
    DoubletSurrogate: [("predict", (0.1, 0.05, 30.0)), ("predict_vectors", (0.1, 0.05, 30.0)),
                       ("predict_fixed_theta", (0.1, 0.05, 30.0)),
                       ("predict_si", (1e-3, 1e-3, 0.072, 1e-4, 5e-11, 30.0)),
                       ("gravity_response", (1.0, 30.0, 0.05, 0.5)), ("summary", ()),
                       ("has_gravity", ())],
    TripletSurrogate: [("predict", (0.1, 0.1, 0.1, 0.3, 30.0)),
                       ("predict_vectors", (np.eye(3) * 3, 0.3, 30.0)),
                       ("predict_si", (1e-3, 0.072, np.eye(3) * 3e-3, 3e-10, 30.0)),
                       ("coalescence_volume", (0.1, 0.1, 0.1, 30.0)),
                       ("covers", (0.1, 0.1, 0.1, 30.0)), ("spline_at", (0, 0, 0, 30, 1)),
                       ("summary", ()), ("gravity_summary", ()), ("has_gravity", ())],
}


def test_not_fitted_error_is_old_and_new():
    assert issubclass(SurrogateNotFittedError, NotFittedError)
    assert issubclass(SurrogateNotFittedError, RuntimeError)      # old except-clauses
    assert issubclass(SurrogateNotFittedError, AttributeError)


@pytest.mark.parametrize("cls", [DoubletSurrogate, TripletSurrogate])
def test_unfitted_surrogate_raises_not_fitted(cls):
    sur = cls()
    assert isinstance(sur, BaseEstimator)
    assert clone(sur).get_params() == sur.get_params()
    for name, args in UNFITTED_CALLS[cls]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            with pytest.raises(NotFittedError, match="not fitted"):
                getattr(sur, name)(*args)
    with pytest.raises(NotFittedError):
        sur.has_gravity_
    assert not hasattr(sur, "table_")


@pytest.fixture(scope="module")
def doublet():
    return DoubletSurrogate().fit(doublet_table())


@pytest.fixture(scope="module")
def triplet():
    if not triplet_table().exists():
        pytest.skip("no triplet table")
    return TripletSurrogate().fit(triplet_table())


def test_fit_returns_self_and_common_attributes(doublet, triplet):
    for sur in (doublet, triplet):
        assert isinstance(sur.has_gravity_, bool)
        with pytest.warns(DeprecationWarning, match="has_gravity_"):
            assert sur.has_gravity() == sur.has_gravity_
        s = sur.summary()
        json.dumps(s)                      # JSON-friendly
        assert "holdout_error" in s and "gravity" in s


def test_doublet_summary_describes_table(doublet):
    s = doublet.summary()
    assert set(s["axes"]) == {"ratio", "theta", "volume", "s"}
    assert s["points"] == doublet.table_["status"].size
    assert s["refine"] == doublet.refine_ == doublet.refine


def test_no_result_rule_doublet(doublet):
    r = doublet.predict([0.0, 5.0], 0.05, 30.0)
    assert r["status"].tolist() == [Status.CONVERGED, Status.RUPTURED]
    assert r["force"][1] == 0.0                          # a ruptured bridge: no force
    assert np.isnan(r["pressure"][1]) and np.isnan(r["beta1"][1])
    assert np.isfinite(r["rupture_gap"]).all()


def test_no_result_rule_helper():
    st = np.array([Status.CONVERGED, Status.RUPTURED, Status.NOT_CONVERGED,
                   Status.EXTRAPOLATED, Status.APPROXIMATE], np.int8)
    out = {"force": np.ones(5), "pressure": np.ones(5), "rupture_gap": np.ones(5),
           "status": st}
    apply_no_result_rule(out, st)
    assert out["force"].tolist()[:2] == [1.0, 0.0] and np.isnan(out["force"][2])
    assert np.isnan(out["pressure"][1:3]).all() and np.isfinite(out["pressure"][[0, 3, 4]]).all()
    assert (out["rupture_gap"] == 1).all()


def test_worst_status_orders_severity():
    C, A, N = Status.CONVERGED, Status.APPROXIMATE, Status.NOT_CONVERGED
    assert worst_status([C, C, A, N], [A, N, C, A]).tolist() == [A, N, A, N]


def test_gravity_lookups_report_status(doublet):
    if not doublet.has_gravity_:
        pytest.skip("shipped table without gravity response")
    r = doublet.gravity_response(np.array([1.0, 1.0]), np.array([30.0, 30.0]),
                                 np.array([0.05, 0.05]), np.array([0.5, 0.5]))
    assert "code" not in r
    assert set(r["status"].tolist()) <= {Status.CONVERGED, Status.APPROXIMATE,
                                         Status.NOT_CONVERGED}


def test_one_set_of_output_names():
    assert CSV_COLUMNS["force"] == "F" and CSV_COLUMNS["pressure"] == "P"
    assert CSV_COLUMNS["rupture_gap"] == "d_rupt"
    assert set(OUTPUT_NAMES) == set(CSV_COLUMNS)
    from capbridge.cli import LOOKUP_OUTPUTS, TRIPLET_OUTPUTS
    assert LOOKUP_OUTPUTS == {"force": "F", "pressure": "P", "beta1": "beta1", "beta2": "beta2",
                              "rupture_gap": "d_rupt"}
    assert TRIPLET_OUTPUTS["volume_coalescence"] == "V_coal" and TRIPLET_OUTPUTS["pressure"] == "P"


def test_no_result_rule_triplet(triplet):
    clip = clone(triplet).set_params(out_of_range="clip").fit(triplet_table())
    vc = float(clip.coalescence_volume(0.1, 0.1, 0.1, 20.0)["volume_coalescence"])
    r = clip.predict(0.1, 0.1, 0.1, [0.3 * vc, 1.0 * vc], 20.0)
    assert r["status"][0] in (Status.OUT_OF_RANGE, Status.NO_EQUILIBRIUM)
    for name in ("f12", "f13", "f23", "pressure", "energy", "force_error"):
        assert np.isnan(r[name][0])
    assert np.isfinite(r["volume_coalescence"]).all()
    if r["status"][1] in (Status.CONVERGED, Status.ABOVE_TOLERANCE):
        assert np.isfinite(r["f12"][1])
