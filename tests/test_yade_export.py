"""Export of capbridge tables to YADE's native capillary files, checked in real YADE.

Pure-Python tests check the writers (columns, order, normalisation, round trip); the
tests marked ``yade`` write files, load them in Debian's YADE 2023.02a through the
scenes in ``tests/yade_scenes`` and compare the force YADE applies with the table.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_export as ye
from capbridge.yade import yade_runtime as yr
from capbridge.status import Status

SCENES = Path(__file__).parent / "yade_scenes"
GAMMA = 0.073          # N/m
R_SMALL = 1e-3         # m, the normalising radius r
REL_TOL = 5e-3         # the 0.5 %



@pytest.fixture(scope="module")
def table():
    return ye.synthetic_suction_table(theta=0.0)


@pytest.fixture(scope="module")
def table30():
    return ye.synthetic_suction_table(theta=30.0)


def _si_suction(s_star):
    return s_star * GAMMA / R_SMALL


def _gaps_arg(gaps):
    return "--gaps=" + ",".join(repr(float(g)) for g in gaps)


# --------------------------------------------------------------------------------------
# Pure Python: the M(r=...) writer
# --------------------------------------------------------------------------------------


def test_unit_conversion_round_trip():
    rho = np.array([1.0, 1.5, 10.0])
    y = ye.to_yade_units(rho, suction=2.0, gap=0.3, volume=0.05, force=0.9)
    np.testing.assert_allclose(y["P"], 2.0 * rho)
    np.testing.assert_allclose(y["D"], 0.3 / rho)
    np.testing.assert_allclose(y["V"], 0.05 / rho**3)
    np.testing.assert_allclose(y["F"], 0.9 / rho)
    yd = ye.to_yade_units(rho, force=0.9, delaunay=True)
    np.testing.assert_allclose(yd["F"], 2 * np.pi * 0.9 / rho)   # F/(gamma R): no 2 pi
    back = ye.from_yade_units(rho, P=y["P"], D=y["D"], V=y["V"], F=y["F"])
    np.testing.assert_allclose(back["suction"], 2.0)
    np.testing.assert_allclose(back["gap"], 0.3)
    np.testing.assert_allclose(back["volume"], 0.05)
    np.testing.assert_allclose(back["force"], 0.9)


def test_si_force_is_independent_of_the_normalising_radius():
    """F = F*_capbridge 2 pi gamma r = F_yade 2 pi gamma R for the same bridge."""
    r, rho, f_star = 1e-3, 2.0, 0.8
    f_yade = ye.to_yade_units(rho, force=f_star)["F"]
    assert math.isclose(f_star * 2 * np.pi * GAMMA * r, f_yade * 2 * np.pi * GAMMA * rho * r)


def test_file_names_and_suffix(tmp_path, table):
    paths = ye.write_capillary_files(table, tmp_path, ye.theta_suffix(0))
    names = [p.name for p in paths]
    assert names[:10] == ["M(r=1)_theta0", "M(r=1.1)_theta0", "M(r=1.25)_theta0",
                          "M(r=1.5)_theta0", "M(r=1.75)_theta0", "M(r=2)_theta0",
                          "M(r=3)_theta0", "M(r=4)_theta0", "M(r=5)_theta0",
                          "M(r=10)_theta0"]
    manifest = json.loads(paths[10].read_text())
    assert manifest["engine_attributes"] == {"suffCapFiles": "_theta0"}
    assert manifest["theta_deg"] == 0.0


def test_file_layout(tmp_path, table):
    ye.write_capillary_files(table, tmp_path)
    for rho in ye.YADE_RATIOS:
        lines = (tmp_path / ye.capillary_file_name(rho)).read_text().splitlines()
        assert float(lines[0]) == rho
        n_d = int(lines[1])
        pos, d_prev = 2, -1.0
        for _ in range(n_d):
            header = lines[pos].split()
            n = int(header[0])
            assert len(header) == 8 and all(float(x) == 0 for x in header[1:])
            rows = np.array([[float(x) for x in lines[pos + 1 + k].split("\t")]
                             for k in range(n)])
            assert rows.shape == (n, 8) and n >= 2
            assert np.all(rows[:, 0] == rows[0, 0])           # one distance per block
            assert np.all(np.diff(rows[:, 1]) > 0)            # P increasing
            assert rows[0, 0] > d_prev                        # D increasing
            if d_prev < 0:
                assert rows[0, 0] == 0.0                      # first block at contact
            d_prev = rows[0, 0]
            pos += n + 1
        assert pos == len(lines)


def test_round_trip_values_and_normalisation(tmp_path, table):
    ye.write_capillary_files(table, tmp_path, "_x")
    files = ye.read_capillary_files(tmp_path, "_x")
    n_edge_rows = 0
    for (rho, blocks), r_expected in zip(files, ye.YADE_RATIOS):
        assert rho == r_expected
        i = table.ratio_index(rho)
        edge = table.edge_points(i)
        for D, rows in blocks:
            k = int(np.argmin(np.abs(table.gap - D * rho)))
            np.testing.assert_allclose(table.gap[k], D * rho, rtol=1e-12, atol=1e-15)
            back = ye.from_yade_units(rho, P=rows[:, 1], V=rows[:, 2], F=rows[:, 3])
            j = np.clip(np.searchsorted(table.suction, back["suction"] - 1e-12), 0,
                        table.suction.size - 1)
            on_grid = np.isclose(table.suction[j], back["suction"], rtol=1e-12, atol=1e-15)
            # grid rows: the table's converged bridges
            g = on_grid
            assert np.all(table.status[i, j[g], k] == int(Status.CONVERGED))
            np.testing.assert_allclose(back["volume"][g], table.volume[i, j[g], k], rtol=1e-13)
            np.testing.assert_allclose(back["force"][g], table.force[i, j[g], k], rtol=1e-13)
            np.testing.assert_allclose(rows[g, 4], table.beta1[i, j[g], k], rtol=1e-13)
            np.testing.assert_allclose(rows[g, 5], table.beta2[i, j[g], k], rtol=1e-13)
            # at most one other row, the last: the bridge rupturing at this very gap
            assert (~on_grid).sum() <= 1 and (on_grid[:-1]).all()
            if not on_grid[-1]:
                n_edge_rows += 1
                e = np.flatnonzero(np.isclose(edge["gap"], table.gap[k], rtol=1e-12)
                                   & np.isclose(edge["suction"], back["suction"][-1], rtol=1e-12))
                assert e.size == 1
                assert math.isclose(back["force"][-1], edge["force"][e[0]], rel_tol=1e-13)
                assert math.isclose(back["volume"][-1], edge["volume"][e[0]], rel_tol=1e-13)
            assert np.all(rows[:, 6:] == 0.0)                 # nn11, nn33 not computed
    assert n_edge_rows > 0


def test_blocks_stop_at_rupture():
    for with_edge in (False, True):
        table = ye.synthetic_suction_table(edge=with_edge)
        i = table.ratio_index(2.0)
        blocks, rep = ye.capillary_file_blocks(table, i)
        conv = table.converged[i]
        edge = table.edge_points(i)
        extra = np.array([np.isclose(edge["gap"], g, rtol=1e-12).any() for g in table.gap])
        n_rows = conv.sum(axis=0) + extra
        short = np.flatnonzero(n_rows < 2)
        assert len(blocks) == short[0]                        # contiguous from gap 0
        for k, (_, rows) in enumerate(blocks):
            assert len(rows) == n_rows[k]                     # every bridge written
            assert np.all(np.diff(rows[:, 1]) > 0)
        assert rep["rupture_rows"] == (extra[:len(blocks)].sum() if with_edge else 0)
        assert rep["interior_points_missing"] == 0
        assert rep["converged_points_not_written"] == 0


def test_emulated_interpolation_hits_table_nodes(tmp_path, table):
    ye.write_capillary_files(table, tmp_path)
    files = ye.read_capillary_files(tmp_path)
    i, j, k = table.ratio_index(1.5), 6, 4
    rho = 1.5
    y = ye.to_yade_units(rho, suction=table.suction[j], gap=table.gap[k])
    res = ye.law2_interpolate(files, rho, float(y["D"]), float(y["P"]))
    assert math.isclose(res["F"] * rho, table.force[i, j, k], rel_tol=1e-12)
    # half-way between two gaps: linear in D
    y2 = ye.to_yade_units(rho, gap=0.5 * (table.gap[k] + table.gap[k + 1]))
    res2 = ye.law2_interpolate(files, rho, float(y2["D"]), float(y["P"]))
    mid = 0.5 * (table.force[i, j, k] + table.force[i, j, k + 1])
    assert math.isclose(res2["F"] * rho, mid, rel_tol=1e-12)
    # beyond the last block: no bridge
    far = ye.law2_interpolate(files, rho, 10.0, float(y["P"]))
    assert far["V"] == 0.0 and far["F"] == 0.0


def test_missing_ratios(tmp_path):
    small = ye.synthetic_suction_table(ratios=(1.0,))
    with pytest.raises(ValueError, match="lacks radius ratios"):
        ye.write_capillary_files(small, tmp_path)
    with pytest.warns(UserWarning, match="placeholder"):
        paths = ye.write_capillary_files(small, tmp_path, missing="stub")
    ratio, blocks = ye.read_capillary_file(paths[1])
    assert ratio == 1.1 and len(blocks) == 1 and np.all(blocks[0][1][:, 2:] == 0)


def test_gap_axis_must_start_at_contact(tmp_path):
    t = ye.synthetic_suction_table(gaps=np.linspace(0.01, 0.5, 10))
    with pytest.raises(ValueError, match="must start at 0"):
        ye.write_capillary_files(t, tmp_path)


def test_bad_tables_are_refused():
    t = ye.synthetic_suction_table(ratios=(1.0,))
    with pytest.raises(ValueError, match="R2/R1 must be >= 1"):
        ye.SuctionTable(ratio=[0.5], suction=t.suction, gap=t.gap, volume=t.volume,
                        force=t.force, beta1=t.beta1, beta2=t.beta2, status=t.status)
    vol = t.volume.copy()
    vol[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="converged points"):
        ye.SuctionTable(ratio=t.ratio, suction=t.suction, gap=t.gap, volume=vol,
                        force=t.force, beta1=t.beta1, beta2=t.beta2, status=t.status)


def test_from_xarray_dataset_with_pressure_axis(table):
    xr = pytest.importorskip("xarray")
    dims = ("ratio", "pressure", "gap")
    ds = xr.Dataset({k: (dims, getattr(table, k)) for k in
                     ("volume", "force", "beta1", "beta2", "status")},
                    coords={"ratio": table.ratio, "pressure": -table.suction, "gap": table.gap},
                    attrs={"theta": 0.0})
    back = ye.SuctionTable.from_dataset(ds)
    np.testing.assert_array_equal(back.suction, table.suction)
    np.testing.assert_array_equal(back.force, table.force)
    assert back.theta == 0.0


# --------------------------------------------------------------------------------------
# Pure Python: the CapillarityEngine file
# --------------------------------------------------------------------------------------


def test_delaunay_records(tmp_path, table):
    paths = ye.write_delaunay_file(table, tmp_path / "capillaryfile.txt")
    d = ye.read_delaunay_file(paths[0])
    assert list(d) == list(ye.DELAUNAY_COLUMNS)
    real = (d["ending"] == 0) & (d["distance"] >= 0) & (d["R"] <= 1.0) & (d["R"] >= 0.1)
    # grid bridges, plus the rupture point of every line that has one past its last bridge
    n_line_ends = 0
    for i in range(table.ratio.size):
        e = table.edge_points(i)
        for j, s_j in enumerate(table.suction):
            last_gap = table.gap[np.flatnonzero(table.converged[i, j])[-1]]
            n_line_ends += int(np.any(np.isclose(e["suction"], s_j, rtol=1e-12, atol=1e-15)
                                      & (e["gap"] > last_gap)))
    assert real.sum() == table.converged.sum() + n_line_ends
    # one bridge, converted by hand: ratio 2, suction index 3, gap index 5
    rho, j, k = 2.0, 3, 5
    i = table.ratio_index(rho)
    hit = (real & np.isclose(d["R"], 1 / rho) & np.isclose(d["succion"], table.suction[j] * rho)
           & np.isclose(d["distance"], table.gap[k] / rho))
    assert hit.sum() == 1
    rec = {c: d[c][hit][0] for c in d}
    assert math.isclose(rec["force"], 2 * np.pi * table.force[i, j, k] / rho, rel_tol=1e-13)
    assert math.isclose(rec["volume"], table.volume[i, j, k] / rho**3, rel_tol=1e-13)
    assert math.isclose(rec["delta1"], table.beta1[i, j, k], rel_tol=1e-13)
    dry = 2 * np.pi * ((1 + np.cos(np.radians(table.beta1[i, j, k])))
                       + rho**2 * (1 + np.cos(np.radians(table.beta2[i, j, k]))))
    assert math.isclose(rec["surface"], (table.area[i, j, k] + dry) / rho**2, rel_tol=1e-13)


def test_delaunay_end_markers_and_pads(table):
    rec = ye.delaunay_records(table, overlap_pad=0.05, ratio_pad=0.01)
    cols = {c: rec[:, n] for n, c in enumerate(ye.DELAUNAY_COLUMNS)}
    marker = cols["ending"] == 1
    assert np.all(cols["force"][marker] == 0)
    # one marker per (ratio, suction) line that ruptures inside the gap grid, plus the
    # copies of the extreme ratios' markers (R = 1.01 and R = 0.099)
    rupturing = ~table.converged[:, :, -1] & table.converged[:, :, 0]
    assert marker.sum() == rupturing.sum() + rupturing[0].sum() + rupturing[-1].sum()
    # a line ends at its rupture point, then a marker a tenth of a gap step further
    i, j = table.ratio_index(1.0), 10
    last = np.flatnonzero(table.converged[i, j])[-1]
    line = np.isclose(cols["R"], 1.0) & np.isclose(cols["succion"], table.suction[j])
    g_rupt = ye.synthetic_bridge(1.0, table.suction[j], 0.0)["g_rupt"]
    assert np.isclose(cols["distance"][line & ~marker].max(), g_rupt)
    step = table.gap[last + 1] - table.gap[last]
    assert np.allclose(cols["distance"][line & marker], g_rupt + 0.02 * step)
    # without rupture points: the marker sits at the next gap of the grid
    plain = ye.synthetic_suction_table(edge=False)
    rec0 = ye.delaunay_records(plain)
    m0 = ((rec0[:, 9] == 1) & np.isclose(rec0[:, 8], 1.0)
          & np.isclose(rec0[:, 0], table.suction[j]))
    assert np.allclose(rec0[m0, 2], table.gap[last + 1])
    assert np.all(cols["distance"] >= -0.05)
    assert np.isclose(cols["R"].max(), 1.01) and np.isclose(cols["R"].min(), 0.1 * 0.99)
    assert np.all(np.isfinite(rec))


def test_delaunay_single_ratio_needs_padding():
    t = ye.synthetic_suction_table(ratios=(1.0,))
    with pytest.raises(ValueError, match="3-D point set"):
        ye.delaunay_records(t, ratio_pad=0.0)
    rec = ye.delaunay_records(t, ratio_pad=0.01)
    assert set(np.round(rec[:, 8], 12)) == {0.99, 1.0, 1.01}
    assert ye.delaunay_records(ye.synthetic_suction_table(ratios=(2.0,)))[:, 8].min() == 0.5 * 0.99


# --------------------------------------------------------------------------------------
# Glue to the exact solver
# --------------------------------------------------------------------------------------


def test_export_from_solver_glue(tmp_path, monkeypatch):
    """The glue with a stand-in solver (same signature and keys as the real one)."""
    from capbridge.solvers import young_laplace

    calls = []

    def fake_solve_doublet_suction(gap, pressure, theta, ratio=1.0):
        calls.append(float(ratio))
        return fake_bridge(gap, pressure, theta, ratio)

    def fake_bridge(gap, pressure, theta, ratio):
        syn = ye.synthetic_suction_table(ratios=(ratio,), suctions=[0.0], gaps=[0.0], theta=theta)
        g, s = np.broadcast_arrays(np.asarray(gap, float), -np.asarray(pressure, float))
        f = syn.force[0, 0, 0] * (1 - g) * (1 + 0.01 * s)
        return {"force": f, "volume": 0.02 * (1 + g) / (1 + s), "pressure": -s,
                "beta1": 30 - 5 * g, "beta2": (30 - 5 * g) / ratio, "neck_radius": 0.1 + 0 * g,
                "area": 0.1 + 0 * g,
                "status": np.where(g < 0.3 / (1 + 0.1 * s), 0, 1)}

    def fake_suction_rupture_distance(pressure, theta, ratio=1.0):
        s = -np.asarray(pressure, float)
        g = 0.3 / (1 + 0.1 * s)                     # the fake's rupture gap
        out = fake_bridge(g * (1 - 1e-12), pressure, theta, ratio)
        out["gap"] = g
        return out

    monkeypatch.setattr(young_laplace, "solve_doublet_suction", fake_solve_doublet_suction,
                        raising=False)
    monkeypatch.setattr(young_laplace, "suction_rupture_distance",
                        fake_suction_rupture_distance, raising=False)
    tab, paths = ye.export_from_solver(tmp_path, 20.0, suctions=[0, 1, 2, 5],
                                       gaps=np.linspace(0, 0.5, 11))
    assert calls == list(ye.YADE_RATIOS)
    assert tab.theta == 20.0 and tab.shape == (10, 4, 11)
    # rupture points: at the grid suctions, and at the grid gaps 0.25 and 0.2 (s = 2, 5)
    e = tab.edge_points(0)
    np.testing.assert_allclose(e["gap"][:4], 0.3 / (1 + 0.1 * np.array([0, 1, 2, 5])))
    at_grid_gaps = e["gap"][4:]
    np.testing.assert_allclose(at_grid_gaps, [0.2, 0.25])
    np.testing.assert_allclose(e["suction"][4:], (0.3 / at_grid_gaps - 1) / 0.1, rtol=1e-8)
    names = {p.name for p in paths}
    assert "M(r=1)_theta20" in names and "capillaryfile_theta20.txt" in names
    files = ye.read_capillary_files(tmp_path, "_theta20")
    y = ye.to_yade_units(2.0, suction=2.0, gap=0.1)
    got = ye.law2_interpolate(files, 2.0, float(y["D"]), float(y["P"]))["F"] * 2.0
    assert math.isclose(got, tab.force[5, 2, 2], rel_tol=1e-12)


# --------------------------------------------------------------------------------------
# In YADE
# --------------------------------------------------------------------------------------


def _run_law2(directory, suffix, ratio, s_star, gaps_star, mode="python", mindlin=False):
    args = ["--dir", str(directory), "--suffix", suffix, "--r1", R_SMALL, "--r2", ratio * R_SMALL,
            "--suction", _si_suction(s_star), "--gamma", GAMMA,
            _gaps_arg(np.asarray(gaps_star) * R_SMALL)]
    if mindlin:
        args.append("--mindlin")
    return yr.run_yade_script(SCENES / "two_spheres_law2.py", args, timeout=120, mode=mode).result


@pytest.fixture(scope="module")
def law2_dir(tmp_path_factory, table, table30):
    d = tmp_path_factory.mktemp("yade_law2")
    ye.write_capillary_files(table, d, ye.theta_suffix(0))
    ye.write_capillary_files(table30, d, ye.theta_suffix(30))
    return d


@pytest.mark.yade
@pytest.mark.parametrize("theta,ratio,j", [(0.0, 1.0, 10), (0.0, 2.0, 6), (30.0, 1.0, 4),
                                           (30.0, 2.0, 12), (30.0, 10.0, 8)])
def test_law2_force_in_yade_equals_table(law2_dir, table, table30, theta, ratio, j, yade):
    """YADE's Law2 with the exported files gives the table's force, and none past rupture."""
    tab = table if theta == 0.0 else table30
    i = tab.ratio_index(ratio)
    # Within a distance block YADE returns no bridge above the block's largest suction,
    # and P = uc R / gamma may round one ulp above the written value: query gaps where
    # the next suction still has a bridge, so P_j is not the block's edge.
    last = np.flatnonzero(tab.converged[i, j + 1])[-1]
    ks = [0, 1, last // 2, last]
    gaps = [tab.gap[k] for k in ks] + [0.5 * (tab.gap[1] + tab.gap[2]), tab.gap[-1] + 0.2]
    res = _run_law2(law2_dir, ye.theta_suffix(theta), ratio, tab.suction[j], gaps)
    rows = res["rows"]
    assert res["yade_version"] == yade.version
    scale = 2 * np.pi * GAMMA * R_SMALL                  # capbridge's force unit, r = R_SMALL
    for k, row in zip(ks, rows[:4]):
        assert row["interaction"] and row["meniscus"]
        assert row["force"] == pytest.approx(tab.force[i, j, k] * scale, rel=REL_TOL)
        assert row["fCap"] == pytest.approx(tab.force[i, j, k] * scale, rel=REL_TOL)
        assert row["vMeniscus"] == pytest.approx(tab.volume[i, j, k] * R_SMALL**3, rel=REL_TOL)
        assert row["Delta1"] == pytest.approx(max(tab.beta1[i, j, k], tab.beta2[i, j, k]), rel=REL_TOL)
    mid = rows[4]
    assert mid["force"] == pytest.approx(0.5 * (tab.force[i, j, 1] + tab.force[i, j, 2]) * scale,
                                         rel=REL_TOL)
    assert rows[5]["force"] == 0.0 and not rows[5]["interaction"]      # ruptured, erased
    for row in rows:                                     # and everywhere YADE = emulation
        assert row["force"] == pytest.approx(row["expected_force"], rel=1e-9, abs=1e-15)


@pytest.mark.yade
def test_law2_between_tabulated_ratios_and_suctions(law2_dir, table):
    """Off the grid, YADE interpolates (trilinear) exactly as capbridge's emulation says,
    and within 0.5 % of the smooth function the table samples."""
    ratio, s_star = 1.6, 0.5 * (table.suction[9] + table.suction[10])
    gaps = [0.0, 0.013, 0.05, 0.11]
    res = _run_law2(law2_dir, ye.theta_suffix(0), ratio, s_star, gaps)
    fine = ye.synthetic_suction_table(ratios=[ratio], suctions=[s_star], gaps=gaps)
    for row, f_true in zip(res["rows"], fine.force[0, 0]):
        assert row["force"] == pytest.approx(row["expected_force"], rel=1e-9)
        assert row["force"] == pytest.approx(f_true * 2 * np.pi * GAMMA * R_SMALL, rel=REL_TOL)


@pytest.mark.yade
@pytest.mark.parametrize("with_edge", [True, False])
def test_law2_pull_apart_to_rupture(tmp_path, with_edge):
    """Two spheres pulled apart at a suction between two tabulated ones, past rupture.

    With the rupture points in the table (``edge``) Law2 follows the table to within
    0.5 % up to the last grid gap before rupture, then fades linearly to zero at the
    next grid gap (YADE's blocks are the only distances it knows: rupture is resolved
    to one gap step) and gives nothing from there on.  Without them YADE drops the
    bridge from the first grid gap where the next tabulated suction has ruptured, well
    before its own rupture: that is what the rupture rows are for.
    """
    tab = ye.synthetic_suction_table(edge=with_edge)
    ratio, j = 2.0, 14
    s = math.sqrt(tab.suction[j] * tab.suction[j + 1])
    g_r = float(ye.synthetic_bridge(ratio, s, 0.0)["g_rupt"])
    g_next = tab.gap[tab.gap > g_r][0]                     # first grid gap past rupture
    g_last = tab.gap[tab.gap <= g_r][-1]                   # last grid gap before it
    gaps = np.concatenate([np.linspace(0.0, 0.999 * g_r, 16),
                           [g_last, 0.5 * (g_r + g_next), g_next, 1.3 * g_r]])
    ye.write_capillary_files(tab, tmp_path, "_t")
    res = _run_law2(tmp_path, "_t", ratio, s, gaps)
    forces = np.array([row["force"] for row in res["rows"]])
    for row in res["rows"]:
        assert row["force"] == pytest.approx(row["expected_force"], rel=1e-9, abs=1e-15)
    true = ye.synthetic_bridge(ratio, s, gaps)["force"] * 2 * np.pi * GAMMA * R_SMALL
    # reference: the table's own linear interpolation in suction between lines j, j+1
    i = tab.ratio_index(ratio)
    w = (s - tab.suction[j]) / (tab.suction[j + 1] - tab.suction[j])
    alive = gaps <= g_r
    if with_edge:
        exact = gaps <= min(g_last, tab.gap[tab.converged[i, j + 1]][-1])
        lin = ((1 - w) * np.interp(gaps, tab.gap, tab.force[i, j])
               + w * np.interp(gaps, tab.gap, tab.force[i, j + 1])) * 2 * np.pi * GAMMA * R_SMALL
        np.testing.assert_allclose(forces[exact], lin[exact], rtol=REL_TOL)
        np.testing.assert_allclose(forces[exact], true[exact], rtol=REL_TOL)
        assert np.all(forces[alive & (gaps <= g_last)] > 0)
        fading = (gaps > g_last) & (gaps < g_next)
        f_last = forces[np.flatnonzero(gaps == g_last)[0]]
        np.testing.assert_allclose(forces[fading], f_last * (g_next - gaps[fading])
                                   / (g_next - g_last), rtol=1e-6)
        assert np.all(forces[gaps >= g_next] < 1e-12 * forces[0])   # 0 up to round-off
    else:
        g_cut = tab.gap[~tab.converged[i, j + 1]][0]       # next line gone from this block on
        assert g_cut < g_r
        early = gaps < tab.gap[tab.gap < g_cut][-1]
        np.testing.assert_allclose(forces[early], true[early], rtol=REL_TOL)
        lost = alive & (gaps >= g_cut)
        assert lost.any() and np.all(forces[lost] < 1e-12 * forces[0])
        assert np.all(forces[~alive] < 1e-12 * forces[0])


@pytest.mark.yade
@pytest.mark.parametrize("with_edge", [True, False])
def test_capillarity_engine_pull_apart_to_rupture(tmp_path, with_edge):
    """CapillarityEngine at a tabulated suction, up to and past rupture: with the
    rupture point the line ends exactly there (within 0.5 % up to rupture); without it,
    the force fades over the last grid cell.  No force past rupture either way."""
    tab = ye.synthetic_suction_table(edge=with_edge)
    ratio, j = 2.0, 14
    g_r = float(ye.synthetic_bridge(ratio, tab.suction[j], 0.0)["g_rupt"])
    gaps = np.concatenate([np.linspace(0.0, 0.999 * g_r, 16), [1.05 * g_r, 1.3 * g_r]])
    ye.write_delaunay_file(tab, tmp_path / "capillaryfile_theta0.txt")
    res = _run_delaunay(tmp_path, ratio, tab.suction[j], gaps)
    forces = np.array([row["fCap"] for row in res["rows"]])
    true = ye.synthetic_bridge(ratio, tab.suction[j], gaps)["force"] * 2 * np.pi * GAMMA * R_SMALL
    alive = gaps <= g_r
    exact = alive if with_edge else gaps <= tab.gap[tab.gap <= g_r][-1]
    np.testing.assert_allclose(forces[exact], true[exact], rtol=REL_TOL)
    assert np.all(forces[alive & ~exact] <= true[alive & ~exact] * (1 + REL_TOL))
    assert np.all(forces[~alive] == 0.0)


@pytest.mark.yade
def test_law2_launcher_and_mindlin(law2_dir, table):
    """Same files through ``yade -n -x`` (Debian's python3) and with Hertz-Mindlin physics."""
    i, j = table.ratio_index(1.5), 7
    gaps = [0.0, table.gap[3]]
    for kw in ({"mode": "launcher"}, {"mindlin": True}):
        res = _run_law2(law2_dir, ye.theta_suffix(0), 1.5, table.suction[j], gaps, **kw)
        for row, k in zip(res["rows"], (0, 3)):
            assert row["force"] == pytest.approx(table.force[i, j, k] * 2 * np.pi * GAMMA * R_SMALL,
                                                 rel=REL_TOL)


@pytest.fixture(scope="module")
def delaunay_dir(tmp_path_factory, table):
    d = tmp_path_factory.mktemp("yade_delaunay")
    ye.write_delaunay_file(table, d / "capillaryfile_theta0.txt")
    return d


def _run_delaunay(directory, ratio, s_star, gaps_star, volumes_star=None):
    return _run_delaunay_file(directory, "capillaryfile_theta0.txt", ratio, s_star, gaps_star,
                              volumes_star)


def _run_delaunay_file(directory, name, ratio, s_star, gaps_star, volumes_star=None):
    args = ["--dir", str(directory), "--file", name, "--r1", R_SMALL,
            "--r2", ratio * R_SMALL, "--suction", _si_suction(s_star), "--gamma", GAMMA,
            _gaps_arg(np.asarray(gaps_star) * R_SMALL)]
    if volumes_star is not None:
        args.append("--volumes=" + ",".join(repr(float(v) * R_SMALL**3) for v in volumes_star))
    return yr.run_yade_script(SCENES / "two_spheres_delaunay.py", args, timeout=120).result


@pytest.mark.yade
@pytest.mark.parametrize("ratio,j", [(1.0, 10), (2.0, 6), (10.0, 16)])
def test_capillarity_engine_suction_control(delaunay_dir, table, ratio, j):
    """CapillarityEngine on the exported file: the table's force at its gaps, linear
    between them, the contact value for an overlap, nothing past rupture."""
    i = table.ratio_index(ratio)
    last = np.flatnonzero(table.converged[i, j])[-1]
    # past rupture: beyond the rupture gap of the next lower suction too, since linear
    # interpolation in tetrahedra smears the rupture over one grid cell
    far = ye.synthetic_bridge(ratio, table.suction[j - 1], 0.0)["g_rupt"] + 0.02
    gaps = [-0.002, 0.0, table.gap[2], 0.5 * (table.gap[3] + table.gap[4]), table.gap[last], far]
    res = _run_delaunay(delaunay_dir, ratio, table.suction[j], gaps)
    scale = 2 * np.pi * GAMMA * R_SMALL
    f = table.force[i, j]
    expected = [f[0], f[0], f[2], 0.5 * (f[3] + f[4]), f[last]]
    for row, fe in zip(res["rows"], expected):
        assert row["interaction"] and row["meniscus"]
        assert row["fCap"] == pytest.approx(fe * scale, rel=REL_TOL)
    for row in res["rows"][1:5]:
        assert row["force"] == pytest.approx(row["fCap"], rel=1e-12)   # no contact force
        # solveStandalone: force / (gamma R_large), R_large = ratio r
        assert row["standalone_force"] * GAMMA * ratio * R_SMALL == pytest.approx(row["fCap"], rel=1e-9)
    assert res["rows"][1]["vMeniscus"] == pytest.approx(table.volume[i, j, 0] * R_SMALL**3, rel=REL_TOL)
    assert res["rows"][-1]["fCap"] == 0.0 and not res["rows"][-1]["interaction"]


@pytest.mark.yade
@pytest.mark.parametrize("ratio,j", [(1.0, 12), (2.0, 8)])
def test_capillarity_engine_volume_control(delaunay_dir, table, ratio, j):
    """imposePressure=False: at a tabulated (volume, gap) YADE finds the table's force and
    suction."""
    i = table.ratio_index(ratio)
    ks = [0, 2, 5, 9]
    res = _run_delaunay(delaunay_dir, ratio, table.suction[j], [table.gap[k] for k in ks],
                        volumes_star=[table.volume[i, j, k] for k in ks])
    assert res["volume_mode"]
    for row, k in zip(res["rows"], ks):
        assert row["fCap"] == pytest.approx(table.force[i, j, k] * 2 * np.pi * GAMMA * R_SMALL,
                                            rel=REL_TOL)
        assert row["capillaryPressure"] == pytest.approx(_si_suction(table.suction[j]), rel=REL_TOL)


@pytest.mark.yade
@pytest.mark.slow
def test_exact_solver_export_loads_in_yade(tmp_path):
    """The real solver's export (equal spheres, placeholders for the other ratios), read
    by both engines at a tabulated suction, agrees with the solver in between the gaps."""
    from capbridge.solvers import young_laplace as yl

    if not hasattr(yl, "solve_doublet_suction"):
        pytest.skip("solve_doublet_suction not in capbridge.solvers.young_laplace yet")
    theta, suctions = 30.0, np.array([0.0, 0.5, 1.0, 2.0, 5.0])
    with pytest.warns(UserWarning, match="placeholder"):
        tab, _ = ye.export_from_solver(tmp_path, theta, ratios=(1.0,), suctions=suctions,
                                       n_gaps=25, missing="stub")
    assert np.isfinite(tab.edge["suction"]).sum() > suctions.size
    j = 2
    g_r = float(yl.suction_rupture_distance(-suctions[j], theta)["gap"])
    gaps = np.array([0.0, 0.3, 0.55, 0.7]) * g_r           # off the gap grid
    exact = yl.solve_doublet_suction(gaps, -suctions[j], theta)["force"] * 2 * np.pi * GAMMA * R_SMALL
    law2 = _run_law2(tmp_path, ye.theta_suffix(theta), 1.0, suctions[j], gaps)
    dela = _run_delaunay_file(tmp_path, "capillaryfile_theta30.txt", 1.0, suctions[j], gaps)
    for r_l, r_d, f in zip(law2["rows"], dela["rows"], exact):
        assert r_l["force"] == pytest.approx(f, rel=REL_TOL)
        assert r_d["fCap"] == pytest.approx(f, rel=REL_TOL)
    past = _run_law2(tmp_path, ye.theta_suffix(theta), 1.0, suctions[j], [1.2 * g_r + 0.02])
    assert past["rows"][0]["force"] == 0.0
