"""capbridge's YADE engine without YADE: the scene table, the bridge model, coalescence.

The YADE runs are in ``test_yade_engine.py``; here the numpy core is checked against the
surrogate, the exact solver and the paper's coalescence volumes.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from capbridge.dem.bridges import BridgeModel, LiquidRule, SceneTable, default_table_path
from capbridge.dem.coalescence_detect import (bridge_pairs_on_shared_grains,
                                                     find_coalescence)
from capbridge.status import Status
from capbridge.surrogate.doublet import DoubletSurrogate

GAMMA = 0.073


@pytest.fixture(scope="module")
def sur():
    return DoubletSurrogate().fit(default_table_path())


def _random_points(sur, rng, n, thetas, ratios, band=1.05):
    th = rng.choice(thetas, n)
    r = rng.choice(ratios, n)
    v = np.exp(rng.uniform(np.log(sur.volume_[0]), np.log(sur.volume_[-1]), n))
    d_r = sur.predict(0.0, v, th, r)["rupture_gap"]
    return d_r * rng.uniform(0.0, band, n), v, th, r


@pytest.mark.slow
@pytest.mark.parametrize("thetas,ratios", [([0.0], [1.0]), ([40.0], [2.0]),
                                           ([20.0, 30.0], [1.0, 1.5, 10.0])])
def test_scene_table_is_the_surrogate_on_tabulated_ratios(sur, thetas, ratios):
    """On the table's ratios (and any angle on the surrogate's 0.5 deg grid) the scene
    table gives the surrogate's numbers to round-off, rupture included."""
    st = SceneTable(sur, thetas, ratios, variables=("force", "beta1", "beta2"))
    assert st.discrete
    g, v, th, r = _random_points(sur, np.random.default_rng(0), 3000, thetas, ratios)
    a = st.predict(g, v, th, r, ("force", "beta1", "beta2"))
    b = sur.predict(g, v, th, r)
    alive = b["status"] == Status.CONVERGED
    assert np.array_equal(a["force"] == 0.0, ~alive)
    np.testing.assert_allclose(a["force"][alive], b["force"][alive], rtol=1e-12)
    np.testing.assert_allclose(a["beta1"][alive], b["beta1"][alive], rtol=1e-12)
    np.testing.assert_allclose(a["beta2"][alive], b["beta2"][alive], rtol=1e-12)
    np.testing.assert_allclose(a["rupture_gap"], b["rupture_gap"], rtol=1e-12)


def test_scene_table_off_grid_angle_and_memory(sur):
    st = SceneTable(sur, [33.3], [1.0])
    g, v, th, r = _random_points(sur, np.random.default_rng(1), 500, [33.3], [1.0], band=0.95)
    np.testing.assert_allclose(st.predict(g, v, th, r)["force"], sur.predict(g, v, th, r)["force"],
                               rtol=1e-12)
    assert st.nbytes < 1e6          # one angle, one ratio, force only: one slice


@pytest.mark.slow
def test_scene_table_between_ratios_against_exact_solver(sur):
    """Continuous size distributions: linear between fine ratio nodes of the spline
    across ratio slices, at a common s; against the exact solver within 0.3 % (s >= 0.2)."""
    from capbridge.solvers.young_laplace import solve_doublet

    st = SceneTable(sur, [30.0], [1.0, 1.5], continuous=True)
    assert not st.discrete
    rng = np.random.default_rng(2)
    n = 200
    r = rng.uniform(1.0, 1.5, n)
    v = np.exp(rng.uniform(np.log(2e-3), np.log(0.4), n))
    s = rng.uniform(0.2, 1.0, n)
    gap = sur.predict(0.0, v, 30.0, r)["rupture_gap"] * (1 - s**2)
    ex = solve_doublet(gap, v, 30.0, r)
    ok = ex["status"] == Status.CONVERGED
    assert ok.sum() > 0.9 * n
    np.testing.assert_allclose(st.predict(gap, v, 30.0, r)["force"][ok], ex["force"][ok], rtol=3e-3)


def test_scene_table_refuses_what_it_does_not_hold(sur):
    st = SceneTable(sur, [10.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="not in this SceneTable"):
        st.theta_index([20.0])
    with pytest.raises(ValueError, match="not among"):
        st.ratio_coordinate([1.5])
    with pytest.raises(ValueError, match="outside the table"):
        st.volume_coordinate([0.9])
    with pytest.raises(ValueError, match="table covers"):
        SceneTable(sur, [85.0], [1.0])


# --------------------------------------------------------------------------------------
# Bridge model: formation, rupture, re-formation, forces, budget
# --------------------------------------------------------------------------------------


def _two(gap, r1=1e-3, r2=1e-3, direction=(1.0, 2.0, 2.0)):
    u = np.asarray(direction, float)
    u /= np.linalg.norm(u)
    return np.array([[0.0, 0.0, 0.0], (r1 + r2 + gap) * u]), u


def test_two_grains_form_keep_rupture_reform(sur):
    r1, r2, vstar, theta = 1e-3, 2e-3, 0.05, 40.0
    m = BridgeModel([r1, r2], theta, sur, GAMMA, LiquidRule(bridge_volume_star=vstar))
    pos, u = _two(1e-6, r1, r2)
    g = m.update(pos)
    assert m.n_bridges == 0                     # apart: no bridge
    d_r = float(sur.predict(0.0, vstar, theta, 2.0)["rupture_gap"]) * r1
    gaps = np.concatenate([[-1e-7, 0.0], np.linspace(0.0, 0.999 * d_r, 30), [1.001 * d_r, 2 * d_r]])
    for k, gap in enumerate(gaps):
        pos, u = _two(gap, r1, r2)
        g = m.update(pos, step=k)
        f, _ = m.grain_forces(g)
        if gap <= d_r:
            assert m.n_bridges == 1
            exp = sur.predict(max(gap, 0.0) / r1, vstar, theta, 2.0)["force"] * 2 * np.pi * GAMMA * r1
            np.testing.assert_allclose(f[0], exp * u, rtol=1e-12, atol=1e-18)   # along i -> j
            np.testing.assert_allclose(f[1], -f[0], rtol=0, atol=0)             # opposite
        else:
            assert m.n_bridges == 0 and np.all(f == 0.0)
    pos, _ = _two(0.5 * d_r, r1, r2)            # apart again, within rupture: no new bridge
    m.update(pos)
    assert m.n_bridges == 0
    pos, _ = _two(-1e-8, r1, r2)                # contact: it re-forms with the same volume
    m.update(pos)
    assert m.n_bridges == 1 and m.vol[0] == pytest.approx(vstar * r1**3, rel=1e-12)
    b = m.budget()
    assert (b["initial_count"], b["formed_count"], b["ruptured_count"]) == (0, 2, 1)
    assert b["balance_error"] < 1e-12


def test_held_forces_stay_equal_and_opposite(sur):
    m = BridgeModel([1e-3, 1e-3], 0.0, sur, GAMMA, LiquidRule(bridge_volume_star=0.02))
    pos, u = _two(0.0)
    f0, ch = m.grain_forces(m.update(pos), tolerance=1e-3)
    assert set(ch.tolist()) == {0, 1}
    pos, u = _two(1e-9)                          # tiny change: held, nothing to hand out
    f1, ch = m.grain_forces(m.update(pos), tolerance=1e-3)
    assert ch.size == 0 and np.array_equal(f1, f0)
    pos, u = _two(2e-5)
    f2, ch = m.grain_forces(m.update(pos), tolerance=1e-3)
    assert ch.size == 2 and np.array_equal(f2[0], -f2[1]) and not np.array_equal(f2, f0)


def test_bridge_volume_must_fit_the_table(sur):
    with pytest.raises(ValueError, match="bridge_volume"):
        BridgeModel([1e-3, 1e-4], 0.0, sur, GAMMA, LiquidRule(bridge_volume=1e-10))
    with pytest.raises(ValueError, match="exactly one"):
        LiquidRule(bridge_volume=1e-10, total_liquid=1e-9)
    with pytest.raises(ValueError, match="total liquid"):
        LiquidRule(bridge_volume=1e-10, conserve=True)


def _jiggle_cluster(m, rng, n_steps, r=1e-3):
    """Grains on a line, pushed together and pulled apart at random."""
    x = np.arange(m.n) * 2 * r * 1.02
    pos = np.column_stack([x, np.zeros(m.n), np.zeros(m.n)])
    checks = []
    for k in range(n_steps):
        pos[:, 0] += rng.normal(0.0, 0.05 * r, m.n)
        pos[:, 1] += rng.normal(0.0, 0.02 * r, m.n)
        g = m.update(pos, step=k)
        m.grain_forces(g)
        checks.append(m.budget()["balance_error"])
    return checks


@pytest.mark.parametrize("rule", [LiquidRule(bridge_volume_star=0.03),
                                  LiquidRule(total_liquid=2e-10),
                                  LiquidRule(total_liquid=2e-10, conserve=False)])
def test_liquid_budget_through_ruptures_and_reformations(sur, rule):
    m = BridgeModel(np.full(12, 1e-3), 10.0, sur, GAMMA, rule, initial_wet_gap=0.05e-3)
    errs = _jiggle_cluster(m, np.random.default_rng(3), 400)
    b = m.budget()
    assert b["ruptured_count"] > 5 and b["formed_count"] > 5
    assert max(errs) < 1e-12
    if rule.total_liquid is not None and rule.conserve:
        assert b["active_volume"] + b["film_volume"] == pytest.approx(2e-10, rel=1e-12)
        assert np.all(m.films >= 0)
    elif rule.total_liquid is not None:        # shared at the start, then fixed
        assert np.allclose(m.vol, b["bridge_volume"]) and b["bridge_volume"] == pytest.approx(
            2e-10 / b["initial_count"])


@pytest.mark.slow
@pytest.mark.parametrize("radii,thetas", [((1e-3, 1e-3), (0.0, 60.0)),
                                          ((1.25e-3, 1e-3), (80.0, 0.0))])
def test_mixed_contact_angles_are_the_exact_solver(sur, radii, thetas):
    """Grains of different angles: the bridge is the exact (theta1, theta2) solution
    (angle of the smaller grain first), within the table's own error (0.35 % max on
    tabulated ratios for d* <= 0.96 d*_rupt; measured here <= 0.03 %), along a
    pull-apart, and not the mean angle's (20-60 % off here)."""
    from capbridge.solvers.young_laplace import rupture_distance, solve_doublet

    r = np.asarray(radii)
    rs, ratio = r.min(), r.max() / r.min()
    small = 0 if r[0] <= r[1] else 1               # equal radii: the first grain
    t_small, t_large = thetas[small], thetas[1 - small]
    vstar = 0.05
    m = BridgeModel(r, thetas, sur, GAMMA, LiquidRule(bridge_volume_star=vstar),
                    initial_wet_gap=1e-9 * rs)
    # the orders the radii allow: both for equal grains, one for unequal ones
    assert m.table.theta_pairs.shape[0] == (2 if r[0] == r[1] else 1)
    d_r = float(rupture_distance(vstar, t_small, ratio, t_large)["gap"])
    assert m.d_rupt_si.size == 0
    gaps = np.linspace(0.0, 0.96, 13) * d_r
    got = []
    for k, g in enumerate(gaps):
        pos, _ = _two(g * rs, r[0], r[1])
        got.append(m.update(pos, step=k)["force"][0] / (2 * np.pi * GAMMA * rs))
    assert m.d_rupt_si[0] / rs == pytest.approx(d_r, rel=1e-3)
    exact = solve_doublet(gaps, vstar, t_small, ratio, t_large)
    assert np.all(exact["status"] == Status.CONVERGED)
    np.testing.assert_allclose(got, exact["force"], rtol=3.5e-3)
    mean = sur.predict(gaps, vstar, 0.5 * sum(thetas), ratio)["force"]
    assert np.min(np.abs(mean / exact["force"] - 1)) > 0.1    # the old rule was far off


def test_films_feed_later_contacts_without_retrying_refusals(sur):
    """Conserved liquid starts on the films (uniform water content): a contact made
    late gets a bridge from the two films; a pair refused for lack of liquid is not
    tried again until a rupture returns liquid to one of its grains."""
    r = 1e-3
    m = BridgeModel(np.full(3, r), 20.0, sur, GAMMA, LiquidRule(total_liquid=3e-11))
    far = np.array([[0, 0, 0], [3 * r, 0, 0], [6 * r, 0, 0]], float)
    m.update(far)
    assert m.n_bridges == 0 and m.films == pytest.approx(np.full(3, 1e-11), rel=1e-12)
    pos = far.copy()
    pos[1, 0] = 2 * r                                   # 0-1 touch: V = 0.5 (f0 + f1)
    m.update(pos, step=1)
    assert m.n_bridges == 1 and m.vol[0] == pytest.approx(1e-11, rel=1e-12)
    assert m.films == pytest.approx([0.5e-11, 0.5e-11, 1e-11], rel=1e-12)
    b = m.budget()
    assert b["balance_error"] < 1e-14 and b["formed_count"] == 1


def test_refused_pairs_are_not_retried(sur):
    r = 1e-3
    lo = sur.volume_[0] * r**3
    # liquid for one bridge at the table's smallest V*, not for a second one
    m = BridgeModel(np.full(2, r), 0.0, sur, GAMMA, LiquidRule(total_liquid=1.5 * lo))
    pos, _ = _two(0.0)
    m.update(pos)
    assert m.n_bridges == 0                              # 0.5 * 1.5 lo < lo: refused
    assert m.cand.refused.sum() == 1 and m.budget()["formations_short_of_liquid"] == 0
    calls = []
    real = m._form
    m._form = lambda i, j, step: (calls.append(i.size), real(i, j, step))[1]
    for k in range(20):
        m.update(pos, step=k)
    assert calls == [] and m.n_bridges == 0              # never tried again


def test_state_round_trip_gives_the_same_forces(sur):
    """get_state -> a fresh model -> set_state: the same bridges, films, ledger and
    forces to round-off, and the run continues identically."""
    rule = LiquidRule(total_liquid=2e-10)
    a = BridgeModel(np.full(12, 1e-3), 10.0, sur, GAMMA, rule, initial_wet_gap=0.05e-3)
    _jiggle_cluster(a, np.random.default_rng(3), 150)
    st = a.get_state()
    b = BridgeModel(np.full(12, 1e-3), 10.0, sur, GAMMA, LiquidRule(total_liquid=2e-10),
                    initial_wet_gap=0.05e-3)
    b.set_state(st)
    rng_a, rng_b = np.random.default_rng(9), np.random.default_rng(9)
    ea = _jiggle_cluster(a, rng_a, 100)
    eb = _jiggle_cluster(b, rng_b, 100)
    assert a.n_bridges == b.n_bridges and a.n_bridges > 0
    np.testing.assert_array_equal(a.vol, b.vol)
    np.testing.assert_array_equal(a.films, b.films)
    assert a.budget() == b.budget() and max(eb) < 1e-12


def test_dropped_grains_take_their_liquid_and_the_budget_stays_exact(sur):
    m = BridgeModel(np.full(12, 1e-3), 10.0, sur, GAMMA, LiquidRule(total_liquid=2e-10),
                    initial_wet_gap=0.05e-3)
    _jiggle_cluster(m, np.random.default_rng(3), 50)
    n_b = m.n_bridges
    gone = np.zeros(12, bool)
    gone[[3, 7]] = True
    had = np.isin(m.bi, [3, 7]) | np.isin(m.bj, [3, 7])
    m.drop_grains(gone)
    assert m.n == 10 and m.n_bridges == n_b - had.sum()
    b = m.budget()
    assert b["removed_volume"] > 0 and b["balance_error"] < 1e-12
    assert b["active_volume"] + b["film_volume"] + b["removed_volume"] == pytest.approx(2e-10, rel=1e-12)


# --------------------------------------------------------------------------------------
# Coalescence
# --------------------------------------------------------------------------------------


def test_no_search_without_a_grain_holding_two_bridges():
    pos = np.random.default_rng(0).normal(size=(6, 3))
    rep = find_coalescence(pos, [0, 2, 4], [1, 3, 5], [80, 80, 80], [80, 80, 80])
    assert not rep.searched and rep.n_triplets == 0
    a, *_ = bridge_pairs_on_shared_grains([0, 2, 4], [1, 3, 5], 6)
    assert a.size == 0


def test_pairs_on_shared_grains_are_all_found():
    rng = np.random.default_rng(5)
    bi = rng.integers(0, 10, 60)
    bj = (bi + rng.integers(1, 10, 60)) % 10
    a, b, g, ea, eb = bridge_pairs_on_shared_grains(bi, bj, 10)
    got = {(min(x, y), max(x, y), int(z)) for x, y, z in zip(a, b, g)}
    want = set()
    for x in range(60):
        for y in range(x + 1, 60):
            for z in {int(bi[x]), int(bj[x])} & {int(bi[y]), int(bj[y])}:
                want.add((x, y, z))
    assert got == want


def test_criterion_uses_the_angle_on_the_shared_grain():
    """Straight chain: 180 deg at the middle grain; a right angle merges at 45+45."""
    pos = np.array([[0, 0, 0], [2, 0, 0], [4, 0, 0], [2, 2, 0]], float)
    rep = find_coalescence(pos, [0, 1], [1, 2], [10, 89.0], [89.0, 10], [1.0, 2.0])
    assert rep.searched and rep.n_triplets == 0            # 89 + 89 < 180
    rep = find_coalescence(pos, [0, 1], [1, 3], [10, 45.5], [45.5, 10], [1.0, 2.0])
    assert rep.n_triplets == 1 and rep.triplets.tolist() == [[0, 1, 3]]
    assert rep.margin[0] == pytest.approx(1.0) and rep.cluster_volumes.tolist() == [3.0]
    assert not rep.closed[0]
    # the betas on the far grains do not matter
    rep = find_coalescence(pos, [0, 1], [1, 3], [89, 44.0], [44.0, 89], [1.0, 2.0])
    assert rep.n_triplets == 0


def test_triangle_is_one_cluster():
    pos = np.array([[0, 0, 0], [2.1, 0, 0], [1.05, 1.8, 0]], float)
    rep = find_coalescence(pos, [0, 0, 1], [1, 2, 2], [40] * 3, [40] * 3, [1.0, 1.0, 1.0])
    assert rep.n_triplets == 3 and rep.closed.all() and rep.n_clusters == 1
    assert rep.coalesced_volume == 3.0


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0])
def test_coalescence_volume_of_the_paper_triplet(sur, theta):
    """El Korchi et al.'s triplet (r = 4 mm; top grain 8.7 mm from the two bottom ones,
    8.3 mm apart), two equal bridges from the top grain: the doublet table's filling
    angles put the geometric criterion at a total volume close to Miot et al.'s
    V_coal = 14.5 ul + (theta / 90 deg) 18 ul (their Fig. 10; 14-14.5 ul at theta = 0)."""
    r = 4e-3
    h = math.sqrt(8.7e-3**2 - 4.15e-3**2)
    pos = np.array([[0, 0, 0], [8.3e-3, 0, 0], [4.15e-3, 0, h]])
    v_paper = 14.5e-9 + theta / 90.0 * 18e-9

    def merged(v_total):
        m = BridgeModel(np.full(3, r), theta, sur, GAMMA, LiquidRule(bridge_volume=v_total / 2))
        g = m.update(pos, initial_pairs=[(0, 2), (1, 2)])
        assert m.n_bridges == 2
        bi, bj = m.filling_angles(g["gap"])
        return find_coalescence(pos, m.bi, m.bj, bi, bj, m.vol).n_triplets == 1

    tol = 0.10 if theta == 0.0 else 0.02
    assert not merged(v_paper * (1 - tol))
    assert merged(v_paper * (1 + tol))


# --------------------------------------------------------------------------------------
# Native fixed-volume files (YADE's Law2 emulated by yade_export.law2_force)
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("radii,kw,theta", [([1e-3], {"bridge_volume_star": 0.05}, 0.0),
                                            ([1e-3, 2e-3], {"bridge_volume_star": 0.02}, 40.0),
                                            ([1e-3, 2e-3], {"bridge_volume": 2e-11}, 40.0)])
def test_native_volume_files_give_the_lookup(sur, tmp_path, radii, kw, theta):
    """What YADE's Law2 reads from the fixed-volume files (capbridge's emulation of its
    interpolation) is the surrogate's volume-controlled force within 0.2 %, up to the
    rupture distance, and nothing past it."""
    from capbridge.yade import yade_export as ye
    from capbridge.yade.native_volume import NativeVolumeBridges

    nb = NativeVolumeBridges(tmp_path, theta, radii, gamma=GAMMA, **kw)
    files = ye.read_capillary_files(tmp_path, nb.suffix)
    for r1, r2 in {(radii[0], radii[-1]), (radii[-1], radii[-1]), (radii[0], radii[0])}:
        rs, ratio = min(r1, r2), max(r1, r2) / min(r1, r2)
        vstar = kw.get("bridge_volume_star") or kw["bridge_volume"] / rs**3
        d_r = float(sur.predict(0.0, vstar, theta, ratio)["rupture_gap"]) * rs
        gaps = np.concatenate([np.linspace(0.0, 0.9999 * d_r, 60), [1.0001 * d_r, 1.1 * d_r]])
        got = np.array([ye.law2_force(files, r1, r2, g, nb.capillary_pressure, GAMMA)[0]
                        for g in gaps])
        want = sur.predict(np.minimum(gaps, d_r) / rs, vstar, theta, ratio)["force"] \
            * 2 * np.pi * GAMMA * rs
        np.testing.assert_allclose(got[:60], want[:60], rtol=2e-3)
        assert np.all(got[60:] == 0.0)
        v = ye.law2_force(files, r1, r2, 0.3 * d_r, nb.capillary_pressure, GAMMA)[1]
        assert v == pytest.approx(nb.bridge_volume_of(r1, r2), rel=1e-9)
    assert 1.0 < nb.detection_factor < 1.5


def test_native_volume_refuses_ratios_between_yade_files(tmp_path):
    from capbridge.yade.native_volume import NativeVolumeBridges

    with pytest.raises(ValueError, match="not among YADE's file ratios"):
        NativeVolumeBridges(tmp_path, 30.0, [1e-3, 1.3e-3], bridge_volume_star=0.02)
    with pytest.raises(ValueError, match="distinct radii"):
        NativeVolumeBridges(tmp_path, 30.0, np.linspace(1e-3, 1.2e-3, 20), bridge_volume_star=0.02)
