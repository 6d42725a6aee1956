"""capbridge.surrogate.grid: the one grid kernel the surrogates and the engine share."""
from __future__ import annotations

import numpy as np

from capbridge.surrogate import doublet, grid, triplet, wall


def test_users_share_the_kernel():
    assert triplet._Grid is grid.Grid and triplet._FineAxis is grid.FineAxis
    assert triplet._Descending is grid.Descending
    assert wall.profile_value is grid.profile_value
    assert doublet.UniformAxis is grid.UniformAxis


def test_bilinear_flat_is_bilinear():
    rng = np.random.default_rng(0)
    g = rng.normal(size=(3, 7, 9))
    av, as_ = grid.UniformAxis(0.0, 1.0, 7), grid.UniformAxis(0.0, 1.0, 9)
    n = 500
    sl = rng.integers(0, 3, n)
    iv, fv = av.locate(rng.uniform(0, 1, n))
    i_s, fs = as_.locate(rng.uniform(0, 1, n))
    got = grid.bilinear_flat(g.ravel(), (sl * 7 + iv) * 9 + i_s, 9, fs, fv)
    want = np.array([grid.bilinear(g[s], iv[m:m + 1], fv[m:m + 1], i_s[m:m + 1],
                                   fs[m:m + 1])[0] for m, s in enumerate(sl)])
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)


def test_uniform_axis_locates_nodes_and_clips():
    ax = grid.UniformAxis(-1.0, 2.0, 4)
    i, f = ax.locate(np.array([-1.0, 0.5, 2.0, 3.0]))
    assert i.tolist() == [0, 1, 2, 2]
    np.testing.assert_allclose(f, [0.0, 0.5, 1.0, 2.0])
    fa = grid.FineAxis([0.0, 1.0, 3.0], 2)
    np.testing.assert_allclose(fa.nodes, [0.0, 0.5, 1.0, 2.0, 3.0])


def test_multilinear_gather_of_all_corners_equals_corner_by_corner(monkeypatch):
    """The multilinear kernel gathers a few points' corners at once (the DEM step's
    clusters) and goes corner by corner for many: the two give the same numbers (the
    same sums in the same order, to round-off), and the nodes back exactly."""
    rng = np.random.default_rng(3)
    vals = rng.normal(size=(5, 4, 6, 3, 7))
    g = grid.Grid(vals, "multilinear")
    idx = [rng.integers(0, s - 1, 40) for s in vals.shape[:-1]]
    fr = [rng.uniform(0, 1, 40) for _ in idx]
    together = g(idx, fr)
    monkeypatch.setattr(grid, "GATHER_MAX", 0)
    one_by_one = g(idx, fr)
    np.testing.assert_allclose(together, one_by_one, rtol=1e-14, atol=1e-14)
    zero = [np.zeros(40)] * 4
    np.testing.assert_array_equal(g(idx, zero), vals[tuple(idx)])
