"""Tests of the vertical doublet with gravity (capbridge.solvers.young_laplace_gravity).

Tolerances: the meridian is integrated to rtol 1e-12 and Newton stops at residuals of
1e-11, so quantities of the solution carry errors of ~1e-10; each check states which
error bounds it.  Surface Evolver comparisons are in benchmarks/gravity_axis_check.py
(minutes), not here.
"""
from __future__ import annotations

import numpy as np
import pytest

from capbridge.solvers.young_laplace import rupture_distance, solve_doublet
from capbridge.solvers.young_laplace_gravity import (BOND_MAX, GravitySettings,
                                                       rupture_distance_gravity,
                                                       solve_doublet_gravity)
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError

CONVERGED = int(Status.CONVERGED)
# (gap, volume, theta1, ratio, theta2): equal and unequal grains, mixed angles, theta = 0
POINTS = [(0.1, 0.05, 30.0, 1.0, 30.0), (0.05, 0.01, 0.0, 1.0, 0.0),
          (0.02, 0.05, 20.0, 2.0, 50.0), (0.3, 0.1, 40.0, 5.0, 10.0)]


def _cols(points):
    return [np.array(c) for c in zip(*points)]


# ------------------------------------------------------------------ Bo -> 0


@pytest.mark.parametrize("bond", [0.0, 1e-9])
def test_zero_bond_is_the_zero_gravity_solution(bond):
    """Bo -> 0: the integrated meridian is the Delaunay roulette of the exact solver.
    Both are converged to ~1e-10 and the gravity effect at Bo = 1e-9 is ~1e-10, so they
    agree to 1e-8 (absolute in degrees, relative otherwise)."""
    d, v, t1, R, t2 = _cols(POINTS)
    g = solve_doublet_gravity(d, v, t1, bond, R, t2)
    z = solve_doublet(d, v, t1, R, t2)
    assert np.all(g["status"] == CONVERGED) and np.all(z["status"] == CONVERGED)
    for key in ("force", "force1", "force2"):
        np.testing.assert_allclose(g[key], z["force"], rtol=1e-8, err_msg=key)
    for key in ("pressure", "energy", "area", "neck_radius", "volume"):
        np.testing.assert_allclose(g[key], z[key], rtol=1e-8, atol=1e-12, err_msg=key)
    for key in ("beta1", "beta2"):
        np.testing.assert_allclose(g[key], z[key], atol=1e-8, err_msg=key)
    assert np.all(g["indicator"] > 0)


def test_ruptured_without_gravity():
    """Beyond the zero-gravity rupture distance: RUPTURED (force 0) at Bo = 0 as in the
    zero-gravity solver; with gravity that verdict is not reused (NOT_CONVERGED), since
    gravity moves the rupture distance."""
    r = solve_doublet_gravity([0.5, 0.5], 0.01, 30.0, [0.0, 0.5])
    assert r["status"].tolist() == [int(Status.RUPTURED), int(Status.NOT_CONVERGED)]
    assert r["force"][0] == 0.0 and np.isnan(r["force"][1])


# ------------------------------------------------------------------ the liquid's weight


@pytest.mark.slow
@pytest.mark.parametrize("gravity_axis", [-1.0, 1.0])
def test_grains_share_the_weight(gravity_axis):
    """The liquid is in equilibrium: the forces on the two grains differ by its weight,
    F2 - F1 = -g_axis Bo V* / (2 pi) (F1 from the contact line and cap of grain 1, F2
    from those of grain 2, V* from the quadrature along the meridian: three independent
    computations, consistent to the integration error ~1e-10).  The lower grain carries
    the weight: its attraction is the smaller one, and its wetted cap the larger."""
    d, v, t1, R, t2 = _cols(POINTS)
    for bond in (0.13, 1.0, 2.5):
        r = solve_doublet_gravity(d, v, t1, bond, R, t2, gravity_axis=gravity_axis)
        assert np.all(r["status"] == CONVERGED)
        np.testing.assert_allclose(r["volume"], v, rtol=1e-10)
        weight = bond * v / (2.0 * np.pi)
        np.testing.assert_allclose(r["force2"] - r["force1"], -gravity_axis * weight,
                                   rtol=0, atol=1e-8)
        np.testing.assert_allclose(r["weight"], weight, rtol=1e-10)
        lower, upper = ("force1", "force2") if gravity_axis < 0 else ("force2", "force1")
        assert np.all(r[lower] < r[upper])
        # the wetted caps shift towards the lower grain (relative to no gravity)
        z = solve_doublet(d, v, t1, R, t2)
        shift = (r["beta1"] - z["beta1"]) * -gravity_axis
        assert np.all(shift > 0), shift


# ------------------------------------------------------------------ virtual work


@pytest.mark.parametrize("point", [
    (0.1, 0.05, 30.0, 1.0, 30.0, 2.14, -1.0),
    (0.05, 0.05, 30.0, 2.0, 30.0, 1.0, 1.0),
    (0.2, 0.1, 60.0, 1.0, 20.0, 0.5, -1.0)])
def test_force_is_virtual_work(point):
    """F2 = (1/2 pi) dE*/dD at fixed volume and Bo (E* with the gravitational energy
    from the centre of grain 1, held fixed): central differences with h = 1e-3 (error
    ~h^2 F''' ~ 1e-7, plus 1e-10 / h from the solutions) agree to 1e-5; F1 then follows
    from the weight (previous test)."""
    d, v, t1, R, t2, bond, ga = point
    h = 1e-3
    r = solve_doublet_gravity([d - h, d, d + h], v, t1, bond, R, t2, gravity_axis=ga)
    assert np.all(r["status"] == CONVERGED)
    dE = (r["energy"][2] - r["energy"][0]) / (2 * h)
    assert abs(dE / (2 * np.pi) - r["force2"][1]) < 1e-5, (dE / (2 * np.pi), r["force2"][1])
    # the pressure is the Lagrange multiplier of the volume: dE*/dV* at fixed gap is
    # P* at the origin of heights (the centre of grain 1); h_V = 1e-4 (truncation
    # ~h^2 P''/6 < 1e-6, solution noise ~1e-10/h = 1e-6)
    hv = 1e-4
    rv = solve_doublet_gravity(d, [v - hv, v + hv], t1, bond, R, t2, gravity_axis=ga)
    dEdV = (rv["energy"][1] - rv["energy"][0]) / (2 * hv)
    assert abs(dEdV - r["pressure_centre1"][1]) < 1e-5, (dEdV, r["pressure_centre1"][1])
    # P*(x) = P_m - b (x - x_m): the two pressures differ by the hydrostatic head
    assert abs(r["pressure_centre1"][1] - r["pressure"][1] + ga * bond * (1 + d / 2)) < 1e-12


# ------------------------------------------------------------------ numerical convergence


def test_converges_under_tolerance_refinement():
    """Tightening the integrator's and Newton's tolerances converges: the change from
    the tightest settings shrinks with the tolerance and is < 1e-9 at the defaults; the
    forward-difference step of the Jacobian does not change the answer (1e-10)."""
    args = (0.05, 0.05, 30.0, 2.14, 2.0, 45.0)
    ref = solve_doublet_gravity(*args, settings=GravitySettings(rtol=1e-13, tol=1e-12))
    errs = []
    for rtol in (1e-8, 1e-10, 1e-12):
        r = solve_doublet_gravity(*args, settings=GravitySettings(rtol=rtol, tol=10 * rtol))
        assert r["status"] == CONVERGED
        errs.append(max(abs(float(r[k] - ref[k])) for k in ("force1", "force2", "pressure",
                                                              "energy")))
    assert errs[2] < errs[0] and errs[2] < 1e-9 and errs[1] < 1e-7, errs
    r = solve_doublet_gravity(*args, settings=GravitySettings(fd_step=1e-6))
    for k in ("force1", "force2", "pressure", "beta1", "beta2"):
        assert abs(float(r[k] - ref[k])) < 1e-9, k


# ------------------------------------------------------------------ symmetry


def test_flipping_gravity_mirrors_the_bridge():
    """Equal spheres: the bridge with angles (t1, t2) and gravity towards grain 1 is the
    mirror image of the bridge with (t2, t1) and gravity towards grain 2: forces and
    filling angles swap, the pressure at mid-gap is the same, and the energies differ
    only by the origin of heights, E_A - E_B = b_A D V* (b_A = Bo, D = 2 + d*)."""
    d, v, bond = 0.15, 0.08, 1.5
    a = solve_doublet_gravity(d, v, 20.0, bond, 1.0, 40.0, gravity_axis=-1.0)
    b = solve_doublet_gravity(d, v, 40.0, bond, 1.0, 20.0, gravity_axis=1.0)
    for ka, kb in (("force1", "force2"), ("force2", "force1"), ("beta1", "beta2"),
                   ("beta2", "beta1"), ("pressure", "pressure"), ("force", "force"),
                   ("neck_radius", "neck_radius"), ("area", "area")):
        assert abs(float(a[ka] - b[kb])) < 1e-9, (ka, float(a[ka]), float(b[kb]))
    assert abs(float(a["energy"] - b["energy"]) - bond * (2.0 + d) * v) < 1e-9
    # equal angles: the mean force is even in Bo, the grains' forces swap
    up = solve_doublet_gravity(d, v, 30.0, bond, gravity_axis=1.0)
    dn = solve_doublet_gravity(d, v, 30.0, bond, gravity_axis=-1.0)
    assert abs(float(up["force1"] - dn["force2"])) < 1e-9
    assert abs(float(up["force"] - dn["force"])) < 1e-9


# ------------------------------------------------------------------ end of the branch


@pytest.mark.slow
def test_gravity_ruptures_a_large_bridge():
    """A large bridge near its zero-gravity rupture (d* = 0.5, V* = 0.3, theta = 0,
    d*_rupt = 0.734) loses its stable state as Bo grows: the stability indicator falls
    towards 0 and the branch folds at one Bo; just below it the bridge exists (with a
    smaller indicator still), beyond it the status is RUPTURED with force 0."""
    r = solve_doublet_gravity(0.5, 0.3, 0.0, [0.0, 2.1, 2.3])
    assert r["status"].tolist() == [CONVERGED, CONVERGED, int(Status.RUPTURED)]
    assert r["indicator"][1] < 0.6 * r["indicator"][0]
    fold = r["rupture_bond"][2:]
    assert 2.1 < fold[0] < 2.3, fold
    assert r["force"][2] == 0.0 and np.isfinite(r["force"][:2]).all()
    below = solve_doublet_gravity(0.5, 0.3, 0.0, fold[0] - 0.01)
    assert below["status"] == CONVERGED and 0 < below["indicator"] < r["indicator"][1]


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize("kw, text", [
    (dict(bond=-0.1), "Bond number Bo=-0.1 is outside the allowed range [0, 5]"),
    (dict(bond=BOND_MAX + 1), "Bond number Bo=6.0 is outside"),
    (dict(bond=np.nan), "Bond number Bo=nan"),
    (dict(bond=1.0, gravity_axis=0.0), "gravity_axis=0.0 is not allowed"),
    (dict(bond=1.0, theta=95.0), "theta=95.0 deg is outside"),
    (dict(bond=1.0, gap=-0.1), "gap d*=-0.1 is outside")])
def test_bad_input_is_one_clear_error(kw, text):
    args = dict(gap=0.1, volume=0.05, theta=30.0) | kw
    with pytest.raises(CapbridgeInputError) as e:
        solve_doublet_gravity(**args)
    assert text in str(e.value) and "\n" not in str(e.value)


# ------------------------------------------------------------------ rupture distance


@pytest.mark.slow
def test_rupture_distance_without_gravity_is_the_zero_gravity_one():
    """At Bo = 0 the walk in the gap ends where the zero-gravity solver puts rupture, to
    1e-7: the fold of an unequal pair (ratio 2) and, for equal grains and angles, the
    symmetry-breaking point, which comes 1.3e-4 before the symmetric fold at V* = 0.05,
    theta = 30 (the walk must not step across that gap onto the symmetric branch's
    return, where the indicator is positive again)."""
    v, th, R = 0.05, 30.0, np.array([1.0, 2.0])
    g = rupture_distance_gravity(v, th, 0.0, R)
    z = rupture_distance(v, th, R)
    assert np.all(g["status"] == CONVERGED)
    np.testing.assert_allclose(g["gap"], z["gap"], rtol=0, atol=1e-7)
    np.testing.assert_allclose(g["force"], z["force"], rtol=1e-5)


@pytest.mark.slow
def test_rupture_distance_with_gravity_is_where_solutions_end():
    """At Bo = 2.14 (V* = 0.05, theta = 30, equal grains) gravity shortens the rupture
    distance (0.4775 -> 0.432), and the two continuations agree: just below d*_rupt(Bo)
    the bridge is reached by continuation in Bo from zero gravity, just above it that
    continuation ends (RUPTURED) at a Bo below 2.14."""
    bond = 2.14
    r = rupture_distance_gravity(0.05, 30.0, bond)
    d_r = float(r["gap"])
    assert r["status"] == CONVERGED and 0.40 < d_r < 0.47
    assert abs(float(r["force2"] - r["force1"]) - bond * 0.05 / (2 * np.pi)) < 1e-8
    s = solve_doublet_gravity([d_r - 1e-3, d_r + 1e-3], 0.05, 30.0, bond)
    assert s["status"].tolist() == [CONVERGED, int(Status.RUPTURED)]
    assert s["rupture_bond"][1] < bond
