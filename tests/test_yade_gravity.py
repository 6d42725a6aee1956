"""Gravity on the liquid in CapbridgeEngine (issue 10), in real YADE (Debian's 2023.02a).

Scene: ``tests/yade_scenes/gravity_capbridge.py``, two equal glass beads held by the
scene (fixed, one driven apart along the skew axis (1, 2, 2)/3) with one water bridge
(V* = 0.05, theta = 20 deg, gamma = 0.073 N/m, drho = 997 kg/m^3), gravity read from the
NewtonIntegrator.

* 4 mm beads (Bo = drho g R^2 / gamma = 2.14): the correction is applied; on the two
  grains together the liquid forces are the liquid's weight drho V g (to 1e-9), each
  grain carries half of it (equal grains: exact), the capillary forces alone (the same
  scene without gravity) have zero net force;
* 0.1 mm beads (Bo = 1.3e-3): skipped, the forces are those without gravity bit for bit,
  the start-up line says why;
* gravity_correction="on" / "off" override the decision;
* a gravity the user changes mid-run is followed and never overwritten;
* O.saveTmp / O.loadTmp give the same forces bit for bit, forces added every step or
  held as permanent forces; O.save / O.load in a new process keep the settings;
* 'auto' decides bridge by bridge (a 1 mm and a 0.1 mm pair in one scene);
* the shipped doublet table's gravity response: equal grains carry half of the weight
  each, the second-order change of the attraction acts along the pair axis;
* with the synthetic responses of tests/test_gravity_surrogate.py: a bridge's w, c are
  the doublet surrogate's, and a coalesced triplet gets the triplet surrogate's response
  rotated into the scene (plain numpy and in YADE).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr
from capbridge.status import Status
from capbridge.dem.liquid_gravity import (DEFAULT_LIQUID_DENSITY,
                                                 bridge_gravity_forces, relative_correction)

SCENE = Path(__file__).parent / "yade_scenes" / "gravity_capbridge.py"
TRIPLET_SCENE = Path(__file__).parent / "yade_scenes" / "gravity_triplet_capbridge.py"
G = np.array([0.0, 0.0, -9.81])


def _run(*args, timeout=120, scene=SCENE):
    return yr.run_yade_script(scene, [str(a) for a in args], timeout=timeout).result


def _forces(rows):
    return np.array([r["f0"] for r in rows]), np.array([r["f1"] for r in rows])


def _startup_line(res):
    lines = [m for m in res["messages"] if "gravity on the liquid (start-up" in m]
    assert len(lines) == 1, res["messages"]
    return lines[0]


def _weights(res, rows):
    """drho V g of every row [N], from the scene's own volume and gravity."""
    return np.array([res["liquid_density"] * r["volume"] * np.array(r["gravity"])
                     for r in rows])


#: the scene's pair axis (tests/yade_scenes/gravity_capbridge.py)
AXIS = np.array([1.0, 2.0, 2.0]) / 3.0


def _check_weight_rides_on_grains(res, ref, rows=None, ref_rows=None):
    """Sum of the two grains' forces = drho V g; each grain carries half of it (equal
    grains: w = u = 1/2), and what differs between the two gravity parts is along the
    pair axis: the second-order change of the attraction (the doublet table's
    curvature c), small against the weight; the zero-gravity reference has zero net
    force."""
    rows = res["rows"] if rows is None else rows
    assert all(r["n_bridges"] == 1 for r in rows)
    f0, f1 = _forces(rows)
    r0, r1 = _forces(ref["rows"] if ref_rows is None else ref_rows)
    W = _weights(res, rows)
    scale = np.linalg.norm(W, axis=1)[:, None]
    assert np.all(scale > 0)
    np.testing.assert_allclose(f0 + f1, W, rtol=0, atol=1e-9 * scale.max())
    np.testing.assert_array_equal(r0 + r1, 0.0)            # capillary: action = reaction
    d0, d1 = f0 - r0, f1 - r1
    np.testing.assert_allclose(d0 + d1, W, rtol=0, atol=1e-9 * scale.max())
    diff = d0 - d1                                 # 2 x the attraction change on grain 0
    np.testing.assert_allclose(np.cross(diff, AXIS), 0.0, rtol=0, atol=1e-9 * scale.max())
    assert np.all(np.linalg.norm(diff, axis=1) <= 0.05 * scale[:, 0])


@pytest.mark.yade
@pytest.mark.parametrize("tolerance", [0.0, 1e-3])
def test_4mm_beads_carry_the_liquid_weight(tolerance):
    """Bo 2.14: applied; forces on the grains sum to drho V g, half on each."""
    res = _run("--radius", 4e-3, "--mode", "auto", "--tolerance", tolerance, "--steps", 40)
    ref = _run("--radius", 4e-3, "--gravity", "none", "--tolerance", tolerance, "--steps", 40)
    line = _startup_line(res)
    st = res["gravity_state"]
    assert "applied" in line and st["applied"] and st["bridges_corrected"] == 1
    bo = res["liquid_density"] * 9.81 * res["radius"] ** 2 / res["gamma"]
    assert st["bond_largest"] == pytest.approx(bo, rel=1e-12)
    assert f"{bo:.4g}" in line and f"{st['table_error']:.3g}" in line
    assert st["largest_relative_correction"] > st["table_error"]
    assert res["liquid_density"] == DEFAULT_LIQUID_DENSITY
    _check_weight_rides_on_grains(res, ref)
    # the weight is not lost in the round-off of the capillary forces
    r0, _ = _forces(ref["rows"])
    assert np.linalg.norm(_weights(res, res["rows"]), axis=1).min() > \
        1e-3 * np.linalg.norm(r0, axis=1).max()


@pytest.mark.yade
def test_small_beads_skip_the_correction():
    """0.1 mm beads (Bo 1.3e-3): skipped, with the reason; forces are those of the
    scene without gravity, bit for bit."""
    res = _run("--radius", 1e-4, "--mode", "auto", "--steps", 30)
    ref = _run("--radius", 1e-4, "--gravity", "none", "--steps", 30)
    line = _startup_line(res)
    st = res["gravity_state"]
    assert "skipped" in line and "below the table error" in line
    assert not st["applied"] and st["bridges_corrected"] == 0
    assert st["largest_relative_correction"] <= st["table_error"]
    assert f"{st['largest_relative_correction']:.3g}" in line
    assert all(r["n_bridges"] == 1 for r in res["rows"])
    f0, f1 = _forces(res["rows"])
    r0, r1 = _forces(ref["rows"])
    np.testing.assert_array_equal(f0, r0)
    np.testing.assert_array_equal(f1, r1)
    # and the gravity it skipped really was below the table's error
    bo = res["liquid_density"] * 9.81 * res["radius"] ** 2 / res["gamma"]
    assert bo * res["vstar"] / (4 * np.pi) < st["table_error"] * np.linalg.norm(r0[0]) / (
        2 * np.pi * res["gamma"] * res["radius"])


@pytest.mark.yade
def test_on_and_off_override_the_decision():
    """'on' applies the correction to the small beads, 'off' removes it from the
    large ones."""
    on = _run("--radius", 1e-4, "--mode", "on", "--steps", 20)
    ref_small = _run("--radius", 1e-4, "--gravity", "none", "--steps", 20)
    assert "applied to every bridge (gravity_correction='on')" in _startup_line(on)
    _check_weight_rides_on_grains(on, ref_small)
    off = _run("--radius", 4e-3, "--mode", "off", "--steps", 20)
    ref_large = _run("--radius", 4e-3, "--gravity", "none", "--steps", 20)
    line = _startup_line(off)
    assert "off (gravity_correction='off')" in line and "2.144" in line
    assert not off["gravity_state"]["applied"]
    for a, b in zip(_forces(off["rows"]), _forces(ref_large["rows"])):
        np.testing.assert_array_equal(a, b)


@pytest.mark.yade
def test_auto_corrects_each_bridge_on_its_own_size():
    """A 1 mm pair (Bo 0.13) and a 0.1 mm pair (Bo 1.3e-3) in one scene: 'auto' applies
    the correction (the 1 mm bridge is above the table error) to the 1 mm bridge only;
    the 0.1 mm pair keeps its zero-gravity forces bit for bit."""
    res = _run("--radius", 1e-3, "--pair2", 1e-4, "--mode", "auto", "--steps", 30)
    ref = _run("--radius", 1e-3, "--pair2", 1e-4, "--gravity", "none", "--steps", 30)
    st = res["gravity_state"]
    assert "applied to each bridge" in _startup_line(res)
    assert st["applied"] and st["bridges_corrected"] == 1
    assert all(r["n_bridges"] == 2 for r in res["rows"])
    f0, f1 = _forces(res["rows"])
    r0, r1 = _forces(ref["rows"])
    W = res["liquid_density"] * res["vstar"] * res["radius"] ** 3 * G
    np.testing.assert_allclose(f0 + f1, np.broadcast_to(W, f0.shape), rtol=0,
                               atol=1e-9 * np.linalg.norm(W))
    # each grain half of the weight; the two differ along the axis only (curvature)
    diff = (f0 - r0) - (f1 - r1)
    np.testing.assert_allclose(np.cross(diff, AXIS), 0.0, rtol=0,
                               atol=1e-9 * np.linalg.norm(W))
    assert np.abs(diff).max() <= 0.05 * np.linalg.norm(W)
    np.testing.assert_array_equal(np.array([r["f_pair2"] for r in res["rows"]]),
                                  np.array([r["f_pair2"] for r in ref["rows"]]))


@pytest.mark.yade
def test_gravity_changed_mid_run_is_followed():
    """The user sets another (oblique) gravity at iter 15: the forces follow it
    from that step, a line says so, and the NewtonIntegrator keeps the user's value."""
    g2 = (3.0, 0.0, -4.0)
    res = _run("--radius", 4e-3, "--mode", "auto", "--steps", 30, "--change-at", 15,
               "--gravity2", ",".join(map(str, g2)))
    ref = _run("--radius", 4e-3, "--gravity", "none", "--steps", 30)
    assert res["final_gravity"] == list(g2)
    assert [r["gravity"] for r in res["rows"]] == [G.tolist()] * 15 + [list(g2)] * 15
    assert sum("gravity changed at iter 15" in m for m in res["messages"]) == 1
    _check_weight_rides_on_grains(res, ref)
    f0, f1 = _forces(res["rows"])
    assert abs(f0[20, 0] + f1[20, 0]) > 0 and f0[5, 0] + f1[5, 0] == 0


@pytest.mark.yade
@pytest.mark.parametrize("tolerance,refresh", [(0.0, 1), (1e-3, 1), (0.0, 3)])
def test_save_tmp_load_tmp_keeps_forces_bit_identical(tolerance, refresh):
    """O.saveTmp mid-run, steps, O.loadTmp, the same steps: the same forces bit for
    bit (forces added every step, held as permanent forces with a tolerance, or
    refreshed every 3 steps), gravity correction included.

    With refresh_every > 1 the engine restores its held forces at its first update
    after the load (YADE drops permanent forces on load; a property of the engine's
    restart, with or without gravity): the steps before that update are left out."""
    res = _run("--radius", 4e-3, "--mode", "auto", "--steps", 40, "--restart",
               "--tolerance", tolerance, "--refresh", refresh)
    assert res["gravity_state"]["applied"]
    b, a = res["before"], res["after"]
    assert [r["iter"] for r in a] == [r["iter"] for r in b]
    first = next(k for k, r in enumerate(a) if (r["iter"] - 1) % refresh == 0)
    assert first < refresh
    b, a = b[first:], a[first:]
    for x, y in zip(_forces(b), _forces(a)):
        np.testing.assert_array_equal(x, y)
    f0, f1 = _forces(a)
    np.testing.assert_allclose(f0 + f1, _weights(res, a), rtol=0,
                               atol=1e-9 * np.abs(_weights(res, a)).max())
    assert sum("state restored" in m for m in res["messages"]) == 1


@pytest.mark.yade
def test_save_and_load_in_a_new_process_keep_the_gravity_settings(tmp_path):
    """O.save with gravity_correction='on' and liquid_density=1260 on 0.1 mm beads
    (which 'auto' would skip), O.load in a new process that makes no engine: the same
    forces bit for bit, the same settings, no new start-up decision."""
    f = tmp_path / "grav.yade.gz"
    ref = _run("--radius", 1e-4, "--mode", "on", "--rho", 1260, "--steps", 30, "--save", f)
    new = _run("--radius", 1e-4, "--steps", 30, "--load", f)
    assert new["mode"] == "on" and new["liquid_density"] == 1260.0
    assert new["gravity_state"]["applied"]
    assert not any("gravity on the liquid" in m for m in new["messages"])
    assert [r["iter"] for r in new["rows"]] == [r["iter"] for r in ref["rows"]]
    for x, y in zip(_forces(ref["rows"]), _forces(new["rows"])):
        np.testing.assert_array_equal(x, y)
    f0, f1 = _forces(new["rows"])
    W = _weights(new, new["rows"])
    np.testing.assert_allclose(f0 + f1, W, rtol=0, atol=1e-9 * np.abs(W).max())


# ------------------------------------------------------------ without YADE


def test_unequal_grains_sum_to_the_weight_and_share_by_the_smaller_grain():
    """bridge_gravity_forces: the two parts sum to drho V g for any order of the
    grains; the smaller grain's part does not depend on which one is i."""
    rng = np.random.default_rng(3)
    m = 50
    d = rng.normal(size=(m, 3))
    dist = np.linalg.norm(d, axis=1) * 1e-3
    d *= 1e-3
    r_i = rng.uniform(0.5e-3, 2e-3, m)
    r_j = rng.uniform(0.5e-3, 2e-3, m)
    rs = np.minimum(r_i, r_j)
    vstar = rng.uniform(1e-3, 0.3, m)
    gamma, drho, g = 0.073, 997.0, np.array([1.0, -2.0, -9.0])
    fs = 2 * np.pi * gamma * rs
    fi, fj = bridge_gravity_forces(d, dist, r_i, r_j, vstar, fs, g, drho, gamma)
    weight = drho * (vstar * rs**3)[:, None] * g
    np.testing.assert_allclose(fi + fj, weight, rtol=1e-12, atol=0)
    gi, gj = bridge_gravity_forces(-d, dist, r_j, r_i, vstar, fs, g, drho, gamma)
    np.testing.assert_allclose(gi, fj, rtol=1e-12, atol=1e-30)
    np.testing.assert_allclose(gj, fi, rtol=1e-12, atol=1e-30)
    # the relative size grows like Bo V* / F*
    assert relative_correction(2.0, 0.1, 0.5) == \
        pytest.approx(2 * relative_correction(1.0, 0.1, 0.5))


def test_bad_liquid_density_and_mode_are_one_line_errors():
    from capbridge.yade.engine import CapbridgeEngine
    from capbridge.validation import CapbridgeInputError

    # the default: water, 1000 kg/m^3 for water_content (as before), 997 for the weight
    eng = CapbridgeEngine(water_content=0.01, label="rho_default")
    assert (eng.liquid_density, eng.gravity.drho) == (1000.0, DEFAULT_LIQUID_DENSITY)
    eng = CapbridgeEngine(water_content=0.01, liquid_density=1260.0, label="rho_given")
    assert (eng.liquid_density, eng.gravity.drho) == (1260.0, 1260.0)

    with pytest.raises(CapbridgeInputError) as exc:
        CapbridgeEngine(bridge_volume_star=0.05, liquid_density=-3.0, label="bad_rho")
    msg = str(exc.value)
    assert "liquid_density=-3.0" in msg and "(0, inf)" in msg and "\n" not in msg
    with pytest.raises(CapbridgeInputError) as exc:
        CapbridgeEngine(bridge_volume_star=0.05, gravity_correction="maybe", label="bad_mode")
    msg = str(exc.value)
    assert "gravity_correction" in msg and "'auto'" in msg and "\n" not in msg


# ------------------------------------------- liquid clusters with a gravity response


def _synthetic_triplet_table():
    """The shipped triplet table with the synthetic gravity response of
    ``tests/test_gravity_surrogate.py`` (the shipped table has none yet)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "_gravity_surrogate_tables", Path(__file__).parent / "test_gravity_surrogate.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.synthetic_triplet_table()


def _synthetic_triplet_surrogate():
    """That table fitted as the engine fits a triplet table (dense coalescence volumes
    beside it)."""
    from capbridge.cli import DEFAULT_COALESCENCE_TABLE
    from capbridge.surrogate.triplet import TripletSurrogate

    return TripletSurrogate().fit(_synthetic_triplet_table(),
                                  coalescence_table=DEFAULT_COALESCENCE_TABLE)


def _merged_triplet(sur, R):
    """A merged triplet inside the synthetic table: liquid volume [m^3] (1.6 V_coal of
    two bridges on grain 2) and centres [m] of three grains of radius R."""
    from capbridge.dem.triplet_clusters import triangle_centres
    from capbridge.solvers.triplet import find_coalescence as exact_coalescence
    from capbridge.solvers.triplet import triplet_geometry

    lo, hi = sur.gaps_[0], sur.gaps_[-1]
    gaps = (lo + 0.25 * (hi - lo), lo + 0.5 * (hi - lo), lo + 0.5 * (hi - lo))
    Vc = exact_coalescence(triplet_geometry(*gaps), 0.0, bridges=((0, 2), (1, 2))).V_coal
    return 1.6 * Vc * R**3, triangle_centres(2 + gaps[0], 2 + gaps[1], 2 + gaps[2]) * R


@pytest.mark.slow
def test_cluster_gravity_is_the_tables_response_in_the_scene_frame():
    """A merged triplet (three 1 mm grains, two bridges on grain 2) with gravity: the
    grains get the zero-gravity forces plus the surrogate's gravity response
    (predict_vectors with bond and direction); the same scene rotated by a random
    rotation gives the rotated forces (the frame mapping), and the response sums to
    the liquid's weight within the synthetic table's residual."""
    from capbridge.dem.bridges import BridgeModel, LiquidRule, default_table_path
    from capbridge.dem.coalescence_detect import find_coalescence
    from capbridge.dem.triplet_clusters import LiquidClusters
    from capbridge.dimensionless import force_scale

    sur = _synthetic_triplet_surrogate()
    assert sur.has_gravity_
    R, gamma, drho = 1e-3, 0.073, 997.0
    V, base = _merged_triplet(sur, R)
    q, _ = np.linalg.qr(np.random.default_rng(5).normal(size=(3, 3)))
    g_scene = np.array([2.0, -3.0, -9.0])

    def run(Q):
        pos = base @ Q.T + np.array([0.01, -0.02, 0.005])
        m = BridgeModel([R] * 3, 0.0, default_table_path(), gamma,
                        LiquidRule(bridge_volume=V / 2))
        m.initialise(pos, pairs=[(0, 2), (1, 2)])
        geom = m.update(pos, form=False)
        rep = find_coalescence(pos, m.bi, m.bj, *m.filling_angles(geom["gap"]), m.vol, m.n)
        assert rep.n_triplets == 1
        cl = LiquidClusters(gamma, surrogate=sur)
        cl.gravity = (Q @ g_scene, drho)
        out = cl.step(m, pos, geom, rep)
        assert cl.n == 1 and cl.gravity_fallback == 0
        return out["forces"], m, cl

    F_id, m, cl = run(np.eye(3))
    # the lookup geometry is the scene's here (same frame): predict_vectors directly
    bond = drho * np.linalg.norm(g_scene) * R**2 / gamma
    ref = sur.predict_vectors(base / R, cl.volume[0] / R**3, 0.0, bond=bond,
                              gravity=g_scene)
    assert ref["status"] in (Status.CONVERGED, Status.ABOVE_TOLERANCE, Status.APPROXIMATE)
    fs = force_scale(R, gamma)
    scale = np.abs(ref["forces"]).max() * fs
    np.testing.assert_allclose(F_id, ref["forces"] * fs, rtol=0, atol=1e-12 * scale)
    part = (ref["gravity_first_order"] + ref["gravity_second_order"]) * fs
    assert np.abs(part).max() > 1e-6 * scale                 # gravity did something
    weight = drho * cl.volume[0] * g_scene
    resid = float(ref["gravity_sum_residual"])
    assert np.linalg.norm(F_id.sum(0) - weight) <= (resid + 0.05) * np.linalg.norm(weight)
    # rotated scene, rotated gravity: rotated forces
    F_q, _, _ = run(q)
    np.testing.assert_allclose(F_q, F_id @ q.T, rtol=0, atol=1e-9 * scale)


@pytest.mark.yade
def test_yade_triplet_cluster_carries_its_weight(tmp_path):
    """In YADE, a coalesced triplet (three fixed 1 mm grains in a tilted frame,
    triplet_forces on) with a triplet table that has a gravity response (the synthetic
    one): the start-up line says clusters get it, and the forces YADE holds differ from
    the gravity-free run ('off') by the surrogate's response rotated into the scene;
    together they carry the liquid's weight within the table's sum residual."""
    from capbridge.dem.triplet_clusters import triangle_centres
    from capbridge.dimensionless import force_scale
    from capbridge.solvers.triplet import find_coalescence as exact_coalescence
    from capbridge.solvers.triplet import triplet_geometry

    from capbridge.dem.triplet_clusters import load_surrogate

    from capbridge.tables.netcdf_io import write_table

    table = tmp_path / "triplet_gravity_synthetic.nc"
    # written as capbridge writes tables (with the checksum a table file needs)
    write_table(_synthetic_triplet_table(), table, command="test synthetic gravity",
                solver_settings={})
    sur = load_surrogate(table)                      # as the engine reads it
    R, gamma = 1e-3, 0.073
    lo, hi = sur.gaps_[0], sur.gaps_[-1]
    gaps = (lo + 0.25 * (hi - lo), lo + 0.5 * (hi - lo), lo + 0.5 * (hi - lo))
    Vc = exact_coalescence(triplet_geometry(*gaps), 0.0, bridges=((0, 2), (1, 2))).V_coal
    V = 1.6 * Vc * R**3
    g = np.array([2.0, -3.0, -9.0])
    args = ("--table", table, "--gaps", ",".join(map(str, gaps)), "--volume", V,
            "--gravity", ",".join(map(str, g)))
    on = _run(*args, "--mode", "on", scene=TRIPLET_SCENE)
    off = _run(*args, "--mode", "off", scene=TRIPLET_SCENE)
    line = _startup_line(on)
    assert "get the triplet table's gravity response" in line
    last = on["rows"][-1]["triplets"]
    assert last["clusters"] == 1 and last["gravity_fallback"] == 0
    assert off["rows"][-1]["triplets"]["clusters"] == 1
    F_on, F_off = np.array(on["rows"][-1]["f"]), np.array(off["rows"][-1]["f"])
    # the expected response: lookup frame = the scene's triangle before its rotation q;
    # rotate g in, the response out
    local = triangle_centres(2 + gaps[0], 2 + gaps[1], 2 + gaps[2]) * R
    q = np.array(on["rotation"])                     # scene = q local + shift
    C = np.array(on["centres"])
    np.testing.assert_allclose(C - C[0], (local - local[0]) @ q.T, rtol=0, atol=1e-15)
    bond = on["drho"] * np.linalg.norm(g) * R**2 / gamma
    ref = sur.predict_vectors(local / R, on["bridge_volume_total"] / R**3, 0.0, bond=bond,
                              gravity=q.T @ g)
    part = (ref["gravity_first_order"] + ref["gravity_second_order"]) * force_scale(R, gamma)
    scale = np.abs(F_off).max()
    np.testing.assert_allclose(F_on - F_off, part @ q.T, rtol=0, atol=1e-9 * scale)
    weight = on["drho"] * on["bridge_volume_total"] * g
    assert np.linalg.norm(F_off.sum(0)) <= 1e-12 * scale
    assert np.linalg.norm(F_on.sum(0) - weight) <= \
        (float(ref["gravity_sum_residual"]) + 0.05) * np.linalg.norm(weight)


def test_doublet_response_from_a_table_that_has_it():
    """With a doublet table carrying a gravity response (the synthetic one of
    tests/test_gravity_surrogate.py: w = 0.5 / ratio^0.3, c = -0.02 V*), the gravity
    parts on an unequal pair (1.5 mm and 1 mm, the larger one first) are the
    surrogate's own F1, F2 with gravity minus the zero-gravity attraction (predict_vectors
    in the pair's frame), and without the response they are the w = 1/2, c = 0 ones."""
    import importlib.util

    from capbridge.dem.bridges import BridgeModel, LiquidRule
    from capbridge.dem.liquid_gravity import LiquidGravity
    from capbridge.dimensionless import force_scale
    from capbridge.surrogate.doublet import DoubletSurrogate

    spec = importlib.util.spec_from_file_location(
        "_gravity_surrogate_tables", Path(__file__).parent / "test_gravity_surrogate.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    sur = DoubletSurrogate().fit(mod.synthetic_doublet_table())
    assert sur.has_gravity()
    gamma, drho, r, Rl, vstar, theta = 0.073, 997.0, 1e-3, 1.5e-3, 0.05, 20.0
    g = np.array([3.0, 1.0, -9.0])
    gap = 0.1 * r
    pos = np.array([[0.0, 0.0, 0.0], [Rl + r + gap, 0.0, 0.0]])    # grain 0 the larger

    def parts(table):
        m = BridgeModel([Rl, r], theta, table, gamma,
                        LiquidRule(bridge_volume_star=vstar), with_beta=False)
        m.initialise(pos, pairs=[(0, 1)])
        geom = m.update(pos, form=False)
        lg = LiquidGravity("on", drho, gamma)
        lg.decide(m, g)
        f, _ = lg.grain_forces(m, geom)
        return f, geom, lg

    f, geom, lg = parts(sur)
    assert lg.doublet_response
    bond = drho * np.linalg.norm(g) * r**2 / gamma
    # the pair's frame: n from the smaller grain (1) to the larger (0) is -x
    n = np.array([-1.0, 0.0, 0.0])
    frame = np.array([n, [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])       # rows: new axes
    ref = sur.predict_vectors(geom["gap"][0] / r, vstar, theta, Rl / r, bond=bond,
                              gravity=frame @ g)
    fs = force_scale(r, gamma)
    F0 = float(ref["force"])
    want_small = (ref["F1"] - F0 * np.array([1.0, 0, 0])) @ frame * fs
    want_large = (ref["F2"] + F0 * np.array([1.0, 0, 0])) @ frame * fs
    weight = drho * vstar * r**3 * g
    np.testing.assert_allclose(f[1], want_small, rtol=0, atol=1e-9 * np.linalg.norm(weight))
    np.testing.assert_allclose(f[0], want_large, rtol=0, atol=1e-9 * np.linalg.norm(weight))
    assert abs(float(ref["share"]) - 0.5) > 0.05 and float(ref["curvature"]) != 0
    # the table's share moves the weight between the grains, the sum stays the weight
    # (the curvature term is equal and opposite)
    np.testing.assert_allclose(f.sum(0), weight, rtol=1e-12)
    f_half, _, lg0 = parts(mod.synthetic_doublet_table().drop_vars(
        ["weight_share_axial", "force_gravity_curvature_axial"]))
    assert not lg0.doublet_response
    assert np.abs(f_half - f).max() > 1e-3 * np.linalg.norm(weight)


@pytest.mark.slow
def test_cluster_above_the_bond_range_keeps_its_weight_shared_equally():
    """A cluster at Bo > BOND_MAX (g x 40 on 1 mm grains): no response there, so the
    liquid's weight drho V g is shared equally by the three grains, counted as a
    fallback (it was dropped)."""
    from capbridge.dem.bridges import BridgeModel, LiquidRule, default_table_path
    from capbridge.dem.coalescence_detect import find_coalescence
    from capbridge.dem.triplet_clusters import LiquidClusters
    from capbridge.surrogate.doublet import BOND_MAX

    sur = _synthetic_triplet_surrogate()
    R, gamma, drho = 1e-3, 0.073, 997.0
    V, pos = _merged_triplet(sur, R)
    g = 40 * np.array([2.0, -3.0, -9.0])
    assert drho * np.linalg.norm(g) * R**2 / gamma > BOND_MAX

    def run(gravity):
        m = BridgeModel([R] * 3, 0.0, default_table_path(), gamma,
                        LiquidRule(bridge_volume=V / 2))
        m.initialise(pos, pairs=[(0, 2), (1, 2)])
        geom = m.update(pos, form=False)
        rep = find_coalescence(pos, m.bi, m.bj, *m.filling_angles(geom["gap"]), m.vol, m.n)
        cl = LiquidClusters(gamma, surrogate=sur)
        cl.gravity = gravity
        return cl.step(m, pos, geom, rep)["forces"], cl

    F0, _ = run(None)
    F, cl = run((g, drho))
    assert cl.gravity_fallback == 1
    weight = drho * cl.volume[0] * g
    np.testing.assert_allclose(F - F0, np.broadcast_to(weight / 3, F.shape), rtol=1e-9,
                               atol=1e-12 * np.linalg.norm(weight))
