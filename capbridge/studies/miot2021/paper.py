"""The numbers Miot et al. (2021) state, against which ``CLAIMS.md`` sets ours."""
from __future__ import annotations

#: the paper's stated numbers (DESIGN.md), used by the claims table
PAPER = {
    "V_coal_theta0_ul": (14.0, 14.5),
    "V_coal_fit": {"V0": 14.5, "dV": 18.0, "dtheta": 90.0},
    "Bo": {0.073: 2.14, 0.0693: 2.26},
    "V_coal_gravity_0693_theta55_60_ul": (24.0, 26.0),
    "beta_alpha_gap_at_20ul_theta60_deg": 3.0,
    "convergence_5_7_max_pct": 0.35,
    "convergence_6_7_max_pct": 0.07,
}

FIG3_VOLUMES = (0.008, 0.156)      # V* of the doublets of Fig. 3


def paper_line(theta):
    """The paper's linear V_coal(theta) [ul]: V0 + theta / dtheta * dV (:data:`PAPER`)."""
    f = PAPER["V_coal_fit"]
    return f["V0"] + theta / f["dtheta"] * f["dV"]


#: the paper's line in words (figure legend, CLAIMS.md)
PAPER_LINE_TEXT = "{V0:g} + theta/{dtheta:g} x {dV:g}".format(**PAPER["V_coal_fit"])
