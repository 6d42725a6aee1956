"""The triplet of the experiment Miot et al. (2021) model, and the unit of its volumes.

El Korchi et al. (2017): three glass beads of radius r = 4 mm, bottom gap 0.3 mm
(d23* = 0.075), top gaps 0.7 mm (d12* = d13* = 0.175).  Volumes are given in ul = mm^3,
V* = V / r^3 = V / 64.
"""
from __future__ import annotations

import numpy as np

RADIUS = 4e-3                      # m
UL_PER_VSTAR = (RADIUS * 1e3) ** 3  # (4 mm)^3 = 64 ul
D12 = D13 = 0.175
D23 = 0.075
GAMMAS = (0.073, 0.0693)           # N/m


def vstar(ul):
    """Volume [ul] -> V* (over r^3)."""
    return np.asarray(ul, float) / UL_PER_VSTAR


def ul(v):
    """V* (over r^3) -> volume [ul]."""
    return np.asarray(v, float) * UL_PER_VSTAR
