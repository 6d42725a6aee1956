"""Coalesced-triplet table: relabelling symmetry of the stored cube, and re-solves of
shipped points by Surface Evolver with the settings recorded in the file."""
import json

import numpy as np
import pytest

from capbridge.dimensionless import canonical_triplet
from capbridge.solvers.triplet import pair_forces, triplet_geometry
from capbridge.tables.triplet import (PAIR_NAMES, PAIRS, EvolverPlan, TripletGrid,
                                               _expand_to_cube, failure_kind)
from capbridge.status import Status

def _phi(d_own, d_others):
    """A pair force that depends on its own gap and on the other two (any labelling)."""
    return 0.9 - 1.3 * d_own + 0.4 * d_others ** 2


def test_canonical_triplet_sorts_and_relabels():
    rng = np.random.default_rng(3)
    for _ in range(50):
        d = rng.choice([0.0, 0.1, 0.2], 3) if rng.random() < 0.5 else rng.uniform(0, .3, 3)
        srt, perm = canonical_triplet(*d)
        assert np.all(np.diff(srt) >= 0)
        gaps = {(0, 1): d[0], (0, 2): d[1], (1, 2): d[2]}
        for (a, b), s in zip(PAIRS, srt):
            assert gaps[tuple(sorted((perm[a], perm[b])))] == s
        assert sorted(perm) == [0, 1, 2]


def test_cube_expansion_permutes_pair_forces_and_rotates_vectors():
    grid = TripletGrid((0.0, 0.1, 0.2), (30.0,), (1.0,))
    canon = grid.canonical_geometries()
    n = len(canon)
    per = {name: np.zeros((n, 1, 1)) for name in PAIR_NAMES}
    per["force"] = np.zeros((n, 1, 1, 3, 3))
    per["volume_coalescence"] = np.arange(n, dtype=float)[:, None]
    for k, (d12, d13, d23) in enumerate(canon):
        g = {(0, 1): d12, (0, 2): d13, (1, 2): d23}
        f = {}
        for (i, j), name in zip(PAIRS, PAIR_NAMES):
            others = sum(v for p, v in g.items() if p != (i, j))
            f[(i, j)] = _phi(g[(i, j)], others)
            per[name][k] = f[(i, j)]
        geom = triplet_geometry(d12, d13, d23)
        for (i, j), fij in f.items():
            per["force"][k, 0, 0, i] += fij * geom.axis(i, j)
            per["force"][k, 0, 0, j] -= fij * geom.axis(i, j)
    cube = _expand_to_cube(grid, canon, per)
    g = grid.gaps
    for a, b, c in np.ndindex(3, 3, 3):
        gaps = {(0, 1): g[a], (0, 2): g[b], (1, 2): g[c]}
        geom = triplet_geometry(g[a], g[b], g[c])
        F = cube["force"][a, b, c, 0, 0]
        for (i, j), name in zip(PAIRS, PAIR_NAMES):
            others = sum(v for p, v in gaps.items() if p != (i, j))
            assert cube[name][a, b, c, 0, 0] == pytest.approx(_phi(gaps[(i, j)], others),
                                                              abs=1e-14)
        # the relabelled, rotated vectors decompose into the same pair forces here
        f, res = pair_forces(geom.centres, F)
        assert res < 1e-12
        for (i, j), name in zip(PAIRS, PAIR_NAMES):
            assert f[(i, j)] == pytest.approx(cube[name][a, b, c, 0, 0], abs=1e-12)
        # a scalar of the geometry is the same for every labelling
        srt, _ = canonical_triplet(g[a], g[b], g[c])
        k = int(np.flatnonzero(np.all(np.isclose(canon, srt), axis=1))[0])
        assert cube["volume_coalescence"][a, b, c, 0] == k


def test_packings_grid_computes_the_bridge_gaps_domain_only():
    """The second table's grid (issue 18): bridge gaps (the two smaller) up to 0.2, the
    open side up to 0.6; the cube's nodes with two gaps above 0.2 are not computed and
    stored as such; held-out points fall in the computed domain."""
    from capbridge.tables.triplet import FAILURE_KINDS, _holdout_points

    grid = TripletGrid.packings()
    canon = grid.canonical_geometries()
    assert len(canon) == 28                   # a <= b <= 0.2, b <= c <= 0.6 on 6 gaps
    assert np.all(canon[:, 1] <= 0.2 + 1e-12) and canon[:, 2].max() == 0.6
    assert max(grid.v) == 5.0 and grid.as_dict()["max_bridge_gap"] == 0.2
    per = {**{f: np.ones((len(canon), 1, 1)) for f in PAIR_NAMES}, "status": np.zeros((len(canon), 1, 1), np.int8),
           "failure": np.zeros((len(canon), 1, 1), np.int8),
           "gravity_status": np.zeros((len(canon), 1, 1), np.int8),
           "volume_coalescence": np.ones((len(canon), 1))}
    cube = _expand_to_cube(grid, canon, per)
    g = np.asarray(grid.gaps)
    n_out = 0
    for a, b, c in np.ndindex(6, 6, 6):
        inside = np.sort([g[a], g[b], g[c]])[1] <= 0.2 + 1e-12
        n_out += not inside
        if inside:
            assert cube["status"][a, b, c, 0, 0] == 0 and cube["f12"][a, b, c, 0, 0] == 1
        else:
            assert cube["status"][a, b, c, 0, 0] == Status.NOT_COMPUTED
            # the gravity response is not computed there either (it was stored as
            # converged, and the table could not be read back)
            assert cube["gravity_status"][a, b, c, 0, 0] == Status.NOT_COMPUTED
            assert cube["failure"][a, b, c, 0, 0] == list(FAILURE_KINDS).index("not_computed")
            assert np.isnan(cube["f12"][a, b, c, 0, 0])
            assert np.isnan(cube["volume_coalescence"][a, b, c, 0])
    assert n_out > 0
    hg, ht, hv = _holdout_points(grid, 200, seed=1)
    assert np.all(np.diff(hg, axis=1) >= 0) and np.all(hg[:, 1] <= 0.2) and hg[:, 2].max() > 0.4
    assert hv.max() <= 5.0 and ht.max() <= 80.0
    # the first table's grid computes its whole cube
    assert len(TripletGrid().canonical_geometries()) == 10


def test_failure_kinds_from_driver_reasons():
    assert failure_kind(Status.CONVERGED, "") == 0
    assert failure_kind(Status.NOT_CONVERGED, "level 2: pinch: bridge 1 pinching off") == 1
    assert failure_kind(Status.NOT_CONVERGED, "level 3 (main) timed out") == 3
    assert failure_kind(Status.NOT_CONVERGED, "fold: inverted/folded facets") == 2
    assert failure_kind(Status.NOT_CONVERGED, "something new") == 4


# ---- the shipped table --------------------------------------------------------------


#: the shipped triplet tables (fixtures of conftest.py) and points of each that the
#: re-solve test solves again: a closed and an open triangle of the first table's grid,
#: and on the second table's an open side beyond the first's (0.45) at a large v
SHIPPED = {"triplet_table": [dict(d12=0.0, d13=0.1, d23=0.2, theta=60.0, v=1.25),
                             dict(d12=0.1, d13=0.1, d23=0.1, theta=40.0, v=1.0)],
           "packings_triplet_table": [dict(d12=0.0, d13=0.1, d23=0.2, theta=60.0, v=1.25),
                                      dict(d12=0.0, d13=0.0, d23=0.45, theta=20.0, v=2.5)]}


@pytest.fixture(scope="module", params=sorted(SHIPPED))
def shipped(request):
    """The name of a shipped table's fixture."""
    return request.param


@pytest.fixture(scope="module")
def table(request, shipped):
    from capbridge.tables.netcdf_io import read_table

    return read_table(request.getfixturevalue(shipped))


def test_shipped_table_is_symmetric_under_relabelling(table):
    # f12(d12, d13, d23) = f13(d13, d12, d23): swapping grains 2 and 3
    f12 = table["f12"].transpose("d12", "d13", "d23", "theta", "v").values
    f13 = table["f13"].transpose("d13", "d12", "d23", "theta", "v").values
    both = np.isfinite(f12) & np.isfinite(f13)
    computed = table["status"].values != Status.NOT_COMPUTED      # max_bridge_gap
    assert both.sum() > 0.5 * computed.sum()
    np.testing.assert_array_equal(np.isfinite(f12), np.isfinite(f13))
    # relabelled copies are exact; where d12 = d13 the two pair forces are two Evolver
    # numbers of one symmetric state: equal within the point's own error estimate
    d12, d13 = np.meshgrid(table.d12, table.d13, indexing="ij")
    tie = np.broadcast_to((d12 == d13)[:, :, None, None, None], f12.shape)
    np.testing.assert_allclose(f12[both & ~tie], f13[both & ~tie], rtol=0, atol=1e-12)
    err = table["force_error"].transpose("d12", "d13", "d23", "theta", "v").values
    assert np.all(np.abs(f12 - f13)[both & tie] <= err[both & tie] + 1e-12)


def test_shipped_table_forces_balance_and_records_its_command(table):
    st = table["status"].values
    ok = np.isin(st, [Status.CONVERGED, Status.ABOVE_TOLERANCE])
    assert ok.sum() > 0.6 * np.sum(st != Status.NOT_COMPUTED)
    conv = st == Status.CONVERGED
    F = table["force"].values                            # (..., grain, component)
    scale = np.abs(F).max(axis=(-2, -1))
    resid = np.linalg.norm(F.sum(axis=-2), axis=-1)
    # no gravity: converged forces balance up to the mesh (the driver's residual) ...
    assert np.all(resid[conv] < 2e-2 * scale[conv])
    assert np.all(table["pair_residual"].values[conv] < 2e-2)
    # ... and points above tolerance within what their own estimate allows (on the
    # second table: 15 canonical points, 13 of them bodies that barely pull at 80 deg)
    above = st == Status.ABOVE_TOLERANCE
    assert np.all(resid[above] <= 2e-2 * scale[above] + 3 * table["force_error"].values[above])
    assert table.attrs["capbridge_command"].startswith("capbridge generate triplet")
    json.loads(table.attrs["evolver_settings"])


@pytest.mark.evolver
def test_shipped_points_resolved_by_evolver(table, shipped):
    """Two canonical points of each shipped table solved again with its recorded settings."""
    from capbridge.solvers.triplet_evolver import evolver_triplet

    plan = EvolverPlan(**json.loads(table.attrs["evolver_settings"]))
    pts = SHIPPED[shipped]
    for p in pts:
        row = table.sel(**p)
        assert int(row["status"]) in (Status.CONVERGED, Status.ABOVE_TOLERANCE)
        geom = triplet_geometry(p["d12"], p["d13"], p["d23"])
        r = evolver_triplet(float(row["volume"]), geom, p["theta"], "coalesced",
                            max_refine=plan.max_refine, tol=plan.ftol, etol=plan.etol,
                            flag_above_tolerance=True, inspect_mesh=False, workers=1,
                            retry_rings=plan.retry_rings)
        assert r["status_code"] == int(row["status"])
        err = float(row["force_error"])
        for key, name in zip(("12", "13", "23"), PAIR_NAMES):
            assert r["pair_forces"][key] == pytest.approx(float(row[name]),
                                                          abs=max(err, 1e-4))
