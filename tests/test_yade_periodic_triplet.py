"""A coalesced triplet across a periodic cell's boundary (issue 18, item 4).

Scene ``tests/yade_scenes/periodic_triplet.py``: three fixed equal grains in a closed
triangle (gaps 0.05 r, V* = 0.12 per bridge, theta = 30 deg: v = 1.58 of the table's
V*_coal), once in the middle of a sheared periodic cell and once across its x = 0 face
(raw centre distances ~1 cell).  Before the coalescence check used nearest-image
vectors the engine switched detection off in periodic cells (both placements kept
doublet forces); now both placements merge into one cluster and YADE applies the same
triplet forces (to round-off of the shifted positions).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr

SCENE = Path(__file__).parent / "yade_scenes" / "periodic_triplet.py"
pytestmark = pytest.mark.yade


@pytest.fixture(scope="module")
def run(yade):
    return yr.run_yade_script(SCENE, [], timeout=300).result


def test_the_triplet_merges_inside_and_across_the_boundary(run):
    for where in ("inside", "across"):
        assert run[where]["coalescence"]["closed_triangles"] == 3, where
        assert run[where]["triplets"]["clusters"] == 1, where
        assert run[where]["triplets"]["events"]["merged"] == 1, where
    # the across placement really straddles: raw distances of ~ a cell, not ~ 2 r
    assert max(run["across"]["raw_distances"]) > 4 * min(run["inside"]["raw_distances"])


def test_across_the_boundary_gives_the_same_forces(run):
    fin, fac = np.array(run["inside"]["forces"]), np.array(run["across"]["forces"])
    scale = np.abs(fin).max()
    assert scale > 0
    # the same triangle: equal forces up to the round-off of positions shifted by L
    np.testing.assert_allclose(fac, fin, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(fac.sum(axis=0), 0.0, atol=1e-12 * scale)
