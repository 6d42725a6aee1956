"""Linear fit V_coal = V0 + (theta/dtheta) dV (Miot et al. 2021, Eq. 8)."""
import numpy as np
import pytest

from capbridge.physics.coalescence_fit import PAPER_FIT, CoalescenceVolumeFit
from capbridge.validation import CapbridgeInputError


def test_recovers_the_paper_line_and_residuals():
    t = np.array([0, 15, 30, 45, 60, 75, 90.0])
    v = PAPER_FIT["V0"] + t / 90 * PAPER_FIT["dV"]
    fit = CoalescenceVolumeFit().fit(t, v)
    assert fit.V0 == pytest.approx(14.5, abs=1e-10)
    assert fit.dV == pytest.approx(18.0, abs=1e-10)
    assert fit.max_abs_residual < 1e-10 and fit.r2 == pytest.approx(1.0)
    assert fit.predict([0, 90]) == pytest.approx([14.5, 32.5])


def test_residuals_show_curvature():
    t = np.linspace(0, 90, 10)
    v = 14 + 0.2 * t - 0.001 * t ** 2
    fit = CoalescenceVolumeFit(dtheta=90).fit(t, v)
    assert fit.residuals == pytest.approx(v - fit.predict(t))
    assert fit.max_abs_residual > 0.5
    assert np.sign(fit.residuals[0]) == np.sign(fit.residuals[-1]) == -1   # concave
    assert np.isfinite(fit.stderr[0]) and fit.stderr[1] > 0
    d = fit.as_dict()
    assert set(d) >= {"V0", "dV", "dtheta", "residuals", "rms_residual", "r2"}


def test_dtheta_only_rescales_dV():
    t, v = [0, 30, 60], [10.0, 13.0, 16.0]
    a = CoalescenceVolumeFit(90).fit(t, v)
    b = CoalescenceVolumeFit(30).fit(t, v)
    assert a.dV == pytest.approx(3 * b.dV) and a.V0 == pytest.approx(b.V0)


def test_errors():
    with pytest.raises(CapbridgeInputError):
        CoalescenceVolumeFit().fit([10], [1.0])
    with pytest.raises(CapbridgeInputError):
        CoalescenceVolumeFit().fit([10, 10], [1.0, 2.0])
    with pytest.raises(CapbridgeInputError):
        CoalescenceVolumeFit().fit([0, 10], [1.0, -2.0])
    with pytest.raises(RuntimeError):
        CoalescenceVolumeFit().predict(10.0)
