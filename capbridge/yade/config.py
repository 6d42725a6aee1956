"""The configuration of :class:`~capbridge.yade.engine.CapbridgeEngine` in a few typed groups.

The engine's 28 keywords, grouped by what they decide::

    from capbridge.yade.config import WaterContent, Coalescence, Speed
    cap = CapbridgeEngine(theta=20, gamma=0.073, liquid=WaterContent(0.01),
                          coalescence=Coalescence(every=10),
                          speed=Speed(refresh_every=10))

=========================  ==========================================================
group                      keywords it replaces
=========================  ==========================================================
the liquid amount          exactly one of :class:`BridgeVolume`, :class:`BridgeVolumeStar`
(``liquid=``)              (a fixed volume per bridge), :class:`LiquidVolume`,
                           :class:`WaterContent`, :class:`Saturation` (a total liquid,
                           with its rule: ``conserve``, ``film_fraction``); each carries
                           ``sample_volume``
:class:`Formation`         ``formation_gap``, ``initial_wet_gap``, ``initial_pairs``
:class:`Bodies`            ``ids``, ``walls``
:class:`Coalescence`       ``coalescence``, ``coalescence_every``, ``triplet_forces``,
                           ``triplet_table``, ``triplet_split``
:class:`GravityCorrection` ``gravity_correction``
:class:`Speed`             ``refresh_every``, ``force_tolerance``, ``skin``,
                           ``ratio_step``
top level                  ``theta``, ``gamma``, ``liquid_density``, ``table``,
                           ``label``
=========================  ==========================================================

``liquid_density`` stays one top-level value (the liquid's, as ``gamma``): None means
water, 1000 kg/m^3 to turn a water content into a volume and 997 kg/m^3 (water - air at
20 C) for the liquid's weight, as the flat keyword always did.

Every group is a small frozen dataclass, checked once when it is made with the checks
of :mod:`capbridge.yade.engine_options` (one line, a
:class:`~capbridge.validation.CapbridgeInputError`, naming the *flat* keyword as the
engine always has: ``Speed(refresh_every=2.7)`` says ``refresh_every=2.7 is not an
integer``), and holds the checked values (``Speed(refresh_every=10.0).refresh_every``
is 10).  :class:`EngineConfig` holds the groups and checks what joins two of them
(``initial_pairs`` and ``walls`` against ``ids``).  What needs a file or the scene (the
doublet and triplet tables, the spheres) is checked when the engine is made.

The flat keywords (``CapbridgeEngine(theta=..., water_content=..., ...)``) are kept, the
shim for scenes written before the groups and for restart files:
:meth:`EngineConfig.from_flat` maps them onto the groups, with the same defaults and
messages, and :meth:`EngineConfig.flat` maps back (what a saved scene stores in
``O.tags``, whichever way the engine was made).  :meth:`EngineConfig.from_keywords`
takes groups and the flat keywords of the groups not given (the engine's constructor
and :meth:`EngineConfig.build`); a flat keyword beside its own group is an error.

:func:`render_option_table` writes the option table of ``docs/yade_plugin.md`` from
:data:`ENGINE_PARAMETERS`, :data:`GROUP_FIELDS` and
:data:`~capbridge.yade.engine_options.OPTION_RULES`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

from capbridge.validation import CapbridgeInputError
from capbridge.yade import engine_options as eo

__all__ = ["BridgeVolume", "BridgeVolumeStar", "LiquidVolume", "WaterContent", "Saturation",
           "LIQUID_GROUPS", "Formation", "Bodies", "Coalescence", "GravityCorrection",
           "Speed", "EngineConfig", "ENGINE_PARAMETERS", "GROUP_FIELDS", "FLAT_DEFAULTS",
           "flat_keywords_given", "render_option_table", "is_group"]

#: name -> (default, meaning) of the 28 flat keywords; the option table of
#: docs/yade_plugin.md is made from this (:func:`render_option_table`).
ENGINE_PARAMETERS = {
    "theta": (0.0, "contact angle [deg]: one number, or a dict {material label or id: "
                   "angle} (a pair of different angles gets the exact bridge of that pair, "
                   "solved at scene start)"),
    "gamma": (0.073, "liquid-gas surface tension [N/m]"),
    "bridge_volume": (None, "fixed rule: every bridge that forms gets this volume [m^3]"),
    "bridge_volume_star": (None, "fixed rule: every bridge gets V = V* r^3, r its smaller "
                                 "radius"),
    "liquid_volume": (None, "total liquid [m^3], on the grains' films at the start "
                            "(in proportion to grain volume)"),
    "water_content": (None, "total liquid as mass of liquid / mass of grains, a fraction "
                            "(0.01 = 1 %; at most the void ratio 1 the pores of any sphere "
                            "packing hold)"),
    "saturation": (None, "total liquid as degree of saturation S_r = V_liquid / V_pores, "
                         "in (0, 1] (needs sample_volume)"),
    "sample_volume": (None, "volume of the sample [m^3], for saturation (and to report "
                            "the current saturation)"),
    "liquid_density": (None, "liquid density [kg/m^3]: liquid mass -> volume for "
                             "water_content and, as the density difference liquid - gas, "
                             "the liquid's weight under gravity; default (None) water: "
                             "1000 for water_content, 997 (water - air at 20 C) for the "
                             "weight"),
    "gravity_correction": ("auto", "gravity on the liquid (g read from NewtonIntegrator."
                                   "gravity at every refresh): 'auto' applies it to the "
                                   "bridges where it exceeds the doublet table's error, "
                                   "'on' to every bridge, 'off' never"),
    "conserve_liquid": (None, "True: liquid conserved (ruptured bridges return it to their "
                              "grains, new bridges take it from them); False: every bridge "
                              "gets the same fixed volume; default True for a total liquid, "
                              "False for a bridge volume"),
    "film_fraction": (0.5, "conserving rule: fraction of each grain's film a new bridge "
                           "takes (split among the bridges a grain forms in one step)"),
    "formation_gap": (0.0, "a bridge forms when the gap between surfaces is <= this [m]"),
    "initial_wet_gap": (None, "at the first step, pairs with gap <= this [m] get a bridge "
                              "(default formation_gap)"),
    "initial_pairs": (None, "at the first step, exactly these pairs of body ids get a bridge "
                            "(instead of initial_wet_gap)"),
    "refresh_every": (1, "update bridges and forces every N steps (forces held constant, "
                         "added to the permanent forces, in between)"),
    "force_tolerance": (0.0, "0: every wet grain's force is added (addF) every step, exact; "
                             "> 0: a bridge's force vector is handed to YADE again only when "
                             "it has changed by more than this fraction of its magnitude "
                             "(added to the permanent forces meanwhile): fewer calls into "
                             "YADE, forces off by up to that fraction"),
    "coalescence": (True, "detect coalesced bridges (reported; with triplet_forces their "
                          "triplets get the triplet table's forces)"),
    "triplet_forces": (False, "coalesced triplets get the triplet table's pair forces "
                              "instead of their bridges' doublet forces (True; opt-in: in "
                              "a settling packing clusters still merge and split at "
                              "almost every check, see docs/guide.md, \"Coalesced "
                              "triplets\") or False: report only"),
    "triplet_table": (None, "triplet table (path); default the shipped "
                            "data/triplet_table_packings.nc (the domain packings reach), "
                            "read at the first coalesced triplet"),
    "triplet_split": ("table", "how a split cluster shares its liquid: 'table' (equal "
                               "Laplace pressure on the doublet table, milliseconds), "
                               "'exact' (equal pressure, exact doublets, seconds per "
                               "split) or 'merge_volumes' (the bridges' volumes at the "
                               "merge, no solve)"),
    "coalescence_every": (10, "steps between coalescence checks"),
    "table": (None, "doublet table (path, Dataset or DoubletSurrogate); default the shipped "
                    "data/doublet_table.nc"),
    "ids": (None, "body ids of the wet spheres (default every sphere)"),
    "skin": (None, "Verlet skin of the near-pair list [m] (default 0.1 x smallest radius)"),
    "ratio_step": (0.01, "ratio node spacing for continuous size distributions"),
    "label": ("capbridge", "name of the engine (PyRunner label, registry key)"),
    "walls": (False, "bridges to walls: True wets every Wall, Box and Facet body (angle from "
                     "its material through theta), a list of body ids those only, False none"),
}

#: flat keyword -> its default
FLAT_DEFAULTS = {k: v[0] for k, v in ENGINE_PARAMETERS.items()}

#: the keywords that stay at the top level (not in a group)
TOP_LEVEL = ("theta", "gamma", "liquid_density", "table", "label")


def _flat_field(flat, default=dataclasses.MISSING):
    """A group field that stands for the flat keyword ``flat``."""
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata={"flat": flat})
    return dataclasses.field(default=default, metadata={"flat": flat})


class _Group:
    """Shared machinery: the flat keywords of the group, checked once at construction."""

    #: the engine_options check of the group (keyword arguments: the flat names)
    _check: ClassVar[Any]
    #: the keyword of :meth:`EngineConfig.build` that takes this group
    slot: ClassVar[str]

    @classmethod
    def flat_names(cls):
        """Field name -> flat keyword."""
        return {f.name: f.metadata["flat"] for f in dataclasses.fields(cls)}

    def flat(self):
        """The group as flat keywords (those of :class:`CapbridgeEngine`)."""
        return {flat: getattr(self, name) for name, flat in self.flat_names().items()}

    def _validate(self, **extra):
        checked = type(self)._check(**self.flat(), **extra)
        for name, flat in self.flat_names().items():
            value = checked[flat]
            if isinstance(value, list):        # frozen: ids and pairs as tuples
                value = tuple(tuple(v) if isinstance(v, (list, tuple)) else v
                              for v in value)
            object.__setattr__(self, name, value)

    def __post_init__(self):
        self._validate()


# ------------------------------------------------------------------------------------
# the liquid: exactly one amount
# ------------------------------------------------------------------------------------


class _Amount(_Group):
    slot = "liquid"

    def _validate(self, **extra):
        checked = eo.check_liquid(**self.flat(), **extra)
        for name, flat in self.flat_names().items():
            object.__setattr__(self, name, checked[flat])

    def flat(self):
        out = {k: None for k in eo.LIQUID_AMOUNTS}
        out.update(conserve_liquid=None, film_fraction=0.5)
        out.update(super().flat())
        return out


@dataclass(frozen=True)
class BridgeVolume(_Amount):
    """Fixed rule: every bridge that forms gets ``volume`` [m^3] (``bridge_volume``)."""
    volume: float = _flat_field("bridge_volume")
    sample_volume: float | None = _flat_field("sample_volume", None)


@dataclass(frozen=True)
class BridgeVolumeStar(_Amount):
    """Fixed rule: every bridge gets V = ``vstar`` r^3, r its smaller radius
    (``bridge_volume_star``)."""
    vstar: float = _flat_field("bridge_volume_star")
    sample_volume: float | None = _flat_field("sample_volume", None)


@dataclass(frozen=True)
class LiquidVolume(_Amount):
    """A total liquid ``volume`` [m^3] on the grains' films (``liquid_volume``);
    ``conserve`` (``conserve_liquid``, None: True), ``film_fraction``."""
    volume: float = _flat_field("liquid_volume")
    conserve: bool | None = _flat_field("conserve_liquid", None)
    film_fraction: float = _flat_field("film_fraction", 0.5)
    sample_volume: float | None = _flat_field("sample_volume", None)


@dataclass(frozen=True)
class WaterContent(_Amount):
    """A total liquid as mass of liquid / mass of grains, a ``fraction``
    (``water_content``; 0.01 = 1 %); ``conserve``, ``film_fraction`` as
    :class:`LiquidVolume`."""
    fraction: float = _flat_field("water_content")
    conserve: bool | None = _flat_field("conserve_liquid", None)
    film_fraction: float = _flat_field("film_fraction", 0.5)
    sample_volume: float | None = _flat_field("sample_volume", None)


@dataclass(frozen=True)
class Saturation(_Amount):
    """A total liquid as degree of saturation ``degree`` = V_liquid / V_pores in (0, 1]
    (``saturation``) of a sample of ``sample_volume`` [m^3]; ``conserve``,
    ``film_fraction`` as :class:`LiquidVolume`."""
    degree: float = _flat_field("saturation")
    sample_volume: float = _flat_field("sample_volume")
    conserve: bool | None = _flat_field("conserve_liquid", None)
    film_fraction: float = _flat_field("film_fraction", 0.5)


#: the liquid amounts, in the order of :data:`~capbridge.yade.engine_options.LIQUID_AMOUNTS`
LIQUID_GROUPS = (BridgeVolume, BridgeVolumeStar, LiquidVolume, WaterContent, Saturation)


# ------------------------------------------------------------------------------------
# the other groups
# ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Formation(_Group):
    """When bridges form: at ``gap`` [m] or closer (``formation_gap``); at the first
    step the pairs within ``initial_wet_gap`` [m] (None: ``gap``) or exactly
    ``initial_pairs`` (pairs of body ids)."""
    _check = staticmethod(eo.check_formation)
    slot = "formation"
    gap: float = _flat_field("formation_gap", 0.0)
    initial_wet_gap: float | None = _flat_field("initial_wet_gap", None)
    initial_pairs: Any = _flat_field("initial_pairs", None)


@dataclass(frozen=True)
class Bodies(_Group):
    """Which bodies are wet: ``ids`` of the wet spheres (None: every sphere) and the
    wall partners ``walls`` (True: every Wall, Box and Facet; a list of ids; False)."""
    _check = staticmethod(eo.check_bodies)
    slot = "bodies"
    ids: Any = _flat_field("ids", None)
    walls: Any = _flat_field("walls", False)

    def __post_init__(self):
        self._validate()
        eo.check_walls_not_ids(self.walls, self.ids)


@dataclass(frozen=True)
class Coalescence(_Group):
    """Coalescence detection (``enabled``: ``coalescence``) every ``every`` steps
    (``coalescence_every``); coalesced triplets get the triplet table's forces with
    ``triplet_forces=True`` (``triplet_table``: None the shipped one, read when the
    engine is made; ``triplet_split``: how a split cluster shares its liquid)."""
    _check = staticmethod(eo.check_coalescence)
    slot = "coalescence"
    enabled: bool = _flat_field("coalescence", True)
    every: int = _flat_field("coalescence_every", 10)
    triplet_forces: bool | None = _flat_field("triplet_forces", False)
    triplet_table: Any = _flat_field("triplet_table", None)
    triplet_split: str = _flat_field("triplet_split", "table")

    def __post_init__(self):
        self._validate()
        if self.triplet_forces and not self.enabled:
            raise CapbridgeInputError("triplet_forces=True needs coalescence=True (the "
                                      "detector finds the triplets)")


@dataclass(frozen=True)
class GravityCorrection(_Group):
    """Gravity on the liquid (``gravity_correction``): ``mode`` 'auto' (where it exceeds
    the doublet table's error), 'on' or 'off'; the density is the top-level
    ``liquid_density``."""
    _check = staticmethod(eo.check_gravity_mode)
    slot = "gravity"
    mode: str = _flat_field("gravity_correction", "auto")


@dataclass(frozen=True)
class Speed(_Group):
    """What trades accuracy or memory for speed: bridges updated every
    ``refresh_every`` steps, forces handed to YADE again when changed by more than
    ``force_tolerance``, the Verlet ``skin`` [m] (None: 0.1 x smallest radius), the
    ratio node spacing ``ratio_step``."""
    _check = staticmethod(eo.check_speed)
    slot = "speed"
    refresh_every: int = _flat_field("refresh_every", 1)
    force_tolerance: float = _flat_field("force_tolerance", 0.0)
    skin: float | None = _flat_field("skin", None)
    ratio_step: float = _flat_field("ratio_step", 0.01)


#: slot of :meth:`EngineConfig.build` -> group class (the liquid: any of LIQUID_GROUPS)
GROUPS = {"liquid": _Amount, "formation": Formation, "bodies": Bodies,
          "coalescence": Coalescence, "gravity": GravityCorrection, "speed": Speed}

#: flat keyword -> the slot of the group that holds it (None: top level)
FLAT_OWNER = {k: None for k in TOP_LEVEL}
FLAT_OWNER.update({k: "liquid" for k in (*eo.LIQUID_AMOUNTS, "sample_volume",
                                          "conserve_liquid", "film_fraction")})
for _cls in (Formation, Bodies, Coalescence, GravityCorrection, Speed):
    FLAT_OWNER.update({k: _cls.slot for k in _cls.flat_names().values()})
del _cls

#: flat keyword -> "Group.field" (the option table's second column)
def _group_fields():
    owners = {}
    for cls in (*LIQUID_GROUPS, Formation, Bodies, Coalescence, GravityCorrection, Speed):
        for name, flat in cls.flat_names().items():
            owners.setdefault(flat, ([], name))[0].append(cls.__name__)
    out = {k: "(top level)" for k in TOP_LEVEL}
    out.update({flat: f"`{'/'.join(classes)}.{name}`"
                for flat, (classes, name) in owners.items()})
    return out


GROUP_FIELDS = _group_fields()


# ------------------------------------------------------------------------------------
# the whole configuration
# ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EngineConfig:
    """The engine's configuration: the top-level values and one of each group."""
    liquid: _Amount
    theta: Any = 0.0
    gamma: float = 0.073
    liquid_density: float | None = None
    table: Any = None
    label: str = "capbridge"
    formation: Formation = dataclasses.field(default_factory=Formation)
    bodies: Bodies = dataclasses.field(default_factory=Bodies)
    coalescence: Coalescence = dataclasses.field(default_factory=Coalescence)
    gravity: GravityCorrection = dataclasses.field(default_factory=GravityCorrection)
    speed: Speed = dataclasses.field(default_factory=Speed)

    def __post_init__(self):
        for slot, cls in GROUPS.items():
            g = getattr(self, slot)
            if not isinstance(g, cls):
                want = ("one of " + ", ".join(c.__name__ for c in LIQUID_GROUPS)
                        if slot == "liquid" else cls.__name__)
                raise CapbridgeInputError(f"{slot}={g!r} is not allowed: give {want}(...)")
        top = eo.check_angles(self.theta, self.gamma)
        object.__setattr__(self, "gamma", top["gamma"])
        rho = eo.check_liquid(**dict(self.liquid.flat(),
                                     liquid_density=self.liquid_density))["liquid_density"]
        object.__setattr__(self, "liquid_density", rho)
        eo.check_table_arg(self.table)
        eo.check_label(self.label)
        # across groups
        eo.check_pairs_among_ids(self.formation.initial_pairs, self.bodies.ids)

    def flat(self):
        """The 28 flat keywords of :class:`~capbridge.yade.engine.CapbridgeEngine`."""
        out = {k: getattr(self, k) for k in TOP_LEVEL}
        for slot in GROUPS:
            out.update(getattr(self, slot).flat())
        for k in ("ids", "walls", "initial_pairs"):        # as the flat keywords take them
            if isinstance(out[k], tuple):
                out[k] = [list(v) if isinstance(v, tuple) else v for v in out[k]]
        return {k: out[k] for k in ENGINE_PARAMETERS}

    def checked(self):
        """The values the engine uses (:func:`~capbridge.yade.engine_options.check_options`
        of :meth:`flat`)."""
        return eo.check_options(**self.flat())

    @classmethod
    def from_flat(cls, **flat):
        """The groups of the flat keywords (the shim of the 28 keywords): checked as
        :func:`~capbridge.yade.engine_options.check_options` checks them, same order and
        messages."""
        unknown = sorted(set(flat) - set(ENGINE_PARAMETERS))
        if unknown:
            raise TypeError(f"unexpected keyword argument(s) {', '.join(unknown)}")
        kw = dict(FLAT_DEFAULTS, **flat)
        eo.check_options(**kw)
        amount = next(k for k in eo.LIQUID_AMOUNTS if kw[k] is not None)
        liquid_cls = LIQUID_GROUPS[eo.LIQUID_AMOUNTS.index(amount)]
        groups = {}
        for slot, gcls in GROUPS.items():
            gcls = liquid_cls if slot == "liquid" else gcls
            groups[slot] = gcls(**{name: kw[f] for name, f in gcls.flat_names().items()})
        return cls(**groups, **{k: kw[k] for k in TOP_LEVEL})

    def as_keywords(self):
        """The keywords of :class:`~capbridge.yade.engine.CapbridgeEngine` that make this
        configuration: the top-level values and the six groups."""
        return {**{k: getattr(self, k) for k in TOP_LEVEL},
                **{slot: getattr(self, slot) for slot in GROUPS}}

    @classmethod
    def build(cls, theta=0.0, gamma=0.073, *, liquid=None, formation=None, bodies=None,
              coalescence=None, gravity=None, speed=None, **flat):
        """Groups, and the flat keywords of the groups not given (and of the top level).
        A flat keyword beside its own group (``coalescence=Coalescence(...),
        coalescence_every=50``) is a :class:`CapbridgeInputError`."""
        groups = {"liquid": liquid, "formation": formation, "bodies": bodies,
                  "coalescence": coalescence, "gravity": gravity, "speed": speed}
        # ``coalescence=False`` is the flat keyword (a bool), not the group
        if coalescence is not None and not isinstance(coalescence, _Group):
            flat["coalescence"] = groups.pop("coalescence")
            groups["coalescence"] = None
        return cls.from_keywords(groups, dict(flat, theta=theta, gamma=gamma))

    @classmethod
    def from_keywords(cls, groups, flat):
        """The configuration of ``groups`` (slot -> group, or None where not given) and
        ``flat`` (flat keyword -> value: the top level and keywords of the groups not
        given; the others take their defaults).

        Raises
        ------
        CapbridgeInputError
            A flat keyword beside its own group, a group given as a flat keyword's value
            or in another group's slot, and every check of the groups and the values.
        TypeError
            An unknown keyword.
        """
        unknown = sorted(set(flat) - set(ENGINE_PARAMETERS))
        if unknown:
            raise TypeError(f"unexpected keyword argument(s) {', '.join(unknown)}")
        for k, v in flat.items():
            if isinstance(v, _Group):
                name = type(v).__name__
                raise CapbridgeInputError(f"{k}={name}(...) is a keyword group: give it as "
                                          f"{v.slot}={name}(...)")
            slot = FLAT_OWNER[k]
            if slot is not None and groups[slot] is not None:
                g = groups[slot]
                raise CapbridgeInputError(
                    f"{k}={v!r} given with {slot}={type(g).__name__}(...): give it "
                    f"in the group (or the flat keywords only), not both")
        for slot, g in groups.items():
            if g is not None and not isinstance(g, GROUPS[slot]):
                want = ("one of " + ", ".join(c.__name__ for c in LIQUID_GROUPS)
                        if slot == "liquid" else GROUPS[slot].__name__)
                raise CapbridgeInputError(f"{slot}={g!r} is not allowed: give {want}(...)")
        kw = dict(FLAT_DEFAULTS, **flat)
        for g in groups.values():
            if g is not None:
                kw.update(g.flat())
        cfg = cls.from_flat(**kw)
        # the groups given are kept as given (the same values, checked)
        return dataclasses.replace(cfg, **{s: g for s, g in groups.items() if g is not None})


def flat_keywords_given(flat):
    """The flat keywords of ``flat`` (all 28, as the engine's constructor receives them)
    that a caller set: the top level, and every other keyword whose value is not its
    default (:data:`FLAT_DEFAULTS`).

    A keyword given at its default cannot be told from one left out (the constructor
    has the defaults in its signature, the one scenes and restart files rely on), so
    beside its own group it is not an error: the group's value holds.
    """
    def at_default(k, v):
        d = FLAT_DEFAULTS[k]
        # same type and equal: 1.0 for refresh_every=1 counts as set (and is checked)
        return v is d or (d is not None and type(v) is type(d) and v == d)

    return {k: v for k, v in flat.items() if k in TOP_LEVEL or not at_default(k, v)}


# ------------------------------------------------------------------------------------
# the docs' option table
# ------------------------------------------------------------------------------------


def _cell(text):
    return str(text).replace("|", "\\|")


def render_option_table():
    """The option table of ``docs/yade_plugin.md`` (markdown, one row per flat keyword:
    the keyword, its group field, default, meaning, what is allowed)."""
    lines = ["| parameter | group field | default | meaning | allowed (checked when the "
             "engine is made) |", "|---|---|---|---|---|"]
    for k, (default, meaning) in ENGINE_PARAMETERS.items():
        lines.append(f"| `{k}` | {_cell(GROUP_FIELDS[k])} | {default!r} | {_cell(meaning)} "
                     f"| {_cell(eo.OPTION_RULES[k])} |")
    return "\n".join(lines) + "\n"


def is_group(value):
    """True for a keyword group (any of this module's group classes)."""
    return isinstance(value, _Group)
