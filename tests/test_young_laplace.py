"""Tests of the exact doublet solver capbridge.solvers.young_laplace.

Every tolerance below is the size of an error that is known (and stated where it is
used): round-off of the solver, or the published error of an approximation.
"""
from __future__ import annotations

import numpy as np
import pytest

from capbridge.solvers import young_laplace as yl
from capbridge.solvers.young_laplace import (SolverSettings, bridge_shape,
                                               rupture_distance, solve_doublet,
                                               solve_doublet_suction,
                                               suction_rupture_distance)
from capbridge.status import Status
from capbridge.physics.closed_forms import (lian_rupture_distance,
                                              pitois_cylindrical_force, richefeu_force,
                                              willett_numeric_force,
                                              willett_rupture_distance)
from capbridge.validation import CapbridgeInputError

CONVERGED, RUPTURED = int(Status.CONVERGED), int(Status.RUPTURED)


def _mixed_points(n=40, seed=7):
    """Random doublets over the supported range, below rupture (0.9 d_rupt at most)."""
    rng = np.random.default_rng(seed)
    v = 10 ** rng.uniform(-3, np.log10(0.3), n)
    t1 = rng.uniform(0, 80, n)
    t2 = np.where(rng.random(n) < 0.5, t1, rng.uniform(0, 80, n))
    ratio = rng.choice([1.0, 2.0, 5.0, 10.0], n)
    d_r = rupture_distance(v, t1, ratio, t2)["gap"]
    d = rng.uniform(0, 0.9, n) * d_r
    return d, v, t1, ratio, t2, d_r


@pytest.fixture(scope="module")
def mixed():
    d, v, t1, ratio, t2, d_r = _mixed_points()
    return dict(d=d, v=v, t1=t1, ratio=ratio, t2=t2, d_r=d_r,
                r=solve_doublet(d, v, t1, ratio, t2))


# ------------------------------------------------------------------ the profile itself


def test_profile_matches_ode_integration():
    """The closed-form roulette against an independent ODE integration of the meridian
    (dx/ds = cos psi, dy/ds = sin psi, dpsi/ds = cos psi / y - P*): gap, volume and the
    end point agree to the integrator's tolerance (1e-9)."""
    from scipy.integrate import solve_ivp

    cases = [(-4.0, 0.35, 0.25, 0.3, 0.5, 1.0), (0.9, 0.3, 0.6, 1.2, 1.0, 3.0),
             (2.5, 0.4, 0.9, 0.2, 1.3, 1.5), (-30.0, 0.12, 0.04, 0.0, 0.0, 10.0)]
    for h, b1, L, t1, t2, R in cases:
        p = bridge_shape(h, b1, L, t1, t2, R)
        psi1 = b1 + t1 - np.pi / 2

        def rhs(s, u):
            x, y, psi, vol = u
            return [np.cos(psi), np.sin(psi), np.cos(psi) / y - 2 * h,
                    np.pi * y * y * np.cos(psi)]

        sol = solve_ivp(rhs, (0, L), [np.cos(b1), np.sin(b1), psi1, 0.0], rtol=1e-12,
                        atol=1e-13, method="DOP853")
        x, y, psi, vol = sol.y[:, -1]
        b2 = np.arcsin(y / R)
        gap = x + R * np.cos(b2) - 1 - R
        cap = lambda r, b: np.pi * r**3 * (2 - 3 * np.cos(b) + np.cos(b) ** 3) / 3  # noqa: E731
        assert float(p["gap"]) == pytest.approx(gap, abs=1e-9)
        assert float(p["volume"]) == pytest.approx(vol - cap(1, b1) - cap(R, b2), abs=1e-9)
        assert float(p["beta2"]) == pytest.approx(b2, abs=1e-9)
        # misfit of Young's angle on grain 2 as the ODE sees it
        assert float(p["angle"]) == pytest.approx(
            np.angle(np.exp(1j * (psi - (np.pi / 2 - b2 - t2)))), abs=1e-9)


def test_analytic_length_derivatives():
    """The Jacobian column in L is analytic (curvature of the meridian, slope of the
    contact circle on grain 2); central differences agree to 1e-7."""
    pts = yl._Points(np.radians([10.0, 70.0]), np.radians([40.0, 70.0]), np.array([3.0, 1.0]),
                     np.array([0.1, 0.2]), np.array([0.02, 0.1]))
    z = np.array([[-2.0, 1.2], [0.4, 0.5], [0.3, 0.6]])
    _, der, _ = yl._evaluate(z, pts, yl.DEFAULT_NODES)
    step = 1e-6
    plus, minus = z.copy(), z.copy()
    plus[2] += step
    minus[2] -= step
    vp, _, _ = yl._evaluate(plus, pts, yl.DEFAULT_NODES, jac=False)
    vm, _, _ = yl._evaluate(minus, pts, yl.DEFAULT_NODES, jac=False)
    for key in ("angle", "sym", "gap", "volume"):
        np.testing.assert_allclose(der[key][:, 2], (vp[key] - vm[key]) / (2 * step),
                                   rtol=1e-7, atol=1e-7, err_msg=key)


def test_bridge_profile_of_a_solution():
    """The (h, beta1, beta2) form of the profile reproduces a solution (force balance
    between the contact lines to 1e-10)."""
    r = solve_doublet(0.1, 0.02, 20.0, 4.0, 50.0)
    p = yl.bridge_profile(r["pressure"] / 2, np.radians(r["beta1"]), np.radians(r["beta2"]),
                          np.radians(20.0), np.radians(50.0), 4.0)
    assert abs(float(p["force_balance"])) < 1e-10
    assert float(p["gap"]) == pytest.approx(0.1, abs=1e-10)
    assert float(p["volume"]) == pytest.approx(0.02, rel=1e-9)


# ------------------------------------------------------------------ limits and identities


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0])
@pytest.mark.parametrize("ratio", [1.0, 5.0])
def test_contact_force_tends_to_cos_theta(theta, ratio):
    """F* -> k cos(theta) as V*, d* -> 0, k = 2 R/(1 + R) (Derjaguin; k = 1 for equal
    spheres).  The correction shrinks like V*^(1/4) (the filling angle): at V* = 1e-8
    it is below 1.5 % for theta <= 60 deg, and it falls by a factor > 1.5 per decade."""
    v = np.array([1e-5, 1e-6, 1e-7, 1e-8])
    r = solve_doublet(0.0, v, theta, ratio)
    assert np.all(r["status"] == CONVERGED)
    err = 1 - r["force"] / (2 * ratio / (1 + ratio) * np.cos(np.radians(theta)))
    assert np.all(err > 0)
    assert err[-1] < 1.5e-2
    assert np.all(err[1:] < err[:-1] / 1.5)


def test_contact_force_mixed_angles():
    """theta1 != theta2: F* -> (cos t1 + cos t2)/2 (equal spheres), same V^(1/4) law."""
    r = solve_doublet(0.0, 1e-8, 20.0, 1.0, 60.0)
    assert float(r["force"]) == pytest.approx(
        0.5 * (np.cos(np.radians(20)) + np.cos(np.radians(60))), rel=1.5e-2)


def test_neck_and_contact_line_forces_agree(mixed):
    """The axial force from the neck, y0 - P* y0^2/2, and from each contact line,
    R sin b sin(b + t) - (P*/2) R^2 sin^2 b, are the same number (1e-9)."""
    r, ok = mixed["r"], mixed["r"]["status"] == CONVERGED
    assert ok.sum() >= 35
    P, F = r["pressure"][ok], r["force"][ok]
    b1, b2 = np.radians(r["beta1"][ok]), np.radians(r["beta2"][ok])
    t1, t2 = np.radians(mixed["t1"][ok]), np.radians(mixed["t2"][ok])
    R = mixed["ratio"][ok]
    f1 = np.sin(b1) * np.sin(b1 + t1) - 0.5 * P * np.sin(b1) ** 2
    f2 = R * np.sin(b2) * np.sin(b2 + t2) - 0.5 * P * (R * np.sin(b2)) ** 2
    np.testing.assert_allclose(f1, F, rtol=0, atol=1e-9)
    np.testing.assert_allclose(f2, F, rtol=0, atol=1e-9)
    # the neck: where the thinnest section lies between the contact lines
    y0 = r["neck_radius"][ok]
    inner = y0 < np.minimum(np.sin(b1), R * np.sin(b2)) - 1e-6
    assert inner.sum() >= 10
    np.testing.assert_allclose((y0 - 0.5 * P * y0**2)[inner], F[inner], rtol=0, atol=1e-9)


@pytest.mark.parametrize("case", [
    (0.05, 0.01, 0.0, 1.0, 0.0), (0.2, 0.05, 30.0, 1.0, 30.0), (0.1, 0.02, 20.0, 5.0, 50.0),
    (0.3, 0.1, 70.0, 2.0, 70.0), (0.08, 0.004, 40.0, 10.0, 10.0), (0.4, 0.2, 75.0, 1.0, 75.0)])
def test_virtual_work(case):
    """F* = dE*/dd* / (2 pi) at fixed volume (central differences, 1e-6 relative)."""
    d, v, t1, ratio, t2 = case
    step = 1e-5
    r = solve_doublet([d - step, d, d + step], v, t1, ratio, t2)
    assert np.all(r["status"] == CONVERGED)
    dE = (r["energy"][2] - r["energy"][0]) / (2 * step)
    assert r["force"][1] == pytest.approx(dE / (2 * np.pi), rel=1e-6)


def test_converged_under_tighter_settings(mixed):
    """128 nodes and a 1e-14 tolerance change F*, P*, beta by < 1e-6 relative
    (observed ~1e-10)."""
    idx = np.flatnonzero(mixed["r"]["status"] == CONVERGED)[::3]
    args = [mixed[k][idx] for k in ("d", "v", "t1", "ratio", "t2")]
    fine = solve_doublet(*args, settings=SolverSettings(nodes=128, tol=1e-14, max_iter=80))
    assert np.all(fine["status"] == CONVERGED)
    for key in ("force", "pressure", "beta1", "beta2", "area"):
        a, b = mixed["r"][key][idx], fine[key]
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9, err_msg=key)


def test_swapping_the_angles_of_equal_spheres():
    """Equal spheres, theta1 <-> theta2: same force and pressure, swapped betas."""
    d = np.array([0.0, 0.05, 0.2])
    a = solve_doublet(d, 0.03, 15.0, 1.0, 65.0)
    b = solve_doublet(d, 0.03, 65.0, 1.0, 15.0)
    assert np.all(a["status"] == CONVERGED) and np.all(b["status"] == CONVERGED)
    np.testing.assert_allclose(a["force"], b["force"], rtol=1e-9)
    np.testing.assert_allclose(a["pressure"], b["pressure"], rtol=1e-9)
    np.testing.assert_allclose(a["beta1"], b["beta2"], rtol=1e-9)
    np.testing.assert_allclose(a["beta2"], b["beta1"], rtol=1e-9)


def test_broadcasting_and_shapes():
    r = solve_doublet(np.array([[0.0], [0.05]]), np.array([0.01, 0.02, 0.05]), 20.0)
    for key in ("force", "pressure", "beta1", "beta2", "neck_radius", "area", "energy",
                "volume", "gap", "status", "iterations"):
        assert r[key].shape == (2, 3), key
    assert np.all(r["status"] == CONVERGED)
    np.testing.assert_allclose(r["volume"], np.broadcast_to([0.01, 0.02, 0.05], (2, 3)),
                               rtol=1e-10)


# ------------------------------------------------------------------ published approximations


def _small_bridges(n, vmax, tmax, frac, seed):
    rng = np.random.default_rng(seed)
    v = 10 ** rng.uniform(-3, np.log10(vmax), n)
    t = rng.uniform(0, tmax, n)
    d = rng.uniform(0, frac, n) * rupture_distance(v, t)["gap"]
    r = solve_doublet(d, v, t)
    assert np.all(r["status"] == CONVERGED)
    return d, v, t, r["force"]


@pytest.mark.slow
def test_willett_numeric_within_a_few_percent():
    """Willett et al. (2000) numeric fit, V* < 0.1, theta < 50: 'a few %' (measured
    against this solver: median 0.6 %, max 6.8 % up to 0.9 d_rupt)."""
    d, v, t, f = _small_bridges(150, 0.1, 50, 0.9, seed=1)
    rel = np.abs(willett_numeric_force(d, v, t) / f - 1)
    assert np.median(rel) < 0.015
    assert rel.max() < 0.08


@pytest.mark.slow
def test_cylindrical_pitois_and_richefeu():
    """Pitois' cylindrical and Richefeu's exponential laws for V* < 0.01, theta < 40,
    d* < d_rupt/2.  Their error is not quantified in the sources; the design card puts
    the closed forms 13-23 % off in median.  Measured here: Pitois median 9 %, max 31 %
    (it gives cos(theta) at contact, the V* -> 0 limit); Richefeu median 24 %, max 39 %.
    The test also pins the sign of the contact error: both over-predict there."""
    d, v, t, f = _small_bridges(150, 0.01, 40, 0.5, seed=2)
    for law, med, mx in ((pitois_cylindrical_force, 0.13, 0.40),
                         (richefeu_force, 0.30, 0.45)):
        rel = np.abs(law(d, v, t) / f - 1)
        assert np.median(rel) < med, law.__name__
        assert rel.max() < mx, law.__name__
    r0 = solve_doublet(0.0, v, t)["force"]
    assert np.all(pitois_cylindrical_force(0.0, v, t) > r0)


@pytest.mark.slow
def test_lian_and_willett_rupture_distances():
    """Lian et al. (1993) (1 + theta/2) V*^(1/3) for small volumes: within 3 % for
    V* <= 0.03, theta <= 40 deg (measured 0.2-2.7 %; e.g. 0.219 against 0.215 at
    V* = 0.01, theta = 0); Willett's (2000) form with its V*^(2/3) term within 4 % up to
    V* = 0.1.  Both are within 10 % for V* <= 0.3, theta <= 60."""
    v = np.array([1e-3, 3e-3, 1e-2, 3e-2])
    for t in (0.0, 20.0, 40.0):
        d_r = rupture_distance(v, t)["gap"]
        np.testing.assert_allclose(d_r, lian_rupture_distance(v, t), rtol=0.03)
        np.testing.assert_allclose(d_r, willett_rupture_distance(v, t), rtol=0.04)
    assert float(rupture_distance(0.01, 0.0)["gap"]) == pytest.approx(0.219, abs=5e-4)
    v = np.array([0.1, 0.3])
    for t in (0.0, 30.0, 60.0):
        np.testing.assert_allclose(rupture_distance(v, t)["gap"], lian_rupture_distance(v, t),
                                   rtol=0.10)


# ------------------------------------------------------------------ rupture and stability


@pytest.mark.slow
def test_ruptured_beyond_and_converged_below(mixed):
    """Just beyond d_rupt: RUPTURED with force 0 (never a number labelled converged);
    just below: CONVERGED; rupture itself is CONVERGED."""
    d_r, args = mixed["d_r"], [mixed[k] for k in ("v", "t1", "ratio", "t2")]
    assert np.all(np.isfinite(d_r))
    above = solve_doublet(d_r * 1.001, *args)
    assert np.all(above["status"] == RUPTURED)
    assert np.all(above["force"] == 0.0)
    assert np.all(np.isnan(above["pressure"]))
    below = solve_doublet(d_r * 0.995, *args)
    assert np.all(below["status"] == CONVERGED)
    assert np.all(np.isfinite(below["force"]))


def test_every_point_converges_or_ruptures_correctly(mixed):
    """Points over the whole range up to 0.9 d_rupt all converge, and each is the bridge
    reached by following its fixed-volume family from contact."""
    r = mixed["r"]
    assert np.all(r["status"] == CONVERGED)
    idx = np.arange(0, r["status"].size, 4)
    pts = yl._Points(np.radians(mixed["t1"][idx]), np.radians(mixed["t2"][idx]),
                     mixed["ratio"][idx], mixed["d"][idx], mixed["v"][idx])
    out = yl._result_arrays(idx.size)
    for sym, grp in yl._groups(pts):
        if grp.size:
            sub = pts.take(grp)
            x_c, ok_c, st_c = yl._contact_state(sub, sym, SolverSettings(), False)
            assert np.all(st_c)
            yl._solve_on_family(yl._Problem(sub, sym, SolverSettings(), False), x_c, st_c,
                                out, grp)
    np.testing.assert_allclose(out["force"], r["force"][idx], rtol=1e-8)


def test_reported_failures_now_converge():
    """The points that ended NOT_CONVERGED before (issue 2 review)."""
    cases = [(0.195, 5.9e-3, 34.0, 5.0), (0.061, 0.0103, 36.6, 10.0),
             (0.0121, 0.0148, 2.96, 10.0), (0.597, 0.112, 77.0, 2.0)]
    d, v, t, ratio = map(np.array, zip(*cases))
    r = solve_doublet(d, v, t, ratio)
    d_r = rupture_distance(v, t, ratio)["gap"]
    assert np.all(np.isfinite(d_r))
    np.testing.assert_array_equal(r["status"], np.where(d < d_r, CONVERGED, RUPTURED))
    r = rupture_distance(0.3, 60.0)
    assert int(r["status"]) == CONVERGED
    assert float(r["gap"]) == pytest.approx(1.0203, abs=1e-3)   # Lian: 1.0196


def test_symmetric_rupture_is_the_limit_of_unequal_spheres():
    """For equal spheres and angles the stable branch ends where the symmetric bridge
    becomes unstable to liquid flowing to one grain (theta > 0: before the symmetric
    family's fold).  That is the limit ratio -> 1 of the unequal-sphere rupture, which
    is a plain fold; the symmetric fold itself lies further out."""
    v, t = 0.05, 45.0
    sym = float(rupture_distance(v, t)["gap"])
    near = rupture_distance(v, t, [1.001, 1.01])["gap"]
    assert near[0] == pytest.approx(sym, rel=2e-3)
    assert near[1] < near[0] < sym * 1.002
    # beyond the symmetry-breaking point the symmetric bridge still exists (fold later)
    assert int(solve_doublet(1.02 * sym, v, t)["status"]) == RUPTURED


def test_rupture_distance_vectorised_and_consistent():
    v = np.array([1e-3, 0.02, 0.2])
    r = rupture_distance(v, 25.0, 3.0, 55.0)
    assert np.all(r["status"] == CONVERGED)
    assert np.all(np.diff(r["gap"]) > 0)
    np.testing.assert_allclose(r["volume"], v, rtol=1e-9)
    # next to the fold the force varies like sqrt(d_rupt - d): 1e-9 below, ~4e-5
    s = solve_doublet(r["gap"] * (1 - 1e-9), v, 25.0, 3.0, 55.0)
    assert np.all(s["status"] == CONVERGED)
    np.testing.assert_allclose(s["force"], r["force"], rtol=1e-4)


# ------------------------------------------------------------------ suction control


@pytest.mark.slow
def test_suction_solve_consistent_with_volume_solve():
    """Volume solve -> P*; the suction solve at that P* and gap returns the same bridge
    (volume and force to 1e-8) wherever that bridge is on the suction-stable branch
    (small gaps; further out the volume-stable bridge is suction-unstable and the
    suction solve returns the wider one, or RUPTURED)."""
    rng = np.random.default_rng(3)
    n = 30
    v = 10 ** rng.uniform(-3, np.log10(0.3), n)
    t1 = rng.uniform(0, 50, n)
    t2 = np.where(rng.random(n) < 0.5, t1, rng.uniform(0, 50, n))
    ratio = rng.choice([1.0, 2.0, 5.0, 10.0], n)
    d = rng.uniform(0, 0.05, n) * rupture_distance(v, t1, ratio, t2)["gap"]
    r = solve_doublet(d, v, t1, ratio, t2)
    assert np.all(r["status"] == CONVERGED)
    s = solve_doublet_suction(d, r["pressure"], t1, ratio, t2)
    assert np.all(s["status"] == CONVERGED)
    np.testing.assert_allclose(s["volume"], v, rtol=1e-8)
    np.testing.assert_allclose(s["force"], r["force"], rtol=1e-8)
    np.testing.assert_allclose(s["beta2"], r["beta2"], rtol=1e-8)


@pytest.mark.slow
def test_suction_branch_and_rupture():
    """At fixed P* the gap falls as the bridge widens on the stable branch; beyond the
    largest gap the status is RUPTURED with force 0."""
    P = np.array([-20.0, -5.0, -1.0])
    for ratio in (1.0, 4.0):
        top = suction_rupture_distance(P, 10.0, ratio)
        assert np.all(top["status"] == CONVERGED)
        d_max = top["gap"]
        gaps = np.linspace(0.0, 1.0, 6)[None, :] * d_max[:, None]
        s = solve_doublet_suction(gaps, P[:, None], 10.0, ratio)
        assert np.all(s["status"] == CONVERGED)
        np.testing.assert_allclose(s["pressure"], np.broadcast_to(P[:, None], gaps.shape))
        assert np.all(np.diff(s["beta1"], axis=1) < 0)      # wider bridge at smaller gap
        out = solve_doublet_suction(1.01 * d_max, P, 10.0, ratio)
        assert np.all(out["status"] == RUPTURED)
        assert np.all(out["force"] == 0.0)
    # larger suction, shorter bridges
    assert np.all(np.diff(suction_rupture_distance(P, 0.0)["gap"]) > 0)


@pytest.mark.slow
def test_suction_grid_like_yade_tables():
    """A grid of suction x gap for ratios 1 and 10 (YADE's range): every point either
    converges or is RUPTURED exactly beyond the largest gap at its pressure."""
    P = -np.logspace(-1.5, 3, 12)
    gaps = np.linspace(0, 0.5, 11)
    for ratio in (1.0, 10.0):
        s = solve_doublet_suction(gaps[None, :], P[:, None], 0.0, ratio)
        d_max = suction_rupture_distance(P, 0.0, ratio)["gap"][:, None]
        assert np.all(np.isfinite(d_max))
        expect = np.where(gaps[None, :] <= d_max, CONVERGED, RUPTURED)
        np.testing.assert_array_equal(s["status"], expect)


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize("kwargs, word", [
    (dict(gap=0.1, volume=-0.01, theta=0.0), "volume"),
    (dict(gap=0.1, volume=np.nan, theta=0.0), "volume"),
    (dict(gap=0.1, volume=0.0, theta=0.0), "volume"),
    (dict(gap=-0.1, volume=0.01, theta=0.0), "gap"),
    (dict(gap=0.1, volume=0.01, theta=95.0), "theta"),
    (dict(gap=0.1, volume=0.01, theta=-1.0), "theta"),
    (dict(gap=0.1, volume=0.01, theta=10.0, theta2=90.0), "theta2"),
    (dict(gap=0.1, volume=0.01, theta=10.0, ratio=0.5), "ratio"),
    (dict(gap=0.1, volume=0.01, theta=10.0, ratio=np.inf), "ratio"),
])
def test_bad_input_raises_naming_the_value(kwargs, word):
    with pytest.raises(CapbridgeInputError, match=word):
        solve_doublet(**kwargs)


def test_bad_input_other_entry_points():
    with pytest.raises(CapbridgeInputError, match="volume"):
        rupture_distance([0.01, -1.0], 0.0)
    with pytest.raises(CapbridgeInputError, match="pressure"):
        solve_doublet_suction(0.1, np.nan, 0.0)
    with pytest.raises(CapbridgeInputError, match="gap"):
        solve_doublet_suction(-0.1, -2.0, 0.0)
    with pytest.raises(CapbridgeInputError, match="ratio"):
        suction_rupture_distance(-2.0, 0.0, 0.9)
