"""Triplets of equal spheres: geometry, separate bridges, coalescence criteria, pair forces."""
import numpy as np
import pytest

from capbridge.solvers.triplet import (bridge_meridian, coalescence_margins,
                                         find_coalescence, pair_forces, parse_bridges,
                                         triplet_geometry, uncoalesced_state)
from capbridge.solvers.young_laplace import solve_doublet
from capbridge.validation import CapbridgeInputError

PAPER = triplet_geometry(0.175, 0.175, 0.075)     # Miot et al. 2021, r = 4 mm
ALPHA = PAPER.angle_at(0, 1, 2) / 2


def test_geometry_matches_gaps_and_paper_alpha():
    C = PAPER.centres
    for (i, j), d in PAPER.gaps.items():
        assert np.linalg.norm(C[i] - C[j]) == pytest.approx(2 + d, abs=1e-12)
    assert C[0, 2] > 0 and C[1, 2] == C[2, 2] == 0        # top grain above, base level
    assert ALPHA == pytest.approx(28.490, abs=1e-3)          # paper, Fig. 4


def test_parse_bridges():
    assert parse_bridges("12,13") == [(0, 1), (0, 2)]
    assert parse_bridges("31, 2-3") == [(0, 2), (1, 2)]
    for bad in ("14", "11", "12,21", "", "1x"):
        with pytest.raises(CapbridgeInputError):
            parse_bridges(bad)


def test_uncoalesced_forces_are_the_doublets():
    V = 0.2
    st = uncoalesced_state(V, PAPER, 30.0)
    ex = solve_doublet(0.175, V / 2, 30.0)
    F = st["forces"]
    u = PAPER.axis(0, 1)
    assert F[0] @ u > 0                                       # grain 1 pulled towards 2
    assert np.linalg.norm(F.sum(axis=0)) < 1e-12
    assert -F[0, 2] == pytest.approx(2 * float(ex["force"]) * np.cos(np.radians(ALPHA)),
                                     rel=1e-10)
    assert float(st["energy"]) == pytest.approx(2 * float(ex["energy"]), rel=1e-12)
    f, res = pair_forces(PAPER.centres, F)
    assert res < 1e-12
    assert f[(0, 1)] == pytest.approx(float(ex["force"]), rel=1e-10)
    assert abs(f[(1, 2)]) < 1e-12


@pytest.mark.slow
def test_caps_criterion_symmetric_triplet_beta_equals_alpha():
    r = find_coalescence(PAPER, 0.0)
    assert r.status == "coalescence" and r.criterion == "caps"
    assert r.beta["12"]["grain 1"] == pytest.approx(ALPHA, abs=1e-6)
    assert r.beta["13"]["grain 1"] == pytest.approx(ALPHA, abs=1e-6)
    # the margin changes sign there: apart just below, overlapping just above
    for f, sign in ((0.99, -1), (1.01, 1)):
        _, ms = coalescence_margins(f * r.V_coal, PAPER, 0.0)
        caps = [m for m in ms if m["criterion"] == "caps"][0]["margin"]
        menisci = [m for m in ms if m["criterion"] == "menisci"][0]["margin"]
        assert np.sign(caps) == sign
        assert np.sign(menisci) == sign      # surfaces meet where the caps do
    assert r.opening_angles["grain 1"] == pytest.approx(2 * ALPHA)


@pytest.mark.slow
def test_vcoal_increases_with_theta():
    V = [find_coalescence(PAPER, t).V_coal for t in (0.0, 20.0, 40.0, 60.0, 80.0)]
    assert np.all(np.diff(V) > 0)


@pytest.mark.slow
def test_paper_vcoal_theta0_measured_value():
    """Paper: 14-14.5 ul (r = 4 mm, theta = 0, no gravity, beta read from a mesh).

    Exact shapes give 13.14 ul, 0.86-1.36 ul below (the mesh-measured beta at theta = 0
    lags: see examples/miot2021/CLAIMS.md).  The test pins our value and its
    consistency, and that it is below the paper's range by about 1 ul.
    """
    r = find_coalescence(PAPER, 0.0)
    v_ul = r.V_coal * 64
    assert v_ul == pytest.approx(13.139, abs=0.005)
    assert 0.9 < 14.25 - v_ul < 1.3          # ~1.1 ul below the middle of 14-14.5
    # consistency: the exact bridge at half that volume has beta = alpha
    b = solve_doublet(0.175, r.V_coal / 2, 0.0)["beta1"]
    assert float(b) == pytest.approx(ALPHA, abs=1e-6)


@pytest.mark.slow
def test_vcoal_on_the_paper_line_from_30_degrees():
    """V_coal = 14.5 + theta/90 * 18 ul holds within 0.15 ul for theta >= 30 deg (at 15
    deg ours is 0.29 ul below, at 0 deg 1.36 ul below: steeper than linear there)."""
    assert find_coalescence(PAPER, 15.0).V_coal * 64 == pytest.approx(17.21, abs=0.02)
    for t in (30.0, 60.0, 75.0):
        v = find_coalescence(PAPER, t).V_coal * 64
        assert v == pytest.approx(14.5 + t / 90 * 18, abs=0.15)


@pytest.mark.slow
def test_unequal_fractions_still_meet_at_the_caps():
    r = find_coalescence(PAPER, 30.0, fractions=[0.7, 0.3])
    assert r.criterion == "caps"
    b = r.beta["12"]["grain 1"] + r.beta["13"]["grain 1"]
    assert b == pytest.approx(2 * ALPHA, abs=1e-6)
    assert r.beta["12"]["grain 1"] > r.beta["13"]["grain 1"]


@pytest.mark.slow
def test_three_bridges_layout():
    r = find_coalescence(PAPER, 0.0, bridges="12,13,23")
    assert set(r.opening_angles) == {"grain 1", "grain 2", "grain 3"}
    assert r.criterion == "caps"
    assert sum(r.opening_angles.values()) == pytest.approx(180.0)


def test_meniscus_reaching_third_grain():
    """A single bridge 1-2 next to a grain 3 it does not wet: it grows until it touches 3."""
    g = triplet_geometry(0.0, 0.0, 0.3)
    r = find_coalescence(g, 0.0, bridges="12")
    assert r.criterion == "grain" and "grain 3" in r.where
    st = uncoalesced_state(r.V_coal, g, 0.0, bridges="12")
    b = st["bridge"][(0, 1)]
    x, y = bridge_meridian(0.0, b["pressure"], b["beta_i"], b["beta_j"], 0.0)
    c, u = g.centres[0], g.axis(0, 1)
    p = g.centres[2] - c
    xk = p @ u
    rk = np.linalg.norm(p - xk * u)
    assert np.min(np.hypot(x - xk, y - rk)) == pytest.approx(1.0, abs=1e-6)


def test_meridian_volume_matches_solver():
    r = solve_doublet(0.1, 0.08, 40.0)
    x, y = bridge_meridian(0.1, r["pressure"], r["beta1"], r["beta2"], 40.0, n=4001)
    from scipy.integrate import trapezoid
    from capbridge.dimensionless import cap_volume
    vol = np.pi * trapezoid(y ** 2, x) - 2 * cap_volume(1.0, np.radians(float(r["beta1"])))
    assert vol == pytest.approx(0.08, rel=1e-5)


def test_pair_forces_exact_for_balanced_set_and_residual_otherwise():
    rng = np.random.default_rng(3)
    for _ in range(5):
        C = rng.normal(size=(3, 3)) * 2
        f_true = rng.normal(size=3)
        pairs = [(0, 1), (0, 2), (1, 2)]
        F = np.zeros((3, 3))
        for (i, j), f in zip(pairs, f_true):
            u = (C[j] - C[i]) / np.linalg.norm(C[j] - C[i])
            F[i] += f * u
            F[j] -= f * u
        f, res = pair_forces(C, F)
        assert res < 1e-12
        assert [f[p] for p in pairs] == pytest.approx(list(f_true), abs=1e-12)
        # a net force (e.g. weight) cannot be pair forces: the residual says so
        F2 = F.copy()
        F2[0] += [0.0, 0.0, 0.3]
        _, res2 = pair_forces(C, F2)
        assert res2 > 1e-2
    with pytest.raises(CapbridgeInputError):
        pair_forces(C, F[:2])


def test_bad_inputs():
    with pytest.raises(CapbridgeInputError):
        triplet_geometry(-0.1, 0.1, 0.1)
    with pytest.raises(CapbridgeInputError):
        find_coalescence(PAPER, 90.0)
    with pytest.raises(CapbridgeInputError):
        find_coalescence(PAPER, 0.0, fractions=[1, 2, 3])
