"""capbridge's capillary engine in real YADE (Debian's 2023.02a), and the native suction path.

Every test runs a scene of ``tests/yade_scenes`` in a fresh YADE process (one thread)
and checks what YADE applied against capbridge's own lookup:

* two spheres pulled apart slowly (equal, and ratio 2 with theta = 40 deg), with the
  Python engine and with the native fixed-volume path: the force YADE applies equals
  the surrogate's within 0.5 % all along and vanishes past rupture;
* YADE's own ``Law2_ScGeom_CapillaryPhys_Capillarity`` fed with capbridge's export
  (theta = 0 and 30 deg) gives the exact suction solution, and the volume-controlled
  lookup at the bridge's volume, within 0.5 %;
* a few hundred grains settle, are shaken and settle again: no NaN, and the liquid is
  accounted for under both rules;
* the paper's triplet: coalescence reported (state and log line) above, not below, the
  volume the criterion gives;
* the scene of ``docs/guide.md`` runs as printed.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from capbridge.yade import yade_runtime as yr
from capbridge.dem.bridges import default_table_path
from capbridge.status import Status

SCENES = Path(__file__).parent / "yade_scenes"
DOCS = Path(__file__).resolve().parents[1] / "docs" / "guide.md"
REL_TOL = 5e-3
GAMMA = 0.073

pytestmark = pytest.mark.yade


@pytest.fixture(scope="module")
def sur():
    from capbridge.surrogate.doublet import DoubletSurrogate
    return DoubletSurrogate().fit(default_table_path())


def _run(scene, args=(), timeout=240, **kw):
    return yr.run_yade_script(SCENES / scene, [str(a) for a in args], timeout=timeout, **kw)


# --------------------------------------------------------------------------------------
# Two spheres pulled apart
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("backend,r2,theta,vstar,tol", [
    ("python", 1e-3, 0.0, 0.05, 0.0), ("python", 2e-3, 40.0, 0.02, 1e-3),
    ("native", 1e-3, 0.0, 0.05, None), ("native", 2e-3, 40.0, 0.02, None)])
def test_pull_apart_force_is_the_lookup(sur, tmp_path, backend, r2, theta, vstar, tol):
    """The force YADE applies at every step equals capbridge's lookup at the gap of that
    step within 0.5 % (to round-off with the Python engine when forces are not held),
    along the centre line, equal and opposite on the two spheres; none past the
    rupture distance.  ``python``: CapbridgeEngine; ``native``: YADE's compiled Law2 on
    NativeVolumeBridges' fixed-volume files."""
    r1 = 1e-3
    args = ["--r1", r1, "--r2", r2, "--theta", theta, "--vstar", vstar, "--steps", 240,
            "--stretch", 1.25, "--backend", backend]
    args += ["--tolerance", tol] if backend == "python" else ["--dir", tmp_path]
    res = _run("pull_apart_capbridge.py", args).result
    rows = res["rows"]
    axis = np.array(res["axis"])
    ratio = r2 / r1
    gaps = np.array([row["gap"] for row in rows])
    f0 = np.array([row["f0"] for row in rows])
    f1 = np.array([row["f1"] for row in rows])
    look = sur.predict(np.maximum(gaps, 0.0) / r1, vstar, theta, ratio)
    expected = look["force"] * 2 * np.pi * GAMMA * r1
    alive = look["status"] == Status.CONVERGED
    d_r = float(sur.predict(0.0, vstar, theta, ratio)["rupture_gap"]) * r1
    assert res["d_rupt"] == pytest.approx(d_r, rel=1e-12)
    assert alive.sum() > 150 and (~alive).sum() > 20          # both sides of rupture seen
    assert np.all(alive == (gaps <= d_r))
    along = f0 @ axis
    np.testing.assert_allclose(along[alive], expected[alive], rtol=REL_TOL if tol != 0.0 else 1e-9)
    np.testing.assert_allclose(f0, np.outer(along, axis), rtol=0, atol=1e-12 * np.abs(along).max())
    np.testing.assert_allclose(f1, -f0, rtol=1e-12, atol=0)     # equal and opposite
    assert np.all(f0[~alive] == 0.0) and np.all(f1[~alive] == 0.0)
    assert all(row["n_bridges"] == (1 if a else 0) for row, a in zip(rows, alive))
    if backend == "python":
        b = res["state"]["budget"]
        assert (b["initial_count"], b["ruptured_count"], b["balance_error"]) == (1, 1, 0.0)


# --------------------------------------------------------------------------------------
# YADE's own Law2 with capbridge's export (suction-controlled)
# --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def suction_files(tmp_path_factory):
    """capbridge's exact-solver export for equal spheres, theta = 0 and 30 deg (the other
    nine ratio files are bridge-free placeholders: the scene only has ratio 1)."""
    from capbridge.yade import yade_export as ye

    d = tmp_path_factory.mktemp("suction_export")
    suctions = np.array([0.0, 0.5, 1.0, 2.0, 5.0])
    for theta in (0.0, 30.0):
        with pytest.warns(UserWarning, match="placeholder"):
            ye.export_from_solver(d, theta, ratios=(1.0,), suctions=suctions, n_gaps=25,
                                  missing="stub", delaunay=False)
    return d, suctions


@pytest.mark.parametrize("theta", [0.0, 30.0])
def test_native_law2_with_capbridge_export(sur, suction_files, theta):
    """Suction-controlled bridges through YADE's compiled Law2 (built by
    ``engine.suction_law2``) at a tabulated suction, off the gap grid: the force equals
    capbridge's exact suction solution and capbridge's volume-controlled lookup at the
    volume YADE reports, within 0.5 %; nothing past rupture."""
    from capbridge.solvers import young_laplace as yl

    d, suctions = suction_files
    s_star, r = suctions[2], 1e-3
    g_r = float(yl.suction_rupture_distance(-s_star, theta)["gap"])
    gaps = np.array([0.0, 0.15, 0.3, 0.55, 0.7, 1.3]) * g_r
    run = _run("suction_native_capbridge.py", ["--dir", d, "--theta", theta, "--r", r,
                                                "--suction", s_star * GAMMA / r, "--gamma", GAMMA,
                                                "--gaps=" + ",".join(repr(g * r) for g in gaps)])
    rows = run.result["rows"]
    exact = yl.solve_doublet_suction(gaps[:-1], -s_star, theta)
    scale = 2 * np.pi * GAMMA * r
    for row, f, v in zip(rows, exact["force"], exact["volume"]):
        assert row["force"] == pytest.approx(f * scale, rel=REL_TOL)
        assert row["vMeniscus"] == pytest.approx(v * r**3, rel=REL_TOL)
        # the same bridge seen as volume-controlled: capbridge's lookup at YADE's volume
        vol = sur.predict(row["gap"] / r, row["vMeniscus"] / r**3, theta)["force"] * scale
        assert row["force"] == pytest.approx(float(vol), rel=REL_TOL)
    assert rows[-1]["force"] == 0.0 and not rows[-1]["interaction"]


# --------------------------------------------------------------------------------------
# A packing
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("rule", ["conserved", "fixed", "native"])
def test_packing_settles_and_keeps_its_liquid(rule, tmp_path):
    """300 grains fall, settle, are shaken (bridges rupture) and settle again (bridges
    re-form): positions and forces stay finite and the liquid is accounted for: with
    the conserving rule bridges + liquid on grains = the water content's volume, with
    the fixed rule active = initial + formed - ruptured, natively every bridge YADE
    holds has the rule's volume."""
    run = _run("packing_capbridge.py", ["--n", 300, "--rule", rule, "--steps", 5000,
                                         "--dir", tmp_path], timeout=400)
    res = run.result
    assert res["finite"]
    recs = res["records"]
    if rule == "native":
        for rec in recs:
            assert rec["scan"]["max_volume_deviation"] < 1e-9
            assert rec["scan"]["total_volume"] == pytest.approx(rec["scan"]["rule_volume"], rel=1e-9)
        assert recs[-1]["n_bridges"] > res["n"] // 2                       # a wet pile
        assert sum(rec["lost"] for rec in recs) > 0                        # ruptures
        assert sum(rec["reformed"] for rec in recs) > 0                    # re-formations
        return
    for rec in recs:
        b = rec["budget"]
        assert b["balance_error"] < 1e-12
        assert rec["sum_bridge_volumes"] == pytest.approx(b["active_volume"], rel=1e-12)
        assert math.isfinite(rec["max_force"])
    last = recs[-1]["budget"]
    assert last["ruptured_count"] > 0 and last["formed_count"] > 0     # rupture, re-formation
    assert recs[-1]["n_bridges"] > res["n"] // 2                       # a wet, cohesive pile
    if rule == "conserved":
        total = res["water_content"] * res["mass"] / res["liquid_density"]
        assert last["expected"] == pytest.approx(total, rel=1e-12)
        assert last["active_volume"] + last["film_volume"] == pytest.approx(total, rel=1e-12)
    else:
        # every bridge holds V* = vstar of its own smaller radius; ledger identity
        assert last["active_volume"] == pytest.approx(
            last["initial_volume"] + last["formed_volume"] - last["ruptured_volume"], rel=1e-12)


# --------------------------------------------------------------------------------------
# Coalescence
# --------------------------------------------------------------------------------------


def test_triplet_coalescence_is_reported_never_silent():
    """The paper's triplet (two bridges from the top grain): no coalescence a little
    below the volume at which the criterion is met, one merged pair (bottom, top,
    bottom) a little above it, in the engine's state and in a log line; the forces
    stay the doublet forces."""
    cases = [(0.0, 6.2e-9, False), (0.0, 7.0e-9, True), (30.0, 10.0e-9, False),
             (30.0, 10.6e-9, True)]
    run = _run("triplet_capbridge.py", ["--cases=" + ",".join(f"{t}:{v!r}" for t, v, _ in cases)])
    lines = re.findall(r"capbridge 'triplet' iter \d+: (\d+) coalesced bridge pairs .*doublet forces",
                       run.stderr)
    assert lines == ["1", "1"]                       # one log line per merged case
    for (theta, volume, merged), res in zip(cases, run.result["cases"]):
        st = res["state"]["coalescence"]
        assert st["searched"]
        if not merged:
            assert st["triplets"] == 0 and not any("coalesced" in m for m in res["messages"])
            continue
        assert st["triplets"] == 1 and st["clusters"] == 1
        assert st["coalesced_volume"] == pytest.approx(2 * volume, rel=1e-12)
        assert res["triplets"] == [[0, 2, 1]]
        assert any("coalesced" in m for m in res["messages"])
        f = np.array(res["forces"])
        np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-12 * np.abs(f).max())
        assert f[2][2] < 0                       # the top grain is pulled down by both bridges
        # doublet forces: each bridge's force is the table's at its own gap and volume
        assert res["bridges"]["force"][0] == pytest.approx(res["bridges"]["force"][1], rel=1e-12)


# --------------------------------------------------------------------------------------
# The documented scene
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["python", "launcher"])
def test_minimal_scene_of_the_docs_runs_as_printed(mode):
    """The scene printed in docs/guide.md, run with the venv's Python and through
    ``yade -n -x`` (with capbridge and the venv's packages on PYTHONPATH, as the doc
    says)."""
    scene = (SCENES / "minimal_capbridge_scene.py").read_text(encoding="utf-8")
    doc = DOCS.read_text(encoding="utf-8")
    assert scene.strip() in doc, "docs/guide.md must show the tested scene verbatim"
    run = _run("minimal_capbridge_scene.py", require_result=False, mode=mode)
    out = run.stdout
    m = re.search(r"bridges: (\d+) formed: (\d+) ruptured: (\d+)", out)
    assert m and int(m.group(1)) > 50
    m = re.search(r"liquid in bridges \+ on grains: (\S+) of (\S+) m\^3", out)
    assert m and float(m.group(1)) == pytest.approx(float(m.group(2)), rel=1e-12)
