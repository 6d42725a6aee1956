"""SphereWallSurrogate: the surrogate contract on sphere-wall slices, checked against the
exact sphere-wall solver at held-out points."""
from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from capbridge.solvers.sphere_wall import (solve_sphere_wall, sphere_wall_rupture_distance,
                                           sphere_wall_table)
from capbridge.status import Status
from capbridge.surrogate.wall import SphereWallSurrogate
from capbridge.validation import CapbridgeInputError

#: the doublet table's V* axis (as the engine's WallTable uses)
VOLUMES = np.geomspace(1e-3, 0.5, 25)
PAIR = (20.0, 40.0)
#: stated tolerances at held-out points with s = sqrt(1 - d*/d*_rupt) >= 0.2 (d* <= 0.96
#: d*_rupt; nearer, dF/dd* diverges at the fold, as for the doublet), relative to the
#: exact solution.  Measured (seed 5, 60 points, (20, 40) deg): force 0.038 % max,
#: pressure 0.34 %, rupture gap 0.31 %; at (30, 30): 0.074 %, 0.15 %, 4e-8.
FORCE_RTOL = 3e-3
PRESSURE_RTOL = 1e-2
RUPTURE_RTOL = 1e-2


@pytest.fixture(scope="module")
def sur():
    return SphereWallSurrogate().fit([sphere_wall_table(*PAIR, VOLUMES)])


def test_unfitted_raises_not_fitted():
    s = SphereWallSurrogate()
    for call in (lambda: s.predict(0.1, 0.05, 30.0), s.summary, lambda: s.profiles([0], 0.05),
                 lambda: s.slice_index(30.0, 30.0)):
        with pytest.raises(NotFittedError):
            call()
    with pytest.raises(RuntimeError):                 # the old error type still works
        s.predict(0.1, 0.05, 30.0)


def test_matches_exact_solver_at_held_out_points(sur):
    rng = np.random.default_rng(5)
    n = 40
    v = np.exp(rng.uniform(np.log(VOLUMES[0]), np.log(VOLUMES[-1]), n))
    s = rng.uniform(0.2, 1.0, n)
    d_r = sur.predict(0.0, v, *PAIR)["rupture_gap"]
    gap = d_r * (1 - s**2)
    ex = solve_sphere_wall(gap, v, *PAIR)
    r = sur.predict(gap, v, *PAIR)
    ok = ex["status"] == Status.CONVERGED
    assert ok.sum() >= 0.9 * n
    assert (r["status"][ok] == Status.CONVERGED).all()
    assert np.max(np.abs(r["force"][ok] / ex["force"][ok] - 1)) < FORCE_RTOL
    assert np.max(np.abs(r["pressure"][ok] / ex["pressure"][ok] - 1)) < PRESSURE_RTOL
    er = sphere_wall_rupture_distance(v[:10], *PAIR)
    assert np.max(np.abs(d_r[:10] / er["gap"] - 1)) < RUPTURE_RTOL


def test_statuses_and_no_result_rule(sur):
    d_r = float(sur.predict(0.0, 0.05, *PAIR)["rupture_gap"])
    r = sur.predict([-0.01, 0.0, 0.5 * d_r, 1.01 * d_r], 0.05, *PAIR)
    assert r["status"].tolist() == [Status.CONVERGED] * 3 + [Status.RUPTURED]
    assert r["force"][0] == r["force"][1] > 0              # a DEM overlap is contact
    assert r["force"][3] == 0.0 and np.isnan(r["pressure"][3])
    assert set(r) == {"force", "pressure", "rupture_gap", "status"}
    assert r["status"].dtype == np.int8


@pytest.mark.parametrize("kw, word", [(dict(gap=-0.2), "gap"), (dict(volume=-1.0), "volume"),
                                      (dict(volume=5.0), "outside the sphere-wall table"),
                                      (dict(theta_s=95.0), "theta_s"),
                                      (dict(theta_s=30.0, theta_w=30.0), "no fitted")])
def test_bad_input_is_refused(sur, kw, word):
    args = dict(gap=0.05, volume=0.05, theta_s=PAIR[0], theta_w=PAIR[1]) | kw
    with pytest.raises(CapbridgeInputError, match=word):
        sur.predict(**args)


def test_summary_and_attributes(sur):
    assert sur.has_gravity_ is False
    s = sur.summary()
    assert s["pairs"] == [list(PAIR)] and s["volume"]["n"] == VOLUMES.size
