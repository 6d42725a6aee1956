"""Triplets by Surface Evolver: coalesced body, separate bridges' cap gaps, energies.

Small meshes (refinement level 2); each Evolver test takes a few seconds on two cores.
"""
import numpy as np
import pytest

from capbridge.solvers.triplet import triplet_geometry, uncoalesced_state
from capbridge.solvers.triplet_evolver import (coalescence_from_cap_gaps,
                                                 energy_convention_check, evolver_triplet)

PAPER = triplet_geometry(0.175, 0.175, 0.075)
ALPHA = PAPER.angle_at(0, 1, 2) / 2


def test_cap_gap_extrapolation_and_interpolation():
    V = np.array([8.0, 10, 12, 14, 16])
    gap = 5 - 0.5 * V + 0.01 * V ** 2                 # closes at 13.82
    root = 25 - np.sqrt(25 ** 2 - 500)
    both = coalescence_from_cap_gaps(V, gap, 2 * ALPHA)
    assert both["bracketed"] and both["V_coal"] == pytest.approx(root, rel=1e-9)
    ahead = coalescence_from_cap_gaps(V[:3], gap[:3], 2 * ALPHA)
    assert not ahead["bracketed"] and ahead["V_coal"] == pytest.approx(root, rel=1e-9)
    assert ahead["beta_equivalent"][0] == pytest.approx(ALPHA - gap[0] / 2)
    assert np.isnan(coalescence_from_cap_gaps([1.0], [1.0], 60.0)["V_coal"])


@pytest.mark.evolver
def test_coalesced_trimer_forces_balance_and_decompose():
    r = evolver_triplet(16 / 64, PAPER, 0.0, "coalesced", max_refine=2)
    assert r["status"] in ("converged", "above_tolerance"), r["reason"]
    F = np.array(r["forces"])
    scale = np.abs(F).max()
    assert np.linalg.norm(F.sum(axis=0)) < 5e-3 * scale      # no gravity: balanced (mesh)
    assert np.abs(F[:, 1]).max() < 1e-6                       # in the plane of the centres
    assert r["pair_residual"] < 5e-3                          # three pair forces
    assert r["F_top_vertical"] > 0
    f = r["pair_forces"]
    assert f["12"] == pytest.approx(f["13"], rel=2e-2)        # mirror symmetry
    assert f["23"] > 0                                        # the body also pulls 2-3
    assert r["lower_meniscus_z"] < 0                          # trimer (paper, section 3.3)
    # the coalesced body holds less energy than the separate bridges at that volume
    unc = uncoalesced_state(16 / 64, PAPER, 0.0)
    assert r["energy_extrapolated"] < float(unc["energy"])


@pytest.mark.evolver
def test_separate_bridges_cap_gap_matches_exact_at_theta60():
    V = 24 / 64
    r = evolver_triplet(V, PAPER, 60.0, "bridges", max_refine=2)
    assert r["status"] in ("converged", "above_tolerance"), r["reason"]
    beta = float(uncoalesced_state(V, PAPER, 60.0)["bridge"][(0, 1)]["beta_i"])
    exact_gap = 2 * (ALPHA - beta)
    assert r["cap_gaps"]["grain 1"] == pytest.approx(exact_gap, abs=0.3)
    ex = uncoalesced_state(V, PAPER, 60.0)
    assert r["F_top_vertical"] == pytest.approx(-ex["forces"][0, 2], rel=1e-2)


@pytest.mark.evolver
def test_energy_convention_agrees_with_exact_doublet():
    c = energy_convention_check(gap=0.175, volume=0.1, theta=60.0, max_refine=2)
    assert c["status"] in ("converged", "above_tolerance")
    assert c["rel_diff"] < 5e-3
