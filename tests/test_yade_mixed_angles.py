"""Exact mixed contact angles in real YADE: two grains of different materials
(theta = 0 deg on the smaller, 60 deg on the larger, ratio 1.25) pulled apart by
CapbridgeEngine.  The force YADE applies equals capbridge's exact Young-Laplace
solution for (theta1, theta2) within the table's error (max 0.35 % on tabulated ratios
for d* <= 0.96 d*_rupt), and the rupture gap is the exact one within 0.2 % (the mean-angle
rule it replaces is 20-60 % off: tests/test_yade_engine_unit.py)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from capbridge.dem_plugin import yade_runtime as yr
from capbridge.status import Status

SCENES = Path(__file__).parent / "yade_scenes"
GAMMA = 0.073
_YADE = yr.find_yade()
pytestmark = [pytest.mark.yade,
              pytest.mark.skipif(_YADE is None, reason="Debian's yade is not installed")]


def test_mixed_angle_pull_apart_is_the_exact_solver():
    from capbridge.generator.young_laplace import rupture_distance, solve_doublet

    r1, r2, t1, t2, vstar = 1e-3, 1.25e-3, 0.0, 60.0, 0.05
    res = yr.run_yade_script(SCENES / "pull_apart_capbridge.py", [
        "--r1", r1, "--r2", r2, "--theta", t1, "--theta2", t2, "--vstar", vstar,
        "--steps", 120, "--stretch", 1.1, "--tolerance", 0.0], timeout=240).result
    rows = res["rows"]
    axis = np.array(res["axis"])
    gaps = np.array([row["gap"] for row in rows]) / r1
    along = np.array([row["f0"] for row in rows]) @ axis / (2 * np.pi * GAMMA * r1)
    d_r = float(rupture_distance(vstar, t1, r2 / r1, t2)["gap"])
    assert res["d_rupt"] / r1 == pytest.approx(d_r, rel=2e-3)
    inner = gaps <= 0.96 * d_r
    assert inner.sum() > 80 and (gaps > d_r * 1.001).sum() > 5
    exact = solve_doublet(np.maximum(gaps[inner], 0.0), vstar, t1, r2 / r1, t2)
    assert np.all(exact["status"] == Status.CONVERGED)
    np.testing.assert_allclose(along[inner], exact["force"], rtol=3.5e-3)
    assert np.all(along[gaps > res["d_rupt"] / r1] == 0.0)          # none past rupture
