"""The keywords of :class:`~capbridge.yade.engine.CapbridgeEngine`, checked in one place.

Every keyword is checked when the engine is made, with one line naming the keyword,
the value and what is allowed (:class:`~capbridge.validation.CapbridgeInputError`), in
three stages, all pure (numpy and the doublet table; no YADE):

:func:`check_options`
    each keyword alone and with the others: type (booleans are ``bool`` or numpy
    booleans, integers are integers or integral floats, numbers are real numbers, not
    strings), range, which keywords go together (exactly one liquid amount, ...).  It
    returns the values the engine uses (``refresh_every=10.0`` -> 10); nothing the
    user set is replaced by another value.
:func:`load_doublet_table`
    the doublet table (path, ``xarray.Dataset`` or fitted ``DoubletSurrogate``) is
    read and validated, and the keywords that depend on it are checked against it:
    a single ``theta`` against its contact angles, ``bridge_volume_star`` against its
    V* range.  The engine keeps the fitted table for its first step.
:func:`check_scene`
    the spheres (radii, masses, materials) and wall bodies the scene holds when the
    engine is made, when it holds any: the angle of every wet sphere's material, the
    radius ratios, a bridge volume against the table's V* range over the radii, a
    water content, liquid volume or saturation against the pores.  The engine
    gathers them from YADE (:meth:`CapbridgeEngine._scene_now`) and checks them
    again at its first step (the spheres may be added after the engine).

What can only be known while running (the gravity of ``NewtonIntegrator``: see
:func:`check_gravity`) is checked at the first step and whenever it changes.

:data:`OPTION_RULES` has the rule of every keyword in one line (the "allowed" column of
the table in ``docs/yade_plugin.md``).
"""
from __future__ import annotations

import keyword
import numbers
import os
from pathlib import Path

import numpy as np

from capbridge.dem.liquid_gravity import GRAVITY_MODES, check_gravity
from capbridge.surrogate.doublet import SI_SURFACE_TENSION_RANGE
from capbridge.validation import CapbridgeInputError, check_int, check_range, interval_text

__all__ = ["check_options", "check_angles", "check_liquid", "check_gravity_mode",
           "check_formation", "check_pairs_among_ids", "check_speed", "check_coalescence",
           "check_table_arg", "check_label", "check_bodies", "check_walls_not_ids",
           "load_doublet_table", "check_scene", "check_gravity",
           "material_angles", "liquid_total", "check_liquid_amount", "check_triplet_table",
           "OPTION_RULES", "LIQUID_AMOUNTS", "TRIPLET_SPLITS", "MAX_VOID_RATIO",
           "WALL_SHAPES"]

#: the liquid amounts, exactly one of which is given
LIQUID_AMOUNTS = ("bridge_volume", "bridge_volume_star", "liquid_volume", "water_content",
                  "saturation")
TOTAL_AMOUNTS = ("liquid_volume", "water_content", "saturation")

#: how a split liquid cluster shares its liquid (:mod:`capbridge.dem.triplet_clusters`)
TRIPLET_SPLITS = ("table", "exact", "merge_volumes")

#: Largest liquid volume per grain volume a water content may give: void ratio 1
#: (porosity 0.5), looser than any random packing of spheres (random loose packing:
#: porosity ~0.44), so more liquid than this cannot be held by the pores of any packing.
MAX_VOID_RATIO = 1.0

#: YADE shapes that can hold a wall bridge (:mod:`capbridge.dem.wall_bridges`)
WALL_SHAPES = ("Wall", "Box", "Facet")

#: relative slack of the table's V* range, as :class:`~capbridge.dem.bridges.BridgeModel`
_VSTAR_SLACK = 1e-12

_SLIP = "SI units expected: gamma in N/m (72 mN/m is 0.072; a unit slip?)"

#: keyword -> what is allowed, one line each (docs/yade_plugin.md has them)
OPTION_RULES = {
    "theta": "a number in [0, 90) deg within the doublet table's angles ([0, 80] for the "
             "shipped table), or a non-empty dict {material label (str) or id (int): "
             "angle in [0, 90]}; every wet sphere's material needs an angle in the table's "
             "range",
    "gamma": f"a number in {interval_text(*SI_SURFACE_TENSION_RANGE)} N/m (the plausible "
             "range of DoubletSurrogate.predict_si, SI_SURFACE_TENSION_RANGE: outside is a "
             "unit slip)",
    "bridge_volume": "None or a number > 0 [m^3] whose V* = V/r^3 over the wet spheres' "
                     "radii is in the table's V* range",
    "bridge_volume_star": "None or a number in the table's V* range ([0.001, 0.5] for the "
                          "shipped table)",
    "liquid_volume": "None or a number > 0 [m^3], at most the void ratio 1 of the grains",
    "water_content": "None or a number > 0 (a fraction), giving at most the void ratio 1",
    "saturation": "None or a number in (0, 1]; needs sample_volume",
    "sample_volume": "None or a number > 0 [m^3], larger than the grains' volume",
    "liquid_density": "None or a number > 0 [kg/m^3]",
    "gravity_correction": "'auto', 'on' or 'off'",
    "conserve_liquid": "None, True or False (a bool); True needs a total liquid "
                       "(liquid_volume, water_content or saturation)",
    "film_fraction": "a number in (0, 1]",
    "formation_gap": "a number >= 0 [m]",
    "initial_wet_gap": "None or a number >= 0 [m]",
    "initial_pairs": "None or a list of distinct pairs of two different body ids (integers "
                     ">= 0) of wet spheres",
    "refresh_every": "an integer >= 1 (an integral float such as 10.0 is taken as 10)",
    "force_tolerance": "a number in [0, 1]",
    "coalescence": "True or False (a bool)",
    "triplet_forces": "True or False (a bool); True needs coalescence=True and a valid "
                      "triplet table",
    "triplet_table": "None or a path (str or os.PathLike); must be a valid triplet table "
                     "when triplet_forces=True",
    "triplet_split": "'table', 'exact' or 'merge_volumes'",
    "coalescence_every": "an integer >= 1 (an integral float such as 10.0 is taken as 10)",
    "table": "None, a path (str or os.PathLike) of a valid doublet table, an "
             "xarray.Dataset or a fitted DoubletSurrogate",
    "ids": "None or a non-empty list of distinct body ids (integers >= 0) of spheres",
    "skin": "None or a number > 0 [m]",
    "ratio_step": "a number > 0",
    "label": "a str that is a Python identifier and not a keyword (YADE makes it a name)",
    "walls": "True, False (a bool) or a list of distinct body ids (integers >= 0) of Wall, "
             "Box or Facet bodies, none of them a wet sphere",
}


# ------------------------------------------------------------------------------------
# Elementary checks
# ------------------------------------------------------------------------------------


def _is_bool(value):
    return isinstance(value, (bool, np.bool_))


def _is_real(value):
    """A real number: Python or numpy int/float (0-d arrays included), not a bool."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    return isinstance(value, numbers.Real) and not _is_bool(value)


def _number(name, value, low=-np.inf, high=np.inf, *, low_open=False, high_open=False,
            units="", hint=""):
    """``value`` as a float after checking it is a real number (not a string, not a
    bool), finite and within the interval."""
    if not _is_real(value):
        raise CapbridgeInputError(
            f"{name}={value!r} is not a number: give a number in "
            f"{interval_text(low, high, low_open, high_open)}{units}"
            + (f"; {hint}" if hint else ""))
    return float(check_range(name, value, low, high, low_open=low_open, high_open=high_open,
                             units=units, hint=hint))


def _optional_number(name, value, *args, **kw):
    return None if value is None else _number(name, value, *args, **kw)


def _bool(name, value, allow_none=False, none_text=""):
    """``value`` as a bool: ``bool`` or a numpy boolean only (``"no"`` is not False)."""
    if value is None and allow_none:
        return None
    if not _is_bool(value):
        raise CapbridgeInputError(f"{name}={value!r} is not a boolean: give True or False"
                                  + none_text)
    return bool(value)


def _integer(name, value, low=None):
    """``value`` as an int: an integer or an integral float (``10.0``), never a bool,
    a string or ``2.7`` (:func:`capbridge.validation.check_int`)."""
    hint = "give an integer" + ("" if low is None else f" >= {low}")
    if isinstance(value, (str, bytes)):
        raise CapbridgeInputError(f"{name}={value!r} is not an integer; {hint}")
    return check_int(name, value, low, hint=hint)


def _choice(name, value, allowed):
    if not isinstance(value, str) or value not in allowed:
        raise CapbridgeInputError(f"{name}={value!r} is not allowed: give one of "
                                  + ", ".join(repr(a) for a in allowed))
    return value


def _id_list(name, value, *, allow_empty=False):
    """A list of distinct body ids (integers >= 0)."""
    if isinstance(value, (str, bytes, dict)) or not np.iterable(value):
        raise CapbridgeInputError(f"{name}={value!r} is not a list of body ids (integers "
                                  ">= 0)")
    out = [_integer(f"{name}[{k}]", v, 0) for k, v in enumerate(value)]
    if not out and not allow_empty:
        raise CapbridgeInputError(f"{name}=[] gives no body: give at least one body id (or "
                                  "None)")
    if len(set(out)) != len(out):
        twice = sorted({i for i in out if out.count(i) > 1})
        raise CapbridgeInputError(f"{name}: body ids {twice[:10]} are given more than once")
    return out


def _is_path(value):
    return isinstance(value, (str, os.PathLike))


# ------------------------------------------------------------------------------------
# Stage 1: the keywords
# ------------------------------------------------------------------------------------


def check_options(*, theta=0.0, gamma=0.073, bridge_volume=None, bridge_volume_star=None,
                  liquid_volume=None, water_content=None, saturation=None,
                  sample_volume=None, liquid_density=None, conserve_liquid=None,
                  film_fraction=0.5, formation_gap=0.0, initial_wet_gap=None,
                  initial_pairs=None, refresh_every=1, force_tolerance=0.0,
                  coalescence=True, coalescence_every=10, table=None, ids=None, skin=None,
                  ratio_step=0.01, label="capbridge", triplet_forces=False,
                  triplet_table=None, walls=False, triplet_split="table",
                  gravity_correction="auto"):
    """Check every keyword of :class:`~capbridge.yade.engine.CapbridgeEngine`
    (the same names and defaults) and return the values the engine uses.

    Raises :class:`~capbridge.validation.CapbridgeInputError` with one line naming the
    keyword, the value and what is allowed (:data:`OPTION_RULES`).  Pure: no YADE, no
    file is read (:func:`load_doublet_table` reads the tables).  The checks are those
    of the keyword groups (:mod:`capbridge.yade.config`), one function per group
    (:func:`check_angles`, :func:`check_liquid`, :func:`check_gravity_mode`,
    :func:`check_bodies`, :func:`check_formation`, :func:`check_speed`,
    :func:`check_coalescence`, :func:`check_table_arg`, :func:`check_label`), and the
    checks across groups (``initial_pairs`` and ``walls`` against ``ids``).

    Returns
    -------
    dict
        Keyword -> value: numbers as float, integers as int, booleans as bool, ids as
        lists of int, ``initial_pairs`` as a list of (int, int); ``theta`` as given
        (a number as float); paths and tables as given.
    """
    out = check_angles(theta, gamma)
    out.update(check_liquid(bridge_volume=bridge_volume,
                            bridge_volume_star=bridge_volume_star,
                            liquid_volume=liquid_volume, water_content=water_content,
                            saturation=saturation, sample_volume=sample_volume,
                            liquid_density=liquid_density, conserve_liquid=conserve_liquid,
                            film_fraction=film_fraction))
    out.update(check_gravity_mode(gravity_correction))
    out.update(check_formation(formation_gap=formation_gap, initial_wet_gap=initial_wet_gap,
                               initial_pairs=initial_pairs))
    out.update(check_speed(refresh_every=refresh_every, force_tolerance=force_tolerance,
                           skin=skin, ratio_step=ratio_step))
    out.update(check_bodies(ids=ids, walls=walls))
    check_pairs_among_ids(out["initial_pairs"], out["ids"])
    out.update(check_coalescence(coalescence=coalescence,
                                 coalescence_every=coalescence_every,
                                 triplet_forces=triplet_forces, triplet_table=triplet_table,
                                 triplet_split=triplet_split))
    out.update(check_table_arg(table))
    out.update(check_label(label))
    check_walls_not_ids(out["walls"], out["ids"])
    return out


def check_angles(theta=0.0, gamma=0.073):
    """``theta`` (a number or {material: angle}) and ``gamma`` [N/m]."""
    from capbridge.solvers.sphere_wall import THETA_WALL_MAX_DEG
    from capbridge.solvers.young_laplace import THETA_MAX_DEG

    out = {}
    if isinstance(theta, dict):
        if not theta:
            raise CapbridgeInputError("theta={} gives no contact angle: give a number, or "
                                      "{material label or id: angle}")
        for key, val in theta.items():
            if not (isinstance(key, str) or (isinstance(key, numbers.Integral)
                                             and not _is_bool(key))):
                raise CapbridgeInputError(
                    f"theta: key {key!r} ({type(key).__name__}) is not a material label "
                    "(str) or material id (int)")
            _number(f"theta[{key!r}]", val, 0.0, THETA_WALL_MAX_DEG, units=" deg",
                    hint="contact angles in degrees: [0, 90) on spheres, [0, 90] on walls")
        out["theta"] = theta
    else:
        out["theta"] = _number("theta", theta, 0.0, THETA_MAX_DEG, high_open=True,
                               units=" deg", hint="a contact angle in degrees, or a dict "
                                                  "{material label or id: angle}")
    out["gamma"] = _number("gamma", gamma, *SI_SURFACE_TENSION_RANGE, units=" N/m",
                           hint=_SLIP)
    return out


def check_liquid(*, bridge_volume=None, bridge_volume_star=None, liquid_volume=None,
                 water_content=None, saturation=None, sample_volume=None,
                 liquid_density=None, conserve_liquid=None, film_fraction=0.5):
    """The liquid: exactly one amount, the sample volume, the density, the rule."""
    out = {}
    amounts = {"bridge_volume": bridge_volume, "bridge_volume_star": bridge_volume_star,
               "liquid_volume": liquid_volume, "water_content": water_content,
               "saturation": saturation}
    given = [k for k in LIQUID_AMOUNTS if amounts[k] is not None]
    if len(given) != 1:
        raise CapbridgeInputError(
            "give exactly one of bridge_volume, bridge_volume_star, liquid_volume, "
            f"water_content, saturation (got {', '.join(given) if given else 'none'})")
    units = {"bridge_volume": " m^3", "liquid_volume": " m^3"}
    hints = {"water_content": "a fraction: liquid mass / grain mass, 0.01 for 1 %",
             "saturation": "degree of saturation V_liquid / V_pores, 0.2 for 20 %"}
    high = {"saturation": 1.0}
    for k in LIQUID_AMOUNTS:
        out[k] = _optional_number(k, amounts[k], 0.0, high.get(k, np.inf), low_open=True,
                                  units=units.get(k, ""), hint=hints.get(k, ""))
    out["sample_volume"] = _optional_number("sample_volume", sample_volume, 0.0, np.inf,
                                            low_open=True, units=" m^3")
    if saturation is not None and sample_volume is None:
        raise CapbridgeInputError("saturation needs sample_volume (the volume of the "
                                  "sample, m^3)")
    out["liquid_density"] = _optional_number(
        "liquid_density", liquid_density, 0.0, np.inf, low_open=True, units=" kg/m^3",
        hint="density difference liquid - gas, 997 for water in air at 20 C")
    out["conserve_liquid"] = _bool("conserve_liquid", conserve_liquid, allow_none=True,
                                   none_text=" (or None: the rule's default)")
    if out["conserve_liquid"] and given[0] not in TOTAL_AMOUNTS:
        raise CapbridgeInputError(
            f"conserve_liquid=True needs a total liquid (liquid_volume, water_content or "
            f"saturation), not {given[0]}")
    out["film_fraction"] = _number("film_fraction", film_fraction, 0.0, 1.0, low_open=True,
                                   hint="the fraction of each grain's film a new bridge takes")
    return out


def check_gravity_mode(gravity_correction="auto"):
    """``gravity_correction``: 'auto', 'on' or 'off'."""
    return {"gravity_correction": _choice("gravity_correction", gravity_correction,
                                          GRAVITY_MODES)}


def check_formation(*, formation_gap=0.0, initial_wet_gap=None, initial_pairs=None):
    """When bridges form: the formation gap, the first step's gap or pairs."""
    out = {}
    out["formation_gap"] = _number("formation_gap", formation_gap, 0.0, np.inf, units=" m")
    out["initial_wet_gap"] = _optional_number("initial_wet_gap", initial_wet_gap, 0.0,
                                              np.inf, units=" m")
    if initial_pairs is None:
        out["initial_pairs"] = None
        return out
    if isinstance(initial_pairs, (str, bytes, dict)) or not np.iterable(initial_pairs):
        raise CapbridgeInputError(f"initial_pairs={initial_pairs!r} is not a list of "
                                  "pairs of body ids")
    pairs, seen = [], set()
    for k, p in enumerate(initial_pairs):
        if isinstance(p, (str, bytes, dict)) or not np.iterable(p) or len(p) != 2:
            raise CapbridgeInputError(f"initial_pairs[{k}]={p!r} is not a pair of two "
                                      "body ids")
        a, b = (_integer(f"initial_pairs[{k}]", v, 0) for v in p)
        if a == b:
            raise CapbridgeInputError(f"initial_pairs[{k}]=({a}, {b}): a bridge joins "
                                      "two different bodies")
        if frozenset((a, b)) in seen:
            raise CapbridgeInputError(f"initial_pairs[{k}]=({a}, {b}): the pair is "
                                      "given more than once")
        seen.add(frozenset((a, b)))
        pairs.append((a, b))
    out["initial_pairs"] = pairs
    return out


def check_pairs_among_ids(pairs, ids):
    """Every body of ``initial_pairs`` is a wet sphere (among ``ids`` when given)."""
    if pairs is not None and ids is not None:
        miss = sorted({i for p in pairs for i in p} - set(ids))
        if miss:
            raise CapbridgeInputError(f"initial_pairs: bodies {miss[:10]} are not among "
                                      "ids (the wet spheres)")


def check_speed(*, refresh_every=1, force_tolerance=0.0, skin=None, ratio_step=0.01):
    """What trades accuracy for speed: refresh period, force tolerance, Verlet skin,
    ratio node spacing."""
    out = {}
    out["skin"] = _optional_number("skin", skin, 0.0, np.inf, low_open=True, units=" m")
    out["ratio_step"] = _number("ratio_step", ratio_step, 0.0, np.inf, low_open=True)
    out["refresh_every"] = _integer("refresh_every", refresh_every, 1)
    out["force_tolerance"] = _number("force_tolerance", force_tolerance, 0.0, 1.0,
                                     hint="a fraction of each bridge force, 0 for exact "
                                          "forces every step")
    return out


def check_coalescence(*, coalescence=True, coalescence_every=10, triplet_forces=False,
                      triplet_table=None, triplet_split="table"):
    """Coalescence detection and coalesced triplets (the triplet table itself is read
    by :func:`check_triplet_table` when the engine is made)."""
    out = {}
    out["coalescence"] = _bool("coalescence", coalescence)
    out["coalescence_every"] = _integer("coalescence_every", coalescence_every, 1)
    # None: the default of scenes saved before triplet_forces was opt-in (on if the
    # triplet table exists); only True / False can be given
    out["triplet_forces"] = _bool("triplet_forces", triplet_forces, allow_none=True)
    if triplet_table is not None and not _is_path(triplet_table):
        raise CapbridgeInputError(f"triplet_table={triplet_table!r} is not a path (str or "
                                  "os.PathLike)")
    out["triplet_table"] = triplet_table
    out["triplet_split"] = _choice("triplet_split", triplet_split, TRIPLET_SPLITS)
    return out


def check_table_arg(table=None):
    """The doublet table argument's type (read by :func:`load_doublet_table`)."""
    if table is not None and not _is_path(table):
        from capbridge.surrogate.doublet import DoubletSurrogate
        import xarray as xr

        if not isinstance(table, (xr.Dataset, DoubletSurrogate)):
            raise CapbridgeInputError(
                f"table: a {type(table).__name__} is not a doublet table: give a path, an "
                "xarray.Dataset or a fitted DoubletSurrogate (or None: the shipped table)")
    return {"table": table}


def check_label(label="capbridge"):
    """The engine's name: a Python identifier, not a keyword."""
    if not isinstance(label, str) or not label.isidentifier() or keyword.iskeyword(label):
        raise CapbridgeInputError(
            f"label={label!r} is not allowed: give a str that is a Python identifier and "
            "not a keyword, e.g. 'capbridge' (YADE makes the label a Python name)")
    return {"label": label}


def check_bodies(*, ids=None, walls=False):
    """The wet spheres (``ids``) and the wall partners (``walls``)."""
    out = {"ids": None if ids is None else _id_list("ids", ids)}
    if _is_bool(walls):
        out["walls"] = bool(walls)
    elif walls is None or isinstance(walls, (str, bytes, dict)) or not np.iterable(walls):
        raise CapbridgeInputError(f"walls={walls!r} is not allowed: give True (every Wall, "
                                  "Box and Facet body), False (none) or a list of body ids")
    else:
        out["walls"] = _id_list("walls", walls, allow_empty=True)
    return out


def check_walls_not_ids(walls, ids):
    """No wall partner is a wet sphere."""
    if ids is not None and not isinstance(walls, bool):
        both = sorted(set(walls) & set(ids))
        if both:
            raise CapbridgeInputError(f"walls: bodies {both[:10]} are also in ids (the "
                                      "wet spheres)")


# ------------------------------------------------------------------------------------
# Stage 2: the tables
# ------------------------------------------------------------------------------------


def load_doublet_table(table, opts):
    """The doublet table ``table`` (None: the shipped one) read, validated and fitted,
    and the keywords that depend on it checked against it; returns the fitted
    :class:`~capbridge.surrogate.doublet.DoubletSurrogate`.

    ``opts`` is :func:`check_options`' answer.  A table the engine cannot use (missing,
    damaged, foreign, with unconverged points) is a :class:`CapbridgeInputError` naming
    it; so are a single ``theta`` outside the table's angles and a
    ``bridge_volume_star`` outside its V* range.
    """
    from capbridge.dem.bridges import SceneTable, default_table_path
    from capbridge.surrogate.doublet import DoubletSurrogate

    what = f"table={str(table)!r}" if _is_path(table) else \
        "the shipped table" if table is None else f"table ({type(table).__name__})"
    try:
        if isinstance(table, DoubletSurrogate):
            if not hasattr(table, "table_"):
                raise CapbridgeInputError("the DoubletSurrogate is not fitted: call "
                                          "fit(table) first")
            sur = table
        else:
            src = default_table_path() if table is None else table
            if _is_path(src) and not Path(src).is_file():
                raise CapbridgeInputError(f"{src} does not exist or is not a file")
            sur = DoubletSurrogate().fit(src)
        SceneTable._check_status(sur.table_)
    except (CapbridgeInputError, OSError, ValueError, KeyError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise CapbridgeInputError(f"{what} cannot be used: {first}") from exc
    th_lo, th_hi = float(sur.theta_[0]), float(sur.theta_[-1])
    if not isinstance(opts["theta"], dict):
        check_range("theta", opts["theta"], th_lo, th_hi, units=" deg",
                    hint=f"the doublet table's contact angles ({what})")
    v_lo, v_hi = float(sur.volume_[0]), float(sur.volume_[-1])
    if opts["bridge_volume_star"] is not None:
        check_range("bridge_volume_star", opts["bridge_volume_star"],
                    v_lo * (1 - _VSTAR_SLACK), v_hi * (1 + _VSTAR_SLACK),
                    hint=f"the doublet table's V* range [{v_lo:g}, {v_hi:g}] ({what})")
    return sur


def check_triplet_table(triplet_forces, triplet_table, coalescence):
    """``(on, path)``: whether coalesced triplets get the triplet table's forces, and the
    table's path (default the shipped one).  ``triplet_forces=True`` needs
    ``coalescence=True`` and a valid table (read here, so that a damaged one is an error
    now, not at the first coalesced triplet); ``None`` (scenes saved with that old
    default) means on when the table exists."""
    from capbridge.surrogate.triplet import engine_table

    path = Path(triplet_table) if triplet_table is not None else engine_table()
    if triplet_forces is None:
        triplet_forces = coalescence and path.exists()
    elif triplet_forces and not path.exists():
        raise CapbridgeInputError(f"triplet_forces=True but the triplet table {path} "
                                  "does not exist: give triplet_table=... or "
                                  "triplet_forces=False")
    if triplet_forces and not coalescence:
        raise CapbridgeInputError("triplet_forces=True needs coalescence=True (the "
                                  "detector finds the triplets)")
    if triplet_forces:
        from capbridge.tables.netcdf_io import TableError
        from capbridge.surrogate.triplet import TripletSurrogate
        try:
            TripletSurrogate._load(path)
        except TableError as exc:
            raise CapbridgeInputError(f"triplet_forces=True but {exc}: give a valid "
                                      "triplet_table=... or triplet_forces=False") from exc
    return bool(triplet_forces), path


# ------------------------------------------------------------------------------------
# Stage 3: the scene (spheres and walls known when the engine is made, and at its
# first step)
# ------------------------------------------------------------------------------------


def material_angles(theta, materials, what="body"):
    """Contact angle [deg] of every body from its material: ``materials`` a list of
    ``(body id, material label, material id)``; ``theta`` a number or a dict keyed by
    material label or id (the label is looked up first)."""
    out = np.empty(len(materials))
    if not isinstance(theta, dict):
        out[:] = float(theta)
        return out
    for k, (bid, mlabel, mid) in enumerate(materials):
        for key in (mlabel, mid):
            if isinstance(key, (str, int)) and key in theta:
                out[k] = float(theta[key])
                break
        else:
            raise CapbridgeInputError(
                f"theta: no contact angle for {what} {bid}'s material (label {mlabel!r}, id {mid}); "
                f"theta has {list(theta)}")
    return out


def liquid_total(amount, radii, masses, sample_volume, liquid_density):
    """``(W, v_s, v_p)``: the total liquid [m^3] a liquid amount gives on these grains
    (None for a bridge volume), the grains' volume and the pores' volume (None without
    ``sample_volume``) [m^3]; ``sample_volume`` must exceed the grains' volume."""
    radii = np.asarray(radii, float)
    v_s = float((4.0 / 3.0 * np.pi * radii**3).sum())
    v_p = None
    if sample_volume is not None:
        v_p = float(sample_volume) - v_s
        if not v_p > 0:
            raise CapbridgeInputError(f"sample_volume {float(sample_volume):g} m^3 is not "
                                      f"larger than the grains' volume {v_s:g} m^3")
    W = None
    if amount.get("liquid_volume") is not None:
        W = float(amount["liquid_volume"])
    elif amount.get("water_content") is not None:
        W = float(amount["water_content"]) * float(sum(masses)) / liquid_density
    elif amount.get("saturation") is not None:
        W = float(amount["saturation"]) * v_p
    return W, v_s, v_p


def check_liquid_amount(amount, W, v_s, v_p, masses, liquid_density):
    """A total liquid W [m^3] the grains cannot hold is an input error, not a number."""
    if W is None:
        return
    if v_p is not None and W > v_p * (1 + 1e-12):
        raise CapbridgeInputError(
            f"the liquid ({W:.4g} m^3) is more than the pores of the sample hold "
            f"({v_p:.4g} m^3): saturation {W / v_p:.4g} is outside (0, 1]")
    if W > MAX_VOID_RATIO * v_s:
        if amount.get("water_content") is not None:
            mass = float(sum(masses))
            w_max = MAX_VOID_RATIO * v_s * liquid_density / mass
            raise CapbridgeInputError(
                f"water_content={amount['water_content']!r} gives {W / v_s:.3g} m^3 of liquid "
                f"per m^3 of grains, more than the pores of any sphere packing hold: allowed "
                f"(0, {w_max:.3g}] for these grains (a fraction: 0.01 for 1 %)")
        raise CapbridgeInputError(
            f"liquid_volume={W!r} m^3 is more than the pores of any packing of these grains "
            f"hold: allowed (0, {MAX_VOID_RATIO * v_s:.4g}] m^3")


def check_scene(opts, surrogate, spheres, walls=(), *, complete=False, liquid_density=1000.0):
    """Check the keywords against the grains the scene holds.

    Parameters
    ----------
    opts : :func:`check_options`' answer.
    surrogate : the fitted doublet table (:func:`load_doublet_table`).
    spheres : list of ``(body id, radius [m], mass [kg], material label, material id)``
        of the wet spheres present (empty: nothing is checked).
    walls : list of ``(body id, shape name, material label, material id)`` of the wall
        partners present (``walls=True``: every Wall, Box and Facet body; a list of
        ids: those bodies, whatever their shape).
    complete : True when ``spheres`` are all the wet spheres the engine will have
        (``ids`` given and all present); the liquid volume and saturation against the
        grains' volume are only checked then (spheres added later would give more pore
        space); a water content (liquid per grain mass) is checked on the spheres present.
    liquid_density : [kg/m^3] for a water content.

    Checks: every wet sphere's material has an angle (dict ``theta``) in the table's
    range; the radius ratios are in the table's; a ``bridge_volume`` gives V* in the
    table's range over the radii; a water content, liquid volume or saturation the
    pores can hold, a ``sample_volume`` larger than the grains; wall partners are Wall,
    Box or Facet bodies with an angle in [0, 90].
    """
    from capbridge.solvers.sphere_wall import THETA_WALL_MAX_DEG

    theta = opts["theta"]
    if spheres:
        _check_spheres(opts, surrogate, spheres, complete, liquid_density)
    for bid, shape, mlabel, mid in walls:
        if shape not in WALL_SHAPES:
            raise CapbridgeInputError(f"walls: body {bid} is a {shape}, not a Wall, Box or "
                                      "Facet")
        ang = material_angles(theta, [(bid, mlabel, mid)], "wall body")
        check_range(f"theta of wall body {bid}'s material (label {mlabel!r}, id {mid})",
                    ang, 0.0, THETA_WALL_MAX_DEG, units=" deg",
                    hint="the contact angle on a wall is supported in [0, 90] degrees")


def _check_spheres(opts, surrogate, spheres, complete, liquid_density):
    theta = opts["theta"]
    bid = np.array([s[0] for s in spheres], np.intp)
    radii = np.array([s[1] for s in spheres], float)
    masses = np.array([s[2] for s in spheres], float)
    ang = material_angles(theta, [(s[0], s[3], s[4]) for s in spheres], "body")
    th_lo, th_hi = float(surrogate.theta_[0]), float(surrogate.theta_[-1])
    bad = ~((ang >= th_lo - 1e-9) & (ang <= th_hi + 1e-9))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise CapbridgeInputError(
            f"theta: the contact angle {ang[k]:g} deg of body {bid[k]}'s material (label "
            f"{spheres[k][3]!r}, id {spheres[k][4]}) is outside the doublet table's "
            f"[{th_lo:g}, {th_hi:g}] deg ({int(bad.sum())} wet spheres)")
    if not np.all(np.isfinite(radii) & (radii > 0)):
        k = int(np.flatnonzero(~(np.isfinite(radii) & (radii > 0)))[0])
        raise CapbridgeInputError(f"sphere {bid[k]} has radius {radii[k]!r}: radii must be "
                                  "positive")
    rmin, rmax = float(radii.min()), float(radii.max())
    r_hi = float(surrogate.ratios_[-1])
    if rmax / rmin > r_hi * (1 + 1e-12):
        raise CapbridgeInputError(
            f"the wet spheres' radii [{rmin:g}, {rmax:g}] m give radius ratios up to "
            f"{rmax / rmin:g}; the doublet table covers [1, {r_hi:g}] (larger / smaller "
            "radius): give ids=[...] of spheres within that ratio")
    lo, hi = float(surrogate.volume_[0]), float(surrogate.volume_[-1])
    v = opts["bridge_volume"]
    if v is not None:
        vs = (v / rmax**3, v / rmin**3)
        if vs[0] < lo * (1 - _VSTAR_SLACK) or vs[1] > hi * (1 + _VSTAR_SLACK):
            raise CapbridgeInputError(
                f"bridge_volume={v:g} m^3 gives V* = V/r^3 from {vs[0]:g} to {vs[1]:g} over "
                f"the wet spheres' radii [{rmin:g}, {rmax:g}] m; the table covers "
                f"[{lo:g}, {hi:g}]: choose a volume in [{lo * rmin**3:g}, "
                f"{hi * rmax**3:g}] m^3 (when that range exists) or use bridge_volume_star")
    amount = {k: opts[k] for k in LIQUID_AMOUNTS}
    if not complete:                   # extensive amounts: more spheres may come
        amount["liquid_volume"] = amount["saturation"] = None
    W, v_s, v_p = liquid_total(amount, radii, masses, opts["sample_volume"], liquid_density)
    check_liquid_amount(amount, W, v_s, v_p if complete else None, masses, liquid_density)


# ------------------------------------------------------------------------------------
# While running
# ------------------------------------------------------------------------------------


