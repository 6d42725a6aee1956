"""Tests of capbridge.dem.vtk_output: bridge and cluster files for ParaView.

Round trips are exact (floats written as shortest round-trip reprs); VTK's own readers
(Debian's python3-vtk9, installed by the Makefile's set-up, or PyPI's vtk) must load the
files with the same numbers (that check is skipped without VTK outside `make test`, and
fails inside it: tests/conftest.py).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from capbridge.dem.vtk_output import (BridgeVTKRecorder, read_vtk, write_bridges,
                                             write_clusters)
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError

FORMATS = [".vtp", ".vtk"]


def _bridges(n=7, seed=0):
    """A small scene: grain centres [m], volumes [m^3], forces [N], statuses, clusters."""
    rng = np.random.default_rng(seed)
    ends = rng.uniform(-5e-3, 5e-3, (n, 2, 3))
    return dict(ends=ends, volume=rng.uniform(1e-13, 1e-11, n),
                force=rng.normal(0, 1e-4, (n, 3)),
                status=rng.choice([int(Status.CONVERGED), int(Status.COALESCED)], n),
                cluster=rng.integers(-1, 3, n))


@pytest.mark.parametrize("suffix", FORMATS)
def test_bridges_round_trip_exactly(tmp_path, suffix):
    """Two points per bridge, one line cell per bridge, every array back bit for bit;
    force_magnitude is the norm of the force."""
    b = _bridges()
    gap = np.linspace(0, 1e-4, 7)
    path = write_bridges(tmp_path / f"b{suffix}", **b, extra={"gap": gap})
    r = read_vtk(path)
    np.testing.assert_array_equal(r["points"], b["ends"].reshape(-1, 3))
    np.testing.assert_array_equal(r["lines"], np.arange(14).reshape(7, 2))
    c = r["cell_data"]
    assert set(c) == {"volume", "force", "force_magnitude", "status", "cluster", "gap"}
    for key in ("volume", "force", "status", "cluster"):
        np.testing.assert_array_equal(c[key], b[key], err_msg=key)
    np.testing.assert_array_equal(c["gap"], gap)
    np.testing.assert_allclose(c["force_magnitude"], np.linalg.norm(b["force"], axis=1),
                               rtol=1e-15)
    assert c["status"].dtype == np.int32 and c["volume"].dtype == np.float64
    assert "m^3" in r["title"]


@pytest.mark.parametrize("suffix", FORMATS)
def test_force_magnitudes_and_empty_scenes(tmp_path, suffix):
    """A force given as magnitudes is written as force_magnitude only; a scene without
    bridges is a valid empty file."""
    b = _bridges(4)
    mag = np.abs(b["force"][:, 0])
    r = read_vtk(write_bridges(tmp_path / f"m{suffix}", b["ends"], b["volume"], mag,
                               b["status"]))
    assert "force" not in r["cell_data"] and "cluster" not in r["cell_data"]
    np.testing.assert_array_equal(r["cell_data"]["force_magnitude"], mag)
    e = read_vtk(write_bridges(tmp_path / f"e{suffix}", np.empty((0, 2, 3)), [],
                               np.empty((0, 3)), []))
    assert e["points"].shape == (0, 3) and e["lines"].shape == (0, 2)


@pytest.mark.parametrize("suffix", FORMATS)
def test_clusters_round_trip(tmp_path, suffix):
    """Clusters: one vertex per cluster at its centroid, volume / n_grains / cluster id
    as point data (ids default to 0..M-1)."""
    cen = np.array([[0.0, 1e-3, 2e-3], [1.5e-3, -2e-3, 0.0], [3e-3, 3e-3, 3e-3]])
    vol = np.array([3e-11, 5.5e-11, 1e-10])
    r = read_vtk(write_clusters(tmp_path / f"c{suffix}", cen, vol, [3, 4, 7]))
    np.testing.assert_array_equal(r["points"], cen)
    np.testing.assert_array_equal(r["verts"], [0, 1, 2])
    np.testing.assert_array_equal(r["point_data"]["volume"], vol)
    np.testing.assert_array_equal(r["point_data"]["n_grains"], [3, 4, 7])
    np.testing.assert_array_equal(r["point_data"]["cluster"], [0, 1, 2])


@pytest.mark.parametrize("suffix", FORMATS)
def test_vtk_itself_reads_the_files(tmp_path, suffix, vtk_read):
    """VTK's own readers (vtkXMLPolyDataReader / vtkPolyDataReader, as ParaView uses)
    load every array with the written values (skipped without VTK's Python module)."""
    b = _bridges()
    path = write_bridges(tmp_path / f"b{suffix}", **b)
    out, cells, _, xyz = vtk_read(path)
    assert out.GetNumberOfPoints() == 14 and out.GetNumberOfLines() == 7
    np.testing.assert_array_equal(xyz, b["ends"].reshape(-1, 3))
    for key in ("volume", "force", "status", "cluster"):
        np.testing.assert_array_equal(cells[key], b[key], err_msg=key)
    out, _, pts, _ = vtk_read(write_clusters(tmp_path / f"c{suffix}", np.eye(3),
                                                [1.0, 2.0, 3.0], [2, 2, 5]))
    assert out.GetNumberOfPoints() == 3 and out.GetNumberOfVerts() == 3
    np.testing.assert_array_equal(pts["n_grains"], [2, 2, 5])
    out, _, _, _ = vtk_read(write_bridges(tmp_path / f"e{suffix}", np.empty((0, 2, 3)),
                                             [], [], []))
    assert out.GetNumberOfPoints() == 0 and out.GetNumberOfLines() == 0


def test_existing_files_are_not_overwritten(tmp_path):
    b = _bridges()
    path = write_bridges(tmp_path / "b.vtp", **b)
    before = path.read_text()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_bridges(path, **(b | {"volume": 2 * b["volume"]}))
    assert path.read_text() == before
    write_bridges(path, **(b | {"volume": 2 * b["volume"]}), overwrite=True)
    np.testing.assert_array_equal(read_vtk(path)["cell_data"]["volume"], 2 * b["volume"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.vtp"]   # no temporary left


@pytest.mark.parametrize("change, word", [
    (dict(ends=np.zeros((7, 3))), r"ends has shape \(7, 3\); expected \(N, 2, 3\)"),
    (dict(force=np.full((7, 3), np.nan)), "force has 21 non-finite"),
    (dict(volume=np.ones(6)), "volume has 6 entries; expected 7"),
    (dict(status=np.full(7, 0.5)), "status must hold integers"),
    (dict(cluster=np.zeros((7, 2), int)), "cluster has shape"),
])
def test_bad_input_is_one_clear_error(tmp_path, change, word):
    with pytest.raises(CapbridgeInputError, match=word):
        write_bridges(tmp_path / "b.vtp", **(_bridges() | change))
    assert not list(tmp_path.iterdir())
    with pytest.raises(CapbridgeInputError, match=r"\.vtp.*\.vtk"):
        write_bridges(tmp_path / "b.csv", **_bridges())
    with pytest.raises(CapbridgeInputError, match="reserved"):
        write_bridges(tmp_path / "b.vtp", **_bridges(), extra={"status": np.zeros(7)})


def test_recorder_writes_a_paraview_time_series(tmp_path):
    """One file per record and a .pvd listing them with their times (relative paths);
    a second recorder on the same prefix refuses to overwrite the first run."""
    rec = BridgeVTKRecorder(tmp_path / "out", prefix="pull")
    for step, t in ((0, 0.0), (100, 1e-4)):
        b = _bridges(3 + step // 100, seed=step)
        files = rec.record(step, t, **b, clusters=dict(centroid=np.zeros((1, 3)),
                                                       volume=[1e-11], n_grains=[3]))
        assert [f.name for f in files] == [f"pull_bridges_{step:09d}.vtp",
                                           f"pull_clusters_{step:09d}.vtp"]
        np.testing.assert_array_equal(read_vtk(files[0])["cell_data"]["force"], b["force"])
    for what in ("bridges", "clusters"):
        ds = ET.parse(tmp_path / "out" / f"pull_{what}.pvd").getroot().findall(
            "Collection/DataSet")
        assert [(float(d.get("timestep")), d.get("file")) for d in ds] == [
            (0.0, f"pull_{what}_000000000.vtp"), (1e-4, f"pull_{what}_000000100.vtp")]
    with pytest.raises(FileExistsError, match="earlier run"):
        BridgeVTKRecorder(tmp_path / "out", prefix="pull")
    BridgeVTKRecorder(tmp_path / "out", prefix="other")
