"""Neighbour list of a packing: the grain pairs close enough to form a bridge soon.

:class:`VerletList` keeps the pairs whose surfaces are closer than a skin, so that
:class:`~capbridge.dem.bridges.BridgeModel` tests only those for bridge formation at
every step; the list is rebuilt (a k-d tree, or the periodic cell's nearest images)
only once some grain has moved by half the skin since the last build.
"""
from __future__ import annotations

import numpy as np

__all__ = ["VerletList"]


class VerletList:
    """Verlet list of sphere pairs closer than r_i + r_j + skin (for bridge formation)."""

    def __init__(self, radii, skin, reach=0.0):
        self.radii = radii
        self.skin = float(skin)
        self.reach = float(reach)          # formation gap
        self.i = self.j = np.empty(0, np.intp)
        self.ref = None
        self.has_bridge = np.empty(0, bool)
        self.refused = np.empty(0, bool)   # touching, refused for lack of liquid
        self.keys = np.empty(0, np.int64)
        self.rebuilds = 0

    def needs_rebuild(self, pos):
        if self.ref is None or self.ref.shape != pos.shape:
            return True
        d2 = np.einsum("ij,ij->i", pos - self.ref, pos - self.ref)
        return float(d2.max(initial=0.0)) > (0.5 * self.skin) ** 2

    def rebuild(self, pos, bridge_keys, n, refused_keys=None):
        """New list around ``pos``; the pairs of ``refused_keys`` (default: those
        refused in the old list) stay refused."""
        if refused_keys is None:
            refused_keys = self.keys[self.refused] if self.refused.size else np.empty(0, np.int64)
        from scipy.spatial import cKDTree

        r = self.radii
        cell = getattr(self, "cell", None)     # periodic: nearest images through the faces
        cut = 2.0 * float(r.max(initial=0.0)) + self.skin
        if cell is not None:
            i, j, dv = cell.near_pairs(pos, cut)
        else:
            pairs = cKDTree(pos).query_pairs(cut, output_type="ndarray").reshape(-1, 2)
            i, j = pairs[:, 0].astype(np.intp), pairs[:, 1].astype(np.intp)
            swap = i > j
            i, j = np.where(swap, j, i), np.where(swap, i, j)
            dv = pos[j] - pos[i]
        keep = np.linalg.norm(dv, axis=1) < r[i] + r[j] + self.skin
        i, j = i[keep], j[keep]
        self.i, self.j = i, j
        self.reach2 = (r[i] + r[j] + self.reach) ** 2
        self.keys = i.astype(np.int64) * n + j
        self.has_bridge = np.isin(self.keys, bridge_keys)
        self.refused = np.isin(self.keys, refused_keys)
        self.ref = pos.copy()
        self.rebuilds += 1

    def index_of(self, keys):
        """Candidate index of each pair key (-1 if absent)."""
        if self.keys.size == 0:
            return np.full(len(keys), -1, np.intp)
        order = np.argsort(self.keys)
        pos = np.searchsorted(self.keys[order], keys)
        pos = np.clip(pos, 0, self.keys.size - 1)
        hit = self.keys[order][pos] == keys
        return np.where(hit, order[pos], -1)
