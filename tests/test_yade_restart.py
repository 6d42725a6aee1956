"""CapbridgeEngine fit for real runs (issue 9), in real YADE (Debian's 2023.02a).

* restarts: after ``O.saveTmp``/``O.loadTmp`` and after ``O.save`` -> a new process ->
  ``O.load`` (no engine created there: the PyRunner re-creates it from the scene) the
  forces YADE applies in the next steps, with bridges rupturing and forming, equal the
  forces of the uninterrupted run to 1e-9 of the largest; both force modes; an engine
  made from flat keywords or from keyword groups;
* the engine adds to a user's permanent force, never replaces it;
* misuse gives one clear error: PyRunner after NewtonIntegrator, two engines of one
  label, a water content of 1.0 (100 %), spheres added while running; an erased wet
  sphere leaves with its liquid and the ledger stays exact.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr

SCENES = Path(__file__).parent / "yade_scenes"
pytestmark = pytest.mark.yade
PERM = 2e-4


def _run(scene, args=(), timeout=240, **kw):
    return yr.run_yade_script(SCENES / scene, [str(a) for a in args], timeout=timeout, **kw)


def _same_forces(before, after):
    assert [r["iter"] for r in before] == [r["iter"] for r in after]
    fb = np.array([r["f"] for r in before])
    fa = np.array([r["f"] for r in after])
    scale = np.abs(fb).max()
    assert scale > 0
    np.testing.assert_allclose(fa, fb, rtol=0, atol=1e-9 * scale)
    # the window is not trivial: bridges form (or rupture) in it, so a state that was
    # not restored would give other forces
    ev0, ev1 = before[0]["events"], before[-1]["events"]
    assert ev1["formed"] + ev1["ruptured"] > ev0["formed"] + ev0["ruptured"]
    assert [r["n_bridges"] for r in after] == [r["n_bridges"] for r in before]
    assert [r["events"] for r in after] == [r["events"] for r in before]
    for r in after:
        assert r["budget_error"] < 1e-12


def _user_perm_kept(rows, tolerance):
    for r in rows:
        ours = np.array(r["ours"]) if tolerance > 0 else np.zeros(3)
        np.testing.assert_allclose(np.array(r["perm"]) - ours, [0.0, 0.0, PERM],
                                   rtol=0, atol=1e-12 * max(1.0, np.abs(ours).max() / PERM) * PERM)


@pytest.mark.parametrize("tolerance", [0.0, 1e-3])
def test_forces_survive_save_tmp_load_tmp(tolerance):
    """O.saveTmp, 40 steps, O.loadTmp, the same 40 steps: equal forces (to 1e-9 of
    the largest), bridges, events and ledger; the user's permanent force is kept (with
    held forces: permanent force = the user's + the engine's)."""
    res = _run("restart_capbridge.py", ["--mode", "tmp", "--tolerance", tolerance]).result
    assert res["n_bridges_at_save"] > 20
    _same_forces(res["before"], res["after"])
    _user_perm_kept(res["before"] + res["after"], tolerance)
    assert any("state restored" in m for m in res["messages"])
    assert res["extra_after_load"] == 11        # a registered state part came back too


def test_forces_survive_save_and_load_in_a_new_process(tmp_path):
    """O.save in one process, O.load in a fresh one that never creates the engine:
    the next 40 steps give the forces of the run that went on after the save."""
    f = tmp_path / "pile.yade.gz"
    ref = _run("restart_capbridge.py", ["--mode", "save", "--file", f]).result
    new = _run("restart_capbridge.py", ["--mode", "load", "--file", f]).result
    _same_forces(ref["before"], new["rows"])
    _user_perm_kept(new["rows"], 0.0)
    # liquid on films feeds the contacts made after the start: bridges and films both
    # hold liquid, and together the water content's volume
    lq = new["rows"][-1]["liquid"]
    assert lq["bridges"] > 0 and lq["films"] > 0
    assert lq["total"] == pytest.approx(ref["state"]["budget"]["expected"], rel=1e-12)
    assert ref["state"]["budget"]["formed_count"] > 0         # bridges made after step 1
    assert any("state restored" in m for m in new["messages"])


def test_engine_made_from_groups_survives_save_and_load_in_a_new_process(tmp_path):
    """An engine made from keyword groups (``liquid=WaterContent(0.01)``,
    ``speed=Speed(...)``) saves the flat keywords: a new process that never creates the
    engine re-creates it from them, and the next 40 steps give the forces of the run
    that went on after the save."""
    f = tmp_path / "pile_groups.yade.gz"
    ref = _run("restart_capbridge.py", ["--mode", "save", "--file", f,
                                        "--style", "groups"]).result
    new = _run("restart_capbridge.py", ["--mode", "load", "--file", f]).result
    _same_forces(ref["before"], new["rows"])
    _user_perm_kept(new["rows"], 0.0)
    assert any("state restored" in m for m in new["messages"])


MISUSE = {
    "after_newton": r"position 4 of O.engines .*must be after ForceResetter and before "
                    r"NewtonIntegrator",
    "duplicate_label": r"2 PyRunners labelled 'capbridge' in O.engines",
    "duplicate_label_running": r"label 'capbridge' is taken by another CapbridgeEngine",
    "water_content": r"water_content=1.0 gives 2.6 m\^3 of liquid per m\^3 of grains.*"
                     r"allowed \(0, 0.385\]",
    "added": r"1 spheres were added after capbridge engine 'capbridge' started \(ids \[8\]\)",
}


def test_misuse_is_a_clear_error():
    """Each misuse (one fresh scene each, in one YADE process) stops with its line."""
    import re

    res = _run("misuse_capbridge.py", ["--case", "errors"]).result
    assert set(res) == set(MISUSE)
    for case, pattern in MISUSE.items():
        err = res[case]["error"]
        assert err is not None, case
        assert re.search(pattern, err["message"]), (case, err["message"][:400])


def test_erased_wet_sphere_leaves_with_its_liquid():
    """A wet sphere in the middle of a wet row is erased: its two bridges rupture, the
    liquid it carried leaves with it (ledger), the rest goes on, budget exact."""
    res = _run("misuse_capbridge.py", ["--case", "erased"]).result
    assert res["error"] is None
    b0, b1 = res["before"], res["after"]
    assert (b0["n_spheres"], b0["n_bridges"]) == (8, 7)
    assert (b1["n_spheres"], b1["n_bridges"], b1["erased_spheres"]) == (7, 5, 1)
    led = b1["budget"]
    assert led["removed_grains"] == 1 and led["ruptured_count"] == 2
    assert led["removed_volume"] > 0 and led["balance_error"] < 1e-12
    total = b0["budget"]["expected"]
    assert led["active_volume"] + led["film_volume"] + led["removed_volume"] == pytest.approx(
        total, rel=1e-12)
    assert any("wet spheres erased" in m for m in res["messages"])
