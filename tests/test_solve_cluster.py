"""One liquid body on N grains (:mod:`capbridge.solvers.cluster`, ``capbridge solve cluster``).

The Evolver tests (level 2, seconds each) check the cluster solver against the exact
doublet, the triplet solver and the shipped triplet table, and the symmetry of a filled
tetrahedron; every tolerance is the error the results state themselves (the Evolver
estimate over refinement levels, the table's ``force_error``), never a fixed number.
"""
import json

import numpy as np
import pytest

from capbridge.cli import main
from capbridge.solvers.cluster import check_cluster, cluster_pair_forces, solve_cluster
from capbridge.solvers.triplet import pair_direction_matrix
from capbridge.status import HAS_RESULT
from capbridge.validation import CapbridgeInputError

# regular tetrahedron of unit spheres, gaps 0.05 (edge 2.05), and a planar square
TETRA = 2.05 / (2 * np.sqrt(2)) * np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1],
                                            [-1, -1, 1]])
SQUARE = np.array([[0.0, 0, 0], [2.05, 0, 0], [2.05, 2.05, 0], [0, 2.05, 0]])
V_TETRA, THETA = 0.6, 30.0


@pytest.fixture(scope="module")
def tetrahedron(evolver):
    """The filled tetrahedron at level 2 (~5 s), shared by the API and CLI tests."""
    return solve_cluster(TETRA, 1.0, V_TETRA, THETA, max_refine=2)


# ----------------------------------------------------------------------------- inputs

@pytest.mark.parametrize("centres, radii, words", [
    ([[0.0, 0, 0]], 1.0, "at least 2 grains"),
    ([[0.0, 0, 0], [np.nan, 0, 0]], 1.0, "centres"),
    ([[0.0, 0, 0], [3, 0, 0]], [1.0, 0.0], "radius"),
    ([[0.0, 0, 0], [1.99, 0, 0]], 1.0, "grains 1 and 2 overlap"),
    ([[0.0, 0, 0], [3, 0]], 1.0, "grain centres"),
    ([[0.0, 0], [3, 0]], 1.0, "shape"),
])
def test_bad_grains_are_one_clear_error(centres, radii, words):
    with pytest.raises(CapbridgeInputError, match=words):
        check_cluster(centres, radii)


def test_contact_overlap_is_refused_with_the_reason():
    with pytest.raises(CapbridgeInputError, match="DEM contact overlap"):
        check_cluster([[0.0, 0, 0], [1.99, 0, 0]], 1.0)


def test_touching_grains_and_normalisation_by_the_smallest_radius():
    C, R, r = check_cluster([[0.0, 0, 0], [5.0, 0, 0]], [2.0, 3.0])     # gap exactly 0
    assert r == 2.0 and R.tolist() == [1.0, 1.5] and C[1].tolist() == [2.5, 0, 0]


@pytest.mark.parametrize("kw, words", [({"volume": 0.0}, "volume"),
                                       ({"theta": 90.0}, "contact angle"),
                                       ({"bond": 6.0}, "Bond"),
                                       ({"max_refine": 1}, "max_refine")])
def test_bad_numbers_are_refused_before_any_run(kw, words):
    args = {"volume": 0.6, "theta": 30.0, **kw}
    with pytest.raises(CapbridgeInputError, match=words):
        solve_cluster(TETRA, 1.0, **args)


# ------------------------------------------------------------------- pair decomposition

def test_pair_decomposition_tetrahedron_determined_square_not():
    A, pairs = pair_direction_matrix(TETRA)
    f = np.linspace(0.1, 0.6, 6)
    r = cluster_pair_forces(TETRA, (A @ f).reshape(4, 3), np.full((4, 3), 1e-3))
    assert r["determined"] and r["rank"] == 6 and r["residual"] < 1e-12
    np.testing.assert_allclose([r["pair_forces"][p] for p in pairs], f, rtol=1e-12)
    assert all(e > 0 for e in r["pair_force_error"].values())
    A, _ = pair_direction_matrix(SQUARE)
    sq = cluster_pair_forces(SQUARE, (A @ f).reshape(4, 3))
    assert not sq["determined"] and sq["rank"] == 5 and sq["pair_forces"] is None
    assert "rank 5" in sq["note"]


# --------------------------------------------------------------------------- Evolver

@pytest.mark.evolver
def test_two_grains_agree_with_the_exact_doublet():
    from capbridge.solvers.young_laplace import solve_doublet

    exact = float(solve_doublet(0.1, 0.05, 30.0)["force"])
    r = solve_cluster([[0.0, 0, 0], [2.1, 0, 0]], 1.0, 0.05, 30.0, max_refine=2)
    assert r["status"] in HAS_RESULT
    F, err = r["forces"], r["force_error"]
    # attraction: grain 1 pulled towards +x, grain 2 towards -x
    assert abs(F[0, 0] - exact) <= err[0, 0] and abs(-F[1, 0] - exact) <= err[1, 0]
    assert r["pairs"]["determined"] and r["pairs"]["rank"] == 1
    assert abs(r["pairs"]["pair_forces"][(0, 1)] - exact) <= r["pairs"]["pair_force_error"][(0, 1)]


@pytest.mark.evolver
def test_three_grains_agree_with_the_triplet_solver_and_table(shipped_triplet_table):
    from capbridge.solvers.triplet import triplet_geometry
    from capbridge.solvers.triplet_evolver import evolver_triplet
    from capbridge.surrogate.triplet import TripletSurrogate

    # a node of the table: gaps 0.1, theta 40, v = V/V_coal = 1
    sur = TripletSurrogate().fit(shipped_triplet_table)
    V = float(sur.predict(0.1, 0.1, 0.1, 0.3, 40.0)["volume_coalescence"])
    geom = triplet_geometry(0.1, 0.1, 0.1)
    r = solve_cluster(geom.centres, 1.0, V, 40.0, max_refine=2)
    t = evolver_triplet(V, geom, 40.0, "coalesced", max_refine=2, inspect_mesh=False)
    assert r["status"] in HAS_RESULT and t["status"] in ("converged", "above_tolerance")
    # the same minimisation: identical up to the error both state
    np.testing.assert_array_less(np.abs(r["forces"] - np.asarray(t["forces"])),
                                 r["force_error"] + np.asarray(t["force_error"]) + 1e-12)
    tab = sur.predict_vectors(geom.centres, V, 40.0)
    # table (level 3) against level 2: within the table's error plus the level-2 estimate
    tol = float(tab["force_error"]) + np.linalg.norm(r["force_error"], axis=1)
    np.testing.assert_array_less(np.linalg.norm(r["forces"] - tab["forces"], axis=1), tol)


@pytest.mark.evolver
def test_filled_tetrahedron_balance_symmetry_and_pair_forces(tetrahedron):
    r = tetrahedron
    assert r["status"] in HAS_RESULT and r["refinement"] == 2
    F, err = r["forces"], r["force_error"]
    # no gravity: the forces balance within their error
    assert np.all(np.abs(F.sum(axis=0)) <= np.sqrt((err ** 2).sum(axis=0)))
    mag = np.linalg.norm(F, axis=1)
    mag_err = np.linalg.norm(err, axis=1)
    assert mag.max() - mag.min() <= mag_err.max()
    # each grain is pulled towards the centre of the tetrahedron
    assert np.all(np.einsum("ij,ij->i", F, -TETRA) > 0)
    pairs = r["pairs"]
    assert pairs["determined"] and pairs["rank"] == 6
    f = np.array(list(pairs["pair_forces"].values()))
    assert np.all(f > 0) and f.max() - f.min() <= max(pairs["pair_force_error"].values())


@pytest.mark.evolver
def test_planar_square_pair_forces_not_determined():
    r = solve_cluster(SQUARE, 1.0, 0.6, THETA, max_refine=2)
    assert r["status"] in HAS_RESULT
    assert not r["pairs"]["determined"] and r["pairs"]["pair_forces"] is None
    assert "not determined" in r["pairs"]["note"]


# ------------------------------------------------------------------------------ CLI

def _grains_csv(path, centres, radii=1.0):
    rows = [f"{x!r},{y!r},{z!r},{float(rad)!r}"
            for (x, y, z), rad in zip(centres, np.broadcast_to(radii, len(centres)))]
    path.write_text("x,y,z,radius\n" + "\n".join(rows) + "\n")
    return str(path)


@pytest.mark.evolver
def test_cli_tetrahedron_in_the_files_order_and_frame(tmp_path, capsys, tetrahedron, vtk_read):
    perm = [2, 0, 3, 1]
    grains = _grains_csv(tmp_path / "g.csv", TETRA[perm])
    shape = tmp_path / "tet.vtp"
    code = main(["solve", "cluster", "--grains", grains, "--V", str(V_TETRA), "--theta",
                 str(THETA), "--max-refine", "2", "--shape", str(shape)])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["status"] in ("converged", "above_tolerance")
    assert out["n_grains"] == 4 and out["refinement"] == 2 and out["cpu_time"] > 0
    F, err = np.array(out["forces"]), np.array(out["force_error"])
    # row k of the file is grain k: the forces are the API's, permuted like the rows
    np.testing.assert_array_less(np.abs(F - tetrahedron["forces"][perm]),
                                 err + tetrahedron["force_error"][perm])
    assert np.all(np.einsum("ij,ij->i", F, -TETRA[perm]) > 0)
    assert out["pair_forces_determined"] and len(out["pair_forces"]) == 6
    assert set(out["pair_forces"]) == {"1-2", "1-3", "1-4", "2-3", "2-4", "3-4"}
    for k in ("pressure", "energy", "energy_error", "force_error_rel", "pair_residual"):
        assert np.isfinite(out[k])
    assert [p.split("/")[-1] for p in out["shape"]] == ["tet.vtp", "tet_grains.vtp"]
    poly, _, point_arrays, pts = vtk_read(shape)
    assert poly.GetNumberOfCells() > 0 and "contact_grain" in point_arrays
    # the surface is in the file's frame: it lies around the file's grains
    assert np.allclose(pts.mean(axis=0), TETRA.mean(axis=0), atol=0.2)


@pytest.mark.parametrize("text, extra, words", [
    (None, [], "does not exist"),
    ("x,y,radius\n0,0,1\n3,0,1\n", [], "missing column"),
    ("x,y,z,radius\n0,0,0,1\n3,zero,0,1\n", [], "not a number"),
    ("x,y,z,radius\n0,0,0,1\n", [], "at least 2"),
    ("x,y,z,radius\n0,0,0,1\n1.5,0,0,1\n", [], "grains 1 and 2 overlap"),
    ("x,y,z,radius\n0,0,0,1\n3,0,0,-1\n", [], "radius"),
    ("x,y,z,radius\n0,0,0,1\n3,0,0,1\n", ["--theta", "95"], "--theta"),
    ("x,y,z,radius\n0,0,0,1\n3,0,0,1\n", ["--gravity", "0,0,-1"], "--bond"),
])
def test_cli_bad_inputs_exit_2_in_one_line(tmp_path, capsys, text, extra, words):
    path = tmp_path / "g.csv"
    if text is not None:
        path.write_text(text)
    args = ["solve", "cluster", "--grains", str(path), "--V", "0.6", "--theta", "30"]
    code = main(args + extra)
    cap = capsys.readouterr()
    err = cap.err.strip()
    assert code == 2 and cap.out == ""
    assert err.startswith("capbridge: error:") and "\n" not in err and "Traceback" not in err
    assert words in err


def test_cli_shape_target_checked_before_the_solve(tmp_path, capsys):
    (tmp_path / "s.vtp").write_text("")
    grains = _grains_csv(tmp_path / "g.csv", TETRA)
    code = main(["solve", "cluster", "--grains", grains, "--V", "0.6", "--theta", "30",
                 "--shape", str(tmp_path / "s.vtp")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "--overwrite" in err and "\n" not in err


def test_cli_without_a_result_exits_3_with_nulls(tmp_path, capsys, monkeypatch):
    """A solve without a result: status and reason, no numbers, exit 3 (the solver is
    replaced by one that fails, as Evolver does on a body with no equilibrium)."""
    import capbridge.solvers.cluster as cluster
    from capbridge.status import Status

    def failed(centres, radii, *a, **kw):
        C, R, r = check_cluster(centres, radii)
        return {"status": Status.NOT_CONVERGED, "reason": "neck pinched", "r": r,
                "refinement": -1, "n_facets": 0, "cpu_time": 1.0, "warnings": [],
                "shape": None, "pairs": None,
                **dict.fromkeys(("forces", "force_error", "force_error_rel", "force_sum",
                                 "pressure", "energy", "energy_error"))}

    monkeypatch.setattr(cluster, "solve_cluster", failed)
    grains = _grains_csv(tmp_path / "g.csv", TETRA)
    code = main(["solve", "cluster", "--grains", grains, "--V", "0.6", "--theta", "30",
                 "--shape", str(tmp_path / "s.vtp")])
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert code == 3 and out["status"] == "not_converged" and out["reason"] == "neck pinched"
    assert out["forces"] is None and out["pair_forces"] is None and out["shape"] is None
    assert not out["pair_forces_determined"] and "no surface written" in cap.err


@pytest.mark.evolver
def test_rhombus_forces_have_its_mirror_symmetries(evolver):
    """Two triangles sharing an edge (a starting body with rings reaching the
    neighbours): the forces have the rhombus' two mirror planes (grains 0 and 1 pulled
    towards each other along x, grains 2 and 3 along y) and sum to zero, within the
    result's own error estimate."""
    D = 2.05
    h = D * np.sqrt(3) / 2
    rhombus = np.array([[0.0, 0, 0], [D, 0, 0], [D / 2, h, 0], [D / 2, -h, 0]])
    res = solve_cluster(rhombus, 1.0, 1.0, THETA, max_refine=2)
    assert res["status"] in HAS_RESULT
    F, err = np.asarray(res["forces"]), float(np.max(res["force_error"]))
    tol = max(err, 1e-6)
    assert F[0, 0] > 0.5 and F[2, 1] < -0.5             # attraction into the rhombus
    np.testing.assert_allclose(F[0], -F[1], atol=tol)
    np.testing.assert_allclose(F[2], -F[3], atol=tol)
    np.testing.assert_allclose(F[:, 2], 0.0, atol=tol)  # the plane of the centres
    np.testing.assert_allclose(F[[0, 1], 1], 0.0, atol=tol)
    np.testing.assert_allclose(F[[2, 3], 0], 0.0, atol=tol)
    np.testing.assert_allclose(F.sum(0), 0.0, atol=tol)
