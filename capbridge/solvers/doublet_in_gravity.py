"""A liquid bridge between two spheres with gravity in any direction.

Gravity along the line of centres keeps the bridge axisymmetric: the exact solver
(:func:`~capbridge.solvers.young_laplace_gravity.solve_doublet_gravity`) answers in
milliseconds.  Any other direction breaks the symmetry, and only Surface Evolver
(:func:`~capbridge.solvers.evolver.minimise_bridge`) answers, in minutes.
:func:`solve_doublet_in_gravity` picks the solver and returns the force vectors on
both grains either way.

Frame: grain 1 (radius 1, which normalises lengths) at the origin, grain 2 (radius
``ratio``) on +x; gravity is the direction along which it pulls.
"""
from __future__ import annotations

import numpy as np

from capbridge.physics.gravity import gravity_vector, liquid_weight
from capbridge.solvers import evolver
from capbridge.solvers.young_laplace_gravity import solve_doublet_gravity, validated_inputs
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError, check_range

#: how close |g_hat.x| must come to 1 for gravity to count as along the axis
#: (the round-off of a direction a user gave as a unit vector)
AXIS_TOLERANCE = 1e-12


def along_axis(direction, bond):
    """True when the exact axisymmetric solver answers: gravity along the axis (+-x, to
    :data:`AXIS_TOLERANCE`) or no gravity (Bo = 0); else Surface Evolver does."""
    g = gravity_vector(1.0, direction)
    return abs(g[0]) >= 1.0 - AXIS_TOLERANCE or bond == 0.0


def check_inputs(gap, volume, theta, bond, ratio=1.0, theta2=None):
    """Refuse values outside their range (one CapbridgeInputError line) with the exact
    solver's checks, whichever solver will answer: a bad value is a message at once,
    not after minutes of Surface Evolver."""
    check_range("gap d*", gap, 0.0, np.inf)
    validated_inputs(None, volume, theta, theta2, ratio, bond, -1.0)


def solve_doublet_in_gravity(gap, volume, theta, bond, direction=(0.0, 0.0, -1.0),
                             ratio=1.0, theta2=None, max_refine=3, keep_shape=False):
    """Force vectors of a bridge of given volume between two spheres, with gravity.

    Parameters
    ----------
    gap : float
        Gap between the sphere surfaces d* = d/R1, >= 0.
    volume : float
        Liquid volume V* = V/R1^3 > 0.
    theta : float
        Contact angle on grain 1 [deg], in [0, 90).
    bond : float
        Bond number Bo = drho g R1^2 / gamma, in [0,
        :data:`~capbridge.solvers.young_laplace_gravity.BOND_MAX`].
    direction : array_like (3,)
        Direction along which gravity pulls (any length > 0), in the frame of the
        module docstring.
    ratio : float
        R2/R1 in [1, 10].
    theta2 : float, optional
        Contact angle on grain 2 [deg]; default ``theta``.
    max_refine : int
        Finest Surface Evolver refinement level (off the axis only).
    keep_shape : bool
        Off the axis: also return the minimised surface, ``shape`` (a
        :class:`~capbridge.solvers.shapes.LiquidShape` source for
        :func:`~capbridge.solvers.shapes.write_shape`; None without a result).  Along
        the axis with Bo > 0 the exact solver keeps no profile: refused.

    Returns
    -------
    dict
        ``method`` (which solver answered, in words), ``forces`` (2, 3): F* = F/(2 pi
        gamma R1) on grain 1 and grain 2 (F1 + F2 = weight * g_hat; NaN without a
        result), ``weight`` (Bo V*/(2 pi)), ``status``
        (:class:`~capbridge.status.Status`) and ``reason`` (why there is no result,
        else ""); along the axis also the attraction ``force``, ``pressure_centre1``,
        ``beta1``, ``beta2`` and ``energy`` of the exact solver; off it
        ``force_error`` (2, 3) and ``cpu_time`` of Surface Evolver.

    Raises
    ------
    CapbridgeInputError
        A value outside its range, before any solver runs (:func:`check_inputs`).
    """
    check_inputs(gap, volume, theta, bond, ratio, theta2)
    g = gravity_vector(1.0, direction)
    weight = float(liquid_weight(volume) * bond)
    if keep_shape and along_axis(g, bond) and bond > 0:
        raise CapbridgeInputError(
            "the shape of a bridge with gravity along its axis is not kept by the exact "
            "solver; without gravity (Bo = 0) the exact profile is written, off the axis "
            "Surface Evolver's surface")
    if along_axis(g, bond):
        axis = -1.0 if g[0] <= 0 else 1.0         # either side at Bo = 0
        r = solve_doublet_gravity(gap, volume, theta, bond, ratio, theta2, gravity_axis=axis)
        r = {k: (float(v) if np.ndim(v) == 0 and k != "status" else v) for k, v in r.items()}
        status = Status(int(r["status"]))
        reason = ""
        if status == Status.NOT_CONVERGED:
            reason = ("no stable bridge reached at this Bo: beyond the rupture distance "
                      "with gravity (see `capbridge lookup doublet --bond`, d_rupt), or "
                      "the solver failed")
        return {"method": "exact (axisymmetric, gravity along the axis)",
                "forces": np.array([[r["force1"], 0.0, 0.0], [-r["force2"], 0.0, 0.0]]),
                "force": r["force"], "weight": weight,
                "pressure_centre1": r["pressure_centre1"], "beta1": r["beta1"],
                "beta2": r["beta2"], "energy": r["energy"], "status": status,
                "reason": reason}
    theta2 = theta if theta2 is None else theta2
    centres = [[0.0, 0.0, 0.0], [1.0 + ratio + gap, 0.0, 0.0]]
    res = evolver.minimise_bridge(centres, [1.0, ratio], [theta, theta2], volume, "doublet",
                                  bond=bond, gravity_dir=tuple(g), max_refine=max_refine,
                                  keep_shape=keep_shape)
    out = {"method": f"Surface Evolver (level {res.refinement})",
           "forces": res.forces if res.converged else np.full((2, 3), np.nan),
           "force_error": res.force_error, "weight": weight, "cpu_time": res.cpu_time,
           "status": res.status, "reason": res.reason}
    if keep_shape:
        out["shape"] = res if res.shape is not None else None
    return out
