"""What is to be minimised: grains, liquid bodies, gravity (input checks at the boundary)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from capbridge.validation import CapbridgeInputError, check_range

#: Topology names accepted by :func:`make_problem`.
TOPOLOGIES = ("doublet", "bridges", "coalesced")


@dataclass
class Body:
    """One liquid body: the grains it wets (0-based indices) and its volume V*."""

    grains: tuple
    volume: float


@dataclass
class Problem:
    """N grains (centres, radii, contact angles in degrees) and the liquid bodies on them.

    ``bond`` is Bo = drho g r^2 / gamma for the normalising radius; ``gravity_dir`` is the
    direction in which gravity pulls (unit vector, default -z).
    """

    centres: np.ndarray
    radii: np.ndarray
    contact_angles_deg: np.ndarray
    bodies: list
    bond: float = 0.0
    gravity_dir: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))

    @property
    def n_grains(self):
        return len(self.radii)

    @property
    def up(self):
        """Unit vector opposite to gravity (heights are h = up . x)."""
        return -self.gravity_dir

    def copy(self):
        return Problem(self.centres.copy(), self.radii.copy(), self.contact_angles_deg.copy(),
                       [Body(tuple(b.grains), float(b.volume)) for b in self.bodies],
                       float(self.bond), self.gravity_dir.copy())

    def moved(self, grain, displacement):
        """A copy with grain ``grain`` translated by ``displacement``."""
        p = self.copy()
        p.centres[grain] = p.centres[grain] + np.asarray(displacement, float)
        return p

    def wetted_grains(self):
        return sorted({g for b in self.bodies for g in b.grains})


def make_problem(centres, radii, contact_angles_deg, volume, topology="doublet", pairs=None,
                 bond=0.0, gravity_dir=(0.0, 0.0, -1.0)):
    """Build and check a :class:`Problem`.

    Parameters
    ----------
    centres : (N, 3) array_like, dimensionless (lengths / r)
    radii : float or (N,) array_like
    contact_angles_deg : float or (N,) array_like, per grain, in [0, 180)
    volume : float, or a sequence with one volume per body for ``topology="bridges"``
    topology : "doublet" (one bridge between ``pairs[0]``, default grains 0-1),
        "bridges" (one body per pair in ``pairs``), "coalesced" (one body wetting the
        grains listed in ``pairs[0]``, default all grains).
    pairs : list of tuples of grain indices (0-based)
    bond : float >= 0, Bond number
    gravity_dir : 3-vector, direction of gravity (normalised here)
    """
    centres = np.atleast_2d(np.asarray(centres, float))
    if centres.ndim != 2 or centres.shape[1] != 3:
        raise CapbridgeInputError(f"centres must have shape (N, 3), got {centres.shape}")
    n = len(centres)
    if n < 2:
        raise CapbridgeInputError("at least two grains are needed")
    check_range("centres", centres)
    radii = np.broadcast_to(check_range("radius", radii, 0.0, np.inf, low_open=True),
                            (n,)).astype(float).copy()
    theta = np.broadcast_to(check_range("contact angle", contact_angles_deg, 0.0, 180.0,
                                        high_open=True, units=" deg"), (n,)).astype(float).copy()
    bond = float(check_range("Bond number Bo", bond, 0.0, np.inf))
    g = check_range("gravity_dir", gravity_dir)
    if g.shape != (3,) or np.linalg.norm(g) == 0:
        raise CapbridgeInputError("gravity_dir must be a non-zero 3-vector")
    g = g / np.linalg.norm(g)
    if topology not in TOPOLOGIES:
        raise CapbridgeInputError(f"topology={topology!r} is not one of {TOPOLOGIES}")
    if topology == "doublet":
        pairs = [tuple(pairs[0])] if pairs else [(0, 1)]
        if len(pairs[0]) != 2:
            raise CapbridgeInputError("a doublet wets exactly two grains")
    elif topology == "bridges":
        if not pairs:
            raise CapbridgeInputError("topology 'bridges' needs pairs=[(i, j), ...]")
        pairs = [tuple(p) for p in pairs]
        if any(len(p) != 2 for p in pairs):
            raise CapbridgeInputError("each bridge wets exactly two grains")
    else:
        pairs = [tuple(pairs[0])] if pairs else [tuple(range(n))]
        if len(pairs[0]) < 2:
            raise CapbridgeInputError("a coalesced body wets at least two grains")
    vols = np.atleast_1d(check_range("volume V*", volume, 0.0, np.inf, low_open=True))
    if vols.size == 1:
        vols = np.full(len(pairs), float(vols[0]))
    if vols.size != len(pairs):
        raise CapbridgeInputError(f"{vols.size} volumes given for {len(pairs)} bodies")
    for p in pairs:
        if len(set(p)) != len(p) or min(p) < 0 or max(p) >= n:
            raise CapbridgeInputError(f"grain indices {p} invalid for {n} grains")
    # overlapping grains are not supported
    for i in range(n):
        for j in range(i + 1, n):
            gap = np.linalg.norm(centres[i] - centres[j]) - radii[i] - radii[j]
            # grains in contact (gap 0) come out of the triangle formula a few ulp apart
            if gap < -1e-12 * (radii[i] + radii[j]):
                raise CapbridgeInputError(
                    f"grains {i} and {j} overlap (gap {gap:.3g}); overlapping grains are "
                    "not supported")
    bodies = [Body(tuple(int(k) for k in p), float(v)) for p, v in zip(pairs, vols)]
    return Problem(centres, radii, theta, bodies, bond, g)
