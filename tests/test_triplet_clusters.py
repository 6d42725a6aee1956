"""LiquidClusters (coalesced triplets in the DEM engine), plain numpy, no YADE.

Three equal grains (r = 1 mm) with two bridges on the shared grain 2, at a volume a
little above the exact coalescence volume (the detector merges them), then moved out of
the table or given a table that prefers the separated state.  Checks: the cluster holds
exactly the bridges' liquid, the grains get the surrogate's forces (and the bridges
none), a split shares the liquid at equal Laplace pressure (exact doublets, independent
check) with the budget exact to 1e-12, >= 4-grain clusters keep their doublet forces
and are counted, the table is read only at the first merge candidate.

The triplet table is ``$CAPBRIDGE_TRIPLET_TABLE`` (default the shipped
``data/triplet_table.nc``; the ``triplet_table`` fixture of conftest.py).
"""
from __future__ import annotations

import numpy as np
import pytest

from capbridge.dem.bridges import BridgeModel, LiquidRule, default_table_path
from capbridge.dem.coalescence_detect import find_coalescence
from capbridge.dem.triplet_clusters import (LiquidClusters, load_surrogate,
                                                    triangle_centres)
from capbridge.dimensionless import force_scale
from capbridge.status import Status
from capbridge.surrogate.triplet import TripletSurrogate
from capbridge.validation import CapbridgeInputError

R = 1e-3
GAMMA = 0.073


@pytest.fixture(scope="module")
def sur(triplet_table):
    """The surrogate as the engine fits it (with the dense V_coal table beside it)."""
    return load_surrogate(triplet_table)


@pytest.fixture(scope="module")
def doublets():
    """The scene table for equal grains at the test's angle, built once."""
    m = BridgeModel([R] * 3, 0.0, default_table_path(), GAMMA, LiquidRule(bridge_volume=1e-10))
    return m.table


def _geometry(sur, theta=0.0, v=1.6):
    """Gaps inside the table (a quarter and a half of its gap range, the shared grain
    2 at the wider two) and the total volume v V*_coal."""
    from capbridge.solvers.triplet import find_coalescence, triplet_geometry

    lo, hi = sur.gaps_[0], sur.gaps_[-1]
    g01, g = lo + 0.25 * (hi - lo), lo + 0.5 * (hi - lo)
    # the exact coalescence volume of the two bridges the tests make (on grain 3)
    Vc = find_coalescence(triplet_geometry(g01, g, g), theta, bridges=((0, 2), (1, 2))).V_coal
    return (g01, g, g), v * Vc * R**3


def _model(centres, pairs, volumes, theta, doublets, conserve=False):
    """A BridgeModel with the given bridges (fixed volumes, or conserved liquid with
    nothing on the films)."""
    n = centres.shape[0]
    if conserve:
        rule = LiquidRule(total_liquid=float(np.sum(volumes)), conserve=True)
    else:
        rule = LiquidRule(bridge_volume=float(volumes[0]))
    m = BridgeModel([R] * n, theta, doublets if n == 3 else default_table_path(), GAMMA, rule)
    m.initialise(centres, pairs=pairs)
    if conserve:
        # the initial bridges take the films' liquid by the film rule: put it back
        # and give every bridge its volume, films empty (the ledger: total liquid)
        m.films[:] = 0.0
        from capbridge.dem.triplet_clusters import set_bridge_volumes
        set_bridge_volumes(m, np.arange(m.n_bridges), np.asarray(volumes, float))
    return m


def _check(m, pos):
    geom = m.update(pos, form=False)
    rep = find_coalescence(pos, m.bi, m.bj, *m.filling_angles(geom["gap"]), m.vol, m.n)
    return geom, rep


def _merged(sur, doublets, theta=0.0, conserve=False, v=1.6, split="table"):
    g, V = _geometry(sur, theta, v)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    m = _model(pos, [(0, 2), (1, 2)], [V / 2, V / 2], theta, doublets, conserve)
    cl = LiquidClusters(GAMMA, surrogate=sur, split_solver=split)
    geom, rep = _check(m, pos)
    assert rep.n_triplets == 1
    out = cl.step(m, pos, geom, rep)
    return m, cl, pos, V, geom, out


def test_merge_volume_and_forces_are_the_surrogates(sur, doublets):
    """Merge: one cluster of exactly the two bridges' volume; the grains get the
    surrogate's force vectors at the three centres (F* 2 pi gamma r) within 1e-12,
    summing to zero; the bridges' doublet forces are replaced (0); the ledger does not
    move."""
    m, cl, pos, V, geom, out = _merged(sur, doublets)
    assert cl.events["merged"] == 1 and cl.n == 1
    assert cl.volume[0] == float(m.vol.sum())              # the bridges' liquid, exactly
    assert cl.volume[0] == pytest.approx(V, rel=1e-15)
    np.testing.assert_array_equal(geom["force"], 0.0)
    ref = sur.predict_vectors(pos / R, V / R**3, 0.0)
    assert ref["status"] in (Status.CONVERGED, Status.ABOVE_TOLERANCE)
    F = ref["forces"] * force_scale(R, GAMMA)
    np.testing.assert_allclose(out["forces"], F, rtol=1e-12, atol=1e-15 * np.abs(F).max())
    np.testing.assert_allclose(out["forces"].sum(0), 0.0, atol=1e-12 * np.abs(F).max())
    assert m.budget()["balance_error"] < 1e-15
    assert cl.report()["statuses"][0] in ("converged", "above_tolerance")
    # the doublet forces it replaces are not the same (the test means something)
    dbl = _model(pos, [(0, 2), (1, 2)], [V / 2, V / 2], 0.0, doublets)
    f_dbl = dbl.grain_forces(dbl.update(pos, form=False))[0]
    assert np.abs(f_dbl - F).max() > 1e-3 * np.abs(F).max()


@pytest.mark.slow
@pytest.mark.parametrize("conserve,split", [(False, "exact"), (True, "exact"),
                                            (False, "table")])
def test_split_out_of_table_equal_pressure_budget_exact(sur, doublets, conserve, split):
    """Grain 1 pulled out of the table's gap range: the cluster splits (geometry), the
    two bridges share its liquid at equal Laplace pressure (exact doublets at their own
    gaps and volumes, an independent solve: equal to 1e-7 with the exact split, to the
    doublet table's pressure error, 1e-3, with the table split, whose volumes are also
    those of the exact split within 1e-3), their volumes add up to the cluster's to
    1e-12, the ledger balances to 1e-12, the doublet forces are back."""
    from capbridge.tables.coalescence import separated_state
    from capbridge.solvers.young_laplace import solve_doublet

    m, cl, pos, V, _, _ = _merged(sur, doublets, conserve=conserve, split=split)
    pos = pos.copy()
    u = (pos[1] - pos[2]) / np.linalg.norm(pos[1] - pos[2])
    g12 = np.linalg.norm(pos[1] - pos[2]) / R - 2
    pos[1] += u * (1.2 * sur.gaps_[-1] - g12) * R       # gap 1-2: 1.2 x the table's largest
    geom = m.update(pos)
    out = cl.step(m, pos, geom, None)
    assert cl.events["split_geometry"] == 1 and cl.n == 0
    assert cl.events["split_share_fallback"] == 0
    assert m.n_bridges == 2
    assert m.vol.sum() == pytest.approx(V, rel=1e-12)
    assert abs(m.vol[0] - m.vol[1]) > 1e-3 * V       # unequal gaps: unequal shares
    b = m.budget()
    assert b["balance_error"] < 1e-12
    gaps = out["geom"]["gap"]
    P = solve_doublet(gaps / R, m.vol / R**3, 0.0)["pressure"]
    assert P[0] == pytest.approx(P[1], rel=1e-7 if split == "exact" else 1e-3)
    if split == "table":
        pairs = list(zip(m.bi.tolist(), m.bj.tolist()))
        g = np.linalg.norm(pos[[1, 0, 1]] - pos[[0, 2, 2]], axis=1) / R - 2
        ex = separated_state(*g, V / R**3, 0.0, ((0, 2), (1, 2)))["volumes"]
        np.testing.assert_allclose([m.vol[pairs.index(p)] / R**3 for p in ((0, 2), (1, 2))],
                                   [ex[(0, 2)], ex[(1, 2)]], rtol=1e-3)
    np.testing.assert_array_equal(out["forces"], 0.0)
    assert np.all(out["geom"]["force"] > 0)


@pytest.mark.slow
def test_split_share_fallback_keeps_merge_volumes(sur, doublets):
    """split_solver='merge_volumes': the bridges keep exactly their merge-time volumes
    (counted as a share fallback)."""
    g, V = _geometry(sur)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    m = _model(pos, [(0, 2), (1, 2)], [V / 2, V / 2], 0.0, doublets)
    cl = LiquidClusters(GAMMA, surrogate=sur, split_solver="merge_volumes")
    cl.step(m, pos, *_check(m, pos))
    before = m.vol.copy()
    pos[1, 0] += 0.5 * R
    cl.step(m, pos, m.update(pos), None)
    assert cl.events["split_geometry"] == 1
    assert cl.events["split_share_fallback"] == 1
    np.testing.assert_array_equal(m.vol, before)


@pytest.mark.slow
def test_split_when_the_separated_state_is_lower(sur, doublets, triplet_table):
    """The energy rule: with a table whose separated state is lower everywhere
    (E_sep = E_coal - 0.5, a constructed field: this tests the rule, not the physics)
    a merged cluster splits (split_energy) and a new one is refused (merge_refused)."""
    from capbridge.tables.netcdf_io import read_table

    ds = read_table(triplet_table)
    # an edited copy (no checksum), without a separated energy of its own
    ds = ds.drop_vars("energy_separated", errors="ignore")
    for key in ("data_sha256", "table_sha256"):
        ds.attrs.pop(key, None)
    e_sep = ds["energy_extrapolated"] - 0.5
    e_sep.name = "energy_separated"
    lower = TripletSurrogate(out_of_range="clip").fit(ds, separated_energy=e_sep)
    m, cl, pos, V, _, _ = _merged(sur, doublets)
    cl._sur = lower
    cl.step(m, pos, m.update(pos), None)
    assert cl.events["split_energy"] == 1 and cl.n == 0
    assert m.vol.sum() == pytest.approx(V, rel=1e-12)
    cl.step(m, pos, *_check(m, pos))
    assert cl.n == 0 and cl.events["merge_refused"] == 1 and cl.events["merged"] == 1


def test_funicular_cluster_keeps_doublets_and_no_table_is_read(doublets):
    """Four grains around a shared one with three bridges whose caps meet: one cluster
    of 4 grains -> counted once (not again at the next check), reported, doublet forces
    kept, no triplet table read (a missing table would raise)."""
    # grain 0 at the centre, three neighbours at 0, 70 and 140 deg, gaps 0.1 r
    ang = np.radians([0.0, 70.0, 140.0])
    pos = np.vstack([[0.0, 0.0, 0.0],
                     np.column_stack([np.cos(ang), np.sin(ang), 0 * ang]) * 2.1]) * R
    m = BridgeModel([R] * 4, 0.0, default_table_path(), GAMMA, LiquidRule(bridge_volume=0.2 * R**3))
    m.initialise(pos, pairs=[(0, 1), (0, 2), (0, 3)])
    cl = LiquidClusters(GAMMA, table="/nonexistent/triplet.nc")
    for k in range(2):
        geom, rep = _check(m, pos)
        assert rep.n_clusters == 1 and rep.clusters[0].size == 3
        f0 = geom["force"].copy()
        out = cl.step(m, pos, geom, rep)
        np.testing.assert_array_equal(out["geom"]["force"], f0)
        np.testing.assert_array_equal(out["forces"], 0.0)
    r = cl.report()
    assert r["events"]["funicular_fallback"] == 1
    assert r["funicular"]["clusters"] == 1 and r["funicular"]["grains"] == 4
    assert r["funicular"]["volume"] == pytest.approx(0.6 * R**3, rel=1e-12)
    assert not cl.loaded and cl.n == 0


def test_lazy_load_only_at_a_merge_candidate(doublets):
    """No coalescence: nothing is read (the table path does not even exist); the first
    merge candidate reads it (here: a clear error naming the missing file)."""
    g = (0.1, 0.1, 0.1)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    m = _model(pos, [(0, 2), (1, 2)], [0.01 * R**3] * 2, 0.0, doublets)   # caps apart
    cl = LiquidClusters(GAMMA, table="/nonexistent/triplet.nc")
    geom, rep = _check(m, pos)
    assert rep.n_triplets == 0
    out = cl.step(m, pos, geom, rep)
    assert not cl.loaded and cl.loads == 0 and out["geom"] is geom
    m2 = _model(pos, [(0, 2), (1, 2)], [0.2 * R**3] * 2, 0.0, doublets)   # caps meet
    geom, rep = _check(m2, pos)
    assert rep.n_triplets == 1
    with pytest.raises(CapbridgeInputError, match="nonexistent"):
        cl.step(m2, pos, geom, rep)


@pytest.mark.slow
def test_lazy_load_reads_the_table_once(doublets, triplet_table):
    cl = LiquidClusters(GAMMA, table=triplet_table)
    sur = load_surrogate(triplet_table)
    g, V = _geometry(sur)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    m = _model(pos, [(0, 2), (1, 2)], [V / 2, V / 2], 0.0, doublets)
    assert not cl.loaded
    for _ in range(3):
        cl.step(m, pos, *_check(m, pos))
    assert cl.loads == 1 and cl.n == 1 and cl.events["merged"] == 1


@pytest.mark.slow
def test_closed_triangle_is_one_cluster_and_state_round_trip(sur, doublets):
    """A ring of three bridges (the two on grain 2 at 0.55 V*_coal each, the one
    between grains 0 and 1 at 0.1 V*_coal): one cluster holding all three, volume
    exact; its state saved and restored gives the same forces."""
    g, V = _geometry(sur, v=1.7)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    vols = np.array([0.1, 0.55, 0.55]) * V / 1.2
    m = _model(pos, [(0, 1), (0, 2), (1, 2)], vols, 0.0, doublets, conserve=True)
    cl = LiquidClusters(GAMMA, surrogate=sur)
    geom, rep = _check(m, pos)
    assert rep.n_triplets >= 1
    out = cl.step(m, pos, geom, rep)
    assert cl.n == 1 and (cl.members[0] >= 0).all()
    assert cl.volume[0] == float(m.vol.sum())
    cl2 = LiquidClusters(GAMMA, surrogate=sur)
    cl2.set_state(cl.get_state())
    assert cl2.stats == cl.stats and cl.stats["triplets_seen"] >= 1   # counters restart too
    out2 = cl2.step(m, pos, m.update(pos), None)
    np.testing.assert_array_equal(out2["forces"], out["forces"])
    assert cl2.events == cl.events
    # a state saved before the counters existed starts them afresh
    old = {k: v for k, v in cl.get_state().items() if k != "stats"}
    cl3 = LiquidClusters(GAMMA, surrogate=sur)
    cl3.set_state(old)
    assert cl3.stats["cluster_steps"] == 0 and cl3.n == 1


def test_unequal_radii_are_approximate_and_counted(sur):
    """Radii 1 and 1.1 mm: merged with the surrogate's unequal-radii approximation
    (status approximate), counted; forces those of predict_vectors(radii=...)."""
    radii = np.array([1.0, 1.1, 1.0]) * R
    g, V = _geometry(sur, v=1.8)
    L = [radii[a] + radii[b] + gg * R for (a, b), gg in zip(((0, 1), (0, 2), (1, 2)), g)]
    pos = triangle_centres(*L)
    m = BridgeModel(radii, 0.0, default_table_path(), GAMMA, LiquidRule(bridge_volume=V / 2))
    m.initialise(pos, pairs=[(0, 2), (1, 2)])
    cl = LiquidClusters(GAMMA, surrogate=sur)
    geom, rep = _check(m, pos)
    assert rep.n_triplets == 1
    out = cl.step(m, pos, geom, rep)
    assert cl.events["approximate"] == 1 and cl.report()["statuses"] == ["approximate"]
    ref = sur.predict_vectors(pos / R, V / R**3, 0.0, radii=radii / R)
    assert ref["status"] == Status.APPROXIMATE
    np.testing.assert_allclose(out["forces"], ref["forces"] * force_scale(R, GAMMA),
                               rtol=1e-12, atol=1e-15)


def _rotate(v, axis, angle):
    """v turned about the unit vector ``axis`` by ``angle`` [rad] (Rodrigues)."""
    k = axis / np.linalg.norm(axis)
    return v * np.cos(angle) + np.cross(k, v) * np.sin(angle) + k * (k @ v) * (1 - np.cos(angle))


@pytest.mark.slow
def test_merged_triplet_joining_a_funicular_cluster_is_released(sur, doublets):
    """A merged triplet (grains 0, 1, 2) and a fourth grain bridged to grain 2, first
    with its cap apart, then turned about grain 2 (same gap) until its cap meets the
    cluster's: the cluster now touches four grains -> released to its bridges (volumes
    unchanged), counted as funicular; the doublet forces are back."""
    g, V = _geometry(sur)
    pos3 = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    p2 = pos3[2]
    away = p2 - 0.5 * (pos3[0] + pos3[1])                  # opposite to grains 0 and 1
    start = p2 + away / np.linalg.norm(away) * (2 + g[1]) * R
    pos = np.vstack([pos3, start])
    m = BridgeModel([R] * 4, 0.0, default_table_path(), GAMMA, LiquidRule(bridge_volume=V / 2))
    m.initialise(pos, pairs=[(0, 2), (1, 2), (2, 3)])
    cl = LiquidClusters(GAMMA, surrogate=sur)
    geom, rep = _check(m, pos)
    assert rep.n_clusters == 1 and rep.clusters[0].size == 2
    cl.step(m, pos, geom, rep)
    assert cl.n == 1 and cl.events["merged"] == 1
    vol = m.vol.copy()
    # grain 3 where grain 0 would be after a quarter turn about the axis 2 -> 1
    pos[3] = p2 + _rotate(pos3[0] - p2, pos3[1] - p2, np.pi / 2)
    geom, rep = _check(m, pos)
    assert rep.n_clusters == 1 and rep.clusters[0].size == 3
    f0 = geom["force"].copy()
    out = cl.step(m, pos, geom, rep)
    assert cl.n == 0 and cl.events["funicular_fallback"] == 1
    np.testing.assert_array_equal(m.vol, vol)
    np.testing.assert_array_equal(out["geom"]["force"], f0)
    np.testing.assert_array_equal(out["forces"], 0.0)


def test_engine_options_of_triplet_forces():
    """CapbridgeEngine: triplet_forces=True without its table is one clear error; by
    default a missing table means report only; a bad triplet_split is refused."""
    from capbridge.yade.engine import CapbridgeEngine

    with pytest.raises(CapbridgeInputError, match="nonexistent.nc does not exist"):
        CapbridgeEngine(bridge_volume=1e-10, triplet_forces=True,
                        triplet_table="/nonexistent.nc", label="h7_missing")
    with pytest.raises(CapbridgeInputError, match="needs coalescence=True"):
        CapbridgeEngine(bridge_volume=1e-10, triplet_forces=True, coalescence=False,
                        triplet_table=default_table_path(), label="h7_nocoal")
    with pytest.raises(CapbridgeInputError, match="triplet_split"):
        CapbridgeEngine(bridge_volume=1e-10, triplet_split="fast", label="h7_split")
    eng = CapbridgeEngine(bridge_volume=1e-10, triplet_table="/nonexistent.nc",
                          label="h7_default")
    assert eng.triplet_forces is False and eng.triplet_report() == {
        "enabled": False, "table_loaded": False, "clusters": 0}


def test_the_engine_reads_the_packings_table_by_default(packings_triplet_table):
    """Without ``triplet_table`` the engine takes the second table, whose domain holds the
    coalesced triplets of real packings (issue 18), not the first one the CLI reads."""
    from capbridge.yade.engine import CapbridgeEngine

    eng = CapbridgeEngine(bridge_volume=1e-10, triplet_forces=True, label="h18_default")
    assert eng.triplet_table == packings_triplet_table


def test_engine_refuses_a_damaged_triplet_table_at_construction(tmp_path):
    """A damaged triplet table is one clear error when the engine is made, not a
    TableError traceback from the PyRunner at the first coalesced triplet."""
    from capbridge.yade.engine import CapbridgeEngine

    bad = tmp_path / "triplet_table.nc"
    bad.write_text("not a table")
    with pytest.raises(CapbridgeInputError, match="triplet_forces=True but"):
        CapbridgeEngine(bridge_volume=1e-10, triplet_forces=True,
                        triplet_table=bad, label="h7_damaged")


def test_a_bridge_formed_inside_a_live_cluster_joins_it(sur, doublets):
    """A gap of a merged open triangle closes and the model forms the third bridge:
    its liquid joins the cluster (event ``absorbed``), its doublet force is replaced by
    the cluster's like the others' (issue 18: seen once in a packing, 0.57 2 pi gamma r
    counted on top of the cluster's forces for a whole run), the cluster's volume is
    the three bridges' and the grains get the surrogate's forces at that volume."""
    g, V = _geometry(sur, 0.0, 1.6)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    # a new bridge gets 5 % of the merged liquid (the two first ones get V / 2 each),
    # so that the grown cluster stays inside the table's v range
    m = _model(pos, [(0, 2), (1, 2)], [0.05 * V], 0.0, doublets)
    m.set_volumes(np.arange(2), np.full(2, V / 2))
    cl = LiquidClusters(GAMMA, surrogate=sur)
    geom, rep = _check(m, pos)
    cl.step(m, pos, geom, rep)
    assert cl.n == 1 and cl.volume[0] == pytest.approx(V, rel=1e-15)
    pos = pos.copy()
    d = pos[0] - pos[1]
    dist = np.linalg.norm(d)
    pos[1] += d / dist * (dist - 2 * R)                  # grains 0 and 1 in contact
    geom = m.update(pos)
    assert geom["formed"] == 1 and m.n_bridges == 3
    out = cl.step(m, pos, geom, None)
    assert cl.n == 1 and cl.events["absorbed"] == 1
    assert (cl.members[0, :, 0] >= 0).all()
    assert cl.volume[0] == pytest.approx(float(m.vol.sum()), rel=1e-15)
    assert cl.volume[0] > V * (1 + 1e-3)
    np.testing.assert_array_equal(out["geom"]["force"], 0.0)
    ref = sur.predict_vectors(pos / R, cl.volume[0] / R**3, 0.0)
    F = ref["forces"] * force_scale(R, GAMMA)
    np.testing.assert_allclose(out["forces"], F, rtol=1e-12, atol=1e-15 * np.abs(F).max())


def test_equal_pressure_shares_where_the_doublet_pressure_turns_down():
    """At theta = 60 deg the doublet's P*(V*) at contact rises to a maximum (V* ~ 0.4)
    and falls after it; the equal-pressure split used to be refused whenever the
    pressures scanned up to the total volume were not rising everywhere (all the
    splits at 60 deg in the packing benchmark fell back to the merge-time volumes).  On
    the rising branch the shares exist: exact doublets at them have equal pressures to
    the doublet table's pressure error (1e-3), and they add up to the total."""
    from capbridge.solvers.young_laplace import solve_doublet
    from capbridge.surrogate.doublet import DoubletSurrogate
    from capbridge.dem.triplet_clusters import table_equal_pressure

    d = DoubletSurrogate().fit(default_table_path())
    vol = np.asarray(d.volume_, float)
    for gaps, V in (((0.0, 0.02), 0.45), ((0.0, 0.03), 0.42), ((0.0, 0.0), 0.6)):
        v = table_equal_pressure(d, list(gaps), V, 60.0, (vol.min(), vol.max()))
        assert v is not None, (gaps, V)
        assert v.sum() == pytest.approx(V, rel=1e-12)
        P = solve_doublet(np.array(gaps), v, 60.0)["pressure"]
        assert P[0] == pytest.approx(P[1], rel=1e-3)


@pytest.mark.parametrize("theta", [30.0, 60.0])
def test_equal_pressure_shares_of_unequal_grains(theta):
    """Bridges between grains of unequal radii (a shared grain of radius r0 = 1 and
    grains of 1.3 and 0.8) share the liquid at one SI pressure: each bridge in its own
    units (its smaller radius, the ratio of its grains), pressures compared as P*_b/s_b.
    Exact doublets at the shares have equal pressures to the doublet table's error
    (1e-3); the shares add up to the total (the split of +-25 % packings fell back to
    the merge-time volumes at every split before)."""
    from capbridge.solvers.young_laplace import solve_doublet
    from capbridge.surrogate.doublet import DoubletSurrogate
    from capbridge.dem.triplet_clusters import table_equal_pressure

    d = DoubletSurrogate().fit(default_table_path())
    vol = np.asarray(d.volume_, float)
    R = np.array([[1.0, 1.3], [0.8, 1.0]])
    s, ratio = R.min(axis=1), R.max(axis=1) / R.min(axis=1)
    for gaps, V in (((0.0, 0.05), 0.3), ((0.02, 0.1), 0.2)):
        v = table_equal_pressure(d, list(gaps), V, theta, (vol.min(), vol.max()), radii=R)
        assert v is not None and v.sum() == pytest.approx(V, rel=1e-12)
        P = [solve_doublet(np.array([g / sb]), np.array([vb / sb**3]), theta,
                           ratio=rb)["pressure"][0] / sb
             for g, vb, sb, rb in zip(gaps, v, s, ratio)]
        assert P[0] == pytest.approx(P[1], rel=1e-3)
        # not the equal-radii answer: the radii matter
        v_eq = table_equal_pressure(d, list(gaps), V, theta, (vol.min(), vol.max()))
        assert np.abs(v - v_eq).max() > 1e-2 * V


def test_lookup_takes_dem_contacts_at_gap_zero_and_skips_deeper_overlaps(sur, doublets):
    """The lookup at the grains' own centres: two contacts overlapping by 2e-4 r (a
    DEM contact) get the surrogate's answer at gap 0 along the actual centre lines;
    an overlap of 0.06 r (deeper than CONTACT_OVERLAP_MAX) is not looked up: no
    number, counted as a gap outside the table, and no exception."""
    from capbridge.validation import CONTACT_OVERLAP_MAX

    g, V = _geometry(sur, 0.0)
    cl = LiquidClusters(GAMMA, surrogate=sur)
    for overlap, answered in ((2e-4, True), (CONTACT_OVERLAP_MAX + 0.01, False)):
        pos = triangle_centres(2 + g[0], 2 - overlap, 2 - overlap) * R
        m = _model(pos, [(0, 2), (1, 2)], [V / 2, V / 2], 0.0, doublets)
        res = cl.lookup(m, pos, np.array([[0, 1, 2]]), np.array([V]))
        assert bool(res["asked"][0]) is answered
        if answered:
            ref = sur.predict(g[0], 0.0, 0.0, V / R**3, 0.0)
            np.testing.assert_allclose(
                res["f"][0], [float(ref[n]) * force_scale(R, GAMMA)
                              for n in ("f12", "f13", "f23")], rtol=1e-12)
            assert int(res["status"][0]) == int(ref["status"])
        else:
            assert np.isnan(res["f"][0]).all()
            assert int(res["status"][0]) == Status.OUT_OF_RANGE


def test_life_distributions_stay_bounded_and_survive_a_restart(monkeypatch):
    """Lives and force jumps are kept exactly up to STATS_KEPT values, then as a
    uniform sample of that size with the exact count and maximum; a restart from the
    saved state continues the same sample, and a state saved before the counts
    existed gets them from its lists."""
    from capbridge.dem import triplet_clusters as tc

    monkeypatch.setattr(tc, "STATS_KEPT", 50)
    cl = LiquidClusters(GAMMA)
    values = np.arange(1, 1001, dtype=float)
    tc._record(cl.stats, "lives", values[:400])
    st = cl.get_state()
    again = LiquidClusters(GAMMA)
    again.set_state(st)
    tc._record(cl.stats, "lives", values[400:])
    tc._record(again.stats, "lives", values[400:])
    assert cl.stats["lives"] == again.stats["lives"]
    s = cl.life_summary()["ended_lives"]
    assert len(cl.stats["lives"]) == 50
    assert s["n"] == 1000 and s["max"] == 1000.0 and s["sampled"] == 50
    assert 300 < s["median"] < 700                 # a uniform sample of 1..1000
    assert len(set(cl.stats["lives"]) & set(values[:50])) < 25   # not just the first
    old = cl.get_state()
    for k in ("lives_n", "lives_max"):
        del old["stats"][k]
    legacy = LiquidClusters(GAMMA)
    legacy.set_state(old)
    assert legacy.stats["lives_n"] == 50 and legacy.stats["lives_max"] == max(cl.stats["lives"])


def test_forces_between_lookups_are_the_expansion_of_the_last_one(sur, doublets):
    """Grain 0 drifts away from grain 2 by 2e-4 r per step: the cluster is looked up
    (one predict_vectors call) only when a lookup gap has moved by more than REUSE_GAP
    since the last lookup; in between its forces are the first-order expansion, within
    1e-4 of max|F| of a lookup at every step; at a lookup they are the lookup's (1e-12).
    The surrogate is multilinear between the nodes of its refined grid, so the
    expansion, whose slopes are secants over REUSE_GAP, misses the slopes' jumps
    where that secant or the drift crosses a refined node (of the gaps, or of v =
    V/V*_coal, which moves with them): an error up to ~REUSE_GAP x the jump (measured
    here: 8.0e-5 of max|F| at the largest drift, 4.5e-2 F* per unit gap).  A restart in between continues
    with the same expansion: the same forces to the last bit."""
    from capbridge.dem.triplet_clusters import REUSE_GAP

    m, cl, pos, V, _, _ = _merged(sur, doublets)
    calls = []
    real = sur.predict_vectors

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    class Counted:                      # the surrogate, its calls counted
        predict_vectors = staticmethod(counted)

        def __getattr__(self, name):
            return getattr(sur, name)

    cl._sur = counted_sur = Counted()
    u = (pos[0] - pos[2]) / np.linalg.norm(pos[0] - pos[2])
    step_gap, n_steps = 2e-4, 25
    errors, looked, twin = [], [], None
    for s in range(1, n_steps + 1):
        pos = pos.copy()
        pos[0] += u * step_gap * R
        n0 = len(calls)
        out = cl.step(m, pos, m.update(pos, form=False), None, step=s)
        looked.append(len(calls) > n0)
        ref = real(pos / R, V / R**3, 0.0)["forces"] * force_scale(R, GAMMA)
        errors.append(np.abs(out["forces"] - ref).max() / np.abs(ref).max())
        if looked[-1]:
            assert errors[-1] < 1e-12
        if s == 12:                      # a restart from this step's state
            twin = LiquidClusters(GAMMA, surrogate=counted_sur)
            twin.set_state(cl.get_state())
        elif twin is not None:
            out2 = twin.step(m, pos, m.update(pos, form=False), None, step=s)
            np.testing.assert_array_equal(out2["forces"], out["forces"])
    assert cl.n == 1 and cl.events["split_geometry"] == 0
    # lookups at the merge step's expansion, then each time the drift passes REUSE_GAP
    expected = int(n_steps * step_gap / REUSE_GAP)
    assert expected - 1 <= sum(looked) <= expected + 2
    assert max(errors) < 1e-4
    assert max(errors) > 1e-9          # the expansion is not the lookup (test is live)


def test_a_refused_candidate_keeps_its_refusal_until_it_moves(sur, doublets):
    """Two bridges whose coalesced body is beyond the table's v range: refused at the
    first check (counted once as merge_refused, reason "volume"); at the next checks
    it is not looked up again while its lookup gaps stay within REUSE_GAP of the
    refusal's and its liquid is the same (still counted as refused, by the same
    reason), and it is looked up again once a gap has moved further; a restart keeps
    the refusal."""
    from capbridge.dem.triplet_clusters import REUSE_GAP

    v_out = 1.2 * float(sur.v_[-1])
    g, V = _geometry(sur, v=v_out)
    pos = triangle_centres(2 + g[0], 2 + g[1], 2 + g[2]) * R
    m = _model(pos, [(0, 2), (1, 2)], [V / 2, V / 2], 0.0, doublets)
    calls = []

    class Counted:
        def predict_vectors(self, *a, **k):
            calls.append(1)
            return sur.predict_vectors(*a, **k)

        def __getattr__(self, name):
            return getattr(sur, name)

    cl = LiquidClusters(GAMMA, surrogate=Counted())

    def check(pos, who=cl):
        geom, rep = _check(m, pos)
        assert rep.n_triplets == 1
        n0 = len(calls)
        who.step(m, pos, geom, rep)
        return len(calls) > n0

    assert check(pos) and cl.n == 0
    assert cl.events["merge_refused"] == 1 and cl.stats["refused_volume"] == 1
    assert not check(pos)                                     # kept, not looked up
    assert cl.stats["refused_volume"] == 2 and cl.events["merge_refused"] == 1
    twin = LiquidClusters(GAMMA, surrogate=Counted())
    twin.set_state(cl.get_state())
    assert not check(pos, twin) and twin.stats["refused_volume"] == 3
    u = (pos[0] - pos[2]) / np.linalg.norm(pos[0] - pos[2])
    near, far = pos.copy(), pos.copy()
    near[0] += u * 0.5 * REUSE_GAP * R
    far[0] += u * 1.5 * REUSE_GAP * R
    assert not check(near)
    assert check(far)                                         # moved: looked up again
    assert cl.events["merge_refused"] == 1 and cl.stats["refused_volume"] == 4


def test_slopes_of_a_gap_without_a_result_either_way_are_pinned():
    """Clusters whose triangle moved in one gap lands in a cell without a result and
    cannot be moved the other way (a contact): that gap gets a zero slope and is
    pinned (the expansion holds only while it does not move); the other gaps get
    their secants; a cluster without a result itself gets NaN slopes."""
    from capbridge.dem.triplet_clusters import PINNED, REUSE_GAP

    class NoRoom:                                   # nothing is inside the table
        def covers(self, *a, **k):
            return np.zeros(np.shape(a[0]), bool)

    n = 3                       # pinned in gap 2; pinned in gap 0; no result
    f0 = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [1.0, 1.0, 1.0]])
    d = np.array([[0.1, 0.2, 0.3], [-0.3, 0.2, 0.1], [0.0, 0.0, 0.0]])
    f = np.concatenate([f0, f0 + 7.0, f0 + d, f0 - 0.4])   # moved in gaps 0, 1, 2
    ok, no = Status.CONVERGED, Status.NO_EQUILIBRIUM
    status = np.array([ok, ok, no] + [ok, no, ok] + [ok, ok, ok] + [no, ok, ok], np.int8)
    vc = np.concatenate([[1.0, 2.0, 1.0], [1.2, 9.0, 1.0], [1.1, 2.1, 1.0],
                         [9.0, 1.9, 1.0]])
    step = np.full((n, 3), REUSE_GAP)
    gn = np.zeros((n, 3))
    out = LiquidClusters._slopes(NoRoom(), f, status, vc, step, gn, gn + 2.0,
                                 np.ones(n), np.zeros(n), np.ones((n, 3)))
    np.testing.assert_array_equal(out["toward"][:2], [[0, 0, PINNED], [PINNED, 0, 0]])
    h = REUSE_GAP
    np.testing.assert_allclose(out["slope"][0], np.column_stack([np.full(3, 7.0 / h),
                                                                 d[0] / h, 0 * d[0]]))
    np.testing.assert_allclose(out["slope"][1], np.column_stack([0 * d[1], d[1] / h,
                                                                 np.full(3, -0.4 / h)]))
    np.testing.assert_allclose(out["vc_slope"][:2], [[0.2 / h, 0.1 / h, 0.0],
                                                     [0.0, 0.1 / h, -0.1 / h]])
    assert np.isnan(out["slope"][2]).all()
