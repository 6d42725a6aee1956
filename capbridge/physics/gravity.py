"""Gravity on the liquid: grain force vectors from the zero-gravity force and the tables'
response to the gravity vector.

Gravity enters as the vector b = Bo g_hat (Bo = drho g r^2 / gamma of the normalising
radius, g_hat the unit vector along which gravity pulls).  The grains carry the liquid's
weight, W b with W = V*/(2 pi) in F* = F/(2 pi gamma r) units, and the sagging body
changes the capillary forces themselves at second order.

Doublet (n the unit vector from grain 1 to grain 2, b_n = b . n, b_perp = b - b_n n):

    F1 = F0 n + W [w b_n n + u b_perp] + c b_n^2 n / 2
    F2 = -F0 n - c b_n^2 n / 2 + W [(1 - w) b_n n + (1 - u) b_perp]

w is the share of the weight grain 1 carries at first order with gravity along the axis
(1/2 for equal grains and angles, by the mirror symmetry that swaps them), c the second
derivative of the attraction in b_n (exact axisymmetric solver with gravity,
:mod:`capbridge.solvers.young_laplace_gravity`), and u the share of the transverse weight
on grain 1, which is the lever rule (:func:`transverse_weight_share`):

    u = 1 - x_c / D,

x_c the distance of the liquid's centre of mass from the centre of grain 1 along n, D the
distance between the centres.  It is exact at first order in b_perp: the liquid exerts no
torque on a sphere about the sphere's centre (pressure acts along the normal, through the
centre; the tension's component along the surface, gamma cos(theta) normal to the contact
line in the surface, integrates to a torque gamma cos(theta) R times the closed contact
line's tangent integral, zero), so the torque balance of the liquid about the centre of
grain 1 is D n x F2 = x_c n x W b_perp at first order.  For equal grains and angles u = 1/2.

Triplet (table frame of :mod:`capbridge.tables.triplet`):

    F_i(b) = F_i(0) + sum_k G_ik b_k + sum_k C_ik b_k^2 / 2

with G = ``force_gravity_gradient`` and C = ``force_gravity_curvature`` of the triplet
table (:mod:`capbridge.tables.triplet_gravity`).

Both sum to F(0) summed plus W b at first order: the sum rule the tests check.

Reference: Miot et al. (2021), Granular Matter 23:66, section 3.4.
"""
from __future__ import annotations

import numpy as np

from capbridge.validation import CapbridgeInputError

__all__ = ["BOND_MAX", "gravity_vector", "liquid_weight", "check_bond",
           "transverse_weight_share", "doublet_gravity_forces", "triplet_gravity_forces"]

#: the largest Bond number Bo = drho g r^2 / gamma the surrogates answer (issue 10's
#: range; the tables' gravity responses are checked against Surface Evolver up to it)
BOND_MAX = 2.5


def gravity_vector(bond, direction):
    """b = Bo g_hat from a Bond number and a direction (normalised here).

    Parameters
    ----------
    bond : array_like
        Bo = drho g r^2 / gamma [-], >= 0.
    direction : array_like (..., 3)
        Direction along which gravity pulls (any length > 0).

    Returns
    -------
    ndarray (..., 3)

    >>> gravity_vector(2.14, (0, 0, -9.81)).tolist()
    [0.0, 0.0, -2.14]
    """
    bond = np.asarray(bond, float)
    if np.any(~np.isfinite(bond)) or np.any(bond < 0):
        bad = bond[~(np.isfinite(bond) & (bond >= 0))].flat[0]
        raise CapbridgeInputError(f"Bond number Bo={bad!r} is not allowed: Bo >= 0 "
                                  "(Bo = drho g r^2 / gamma)")
    d = np.asarray(direction, float)
    if d.shape[-1:] != (3,):
        raise CapbridgeInputError(f"gravity direction {direction!r}: give three "
                                  "components x,y,z")
    big = np.max(np.abs(d), axis=-1, keepdims=True)
    if not np.all(np.isfinite(d)) or np.any(big == 0):
        raise CapbridgeInputError(f"gravity direction {direction!r}: must be a finite, "
                                  "non-zero vector (e.g. 0,0,-1)")
    d = d / big                                    # no overflow in the norm (1e308 parts)
    return bond[..., None] * d / np.linalg.norm(d, axis=-1, keepdims=True)


def check_bond(bond, has_response, table, response, solver):
    """Bo for a surrogate's lookup: finite, in [0, :data:`BOND_MAX`], and 0 with a table
    (``table``: "doublet", "triplet") that has no gravity ``response`` (variable names);
    ``solver`` names what answers beyond (the messages say it).  Returns Bo as an
    array; raises CapbridgeInputError (one line) otherwise."""
    bo = np.asarray(bond, float)
    gravity_vector(bo, (0.0, 0.0, -1.0))            # finite, >= 0
    if np.any(bo > BOND_MAX):
        raise CapbridgeInputError(
            f"Bond number Bo={float(bo.max())!r} is above the supported range [0, "
            f"{BOND_MAX:g}] (the {table} table's gravity response is checked up to it); "
            f"use {solver}")
    if np.any(bo > 0) and not has_response:
        raise CapbridgeInputError(
            f"Bond number Bo={float(bo.max())!r}: this {table} table has no gravity "
            f"response ({response}); Bo must be 0 with it, or use {solver}")
    return bo


def liquid_weight(volume):
    """Weight of the liquid per unit of b, W = V*/(2 pi) [F* per unit Bo].

    The force of gravity on a liquid volume V in F* = F/(2 pi gamma r) units is
    drho g V / (2 pi gamma r) = Bo V* / (2 pi).

    >>> round(float(liquid_weight(2 * np.pi)), 12)
    1.0
    """
    return np.asarray(volume, float) / (2 * np.pi)


def transverse_weight_share(moment, volume, centre_distance):
    """Share u of the transverse weight carried by grain 1 of a doublet (lever rule).

    u = 1 - x_c / D, x_c = (int x dV) / V the axial position of the liquid's centre of mass
    measured from the centre of grain 1 and D the distance between the centres; exact at
    first order in the transverse component of gravity (module docstring).

    Parameters
    ----------
    moment : array_like
        First moment int x dV of the liquid about the centre of grain 1 along n [R1^4].
    volume : array_like
        Liquid volume V* [R1^3].
    centre_distance : array_like
        D = 1 + R2/R1 + d* [R1].

    Returns
    -------
    ndarray

    Examples
    --------
    The liquid of a doublet of ratio 2 at d* = 0.1 (V* = 0.05, theta = 20 deg) has its
    centre of mass at x_c = 1.0444 of D = 3.1 (exact bridge): the small grain carries 0.663
    of the transverse weight; direct Surface Evolver minimisations with gravity across
    give 0.656-0.665 (``benchmarks/gravity_doublet_validity.json``).

    >>> round(float(transverse_weight_share(1.0443558 * 0.05, 0.05, 3.1)), 4)
    0.6631
    """
    return 1.0 - np.asarray(moment, float) / (np.asarray(volume, float)
                                              * np.asarray(centre_distance, float))


def doublet_gravity_forces(force, axis, volume, b, share_axial=0.5, curvature_axial=0.0,
                           share_transverse=0.5):
    """Force vectors of the liquid on the two grains of a doublet with gravity.

    Parameters
    ----------
    force : array_like (...)
        Zero-gravity attraction F0 [F*], > 0 attractive.
    axis : array_like (..., 3)
        Unit vector n from grain 1 to grain 2.
    volume : array_like (...)
        Bridge volume V* [-] (normalising radius, as for Bo and F*).
    b : array_like (..., 3)
        Gravity vector b = Bo g_hat (:func:`gravity_vector`).
    share_axial : array_like (...), default 1/2
        w: first-order share of the weight on grain 1, gravity along the axis.
    curvature_axial : array_like (...), default 0
        c = d2F/db_n^2 of the attraction [F*].
    share_transverse : array_like (...), default 1/2
        u: first-order share of the transverse weight on grain 1
        (:func:`transverse_weight_share`; 1/2 for equal grains and angles).

    Returns
    -------
    F1, F2 : ndarray (..., 3)
        Forces on grain 1 and grain 2 [F*]; F1 + F2 = V*/(2 pi) b exactly.

    Examples
    --------
    Equal grains, gravity across the axis: each grain carries half of the weight.

    >>> F1, F2 = doublet_gravity_forces(0.4, (1, 0, 0), 2 * np.pi, (0, 0, -0.1))
    >>> F1.round(12).tolist(), F2.round(12).tolist()
    ([0.4, 0.0, -0.05], [-0.4, 0.0, -0.05])
    """
    n = np.asarray(axis, float)
    b = np.asarray(b, float)
    F0 = np.asarray(force, float)[..., None]
    W = liquid_weight(volume)[..., None]
    w = np.asarray(share_axial, float)[..., None]
    c = np.asarray(curvature_axial, float)[..., None]
    u = np.asarray(share_transverse, float)[..., None]
    bn = np.sum(b * n, axis=-1)[..., None]
    b_perp = b - bn * n
    attraction = F0 + 0.5 * c * bn ** 2
    F1 = attraction * n + W * (w * bn * n + u * b_perp)
    F2 = -attraction * n + W * ((1.0 - w) * bn * n + (1.0 - u) * b_perp)
    return F1, F2


def triplet_gravity_forces(force, gradient, curvature, b):
    """Force vectors on the three grains of a coalesced triplet with gravity.

    Parameters
    ----------
    force : array_like (..., 3, 3)
        Zero-gravity force vectors [grain, component] [F*].
    gradient, curvature : array_like (..., 3, 3, 3)
        G = dF/db and C = d2F/db_k2 [grain, component, component of b] in the same frame.
    b : array_like (..., 3)
        Gravity vector b = Bo g_hat in that frame.

    Returns
    -------
    ndarray (..., 3, 3)
        F_i(b) = F_i(0) + G_i b + C_i b^2 / 2 (b^2 componentwise).

    >>> G = np.zeros((3, 3, 3)); G[:, 2, 2] = 1 / 3
    >>> F = triplet_gravity_forces(np.zeros((3, 3)), G, np.zeros((3, 3, 3)), (0, 0, -0.3))
    >>> F[:, 2].round(12).tolist()
    [-0.1, -0.1, -0.1]
    """
    b = np.asarray(b, float)[..., None, None, :]
    return (np.asarray(force, float) + np.sum(np.asarray(gradient, float) * b, axis=-1)
            + 0.5 * np.sum(np.asarray(curvature, float) * b ** 2, axis=-1))
