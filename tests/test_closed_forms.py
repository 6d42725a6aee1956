"""Tests for capbridge.physics.closed_forms (literature formulas for doublet forces)."""
import inspect

import numpy as np
import pytest

from capbridge.physics import closed_forms as cf
from capbridge.physics.closed_forms import (
    CLOSED_FORMS,
    lian_rupture_distance,
    pitois_cylindrical_force,
    rabinovich_force,
    richefeu_force,
    willett_analytic_force,
    willett_numeric_force,
    willett_rupture_distance,
)
from capbridge.validation import CapbridgeInputError

THETAS = np.array([0.0, 10.0, 30.0, 50.0, 80.0])
ALL_FORCES = list(CLOSED_FORMS.items())
# models that accept unequal spheres through the Derjaguin radius
DERJAGUIN_FORCES = [(n, f) for n, f in ALL_FORCES if n != "richefeu"]


def test_registry_lists_the_five_force_models_with_one_signature():
    assert set(CLOSED_FORMS) == {"pitois", "richefeu", "willett_numeric",
                                 "willett_analytic", "rabinovich"}
    for func in CLOSED_FORMS.values():
        params = list(inspect.signature(func).parameters)
        assert params[:3] == ["gap", "volume", "theta"]
        assert inspect.signature(func).parameters["ratio"].default == 1.0


# --------------------------------------------------------------------------------------
# limits at contact
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("func", [pitois_cylindrical_force, richefeu_force,
                                  willett_analytic_force])
@pytest.mark.parametrize("volume", [1e-4, 0.01, 0.1])
def test_contact_force_is_cos_theta(func, volume):
    np.testing.assert_allclose(func(0.0, volume, THETAS), np.cos(np.radians(THETAS)),
                               rtol=1e-12)


def test_willett_numeric_at_contact_tends_to_cos_theta_for_small_volume():
    # Stated tolerance: at V* = 1e-4 the fit is within 10 % below cos(theta)
    # (the exact contact force of a finite bridge is below cos(theta), and
    # approaches it only as V*^(1/4)); it must approach it as V* decreases.
    thetas = np.array([0.0, 10.0, 20.0, 30.0, 40.0])
    c = np.cos(np.radians(thetas))
    f_small = willett_numeric_force(0.0, 1e-4, thetas)
    assert np.all(f_small <= c)
    assert np.all(f_small >= 0.9 * c)
    f_mid = willett_numeric_force(0.0, 1e-3, thetas)
    f_big = willett_numeric_force(0.0, 1e-2, thetas)
    assert np.all(f_small > f_mid) and np.all(f_mid > f_big)


def test_rabinovich_contact_value_is_the_continuous_limit():
    v, theta = 0.01, 30.0
    t = np.radians(theta)
    alpha0 = (2.0 * v / np.pi) ** 0.25
    expected = np.cos(t) + np.sin(alpha0) * np.sin(t + alpha0)
    assert rabinovich_force(0.0, v, theta) == pytest.approx(expected, rel=1e-12)
    assert rabinovich_force(1e-12, v, theta) == pytest.approx(expected, rel=1e-9)


def test_rabinovich_is_pitois_plus_the_contact_line_term():
    d = np.linspace(0.0, 0.3, 7)
    extra = rabinovich_force(d, 0.02, 20.0) - pitois_cylindrical_force(d, 0.02, 20.0)
    assert np.all(extra > 0.0)
    assert np.all(np.diff(extra) < 0.0)


# --------------------------------------------------------------------------------------
# shape of the force-distance curves
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name,func", ALL_FORCES)
@pytest.mark.parametrize("volume", [1e-3, 0.01, 0.1])
@pytest.mark.parametrize("theta", [0.0, 30.0, 50.0])
def test_force_decreases_with_gap_and_stays_positive(name, func, volume, theta):
    gaps = np.linspace(0.0, 1.2 * lian_rupture_distance(volume, theta), 60)
    f = func(gaps, volume, theta)
    assert np.all(np.isfinite(f))
    assert np.all(f > 0.0)
    assert np.all(np.diff(f) < 0.0), name


@pytest.mark.parametrize("name,func", [(n, f) for n, f in ALL_FORCES if n != "rabinovich"])
def test_force_decreases_with_contact_angle(name, func):
    f = func(0.05, 0.01, np.linspace(0.0, 60.0, 13))
    assert np.all(np.diff(f) < 0.0), name


def test_rabinovich_rises_with_small_contact_angles_as_documented():
    # the sin(alpha) sin(theta + alpha) term grows with theta; the exact force does not
    f = rabinovich_force(0.05, 0.01, np.array([0.0, 20.0, 60.0]))
    assert f[1] > f[0] > f[2]


# --------------------------------------------------------------------------------------
# reference values
# --------------------------------------------------------------------------------------

# Exact Young-Laplace forces F* for equal spheres, hard-coded (from
# capbridge.solvers.young_laplace.solve_doublet; an independent shooting solution gives
# the same to 1e-4): (gap d*, volume V*, theta [deg], F*).
YOUNG_LAPLACE = [
    (0.0, 0.001, 0.0, 0.9361),
    (0.025, 0.001, 0.0, 0.3117),
    (0.0, 0.01, 0.0, 0.8844),
    (0.05, 0.01, 0.0, 0.4732),
    (0.1077, 0.01, 0.0, 0.2306),
    (0.068, 0.01, 30.0, 0.3285),
    (0.0774, 0.01, 50.0, 0.2289),
    (0.1162, 0.05, 30.0, 0.4058),
    (0.2321, 0.1, 0.0, 0.3651),
    (0.3333, 0.1, 50.0, 0.2113),
]


@pytest.mark.parametrize("gap,volume,theta,exact", YOUNG_LAPLACE)
def test_willett_numeric_matches_young_laplace(gap, volume, theta, exact):
    # documented accuracy: within 3 % for theta <= 30 deg, 5 % at 50 deg
    tol = 0.03 if theta <= 30 else 0.05
    assert willett_numeric_force(gap, volume, theta) == pytest.approx(exact, rel=tol)


def test_willett_numeric_closed_values():
    # pins the coefficient table (ln, half-separation S+, theta terms)
    assert willett_numeric_force(0.0, 0.01, 0.0) == pytest.approx(0.871488, rel=1e-5)
    assert willett_numeric_force(0.05, 0.01, 0.0) == pytest.approx(0.470987, rel=1e-5)
    t = np.radians(40.0)
    lnv = np.log(1e-3)
    f1 = ((-0.44507 + 0.050832 * t - 1.1466 * t**2)
          + (-0.1119 - 0.000411 * t - 0.1490 * t**2) * lnv
          + (-0.012101 - 0.0036456 * t - 0.01255 * t**2) * lnv**2
          + (-0.0005 - 0.0003505 * t - 0.00029076 * t**2) * lnv**3)
    assert willett_numeric_force(0.0, 1e-3, 40.0) == pytest.approx(np.exp(f1), rel=1e-12)


def test_willett_analytic_equals_herminghaus_full_gap_form():
    d = np.linspace(0.0, 0.4, 9)
    v, theta = 0.02, 25.0
    s_hat = d / np.sqrt(v)                 # full gap * sqrt(R/V), R = r
    expected = np.cos(np.radians(theta)) / (1.0 + 1.05 * s_hat + 2.5 * s_hat**2)
    np.testing.assert_allclose(willett_analytic_force(d, v, theta), expected, rtol=1e-12)


def test_pitois_matches_miot_equation_6():
    d, v, theta = 0.1, 0.008, 20.0
    expected = np.cos(np.radians(theta)) * (1 - 1 / np.sqrt(1 + 2 * v / (np.pi * d**2)))
    assert pitois_cylindrical_force(d, v, theta) == pytest.approx(expected, rel=1e-12)


def test_richefeu_matches_miot_equation_7():
    d, v, theta = 0.1, 0.156, 40.0
    expected = np.cos(np.radians(theta)) * np.exp(-d / (0.9 * np.sqrt(v)))
    assert richefeu_force(d, v, theta) == pytest.approx(expected, rel=1e-12)


# --------------------------------------------------------------------------------------
# unequal spheres (Derjaguin radius) and normalisation by the smaller radius
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name,func", DERJAGUIN_FORCES)
@pytest.mark.parametrize("ratio", [1.5, 3.0])
def test_unequal_spheres_rescale_by_the_derjaguin_radius(name, func, ratio):
    # F/(2 pi gamma r) = k * F/(2 pi gamma R_eff), lengths / R_eff = (lengths / r) / k
    k = 2 * ratio / (1 + ratio)
    d = np.array([0.0, 0.02, 0.08, 0.2])
    v, theta = 0.03, 20.0
    expected = k * func(d / k, v / k**3, theta)
    np.testing.assert_allclose(func(d, v, theta, ratio=ratio), expected, rtol=1e-12,
                               err_msg=name)


@pytest.mark.parametrize("name,func", ALL_FORCES)
def test_ratio_one_is_the_default(name, func):
    assert func(0.03, 0.02, 10.0, ratio=1.0) == func(0.03, 0.02, 10.0)


def test_larger_partner_sphere_attracts_more_at_contact():
    # at contact the Derjaguin force scales with R_eff = k r, k -> 2 for ratio -> inf
    f = pitois_cylindrical_force(0.0, 0.01, 0.0, ratio=np.array([1.0, 2.0, 1e6]))
    np.testing.assert_allclose(f, [1.0, 4.0 / 3.0, 2.0], rtol=1e-5)


def test_richefeu_refuses_unequal_spheres():
    with pytest.raises(CapbridgeInputError, match="ratio"):
        richefeu_force(0.01, 0.01, 0.0, ratio=2.0)


# --------------------------------------------------------------------------------------
# broadcasting and return types
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name,func", ALL_FORCES)
def test_broadcasting_shapes(name, func):
    gap = np.linspace(0.0, 0.1, 5)[:, None]
    volume = np.array([0.001, 0.01, 0.1])[None, :]
    assert func(gap, volume, 30.0).shape == (5, 3)
    theta = np.array([0.0, 45.0])[:, None, None]
    out = func(gap, volume, theta)
    assert out.shape == (2, 5, 3)
    # each element equals the scalar call
    assert out[1, 2, 0] == pytest.approx(func(float(gap[2, 0]), 0.001, 45.0), rel=1e-14)


@pytest.mark.parametrize("name,func", DERJAGUIN_FORCES)
def test_ratio_broadcasts(name, func):
    out = func(np.array([0.0, 0.05]), 0.01, 0.0, ratio=np.array([[1.0], [2.0], [4.0]]))
    assert out.shape == (3, 2)


@pytest.mark.parametrize("name,func", ALL_FORCES)
def test_scalar_in_float_out(name, func):
    assert isinstance(func(0.01, 0.01, 10.0), float)


def test_rupture_distances_broadcast_and_return_floats():
    v = np.array([1e-3, 1e-2, 1e-1])[:, None]
    t = np.array([0.0, 30.0])[None, :]
    assert lian_rupture_distance(v, t).shape == (3, 2)
    assert willett_rupture_distance(v, t).shape == (3, 2)
    assert isinstance(lian_rupture_distance(0.01, 0.0), float)
    assert isinstance(willett_rupture_distance(0.01, 0.0), float)


# --------------------------------------------------------------------------------------
# rupture distances
# --------------------------------------------------------------------------------------


def test_lian_rupture_at_zero_angle_is_cube_root_of_volume():
    v = np.array([1e-5, 1e-3, 0.008, 0.1, 0.5])
    np.testing.assert_allclose(lian_rupture_distance(v, 0.0), np.cbrt(v), rtol=1e-14)
    assert lian_rupture_distance(0.008, 0.0) == pytest.approx(0.2, rel=1e-14)


def test_rupture_distances_grow_with_contact_angle_as_one_plus_half_theta():
    v = 0.02
    for theta in [10.0, 45.0, 80.0]:
        factor = 1.0 + 0.5 * np.radians(theta)
        assert lian_rupture_distance(v, theta) == pytest.approx(
            factor * lian_rupture_distance(v, 0.0), rel=1e-14)
        assert willett_rupture_distance(v, theta) == pytest.approx(
            factor * willett_rupture_distance(v, 0.0), rel=1e-14)


def test_willett_rupture_adds_the_two_thirds_power_correction():
    v = np.array([1e-6, 1e-3, 0.05])
    c = np.cbrt(v)
    np.testing.assert_allclose(willett_rupture_distance(v, 0.0), c + 0.1 * c**2,
                               rtol=1e-14)
    ratio = willett_rupture_distance(v, 20.0) / lian_rupture_distance(v, 20.0)
    assert np.all(ratio > 1.0)
    assert ratio[0] == pytest.approx(1.0, abs=1e-3)   # reduces to Lian as V* -> 0


# --------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------

BAD_FORCE_INPUTS = [
    ({"theta": 90.0}, "theta"),
    ({"theta": 120.0}, "theta"),
    ({"theta": -1.0}, "theta"),
    ({"theta": np.nan}, "theta"),
    ({"volume": 0.0}, "volume"),
    ({"volume": -0.01}, "volume"),
    ({"volume": np.inf}, "volume"),
    ({"gap": -1e-3}, "gap"),
    ({"gap": np.nan}, "gap"),
    ({"gap": np.array([0.0, 0.1, -0.2])}, "gap"),
    ({"ratio": 0.5}, "ratio"),
]


@pytest.mark.parametrize("name,func", ALL_FORCES)
@pytest.mark.parametrize("override,word", BAD_FORCE_INPUTS)
def test_bad_force_input_raises_and_names_the_value(name, func, override, word):
    args = {"gap": 0.05, "volume": 0.01, "theta": 20.0}
    args.update(override)
    with pytest.raises(CapbridgeInputError) as info:
        func(**args)
    assert word in str(info.value)


@pytest.mark.parametrize("func", [lian_rupture_distance, willett_rupture_distance])
@pytest.mark.parametrize("volume,theta,word", [
    (0.0, 0.0, "volume"), (-1.0, 0.0, "volume"), (np.nan, 0.0, "volume"),
    (0.01, 90.0, "theta"), (0.01, -5.0, "theta"), (0.01, np.inf, "theta"),
])
def test_bad_rupture_input_raises_and_names_the_value(func, volume, theta, word):
    with pytest.raises(CapbridgeInputError) as info:
        func(volume, theta)
    assert word in str(info.value)


def test_error_message_states_the_allowed_range():
    with pytest.raises(CapbridgeInputError) as info:
        willett_numeric_force(0.0, 0.01, 95.0)
    msg = str(info.value)
    assert "95" in msg and "[0, 90)" in msg


def test_input_error_is_a_value_error():
    assert issubclass(CapbridgeInputError, ValueError)
    with pytest.raises(ValueError):
        cf.pitois_cylindrical_force(0.0, -1.0, 0.0)
