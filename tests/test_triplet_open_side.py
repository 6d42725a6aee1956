"""An open side beyond the second triplet table: the continuation of
capbridge.surrogate.triplet_open_side (TripletSurrogate(open_side="linear"))."""
import json
from pathlib import Path

import numpy as np
import pytest

from capbridge.status import Status
from capbridge.surrogate.triplet import TripletSurrogate
from capbridge.surrogate.triplet_open_side import OPEN_SIDE_ERROR, OPEN_SIDE_LINEAR_MAX
from capbridge.validation import CapbridgeInputError

EVOLVER = Path(__file__).resolve().parents[1] / "benchmarks" / "evolver_out" / "open_side.json"


@pytest.fixture(scope="module")
def surrogates(packings_triplet_table):
    refuse = TripletSurrogate(method="auto").fit(packings_triplet_table)
    linear = TripletSurrogate(method="auto", open_side="linear").fit(packings_triplet_table)
    return refuse, linear


def test_refused_by_default_and_beyond_the_limit(surrogates):
    refuse, linear = surrogates
    with pytest.raises(CapbridgeInputError, match=r"d23=0.7 is outside the triplet table's "
                                                  r"range \[0, 0.6\]; another"):
        refuse.predict(0.0, 0.0, 0.7, 0.6, 30.0)
    with pytest.raises(CapbridgeInputError, match=r"d23=1.05 is outside .* \(open_side="
                                                  r"'linear' continues an open side up to 1\)"):
        linear.predict(0.0, 0.0, 1.05, 0.6, 30.0)
    assert not refuse.covers(0.0, 0.0, 0.7, 30.0)
    assert linear.covers(0.0, 0.0, [0.7, OPEN_SIDE_LINEAR_MAX], 30.0).all()
    assert not linear.covers(0.0, 0.3, 0.7, 30.0)      # a bridge gap beyond the table
    with pytest.raises(CapbridgeInputError, match="open_side"):
        TripletSurrogate(open_side="clamp")
    # a volume outside the table is named as asked, not as looked up at the edge
    with pytest.raises(CapbridgeInputError, match=r"V\*=20.0 gives v = .* at d12=0, d13=0, "
                                                  r"d23=0.8, theta=30"):
        linear.predict(0.0, 0.0, 0.8, 20.0, 30.0)


def test_continuation_is_the_table_at_its_edge_and_linear_beyond(surrogates):
    refuse, linear = surrogates
    d_max, d_prev = float(linear.gaps_[-1]), float(linear.gaps_[-2])
    t = np.array([20.0, 40.0])
    a, b = refuse.predict(0.0, 0.1, d_max, 0.7, t), linear.predict(0.0, 0.1, d_max, 0.7, t)
    for k in ("f12", "f13", "f23", "pressure", "v", "status"):
        np.testing.assert_array_equal(a[k], b[k])
    # V*_coal continued linearly in the open side
    d = np.array([d_max + 0.1, d_max + 0.2, d_max + 0.3])
    vc = linear.coalescence_volume(0.0, 0.1, d, 40.0)["volume_coalescence"]
    np.testing.assert_allclose(np.diff(vc, 2), 0.0, atol=1e-12)
    edge, prev = (float(linear.coalescence_volume(0.0, 0.1, x, 40.0)["volume_coalescence"])
                  for x in (d_max, d_prev))
    assert vc[0] == pytest.approx(edge + (edge - prev) * 0.1 / (d_max - d_prev), rel=1e-12)
    # at a fixed v = V*/V*_coal the forces are linear in the open side too, continuous at
    # the edge, and answered as approximate
    v = 1.3
    r = linear.predict(0.0, 0.1, d, v * vc, 40.0)
    assert np.all(r["status"] == Status.APPROXIMATE)
    np.testing.assert_allclose(r["v"], v, rtol=1e-12)
    for k in ("f12", "f13", "f23", "pressure"):
        np.testing.assert_allclose(np.diff(r[k], 2), 0.0, atol=1e-9)
    near = linear.predict(0.0, 0.1, d_max * (1 + 1e-9), v * edge, 40.0)
    at = refuse.predict(0.0, 0.1, d_max, v * edge, 40.0)
    for k in ("f12", "f13", "f23"):
        assert float(near[k]) == pytest.approx(float(at[k]), abs=1e-6)


def test_a_table_over_its_whole_cube_has_no_open_side(triplet_table):
    full = TripletSurrogate(open_side="linear").fit(triplet_table)
    hi = float(full.gaps_[-1])
    assert not full.covers(0.0, 0.0, hi + 0.1, 30.0)
    assert not full.continues(0.0, 0.0, hi + 0.1)
    with pytest.raises(CapbridgeInputError, match="outside the triplet table's range"):
        full.predict(0.0, 0.0, hi + 0.1, 0.1, 30.0)


def test_continuation_against_surface_evolver(surrogates):
    """The cached Evolver triplets beyond the open side (benchmarks/bench_open_side.py):
    every pair within the measured bound OPEN_SIDE_ERROR of the body's largest force."""
    _, linear = surrogates
    data = json.loads(EVOLVER.read_text())
    worst, n = 0.0, 0
    for e in data.values():
        if "pair_forces" not in e or e["gaps"][2] <= float(linear.gaps_[-1]):
            continue
        R = np.array(e["radii"])
        assert linear.continues(*e["gaps"], radii=R)
        r = linear.predict_vectors(np.array(e["centres"]), e["volume"], e["theta"], radii=R)
        assert int(r["status"]) == Status.APPROXIMATE
        f = np.array([float(r[k]) for k in ("f12", "f13", "f23")])
        ref = np.array(e["pair_forces"])
        worst = max(worst, float(np.max(np.abs(f - ref)) / np.max(np.abs(ref))))
        n += 1
    assert n == OPEN_SIDE_ERROR["n_triplets"]
    assert worst <= OPEN_SIDE_ERROR["max"] + 1e-3
