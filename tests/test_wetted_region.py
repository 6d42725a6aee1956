"""The force of a liquid body on a grain from its wetted region (capbridge.physics.wetted_region)."""
from __future__ import annotations

import numpy as np
import pytest

from capbridge.physics import wetted_region as wr
from capbridge.solvers.young_laplace import solve_doublet


def _circle(e, alpha, n=4000):
    e = np.asarray(e, float) / np.linalg.norm(e)
    h = np.array([1.0, 0, 0]) if abs(e[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(e, h)
    u /= np.linalg.norm(u)
    w = np.cross(e, u)
    t = np.linspace(0, 2 * np.pi, n + 1)
    p = np.cos(alpha) * e + np.sin(alpha) * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * w)
    return np.stack([p[:-1], p[1:]], axis=1)


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0])
@pytest.mark.parametrize("alpha_deg", [5.0, 25.0, 60.0])
def test_cap_reproduces_doublet_closed_form(theta, alpha_deg):
    a = np.radians(alpha_deg)
    e = np.array([0.3, -0.4, 0.866])
    e /= np.linalg.norm(e)
    for P in (-6.0, -1.0, 0.0, 2.5):
        F = wr.region_force(P, theta, *wr.cap_region(a, e))
        closed = np.sin(a) * np.sin(a + np.radians(theta)) - 0.5 * np.sin(a) ** 2 * P
        np.testing.assert_allclose(F, closed * e, atol=1e-13)


def test_cap_force_matches_exact_doublet():
    """The exact doublet's filling angle and pressure give its force through the cap."""
    r = solve_doublet(gap=0.1, volume=0.05, theta=30)
    F = wr.region_force(r["pressure"], 30.0, *wr.cap_region(np.radians(r["beta1"]), [1, 0, 0]))
    assert F[0] == pytest.approx(r["force"], rel=1e-6)


def test_polygon_region_of_a_cap_and_its_orientation():
    for alpha in (0.2, 1.0, 1.4):
        S, L = wr.polygon_region(_circle([0, 1, 0], alpha), [0, 0, 0])
        Sc, Lc = wr.cap_region(alpha, [0, 1, 0])
        np.testing.assert_allclose(S, Sc, atol=2e-6)
        np.testing.assert_allclose(L, Lc, atol=2e-6)
    # the same line run the other way bounds the complement: S changes sign, L (the
    # normal's integral along the line) does not; it is the complementary cap's
    seg = _circle([0, 1, 0], 0.5)[:, ::-1]
    S, L = wr.polygon_region(seg, [0, 0, 0])
    Sc, Lc = wr.cap_region(np.pi - 0.5, [0, -1, 0])
    np.testing.assert_allclose(S, Sc, atol=2e-6)
    np.testing.assert_allclose(L, Lc, atol=2e-6)
    # translated grain of radius 2: S* and L* are per the grain's own radius
    c = np.array([1.0, 2.0, 3.0])
    S2, L2 = wr.polygon_region(2 * _circle([0, 1, 0], 0.5) + c, c, radius=2.0)
    np.testing.assert_allclose(S2, wr.cap_region(0.5, [0, 1, 0])[0], atol=2e-6)


def test_fully_wetted_and_dry_limits():
    S, L = wr.cap_region(np.pi, [0, 0, 1])          # fully wetted sphere
    np.testing.assert_allclose(S, 0, atol=1e-12)
    np.testing.assert_allclose(L, 0, atol=1e-12)
    np.testing.assert_allclose(wr.region_force(-3.0, 20.0, S, L), 0, atol=1e-12)
    # a hemisphere: S* = pi e, L* = 0
    S, L = wr.cap_region(np.pi / 2, [0, 0, 1])
    np.testing.assert_allclose(S, [0, 0, np.pi], atol=1e-12)
    np.testing.assert_allclose(L, 0, atol=1e-12)


def test_cap_half_angle_inverts_cap_region():
    a = np.array([0.01, 0.4, 1.2, np.pi / 2])
    S, _ = wr.cap_region(a, np.tile([1.0, 2.0, 2.0], (4, 1)))
    np.testing.assert_allclose(wr.cap_half_angle(S), a, atol=1e-7)


def test_meridian_half_angles_fisher_equal_spheres():
    """Equal spheres: cos(alpha + theta) = k (1 - cos(alpha) + d/2) (Fisher)."""
    for th in (0.0, 30.0, 60.0):
        for d in (0.0, 0.2, 0.5):
            k = np.array([-0.3, 0.5, 2.0, 6.0])
            a, b, _ = wr.meridian_half_angles(2 + d, 1.0, 1.0, th, k)
            ok = np.isfinite(a)
            assert ok.sum() >= 3
            np.testing.assert_allclose(a[ok], b[ok], atol=1e-9)
            res = np.cos(a[ok] + np.radians(th)) - k[ok] * (1 - np.cos(a[ok]) + d / 2)
            np.testing.assert_allclose(res, 0, atol=1e-8)


def test_meridian_half_angles_swap_symmetry():
    a, b, y = wr.meridian_half_angles(3.2, 1.0, 1.7, 25.0, 1.5)
    b2, a2, y2 = wr.meridian_half_angles(3.2, 1.7, 1.0, 25.0, 1.5)
    np.testing.assert_allclose([a, b, y], [a2, b2, y2], atol=1e-9)
    assert a > b          # the smaller grain is wetted over the wider angle


def test_toroidal_half_angles_laplace_and_trend():
    """Laplace at the neck holds, and more suction means smaller caps."""
    prev = np.inf
    for P in (0.5, -1.0, -3.0, -6.0):
        ai, aj, ok = wr.toroidal_half_angles(2.05, 1.0, 1.0, 20.0, P)
        assert ok and ai == pytest.approx(aj, abs=1e-6)
        assert ai < prev
        prev = ai
        th = np.radians(20.0)
        rho = (1 - np.cos(ai) + 0.025) / np.cos(ai + th)
        neck = np.sin(ai) - rho * (1 - np.sin(ai + th))
        assert 1 / neck - 1 / rho == pytest.approx(P, abs=0.05)


def test_union_region_single_cap_and_disjoint_caps():
    e1, e2 = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    S, L = wr.union_region([("cap", (e1, 0.3))], n=2880)
    Sc, Lc = wr.cap_region(0.3, e1)
    np.testing.assert_allclose(S, Sc, atol=1e-5)
    np.testing.assert_allclose(L, Lc, atol=1e-5)
    S, L = wr.union_region([("cap", (e1, 0.3)), ("cap", (e2, 0.4))], n=2880)
    np.testing.assert_allclose(S, Sc + wr.cap_region(0.4, e2)[0], atol=1e-5)
    # overlapping caps: the union's vector area is less than the sum
    S, _ = wr.union_region([("cap", (e1, 0.9)), ("cap", (e2, 0.9))], n=2880)
    Ssum = wr.cap_region(0.9, e1)[0] + wr.cap_region(0.9, e2)[0]
    assert np.linalg.norm(S) < np.linalg.norm(Ssum) - 0.05


def test_cap_hull_polygon_contains_caps_between():
    e1, e2 = np.array([1.0, 0, 0]), np.array([np.cos(1.2), np.sin(1.2), 0])
    V = wr.cap_hull_polygon(e1, 0.3, e2, 0.3)
    assert V.shape == (4, 3)
    mid = (e1 + e2) / np.linalg.norm(e1 + e2)       # between the caps, inside the hull
    assert all(mid @ np.cross(a, b) > 0 for a, b in zip(V, np.roll(V, -1, axis=0)))
    S_hull, _ = wr.union_region([("cap", (e1, 0.3)), ("cap", (e2, 0.3)), ("polygon", V)])
    S_caps, _ = wr.union_region([("cap", (e1, 0.3)), ("cap", (e2, 0.3))])
    assert np.linalg.norm(S_hull) > np.linalg.norm(S_caps)
    assert wr.cap_hull_polygon(e1, 0.9, e1, 0.2) is None            # nested caps


def _triangle(d=2.0, opening_deg=60.0):
    h = np.radians(opening_deg) / 2
    return np.array([[0, 0, 1.0], [-d * np.sin(h), 0, 1 - d * np.cos(h)],
                     [d * np.sin(h), 0, 1 - d * np.cos(h)]])


def test_predict_regions_doublet_and_balance():
    C = np.array([[0, 0, 0], [2.1, 0, 0]])
    S, L, info = wr.predict_regions(C, [1, 1], 30.0, -2.0, [(0, 1)])
    F = wr.region_force(-2.0, 30.0, S, L)
    np.testing.assert_allclose(F[0], -F[1], atol=1e-4)
    ai = info["alpha"][(0, 1)][0]
    closed = np.sin(ai) * np.sin(ai + np.radians(30)) + np.sin(ai) ** 2
    assert F[0, 0] == pytest.approx(closed, rel=1e-3)


@pytest.mark.parametrize("open_side", ["point", "mirror"])
def test_predict_regions_triplet_symmetry(open_side):
    """A symmetric open triangle: mirror-image forces on the outer grains, the shared
    grain's force on the symmetry axis, and the pore adds to the shared grain."""
    C = _triangle(2.0, 70.0)
    S, L, info = wr.predict_regions(C, np.ones(3), 30.0, -1.0, [(0, 1), (0, 2)],
                                    open_side=open_side)
    F = wr.region_force(-1.0, 30.0, S, L)
    np.testing.assert_allclose(F[1] * [-1, 1, 1], F[2], atol=1e-3)
    assert abs(F[0, 0]) < 1e-3 and abs(F[0, 1]) < 1e-3
    assert info["triangles"] == [(0, 1, 2)]
    S0, _, _ = wr.predict_regions(C, np.ones(3), 30.0, -1.0, [(0, 1), (0, 2)], pores=False)
    assert np.linalg.norm(S[0]) > np.linalg.norm(S0[0])


def test_predict_regions_tetrahedron_symmetry():
    D = 2.05
    h = D * np.sqrt(3) / 2
    C = np.array([[0, 0, 0], [D, 0, 0], [D / 2, h, 0], [D / 2, h / 3, D * np.sqrt(2 / 3)]])
    pairs = [(i, j) for i in range(4) for j in range(i + 1, 4)]
    S, L, info = wr.predict_regions(C, np.ones(4), 20.0, -3.0, pairs)
    F = wr.region_force(-3.0, 20.0, S, L)
    mag = np.linalg.norm(F, axis=1)
    np.testing.assert_allclose(mag, mag[0], rtol=2e-3)
    np.testing.assert_allclose(F.sum(axis=0), 0, atol=5e-3 * mag[0])
    towards = C.mean(axis=0) - C
    cosang = np.einsum("ij,ij->i", F, towards) / (mag * np.linalg.norm(towards, axis=1))
    np.testing.assert_allclose(cosang, 1, atol=1e-4)       # pulled toward the centre
    assert len(info["tetrahedra"]) == 1


def test_predict_regions_refuses_nothing_but_gives_no_cap_without_bridge():
    C = np.array([[0, 0, 0], [2.1, 0, 0], [10.0, 0, 0]])
    S, L, _ = wr.predict_regions(C, np.ones(3), 30.0, -2.0, [(0, 1)])
    np.testing.assert_allclose(S[2], 0)
    np.testing.assert_allclose(L[2], 0)


def test_window_balls_touch_three_grains_at_the_contact_angle():
    C = _triangle(2.05, 70.0)
    for theta, b in ((0.0, 0.8), (30.0, 1.5)):
        balls = wr.window_balls(C, np.ones(3), theta, b)
        assert balls.shape == (2, 3)
        D = np.sqrt(1 + b * b + 2 * b * np.cos(np.radians(theta)))
        for x in balls:
            np.testing.assert_allclose(np.linalg.norm(C - x, axis=1), D, rtol=1e-10)
        # one on each side of the plane of the centres (y = 0 here)
        assert balls[0, 1] * balls[1, 1] < 0
    # a ball small enough to pass through the triangle touches no three grains
    assert len(wr.window_balls(_triangle(2.6, 100.0), np.ones(3), 0.0, 0.05)) == 0


def test_window_model_open_triangle_and_its_fallback():
    C = _triangle(2.0, 70.0)
    pairs = [(0, 1), (0, 2)]
    # suction: window pieces, symmetric, and the pore adds to every grain
    S, L, _ = wr.predict_regions(C, np.ones(3), 30.0, -1.5, pairs)
    F = wr.region_force(-1.5, 30.0, S, L)
    np.testing.assert_allclose(F[1] * [-1, 1, 1], F[2], atol=1e-3)
    S0, _, _ = wr.predict_regions(C, np.ones(3), 30.0, -1.5, pairs, pores=False)
    assert np.all(np.linalg.norm(S, axis=1) > np.linalg.norm(S0, axis=1))
    np.testing.assert_allclose(F.sum(axis=0), 0, atol=0.05 * np.abs(F).max())
    # P* >= 0, positive_pressure="hull" (the model before 2026-11-27): no window ball;
    # the hull with mirror caps
    S, L, _ = wr.predict_regions(C, np.ones(3), 60.0, 0.8, pairs, positive_pressure="hull")
    Sh, Lh, _ = wr.predict_regions(C, np.ones(3), 60.0, 0.8, pairs, pore_shape="hull",
                                   windows=False, open_side="mirror")
    np.testing.assert_allclose(S, Sh, atol=1e-12)
    np.testing.assert_allclose(L, Lh, atol=1e-12)
    # the default continues the windows through P* >= 0 as flat ones: not the hull
    Sf, _, _ = wr.predict_regions(C, np.ones(3), 60.0, 0.8, pairs)
    assert np.abs(Sf - Sh).max() > 0.05


def test_body_volume_doublet_and_pore():
    """One pair: the toroidal bridge holds the exact doublet's volume at the same P*
    within the toroidal approximation's error; a triangle's pore adds liquid."""
    r = solve_doublet(gap=0.0, volume=0.05, theta=30)
    V = wr.body_volume([[0, 0, 0], [2.0, 0, 0]], [1, 1], 30.0, r["pressure"], [(0, 1)])
    assert V == pytest.approx(0.05, rel=0.05)
    C = _triangle(2.0, 70.0)
    Vb = wr.body_volume(C, np.ones(3), 30.0, -1.5, [(0, 1), (0, 2)], max_open_gap=-1.0)
    Vp = wr.body_volume(C, np.ones(3), 30.0, -1.5, [(0, 1), (0, 2)])
    assert Vp > 1.2 * Vb > 0
    assert np.isnan(wr.body_volume(C, np.ones(3), 30.0, 0.5, [(0, 1), (0, 2)]))


def test_missing_bridge_none_drops_the_cap_only_where_no_bridge_exists():
    """theta = 60, gap 0.2: no toroidal bridge in suction (the bridge's pressure stays
    positive); "minimum" keeps the caps of its pressure minimum, "none" none."""
    C = [[0, 0, 0], [2.2, 0, 0]]
    _, _, ok = wr.toroidal_half_angles(2.2, 1.0, 1.0, 60.0, -1.0)
    assert not ok
    S, _, _ = wr.predict_regions(C, [1, 1], 60.0, -1.0, [(0, 1)], missing_bridge="minimum")
    Sn, Ln, _ = wr.predict_regions(C, [1, 1], 60.0, -1.0, [(0, 1)], missing_bridge="none")
    assert np.linalg.norm(S[0]) > 0.1
    np.testing.assert_allclose(Sn, 0)
    np.testing.assert_allclose(Ln, 0)
    assert wr.body_volume(C, [1, 1], 60.0, -1.0, [(0, 1)], missing_bridge="none") == 0
    assert wr.body_volume(C, [1, 1], 60.0, -1.0, [(0, 1)]) > 0
    # where the bridge exists the option changes nothing
    C2 = [[0, 0, 0], [2.05, 0, 0]]
    a = wr.predict_regions(C2, [1, 1], 30.0, -2.0, [(0, 1)])[0]
    b = wr.predict_regions(C2, [1, 1], 30.0, -2.0, [(0, 1)], missing_bridge="none")[0]
    np.testing.assert_allclose(a, b, atol=1e-12)
    with pytest.raises(ValueError, match="missing_bridge"):
        wr.predict_regions(C2, [1, 1], 30.0, -2.0, [(0, 1)], missing_bridge="zero")


@pytest.mark.parametrize("pairs", [[(0, 1), (0, 2), (1, 2)], [(0, 1), (0, 2)]])
def test_pressure_from_volume_inverts_body_volume(pairs):
    C = _triangle(2.1, 65.0)
    kw = dict(n_samples=60_000, seed=3)
    for P in (-4.0, -1.2):
        V = wr.body_volume(C, np.ones(3), 20.0, P, pairs, **kw)
        Pm = wr.pressure_from_volume(C, np.ones(3), 20.0, V, pairs, **kw)
        # a step function of P (Monte Carlo with fixed samples): a few per cent
        assert Pm == pytest.approx(P, rel=0.05)
        # more liquid, less suction
        Pl = wr.pressure_from_volume(C, np.ones(3), 20.0, 1.3 * V, pairs, **kw)
        assert Pm < Pl < 0
    assert np.isnan(wr.pressure_from_volume(C, np.ones(3), 20.0, 1e3, pairs, **kw))
    with pytest.raises(ValueError, match="bracket"):
        wr.pressure_from_volume(C, np.ones(3), 20.0, 0.5, pairs, bracket=(-1.0, 0.5))


def _closed_triplet_forces(gaps, theta, P, **kw):
    from capbridge.solvers.triplet import triplet_geometry
    C = triplet_geometry(*gaps).centres
    S, L, _ = wr.predict_regions(C, np.ones(3), theta, P, [(0, 1), (0, 2), (1, 2)], n=360,
                                 **kw)
    return wr.region_force(P, theta, S, L)


def test_toroidal_fold_is_where_the_bridge_stops_existing():
    for gap, theta in ((0.2, 0.0), (0.1, 40.0), (0.15, 20.0)):
        ai, aj, Pf = wr.toroidal_fold(2.0 + gap, 1.0, 1.0, theta)
        assert Pf < 0 and ai == pytest.approx(aj)
        assert wr.toroidal_half_angles(2.0 + gap, 1.0, 1.0, theta, Pf + 0.01)[2]
        assert not wr.toroidal_half_angles(2.0 + gap, 1.0, 1.0, theta, Pf - 0.01)[2]
        # the caps are continuous across the fold (to the curvature scan's resolution)
        a_in = wr.pair_caps(2.0 + gap, 1.0, 1.0, theta, Pf + 1e-3)[0]
        a_out = wr.pair_caps(2.0 + gap, 1.0, 1.0, theta, Pf - 1e-3)[0]
        assert abs(a_in - a_out) < np.radians(0.5)
    # theta = 60, gap 0.2: the global minimum over the scan is at its wide end (62 deg
    # caps, the "minimum" rule); the fold is the first minimum from rupture
    assert np.degrees(wr.toroidal_half_angles(2.2, 1.0, 1.0, 60.0, -1.0)[0]) > 55
    assert 15 < np.degrees(wr.toroidal_fold(2.2, 1.0, 1.0, 60.0)[0]) < 30


def test_torus_reach_limits():
    for theta in (0.0, 30.0, 60.0):
        bi, bj = wr.torus_reach(2.1, 1.0, 1.0, theta, 1e6)     # flat: 90 deg - theta
        assert np.degrees(bi) == pytest.approx(90.0 - theta, abs=1e-3)
        assert bi == pytest.approx(bj)
    # shrinks with the ball, zero once the torus passes through the gap
    b = [wr.torus_reach(2.1, 1.0, 1.0, 30.0, x)[0] for x in (10.0, 1.0, 0.3, 0.1, 0.01)]
    assert all(x >= y for x, y in zip(b, b[1:])) and b[0] > b[2] and b[-1] == 0.0


def test_reach_caps_are_continuous_and_shrink_beyond_the_fold():
    """Beyond the fold the caps shrink with the suction and vanish where the gas torus
    of the body's curvature passes through the gap; in suction they never exceed the
    fold's, and where the bridge exists the rule changes nothing."""
    d, th = 2.2, 0.0
    fi, _, Pf = wr.toroidal_fold(d, 1.0, 1.0, th)
    a = [wr.pair_caps(d, 1.0, 1.0, th, P)[0] for P in (Pf - 0.01, -3.0, -6.0, -12.0, -60.0)]
    assert all(x >= y for x, y in zip(a, a[1:])) and a[0] <= fi and a[-1] == 0.0
    assert a[0] == pytest.approx(fi)
    for mb in ("reach", "fold", "minimum", "none"):
        assert wr.pair_caps(2.05, 1.0, 1.0, 30.0, -2.0, mb) == \
            wr.toroidal_half_angles(2.05, 1.0, 1.0, 30.0, -2.0)


@pytest.mark.parametrize("theta,P", [(0.0, -2.0), (60.0, -1.0)])
def test_forces_continuous_in_the_gap_across_the_bridge_existence_limit(theta, P):
    """A closed triplet whose third gap crosses the gap where that pair's toroidal
    bridge stops existing at P*: the default's grain forces move by little per step of
    the gap; "none" (no cap without a bridge) and, at theta = 60, "minimum" jump."""
    gaps = np.linspace(0.05, 0.2, 31)

    def max_step(**kw):
        F = [_closed_triplet_forces((0.05, 0.05, g), theta, P, **kw) for g in gaps]
        return max(np.abs(F[i + 1] - F[i]).max() / np.abs(F[i]).max()
                   for i in range(len(F) - 1))

    assert max_step() < 0.035
    assert max_step(missing_bridge="none") > 0.06
    if theta == 60.0:
        assert max_step(missing_bridge="minimum") > 0.3


@pytest.mark.parametrize("gaps,theta", [((0.1, 0.1, 0.1), 30.0), ((0.0, 0.0, 0.3), 30.0),
                                        ((0.05, 0.1, 0.2), 60.0)])
def test_forces_continuous_through_zero_pressure(gaps, theta):
    """The window pieces continue through P* = 0 as flat windows: the forces just below
    and just above P* = 0 agree; the old hull at P* >= 0 jumps by > 10 %."""
    def jump(**kw):
        a = _closed_triplet_forces(gaps, theta, -1e-4, **kw)
        b = _closed_triplet_forces(gaps, theta, 1e-4, **kw)
        return np.abs(a - b).max() / np.abs(a).max()

    assert jump() < 1e-3
    assert jump(positive_pressure="hull") > 0.1
    with pytest.raises(ValueError, match="positive_pressure"):
        _closed_triplet_forces(gaps, theta, 0.5, positive_pressure="convex")
