"""Separated triplet states at equal pressure and the shipped coalescence-volume table."""
import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from capbridge.tables.netcdf_io import read_table
from capbridge.solvers.triplet import find_coalescence, triplet_geometry, uncoalesced_state
from capbridge.tables.coalescence import (COALESCENCE_CONFIGURATIONS,
                                                     CoalescenceGrid, build_coalescence_table,
                                                     coalescence_chunk, fit_errors,
                                                     interpolation_errors,
                                                     lowest_separated_energy, main,
                                                     save_coalescence_table, separated_state)
from capbridge.solvers.young_laplace import solve_doublet, solve_doublet_suction
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError

PAPER = (0.175, 0.175, 0.075)              # Miot et al. 2021: r = 4 mm, V* = V[ul] / 64
UNEQUAL = (0.05, 0.2, 0.075)               # bridges 12 (narrow) and 13 (wide) on grain 1


def _dP_dV(gap, volume, theta, eps=1e-4):
    """dP*/dV* of one bridge at fixed gap (central difference, volume control)."""
    r = solve_doublet(gap, volume * np.array([1 - eps, 1 + eps]), theta)
    return float(np.diff(r["pressure"])[0] / (2 * eps * volume))


# --------------------------------------------------------------------------------------
# separated states
# --------------------------------------------------------------------------------------


@pytest.mark.slow
def test_symmetric_pair_shares_equally_and_matches_uncoalesced_state():
    V, theta = 0.2, 30.0
    s = separated_state(*PAPER, V, theta)
    u = uncoalesced_state(V, triplet_geometry(*PAPER), theta)      # equal fractions
    assert s["status"] == Status.CONVERGED
    vols = np.array(list(s["volumes"].values()))
    assert abs(vols.sum() - V) < 1e-12
    assert np.allclose(vols, V / 2, rtol=0, atol=1e-12)
    assert s["pressure_spread"] < 1e-9
    assert s["energy"] == pytest.approx(float(u["energy"]), abs=1e-9)
    assert np.max(np.abs(s["forces"] - u["forces"])) < 1e-9
    assert all(s["pressure_stable"].values())


@pytest.mark.slow
def test_unequal_gaps_share_the_liquid_at_one_pressure():
    V, theta = 0.2, 20.0
    s = separated_state(*UNEQUAL, V, theta)
    assert s["status"] == Status.CONVERGED
    v12, v13 = s["volumes"][(0, 1)], s["volumes"][(0, 2)]
    assert abs(v12 + v13 - V) < 1e-12
    assert v12 > v13                         # the narrower gap holds more at one suction
    # independent check: each bridge solved at its own volume has the common pressure
    p = [float(solve_doublet(d, v, theta)["pressure"]) for d, v in ((0.05, v12), (0.2, v13))]
    assert abs(p[0] - p[1]) < 1e-9
    assert s["pressure"] == pytest.approx(p[0], abs=1e-9)
    e = sum(float(solve_doublet(d, v, theta)["energy"]) for d, v in ((0.05, v12), (0.2, v13)))
    assert s["energy"] == pytest.approx(e, abs=1e-9)
    assert np.linalg.norm(s["forces"].sum(axis=0)) < 1e-12


@pytest.mark.parametrize("theta", [0.0, 40.0])
def test_suction_branch_volume_increases_with_pressure(theta):
    # the premise of the equal-pressure solve: on the suction-stable branch V(P) rises
    # pressures spanning the family at d* = 0.175, from volume-controlled solves
    P = np.sort(solve_doublet(0.175, np.geomspace(0.004, 0.4, 16), theta)["pressure"])
    r = solve_doublet_suction(0.175, P[np.isfinite(P)], theta)
    ok = r["status"] == Status.CONVERGED
    assert ok.sum() >= 8
    assert np.all(np.diff(r["volume"][ok]) > 0)


@pytest.mark.slow
def test_widest_bridge_drains_past_its_pressure_fold_and_stays_stable():
    theta = 20.0
    s = separated_state(*UNEQUAL, 0.141, theta)
    assert s["status"] == Status.CONVERGED
    assert s["master"] == (0, 2) and s["pressure_stable"] == {(0, 1): True, (0, 2): False}
    k12 = _dP_dV(0.05, s["volumes"][(0, 1)], theta)
    k13 = _dP_dV(0.2, s["volumes"][(0, 2)], theta)
    assert k13 < 0 < k12                 # the wide bridge is past its pressure fold ...
    assert k12 + k13 > 0                 # ... yet the exchange Hessian is positive: stable
    # below the configuration's smallest total volume (~0.1397) nothing is separated
    assert separated_state(*UNEQUAL, 0.136, theta)["status"] == Status.RUPTURED


@pytest.mark.slow
def test_equal_gaps_below_the_pressure_fold_cannot_share():
    # V/2 = 0.015 is between the rupture volume (0.0052) and the pressure fold (0.023)
    # of a bridge at d* = 0.175: each bridge exists at fixed volume, but exchanging
    # liquid the pair is unstable (dP/dV < 0 for both), so no separated state exists
    V = 0.03
    u = uncoalesced_state(V, triplet_geometry(*PAPER), 0.0)
    assert int(u["status"]) == Status.CONVERGED
    assert _dP_dV(0.175, V / 2, 0.0) < 0
    assert separated_state(*PAPER, V, 0.0)["status"] == Status.RUPTURED


@pytest.mark.slow
def test_lowest_separated_energy_picks_the_lowest_candidate():
    r = lowest_separated_energy(*PAPER, 0.2, 0.0)
    c = r["candidates"]
    assert set(c) == {"12,13", "12,23", "13,23", "12,13,23"}
    assert all(st == Status.CONVERGED for _, st in c.values())
    assert r["energy"] == min(e for e, _ in c.values())
    assert c["12,23"][0] == pytest.approx(c["13,23"][0], abs=1e-9)    # mirror images
    assert r["configuration"] in ("12,23", "13,23")     # the narrow bottom gap is used
    assert r["energy"] == pytest.approx(r["state"]["energy"], abs=0)
    ring = separated_state(*PAPER, 0.2, 0.0, "12,13,23")
    assert ring["energy"] == c["12,13,23"][0]
    assert abs(sum(ring["volumes"].values()) - 0.2) < 1e-12
    assert ring["pressure_spread"] < 1e-9


def test_bad_input_is_one_clear_error():
    with pytest.raises(CapbridgeInputError, match="total volume"):
        separated_state(*PAPER, -0.1, 0.0)
    with pytest.raises(CapbridgeInputError, match="theta"):
        separated_state(*PAPER, 0.1, 95.0)
    with pytest.raises(CapbridgeInputError, match="d12"):
        lowest_separated_energy(float("nan"), 0.1, 0.1, 0.1, 0.0)


# --------------------------------------------------------------------------------------
# coalescence volumes: solver, builder, shipped table
# --------------------------------------------------------------------------------------


@pytest.mark.slow
def test_chunk_solver_gives_the_papers_coalescence_volume():
    r = coalescence_chunk(np.array([0.175]), np.array([0.175]), np.array([0.075]),
                          np.array([0.0]), configuration="pair")
    assert r["status"][0] == Status.CONVERGED
    assert round(float(r["V_coal"][0]) * 64, 2) == 13.14          # ul for r = 4 mm
    assert r["criterion"][0] == 0                                 # caps (beta = alpha)


@pytest.mark.slow
def test_quick_table_is_built_and_never_overwritten(tmp_path):
    grid = CoalescenceGrid(gaps=(0.1, 0.2), theta=(60.0, 80.0), n_heldout=1,
                           configurations=("pair",))
    ds = build_coalescence_table(grid, n_jobs=1, progress=False, command="test")
    V = ds["V_coal_pair"].values
    assert np.all(ds["status_pair"].values == Status.CONVERGED)
    assert np.array_equal(V, V.transpose(1, 0, 2, 3))            # d12 <-> d13
    assert not np.allclose(V, V.transpose(0, 2, 1, 3))           # not d13 <-> d23
    r = find_coalescence(triplet_geometry(0.1, 0.2, 0.1), 80.0)
    assert V[0, 1, 0, 1] == pytest.approx(r.V_coal, rel=1e-12)
    out = tmp_path / "t.nc"
    out.write_text("user data")
    with pytest.raises(CapbridgeInputError, match="exists"):
        save_coalescence_table(ds, out, command="test")
    assert out.read_text() == "user data"
    save_coalescence_table(ds, out, command="test", overwrite=True)
    back = read_table(out)
    assert back["V_coal_pair"].attrs["units"] == "1"
    assert np.array_equal(back["V_coal_pair"].values, V)


def test_cli_errors_are_one_line_and_leave_files_alone(tmp_path, capsys):
    out = tmp_path / "mine.nc"
    out.write_text("user data")
    assert main(["--quick", "--output", str(out)]) == 2
    assert out.read_text() == "user data"
    assert main(["--quick", "--jobs", "0", "--output", str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(e.startswith("error: ") for e in err)


@pytest.fixture(scope="module")
def table(coalescence_table):
    return read_table(coalescence_table)


def test_shipped_table_provenance_and_size(table, coalescence_table):
    assert coalescence_table.stat().st_size < 2e6
    assert "triplet_coalescence" in table.attrs["capbridge_command"]
    for name in list(table.data_vars) + list(table.coords):
        assert table[name].attrs.get("units") and table[name].attrs.get("long_name"), name
    for c in COALESCENCE_CONFIGURATIONS:
        assert np.all(table[f"status_{c}"].values == Status.CONVERGED), c
        assert np.all(np.isfinite(table[f"V_coal_{c}"].values))


def test_shipped_cube_permutation_symmetry(table):
    ring = table["V_coal_ring"].values
    for p in itertools.permutations(range(3)):
        assert np.array_equal(ring, ring.transpose(*p, 3))
    pair = table["V_coal_pair"].values
    assert np.array_equal(pair, pair.transpose(1, 0, 2, 3))
    # not symmetric under d13 <-> d23: that moves the shared grain
    assert not np.allclose(pair, pair.transpose(0, 2, 1, 3))
    assert "canonical order" in table["V_coal_pair"].attrs["long_name"]
    # equilateral triplets: the caps criterion at the same bridge volume in both
    # configurations, so the ring holds 3/2 of the pair's total
    n = table.sizes["d12"]
    for i in range(n):
        crit = table["criterion_pair"].values[i, i, i]
        same = (crit == 0) & (table["criterion_ring"].values[i, i, i] == 0)
        assert np.allclose(ring[i, i, i][same], 1.5 * pair[i, i, i][same], rtol=1e-7)


def test_linear_law_reproduces_the_table_within_its_stored_residual(table):
    th = table["theta"].values
    for c in COALESCENCE_CONFIGURATIONS:
        fit = table[f"V0_{c}"].values[..., None] + th / 90.0 * table[f"dV_{c}"].values[..., None]
        res = np.abs(table[f"V_coal_{c}"].values - fit)
        assert np.all(res <= table[f"fit_max_{c}"].values[..., None] + 1e-12)
        rms = np.sqrt(np.mean(res ** 2, axis=-1))
        assert np.allclose(rms, table[f"fit_rms_{c}"].values, rtol=1e-9, atol=1e-14)


#: roundings per interpolated value, relative to the largest node value involved: linear,
#: 16 corner weights of 4 factors each, times V, summed (4 + 1 + 15, and 1 for /exact - 1);
#: cubic, 4 successive 1-D not-a-knot spline fits and evaluations on 5 nodes (~50
#: roundings each), amplified by the spline's Lebesgue constant 1.86 per axis (1.86^4 = 12)
_INTERPOLATION_ROUNDINGS = {"linear": 21, "cubic": 12 * 50}


def test_stored_interpolation_errors_are_reproduced(table):
    """The stored held-out errors are what interpolating the stored cube gives here: to
    the round-off of the interpolation (the processor and BLAS that made the table may
    round differently: measured 3 ulp for cubic), not bit for bit."""
    u = np.finfo(float).eps
    for c in COALESCENCE_CONFIGURATIONS:
        h = f"heldout_{c}"
        pts = np.vstack([table[f"{h}_{a}"].values for a in ("d12", "d13", "d23", "theta")])
        exact = table[f"{h}_V_coal"].values
        summary = json.loads(table.attrs[f"interpolation_error_{c}"])
        # relative errors (interpolated / exact - 1): round-off of values up to max|V|
        # divided by the exact value (max|V| / min exact ~ 4.5 here)
        scale = np.abs(table[f"V_coal_{c}"].values).max() / np.abs(exact).min()
        for method in ("linear", "cubic"):
            tol = _INTERPOLATION_ROUNDINGS[method] * u * scale  # 2e-14 linear, 6e-13 cubic
            e = interpolation_errors(table, c, pts, exact, method)
            assert np.allclose(e, table[f"{h}_error_{method}"].values, rtol=0, atol=tol)
            # the largest |error| moves by no more than the errors do
            assert np.max(np.abs(e)) == pytest.approx(summary[method]["max"], rel=0, abs=tol)
        # the linear law: V0 + theta/90 dV, V0 and dV multilinear in the gaps (as linear,
        # 2 more roundings, values up to max(|V0| + |dV|))
        law = np.abs(table[f"V0_{c}"].values) + np.abs(table[f"dV_{c}"].values)
        tol = (_INTERPOLATION_ROUNDINGS["linear"] + 2) * u * law.max() / np.abs(exact).min()
        e = fit_errors(table, c, pts, exact)
        assert np.max(np.abs(e)) == pytest.approx(summary["linear_law"]["max"], rel=0, abs=tol)


def test_papers_triplet_interpolated_within_the_stored_error(table):
    err = json.loads(table.attrs["interpolation_error_pair"])["linear"]["max"]
    e = interpolation_errors(table, "pair", np.array([[*PAPER, 0.0]]).T, [13.14 / 64])
    assert abs(e[0]) <= err + 5e-4            # 13.14 is rounded to 5e-3 ul (4e-4 rel)


@pytest.mark.slow
@pytest.mark.parametrize("c, idx", [("pair", (1, 2, 0, 4)), ("pair", (0, 3, 4, 0)),
                                    ("pair", (4, 2, 2, 3)), ("ring", (1, 3, 2, 4))])
def test_shipped_points_resolve_with_find_coalescence(table, c, idx):
    g = [float(table[a].values[i]) for a, i in zip(("d12", "d13", "d23"), idx[:3])]
    theta = float(table["theta"].values[idx[3]])
    r = find_coalescence(triplet_geometry(*g), theta, bridges=COALESCENCE_CONFIGURATIONS[c])
    assert float(table[f"V_coal_{c}"].values[idx]) == pytest.approx(r.V_coal, rel=1e-6)
