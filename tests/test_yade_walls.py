"""Wall bridges, periodic cells and VTK output of the YADE engine (issue 9 items 4-6).

Real YADE runs (scenes in tests/yade_scenes/wall_*.py, periodic_*.py), each asserting
numbers:

* a sphere pulled away from a Wall, a tilted Box and a Facet (theta 20 deg on the
  sphere, 40 deg on the wall, V* = 0.05): the force YADE applies equals the exact
  sphere-plane solution (``solve_sphere_wall``) within the wall table's interpolation
  error (measured 5.5e-3 relative at worst over 192 mid-cell points of this slice,
  median 3e-5) up to 98 % of the rupture gap, points exactly towards the wall, its reaction on the wall body is
  exactly opposite (with the torque about the facet's centre), and the bridge ruptures
  within one step of the exact rupture gap;
* the contact limit: at contact the force tends to 4 pi gamma R cos(theta) as V* -> 0
  (the engine at the table's smallest V* = 1e-3 gives the exact solver's 0.9602 of it,
  and the exact deviation shrinks like V*^(1/4) towards 0);
* conserving rule: a wall bridge takes half the sphere's film and gives all of it back;
  the ledger balances to round-off at every step; after O.saveTmp/O.loadTmp the wall
  forces and films are those of the uninterrupted run;
* a periodic pull-apart across the (sheared) cell's boundary equals the same pull-apart
  inside the cell to 1e-12 of the force;
* the VTK files read back (``vtk_output.read_vtk``): ends at the sphere centres and the
  wall feet / nearest images, volumes and forces bit for bit.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr
from capbridge.dem.periodic import PeriodicCell
from capbridge.dem.vtk_output import read_vtk
from capbridge.dem.wall_bridges import _closest_on_triangles
from capbridge.solvers.sphere_wall import solve_sphere_wall

SCENES = Path(__file__).parent / "yade_scenes"
#: the sphere-wall table's interpolation error, measured for the (20, 40) deg slice
#: (largest relative error over 8 random gaps in every volume cell: 5.5e-3)
TABLE_ERROR = 6e-3


def _run(scene, args=(), timeout=300):
    return yr.run_yade_script(SCENES / scene, [str(a) for a in args], timeout=timeout).result


@pytest.fixture(scope="module")
def wall_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("wall_vtk")
    return _run("wall_capbridge.py", ["--vtk", d]), d


@pytest.mark.parametrize("k, partner", [(0, "Wall"), (1, "Box"), (2, "Facet")])
@pytest.mark.yade
def test_wall_force_equals_exact_sphere_plane_bridge(wall_run, k, partner):
    """Pull-apart from each partner kind: force on the sphere = exact F*(d*, V*) 2 pi
    gamma R within the table's error, along the normal; reaction exactly opposite;
    rupture within one step of the exact rupture gap."""
    res, _ = wall_run
    R, n = res["radii"][k], np.array(res["normals"][k])
    gamma = res["gamma"]
    gaps = np.array([r["gap"][k] for r in res["rows"]]) / R
    f = np.array([r["f"][k] for r in res["rows"]])
    f_wall = np.array([r["f_wall"][k] for r in res["rows"]])
    towards = -f @ n
    alive = towards > 0
    assert alive[0] and not alive[-1]
    # direction: exactly along the partner's normal, towards it
    assert np.abs(f + towards[:, None] * n).max() <= 1e-12 * towards.max()
    # the partner body gets the opposite force (YADE's O.forces.f of the wall body)
    np.testing.assert_allclose(f_wall, -f, rtol=0, atol=1e-15 * towards.max())
    # up to 98 % of the rupture gap: nearer, the exact solver's own solutions jump
    # between branches for V* ~ 0.062-0.066 at (20, 40) deg (F* at 0.99 d*_rupt: 0.101,
    # 0.073, 0.074, 0.102 for V* = 0.060, 0.062, 0.063, 0.064), and the slice inherits
    # that node (engine off by up to 3 % there; reported, see docs/validation.md)
    sel = np.flatnonzero(alive & (gaps <= 0.98 * res["d_rupt_star"]))[::4]
    exact = solve_sphere_wall(np.maximum(gaps[sel], 0.0), res["vstar"], res["theta_s"],
                              res["theta_w"])
    assert np.all(exact["status"] == 0)
    f_exact = exact["force"] * 2 * np.pi * gamma * R
    err = np.abs(towards[sel] - f_exact) / f_exact
    assert err.max() < TABLE_ERROR, (partner, err.max())
    # rupture: the last gap with a bridge is below the exact rupture gap, the first
    # without one above it, and they are consecutive steps
    d_r = res["d_rupt_star"]
    last = np.flatnonzero(alive)[-1]
    assert gaps[last] <= d_r < gaps[last + 1]
    assert not alive[last + 1:].any()


@pytest.mark.yade
def test_facet_reaction_torque(wall_run):
    """The reaction on the facet acts at the foot: its torque about the facet's centre
    is (foot - centre) x F_wall."""
    res, _ = wall_run
    row = res["rows"][5]
    R = res["radii"][2]
    verts = np.array([(-5e-3, 15e-3, 10e-3), (5e-3, 15e-3, 10e-3), (0, 28e-3, 10e-3)])
    # YADE puts a facet's body at the centre of its inscribed circle
    a, b, c = (np.linalg.norm(verts[(i + 1) % 3] - verts[(i + 2) % 3]) for i in range(3))
    centre = (a * verts[0] + b * verts[1] + c * verts[2]) / (a + b + c)
    centre_sphere_xy = np.array([0.0, 20e-3])
    foot = np.array([*centre_sphere_xy, 10e-3])
    fw = np.array(row["f_wall"][2])
    np.testing.assert_allclose(row["t_wall"][2], np.cross(foot - centre, fw), rtol=0,
                               atol=1e-12 * np.linalg.norm(fw) * R)
    assert np.linalg.norm(row["t_wall"][2]) > 0


@pytest.mark.yade
def test_wall_vtk_read_back(wall_run):
    """cap.write_vtk: one line per wall bridge from the sphere centre to the foot on
    the partner, volume V* R^3, the force vector, flagged as wall bridges; the
    recorder's series lists one file per 40 steps."""
    res, d = wall_run
    v = res["vtk"]
    got = read_vtk(v["files"][0])
    cd = got["cell_data"]
    assert got["lines"].shape == (3, 2)
    ends = got["points"][got["lines"]]
    np.testing.assert_array_equal(ends, np.array(v["ends"]))
    np.testing.assert_array_equal(cd["volume"], v["volume"])
    np.testing.assert_array_equal(cd["force"], v["force"])
    np.testing.assert_array_equal(cd["wall"], [1, 1, 1])
    np.testing.assert_array_equal(cd["id2"], res["w_ids"])
    R = np.array(res["radii"])
    np.testing.assert_allclose(cd["volume"], res["vstar"] * R**3, rtol=1e-15)
    # second end = the foot: on the partner's plane, one radius + gap from the centre
    n = np.array(res["normals"])
    dist = np.einsum("ij,ij->i", ends[:, 0] - ends[:, 1], n)
    np.testing.assert_allclose(dist, R + cd["gap"], rtol=1e-12)
    series = read_pvd(Path(d) / "walls_bridges.pvd")
    # the PyRunner runs at iterations 40, 80, ..., 200 of the 240 steps
    assert [f.name[-13:-4] for f in series] == [f"{i:09d}" for i in range(40, 240, 40)]
    assert read_vtk(series[0])["lines"].shape == (3, 2)


def read_pvd(path):
    import xml.etree.ElementTree as ET

    return [path.parent / e.get("file") for e in ET.parse(path).getroot().iter("DataSet")]


@pytest.mark.yade
def test_wall_contact_limit_small_volume():
    """F -> 4 pi gamma R cos(theta) at contact as V* -> 0 (theta = 0 here): the engine
    at the table's smallest V* = 1e-3 gives the exact solver's value (a table node, to
    1e-9), 0.9602 of the limit, and the exact deviation falls like V*^(1/4)."""
    res = _run("wall_capbridge.py", ["--theta-s", 0, "--theta-w", 0, "--vstar", 1e-3,
                                     "--steps", 2])
    R = np.array(res["radii"])
    F = np.linalg.norm(np.array(res["rows"][0]["f"]), axis=1)
    limit = 4 * np.pi * res["gamma"] * R
    exact = solve_sphere_wall(0.0, np.array([1e-3, 1e-5, 1e-7]), 0.0)["force"] / 2.0
    np.testing.assert_allclose(F / limit, exact[0], rtol=1e-9)
    assert 0.95 < exact[0] < 0.97
    dev = 1.0 - exact
    assert np.all(dev > 0)
    # two decades of V* shrink the deviation by 10^(2/4) = 3.2 (measured 3.3, 3.2)
    np.testing.assert_allclose(dev[:-1] / dev[1:], 10 ** 0.5, rtol=0.1)


@pytest.mark.yade
def test_wall_bridges_conserve_liquid():
    """Conserving rule: each wall bridge takes half its sphere's film (V* R^3 of 2 V*
    R^3) at the first step and returns all of it at rupture; the ledger balances
    exactly at every step."""
    res = _run("wall_capbridge.py", ["--rule", "conserved"])
    R = np.array(res["radii"])
    v = res["vstar"] * R**3
    rows = res["rows"]
    assert rows[0]["n_wall_bridges"] == 3 and rows[-1]["n_wall_bridges"] == 0
    np.testing.assert_allclose(rows[0]["films"], v, rtol=1e-12)
    np.testing.assert_allclose(rows[0]["wall_volume"], v.sum(), rtol=1e-12)
    np.testing.assert_allclose(rows[-1]["films"], 2 * v, rtol=1e-12)
    assert max(r["budget_error"] for r in rows) < 1e-12


@pytest.mark.yade
def test_wall_bridges_survive_save_tmp_load_tmp():
    """O.saveTmp, 60 steps in which the three wall bridges rupture, O.loadTmp, the same
    60 steps: the forces on spheres and walls are the same (to 1e-9 of the largest),
    and so are the films."""
    res = _run("wall_capbridge.py", ["--reload", "--rule", "conserved"])
    a = np.array([r["f"] for r in res["before"]])
    b = np.array([r["f"] for r in res["after"]])
    assert np.abs(a).max() > 0
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * np.abs(a).max())
    n = [r["n"] for r in res["before"]]
    assert n[0] == 3 and n[-1] == 0                   # ruptures happen in the window
    assert n == [r["n"] for r in res["after"]]
    np.testing.assert_allclose([r["films"] for r in res["after"]],
                               [r["films"] for r in res["before"]], rtol=1e-15)


@pytest.fixture(scope="module")
def periodic_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("periodic_vtk")
    return _run("periodic_capbridge.py", ["--vtk", d])


@pytest.mark.yade
def test_periodic_pull_apart_across_boundary_equals_inside(periodic_run):
    """Sheared periodic cell: the pull-apart whose grains touch only through the
    boundary (their scene distance is ~L) gives the forces of the pull-apart inside the
    cell, to 1e-12 of the largest, including the rupture step."""
    res = periodic_run
    rows = res["rows"]
    f = np.array([r["f"] for r in rows])
    g = np.array([r["gap"] for r in rows])
    assert min(r["raw_distance"][1] for r in rows) > 0.5 * res["L"]
    np.testing.assert_allclose(g[:, 1], g[:, 0], rtol=0, atol=1e-15)
    scale = np.abs(f).max()
    assert scale > 1e-4
    np.testing.assert_allclose(f[:, 2:], f[:, :2], rtol=0, atol=1e-12 * scale)
    alive = np.linalg.norm(f[:, 0], axis=1) > 0
    last = np.flatnonzero(alive)[-1]
    assert g[last, 0] <= res["d_rupt"] < g[last + 1, 0]
    assert rows[0]["n_bridges"] == 2 and rows[-1]["n_bridges"] == 0


@pytest.mark.yade
def test_periodic_vtk_lines_use_nearest_image(periodic_run):
    """VTK: the bridge across the boundary is drawn from its first grain to the nearest
    image of the second (length 2R + gap, not ~L); volumes read back bit for bit, the
    force's norm to round-off."""
    v = periodic_run["vtk"]
    got = read_vtk(v["files"][0])
    ends = got["points"][got["lines"]]
    length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    np.testing.assert_allclose(length, 2 * periodic_run["R"] + got["cell_data"]["gap"], rtol=1e-12)
    assert length.max() < 0.5 * periodic_run["L"]
    np.testing.assert_array_equal(got["cell_data"]["volume"], v["volume"])
    # the vector is written; its norm is the bridge force to round-off
    np.testing.assert_allclose(got["cell_data"]["force_magnitude"], v["force"], rtol=1e-15)
    np.testing.assert_array_equal(got["cell_data"]["id1"], v["id1"])


# ------------------------------------------------------------------ pure numpy parts


def test_periodic_near_pairs_equal_brute_force():
    """Near pairs of a sheared cell through its faces = the brute-force minimum over
    the 27 images, and the minimum-image vectors are the shortest ones."""
    rng = np.random.default_rng(3)
    h = np.array([[1.0, 0.3, 0.1], [0.0, 0.9, -0.2], [0.0, 0.0, 1.1]])
    cell = PeriodicCell(h)
    pos = rng.uniform(-0.5, 1.5, (150, 3)) @ h.T         # some outside the cell
    cut = 0.25
    i, j, d = cell.near_pairs(pos, cut)
    # raw differences reach two cells: brute force over shifts -2..2
    shifts = np.array(np.meshgrid(*[np.arange(-2, 3)] * 3, indexing="ij")).reshape(3, -1).T @ h.T
    dd = pos[None, :, None, :] - pos[:, None, None, :] + shifts[None, None]   # (n, n, 125, 3)
    dmin = np.linalg.norm(dd, axis=3).min(axis=2)
    bi, bj = np.nonzero(np.triu(dmin < cut, 1))
    assert bi.size > 20
    np.testing.assert_array_equal(np.column_stack([i, j]), np.column_stack([bi, bj]))
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), dmin[i, j], rtol=1e-12)


def test_closest_point_on_triangle_brute_force():
    """The foot on a facet is the closest of 200k points sampled on the triangle (to
    the sampling resolution), inside, on an edge or at a vertex."""
    rng = np.random.default_rng(5)
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0.2, 0]), np.array([0.3, 1.0, 0.1])
    u, v = rng.uniform(size=(2, 200_000))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    samples = a + u[:, None] * (b - a) + v[:, None] * (c - a)
    p = np.array([[0.4, 0.3, 0.5], [1.5, 0.2, 0.3], [-0.5, -0.5, 0.0], [0.6, 0.8, -0.3]])
    k = len(p)
    foot = _closest_on_triangles(p, np.tile(a, (k, 1)), np.tile(b, (k, 1)), np.tile(c, (k, 1)))
    best = np.linalg.norm(samples[None] - p[:, None], axis=2).min(axis=1)
    got = np.linalg.norm(foot - p, axis=1)
    assert np.all(got <= best + 1e-12)
    np.testing.assert_allclose(got, best, atol=5e-3)
