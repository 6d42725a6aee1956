"""Periodic cells for the capillary engine: minimum-image bridge vectors and near pairs.

YADE's periodic cell (``O.periodic = True``) is the parallelepiped spanned by the
columns of ``O.cell.hSize`` (the base vectors, in m).  YADE keeps ``state.pos``
unwrapped (a grain that leaves the cell on one side is not moved to the other), so
every centre-to-centre vector d = x_j - x_i is brought to its nearest image,

    d' = d - H round(H^-1 d),

the minimum-image convention (Allen & Tildesley, *Computer Simulation of Liquids*,
2nd ed. 2017, section 1.6.1).  Rounding the fractional coordinates gives the nearest
image when |d'| is below half the cell's smallest perpendicular width w_min
(w_k = 1 / |row k of H^-1|); :meth:`PeriodicCell.check_reach` refuses a cell in which a
bridge could reach further than that, so a bridge never jumps to another image.

Near pairs (the engine's Verlet list) are found with a k-d tree on the wrapped centres
and on their images that lie within the cut-off of a face (``near_pairs``), so sheared
cells work too.
"""
from __future__ import annotations

import itertools

import numpy as np

from capbridge.validation import CapbridgeInputError

__all__ = ["PeriodicCell"]

#: the 27 integer shifts of a cell and its neighbours
_SHIFTS = np.array(list(itertools.product((-1, 0, 1), repeat=3)), float)


class PeriodicCell:
    """A periodic cell given by its base vectors (columns of ``hsize`` [m]).

    Parameters
    ----------
    hsize : (3, 3) array_like
        ``O.cell.hSize``: column k is the k-th base vector of the cell [m].
    """

    def __init__(self, hsize):
        self.h = np.zeros((3, 3))
        self.set(hsize)

    @classmethod
    def from_scene(cls, O):
        """The cell of a YADE scene (``O.periodic`` must be on)."""
        return cls(cell_matrix(O.cell.hSize))

    def set(self, hsize):
        """New base vectors (the cell deforms in a periodic triaxial test).  Returns the
        largest displacement [m] any image moves by, relative to the old cell (for the
        Verlet list): ``max_k |dh_k|`` summed over the three base vectors."""
        h = np.asarray(hsize, float).reshape(3, 3)
        drift = float(np.linalg.norm(h - self.h, axis=0).sum())
        if not np.all(np.isfinite(h)) or abs(np.linalg.det(h)) <= 0:
            raise CapbridgeInputError(f"periodic cell hSize {h.tolist()} is degenerate")
        self.h = h.copy()
        self.inv = np.linalg.inv(h)
        # perpendicular width of the cell across each pair of faces [m]
        self.widths = 1.0 / np.linalg.norm(self.inv, axis=1)
        return drift

    def check_reach(self, reach):
        """Refuse a cell in which a bridge or near pair could be longer (centre to
        centre, ``reach`` [m]) than half the smallest width: the nearest image would
        then be ambiguous."""
        half = 0.5 * float(self.widths.min())
        if reach >= half:
            raise CapbridgeInputError(
                f"periodic cell too small for capillary bridges: its smallest width is "
                f"{2 * half:.4g} m, a bridge reaches {reach:.4g} m centre to centre "
                f"(2 x largest radius + largest rupture gap); the cell must be wider "
                f"than {2 * reach:.4g} m in every direction")

    def min_image(self, d):
        """Vectors ``d`` (m, 3) [m] brought to their nearest image (in place, returned)."""
        f = d @ self.inv.T
        d -= np.rint(f) @ self.h.T
        return d

    def wrap(self, pos):
        """Centres (n, 3) [m] moved into the cell (fractional coordinates in [0, 1))."""
        f = pos @ self.inv.T
        f -= np.floor(f)
        return f @ self.h.T

    def near_pairs(self, pos, cutoff):
        """Pairs (i < j) of centres closer than ``cutoff`` [m] through the cell's
        boundaries (nearest image), with their minimum-image vectors i -> j.

        Returns ``(i, j, d)``.  A k-d tree holds the wrapped centres and their images
        within ``cutoff`` of a face (in fractional units cutoff / width per axis), so
        the search is exact for sheared cells as long as :meth:`check_reach` holds.
        """
        from scipy.spatial import cKDTree

        pos = np.asarray(pos, float)
        n = pos.shape[0]
        f = pos @ self.inv.T
        f -= np.floor(f)
        margin = cutoff / self.widths                       # fractional, per axis
        fs = f[None, :, :] + _SHIFTS[:, None, :]            # (27, n, 3)
        keep = np.all((fs >= -margin) & (fs < 1.0 + margin), axis=2)
        owner = np.broadcast_to(np.arange(n), (27, n))[keep]
        images = fs[keep] @ self.h.T
        inside = f @ self.h.T
        pairs = cKDTree(inside).sparse_distance_matrix(cKDTree(images), cutoff,
                                                       output_type="ndarray")
        i = pairs["i"].astype(np.intp)
        j = owner[pairs["j"]].astype(np.intp)
        ok = i < j                                          # each pair once, no self-image
        i, j = i[ok], j[ok]
        key = np.unique(i.astype(np.int64) * n + j)
        i, j = (key // n).astype(np.intp), (key % n).astype(np.intp)
        d = self.min_image(pos[j] - pos[i])
        return i, j, d


def cell_matrix(m):
    """A minieigen Matrix3 as a (3, 3) numpy array."""
    return np.array([[m[r, c] for c in range(3)] for r in range(3)], float)
