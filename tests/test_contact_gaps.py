"""Contacts are valid input: a lookup never refuses the grains-in-contact geometry that
its own caller (the DEM engine) produces.

The bug this pins (issue 16, item 0): ``LiquidClusters.lookup`` clamps contact gaps to 0
and rebuilds the centres with :func:`triangle_centres`; ``predict_vectors`` recomputed
the gaps from those centres, got -2.2e-16 and refused the "overlap", so about half of
the in-table triplets with two contacts got no force and the engine switched the
cluster's forces off and on.  Now gaps down to -CONTACT_OVERLAP_MAX (a DEM overlap) are
contacts, looked up at gap 0; deeper overlaps are still one clear error.
"""
from __future__ import annotations

import numpy as np
import pytest

from capbridge.dem.bridges import default_table_path
from capbridge.dem.triplet_clusters import load_surrogate, triangle_centres
from capbridge.status import HAS_RESULT, Status
from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.surrogate.triplet import default_table
from capbridge.validation import CONTACT_OVERLAP_MAX, CapbridgeInputError, check_range

PAIRS = ((0, 1), (0, 2), (1, 2))


@pytest.fixture(scope="module")
def sur():
    return load_surrogate(default_table())


@pytest.fixture(scope="module")
def dbl():
    return DoubletSurrogate().fit(default_table_path())


def _random_contact_triplets(sur, n, seed):
    """n in-table triplets with grains 1-2 and 1-3 in contact (gap 0) and the open
    side d23 anywhere on the table's gap axis: centre distances as the engine forms
    them (2 + gap, then triangle_centres)."""
    rng = np.random.default_rng(seed)
    d23 = rng.uniform(sur.gaps_[0], sur.gaps_[-1], n)
    theta = rng.uniform(sur.theta_[0], sur.theta_[-1], n)
    zero = np.zeros(n)
    Vc = sur.coalescence_volume(zero, zero, d23, theta)["volume_coalescence"]
    volume = rng.uniform(1.05, 1.9, n) * Vc
    C = triangle_centres(2.0 + zero, 2.0 + zero, 2.0 + d23)
    return C, volume, theta, d23


def test_rebuilt_contact_centres_are_answered_like_their_gaps(sur):
    """400 in-table triplets with two contacts, centres rebuilt from the gaps as the
    engine does: every one gets the answer of predict() at the clamped gaps (to
    round-off), none is refused; before the fix a large share raised "overlap"."""
    C, V, t, d23 = _random_contact_triplets(sur, 400, 1)
    gaps_back = np.stack([np.linalg.norm(C[:, j] - C[:, i], axis=-1) - 2 for i, j in PAIRS], -1)
    assert (gaps_back < 0).sum() > 50        # the round-off the bug tripped on is there
    res = sur.predict_vectors(C, V, t)
    ref = sur.predict(0.0, 0.0, d23, V, t)
    for name in ("f12", "f13", "f23", "pressure"):
        np.testing.assert_allclose(res[name], ref[name], rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(res["status"], ref["status"])
    assert np.isin(res["status"], HAS_RESULT).mean() > 0.9


@pytest.mark.parametrize("overlap", [1e-12, 1e-6, 2e-4, 1e-2, CONTACT_OVERLAP_MAX])
def test_dem_overlaps_are_contacts_and_grain_order_does_not_matter(sur, overlap):
    """Grains 1-2 and 1-3 overlapping by a DEM amount: the answer at gap 0, forces along
    the actual centre lines, summing to zero; relabelling the grains permutes the
    forces and nothing else."""
    d23 = 0.5 * (sur.gaps_[0] + sur.gaps_[-1])
    theta = 30.0
    Vc = float(sur.coalescence_volume(0.0, 0.0, d23, theta)["volume_coalescence"])
    V = 1.3 * Vc
    C = triangle_centres(2.0 - overlap, 2.0 - overlap, 2.0 + d23)
    res = sur.predict_vectors(C, V, theta)
    ref = sur.predict(0.0, 0.0, d23, V, theta)
    assert int(res["status"]) in HAS_RESULT
    for name in ("f12", "f13", "f23"):
        assert float(res[name]) == pytest.approx(float(ref[name]), rel=1e-12)
    np.testing.assert_allclose(res["gaps"], [-overlap, -overlap, d23], atol=1e-12)
    F = res["forces"]
    np.testing.assert_allclose(F.sum(0), 0.0, atol=1e-12)
    u12 = (C[1] - C[0]) / np.linalg.norm(C[1] - C[0])
    u13 = (C[2] - C[0]) / np.linalg.norm(C[2] - C[0])
    u23 = (C[2] - C[1]) / np.linalg.norm(C[2] - C[1])
    np.testing.assert_allclose(F[0], ref["f12"] * u12 + ref["f13"] * u13, atol=1e-12)
    np.testing.assert_allclose(F[1], -ref["f12"] * u12 + ref["f23"] * u23, atol=1e-12)
    for perm in ((1, 0, 2), (2, 1, 0), (0, 2, 1), (1, 2, 0)):
        p = sur.predict_vectors(C[list(perm)], V, theta)
        np.testing.assert_allclose(p["forces"], F[list(perm)], rtol=1e-9, atol=1e-12)
        assert int(p["status"]) == int(res["status"])


def test_overlap_deeper_than_a_dem_contact_is_one_clear_error(sur):
    C = triangle_centres(2.0 - 2 * CONTACT_OVERLAP_MAX, 2.0, 2.1)
    with pytest.raises(CapbridgeInputError, match="grains 1 and 2 overlap by 0.1") as exc:
        sur.predict_vectors(C, 0.3, 30.0)
    assert "\n" not in str(exc.value)
    with pytest.raises(CapbridgeInputError, match=r"gap d12=-0.06 is outside .*\[-0.05, inf\)"):
        sur.predict(-0.06, 0.0, 0.1, 0.3, 30.0)


def test_unequal_radii_overlap_limit_is_the_pairs_smaller_radius(sur):
    """Radii 1, 2, 1: a 0.04 overlap of the pair (1, 2) is a contact (< 0.05 x 1)."""
    R = np.array([1.0, 2.0, 1.0])
    C = triangle_centres(2.96, 2.05, 3.05)[()]               # gaps -0.04, 0.05, 0.05
    res = sur.predict_vectors(C, 0.5, 30.0, radii=R)
    assert res["gaps"][0] == pytest.approx(-0.04)
    C[1, 0] = 2.9                                             # 0.1 > 0.05 x 1
    with pytest.raises(CapbridgeInputError, match="overlap"):
        sur.predict_vectors(C, 0.5, 30.0, radii=R)


@pytest.mark.slow
def test_doublet_contact_overlap_is_the_contact_answer(dbl):
    at0 = dbl.predict(0.0, 0.05, 30.0)
    for g in (-1e-12, -1e-3, -CONTACT_OVERLAP_MAX):
        r = dbl.predict(g, 0.05, 30.0)
        assert float(r["force"]) == float(at0["force"])
        assert int(r["status"]) == Status.CONVERGED
    with pytest.raises(CapbridgeInputError, match=r"gap d\*=-0.1 .*\[-0.05, inf\)"):
        dbl.predict(-0.1, 0.05, 30.0)
    # SI: an overlap of 1 % of the smaller radius (1 mm) is a contact
    si = dbl.predict_si(1e-3, 2e-3, 0.072, -1e-5, 5e-11, 30.0)
    si0 = dbl.predict_si(1e-3, 2e-3, 0.072, 0.0, 5e-11, 30.0)
    assert float(si["force"]) == float(si0["force"])
    with pytest.raises(CapbridgeInputError, match="predict_si gap"):
        dbl.predict_si(1e-3, 2e-3, 0.072, -1e-4, 5e-11, 30.0)


def test_bond_per_point_against_one_geometry(sur):
    """bond=[0.5, 1.0] with one geometry: two answers (was a numpy broadcast error)."""
    if not sur.has_gravity_:
        pytest.skip("the triplet table has no gravity response")
    d = 0.5 * (sur.gaps_[0] + sur.gaps_[-1])
    C = triangle_centres(2.0 + d, 2.0 + d, 2.0 + d)
    Vc = float(sur.coalescence_volume(d, d, d, 30.0)["volume_coalescence"])
    res = sur.predict_vectors(C, 1.3 * Vc, 30.0, bond=[0.5, 1.0])
    assert res["forces"].shape == (2, 3, 3)
    for k, bo in enumerate((0.5, 1.0)):
        one = sur.predict_vectors(C, 1.3 * Vc, 30.0, bond=bo)
        np.testing.assert_allclose(res["forces"][k], one["forces"], rtol=1e-12, atol=1e-15)
    with pytest.raises(CapbridgeInputError, match="do not broadcast"):
        sur.predict_vectors(np.stack([C] * 3), 1.3 * Vc, 30.0, bond=[0.5, 1.0])


@pytest.mark.parametrize("value, word", [
    (np.datetime64("2020-01-01"), "a date"),
    (np.array(["2020-01-01"], dtype="datetime64[D]"), "a date"),
    (np.timedelta64(5, "s"), "a time span"),
    (0.1 + 0.2j, "a complex number"),
    (True, "a boolean"),
    (np.array([True, False]), "a boolean"),
    ("0.1", "text"),
    ([0.1, "x"], "not a number"),
    ([0.1, None], "not a number"),
])
def test_values_that_only_look_like_numbers_are_refused(sur, value, word):
    with pytest.raises(CapbridgeInputError, match=word):
        check_range("gap", value)
    with pytest.raises(CapbridgeInputError, match="gap d12"):
        sur.predict(value, 0.05, 0.05, 0.3, 30.0)


def test_plain_numbers_still_pass():
    np.testing.assert_array_equal(check_range("x", [1, 2.5, np.float32(3)]), [1, 2.5, 3])
    assert float(check_range("x", np.int64(4))) == 4.0
    from decimal import Decimal
    from fractions import Fraction
    np.testing.assert_array_equal(check_range("x", [Decimal("0.5"), Fraction(1, 4)]),
                                  [0.5, 0.25])


@pytest.mark.slow
def test_cli_lookup_answers_dem_contacts_for_table_and_exact_rows(tmp_path):
    """A DEM overlap in `lookup doublet` is a contact for the table rows and for the
    mixed-angle rows that the exact solver answers."""
    import pandas as pd

    from capbridge.cli import main

    src = tmp_path / "p.csv"
    pd.DataFrame({"d": [-0.01, 0.0, -0.01, 0.0], "V": [0.05] * 4,
                  "theta": [30.0] * 4, "theta2": [30.0, 30.0, 40.0, 40.0]}).to_csv(src, index=False)
    out = tmp_path / "o.csv"
    assert main(["lookup", "doublet", "--input", str(src), "--output", str(out)]) == 0
    df = pd.read_csv(out)
    assert list(df["method"]) == ["table", "table", "exact", "exact"]
    assert df["F"][0] == df["F"][1] and df["F"][2] == df["F"][3]
    assert set(df["status"]) == {"converged"}
