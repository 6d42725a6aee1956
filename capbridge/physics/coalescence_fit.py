"""Linear fit of the coalescence volume against the contact angle (Miot et al. 2021, Eq. 8).

    V_coal(theta) = V0 + (theta / dtheta) * dV

The paper reports V0 = 14.5 ul, dV = 18 ul, dtheta = 90 deg for its triplet (r = 4 mm,
so V* = V / 64).  :class:`CoalescenceVolumeFit` fits V0 and dV by (weighted) least
squares for a fixed ``dtheta`` and keeps the residuals, so that "linear" can be judged.

>>> fit = CoalescenceVolumeFit().fit([0, 30, 60, 90], [14.5, 20.5, 26.5, 32.5])
>>> round(fit.V0, 6), round(fit.dV, 6), round(fit.max_abs_residual, 9)
(14.5, 18.0, 0.0)
>>> round(fit.predict(45.0), 9)
23.5
"""
from __future__ import annotations

import numpy as np

from capbridge.validation import CapbridgeInputError, check_range

__all__ = ["CoalescenceVolumeFit", "PAPER_FIT"]

#: Miot et al. (2021), Eq. (8) and Fig. 10 (volumes in ul for r = 4 mm)
PAPER_FIT = {"V0": 14.5, "dV": 18.0, "dtheta": 90.0, "units": "ul", "radius_mm": 4.0}


class CoalescenceVolumeFit:
    """Least-squares line V_coal = V0 + (theta/dtheta) dV.

    Parameters
    ----------
    dtheta : float, default 90
        Angle step [deg] that ``dV`` refers to (the paper's 90 deg).

    Attributes after :meth:`fit`: ``V0``, ``dV`` (units of the input volumes),
    ``residuals`` (data - fit, same order as the input), ``rms_residual``,
    ``max_abs_residual``, ``r2``, ``theta``, ``volume``, ``stderr`` (standard errors of
    V0 and dV from the residual variance; NaN with two points).
    """

    def __init__(self, dtheta=90.0):
        self.dtheta = float(check_range("dtheta", dtheta, 0.0, np.inf, low_open=True))
        self.V0 = np.nan
        self.dV = np.nan

    def fit(self, theta, volume, weights=None):
        """Fit to contact angles ``theta`` [deg] and coalescence volumes ``volume``."""
        t = np.atleast_1d(check_range("theta", theta, 0.0, 180.0, units=" deg"))
        v = np.atleast_1d(check_range("coalescence volume", volume, 0.0, np.inf,
                                      low_open=True))
        if t.shape != v.shape:
            raise CapbridgeInputError(f"{t.size} angles but {v.size} volumes")
        if t.size < 2 or np.ptp(t) == 0:
            raise CapbridgeInputError("at least two distinct contact angles are needed")
        w = np.ones_like(t) if weights is None else np.atleast_1d(
            check_range("weights", weights, 0.0, np.inf, low_open=True))
        A = np.stack([np.ones_like(t), t / self.dtheta], axis=1)
        sw = np.sqrt(w)
        coef, *_ = np.linalg.lstsq(A * sw[:, None], v * sw, rcond=None)
        self.V0, self.dV = float(coef[0]), float(coef[1])
        self.theta, self.volume = t, v
        self.residuals = v - A @ coef
        self.rms_residual = float(np.sqrt(np.mean(self.residuals ** 2)))
        self.max_abs_residual = float(np.max(np.abs(self.residuals)))
        ss = float(np.sum((v - v.mean()) ** 2))
        self.r2 = 1.0 - float(np.sum(self.residuals ** 2)) / ss if ss > 0 else 1.0
        dof = t.size - 2
        if dof > 0:
            s2 = float(np.sum(w * self.residuals ** 2)) / dof
            cov = s2 * np.linalg.inv((A * w[:, None]).T @ A)
            self.stderr = (float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1])))
        else:
            self.stderr = (np.nan, np.nan)
        return self

    def predict(self, theta):
        """V_coal at contact angles ``theta`` [deg] (float for scalar input)."""
        if not np.isfinite(self.V0):
            raise RuntimeError("call fit() first")
        t = np.asarray(check_range("theta", theta, 0.0, 180.0, units=" deg"))
        out = self.V0 + t / self.dtheta * self.dV
        return float(out) if out.ndim == 0 else out

    def as_dict(self):
        return {"V0": self.V0, "dV": self.dV, "dtheta": self.dtheta,
                "rms_residual": self.rms_residual, "max_abs_residual": self.max_abs_residual,
                "r2": self.r2, "stderr_V0": self.stderr[0], "stderr_dV": self.stderr[1],
                "theta": self.theta.tolist(), "volume": self.volume.tolist(),
                "residuals": self.residuals.tolist()}
