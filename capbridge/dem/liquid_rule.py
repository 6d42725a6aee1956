"""The liquid rule of a DEM scene: how much liquid a bridge gets when it forms.

:class:`LiquidRule` states it (a fixed volume per bridge, a fixed V* per bridge, or a
total liquid shared among the bridges, conserved or not);
:class:`~capbridge.dem.bridges.BridgeModel` applies it at every formation and keeps the
ledger of the liquid it says must balance.
"""
from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["LiquidRule"]


@dataclasses.dataclass
class LiquidRule:
    """How much liquid a bridge gets when it forms (see ``docs/guide.md``, "Liquid rules").

    Exactly one of:

    ``bridge_volume``       every bridge that forms gets this volume [m^3];
    ``bridge_volume_star``  every bridge gets V = V* r^3 (r its smaller radius);
    ``total_liquid``        a total liquid volume [m^3] (the engine converts a water
                            content or a degree of saturation into it).

    With ``total_liquid`` and ``conserve=False`` the liquid is shared equally among the
    bridges present at the start and that volume becomes the fixed volume of every
    later bridge.  With ``conserve=True`` (default for ``total_liquid``) the liquid is
    conserved: it starts shared equally among the initial bridges, a ruptured bridge
    gives its liquid back to its two grains (in proportion to their surface, R^2) and a
    new bridge takes ``film_fraction`` of the liquid held by each of its two grains.
    """

    bridge_volume: float | None = None
    bridge_volume_star: float | None = None
    total_liquid: float | None = None
    conserve: bool | None = None
    film_fraction: float = 0.5

    def __post_init__(self):
        given = [k for k in ("bridge_volume", "bridge_volume_star", "total_liquid")
                 if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of bridge_volume, bridge_volume_star, "
                             f"total_liquid (got {given or 'none'})")
        val = getattr(self, given[0])
        if not (np.isfinite(val) and val > 0):
            raise ValueError(f"{given[0]} must be a positive number (got {val!r})")
        if self.conserve is None:
            self.conserve = self.total_liquid is not None
        if self.conserve and self.total_liquid is None:
            raise ValueError("conserve=True needs a total liquid (total_liquid, "
                             "water_content or saturation)")
        if not 0 < self.film_fraction <= 1:
            raise ValueError("film_fraction must be in (0, 1]")

    @property
    def kind(self):
        return "conserved" if self.conserve else "fixed"
