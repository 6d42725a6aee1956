"""Closed-form capillary-bridge formulas from the literature, for benchmarks and fallbacks.

Every function is vectorised (numpy broadcasting over all arguments) and works in the
dimensionless convention of :mod:`capbridge.dimensionless`:

* ``gap``    d* = d / r, gap between the sphere surfaces,
* ``volume`` V* = V / r**3, bridge volume,
* ``theta``  contact angle in **degrees** (radians inside),
* ``ratio``  R2 / R1 >= 1 (optional; equal spheres by default),
* returned force F* = F / (2 pi gamma r), attraction positive,

where ``r = R1`` is the **smaller** radius.  Most published formulas are written for
two equal spheres of radius R.  Where a model is used for unequal spheres through the
Derjaguin (harmonic-mean) radius

    R_eff = 2 R1 R2 / (R1 + R2) = k r,   k = 2 ratio / (1 + ratio)   (1 <= k < 2),

the function evaluates the equal-sphere formula with R = R_eff and converts back to our
normalisation: V/R_eff**3 = V*/k**3, d/R_eff = d*/k and F/(2 pi gamma r) = k F/(2 pi gamma
R_eff).  This is the convention of YADE's ``ViscElCapMat`` (``phys.R = 2 R1 R2/(R1+R2)``)
and MercuryDPM's ``LiquidBridgeWillet`` (``2*getEffectiveRadius()``).  Willett et al.
(2000) report that the Derjaguin approximation for unequal spheres is "relatively
accurate for small bridge volumes and for separation distances excluding those at
close-contact and near-rupture".

Valid inputs: ``0 <= theta < 90`` degrees, ``volume > 0``, ``gap >= 0``, ``ratio >= 1``,
all finite; anything else raises :class:`capbridge.validation.CapbridgeInputError`.

Accuracy.  Besides what each source says, every docstring quotes the range of relative
errors against the exact Young-Laplace doublet
(:func:`capbridge.solvers.young_laplace.solve_doublet` and ``rupture_distance``; equal
spheres, no gravity), called "exact check" below, on the grid
V* in {0.001, 0.003, 0.01, 0.03, 0.05, 0.1}, theta in {0, 10, ..., 50} deg and 20 gaps
from contact to 0.95 of the exact rupture distance.  A separate shooting solution
written while preparing this module agreed with that solver within 0.2 %.

The formulas do not know about rupture: beyond the rupture distance
(:func:`lian_rupture_distance`, :func:`willett_rupture_distance`) they still return a
(small) number, and callers decide whether a bridge exists.

References
----------
.. [Lian1993] G. Lian, C. Thornton, M. J. Adams, "A theoretical study of the liquid
   bridge forces between two rigid spherical bodies", J. Colloid Interface Sci. 161
   (1993) 138-147.
.. [Pitois2000] O. Pitois, P. Moucheront, X. Chateau, "Liquid bridge between two moving
   spheres: an experimental study of viscosity effects", J. Colloid Interface Sci. 231
   (2000) 26-31.
.. [Willett2000] C. D. Willett, M. J. Adams, S. A. Johnson, J. P. K. Seville,
   "Capillary bridges between two spherical bodies", Langmuir 16 (2000) 9396-9405.
.. [Rabinovich2005] Y. I. Rabinovich, M. S. Esayanur, B. M. Moudgil, "Capillary forces
   between two spheres with a fixed volume liquid bridge: theory and experiment",
   Langmuir 21 (2005) 10992-10997.
.. [Richefeu2006] V. Richefeu, M. S. El Youssoufi, F. Radjai, "Shear strength
   properties of wet granular materials", Phys. Rev. E 73 (2006) 051304.
.. [Lambert2008] P. Lambert, A. Chau, A. Delchambre, S. Regnier, "Comparison between
   two capillary forces models", Langmuir 24 (2008) 3157-3163.
.. [Miot2021] M. Miot et al., "Numerical analysis of capillary bridges and coalescence
   in a triplet of spheres", Granular Matter 23 (2021), Eqs. (6)-(7) and section 2.2.
"""
from __future__ import annotations

import numpy as np

from capbridge.validation import check_range

__all__ = [
    "pitois_cylindrical_force",
    "richefeu_force",
    "willett_numeric_force",
    "willett_analytic_force",
    "rabinovich_force",
    "lian_rupture_distance",
    "willett_rupture_distance",
    "CLOSED_FORMS",
]


# --------------------------------------------------------------------------------------
# Input checks and helpers
# --------------------------------------------------------------------------------------


def _check_theta(theta):
    return np.radians(check_range("theta", theta, 0.0, 90.0, high_open=True, units=" deg",
                                  hint="contact angle in degrees, wetting liquids only"))


def _check_volume(volume):
    return check_range("volume V*", volume, 0.0, np.inf, low_open=True)


def _check_inputs(gap, volume, theta, ratio):
    """Validate and return (d*, V*, theta [rad], ratio) as float arrays."""
    d = check_range("gap d*", gap, 0.0, np.inf)
    v = _check_volume(volume)
    t = _check_theta(theta)
    q = check_range("ratio R2/R1", ratio, 1.0, np.inf,
                    hint="ratio is the larger radius over the smaller one")
    return d, v, t, q


def _derjaguin_factor(ratio):
    """k = R_eff / r with R_eff = 2 R1 R2 / (R1 + R2) and r = R1 the smaller radius."""
    return 2.0 * ratio / (1.0 + ratio)


def _out(x):
    """Plain float for scalar input, array otherwise (as in :mod:`dimensionless`)."""
    x = np.asarray(x, dtype=float)
    return float(x) if x.ndim == 0 else x


# --------------------------------------------------------------------------------------
# Forces
# --------------------------------------------------------------------------------------


def pitois_cylindrical_force(gap, volume, theta, ratio=1.0):
    r"""Capillary force in the cylindrical approximation of Pitois et al. (2000).

    .. math::

        F^* = k \cos\theta \left(1 - \frac{1}{\sqrt{1 + 2V^*/(\pi k\, d^{*2})}}\right)
            = k \cos\theta \left(1 - \frac{d^*}{\sqrt{d^{*2} + 2V^*/(\pi k)}}\right)

    with k = 1 for equal spheres (Miot et al. 2021, Eq. 6).  The second form is used so
    that d* = 0 gives F* = k cos(theta) without a division by zero.

    Parameters
    ----------
    gap : array_like
        d* = d / r, gap between the surfaces [-], >= 0.
    volume : array_like
        V* = V / r**3, bridge volume [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90.
    ratio : array_like, default 1
        R2 / R1 >= 1.  Unequal spheres use the Derjaguin radius R_eff = k r,
        k = 2 ratio / (1 + ratio), in place of R (an extension, not in Pitois et al.).

    Returns
    -------
    force : float or ndarray
        F* = F / (2 pi gamma r) [-], attraction positive, r the smaller radius.

    Notes
    -----
    Validity: small bridges, V* < 0.01 (Miot et al. 2021, section 2.2).
    Error: not quantified in the sources consulted.  Exact check: -25 % to +13 % for
    theta = 0, V* <= 0.01; -64 % to +61 % over the whole grid (too high near contact,
    where it gives cos(theta), too low towards rupture).  The same expression
    is the first term of :func:`rabinovich_force`.

    References
    ----------
    [Pitois2000]_, [Miot2021]_ Eq. (6).

    Examples
    --------
    At contact the force is cos(theta) (to the last ulp of the processor's cosine):

    >>> round(pitois_cylindrical_force(0.0, 0.01, 60.0), 12)
    0.5
    >>> round(pitois_cylindrical_force(0.05, 0.01, 0.0), 3)  # exact Young-Laplace: 0.473
    0.469
    """
    d, v, t, q = _check_inputs(gap, volume, theta, ratio)
    k = _derjaguin_factor(q)
    f = k * np.cos(t) * (1.0 - d / np.sqrt(d * d + 2.0 * v / (np.pi * k)))
    return _out(f)


def richefeu_force(gap, volume, theta, ratio=1.0):
    r"""Exponential capillary-force law of Richefeu et al. (2006), equal spheres.

    .. math::

        F^* = \cos\theta \, \exp\!\left(-\frac{d^*}{0.9\sqrt{V^*}}\right)

    i.e. F = 2 pi gamma R cos(theta) exp(-d/lambda) with lambda = 0.9 sqrt(V/R), a fit
    to Young-Laplace solutions for monodisperse grains (Miot et al. 2021, Eq. 7).

    Parameters
    ----------
    gap : array_like
        d* = d / r [-], >= 0.
    volume : array_like
        V* = V / r**3 [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90.
    ratio : array_like, default 1
        Must be 1: only the monodisperse law is implemented (Richefeu and co-authors
        published a polydisperse variant later; it is not included here).

    Returns
    -------
    force : float or ndarray
        F* = F / (2 pi gamma r) [-], attraction positive.

    Notes
    -----
    Validity: small volumes (Miot et al. 2021 state that Willett's fit covers a larger
    range than Eqs. (6)-(7)); no precise bound in the sources consulted.
    Error: not quantified in the sources consulted.  Exact check: -16 % to +40 % for
    theta = 0, V* <= 0.01; -79 % to +61 % over the whole grid.  The contact value is exactly
    cos(theta) whatever the volume, whereas the exact contact force decreases with
    volume (0.884 for V* = 0.01, theta = 0).

    References
    ----------
    [Richefeu2006]_, [Miot2021]_ Eq. (7).

    Examples
    --------
    Contact value and the decay length 0.9 sqrt(V*) (force cos(theta)/e there):

    >>> richefeu_force(0.0, 0.01, 0.0)
    1.0
    >>> round(richefeu_force(0.09, 0.01, 0.0), 6)  # exp(-1)
    0.367879
    """
    d, v, t, _ = _check_inputs(gap, volume, theta, ratio)
    check_range("ratio R2/R1", ratio, 1.0, 1.0,
                hint="richefeu_force implements the equal-sphere law only")
    return _out(np.cos(t) * np.exp(-d / (0.9 * np.sqrt(v))))


# Willett et al. (2000), appendix: ln F+ = f1 - f2 exp(f3 ln S+ + f4 ln^2 S+), each f_i a
# polynomial in ln V+ whose coefficients are quadratics in theta [rad].
# _WILLETT[i][j] = (c0, c1, c2) multiplies (ln V+)**j and gives c0 + c1 theta + c2 theta^2.
_WILLETT = (
    (  # f1
        (-0.44507, 0.050832, -1.1466),
        (-0.1119, -0.000411, -0.1490),
        (-0.012101, -0.0036456, -0.01255),
        (-0.0005, -0.0003505, -0.00029076),
    ),
    (  # f2
        (1.9222, -0.57473, -1.2918),
        (-0.0668, -0.1201, -0.22574),
        (-0.0013375, -0.0068988, -0.01137),
    ),
    (  # f3
        (1.268, -0.01396, -0.23566),
        (0.198, 0.092, -0.06418),
        (0.02232, 0.02238, -0.009853),
        (0.0008585, 0.001318, -0.00053),
    ),
    (  # f4
        (-0.010703, 0.073776, -0.34742),
        (0.03345, 0.04543, -0.09056),
        (0.0018574, 0.004456, -0.006257),
    ),
)


def _willett_f(i, lnv, t):
    out = 0.0
    for j, (c0, c1, c2) in enumerate(_WILLETT[i]):
        out = out + (c0 + t * (c1 + t * c2)) * lnv**j
    return out


def _willett_variables(gap, volume, theta, ratio):
    """Willett's V+ = V/R**3 and S+ = (s/2)/sqrt(V/R) with R = R_eff, s the full gap."""
    d, v, t, q = _check_inputs(gap, volume, theta, ratio)
    k = _derjaguin_factor(q)
    v_plus = v / k**3
    s_plus = 0.5 * d * np.sqrt(k / v)
    return s_plus, v_plus, t, k


def willett_numeric_force(gap, volume, theta, ratio=1.0):
    r"""Willett et al. (2000) fitted expression for the force between equal spheres.

    .. math::

        \ln F^+ = f_1 - f_2 \exp\left(f_3 \ln S^+ + f_4 \ln^2 S^+\right),
        \qquad F^* = k\, F^+

    with F+ = F / (2 pi gamma R), S+ = (s/2) / sqrt(V/R) the *half*-separation scaled by
    sqrt(V/R) (s the full gap between the surfaces), V+ = V/R**3, natural logarithms,
    and f1..f4 polynomials in ln V+ (cubic, quadratic, cubic, quadratic) whose
    coefficients are quadratics in theta [rad] (Willett et al. 2000, appendix).  For
    equal spheres R = r, k = 1, so F* = F+ and S+ = d* / (2 sqrt(V*)).  At S+ = 0 the
    expression is exp(f1).

    Parameters
    ----------
    gap : array_like
        d* = d / r [-], >= 0.
    volume : array_like
        V* = V / r**3 [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90 (fitted range 0-50 deg, see Notes).
    ratio : array_like, default 1
        R2 / R1 >= 1.  Unequal spheres: R = R_eff = k r, k = 2 ratio / (1 + ratio)
        (Derjaguin approximation, as YADE and MercuryDPM do), V+ = V*/k**3,
        S+ = (d*/2) sqrt(k/V*), F* = k F+.

    Returns
    -------
    force : float or ndarray
        F* = F / (2 pi gamma r) [-], attraction positive, r the smaller radius.

    Notes
    -----
    Validity: V* < 0.1 (Miot et al. 2021, section 2.2) and theta < 50 deg (the range
    usually quoted with the fit); outside, the polynomials are extrapolated and can
    behave badly (e.g. f4 > 0 makes the force vanish at contact).
    Error: the fit's own error figure is not available in the sources consulted;
    Miot et al. (2021, Fig. 3) find it agrees "fairly well" with exact Young-Laplace
    solutions.  Exact check, up to 0.8 of the rupture distance: -2.9 % to +2.4 % for
    theta <= 30 deg, -2.5 % to +5.6 % for theta = 40-50 deg; closer to rupture (0.8 to
    0.95 of it) up to +12.6 % of a small force (absolute error <= 0.025 everywhere).
    By far the most accurate formula here.
    Coefficients as in YADE ``pkg/dem/ViscoelasticCapillarPM.cpp``
    (``Willett_numeric_f``); one other public transcription has -0.0029076 for the
    theta**2 ln**3 V+ term of f1, which gives contact forces above cos(theta) and is
    rejected.

    References
    ----------
    [Willett2000]_ (appendix).

    Examples
    --------
    At contact the fit gives exp(f1); for V* = 0.01, theta = 0 this is 0.8715 against
    0.884 from the Young-Laplace equation:

    >>> round(willett_numeric_force(0.0, 0.01, 0.0), 4)
    0.8715
    >>> round(willett_numeric_force(0.05, 0.01, 0.0), 3)  # exact Young-Laplace: 0.473
    0.471
    """
    s_plus, v_plus, t, k = _willett_variables(gap, volume, theta, ratio)
    lnv = np.log(v_plus)
    f1 = _willett_f(0, lnv, t)
    f2 = _willett_f(1, lnv, t)
    f3 = _willett_f(2, lnv, t)
    f4 = _willett_f(3, lnv, t)
    touching = s_plus <= 0.0
    lns = np.log(np.where(touching, 1.0, s_plus))
    with np.errstate(over="ignore"):
        tail = np.where(touching, 0.0, f2 * np.exp(f3 * lns + f4 * lns * lns))
    return _out(k * np.exp(f1 - tail))


def willett_analytic_force(gap, volume, theta, ratio=1.0):
    r"""Willett et al. (2000) simple closed form for equal spheres.

    .. math::

        F^+ = \frac{\cos\theta}{1 + 2.1\,S^+ + 10.0\,S^{+2}}, \qquad F^* = k\, F^+

    with S+ = (s/2) / sqrt(V/R) (half-separation, as in :func:`willett_numeric_force`)
    and F+ = F / (2 pi gamma R) (Willett et al. 2000, Eq. 12).  Written with the full
    gap s and s^ = s sqrt(R/V) = 2 S+ it is Herminghaus's (2005) form
    F = 2 pi R gamma cos(theta) / (1 + 1.05 s^ + 2.5 s^**2).

    Parameters
    ----------
    gap : array_like
        d* = d / r [-], >= 0.
    volume : array_like
        V* = V / r**3 [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90.
    ratio : array_like, default 1
        R2 / R1 >= 1, through R = R_eff = k r, k = 2 ratio / (1 + ratio):
        S+ = (d*/2) sqrt(k/V*), F* = k F+.

    Returns
    -------
    force : float or ndarray
        F* = F / (2 pi gamma r) [-], attraction positive, r the smaller radius.

    Notes
    -----
    Validity: small volumes and small contact angles (the contact value is exactly
    cos(theta), the small-volume limit, so it over-predicts the contact force of finite
    bridges: 1.0 against 0.884 for V* = 0.01, theta = 0).
    Error: not quantified in the sources consulted.  Exact check: -20 % to +13 % for
    theta = 0, V* <= 0.01; -61 % to +61 % over the whole grid.
    Source of the form: YADE ``Willett_analytic_f`` (cites Willett 2000 Eq. 12 and the
    S+ definition after Eq. 11) and MercuryDPM ``LiquidBridgeWilletInteraction``
    (full-gap form 1 + 1.05 s^ + 2.5 s^**2), which agree.

    References
    ----------
    [Willett2000]_ Eq. (12); S. Herminghaus, Adv. Phys. 54 (2005) 221, Eq. (7).

    Examples
    --------
    >>> willett_analytic_force(0.0, 0.01, 60.0)
    0.5000000000000001
    >>> round(willett_analytic_force(0.1, 0.01, 0.0), 4)  # S+ = 0.5: 1/(1 + 1.05 + 2.5)
    0.2198
    """
    s_plus, _, t, k = _willett_variables(gap, volume, theta, ratio)
    return _out(k * np.cos(t) / (1.0 + 2.1 * s_plus + 10.0 * s_plus**2))


def rabinovich_force(gap, volume, theta, ratio=1.0):
    r"""Rabinovich et al. (2005) force for a fixed-volume bridge between spheres.

    .. math::

        F^+ = \frac{\cos\theta}{1 + H/(2 d_{sp})} + \sin\alpha\,\sin(\theta + \alpha),
        \qquad F^* = k\, F^+

        d_{sp} = \frac{H}{2}\left(-1 + \sqrt{1 + \frac{2V}{\pi R H^2}}\right),
        \qquad \alpha = \sqrt{\frac{2 d_{sp}}{R}}
        = \sqrt{\frac{H}{R}\left(-1 + \sqrt{1 + \frac{2V}{\pi R H^2}}\right)}

    with H the gap, d_sp the immersion depth of each sphere, alpha the half-filling
    (immersion) angle and F+ = F / (2 pi gamma R) (Rabinovich et al. 2005, Eqs. 19, 20
    and A3, sign changed so that attraction is positive).  For equal spheres R = r.
    The first term equals :func:`pitois_cylindrical_force`.

    Parameters
    ----------
    gap : array_like
        d* = d / r [-], >= 0.
    volume : array_like
        V* = V / r**3 [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90.
    ratio : array_like, default 1
        R2 / R1 >= 1, through R = R_eff = k r, k = 2 ratio / (1 + ratio), as Rabinovich
        et al. do for unequal spheres (Derjaguin radius).

    Returns
    -------
    force : float or ndarray
        F* = F / (2 pi gamma r) [-], attraction positive, r the smaller radius.

    Notes
    -----
    At H = 0 the continuous limit is used: d_sp = sqrt(V/(2 pi R)),
    alpha**4 = 2V/(pi R**3) (the small-angle toroidal filling angle).  YADE's
    ``Rabinovich_f`` instead sets alpha = 0 at exactly H = 0, a jump.
    Validity: small filling angles alpha (small volumes).
    Error: not quantified in the sources consulted.  Lambert et al. (2008) argue the
    second (surface-tension) term double-counts; it makes the contact force exceed
    cos(theta) (1.078 for V* = 0.01, theta = 0, against 0.884 exact).  Exact check:
    -18 % to +22 % for theta = 0, V* <= 0.01; -18 % to +101 % for theta <= 30 deg;
    +22 % to +179 % for theta = 40-50 deg.  The same
    term makes the force rise with theta at small angles (e.g. V* = 0.01, d* = 0.05:
    0.513 at 0 deg, 0.551 at 20 deg), unlike the exact force.  YADE's
    ``Lambert_f`` keeps only the first term.  Formulas as in YADE ``Rabinovich_f``.

    References
    ----------
    [Rabinovich2005]_, [Lambert2008]_.

    Examples
    --------
    >>> round(rabinovich_force(0.0, 0.01, 0.0), 4)  # cos(0) + sin(a0)**2, a0 = 0.2825 rad
    1.0777
    >>> round(rabinovich_force(0.05, 0.01, 0.0), 3)  # exact Young-Laplace: 0.473
    0.513
    """
    d, v, t, q = _check_inputs(gap, volume, theta, ratio)
    k = _derjaguin_factor(q)
    root = np.sqrt(d * d + 2.0 * v / (np.pi * k))
    d_sp = 0.5 * (root - d)              # = H/2 (-1 + sqrt(1 + 2V/(pi R H^2))), in r units
    alpha = np.sqrt(2.0 * d_sp / k)
    meniscus = np.cos(t) * (1.0 - d / root)   # = cos(theta) / (1 + H/(2 d_sp))
    tension = np.sin(alpha) * np.sin(t + alpha)
    return _out(k * (meniscus + tension))


# --------------------------------------------------------------------------------------
# Rupture distances (equal spheres)
# --------------------------------------------------------------------------------------


def lian_rupture_distance(volume, theta):
    r"""Rupture distance of Lian, Thornton and Adams (1993).

    .. math::

        d^*_{rupt} = \left(1 + \frac{\theta}{2}\right) V^{*1/3}, \qquad \theta \text{ in rad}

    d*_rupt is the full gap between the surfaces.  The law is scale-free
    (d_rupt = (1 + theta/2) V**(1/3)), so it holds for any normalising radius, including
    the smaller radius of unequal spheres.

    Parameters
    ----------
    volume : array_like
        V* = V / r**3 [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90.

    Returns
    -------
    gap : float or ndarray
        d*_rupt = d_rupt / r [-].

    Notes
    -----
    Validity: small volumes (it is the leading term of Willett's expression,
    :func:`willett_rupture_distance`); error not quantified in the sources consulted.
    Exact check (V* 0.001-0.1, theta 0/30/50 deg): -4.9 % to +2.8 %, too short at
    large volumes.

    References
    ----------
    [Lian1993]_.

    Examples
    --------
    >>> lian_rupture_distance(0.008, 0.0)
    0.2
    >>> round(lian_rupture_distance(0.008, 60.0), 4)  # (1 + pi/6) * 0.2
    0.3047
    """
    v = _check_volume(volume)
    t = _check_theta(theta)
    return _out((1.0 + 0.5 * t) * np.cbrt(v))


def willett_rupture_distance(volume, theta):
    r"""Rupture distance of Willett et al. (2000) for equal spheres.

    .. math::

        d^*_{rupt} = \left(1 + \frac{\theta}{2}\right)
                     \left(V^{*1/3} + 0.1\,V^{*2/3}\right), \qquad \theta \text{ in rad}

    with V* = V/R**3 for two spheres of radius R = r, and d*_rupt the full gap between
    the surfaces (Willett et al. 2000, Eq. 15, as used in YADE ``critDist``).

    Parameters
    ----------
    volume : array_like
        V* = V / r**3 [-], > 0.
    theta : array_like
        Contact angle [deg], 0 <= theta < 90.

    Returns
    -------
    gap : float or ndarray
        d*_rupt = d_rupt / r [-].

    Notes
    -----
    Equal spheres only: Willett's unequal-sphere variant (with a radius-ratio
    dependence) is not implemented.  Validity: as the Willett force fit, V* < 0.1;
    error not quantified in the sources consulted.  Exact check (V* 0.001-0.1,
    theta 0/30/50 deg): -0.5 % to +0.5 % at theta = 0, up to +3.9 % at 50 deg.  It
    reduces to
    :func:`lian_rupture_distance` as V* -> 0.

    References
    ----------
    [Willett2000]_ Eq. (15).

    Examples
    --------
    >>> round(willett_rupture_distance(0.008, 0.0), 6)  # 0.2 + 0.1 * 0.04
    0.204
    """
    v = _check_volume(volume)
    t = _check_theta(theta)
    c = np.cbrt(v)
    return _out((1.0 + 0.5 * t) * (c + 0.1 * c * c))


#: Force functions with the common signature ``f(gap, volume, theta, ratio=1.0) -> F*``.
CLOSED_FORMS = {
    "pitois": pitois_cylindrical_force,
    "richefeu": richefeu_force,
    "willett_numeric": willett_numeric_force,
    "willett_analytic": willett_analytic_force,
    "rabinovich": rabinovich_force,
}
