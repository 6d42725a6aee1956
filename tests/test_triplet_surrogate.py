"""TripletSurrogate: symmetry, vectors, nodes, held-out points, statuses, bad input.

The table is ``$CAPBRIDGE_TRIPLET_TABLE`` (default: the shipped ``data/triplet_table.nc``;
the ``triplet_table`` fixture of conftest.py).
"""
import itertools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from capbridge.tables.netcdf_io import read_table
from capbridge.status import HAS_RESULT, Status
from capbridge.surrogate.triplet import (LOWER_ENERGY_STATES, PAIR_NAMES, PAIRS,
                                         TripletSurrogate, _Descending, _Grid,
                                         holdout_errors)
from capbridge.validation import CapbridgeInputError

ANSWERED = (Status.CONVERGED, Status.ABOVE_TOLERANCE)


@pytest.fixture(scope="module")
def table(triplet_table):
    return read_table(triplet_table)


@pytest.fixture(scope="module")
def sur(table):
    return TripletSurrogate().fit(table)


def _editable(table):
    """A copy whose values may be changed (the checksum would refuse an edit)."""
    ds = table.copy(deep=True)
    for key in ("data_sha256", "table_sha256"):
        ds.attrs.pop(key, None)
    return ds


def _inside(sur, n, seed, v=None):
    """Random (d12, d13, d23, theta, V*) inside the table, answered by the surrogate."""
    rng = np.random.default_rng(seed)
    g = rng.uniform(sur.gaps_[0], sur.gaps_[-1], (3, n))
    t = rng.uniform(sur.theta_[0], sur.theta_[-1], n)
    span = sur.v_[-1] - sur.v_[0]          # 1 % off the edges: V*_coal of the lookup
    vv = rng.uniform(sur.v_[0] + 0.01 * span, sur.v_[-1] - 0.01 * span, n) if v is None \
        else np.full(n, v)
    return g, t, vv * sur.coalescence_volume(*g, t)["volume_coalescence"]


def test_permutation_symmetry(sur):
    """Relabelling the grains permutes the pair forces, nothing else changes."""
    g, t, V = _inside(sur, 300, 1)
    ref = sur.predict(*g, V, t)
    gap = {p: g[k] for k, p in enumerate(PAIRS)}
    for perm in itertools.permutations(range(3)):
        q = [gap[tuple(sorted((perm[i], perm[j])))] for i, j in PAIRS]
        r = sur.predict(*q, V, t)
        for (i, j), name in zip(PAIRS, PAIR_NAMES):
            src = PAIR_NAMES[PAIRS.index(tuple(sorted((perm[i], perm[j]))))]
            np.testing.assert_allclose(r[name], ref[src], rtol=1e-12, atol=1e-13)
        for name in ("pressure", "energy", "volume_coalescence", "V0", "dV", "v"):
            np.testing.assert_allclose(r[name], ref[name], rtol=1e-12, atol=1e-13)
        np.testing.assert_array_equal(r["status"], ref["status"])


def test_vectors_balance_and_match_pair_forces(sur):
    """Forces sum to zero, have no torque, and decompose into the pair forces of predict,
    in any frame (rotated, translated)."""
    g, t, V = _inside(sur, 50, 2)
    rng = np.random.default_rng(3)
    a, b, c = 2 + g
    x3 = (a * a + b * b - c * c) / (2 * a)
    C = np.zeros((50, 3, 3))
    C[:, 1, 0] = a
    C[:, 2, 0], C[:, 2, 1] = x3, np.sqrt(b * b - x3 * x3)
    Q, _ = np.linalg.qr(rng.normal(size=(50, 3, 3)))
    C = np.einsum("nij,nkj->nki", Q, C) + rng.normal(size=(50, 1, 3))
    r = sur.predict_vectors(C, V, t)
    p = sur.predict(*g, V, t)
    ok = np.isin(r["status"], ANSWERED)
    assert ok.sum() > 10
    F = r["forces"][ok]
    scale = np.abs(F).max()
    assert np.abs(F.sum(axis=1)).max() < 1e-12 * scale
    torque = np.cross(C[ok], F).sum(axis=1)
    assert np.abs(torque).max() < 1e-11 * scale
    np.testing.assert_allclose(r["gaps"], g.T, atol=1e-12)
    for name in PAIR_NAMES:
        np.testing.assert_allclose(r[name][ok], p[name][ok], rtol=1e-12)
    # attraction > 0 pulls grain 1 towards grain 2: F_1 . u_12 = f12 + f13 cos(angle)
    u12 = (C[ok, 1] - C[ok, 0]) / np.linalg.norm(C[ok, 1] - C[ok, 0], axis=1)[:, None]
    u13 = (C[ok, 2] - C[ok, 0]) / np.linalg.norm(C[ok, 2] - C[ok, 0], axis=1)[:, None]
    np.testing.assert_allclose(np.einsum("ni,ni->n", F[:, 0], u12),
                               p["f12"][ok] + p["f13"][ok] * np.einsum("ni,ni->n", u12, u13),
                               rtol=1e-10)


def test_nodes_reproduced(sur, table):
    """At every table node answered by its cell, the table's values come back: exactly
    (1e-9) where the three gaps differ, within the Evolver error estimate at ties
    (where the surrogate averages pair forces that are equal by symmetry)."""
    G = np.meshgrid(*(table[d].values for d in ("d12", "d13", "d23", "theta", "v")),
                    indexing="ij")
    V = G[4] * table["volume_coalescence"].values[..., None]
    r = sur.predict(G[0], G[1], G[2], V, G[3])
    ok = np.isin(r["status"], ANSWERED) & np.isin(table["status"].values, ANSWERED)
    assert ok.sum() >= 0.3 * ok.size
    np.testing.assert_allclose(r["volume_coalescence"],
                               np.broadcast_to(table["volume_coalescence"].values[..., None],
                                               V.shape), rtol=1e-12)
    distinct = (G[0] != G[1]) & (G[0] != G[2]) & (G[1] != G[2])
    for name in PAIR_NAMES:
        got, want = r[name], table[name].values
        np.testing.assert_allclose(got[ok & distinct], want[ok & distinct], rtol=1e-9,
                                   atol=1e-12)
        tie = ok & ~distinct
        assert np.all(np.abs(got[tie] - want[tie]) <= table["force_error"].values[tie]
                      + 1e-12), name
    # scalars are the same at every relabelled copy: exact at ties too
    np.testing.assert_allclose(r["pressure"][ok], table["pressure"].values[ok], rtol=1e-9)
    np.testing.assert_allclose(r["energy"][ok], table["energy_extrapolated"].values[ok],
                               rtol=1e-9)


def test_holdout_points_within_error(sur):
    """Held-out Evolver points (one level finer): each pair force within the surrogate's
    own error estimate (the cell's Evolver error plus the measured interpolation error),
    and the same errors under every relabelling of the grains."""
    if sur.holdout_ is None:
        pytest.skip("the table has no held-out points")
    e = holdout_errors(sur)
    assert e["n"] >= 1
    h = sur.holdout_
    r = sur.predict(h["d12"], h["d13"], h["d23"], h["volume"], h["theta"])
    used = e["used"]
    for k, name in enumerate(PAIR_NAMES):
        diff = np.abs(r[name][used] - h[name][used])
        assert np.all(diff <= r["force_error"][used] + 1e-12), name
    ep = holdout_errors(sur, permute=True)
    np.testing.assert_allclose(np.sort(ep["rel_error"][ep["used"]].ravel()),
                               np.sort(np.tile(e["rel_error"][used], (6, 1)).ravel()),
                               rtol=1e-9, atol=1e-12)
    assert sur.interpolation_error_["max_rel_error"] == pytest.approx(e["max_rel_error"])


def test_linear_method_reproduces_multilinear(table):
    """method='linear' is multilinear on the raw grid: at a cell centre the mean of the
    cell's 32 corners."""
    s = TripletSurrogate(method="linear").fit(table)
    ok = np.isin(table["status"].values, ANSWERED)
    idx = np.argwhere(ok[:-1, :-1, :-1, :-1, :-1] & ok[1:, 1:, 1:, 1:, 1:])
    for i in idx[:3]:
        sl = tuple(slice(a, a + 2) for a in i)
        axes = [table[d].values for d in ("d12", "d13", "d23", "theta", "v")]
        mid = [0.5 * (ax[a] + ax[a + 1]) for ax, a in zip(axes, i)]
        V = mid[4] * s.coalescence_volume(*mid[:4])["volume_coalescence"]
        r = s.predict(*mid[:3], V, mid[3])
        if not np.isin(r["status"], ANSWERED):
            continue
        # the corners of the symmetrised cube: the table's own where gaps differ
        want = np.mean(table["f23"].values[sl])
        assert r["f23"] == pytest.approx(want, rel=0, abs=2 * float(
            table["force_error"].values[sl].max()) + 1e-12)


def test_kernels_exact_on_linear_functions():
    """Simplex and multilinear kernels reproduce a linear function exactly; the
    insertion sort of the fractions sorts (ties included) and keeps each axis."""
    for k in range(1, 6):
        P = np.array(list(itertools.product(range(k), repeat=k)), float).T   # (k, n)
        d = _Descending()
        for a in range(k):
            d = d.insert(P[a], a)
        F, A = np.array(d.fracs), np.array(d.axes)
        np.testing.assert_array_equal(F, -np.sort(-P, axis=0))
        np.testing.assert_array_equal(np.take_along_axis(P, A.astype(int), 0), F)
        assert all(sorted(col) == list(range(k)) for col in A.T)
    shape = (4, 3, 5, 3, 4)
    X = np.meshgrid(*(np.arange(n, dtype=float) for n in shape), indexing="ij")
    vals = np.stack([sum((m + 1) * x for m, x in enumerate(X)), X[0] - 2 * X[4]], -1)
    rng = np.random.default_rng(0)
    pts = [rng.uniform(0, n - 1, 200) for n in shape]
    idx = [np.minimum(p.astype(int), n - 2) for p, n in zip(pts, shape)]
    fr = [p - i for p, i in zip(pts, idx)]
    want = np.stack([sum((m + 1) * p for m, p in enumerate(pts)), pts[0] - 2 * pts[4]], -1)
    for kernel in ("simplex", "multilinear"):
        np.testing.assert_allclose(_Grid(vals, kernel)(idx, fr), want, rtol=1e-12,
                                   atol=1e-12)


def test_fine_grid_error_small(sur):
    """The fine-grid lookup against the spline interpolant it stands for (evaluated
    directly at each point) stays within half of the surrogate's accuracy targets
    (0.5 % median, 2 % max in f_ij): 0.25 % median, 1 % max (measured 0.09 %, 0.32 %
    on the d <= 0.1 part of the shipped grid)."""
    g, t, V = _inside(sur, 150, 5)
    v = V / sur.coalescence_volume(*g, t)["volume_coalescence"]
    r = sur.predict(*g, V, t)
    ok = np.isin(r["status"], ANSWERED)
    if ok.sum() < 10:
        pytest.skip("fewer than 10 answered points")
    exact = sur.spline_at(*(x[ok] for x in g), t[ok], v[ok])
    rel = np.abs(np.stack([r[n][ok] for n in PAIR_NAMES], 1) / exact[:, :3] - 1)
    assert np.median(rel) < 2.5e-3 and rel.max() < 1e-2, (np.median(rel), rel.max())


def test_statuses_at_failed_and_inexact_nodes(table):
    """A no-equilibrium node: its cells answer NO_EQUILIBRIUM with no number; another
    failure: NOT_CONVERGED; above tolerance: ABOVE_TOLERANCE with the number; cells
    away from them are unaffected."""
    import json

    ds = _editable(table)
    st = ds["status"].values.copy()
    fail = ds["failure"].values.copy()
    kinds = list(json.loads(ds.attrs["failure_kinds"]))
    st[:] = Status.CONVERGED
    fail[:] = 0
    # node (0,0,0,0,0) no equilibrium (and its relabelled copies: the same node)
    st[0, 0, 0, 0, 0], fail[0, 0, 0, 0, 0] = Status.NOT_CONVERGED, kinds.index("no_equilibrium")
    st[-1, -1, -1, -1, -1], fail[-1, -1, -1, -1, -1] = Status.NOT_CONVERGED, kinds.index("timeout")
    st[0, 0, 0, -1, -1] = Status.ABOVE_TOLERANCE
    ds["status"].values[:] = st
    ds["failure"].values[:] = fail
    for name in ("f12", "f13", "f23", "pressure", "energy_extrapolated", "force_error"):
        ds[name].values[np.isnan(ds[name].values)] = 0.5
    s = TripletSurrogate().fit(ds)
    ax = [ds[d].values for d in ("d12", "d13", "d23", "theta", "v")]
    if min(len(x) for x in ax) < 3:
        pytest.skip("needs >= 3 nodes per axis (the shipped table)")
    lo = [x[0] + 0.25 * (x[1] - x[0]) for x in ax]                             # first cell
    hi = [x[-1] - 0.25 * (x[-1] - x[-2]) for x in ax]                          # last cell
    corner = [x[0] + 0.25 * (x[1] - x[0]) for x in ax[:3]] + \
        [ax[3][-1] - 0.1, ax[4][-1] - 0.01]
    mid = [x[len(x) // 2] + 0.3 * (x[len(x) // 2 + 1] - x[len(x) // 2])
           if len(x) > 2 else 0.5 * (x[0] + x[1]) for x in ax]
    out = {}
    for key, p in (("lo", lo), ("hi", hi), ("corner", corner), ("mid", mid)):
        Vc = s.coalescence_volume(*p[:4])["volume_coalescence"]
        out[key] = s.predict(*p[:3], p[4] * Vc, p[3])
    assert out["lo"]["status"] == Status.NO_EQUILIBRIUM and np.isnan(out["lo"]["f12"])
    assert out["hi"]["status"] == Status.NOT_CONVERGED and np.isnan(out["hi"]["f23"])
    assert out["corner"]["status"] == Status.ABOVE_TOLERANCE
    assert np.isfinite(out["corner"]["f13"])
    if len(ax[0]) > 2:
        assert out["mid"]["status"] == Status.CONVERGED


def test_volume_outside_the_table(sur, table):
    """v above the table: an error naming the value and range, or with clip the edge's
    answer (EXTRAPOLATED); below it: an error, or with clip no number."""
    g = [float(np.mean(table["d12"].values[:2]))] * 3
    t = float(table["theta"].values[1])
    clip = TripletSurrogate(refine=sur.refine, out_of_range="clip").fit(table)
    Vc = float(sur.coalescence_volume(*g, t)["volume_coalescence"])
    vmax, vmin = float(table["v"].values[-1]), float(table["v"].values[0])
    with pytest.raises(CapbridgeInputError, match=r"outside the triplet table's range"):
        sur.predict(*g, 1.5 * vmax * Vc, t)
    with pytest.raises(CapbridgeInputError, match=r"\[" + f"{vmin:g}"):
        sur.predict(*g, 0.5 * vmin * Vc, t)
    edge = clip.predict(*g, vmax * Vc, t)
    above = clip.predict(*g, 1.5 * vmax * Vc, t)
    if edge["status"] in ANSWERED:
        assert above["status"] == Status.EXTRAPOLATED
        for n in PAIR_NAMES:
            assert above[n] == pytest.approx(float(edge[n]), rel=1e-9)
    below = clip.predict(*g, 0.5 * vmin * Vc, t)
    assert below["status"] in (Status.OUT_OF_RANGE, Status.NO_EQUILIBRIUM,
                               Status.NOT_CONVERGED)
    assert np.isnan(below["f12"])


@pytest.mark.parametrize("args, match", [
    # a DEM overlap (down to -CONTACT_OVERLAP_MAX = -0.05) is a contact; deeper is refused
    ((-0.1, 0.05, 0.05, 0.3, 30), r"gap d12=-0\.1.*\[-0.05, inf\)"),
    ((np.nan, 0.05, 0.05, 0.3, 30), r"gap d12=nan"),
    ((0.05, 0.05, 0.05, -0.3, 30), r"volume V\*=-0\.3.*\(0, inf\)"),
    ((0.05, 0.05, 0.05, np.nan, 30), r"volume V\*=nan"),
    ((0.05, 0.05, 0.05, 0.0, 30), r"volume V\*=0\.0"),
    ((0.05, 0.05, 0.05, 0.3, 90), r"theta=90\.0 deg.*\[0, 90\)"),
    ((0.05, 0.05, 0.05, 0.3, -5), r"theta=-5\.0 deg"),
    ((0.05, 0.05, 0.05, 0.3, np.nan), r"theta=nan"),
    ((0.0, 0.0, 2.5, 0.3, 30), r"do not form a triangle"),
    ((0.05, 0.05, 5.0, 0.3, 30), r"do not form a triangle"),
    ((0.05, 0.05, 1.0, 0.3, 30), r"gap d23=1\.0 is outside the triplet table's range"),
    (("x", 0.05, 0.05, 0.3, 30), r"not a number"),
])
def test_bad_input_is_one_clear_error(sur, args, match):
    with pytest.raises(CapbridgeInputError, match=match) as exc:
        sur.predict(*args)
    assert "\n" not in str(exc.value)


def test_theta_outside_table_is_an_error_even_with_clip(table):
    clip = TripletSurrogate(out_of_range="clip").fit(table)
    top = float(table["theta"].values[-1])
    if top < 89:
        with pytest.raises(CapbridgeInputError, match="theta=.*outside the triplet table"):
            clip.predict(0.05, 0.05, 0.05, 0.3, top + 0.5)


def test_vectors_and_si_inputs(sur):
    good = np.array([[0.0, 0, 0], [2.1, 0, 0], [1.05, 0, 1.9]])
    with pytest.raises(CapbridgeInputError, match="overlap"):
        sur.predict_vectors(good * 0.9, 0.3, 30)
    with pytest.raises(CapbridgeInputError, match=r"shape \(\.\.\., 3, 3\)"):
        sur.predict_vectors(good[:2], 0.3, 30)
    with pytest.raises(CapbridgeInputError, match="predict_si radius=1.0 m"):
        sur.predict_si(1.0, 0.072, good * 1e-3, 1e-10, 30)          # radius in mm
    with pytest.raises(CapbridgeInputError, match="surface_tension=72.0 N/m"):
        sur.predict_si(1e-3, 72.0, good * 1e-3, 1e-10, 30)          # gamma in mN/m
    with pytest.raises(CapbridgeInputError, match="predict_si volume"):
        sur.predict_si(1e-3, 0.072, good * 1e-3, -1e-10, 30)


def test_si_and_scaling(sur):
    """Equal radii R: the equal-sphere answer scaled exactly; SI = dimensionless x
    2 pi gamma R; unequal radii: APPROXIMATE, never silent."""
    g, t, V = _inside(sur, 20, 8)
    a, b, c = 2 + g
    x3 = (a * a + b * b - c * c) / (2 * a)
    C = np.zeros((20, 3, 3))
    C[:, 1, 0] = a
    C[:, 2, 0], C[:, 2, 2] = x3, np.sqrt(b * b - x3 * x3)
    r1 = sur.predict_vectors(C, V, t)
    ok = np.isin(r1["status"], ANSWERED)
    R = 1.7
    r2 = sur.predict_vectors(C * R, V * R**3, t, radii=np.full(3, R))
    np.testing.assert_allclose(r2["forces"][ok], R * r1["forces"][ok], rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(r2["status"], r1["status"])
    Rm, gamma = 2e-3, 0.072
    si = sur.predict_si(Rm, gamma, C * Rm, V * Rm**3, t)
    np.testing.assert_allclose(si["forces"][ok], r1["forces"][ok] * 2 * np.pi * gamma * Rm,
                               rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(si["pressure"][ok], r1["pressure"][ok] * gamma / Rm, rtol=1e-12)
    # unequal radii
    radii = np.array([1.0, 1.0 + 1e-6, 1.0])
    Cu = C.copy()
    Cu[:, 1, 0] += 1e-6
    r3 = sur.predict_vectors(Cu, V, t, radii=radii)
    assert np.all(r3["status"][ok] == Status.APPROXIMATE)
    assert Status.APPROXIMATE in HAS_RESULT
    np.testing.assert_allclose(r3["forces"][ok], r1["forces"][ok], rtol=1e-4, atol=1e-5)


def test_coalescence_table_plugs_in(table, sur):
    """A coalescence table on the triplet table's own grid with its own values keeps
    V*_coal at the nodes; its linear law is used for V0, dV; one that does not cover
    the table is refused."""
    axes = {d: table[d] for d in ("d12", "d13", "d23", "theta")}
    Vc = table["volume_coalescence"]
    V0 = xr.DataArray(np.full(Vc.shape[:3], 0.123), dims=("d12", "d13", "d23"))
    dc = xr.Dataset({"V_coal_pair": Vc, "V0_pair": V0, "dV_pair": V0 * 2}, coords=axes)
    s = TripletSurrogate().fit(table, coalescence_table=dc)
    G = np.meshgrid(*(table[d].values for d in ("d12", "d13", "d23", "theta")),
                    indexing="ij")
    np.testing.assert_allclose(s.coalescence_volume(*G)["volume_coalescence"], Vc.values,
                               rtol=1e-12)
    g, t, V = _inside(sur, 100, 9)
    b = s.coalescence_volume(*g, t)
    np.testing.assert_allclose(b["V0"], 0.123, rtol=1e-12)
    np.testing.assert_allclose(b["dV"], 0.246, rtol=1e-12)
    small = dc.assign_coords({d: dc[d] * 0.5 for d in ("d12", "d13", "d23")})
    with pytest.raises(CapbridgeInputError, match="covers gaps"):
        TripletSurrogate().fit(table, coalescence_table=small)


def test_linear_law_without_coalescence_table(sur, table):
    """V0 + (theta/90) dV is the least-squares line of the table's V*_coal over theta."""
    th = table["theta"].values
    Vc = table["volume_coalescence"].values[0, 1, -1]
    A = np.stack([np.ones_like(th), th / 90], 1)
    coef = np.linalg.lstsq(A, Vc, rcond=None)[0]
    g = table["d12"].values
    r = sur.predict(g[0], g[1], g[-1], Vc[1] * table["v"].values[1], th[1])
    assert r["V0"] == pytest.approx(coef[0], rel=1e-9)
    assert r["dV"] == pytest.approx(coef[1], rel=1e-9)


@pytest.mark.slow
def test_lower_energy_state(table, sur):
    """Without separated energies the state is 'unknown'; with them, the sign of
    E_coalesced - E_separated beyond the energy error decides."""
    g, t, V = _inside(sur, 50, 10)
    bare = TripletSurrogate().fit(_editable(table).drop_vars("energy_separated",
                                                            errors="ignore"))
    r = bare.predict(*g, V, t)
    assert np.all(r["lower_energy_state"] == 3) and LOWER_ENERGY_STATES[3] == "unknown"
    E = table["energy_extrapolated"]
    for shift, code in ((1.0, 0), (-1.0, 1), (0.0, 2)):
        s = TripletSurrogate().fit(table, separated_energy=(E + shift).rename(
            "energy_separated"))
        r = s.predict(*g, V, t)
        ok = np.isin(r["status"], ANSWERED)
        assert np.all(r["lower_energy_state"][ok] == code), shift
        np.testing.assert_allclose(r["energy_difference"][ok], -shift, atol=1e-9)
        assert np.all(r["lower_energy_state"][~ok] == 3)


def test_summary_for_info(sur):
    """The error model and fit description are JSON-ready and count every cell."""
    import json

    d = json.loads(json.dumps(sur.summary()))
    n_cells = int(np.prod([len(x) - 1 for x in (d["gaps"],) * 3 + (d["theta"], d["v"])]))
    assert sum(d["cells"].values()) == n_cells
    assert d["holdout_error"] is None or d["holdout_error"]["n"] >= 1


def test_coalescence_volume_against_exact(table, coalescence_table):
    """V*_coal against exact coalescence volumes (benchmarks/triplet_vcoal_exact.json,
    find_coalescence at random geometries): within 3 % from the triplet table alone
    (measured 2.6 % max on the shipped grid), within 0.3 % with the coalescence table
    (measured 0.12 %)."""
    import json

    root = Path(__file__).resolve().parents[1]
    pts = [p for p in json.loads((root / "benchmarks" / "triplet_vcoal_exact.json")
                                 .read_text())["points"] if p["V_coal"]]
    g = np.array([p["gaps"] for p in pts]).T
    t = np.array([p["theta"] for p in pts])
    V = np.array([p["V_coal"] for p in pts])
    for ct, tol in ((None, 3e-2), (coalescence_table, 3e-3)):
        if tol < 1e-2 and ct is None:
            continue
        s = TripletSurrogate().fit(table, coalescence_table=ct)
        inside = s.covers(*g, t)
        if inside.sum() < 5:
            pytest.skip("the table covers fewer than 5 of the exact points")
        r = s.coalescence_volume(*(x[inside] for x in g), t[inside])
        assert np.max(np.abs(r["volume_coalescence"] / V[inside] - 1)) < tol


def test_lower_energy_state_without_separated_states(table, sur):
    """NaN energy_separated means no separated state exists: where no node of the cell
    has one, the coalesced body is the lower (only) state; forces are unaffected."""
    g, t, V = _inside(sur, 50, 12)
    E = table["energy_extrapolated"] * np.nan
    s = TripletSurrogate().fit(table, separated_energy=E.rename("energy_separated"))
    r, a = s.predict(*g, V, t), sur.predict(*g, V, t)
    ok = np.isin(r["status"], ANSWERED)
    assert np.all(r["lower_energy_state"][ok] == 0)
    for n in PAIR_NAMES:
        np.testing.assert_array_equal(r[n], a[n])


def test_covers_matches_predict_vectors_with_radii(sur):
    """covers(..., radii) says True exactly where predict_vectors(radii) does not raise
    for the gaps (unequal radii, default scheme)."""
    rng = np.random.default_rng(13)
    R = rng.uniform(1.0, 2.0, (40, 3))
    g = rng.uniform(0.0, 1.6 * sur.gaps_[-1], (40, 3))
    t = np.full(40, sur.theta_[1])
    cov = sur.covers(g[:, 0], g[:, 1], g[:, 2], t, radii=R)
    L = np.stack([g[:, m] + R[:, a] + R[:, b] for m, (a, b) in enumerate(PAIRS)], 1)
    for k in range(40):
        a, b, c = L[k]
        x3 = (a * a + b * b - c * c) / (2 * a)
        C = np.array([[0, 0, 0], [a, 0, 0], [x3, 0, np.sqrt(b * b - x3 * x3)]])
        Rh = 3 / np.sum(1 / R[k])
        Vc = sur.coalescence_volume(*np.clip(g[k] / Rh, sur.gaps_[0], sur.gaps_[-1]), t[k])
        V = 1.2 * float(Vc["volume_coalescence"]) * Rh**3
        try:
            sur.predict_vectors(C, V, t[k], radii=R[k])
            answered = True
        except CapbridgeInputError as exc:
            answered = "v = V*/V*_coal" in str(exc)     # a volume matter, not the gaps
        assert answered == bool(cov[k]), (k, g[k], R[k])


def _cut_at(ds, max_bridge_gap):
    """A copy of a triplet table computed only where its middle gap is at most
    ``max_bridge_gap`` (the rest NOT_COMPUTED / NaN, the grid attribute saying so), as
    `TripletGrid.packings()` tables are; no checksum (an edited copy)."""
    import json

    from capbridge.status import Status as St

    cut = ds.copy(deep=True)
    g = cut.d12.values
    mid = np.median(np.stack(np.meshgrid(g, g, g, indexing="ij")), axis=0)
    out = mid > max_bridge_gap + 1e-12
    for name, var in cut.data_vars.items():
        if var.dims[:3] == ("d12", "d13", "d23"):
            if name == "status":
                var.values[out] = St.NOT_COMPUTED
            elif np.issubdtype(var.dtype, np.floating):
                var.values[out] = np.nan
    for k in ("table_sha256", "data_sha256"):
        cut.attrs.pop(k, None)
    grid = json.loads(cut.attrs["grid"])
    grid["max_bridge_gap"] = max_bridge_gap
    cut.attrs["grid"] = json.dumps(grid)
    return cut


def test_a_table_computed_over_part_of_its_cube(shipped_triplet_table):
    """A table made on a grid with ``max_bridge_gap`` (TripletGrid.packings(): the two
    smaller gaps up to it, the open side over the whole axis) stores the rest of its
    cube as not computed: the surrogate says it does not cover those geometries and
    refuses them in one line, and answers inside exactly as the full table does where
    no cell touches the missing nodes (linear: local).  Here: the shipped table cut at
    max_bridge_gap = 0.1."""
    from capbridge.tables.netcdf_io import read_table

    ds = read_table(shipped_triplet_table)
    cut = _cut_at(ds, 0.1)
    cut = cut.drop_vars([v for v in cut.data_vars
                         if v.startswith(("holdout", "gravity_holdout"))])
    full = TripletSurrogate(method="linear").fit(ds)
    sur = TripletSurrogate(method="linear").fit(cut)
    assert sur.max_bridge_gap_ == 0.1 and full.max_bridge_gap_ is None
    np.testing.assert_array_equal(sur.covers([0.05, 0.0, 0.15], [0.15, 0.05, 0.0],
                                             [0.15, 0.2, 0.05], 30.0), [False, True, True])
    with pytest.raises(CapbridgeInputError, match="max_bridge_gap 0.1"):
        sur.predict(0.05, 0.15, 0.15, 0.3, 30.0)
    # inside, cells [0, 0.1]^2 x [0.1, 0.2] and relabellings: all their nodes computed
    d = (np.array([0.0, 0.05, 0.15]), np.array([0.05, 0.15, 0.02]), np.array([0.15, 0.02, 0.08]))
    a, b = full.predict(*d, 0.3, 30.0), sur.predict(*d, 0.3, 30.0)
    for k in ("f12", "f13", "f23", "pressure", "volume_coalescence", "status"):
        np.testing.assert_array_equal(b[k], a[k])
    assert np.isin(b["status"], HAS_RESULT).all()
    # cubic splines across the gaps would run through the not-computed nodes (measured
    # up to 3 % off inside): refused; "auto" is cubic in theta and v, linear in the gaps,
    # and answers inside exactly as the full table does with that method
    with pytest.raises(CapbridgeInputError, match="cubic_tv"):
        TripletSurrogate(method="cubic").fit(cut)
    auto = TripletSurrogate(method="auto").fit(cut)
    assert auto.method_ == "cubic_tv" and auto.method == "auto"
    ref = TripletSurrogate(method="cubic_tv").fit(ds)
    a, b = ref.predict(*d, 0.3, 30.0), auto.predict(*d, 0.3, 30.0)
    for k in ("f12", "f13", "f23", "status"):
        np.testing.assert_array_equal(b[k], a[k])
    assert TripletSurrogate(method="auto").fit(ds).method_ == "cubic"


def test_the_default_coalescence_table_only_where_it_covers(tmp_path, shipped_triplet_table):
    """The loaders fit a triplet table with the shipped coalescence table only if that
    covers its gaps and angles (the packings grid's open side reaches 0.6, the shipped
    coalescence table's gaps 0.3): else the table's own V*_coal nodes."""
    from capbridge.surrogate.load import default_coalescence_table
    from capbridge.tables import COALESCENCE_TABLE

    assert default_coalescence_table(shipped_triplet_table) == COALESCENCE_TABLE
    wide = read_table(shipped_triplet_table)
    wide = wide.assign_coords(d12=wide.d12.values * 3)        # gaps to 0.6
    path = tmp_path / "wide.nc"
    wide.to_netcdf(path)
    assert default_coalescence_table(path) is None
    assert default_coalescence_table(shipped_triplet_table, tmp_path / "none.nc") is None


def test_auto_refine_fits_the_fine_grid_in_its_budget(shipped_triplet_table, monkeypatch):
    """refine="auto" (the default) takes DEFAULT_REFINE for the shipped table and, for a
    table whose fine grid would exceed AUTO_GRID_BYTES, the first coarser entry of
    AUTO_REFINE that fits (here the budget is shrunk to make the shipped table large);
    an explicit refine is kept as given."""
    import capbridge.surrogate.triplet as tri

    ds = read_table(shipped_triplet_table)
    assert TripletSurrogate().fit(ds).refine_ == tri.DEFAULT_REFINE
    monkeypatch.setattr(tri, "AUTO_GRID_BYTES", 2e6)
    sur = TripletSurrogate().fit(ds)
    assert sur.refine_ != tri.DEFAULT_REFINE and sur.refine_ in tri.AUTO_REFINE
    n_fine = np.prod([a.n for a in sur.axes_])
    assert n_fine * (len(tri.GRID_VARIABLES) + 1) * 8 <= 2e6
    # the previous entry would not have fitted
    k = tri.AUTO_REFINE.index(sur.refine_)
    rg, rt, rv = tri.AUTO_REFINE[k - 1]
    sizes = [ds.sizes[d] for d in ("d12", "d13", "d23", "theta", "v")]
    steps = (rg, rg, rg, rt, rv)
    assert np.prod([(n - 1) * s + 1 for n, s in zip(sizes, steps)]) * \
        (len(tri.GRID_VARIABLES) + 1) * 8 > 2e6
    assert TripletSurrogate(refine=(1, 2, 2)).fit(ds).refine_ == (1, 2, 2)


def test_error_model_of_a_table_computed_over_part_of_its_cube(shipped_triplet_table,
                                                               tmp_path):
    """The held-out error model of a table with ``max_bridge_gap`` (what `generate
    triplet --grid packings` stores at the end of its sweep) is fitted with the method
    that table allows (auto: linear in the gaps), not refused; the written table keeps
    its ``max_bridge_gap`` (the grid attribute is rewritten from the coordinates), so
    the surrogate fitted from the file is the one the error model describes."""
    import json

    from capbridge.surrogate.error_model import store_triplet_error_model

    cut = _cut_at(read_table(shipped_triplet_table), 0.1)
    hg = np.sort(np.stack([cut[f"holdout_{d}"].values for d in ("d12", "d13", "d23")]), 0)
    cut = cut.isel(holdout=np.flatnonzero(hg[1] <= 0.1))
    assert cut.sizes["holdout"] >= 3
    cut = cut.drop_vars([v for v in cut.data_vars if "gravity" in v])   # no response
    cut = cut.drop_dims([d for d in cut.dims if "gravity" in d])
    for k in [k for k in cut.attrs if k.startswith("gravity")]:
        cut.attrs.pop(k)
    with pytest.raises(CapbridgeInputError, match="cubic_tv"):
        TripletSurrogate(method="cubic").fit(cut)
    store_triplet_error_model(cut)
    assert cut.attrs["holdout_n_by_v"] >= 3
    assert np.isfinite(cut.attrs["holdout_median_rel_error_pair_force_by_v"])
    from capbridge.surrogate.triplet_holdout import holdout_errors
    from capbridge.tables.triplet import save_triplet_table

    path = tmp_path / "cut.nc"
    save_triplet_table(cut, path, command="test")
    back = read_table(path)
    assert json.loads(back.attrs["grid"])["max_bridge_gap"] == 0.1
    sur = TripletSurrogate(method="auto").fit(back)
    assert sur.max_bridge_gap_ == 0.1 and sur.method_ == "cubic_tv"
    e = holdout_errors(sur, by="v")
    assert e["median_rel_error"] == pytest.approx(
        back.attrs["holdout_median_rel_error_pair_force_by_v"], rel=1e-12)


def test_refine_words_other_than_auto_are_refused_in_one_line():
    """refine='fine' names the value and what is allowed (no traceback of int())."""
    with pytest.raises(CapbridgeInputError, match="give 'auto', one integer or three"):
        TripletSurrogate(refine="fine")
