"""Unequal radii in the triplet surrogate: a documented approximation (status APPROXIMATE).

The triplet table is for equal spheres.  For radii R1, R2, R3 the triplet is looked up once as
the equal-sphere triplet of the harmonic mean radius R_h = 3 / (1/R1 + 1/R2 + 1/R3)
(gaps / R_h, V / R_h^3: one liquid body, one volume scale), and each pair force is
scaled by that pair's Derjaguin radius R_ij = 2 R_i R_j / (R_i + R_j) instead of R_h:
F_ij = 2 pi gamma R_ij f*_ij.  For a doublet R_ij is the radius that makes the contact
force 2 pi gamma R cos(theta) exact; in the body each pair force comes from the
meniscus near its own contact, whose curvature is that of the pair.  Other schemes
(:data:`UNEQUAL_SCHEMES`, ``predict_vectors(..., unequal=...)``) were measured against
Surface Evolver on the same triplets and are worse: one lookup per pair at R_ij
("pair") leaves the table's v range for 6 of these 13 triplets (V / R_ij^3 varies by up
to 8x between the pairs) and reaches 53 % where it answers; one lookup with forces * R_h
("harmonic") 8 % median, 23 % max; the arithmetic mean 11 %, 35 %.

Measured (``benchmarks/bench_triplet.py``, Evolver level 3 with the table's settings,
``benchmarks/triplet_unequal_evolver.json``): on 13 triplets with radii ratios up to 2
(theta 0-80 deg, v 1.1-1.5) the relative error of f_ij is 2.3 % median and 10.7 % max
(force vectors: 7.4 % of the largest grain force at most), against 0.25 % for an
equal-radii control; the largest errors are on the pair between the two large grains
of a (2, 2, 1) or (2, 1, 1) triplet at theta >= 60 deg.  Measured on the completed
sub-cube d <= 0.1 of the shipped grid (the full table was still being computed; see
``benchmarks/RESULTS.md``).  See :data:`UNEQUAL_RADII_ERROR`.

:func:`unequal_scales` gives, per pair, the length scale of the lookup and the scale of
the pair force of a scheme; :meth:`TripletSurrogate.predict_vectors
<capbridge.surrogate.triplet.TripletSurrogate.predict_vectors>` applies them and, when a
scheme needs several lookups, merges their statuses with :func:`combine_status`.
"""
from __future__ import annotations

import numpy as np

from capbridge.status import Status
from capbridge.surrogate.triplet_nodes import PAIRS
from capbridge.validation import check_choice

__all__ = ["UNEQUAL_RADII_ERROR", "UNEQUAL_SCHEMES", "unequal_scales", "combine_status"]

#: errors of the unequal-radii approximation against Surface Evolver (relative, f_ij),
#: filled from benchmarks/bench_triplet.py (see the module docstring)
UNEQUAL_RADII_ERROR = {"scheme": "harmonic_pair", "median": 0.023, "max": 0.107,
                       "vector_max": 0.074, "n_triplets": 13, "equal_control_max": 0.0025,
                       "source": "benchmarks/RESULTS.md, Triplet surrogate"}

#: unequal-radii approximations: (length scale of the lookup, scale of the pair force)
#: per pair, R_ij = 2 R_i R_j / (R_i + R_j) the pair's Derjaguin radius, R_h the
#: harmonic mean 3 / sum(1/R_i) and R_a the arithmetic mean of the three radii
UNEQUAL_SCHEMES = {
    "pair": "each pair force from the triplet scaled by its Derjaguin radius R_ij "
            "(lengths / R_ij, force * R_ij): three lookups",
    "harmonic_pair": "one lookup at the harmonic mean radius R_h (lengths / R_h), each "
                     "pair force scaled by R_ij",
    "harmonic": "one lookup at R_h, forces * R_h",
    "arithmetic": "one lookup at the arithmetic mean radius R_a, forces * R_a",
}


def unequal_scales(R, equal, scheme):
    """[(lookup scale, force scale)] per pair (PAIRS order) for radii R (..., 3)."""
    check_choice("unequal", scheme, tuple(UNEQUAL_SCHEMES))
    if np.all(equal):
        s = R[..., 0]                     # exact: the table scaled by the radius
        return [(s, s)] * 3
    Rij = [np.where(equal, R[..., 0], 2 * R[..., i] * R[..., j] / (R[..., i] + R[..., j]))
           for i, j in PAIRS]
    Rh = np.where(equal, R[..., 0], 3.0 / np.sum(1.0 / R, axis=-1))
    Ra = np.where(equal, R[..., 0], np.mean(R, axis=-1))
    return {"pair": list(zip(Rij, Rij)), "harmonic_pair": [(Rh, r) for r in Rij],
            "harmonic": [(Rh, Rh)] * 3, "arithmetic": [(Ra, Ra)] * 3}[scheme]


#: precedence of statuses when one point is answered by several lookups: a status
#: without a result first, then EXTRAPOLATED, ABOVE_TOLERANCE, CONVERGED
_RANK = np.full(max(Status) + 1, 3, np.int8)
_RANK[[Status.CONVERGED, Status.ABOVE_TOLERANCE, Status.EXTRAPOLATED]] = (0, 1, 2)


def combine_status(a, b):
    """Status of a point answered by several lookups (precedence :data:`_RANK`)."""
    a, b = np.asarray(a, np.int8), np.asarray(b, np.int8)
    return np.where(_RANK[b] > _RANK[a], b, a).astype(np.int8)
