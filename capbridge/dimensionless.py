"""Geometry and dimensionless conversions shared by every solver, table and plugin.

Conventions (``../shared/DESIGN.md``)
-------------------------------------
Lengths are scaled by the normalising radius ``r`` and energies by the liquid-gas
surface tension ``gamma``:

=========  ===========================  ==========================
quantity   dimensionless form           name here
=========  ===========================  ==========================
gap        d* = d / r                   ``gap``
volume     V* = V / r**3                ``volume``
force      F* = F / (2 pi gamma r)      ``force``
pressure   P* = dp r / gamma            ``pressure`` (dp = p_liquid - p_gas)
energy     E* = E / (gamma r**2)        ``energy``
Bond       Bo = drho g r**2 / gamma     ``bond_number``
=========  ===========================  ==========================

For two spheres of unequal radii the normalising radius is the **smaller** one,
``r = R1``, and the radius ratio is ``ratio = R2 / R1 >= 1``; equal spheres are
``ratio = 1``.  (YADE's native capillary files use the larger radius; the exporter in
:mod:`capbridge.yade` converts.)  A positive force is an attraction.
Angles are in degrees at every interface (API, CLI, tables) and in radians inside.
"""
from __future__ import annotations

import numpy as np

# --------------------------------------------------------------------------------------
# SI <-> dimensionless
# --------------------------------------------------------------------------------------


def force_scale(radius, surface_tension):
    """Force unit 2*pi*gamma*r [N] for radius [m] and surface tension [N/m]."""
    return 2.0 * np.pi * np.asarray(surface_tension, float) * np.asarray(radius, float)


def pressure_scale(radius, surface_tension):
    """Pressure unit gamma/r [Pa]."""
    return np.asarray(surface_tension, float) / np.asarray(radius, float)


def energy_scale(radius, surface_tension):
    """Energy unit gamma*r**2 [J]."""
    return np.asarray(surface_tension, float) * np.asarray(radius, float) ** 2


def to_dimensionless(radius, surface_tension, gap=None, volume=None, force=None,
                     pressure=None, energy=None):
    """Convert SI quantities to the dimensionless ones of the module docstring.

    Parameters are SI: radius [m], surface_tension [N/m], gap [m], volume [m^3],
    force [N], pressure [Pa], energy [J].  Returns a dict with the keys given.

    >>> out = to_dimensionless(4e-3, 0.073, gap=0.7e-3, volume=16e-9)
    >>> {k: round(v, 12) for k, v in out.items()}     # r**3 is pow(): +-1 ulp by processor
    {'gap': 0.175, 'volume': 0.25}
    """
    r = np.asarray(radius, float)
    out = {}
    if gap is not None:
        out["gap"] = np.asarray(gap, float) / r
    if volume is not None:
        out["volume"] = np.asarray(volume, float) / r**3
    if force is not None:
        out["force"] = np.asarray(force, float) / force_scale(r, surface_tension)
    if pressure is not None:
        out["pressure"] = np.asarray(pressure, float) / pressure_scale(r, surface_tension)
    if energy is not None:
        out["energy"] = np.asarray(energy, float) / energy_scale(r, surface_tension)
    return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in out.items()}


def to_si(radius, surface_tension, gap=None, volume=None, force=None, pressure=None,
          energy=None):
    """Inverse of :func:`to_dimensionless`: dimensionless values to SI units."""
    r = np.asarray(radius, float)
    out = {}
    if gap is not None:
        out["gap"] = np.asarray(gap, float) * r
    if volume is not None:
        out["volume"] = np.asarray(volume, float) * r**3
    if force is not None:
        out["force"] = np.asarray(force, float) * force_scale(r, surface_tension)
    if pressure is not None:
        out["pressure"] = np.asarray(pressure, float) * pressure_scale(r, surface_tension)
    if energy is not None:
        out["energy"] = np.asarray(energy, float) * energy_scale(r, surface_tension)
    return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in out.items()}


def bond_number(radius, surface_tension, density_difference=997.0, gravity=9.81):
    """Bond number Bo = drho g r**2 / gamma [-].

    Parameters
    ----------
    radius : float or array [m]
    surface_tension : float or array [N/m]
    density_difference : float, default 997 [kg/m^3] (water - air at 20 C)
    gravity : float, default 9.81 [m/s^2]

    References
    ----------
    Miot et al. (2021), Granular Matter 23:66, Eq. (9): Bo = 2.14 for r = 4 mm,
    gamma = 0.073 N/m.

    >>> round(float(bond_number(4e-3, 0.073)), 2)
    2.14
    >>> round(float(bond_number(4e-3, 0.0693)), 2)
    2.26
    """
    return (np.asarray(density_difference, float) * gravity
            * np.asarray(radius, float) ** 2 / np.asarray(surface_tension, float))


# --------------------------------------------------------------------------------------
# Sphere geometry (lengths in units of the radius passed in)
# --------------------------------------------------------------------------------------


def cap_volume(radius, beta):
    """Volume of the spherical cap of half-angle ``beta`` [rad] on a sphere.

    V = pi R^3 (1 - cos b)^2 (2 + cos b) / 3, with 1 - cos b = 2 sin^2(b/2) so that tiny
    caps on large spheres keep all their digits (the textbook 2 - 3 cos b + cos^3 b
    loses ~1/b^4 of them, which stalls Newton's method at V* ~ 1e-3 and R2/R1 = 10).
    ``beta = pi`` gives the whole sphere.

    >>> round(float(cap_volume(1.0, np.pi)) / (4 * np.pi / 3), 12)
    1.0
    """
    v = 2.0 * np.sin(0.5 * np.asarray(beta, float)) ** 2
    return np.pi * np.asarray(radius, float) ** 3 * v * v * (2.0 + np.cos(beta)) / 3.0


def cap_height(radius, beta):
    """Height of the spherical cap of half-angle ``beta`` [rad]: R (1 - cos b) = 2 R sin^2(b/2).

    Written without cancellation, like :func:`cap_volume`.

    >>> round(float(cap_height(2.0, np.pi / 2)), 12)
    2.0
    """
    return 2.0 * np.asarray(radius, float) * np.sin(0.5 * np.asarray(beta, float)) ** 2


def cap_area(radius, beta):
    """Area of the spherical cap of half-angle ``beta`` [rad]: 4 pi R^2 sin^2(b/2)."""
    return 4.0 * np.pi * np.asarray(radius, float) ** 2 * np.sin(0.5 * np.asarray(beta, float)) ** 2


def centre_distance(gap, ratio=1.0):
    """Distance between the centres of spheres of radii 1 and ``ratio`` at ``gap``."""
    return 1.0 + np.asarray(ratio, float) + np.asarray(gap, float)


def opening_angle(d_shared_j, d_shared_k, d_jk, ratio=1.0):
    """Angle [rad] at a shared grain i between the axes to grains j and k.

    For three equal spheres (radius 1, gaps given dimensionless): the law of cosines
    on the triangle of centres.  Half of it is the paper's opening angle alpha for a
    symmetric top grain (Miot et al. 2021, Fig. 4).

    >>> round(float(np.degrees(opening_angle(0.175, 0.175, 0.075)) / 2), 2)
    28.49
    """
    a = centre_distance(d_shared_j, ratio)
    b = centre_distance(d_shared_k, ratio)
    c = centre_distance(d_jk, ratio)
    return np.arccos(np.clip((a**2 + b**2 - c**2) / (2 * a * b), -1.0, 1.0))


def triplet_centres(d12, d13, d23):
    """Centres of three unit spheres in the plane z = 0 from their three gaps.

    Grain 1 sits at the origin, grain 2 on the +x axis, grain 3 at y > 0.
    Returns an array of shape (3, 3).
    """
    a = float(centre_distance(d12))
    b = float(centre_distance(d13))
    c = float(centre_distance(d23))
    if not (a + b > c and a + c > b and b + c > a):
        raise ValueError(f"gaps d12={d12}, d13={d13}, d23={d23} do not form a triangle")
    x3 = (a**2 + b**2 - c**2) / (2 * a)
    y3 = np.sqrt(max(b**2 - x3**2, 0.0))
    return np.array([[0.0, 0.0, 0.0], [a, 0.0, 0.0], [x3, y3, 0.0]])


#: the grain pairs of a triplet (0-based grains) and the names of their pair forces, in
#: the one order every triplet table, surrogate and DEM lookup uses
TRIPLET_PAIRS = ((0, 1), (0, 2), (1, 2))
TRIPLET_PAIR_NAMES = ("f12", "f13", "f23")


def canonical_triplet(d12, d13, d23):
    """Relabel three equal grains so that their gaps are sorted, d12 <= d13 <= d23.

    A triplet of equal spheres and its relabelled copies are one physical state, so
    tables hold only the canonical order.  Grain 1 of the canonical order is then the
    grain shared by the two smallest gaps.

    Returns
    -------
    gaps : ndarray (3,)
        The canonical (d12, d13, d23).
    perm : ndarray of int (3,)
        ``perm[k]`` is the input grain (0-based) that becomes canonical grain k; the
        gap between canonical grains a and b is the input gap between grains
        ``perm[a]`` and ``perm[b]``.

    >>> canonical_triplet(0.2, 0.05, 0.1)
    (array([0.05, 0.1 , 0.2 ]), array([2, 0, 1]))
    """
    gaps = {(0, 1): float(d12), (0, 2): float(d13), (1, 2): float(d23)}
    # each grain faces one gap; the grain facing the largest gap is shared by the
    # two smallest gaps (stable sort: ties keep the input order)
    facing = np.array([gaps[(1, 2)], gaps[(0, 2)], gaps[(0, 1)]])
    perm = np.argsort(-facing, kind="stable")
    sorted_gaps = np.array([gaps[tuple(sorted((perm[a], perm[b])))]
                            for a, b in ((0, 1), (0, 2), (1, 2))])
    return sorted_gaps, perm
