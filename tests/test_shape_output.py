"""Liquid surfaces as VTK files (capbridge.solvers.shapes, capbridge.vtk_io triangles).

* Triangles round-trip exactly through capbridge.vtk_io in both formats, and VTK's own
  readers (python3-vtk9) load them.
* The exact doublet revolved: its volume closed by the two sphere caps converges to V*
  as the square of the mesh spacing (Richardson: to 1e-5), its smallest distance from
  the axis is the solver's neck radius, its contact rings lie on the spheres.
* Surface Evolver (small meshes, refinement level 1: about a second each): the file
  holds the mesh Evolver reported (its own vertex and facet counts), a surface of the
  right topology (Euler's formula), outside the grains, with the contact-line vertices
  on their spheres; the grains file carries the radii.
* Nothing is overwritten without overwrite=True (neither file).
"""
from __future__ import annotations

import numpy as np
import pytest

from capbridge.solvers.shapes import doublet_shape, shape_paths, write_shape
from capbridge.solvers.young_laplace import solve_doublet
from capbridge.validation import CapbridgeInputError
from capbridge.vtk_io import read_vtk, write_polydata

FORMATS = [".vtp", ".vtk"]


def _vtk_triangles(poly):
    """(T, 3) point indices of VTK's polygons (all triangles)."""
    from vtk.util.numpy_support import vtk_to_numpy

    polys = poly.GetPolys()
    off = vtk_to_numpy(polys.GetOffsetsArray())
    assert np.all(np.diff(off) == 3)
    return vtk_to_numpy(polys.GetConnectivityArray()).reshape(-1, 3)


def _signed_volume(points, triangles):
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def _doublet_liquid_volume(shape):
    """Volume of the liquid: the mesh closed by flat discs on its two contact rings,
    less the sphere segments beyond those discs."""
    vol = _signed_volume(shape.points, shape.triangles)
    for g in (0, 1):
        ring = np.flatnonzero(shape.contact_grain == g)      # in azimuthal order
        centre = shape.points[ring].mean(axis=0)
        pts = np.vstack([shape.points, centre])
        a, b = ring, np.roll(ring, -1)
        fan = np.stack([np.full_like(a, len(shape.points)), b, a] if g == 0 else
                       [np.full_like(a, len(shape.points)), a, b], axis=1)
        vol += _signed_volume(pts, fan)                      # outward: -x on 1, +x on 2
        R = shape.radii[g]
        h = R - abs(centre[0] - shape.centres[g][0])
        vol -= np.pi * h * h * (3 * R - h) / 3
    return vol


# --------------------------------------------------------------------------------------
# capbridge.vtk_io: triangles
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", FORMATS)
def test_triangles_round_trip_exactly_and_vtk_reads_them(tmp_path, suffix, vtk_read):
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(6, 3))
    tri = np.array([[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4]])
    path = write_polydata(tmp_path / f"t{suffix}", pts, tri, "polys",
                          cell_data={"body": [0, 0, 1, 1], "area": np.arange(4) / 3},
                          point_data={"z": pts[:, 2]}, title="t, lengths / r")
    r = read_vtk(path)
    np.testing.assert_array_equal(r["points"], pts)
    np.testing.assert_array_equal(r["polys"], tri)
    np.testing.assert_array_equal(r["cell_data"]["area"], np.arange(4) / 3)
    np.testing.assert_array_equal(r["point_data"]["z"], pts[:, 2])
    assert r["lines"].shape == (0, 2) and r["verts"].shape == (0,)
    assert r["title"] == "t, lengths / r"
    poly, cells, points, _ = vtk_read(path)
    assert poly.GetNumberOfPolys() == 4 and poly.GetNumberOfPoints() == 6
    np.testing.assert_array_equal(_vtk_triangles(poly), tri)
    np.testing.assert_array_equal(cells["body"], [0, 0, 1, 1])


@pytest.mark.parametrize("cells, kind, word", [
    ([[0, 1, 6]], "polys", r"point indices in \[0, 5\]"),
    ([[0, 1]], "polys", r"expected \(C, 3 or more\)"),
    ([[0, 1, 2]], "strips", "not one of"),
])
def test_bad_cells_are_one_clear_error(tmp_path, cells, kind, word):
    with pytest.raises(CapbridgeInputError, match=word):
        write_polydata(tmp_path / "t.vtp", np.zeros((6, 3)), cells, kind)
    assert not list(tmp_path.iterdir())


# --------------------------------------------------------------------------------------
# the exact doublet, revolved
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("gap, volume, theta, ratio", [
    (0.1, 0.05, 20.0, 1.0), (0.05, 0.2, 40.0, 3.0), (0.0, 0.3, 0.0, 1.0)])
def test_revolved_doublet_holds_its_volume_and_neck(gap, volume, theta, ratio):
    r = solve_doublet(gap, volume, theta, ratio)
    coarse = doublet_shape(gap, volume, theta, ratio, result=r, n_meridian=81, n_azimuth=72)
    fine = doublet_shape(gap, volume, theta, ratio, result=r, n_meridian=161,
                         n_azimuth=144)
    v2h, vh = _doublet_liquid_volume(coarse), _doublet_liquid_volume(fine)
    assert abs(vh / volume - 1) < 1.5e-3                     # a polyhedron inside
    assert abs((4 * vh - v2h) / 3 / volume - 1) < 1e-5        # second order: Richardson
    for s in (coarse, fine):
        rho = np.hypot(s.points[:, 1], s.points[:, 2])
        assert rho.min() == pytest.approx(float(r["neck_radius"]), abs=1e-12)
        for g in (0, 1):
            on = s.points[s.contact_grain == g]
            np.testing.assert_allclose(np.linalg.norm(on - s.centres[g], axis=1),
                                       s.radii[g], atol=1e-12)
    assert len(fine.triangles) == 2 * (len(fine.points) // 144 - 1) * 144


@pytest.mark.parametrize("suffix", FORMATS)
def test_doublet_files_read_back_and_load_in_vtk(tmp_path, suffix, vtk_read):
    shape = doublet_shape(0.1, 0.05, 30.0, ratio=2.0)
    surf, grains = write_shape(shape, tmp_path / f"bridge{suffix}")
    assert grains.name == f"bridge_grains{suffix}"
    r = read_vtk(surf)
    np.testing.assert_array_equal(r["points"], shape.points)
    np.testing.assert_array_equal(r["polys"], shape.triangles)
    np.testing.assert_array_equal(r["point_data"]["contact_grain"], shape.contact_grain)
    np.testing.assert_array_equal(r["cell_data"]["body"], 0)
    for word in ("lengths / r", "d12=0.1", "theta=30 deg", "V*=0.05", "Bo=0",
                 "status converged", "revolved"):
        assert word in r["title"]
    g = read_vtk(grains)
    np.testing.assert_array_equal(g["points"], [[0, 0, 0], [3.1, 0, 0]])
    np.testing.assert_array_equal(g["point_data"]["radius"], [1.0, 2.0])
    np.testing.assert_array_equal(g["point_data"]["wetted"], [1, 1])
    poly, cells, points, _ = vtk_read(surf)
    assert poly.GetNumberOfPolys() == len(shape.triangles)
    assert poly.GetNumberOfPoints() == len(shape.points)
    np.testing.assert_array_equal(_vtk_triangles(poly), shape.triangles)
    poly, _, points, _ = vtk_read(grains)
    assert poly.GetNumberOfVerts() == 2
    np.testing.assert_array_equal(points["radius"], [1.0, 2.0])


def test_existing_files_are_refused_before_writing(tmp_path):
    shape = doublet_shape(0.1, 0.05, 30.0, n_meridian=11, n_azimuth=8)
    surf, grains = write_shape(shape, tmp_path / "b.vtp")
    before = surf.read_text(), grains.read_text()
    other = doublet_shape(0.1, 0.08, 30.0, n_meridian=11, n_azimuth=8)
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_shape(other, surf)
    assert (surf.read_text(), grains.read_text()) == before
    surf.unlink()                                   # the grains file alone blocks too
    with pytest.raises(FileExistsError, match="b_grains.vtp"):
        write_shape(other, surf)
    assert not surf.exists()
    with pytest.raises(FileExistsError, match="--overwrite"):
        shape_paths(surf, flag="--overwrite")
    write_shape(other, surf, overwrite=True)
    assert "V*=0.08" in read_vtk(surf)["title"] and "V*=0.08" in read_vtk(grains)["title"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.vtp", "b_grains.vtp"]
    with pytest.raises(CapbridgeInputError, match=r"\.vtp.*\.vtk"):
        write_shape(shape, tmp_path / "b.stl")
    with pytest.raises(CapbridgeInputError, match="does not exist"):
        write_shape(shape, tmp_path / "no" / "b.vtp")


def test_no_bridge_no_shape():
    with pytest.raises(CapbridgeInputError, match="status ruptured"):
        doublet_shape(0.5, 0.02, 10.0)
    with pytest.raises(CapbridgeInputError, match="not_converged.*keep_shape=True"):
        write_shape({"status": "not_converged", "shape": None}, "x.vtp")
    with pytest.raises(CapbridgeInputError, match="n_azimuth"):
        doublet_shape(0.1, 0.05, 30.0, n_azimuth=4)


# --------------------------------------------------------------------------------------
# Surface Evolver
# --------------------------------------------------------------------------------------


@pytest.fixture
def evolver_counts(monkeypatch):
    """Evolver's own vertex and facet counts (its report's vertex_count, facet_count) of
    every mesh turned into a shape."""
    from capbridge.solvers.evolver import parse

    seen = []
    original = parse.Snapshot.triangle_mesh

    def spy(self, contact_constraints):
        seen.append((self.counts[0], self.counts[2]))
        return original(self, contact_constraints)

    monkeypatch.setattr(parse.Snapshot, "triangle_mesh", spy)
    return seen


def _euler_vertices(n_facets, contact_vertices, n_loops):
    """Vertices of a triangulated sphere with ``n_loops`` holes: V - E + F = 2 - loops,
    E = (3 F + boundary edges) / 2, as many boundary edges as contact-line vertices."""
    return 2 - n_loops + (3 * n_facets + contact_vertices) // 2 - n_facets


@pytest.mark.evolver
def test_evolver_triplet_surface_is_the_reported_mesh(tmp_path, evolver_counts, vtk_read):
    from capbridge.solvers.triplet import triplet_geometry
    from capbridge.solvers.triplet_evolver import evolver_triplet

    geom = triplet_geometry(0.175, 0.175, 0.075)
    r = evolver_triplet(0.25, geom, 0.0, "coalesced", max_refine=1, inspect_mesh=False,
                        keep_shape=True, workers=1)
    assert r["status"] in ("converged", "above_tolerance"), r["reason"]
    surf, grains = write_shape(r, tmp_path / "trimer.vtp")
    got = read_vtk(surf)
    nv, nf = evolver_counts[-1]
    assert got["points"].shape == (nv, 3) and got["polys"].shape == (nf, 3)
    assert nf == r["n_facets"]
    cg = got["point_data"]["contact_grain"]
    assert sorted(set(cg.tolist())) == [-1, 0, 1, 2]         # three contact lines
    assert nv == _euler_vertices(nf, int(np.sum(cg >= 0)), 3)
    assert set(np.unique(got["polys"])) == set(range(nv))     # no stray vertex
    np.testing.assert_array_equal(got["cell_data"]["body"], 0)
    # in the frame of the forces: the grains file holds geom's centres, radius 1
    g = read_vtk(grains)
    np.testing.assert_array_equal(g["points"], geom.centres)
    np.testing.assert_array_equal(g["point_data"]["radius"], [1.0, 1.0, 1.0])
    # on the liquid body: outside every grain (one-sided constraints), inside the box of
    # the grains, contact-line vertices on their sphere
    P = got["points"]
    dist = np.linalg.norm(P[:, None, :] - geom.centres[None], axis=2)
    assert dist.min() > 1 - 1e-9
    assert np.all(P >= geom.centres.min(0) - 1) and np.all(P <= geom.centres.max(0) + 1)
    on = cg >= 0
    np.testing.assert_allclose(dist[on, cg[on]], 1.0, atol=1e-9)
    for word in ("lengths / r", "d12=0.175 d13=0.175 d23=0.075", "theta=0 deg",
                 "V*=0.25", f"status {r['status']}", "Surface Evolver, refinement level 1"):
        assert word in got["title"]
    poly, cells, points, _ = vtk_read(surf)
    assert (poly.GetNumberOfPoints(), poly.GetNumberOfPolys()) == (nv, nf)
    np.testing.assert_array_equal(_vtk_triangles(poly), got["polys"])
    np.testing.assert_array_equal(points["contact_grain"], cg)


@pytest.mark.evolver
def test_evolver_doublet_shape_through_the_result(tmp_path, evolver_counts):
    from capbridge.solvers.evolver import minimise_bridge

    centres = [[0.0, 0.0, 0.0], [2.1, 0.0, 0.0]]
    res = minimise_bridge(centres, 1.0, 30.0, 0.05, "doublet", max_refine=1,
                          min_refine=1, keep_shape=True, workers=1)
    assert res.converged, res.reason
    surf, _ = write_shape(res, tmp_path / "doublet.vtk")
    got = read_vtk(surf)
    nv, nf = evolver_counts[-1]
    cg = got["point_data"]["contact_grain"]
    assert got["points"].shape == (nv, 3) and len(got["polys"]) == nf == res.n_facets
    assert nv == _euler_vertices(nf, int(np.sum(cg >= 0)), 2)
    # the contact rings sit where the exact bridge has them (level 1: a few per cent)
    ex = solve_doublet(0.1, 0.05, 30.0)
    rho = np.hypot(got["points"][cg >= 0, 1], got["points"][cg >= 0, 2])
    assert rho.mean() == pytest.approx(np.sin(np.radians(float(ex["beta1"]))), rel=0.05)
    plain = minimise_bridge(centres, 1.0, 30.0, 0.05, "doublet", max_refine=1,
                            min_refine=1, workers=1)
    assert plain.shape is None                      # kept only when asked
    with pytest.raises(CapbridgeInputError, match="keep_shape=True"):
        write_shape(plain, tmp_path / "plain.vtp")


def _cli(args, capsys):
    import json

    from capbridge.cli import main

    code = main(args)
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip() else None), err


def test_cli_solve_doublet_shape(tmp_path, capsys):
    """``solve doublet --shape``: the exact profile revolved, two files, their paths in
    the JSON; a second run refuses the existing files in one line (exit 2) and leaves
    them as they were, ``--overwrite`` replaces them; gravity along the axis (Bo > 0)
    is refused before any solve (the exact gravity solver keeps no profile)."""
    path = tmp_path / "bridge.vtp"
    args = ["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30",
            "--shape", str(path)]
    code, out, _ = _cli(args, capsys)
    assert code == 0 and out["shape"] == [str(path), str(tmp_path / "bridge_grains.vtp")]
    surf = read_vtk(path)
    assert surf["points"].shape[0] > 100
    before = path.read_bytes()
    code, out, err = _cli(args, capsys)
    assert code == 2 and out is None and "exists" in err and "--overwrite" in err
    assert err.count("\n") == 1 and path.read_bytes() == before
    code, out, _ = _cli(args + ["--overwrite"], capsys)
    assert code == 0 and out["shape"][0] == str(path)
    code, out, err = _cli(["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30",
                           "--bond", "0.5", "--gravity", "-1,0,0",
                           "--shape", str(tmp_path / "g.vtp")], capsys)
    assert code == 2 and "along its axis" in err and not (tmp_path / "g.vtp").exists()


@pytest.mark.evolver
def test_cli_solve_triplet_shape(tmp_path, capsys, evolver):
    """``solve triplet --shape``: Surface Evolver's surface (level 2, seconds) with the
    same point count as the mesh the result's numbers come from."""
    path = tmp_path / "trimer.vtp"
    code, out, _ = _cli(["solve", "triplet", "--d12", "0", "--d13", "0", "--d23", "0.1",
                         "--V", "0.3", "--theta", "30", "--max-refine", "2",
                         "--shape", str(path)], capsys)
    assert code == 0 and out["shape"][0] == str(path)
    grains = read_vtk(tmp_path / "trimer_grains.vtp")
    np.testing.assert_allclose(grains["points"], np.asarray(out["centres"]), atol=1e-9)
    assert read_vtk(path)["points"].shape[0] > 50
