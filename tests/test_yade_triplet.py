"""Coalesced triplets in real YADE: the triplet table's forces, the split, no cost without.

Scene ``tests/yade_scenes/triplet_capbridge.py --closing``: three equal grains (r = 1 mm)
with two bridges from the shared grain 2; grain 1 is driven around grain 2 towards
grain 0 until the caps meet (the engine checks coalescence at every step), held, then
pulled straight away from grain 2 beyond the table's gaps.  Checks, on what YADE
applied:

* while the cluster exists, the forces on the three grains are the triplet
  surrogate's (predict_vectors at the centres the engine saw, total volume = the two
  bridges') within 1 % (in fact to round-off), summing to zero;
* pulling apart splits the cluster (split_geometry), the two bridges share its liquid at
  equal Laplace pressure at that step (the doublet table's, checked with exact doublets
  to the table's 1e-3), their volumes add up to
  the two initial bridges' to 1e-12 and the ledger balances to 1e-12;
* a scene saved with a cluster (O.saveTmp) and loaded again (O.loadTmp) gives the same
  forces and cluster as the run that went on;
* the same scene with bridges too small to coalesce does no triplet work: the table is
  never read, no cluster bookkeeping is made.

The triplet table is ``$CAPBRIDGE_TRIPLET_TABLE`` (default the shipped
``data/triplet_table.nc``; the ``triplet_table`` fixture of conftest.py).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr
from capbridge.dimensionless import force_scale
from capbridge.status import HAS_RESULT
from capbridge.dem.triplet_clusters import load_surrogate

SCENE = Path(__file__).parent / "yade_scenes" / "triplet_capbridge.py"
R = 1e-3
THETA = 60.0
REL_TOL = 0.01          # the "within 1 %"
pytestmark = pytest.mark.yade


@pytest.fixture(scope="module")
def sur(triplet_table):
    """The surrogate as the engine fits it (with the dense V_coal table beside it)."""
    return load_surrogate(triplet_table)


def _path(sur):
    """(gaps g01_start, g01_end, g; pull gap) inside / outside the table's gap axis."""
    lo, hi = sur.gaps_[0], sur.gaps_[-1]
    g = lo + 0.5 * (hi - lo)
    g01_end = lo + 0.1 * (hi - lo)
    return [0.5, g01_end, g], 1.5 * hi


def _run(sur, table, v, triplet_forces="on", steps=(150, 20, 100, 10), extra=()):
    """The closing scene with two bridges of v V*_coal / 2 each (V*_coal at the end of
    the closing path)."""
    gaps, pull = _path(sur)
    Vc = float(sur.coalescence_volume(gaps[1], gaps[2], gaps[2], THETA)["volume_coalescence"])
    volume = v * Vc * R**3 / 2
    args = ["--closing", "--r", R, "--theta", THETA, "--volume", repr(volume),
            "--gaps", ",".join(map(repr, gaps)), "--pull-gap", pull,
            "--steps", ",".join(map(str, steps)), "--table", table,
            "--triplet-forces", triplet_forces, *extra]
    res = yr.run_yade_script(SCENE, [str(a) for a in args], timeout=300).result
    return res, volume


def test_triplet_forces_then_split_in_yade(sur, triplet_table):
    from capbridge.solvers.young_laplace import solve_doublet

    res, vb = _run(sur, triplet_table, 1.15)
    rows = res["rows"]
    n_cl = np.array([row["triplets"].get("clusters", 0) for row in rows])
    merged = np.flatnonzero(n_cl == 1)
    assert merged.size > 20, f"the cluster never formed: {rows[-1]['triplets']}"
    first = merged[0]
    assert np.all(n_cl[:first] == 0)
    fs = force_scale(R, res["gamma"])
    for k in merged:
        row = rows[k]
        pos = np.array(row["pos"])
        F = np.array(row["forces"])
        ref = sur.predict_vectors(pos / R, 2 * vb / R**3, THETA)
        assert ref["status"] in HAS_RESULT
        Fr = ref["forces"] * fs
        scale = np.abs(Fr).max()
        np.testing.assert_allclose(F, Fr, rtol=0, atol=REL_TOL * scale)
        np.testing.assert_allclose(F.sum(0), 0.0, atol=1e-12 * scale)
        assert row["bridge_force"] == [0.0, 0.0]        # the doublets are replaced
    # the forces did switch at the merge: a jump far larger than one step of motion
    # makes in the doublet forces just before it
    f = [np.array(rows[k]["forces"]) for k in (first - 2, first - 1, first)]
    scale = np.abs(f[1]).max()
    assert np.abs(f[2] - f[1]).max() > 2 * REL_TOL * scale
    assert np.abs(f[1] - f[0]).max() < 0.1 * np.abs(f[2] - f[1]).max()
    # pulled apart: split once, at equal pressure, liquid exact
    last = rows[-1]
    ev = last["triplets"]["events"]
    assert ev["merged"] == 1 and ev["split_geometry"] == 1 and last["triplets"]["clusters"] == 0
    assert ev["split_share_fallback"] == 0
    vol = np.array(last["vol"])
    assert vol.size == 2 and vol.sum() == pytest.approx(2 * vb, rel=1e-12)
    assert abs(vol[0] - vol[1]) > 1e-3 * vb
    assert last["budget"]["balance_error"] < 1e-12
    assert last["budget"]["active_volume"] == pytest.approx(2 * vb, rel=1e-12)
    # equal pressure at the step of the split (later the bridges keep their volumes
    # while their gaps change, as every bridge of the engine does)
    split = rows[merged[-1] + 1]
    assert split["triplets"]["events"]["split_geometry"] == 1 and split["vol"] == last["vol"]
    # the engine's default split: equal pressure on the doublet table (to its P*
    # interpolation error against exact doublets)
    P = solve_doublet(np.array(split["gap"]) / R, vol / R**3, THETA)["pressure"]
    assert P[0] == pytest.approx(P[1], rel=1e-3)
    # and the doublet forces are back: grain 0 feels its one bridge only
    f0 = np.array(last["forces"][0])
    assert np.linalg.norm(f0) == pytest.approx(last["bridge_force"][
        [tuple(p) for p in zip(last["bi"], last["bj"])].index((0, 2))], rel=1e-12)


def test_no_coalescence_no_triplet_work(sur, triplet_table):
    """Bridges far too small to coalesce on the same path: no cluster bookkeeping is
    made and the triplet table is never read."""
    res, _ = _run(sur, triplet_table, 0.3, steps=(60, 0, 20, 0))
    for row in res["rows"]:
        t = row["triplets"]
        assert t == {"enabled": True, "table_loaded": False, "clusters": 0}
    assert res["state"]["coalescence"]["triplets"] == 0
    assert not any("triplet table" in m for m in res["messages"])


def test_cluster_survives_save_and_load(sur, triplet_table):
    """O.saveTmp with a merged cluster, 5 steps, O.loadTmp, the same 5 steps: the
    cluster is restored (events, volume) and YADE gets bit-identical forces."""
    res, vb = _run(sur, triplet_table, 1.15, steps=(150, 5, 0, 0), extra=("--restart", 5))
    a, b = res["restart"]
    assert a[0]["triplets"]["clusters"] == 1
    # the restored cluster is the saved one (merged before the save), not a new merge
    born = a[0]["triplets"]["born"]
    assert born[0] < a[0]["iter"] - 1 and b[0]["triplets"]["born"] == born
    for ra, rb in zip(a, b):
        assert ra["iter"] == rb["iter"]
        assert ra["forces"] == rb["forces"]
        assert ra["triplets"]["events"] == rb["triplets"]["events"]
        assert ra["triplets"]["cluster_volume"] == rb["triplets"]["cluster_volume"] == \
            pytest.approx(2 * vb, rel=1e-15)
