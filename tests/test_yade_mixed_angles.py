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

from capbridge.yade import yade_runtime as yr
from capbridge.status import Status

SCENES = Path(__file__).parent / "yade_scenes"
GAMMA = 0.073
pytestmark = pytest.mark.yade


def test_mixed_angle_pull_apart_is_the_exact_solver():
    from capbridge.solvers.young_laplace import rupture_distance, solve_doublet

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


def test_yade_law2_with_a_mixed_angle_export(tmp_path):
    """Where YADE's format allows it (every bridge of the scene joins the two
    materials): capbridge's export for (0, 60) deg read by YADE's compiled Law2 gives
    the exact suction solution for that pair within 0.5 %, nothing past rupture."""
    from capbridge.yade import yade_export as ye
    from capbridge.solvers import young_laplace as yl

    t1, t2, r = 0.0, 60.0, 1e-3
    suctions = np.array([0.0, 0.5, 1.0, 2.0, 5.0])
    with pytest.warns(UserWarning, match="placeholder"):
        ye.export_from_solver(tmp_path, t1, ratios=(1.0,), suctions=suctions, n_gaps=25,
                              missing="stub", delaunay=False, theta2=t2)
    assert (tmp_path / ("M(r=1)" + ye.theta_suffix(t1, t2))).exists()
    s_star = suctions[2]
    g_r = float(yl.suction_rupture_distance(-s_star, t1, theta2=t2)["gap"])
    gaps = np.array([0.0, 0.15, 0.3, 0.55, 0.7, 1.3]) * g_r
    run = yr.run_yade_script(SCENES / "suction_native_capbridge.py", [
        "--dir", tmp_path, "--theta", t1, "--theta2", t2, "--r", r,
        "--suction", s_star * GAMMA / r, "--gamma", GAMMA,
        "--gaps=" + ",".join(repr(g * r) for g in gaps)], timeout=240)
    rows = run.result["rows"]
    exact = yl.solve_doublet_suction(gaps[:-1], -s_star, t1, theta2=t2)
    assert np.all(exact["status"] == Status.CONVERGED)
    same = yl.solve_doublet_suction(gaps[:-1], -s_star, t1)          # theta2 = theta1
    scale = 2 * np.pi * GAMMA * r
    for row, f, f_same in zip(rows, exact["force"], same["force"]):
        assert row["force"] == pytest.approx(f * scale, rel=5e-3)
        assert abs(f / f_same - 1) > 0.05          # the pair of angles matters here
    assert rows[-1]["force"] == 0.0 and not rows[-1]["interaction"]
