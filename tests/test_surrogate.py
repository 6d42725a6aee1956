"""The shipped doublet table and its surrogate, checked against the exact solver."""
import numpy as np
import pytest

from capbridge.cli import DEFAULT_TABLE
from capbridge.tables.netcdf_io import read_table
from capbridge.solvers.young_laplace import solve_doublet
from capbridge.status import Status
from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.validation import CapbridgeInputError


@pytest.fixture(scope="module")
def table():
    return read_table(DEFAULT_TABLE)


@pytest.fixture(scope="module")
def surrogate(table):
    return DoubletSurrogate().fit(table)


def test_table_is_self_describing(table):
    assert table.attrs["Conventions"].startswith("CF")
    assert table.attrs["capbridge_command"].startswith("capbridge generate doublet")
    for name, var in list(table.data_vars.items()) + list(table.coords.items()):
        assert "units" in var.attrs and "long_name" in var.attrs, name
    assert (table["status"].values == Status.CONVERGED).all()


@pytest.mark.slow
def test_table_points_resolve_exactly(table):
    """A random sample of stored points, re-solved now, agrees to 1e-7 relative."""
    rng = np.random.default_rng(7)
    st = table.stack(p=("ratio", "theta", "volume", "s"))
    idx = rng.choice(st.sizes["p"], 40, replace=False)
    pts = st.isel(p=idx)
    inner = pts["s"].values > 0  # s = 0 rows are the rupture state itself
    r = solve_doublet(pts["gap"].values[inner], pts["volume"].values[inner],
                      pts["theta"].values[inner], pts["ratio"].values[inner])
    assert (r["status"] == Status.CONVERGED).all()
    np.testing.assert_allclose(r["force"], pts["force"].values[inner], rtol=1e-7)
    np.testing.assert_allclose(r["pressure"], pts["pressure"].values[inner], rtol=1e-6, atol=1e-9)


@pytest.mark.slow
def test_surrogate_matches_exact_away_from_rupture(surrogate):
    """Median <= 0.05 %, max <= 0.5 % for d* <= 0.96 d*_rupt (the stated band)."""
    rng = np.random.default_rng(3)
    n = 150
    th = rng.uniform(0, surrogate.theta_[-1], n)
    v = np.exp(rng.uniform(np.log(surrogate.volume_[0]), np.log(surrogate.volume_[-1]), n))
    d_r = surrogate.predict(0.0, v, th)["rupture_gap"]
    gap = d_r * (1 - rng.uniform(0.2, 1.0, n) ** 2)
    exact = solve_doublet(gap, v, th)
    approx = surrogate.predict(gap, v, th)
    assert (exact["status"] == Status.CONVERGED).all()
    rel = np.abs(approx["force"] / exact["force"] - 1)
    assert np.median(rel) < 5e-4
    assert rel.max() < 5e-3


def test_rupture_distance_and_beyond(surrogate):
    from capbridge.solvers.young_laplace import rupture_distance

    exact = rupture_distance(0.02, 20.0)
    r = surrogate.predict(0.0, 0.02, 20.0)
    assert abs(r["rupture_gap"] / exact["gap"] - 1) < 1e-4
    beyond = surrogate.predict(exact["gap"] * 1.01, 0.02, 20.0)
    assert beyond["status"] == Status.RUPTURED and beyond["force"] == 0.0
    assert np.isnan(beyond["pressure"])


def test_fast_path_equals_general_path(surrogate):
    rng = np.random.default_rng(5)
    v = np.exp(rng.uniform(np.log(0.002), np.log(0.2), 500))
    d = rng.uniform(0, 0.5, 500)
    fast = surrogate.predict_fixed_theta(d, v, 30.0)
    slow = surrogate.predict(d, v, 30.0)["force"]
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-14)


def test_broadcasting_shapes(surrogate):
    r = surrogate.predict(np.linspace(0, 0.1, 5)[:, None], np.array([0.01, 0.02, 0.05]), 10.0)
    assert r["force"].shape == (5, 3) and r["status"].shape == (5, 3)


@pytest.mark.parametrize("kw, word", [
    (dict(gap=0.1, volume=-0.01, theta=10), "volume"),
    (dict(gap=0.1, volume=np.nan, theta=10), "volume"),
    (dict(gap=-0.1, volume=0.01, theta=10), "gap"),
    (dict(gap=0.1, volume=0.01, theta=95), "theta"),
    (dict(gap=0.1, volume=5.0, theta=10), "outside the table"),
])
def test_bad_input_is_refused(surrogate, kw, word):
    with pytest.raises(CapbridgeInputError, match=word):
        surrogate.predict(**kw)


@pytest.mark.slow
def test_clip_fallback_is_flagged():
    sur = DoubletSurrogate(out_of_range="clip").fit(DEFAULT_TABLE)
    r = sur.predict(0.01, 5.0, 10.0)
    assert r["status"] == Status.EXTRAPOLATED and np.isfinite(r["force"])


@pytest.mark.slow
@pytest.mark.parametrize("ratio", [3.5, 7.0])
def test_between_tabulated_ratios(surrogate, ratio):
    """Spline across ratio slices: median <= 0.05 %, max <= 1 % (d* <= 0.96 d*_rupt)."""
    rng = np.random.default_rng(11)
    n = 80
    th = rng.uniform(0, 60, n)
    v = np.exp(rng.uniform(np.log(2e-3), np.log(0.3), n))
    d_r = surrogate.predict(0.0, v, th, ratio)["rupture_gap"]
    gap = d_r * (1 - rng.uniform(0.2, 1.0, n) ** 2)
    exact = solve_doublet(gap, v, th, ratio)
    approx = surrogate.predict(gap, v, th, ratio)
    ok = exact["status"] == Status.CONVERGED
    assert ok.mean() > 0.95
    rel = np.abs(approx["force"][ok] / exact["force"][ok] - 1)
    assert np.median(rel) < 5e-4
    assert rel.max() < 1e-2


def test_si_api_matches_dimensionless(surrogate):
    """Grains of 2 mm and 1 mm: the 1 mm grain normalises, the order does not matter."""
    gamma, d, vol = 0.072, 0.1e-3, 0.05e-9
    a = surrogate.predict_si(2e-3, 1e-3, gamma, d, vol, 30.0)
    b = surrogate.predict_si(1e-3, 2e-3, gamma, d, vol, 30.0)
    star = surrogate.predict(d / 1e-3, vol / 1e-9, 30.0, 2.0)
    assert a["force"] == pytest.approx(star["force"] * 2 * np.pi * gamma * 1e-3, rel=1e-12)
    assert a["force"] == pytest.approx(b["force"], rel=1e-12)
    assert a["pressure"] == pytest.approx(star["pressure"] * gamma / 1e-3, rel=1e-12)
    with pytest.raises(CapbridgeInputError, match="radius1"):
        surrogate.predict_si(-1e-3, 1e-3, gamma, d, vol, 30.0)


@pytest.mark.slow
def test_table_rupture_rows_resolve_exactly(table):
    """The stored rupture distances (s = 0 rows) re-solved now agree to 1e-6."""
    from capbridge.solvers.young_laplace import rupture_distance

    rng = np.random.default_rng(8)
    st = table.stack(p=("ratio", "theta", "volume"))
    pts = st.isel(p=rng.choice(st.sizes["p"], 12, replace=False))
    r = rupture_distance(pts["volume"].values, pts["theta"].values, pts["ratio"].values)
    assert (r["status"] == Status.CONVERGED).all()
    np.testing.assert_allclose(r["gap"], pts["rupture_gap"].values, rtol=1e-6)
