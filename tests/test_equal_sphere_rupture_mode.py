"""Which instability ends an equal-sphere, equal-angle bridge: the fold of the symmetric
family or the shift (symmetry-breaking) mode?

Independent check of ``rupture_distance`` (issue 9, item 7): the symmetric family at
fixed volume is built here from ``bridge_profile`` alone (beta1 = beta2, the mean
curvature found by root search on the volume), and its largest gap (the fold) is found
by a bounded scalar search.  Measured (V* = 0.01 / 0.05 / 0.2): rupture_distance equals
the fold to 1e-13 up to theta = 30 / 28 / 26 deg; from 31 / 29 / 27 deg on the fold lies
beyond it (the shift mode comes first; 0.8 % beyond at V* = 0.05, theta = 35 deg).  The
test pins one point on each side at V* = 0.05.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from capbridge.solvers.young_laplace import bridge_profile, rupture_distance

_H = np.linspace(-40.0, 3.0, 2000)        # mean curvature scan (suction side mostly)


def _symmetric_gap(beta, theta, vstar):
    """Gap of the symmetric bridge (beta1 = beta2 = beta) holding V*."""
    v = bridge_profile(_H, beta, beta, theta, theta, 1.0)["volume"] - vstar
    ok = np.isfinite(v)
    s = np.flatnonzero(ok[:-1] & ok[1:] & (v[:-1] * v[1:] < 0))
    if s.size == 0:
        return np.nan
    k = s[-1]                              # the least concave root: the stable branch
    f = lambda h: float(bridge_profile(h, beta, beta, theta, theta, 1.0)["volume"]) - vstar  # noqa: E731
    h = brentq(f, _H[k], _H[k + 1], xtol=1e-15, rtol=1e-15)
    return float(bridge_profile(h, beta, beta, theta, theta, 1.0)["gap"])


def _fold(theta_deg, vstar, beta_guess):
    th = np.radians(theta_deg)
    r = minimize_scalar(lambda b: -_symmetric_gap(b, th, vstar), method="bounded",
                        bounds=(0.8 * beta_guess, 1.3 * beta_guess), options={"xatol": 1e-9})
    return -r.fun


@pytest.mark.parametrize("theta,mode", [(20.0, "fold"), (35.0, "shift")])
def test_rupture_is_the_fold_below_the_crossover_and_the_shift_above(theta, mode):
    vstar = 0.05
    rup = rupture_distance(vstar, theta)
    d_r, beta_r = float(rup["gap"]), np.radians(float(rup["beta1"]))
    assert float(rup["beta2"]) == pytest.approx(float(rup["beta1"]), rel=1e-9)   # symmetric
    d_fold = _fold(theta, vstar, beta_r)
    if mode == "fold":
        assert d_r == pytest.approx(d_fold, rel=1e-9)
    else:
        assert d_fold > d_r * 1.005        # the symmetric family goes on: shift mode first
