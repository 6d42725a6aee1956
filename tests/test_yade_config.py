"""The keyword groups of CapbridgeEngine (capbridge.yade.config): each group's checks,
the shim of the 28 flat keywords (same parameters, state and forces), mixing refused,
and the docs' option table made from the definitions."""
from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import pytest

from capbridge.validation import CapbridgeInputError
from capbridge.yade import config as C
from capbridge.yade import yade_runtime as yr

DOCS = Path(__file__).resolve().parents[1] / "docs" / "yade_plugin.md"
SCENES = Path(__file__).parent / "yade_scenes"


# --------------------------------------------------------------------------------------
# each group: checked once when made, one line naming the flat keyword
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("make,pattern", [
    (lambda: C.BridgeVolume(-1e-12), r"^bridge_volume=-1e-12 m\^3 is outside the allowed "
                                     r"range \(0, inf\)"),
    (lambda: C.BridgeVolume("1e-12"), r"^bridge_volume='1e-12' is not a number"),
    (lambda: C.BridgeVolumeStar(0.0), r"^bridge_volume_star=0\.0 is outside"),
    (lambda: C.LiquidVolume(1e-9, conserve="yes"), r"^conserve_liquid='yes' is not a boolean"),
    (lambda: C.LiquidVolume(1e-9, film_fraction=1.5), r"^film_fraction=1\.5 is outside"),
    (lambda: C.WaterContent(math.nan), r"^water_content=nan is outside"),
    (lambda: C.Saturation(1.2, 1e-6), r"^saturation=1\.2 is outside the allowed range "
                                      r"\(0, 1\]"),
    (lambda: C.Saturation(0.2, -1.0), r"^sample_volume=-1\.0 m\^3 is outside"),
    (lambda: C.Formation(gap=-1e-6), r"^formation_gap=-1e-06 m is outside"),
    (lambda: C.Formation(initial_pairs=[(1, 1)]), r"^initial_pairs\[0\]=\(1, 1\): a bridge "
                                                  r"joins two different bodies"),
    (lambda: C.Formation(initial_pairs="0-1"), r"^initial_pairs='0-1' is not a list"),
    (lambda: C.Bodies(ids=[]), r"^ids=\[\] gives no body"),
    (lambda: C.Bodies(walls="all"), r"^walls='all' is not allowed"),
    (lambda: C.Bodies(ids=[1, 2], walls=[2]), r"^walls: bodies \[2\] are also in ids"),
    (lambda: C.Coalescence(enabled="yes"), r"^coalescence='yes' is not a boolean"),
    (lambda: C.Coalescence(every=0), r"^coalescence_every=0 is outside"),
    (lambda: C.Coalescence(triplet_forces="no"), r"^triplet_forces='no' is not a boolean"),
    (lambda: C.Coalescence(triplet_table=3), r"^triplet_table=3 is not a path"),
    (lambda: C.Coalescence(triplet_split="fast"), r"^triplet_split='fast' is not allowed"),
    (lambda: C.Coalescence(enabled=False, triplet_forces=True),
     r"^triplet_forces=True needs coalescence=True"),
    (lambda: C.GravityCorrection("yes"), r"^gravity_correction='yes' is not allowed"),
    (lambda: C.Speed(refresh_every=2.7), r"^refresh_every=2\.7 is not an integer"),
    (lambda: C.Speed(force_tolerance=2.0), r"^force_tolerance=2\.0 is outside"),
    (lambda: C.Speed(skin=-1e-4), r"^skin=-0\.0001 m is outside the allowed range \(0, inf\)"),
    (lambda: C.Speed(ratio_step=0), r"^ratio_step=0(\.0)? is outside"),
])
def test_each_group_checks_its_fields(make, pattern):
    with pytest.raises(CapbridgeInputError, match=pattern) as err:
        make()
    assert "\n" not in str(err.value)


def test_groups_hold_the_checked_values_and_are_frozen():
    s = C.Speed(refresh_every=10.0, force_tolerance=1)
    assert s.refresh_every == 10 and type(s.refresh_every) is int
    assert s.force_tolerance == 1.0 and type(s.force_tolerance) is float
    assert C.Bodies(ids=[3, 1]).ids == (3, 1)
    assert C.Formation(initial_pairs=[[0, 1]]).initial_pairs == ((0, 1),)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.refresh_every = 2
    # the defaults are the flat keywords'
    for g in (C.Formation(), C.Bodies(), C.Coalescence(), C.GravityCorrection(), C.Speed()):
        assert all(C.FLAT_DEFAULTS[k] == v for k, v in g.flat().items())
    assert C.Saturation(0.3, 1e-6).flat()["saturation"] == 0.3


def test_config_checks_across_groups():
    with pytest.raises(CapbridgeInputError, match=r"^initial_pairs: bodies \[5\] are not "
                                                  r"among ids"):
        C.EngineConfig(C.WaterContent(0.01), formation=C.Formation(initial_pairs=[(0, 5)]),
                       bodies=C.Bodies(ids=[0, 1]))
    with pytest.raises(CapbridgeInputError, match=r"^liquid=0\.01 is not allowed: give one "
                                                  r"of BridgeVolume"):
        C.EngineConfig(0.01)
    with pytest.raises(CapbridgeInputError, match=r"^gamma=72\.0 N/m is outside"):
        C.EngineConfig(C.WaterContent(0.01), gamma=72.0)
    with pytest.raises(CapbridgeInputError, match=r"^label='my label' is not allowed"):
        C.EngineConfig(C.WaterContent(0.01), label="my label")


# --------------------------------------------------------------------------------------
# the shim: the 28 flat keywords onto the groups and back
# --------------------------------------------------------------------------------------


FLAT_CASES = [
    dict(water_content=0.01),
    dict(theta={"glass": 20.0, 3: 30.0}, gamma=0.05, bridge_volume=2e-12, sample_volume=1e-6,
         formation_gap=1e-5, initial_wet_gap=2e-5, ids=[0, 1, 2], walls=[7],
         initial_pairs=[(0, 1)], refresh_every=10, force_tolerance=1e-3, skin=1e-4,
         ratio_step=0.02, coalescence=False, coalescence_every=7, label="cap2",
         gravity_correction="off", liquid_density=1100.0),
    dict(saturation=0.3, sample_volume=1e-6, conserve_liquid=False, film_fraction=0.3,
         triplet_split="exact", triplet_table="/some/triplets.nc"),
    dict(bridge_volume_star=0.05, conserve_liquid=None),
    dict(liquid_volume=1e-9, conserve_liquid=True),
]


@pytest.mark.parametrize("flat", FLAT_CASES)
def test_flat_keywords_map_onto_the_groups_and_back(flat):
    cfg = C.EngineConfig.from_flat(**flat)
    back = cfg.flat()
    assert set(back) == set(C.ENGINE_PARAMETERS)
    full = dict(C.FLAT_DEFAULTS, **flat)
    for k, v in full.items():
        want = [list(p) for p in v] if k == "initial_pairs" and v is not None else v
        assert back[k] == want, k
    assert C.EngineConfig.from_flat(**back) == cfg
    # the same configuration from the groups
    groups = {g: getattr(cfg, g) for g in C.GROUPS}
    top = {k: getattr(cfg, k) for k in C.TOP_LEVEL}
    theta, gamma = top.pop("theta"), top.pop("gamma")
    assert C.EngineConfig.build(theta, gamma, **groups, **top) == cfg


def test_flat_keywords_keep_their_messages():
    with pytest.raises(CapbridgeInputError, match=r"^give exactly one of bridge_volume, "
                                                  r"bridge_volume_star, liquid_volume, "
                                                  r"water_content, saturation \(got none\)"):
        C.EngineConfig.from_flat()
    with pytest.raises(CapbridgeInputError, match=r"^conserve_liquid=True needs a total "
                                                  r"liquid"):
        C.EngineConfig.from_flat(bridge_volume=1e-12, conserve_liquid=True)
    with pytest.raises(TypeError, match="refresh"):
        C.EngineConfig.from_flat(water_content=0.01, refresh=3)


def test_mixing_a_group_and_its_flat_keywords_is_refused():
    with pytest.raises(CapbridgeInputError, match=r"^coalescence_every=50 given with "
                                                  r"coalescence=Coalescence\(\.\.\.\)"):
        C.EngineConfig.build(liquid=C.WaterContent(0.01), coalescence=C.Coalescence(),
                             coalescence_every=50)
    with pytest.raises(CapbridgeInputError, match=r"^water_content=0\.02 given with "
                                                  r"liquid=WaterContent"):
        C.EngineConfig.build(liquid=C.WaterContent(0.01), water_content=0.02)
    with pytest.raises(CapbridgeInputError, match=r"^sample_volume=1e-06 given with "
                                                  r"liquid=BridgeVolume"):
        C.EngineConfig.build(liquid=C.BridgeVolume(1e-12), sample_volume=1e-6)
    with pytest.raises(CapbridgeInputError, match=r"^skin=0\.001 given with speed=Speed"):
        C.EngineConfig.build(liquid=C.WaterContent(0.01), speed=C.Speed(), skin=1e-3)
    # the flat keywords of the groups *not* given are fine; coalescence=False is the flat one
    cfg = C.EngineConfig.build(liquid=C.WaterContent(0.01), skin=1e-3, coalescence=False)
    assert cfg.speed.skin == 1e-3 and cfg.coalescence.enabled is False


def test_engine_from_groups_equals_engine_from_flat_keywords():
    """Outside YADE (no scene): the same parameters (what a restart file holds), the same
    values in the engine, whether the groups go to the constructor or to configure; a
    group in a flat keyword's place is refused."""
    from capbridge.yade.engine import CapbridgeEngine

    flat = dict(theta=20.0, gamma=0.073, water_content=0.01, film_fraction=0.4,
                formation_gap=1e-5, initial_wet_gap=5e-5, coalescence_every=50,
                gravity_correction="on", force_tolerance=1e-3, skin=2e-4, label="cfg_a")
    a = CapbridgeEngine(**flat)
    b = CapbridgeEngine.configure(
        theta=20.0, gamma=0.073, liquid=C.WaterContent(0.01, film_fraction=0.4),
        formation=C.Formation(gap=1e-5, initial_wet_gap=5e-5),
        coalescence=C.Coalescence(every=50), gravity=C.GravityCorrection("on"),
        speed=C.Speed(force_tolerance=1e-3, skin=2e-4), label="cfg_b")
    pa, pb = dict(a._params, label=None), dict(b._params, label=None)
    assert pa == pb
    assert list(pa) == list(pb)                      # the same JSON text when saved
    assert a._opts == dict(b._opts, label="cfg_a")
    assert a.config == dataclasses.replace(b.config, label="cfg_a")
    for k in ("gamma", "amount", "liquid_density", "refresh_every", "force_tolerance",
              "coalescence_every", "skin", "holds_forces"):
        assert getattr(a, k) == getattr(b, k), k
    c = CapbridgeEngine(
        theta=20.0, gamma=0.073, liquid=C.WaterContent(0.01, film_fraction=0.4),
        formation=C.Formation(gap=1e-5, initial_wet_gap=5e-5),
        coalescence=C.Coalescence(every=50), gravity=C.GravityCorrection("on"),
        speed=C.Speed(force_tolerance=1e-3, skin=2e-4), label="cfg_c")
    assert dict(c._params, label=None) == pa and list(c._params) == list(pa)
    assert c._opts == dict(b._opts, label="cfg_c")
    assert c.config == dataclasses.replace(b.config, label="cfg_c")
    with pytest.raises(CapbridgeInputError, match=r"^water_content=WaterContent\(\.\.\.\) is "
                                                  r"a keyword group: give it as "
                                                  r"liquid=WaterContent"):
        CapbridgeEngine(water_content=C.WaterContent(0.01), label="cfg_d")


def test_the_constructor_refuses_a_flat_keyword_set_beside_its_group():
    """The constructor's flat keywords have their defaults in its signature: one set to
    another value beside its own group is refused, as by configure; one at its default
    cannot be told from one left out and gives way to the group."""
    from capbridge.yade.engine import CapbridgeEngine

    with pytest.raises(CapbridgeInputError, match=r"^water_content=0\.02 given with "
                                                  r"liquid=WaterContent"):
        CapbridgeEngine(liquid=C.WaterContent(0.01), water_content=0.02, label="mix_a")
    with pytest.raises(CapbridgeInputError, match=r"^coalescence_every=50 given with "
                                                  r"coalescence=Coalescence"):
        CapbridgeEngine(liquid=C.WaterContent(0.01), coalescence=C.Coalescence(),
                        coalescence_every=50, label="mix_b")
    with pytest.raises(CapbridgeInputError, match=r"^refresh_every=1\.0 given with "
                                                  r"speed=Speed"):
        CapbridgeEngine(liquid=C.WaterContent(0.01), speed=C.Speed(), refresh_every=1.0,
                        label="mix_c")
    with pytest.raises(CapbridgeInputError, match=r"^coalescence=None is not a boolean"):
        CapbridgeEngine(liquid=C.WaterContent(0.01), coalescence=None, label="mix_d")
    eng = CapbridgeEngine(liquid=C.WaterContent(0.01), speed=C.Speed(skin=1e-3), skin=None,
                          coalescence=False, label="mix_e")
    assert eng.skin == 1e-3 and eng.config.coalescence.enabled is False


# --------------------------------------------------------------------------------------
# the docs' option table is made from the definitions
# --------------------------------------------------------------------------------------


def test_the_docs_option_table_is_the_rendered_one():
    text = DOCS.read_text(encoding="utf-8")
    table = C.render_option_table()
    assert table in text
    rows = [line for line in text.splitlines() if re.match(r"\| `\w+` \| ", line)
            and line.count(" | ") >= 4]
    assert "\n".join(rows) + "\n" == "\n".join(table.splitlines()[2:]) + "\n"
    assert len(rows) == len(C.ENGINE_PARAMETERS) == 28


# --------------------------------------------------------------------------------------
# real YADE: identical forces
# --------------------------------------------------------------------------------------


@pytest.mark.yade
@pytest.mark.skipif(yr.find_yade() is None, reason="Debian's yade is not installed")
def test_groups_and_flat_keywords_give_identical_forces_in_yade():
    """A small wet pile settles with an engine made from flat keywords and one made from
    groups (fresh YADE processes): the same saved parameters, state, bridges, positions
    and forces, bit for bit."""
    out = {}
    for style in ("flat", "groups"):
        out[style] = yr.run_yade_script(SCENES / "config_equivalence.py",
                                        ["--style", style, "--steps", "600"],
                                        timeout=300).result
    a, b = out["flat"], out["groups"]
    assert a["state"]["n_bridges"] > 0
    for key in ("params", "state", "bridges", "pos", "force"):
        assert a[key] == b[key], key
