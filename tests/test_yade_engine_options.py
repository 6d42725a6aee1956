"""CapbridgeEngine's keywords are checked when the engine is made (issue 16, item 4).

Every keyword of the constructor: type, range and which go together, one line naming
the keyword and what is allowed (``CapbridgeInputError``), before any step.  Most checks
are pure (:mod:`capbridge.yade.engine_options`) and run here without YADE; two
YADE scenes (``tests/yade_scenes/options_capbridge.py``, ``erase_capbridge.py``) check
that a bad keyword stops a real scene at construction, before ``O.run``, and that an
engine whose wet grains were all erased idles (no force, ledger exact, save/load) and
goes on when grains meet again.
"""
from __future__ import annotations

import inspect
import math
import re
from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr
from capbridge.validation import CapbridgeInputError, interval_text

SCENES = Path(__file__).parent / "yade_scenes"
DOCS = Path(__file__).resolve().parents[1] / "docs" / "yade_plugin.md"

#: a valid liquid amount for the cases that test another keyword
OK = {"theta": 20.0, "water_content": 0.01}


def _engine(**kw):
    from capbridge.yade.engine import CapbridgeEngine

    args = dict(OK)
    if any(k in kw for k in ("bridge_volume", "bridge_volume_star", "liquid_volume",
                             "saturation")):
        args.pop("water_content")
    args.update(kw)
    return CapbridgeEngine(**args)


def _refused(kw, *needles):
    """The engine refuses ``kw`` with one line holding every needle."""
    with pytest.raises(CapbridgeInputError) as exc:
        _engine(**kw)
    msg = str(exc.value)
    assert "\n" not in msg, msg
    for n in needles:
        assert n in msg, (kw, msg)
    return msg


# --------------------------------------------------------------------------------------
# booleans, integers, gaps
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name,value", [
    ("triplet_forces", "no"), ("triplet_forces", "True"), ("triplet_forces", 0),
    ("coalescence", "False"), ("coalescence", 1), ("coalescence", None),
    ("conserve_liquid", "yes"), ("conserve_liquid", 1.0)])
def test_booleans_must_be_booleans(name, value):
    """``triplet_forces="no"`` was True (``bool("no")``): strings, numbers and None
    are refused, naming the keyword."""
    _refused({name: value}, f"{name}={value!r}", "is not a boolean", "True or False")


def test_numpy_booleans_are_booleans():
    eng = _engine(coalescence=np.bool_(False), triplet_forces=np.False_,
                  walls=np.True_, label="np_bools")
    assert eng.coalescence is False and eng.triplet_forces is False
    assert eng.walls_requested is True


def test_integer_options_are_integers_in_range():
    """``refresh_every=2.7`` was 2, ``coalescence_every=0`` or ``-5`` was 1; integral
    floats (``10.0``) are taken as integers, as ``capbridge.validation.check_int``
    takes them everywhere in capbridge."""
    for name, value, needle in [
            ("refresh_every", 2.7, "is not an integer"), ("refresh_every", "10", "is not an integer"),
            ("refresh_every", True, "is not an integer"), ("refresh_every", 0, "[1, inf)"),
            ("coalescence_every", 0, "[1, inf)"), ("coalescence_every", -5, "[1, inf)"),
            ("coalescence_every", 99.5, "is not an integer"),
            ("coalescence_every", None, "is not an integer")]:
        _refused({name: value}, f"{name}=", needle, "give an integer >= 1")
    eng = _engine(refresh_every=10.0, coalescence_every=np.int64(7), label="int_floats")
    assert (eng.refresh_every, eng.coalescence_every) == (10, 7)
    assert type(eng.refresh_every) is int and type(eng.coalescence_every) is int


@pytest.mark.parametrize("name,value,allowed", [
    ("formation_gap", -1e-6, "[0, inf)"), ("formation_gap", math.nan, "[0, inf)"),
    ("formation_gap", "0", "[0, inf)"), ("initial_wet_gap", -1e-6, "[0, inf)"),
    ("initial_wet_gap", math.inf, "[0, inf)"),
    ("skin", -1e-4, "(0, inf)"), ("skin", math.nan, "(0, inf)"), ("skin", 0.0, "(0, inf)"),
    ("ratio_step", -0.01, "(0, inf)"), ("ratio_step", math.nan, "(0, inf)"),
    ("ratio_step", 0, "(0, inf)"),
    ("film_fraction", 0.0, "(0, 1]"), ("film_fraction", 1.5, "(0, 1]"),
    ("film_fraction", math.nan, "(0, 1]"),
    ("force_tolerance", -1e-3, "[0, 1]"), ("force_tolerance", math.nan, "[0, 1]"),
    ("force_tolerance", 2.0, "[0, 1]")])
def test_lengths_and_fractions_in_range(name, value, allowed):
    """Negative or NaN ``formation_gap``, ``skin``, ``ratio_step`` (and the other
    lengths and fractions) are refused with the allowed interval."""
    _refused({name: value}, f"{name}=", allowed)


# --------------------------------------------------------------------------------------
# surface tension, angles, walls, label, gravity
# --------------------------------------------------------------------------------------


def test_gamma_has_the_plausible_range_of_predict_si(doublet_table):
    """``gamma=72`` (mN/m typed as N/m) is refused like ``predict_si`` refuses it: the
    same constant, the same interval."""
    from capbridge.surrogate.doublet import SI_SURFACE_TENSION_RANGE, DoubletSurrogate

    lo, hi = SI_SURFACE_TENSION_RANGE
    allowed = interval_text(lo, hi)
    msg = _refused({"gamma": 72.0}, "gamma=72.0", allowed, "unit slip")
    assert "N/m" in msg
    for bad in (lo * 0.99, hi * 1.01, math.nan, -0.073, "0.073", None):
        _refused({"gamma": bad}, "gamma=")
    for good in (lo, hi, 0.073):
        assert _engine(gamma=good, label="gamma_ok").gamma == good
    # predict_si refuses the same slip, with the same interval
    sur = DoubletSurrogate().fit(doublet_table)
    with pytest.raises(CapbridgeInputError, match=re.escape(allowed)):
        sur.predict_si(1e-3, 1e-3, 72.0, 0.0, 1e-12, 20.0)


@pytest.mark.parametrize("theta,needles", [
    (math.nan, ("theta=nan", "[0, 90)")), (math.inf, ("theta=inf",)), (-5.0, ("theta=-5.0",)),
    (85.0, ("theta=85.0", "[0, 80]", "table")), ("20", ("theta='20'", "not a number")),
    ([20, 30], ("not a number",)), ({}, ("theta={}",)),
    ({"glass": math.nan}, ("theta['glass']=nan", "[0, 90]")),
    ({"glass": 95.0}, ("theta['glass']=95.0", "[0, 90]")),
    ({True: 20.0}, ("key True", "material label")), ({2.5: 20.0}, ("key 2.5",))])
def test_contact_angles(theta, needles):
    """``theta=nan`` ended in "index -9223372036854775808 out of bounds"; every angle
    is checked when the engine is made (a single angle against the table's)."""
    _refused({"theta": theta}, *needles)


@pytest.mark.parametrize("walls,needles", [
    ("all", ("walls='all'", "True", "False", "list of body ids")), (None, ("walls=None",)),
    (3, ("walls=3",)), ([1.5], ("walls[0]=1.5", "not an integer")),
    ([4, 4], ("given more than once",)), ([-1], ("walls[0]=-1", "[0, inf)"))])
def test_walls(walls, needles):
    """``walls="all"`` ended in ``int('a')`` at the first step."""
    _refused({"walls": walls}, *needles)


@pytest.mark.parametrize("label", [None, "my engine", "class", 3, "", "2cap"])
def test_label_is_a_python_name(label):
    """``label=None`` ended in a SyntaxError from YADE at the first step (YADE makes
    the label a Python name)."""
    _refused({"label": label}, f"label={label!r}", "Python identifier")


def test_gravity_vector_is_finite():
    """A NaN gravity vector ended in "index ... out of bounds"; the engine checks the
    NewtonIntegrator's gravity at its first step and whenever it changes."""
    from capbridge.yade.engine_options import check_gravity

    for bad in ((0.0, 0.0, math.nan), (math.inf, 0.0, -9.81)):
        with pytest.raises(CapbridgeInputError, match=r"NewtonIntegrator\.gravity=.*finite"):
            check_gravity(bad)
    np.testing.assert_array_equal(check_gravity((0, 0, -9.81)), [0.0, 0.0, -9.81])


def test_choices():
    _refused({"gravity_correction": True}, "gravity_correction=True", "'auto'", "'off'")
    _refused({"gravity_correction": "maybe"}, "gravity_correction='maybe'")
    _refused({"triplet_split": "fast"}, "triplet_split='fast'", "'merge_volumes'")
    _refused({"triplet_split": None}, "triplet_split=None")


# --------------------------------------------------------------------------------------
# liquid amounts, tables, ids
# --------------------------------------------------------------------------------------


def test_liquid_amounts():
    """Exactly one liquid amount (a CapbridgeInputError now, it was a plain
    ValueError), each positive and finite, a saturation in (0, 1] with its sample
    volume, V* in the table's range (it was an error at the first step);
    conserve_liquid=True only with a total liquid."""
    for kw, needles in [
            ({"water_content": None}, ("give exactly one of", "got none")),
            ({"liquid_volume": 1e-9, "water_content": 0.01},
             ("give exactly one of", "liquid_volume, water_content")),
            ({"bridge_volume": 1e-10, "bridge_volume_star": 0.05},
             ("give exactly one of", "bridge_volume, bridge_volume_star")),
            ({"water_content": -0.01}, ("water_content=-0.01", "(0, inf)")),
            ({"water_content": math.nan}, ("water_content=nan",)),
            ({"water_content": "0.01"}, ("water_content='0.01'", "not a number")),
            ({"saturation": 1.5, "sample_volume": 1e-6}, ("saturation=1.5", "(0, 1]")),
            ({"saturation": 0.5}, ("saturation needs sample_volume",)),
            ({"saturation": 0.5, "sample_volume": -1.0}, ("sample_volume=-1.0",)),
            ({"liquid_volume": 0.0}, ("liquid_volume=0.0", "(0, inf)")),
            ({"bridge_volume": -1e-10}, ("bridge_volume=-1e-10",)),
            ({"bridge_volume": True}, ("bridge_volume=True", "not a number")),
            ({"bridge_volume_star": 0.9}, ("bridge_volume_star=0.9", "[0.001, 0.5]")),
            ({"bridge_volume_star": 1e-4}, ("bridge_volume_star=0.0001", "[0.001, 0.5]")),
            ({"bridge_volume": 1e-10, "conserve_liquid": True},
             ("conserve_liquid=True needs a total liquid", "not bridge_volume"))]:
        _refused(kw, *needles)


def test_tables_are_read_at_construction(tmp_path):
    """A missing or damaged doublet table was a traceback from the PyRunner at the
    first step; a table of the wrong type too."""
    from capbridge.surrogate.doublet import DoubletSurrogate

    _refused({"table": "/nonexistent/doublet.nc"}, "table='/nonexistent/doublet.nc'",
             "does not exist")
    bad = tmp_path / "doublet.nc"
    bad.write_text("not a table")
    _refused({"table": bad}, f"table='{bad}'", "cannot be used")
    _refused({"table": 3}, "table: a int is not a doublet table")
    _refused({"table": DoubletSurrogate()}, "not fitted")
    _refused({"triplet_table": 5}, "triplet_table=5", "not a path")
    _refused({"triplet_forces": True, "triplet_table": tmp_path / "none.nc"},
             "triplet_forces=True but", "does not exist")


@pytest.mark.parametrize("kw,needles", [
    ({"ids": "0123"}, ("ids='0123'", "not a list of body ids")),
    ({"ids": []}, ("ids=[] gives no body",)),
    ({"ids": [1, 1]}, ("ids: body ids [1] are given more than once",)),
    ({"ids": [0, 2.5]}, ("ids[1]=2.5", "not an integer")),
    ({"ids": [-1]}, ("ids[0]=-1",)),
    ({"initial_pairs": [(0, 0)]}, ("initial_pairs[0]=(0, 0)", "two different bodies")),
    ({"initial_pairs": [(0, 1), (1, 0)]}, ("initial_pairs[1]=(1, 0)", "more than once")),
    ({"initial_pairs": [(0, 1, 2)]}, ("initial_pairs[0]=(0, 1, 2)", "pair of two")),
    ({"initial_pairs": [(0, 1.5)]}, ("initial_pairs[0]=1.5", "not an integer")),
    ({"initial_pairs": "01"}, ("initial_pairs='01'",)),
    ({"ids": [0, 1], "initial_pairs": [(0, 2)]}, ("bodies [2] are not among ids",)),
    ({"ids": [0, 1], "walls": [1]}, ("walls: bodies [1] are also in ids",))])
def test_ids_and_pairs(kw, needles):
    """Ids are distinct integers (``ids="0123"`` was read as [0, 1, 2, 3], 2.5 as 2)."""
    _refused(kw, *needles)


# --------------------------------------------------------------------------------------
# the scene known at construction (pure: the engine gathers these from YADE)
# --------------------------------------------------------------------------------------


def _glass(n=4, r=1e-3, first=0, label="glass"):
    m = 2600.0 * 4.0 / 3.0 * math.pi * r**3
    return [(first + k, r, m, label, 0) for k in range(n)]


@pytest.fixture(scope="module")
def sur():
    from capbridge.dem.bridges import default_table_path
    from capbridge.surrogate.doublet import DoubletSurrogate

    return DoubletSurrogate().fit(default_table_path())


def _scene_refuses(sur, kw, spheres, walls=(), complete=False, needles=()):
    from capbridge.yade.engine_options import check_options, check_scene

    args = dict(OK)
    if any(k in kw for k in ("bridge_volume", "bridge_volume_star", "liquid_volume",
                             "saturation")):
        args.pop("water_content")
    args.update(kw)
    opts = check_options(**args)
    with pytest.raises(CapbridgeInputError) as exc:
        check_scene(opts, sur, spheres, walls, complete=complete)
    msg = str(exc.value)
    assert "\n" not in msg
    for n in needles:
        assert n in msg, msg


def test_scene_checks_at_construction(sur):
    """What was an error at the first step is one at construction when the scene
    already holds the grains: angles per material, radius ratios, bridge volume
    against the table's V*, liquid the pores cannot hold, wall partners."""
    from capbridge.yade.engine_options import check_options, check_scene

    glass = _glass()
    _scene_refuses(sur, {"theta": {"sand": 20.0}}, glass,
                   needles=("theta: no contact angle for body 0's material", "'glass'"))
    _scene_refuses(sur, {"theta": {"glass": 85.0}}, glass,
                   needles=("85", "[0, 80]", "body 0"))
    _scene_refuses(sur, {}, glass + [(9, 2e-2, 1.0, "glass", 0)],
                   needles=("radius ratios up to 20", "[1, 10]"))
    _scene_refuses(sur, {"bridge_volume": 1e-6}, glass,
                   needles=("bridge_volume=1e-06", "V* = V/r^3 from 1000"))
    _scene_refuses(sur, {"water_content": 1.0}, glass,
                   needles=("water_content=1.0", "allowed (0, 0.385]"))
    _scene_refuses(sur, {"liquid_volume": 1e-6}, glass, complete=True,
                   needles=("liquid_volume=1e-06",))
    _scene_refuses(sur, {"saturation": 0.5, "sample_volume": 1e-9}, glass,
                   needles=("sample_volume 1e-09 m^3 is not larger than the grains' volume",))
    _scene_refuses(sur, {"walls": True}, glass, walls=[(5, "Sphere", "steel", 1)],
                   needles=("walls: body 5 is a Sphere",))
    _scene_refuses(sur, {"theta": {"glass": 20.0}, "walls": True}, glass,
                   walls=[(5, "Wall", "steel", 1)],
                   needles=("no contact angle for wall body 5's material", "'steel'"))
    # valid scenes pass; an extensive amount is left to the first step unless the
    # wet spheres are all known (more may be added before the run)
    opts = check_options(theta={"glass": 20.0, "steel": 90.0}, liquid_volume=1e-6,
                         walls=True)
    check_scene(opts, sur, glass, [(5, "Wall", "steel", 1)], complete=False)
    check_scene(check_options(**OK), sur, glass)
    check_scene(check_options(**OK), sur, [])


# --------------------------------------------------------------------------------------
# nothing wet: the numpy core idles
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("rule", [{"total_liquid": 2e-10}, {"bridge_volume_star": 0.05}])
def test_a_model_without_grains_idles(sur, rule):
    """Every wet grain erased: the model's update, forces and ledger work on zero
    grains (it raised "zero-size array to reduction operation"), and a model of zero
    grains can be made again from its saved state (restart)."""
    from capbridge.dem.bridges import BridgeModel, LiquidRule

    n = 6
    pos = np.column_stack([np.arange(n) * 2e-3 * (1 - 1e-4), np.zeros(n), np.zeros(n)])
    m = BridgeModel(np.full(n, 1e-3), 20.0, sur, 0.073, LiquidRule(**rule))
    m.update(pos)
    assert m.n_bridges == n - 1
    m.drop_grains(np.ones(n, bool))
    for _ in range(3):
        g = m.update(np.empty((0, 3)))
        f, changed = m.grain_forces(g, 1e-3)
        assert f.shape == (0, 3) and f.dtype == float and changed.size == 0
    assert m.held_grain_forces().shape == (0, 3)
    b = m.budget()
    assert (m.n, b["active_count"], b["removed_grains"]) == (0, 0, n)
    assert b["balance_error"] < 1e-12
    if "total_liquid" in rule:
        assert b["removed_volume"] == pytest.approx(2e-10, rel=1e-12)
    st = m.get_state()
    again = BridgeModel(np.empty(0), np.empty(0), sur, 0.073, LiquidRule(**st["liquid"]))
    again.set_state(st)
    again.update(np.empty((0, 3)))
    assert again.budget() == m.budget()


# --------------------------------------------------------------------------------------
# every keyword: a rule, the same defaults, a row in the docs
# --------------------------------------------------------------------------------------


def test_every_keyword_has_its_rule_and_its_row_in_the_docs():
    """The constructor's keywords, ENGINE_PARAMETERS, check_options and OPTION_RULES
    name the same keywords with the same defaults; the docs' table shows each rule.
    Beside the 28 flat keywords the constructor takes the keyword groups (keyword-only,
    default None; ``coalescence`` is both the flat keyword and the group's slot)."""
    from capbridge.yade.engine import ENGINE_PARAMETERS, CapbridgeEngine
    from capbridge.yade.engine_options import OPTION_RULES, check_options

    ctor = {k: p.default for k, p in inspect.signature(CapbridgeEngine).parameters.items()}
    groups = {k: ctor.pop(k) for k in ("liquid", "formation", "bodies", "gravity", "speed")}
    assert groups == dict.fromkeys(groups)
    assert all(inspect.signature(CapbridgeEngine).parameters[k].kind
               is inspect.Parameter.KEYWORD_ONLY for k in groups)
    pure = {k: p.default for k, p in inspect.signature(check_options).parameters.items()}
    assert ctor == pure
    assert set(ctor) == set(ENGINE_PARAMETERS) == set(OPTION_RULES) and len(ctor) == 28
    assert all(ENGINE_PARAMETERS[k][0] == d for k, d in ctor.items())
    rows = {}
    for line in DOCS.read_text(encoding="utf-8").splitlines():
        m = re.match(r"\| `(\w+)` \| (.*?) \| (.*) \| (.*) \|$", line)
        if m and m.group(1) in ctor:
            rows[m.group(1)] = m.group(4)
    assert rows == OPTION_RULES


# --------------------------------------------------------------------------------------
# real YADE
# --------------------------------------------------------------------------------------


#: case -> (stage, pattern) of tests/yade_scenes/options_capbridge.py
YADE_CASES = {
    "label_none": ("construct", r"^label=None is not allowed"),
    "walls_all": ("construct", r"^walls='all' is not allowed"),
    "theta_nan": ("construct", r"^theta=nan deg is outside the allowed range \[0, 90\)"),
    "theta_85": ("construct", r"^theta=85\.0 deg is outside the allowed range \[0, 80\]"),
    "gamma_72": ("construct", r"^gamma=72\.0 N/m is outside the allowed range \[0\.001, 2\]"),
    "triplet_forces_no": ("construct", r"^triplet_forces='no' is not a boolean"),
    "refresh_2_7": ("construct", r"^refresh_every=2\.7 is not an integer"),
    "coalescence_every_0": ("construct", r"^coalescence_every=0 is outside"),
    "skin_negative": ("construct", r"^skin=-0\.0001 m is outside the allowed range \(0, inf\)"),
    "table_missing": ("construct", r"^table='/nonexistent/doublet\.nc' cannot be used"),
    "water_content_1": ("construct", r"^water_content=1\.0 gives 2\.6 m\^3 .*allowed \(0, 0\.385\]"),
    "theta_no_material": ("construct", r"^theta: no contact angle for body 0's material "
                                       r"\(label 'glass'"),
    "theta_glass_85": ("construct", r"^theta: the contact angle 85 deg of body 0's material"),
    "bridge_volume_large": ("construct", r"^bridge_volume=1e-06 m\^3 gives V\* = V/r\^3 from"),
    "ratio_20": ("construct", r"^the wet spheres' radii \[0\.001, 0\.02\] m give radius "
                              r"ratios up to 20"),
    "wall_no_material": ("construct", r"^theta: no contact angle for wall body 4's material "
                                      r"\(label 'steel'"),
    "walls_sphere": ("construct", r"^walls: body 0 is a Sphere"),
    "ids_wall": ("construct", r"^ids: body 4 is a Wall, not a sphere"),
    "liquid_volume_large": ("construct", r"^liquid_volume=1e-06 m\^3 is more than the pores"),
    "sample_volume_small": ("construct", r"^sample_volume 1e-09 m\^3 is not larger"),
    "gravity_nan": ("run", r"NewtonIntegrator\.gravity=\(0\.0, 0\.0, nan\) is not a vector "
                           r"of three finite numbers"),
    "valid": ("ran", None),
}


@pytest.mark.yade
def test_bad_keywords_stop_a_real_scene_at_construction():
    """In real YADE, each bad keyword (one fresh scene each, one process) raises
    CapbridgeInputError from the constructor, before O.run (O.iter 0, no PyRunner
    error), with its one line; what only the run knows (a NaN gravity) stops the
    first step with its line; the valid scene runs."""
    res = yr.run_yade_script(SCENES / "options_capbridge.py", ["--case", "all"],
                             timeout=400).result
    assert set(res) == set(YADE_CASES)
    for case, (stage, pattern) in YADE_CASES.items():
        got = res[case]
        assert got["stage"] == stage, (case, got)
        if stage == "construct":
            assert got["type"] == "CapbridgeInputError" and got["iter"] == 0, (case, got)
            assert "\n" not in got["message"], (case, got["message"])
        if pattern:
            assert re.search(pattern, got["message"]), (case, got["message"][:500])
    assert res["valid"]["n_bridges"] > 0 and res["valid"]["iter"] == 3


@pytest.mark.yade
def test_erasing_every_wet_grain_idles_and_resumes():
    """Every wet sphere erased (a wet row touching a wall, forces held): the engine
    goes on without error, applies nothing (the wall's permanent force is the user's
    again), its ledger is exact (all the liquid left with the grains), and it survives
    O.saveTmp/O.loadTmp.  Every bridged sphere erased while dry ones remain: it idles
    with no bridge, then bridges the dry spheres when they meet."""
    res = yr.run_yade_script(SCENES / "erase_capbridge.py", ["--case", "both"],
                             timeout=400).result
    a = res["all"]
    assert a["error"] is None, a["error"]
    b0, b1, b2 = a["before"], a["after"], a["reloaded"]
    assert b0["n_bridges"] > 0 and b0["walls"]["n_bridges"] > 0
    assert abs(a["wall_perm_before"][2] - a["user_perm"]) > 1e-6     # ours was held there
    for s in (b1, b2):
        assert (s["n_spheres"], s["n_bridges"], s["erased_spheres"]) == (0, 0, 4)
        assert s["walls"]["n_bridges"] == 0 and s["total_force"] == 0.0
        led = s["budget"]
        assert led["removed_grains"] == 4 and led["balance_error"] < 1e-12
        assert led["active_volume"] == 0.0 and led["film_volume"] == 0.0
        assert led["removed_volume"] == pytest.approx(led["total_liquid"], rel=1e-12)
    assert b1["timings"]["steps"] > b0["timings"]["steps"]            # it ran, idle
    np.testing.assert_allclose(a["wall_perm_after"], [0.0, 0.0, a["user_perm"]], rtol=0,
                               atol=1e-12 * a["user_perm"])
    assert a["iter_after"] == a["iter_before"] + 6
    assert any("4 wet spheres erased" in m for m in a["messages"])

    r = res["resume"]
    assert r["error"] is None, r["error"]
    assert r["before"]["n_bridges"] == 3
    idle, met = r["idle"], r["met"]
    assert (idle["n_spheres"], idle["n_bridges"]) == (2, 0)
    assert idle["budget"]["balance_error"] < 1e-12
    assert met["n_bridges"] == 1 and met["events"]["formed"] == idle["events"]["formed"] + 1
    assert met["budget"]["balance_error"] < 1e-12
    # what YADE applied to the two grains (no contact between them): the new bridge's
    # attraction, equal and opposite
    f = np.array(r["forces"])
    assert r["bridge_force"] > 0
    np.testing.assert_allclose(f[0], r["bridge_force"] * np.array(r["axis"]), rtol=1e-12,
                               atol=1e-15 * r["bridge_force"])
    np.testing.assert_allclose(f[1], -f[0], rtol=0, atol=1e-15 * r["bridge_force"])
