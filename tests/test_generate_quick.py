"""`capbridge generate triplet --quick` and `generate coalescence --quick` end to end
through the command line (issue 16): every phase runs, the table is usable by `info`,
`lookup triplet` and `TripletSurrogate().fit`, and a sweep killed with SIGKILL resumes
from its checkpoints (finished chunks reused, not recomputed) to the table of an
uninterrupted run.

Cost: about 6 CPU minutes in all (measured on a shared 2-core machine); the triplet
test reuses the reference run's finished phases (see its docstring).
"""
from __future__ import annotations

import logging
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from capbridge.cli import main
from capbridge.tables.netcdf_io import read_table, write_table
from capbridge.tables.triplet_gravity import HOLDOUT_CASES, GravityPlan
from capbridge.tables.triplet import TripletGrid
from capbridge.status import HAS_RESULT, Status

ROOT = Path(__file__).resolve().parent.parent
#: per command (Evolver runs are slower on a loaded machine; the quick plan takes
#: about 2 CPU minutes)
TIMEOUT = 1500

#: variables that differ between two runs of the same command: measured CPU times
TIMINGS = ("cpu_time", "gravity_cpu_time")


# ------------------------------------------------------------------------- cheap checks

def test_quick_and_shipped_gravity_holdout_cases_lie_inside_their_grids():
    """The quick plan's held-out gravity case was at gap 0.175, outside the quick grid
    (0.05-0.15): the fit after the whole sweep failed on a gap the user never gave."""
    for quick in (True, False):
        grid, plan = TripletGrid.shipped(quick), GravityPlan.shipped(quick)
        for gaps, theta, v, _, _ in plan.cases:
            for x, axis in ((max(gaps), grid.gaps), (min(gaps), grid.gaps),
                            (theta, grid.theta), (v, grid.v)):
                assert min(axis) <= x <= max(axis), (quick, gaps, theta, v)
        inside, outside = plan.cases_inside(grid)
        assert inside and not outside, quick
    assert GravityPlan.shipped(False).cases == HOLDOUT_CASES


@pytest.mark.slow
def test_gravity_holdout_cases_outside_the_grid_are_skipped_and_counted(caplog):
    from capbridge.tables.triplet import _gravity_holdout_dataset, table_axes

    grid = TripletGrid.shipped(True)
    outside = HOLDOUT_CASES[1]                             # gaps 0.175, 0.175, 0.075
    inside = ((0.1, 0.12, 0.05), 20.0, 1.2, "oblique", (0.0, 0.6, -0.8))
    plan = GravityPlan(holdout_cases=(outside, inside), holdout_bonds=(0.0, 0.5))
    seen = {}

    def phase(name, fn, inputs, chunk_size, settings):    # no Evolver: a stand-in
        seen.update(inputs)
        n = len(inputs["d12"])
        out = {f"force_{g}{c}": np.full(n, 0.1) for g in (1, 2, 3) for c in "xyz"}
        return out | {"status": np.zeros(n, np.int8), "cpu_time": np.ones(n)}

    with caplog.at_level(logging.WARNING, logger="capbridge"):
        ds = _gravity_holdout_dataset(grid, plan, phase)
    assert ds.attrs["gravity_holdout_cases_skipped"] == 1
    assert ds.sizes["gravity_holdout"] == 2               # the inside case, two Bo
    np.testing.assert_array_equal(seen["d12"], [0.1, 0.1])
    assert "1 of 2 gravity held-out cases lie outside" in caplog.text
    assert "0.175" in caplog.text
    axes = table_axes(grid, 0, plan)
    assert len(axes["gravity_holdout"]) == 2 and "holdout" not in axes
    none = _gravity_holdout_dataset(grid, GravityPlan(holdout_cases=(outside,)), phase)
    assert none.attrs["gravity_holdout_cases_skipped"] == 1 and not none.data_vars
    assert "gravity_holdout" not in table_axes(grid, 2, GravityPlan(holdout_cases=(outside,)))


# ------------------------------------------------------------- kill, resume, compare

def _command(what, out, ck, jobs):
    return [sys.executable, "-m", "capbridge.cli", "generate", what, "--quick", "--jobs",
            str(jobs), "--no-progress", "--output", str(out), "--checkpoint-dir", str(ck)]


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))


def _chunks(ck):
    """Chunk checkpoints under ``ck``: relative path -> (inode, mtime_ns)."""
    return {str(p.relative_to(ck)): (p.stat().st_ino, p.stat().st_mtime_ns)
            for p in Path(ck).rglob("chunk_*.npz")}


def _start(what, out, ck, jobs, log):
    with open(log, "w") as f:
        return subprocess.Popen(_command(what, out, ck, jobs), env=_env(), cwd=out.parent,
                                stdout=f, stderr=subprocess.STDOUT)


def _finish(proc, log):
    try:
        assert proc.wait(TIMEOUT) == 0, Path(log).read_text()[-3000:]
    finally:
        if proc.poll() is None:
            proc.kill()


def _kill_then_rerun(what, out, ck, jobs, kill_when):
    """Start ``generate <what> --quick``, SIGKILL it once ``kill_when(ck)`` holds, rerun
    the same command to the end.  Returns (chunks on disk at the kill, chunks after the
    rerun, output of the rerun)."""
    tmp = out.parent
    killed = _start(what, out, ck, jobs, tmp / "killed.log")
    try:
        deadline = time.monotonic() + TIMEOUT
        while not kill_when(ck):
            assert killed.poll() is None, "finished before it could be killed: " + \
                (tmp / "killed.log").read_text()[-3000:]
            assert time.monotonic() < deadline, "no chunk checkpoint in time"
            time.sleep(0.1)
        killed.send_signal(signal.SIGKILL)
        assert killed.wait(60) == -signal.SIGKILL
    finally:
        if killed.poll() is None:
            killed.kill()
    at_kill = _chunks(ck)
    assert at_kill and not out.exists()
    again = subprocess.run(_command(what, out, ck, jobs), env=_env(), cwd=tmp,
                           capture_output=True, text=True, timeout=TIMEOUT)
    assert again.returncode == 0, again.stderr[-3000:]
    return at_kill, _chunks(ck), again.stdout + again.stderr


def _assert_same_tables(a, b, skip=()):
    """Every variable and coordinate of two tables equal, NaN where NaN (bitwise:
    each point is a deterministic function of its inputs), except ``skip``."""
    ta, tb = read_table(a), read_table(b)
    assert set(ta.variables) == set(tb.variables)
    assert dict(ta.sizes) == dict(tb.sizes)
    compared = 0
    for name in ta.variables:
        if name in skip:
            continue
        x, y = ta[name].values, tb[name].values
        if x.dtype.kind in "fc":
            np.testing.assert_array_equal(x, y, err_msg=name)
        else:
            assert np.array_equal(x, y), name
        compared += 1
    assert compared > 10
    return ta, tb


def _assert_reused(at_kill, after, ref_ck, ck):
    """The chunks on disk at the kill are the same files after the rerun (a recomputed
    chunk is written to a new file and os.replace-d: another inode), and the rerun
    finished the same chunks as the uninterrupted run."""
    for name, stamp in at_kill.items():
        assert after.get(name) == stamp, f"{name} was recomputed"
    assert set(after) == set(_chunks(ref_ck))
    assert len(after) > len(at_kill)
    assert not list(Path(ck).rglob("failures.json"))


@pytest.mark.slow
@pytest.mark.evolver
def test_generate_triplet_quick_resumes_after_kill_and_is_usable(tmp_path, capsys):
    """The uninterrupted run first (the reference); then the same command in a
    checkpoint directory holding what a run killed in its gravity phase leaves on disk
    (the finished phases before it), killed by SIGKILL once its first chunk of the
    gravity response is written, and rerun.

    The finished phases are copies of the reference's chunks (each chunk is a
    deterministic function of its inputs: the same bytes a fresh run writes), which
    halves the cost of the test (two full quick runs: ~9 CPU minutes)."""
    ref, ref_ck = tmp_path / "reference.nc", tmp_path / "ck-reference"
    _finish(_start("triplet", ref, ref_ck, 2, tmp_path / "reference.log"),
            tmp_path / "reference.log")
    out, ck = tmp_path / "resumed.nc", tmp_path / "ck"
    phases = ["coalescence_volumes", "separated_energies", "coalesced_bodies",
              "holdout_coalescence_volumes", "holdout_bodies_level3",
              "gravity_response", "gravity_holdout_level2"]
    assert sorted(p.name for p in ref_ck.iterdir()) == sorted(phases)
    done = phases[:phases.index("gravity_response")]
    for name in done:
        shutil.copytree(ref_ck / name, ck / name)
    seeded = _chunks(ck)

    def kill_when(ck):
        return any((ck / "gravity_response").glob("chunk_*.npz"))

    at_kill, after, log = _kill_then_rerun("triplet", out, ck, 2, kill_when)
    # the finished phases were reused by the killed run and the rerun, the chunks of
    # the gravity response written before the kill by the rerun
    assert all(at_kill[n] == seeded[n] for n in seeded)
    assert {Path(n).parts[0] for n in at_kill} == set(done) | {"gravity_response"}
    _assert_reused(at_kill, after, ref_ck, ck)
    assert {Path(n).parts[0] for n in after} == set(phases)
    ta, tb = _assert_same_tables(ref, out, skip=TIMINGS)
    for name in TIMINGS:
        assert np.all(np.isfinite(tb[name].values) == np.isfinite(ta[name].values)), name
    assert "capbridge: error" not in log and "Traceback" not in log

    # every phase gave numbers: the table, its held-out points, the gravity response
    # and its held-out check inside the grid
    assert np.isin(tb["status"].values, [int(s) for s in HAS_RESULT]).all()
    assert tb.sizes["holdout"] == 2 and np.isfinite(tb["holdout_f12"].values).all()
    assert (tb["gravity_status"].values == Status.CONVERGED).all()
    assert tb.attrs["gravity_holdout_cases_skipped"] == 0
    assert tb.sizes["gravity_holdout"] == 2
    assert np.isin(tb["gravity_holdout_status"].values, [int(s) for s in HAS_RESULT]).all()

    # usable: info, lookup triplet (with and without gravity), the surrogate
    assert main(["info", "--table", str(out)]) == 0
    text = capsys.readouterr().out
    assert "held-out direct Evolver points with gravity (1 cases)" in text
    assert "holdout_max_rel_error_pair_force_by_volume" in text
    from capbridge.surrogate.triplet import TripletSurrogate

    sur = TripletSurrogate().fit(out)
    assert sur.interpolation_error_["n"] == 2
    assert sur.gravity_summary()["holdout"]["n_cases"] == 1
    pts = pd.DataFrame({"d12": [0.1, 0.05, 0.15], "d13": [0.1, 0.15, 0.1],
                        "d23": [0.05, 0.1, 0.15], "theta": [15.0, 0.0, 30.0]})
    vc = sur.coalescence_volume(pts.d12, pts.d13, pts.d23, pts.theta)["volume_coalescence"]
    pts.insert(3, "V", 1.15 * vc)
    pts.to_csv(tmp_path / "pts.csv", index=False)
    r = sur.predict(pts.d12, pts.d13, pts.d23, pts.V, pts.theta)
    assert np.isfinite(r["f12"]).all() and np.isin(r["status"], HAS_RESULT).all()
    for extra in ([], ["--bond", "0.5"]):
        dst = tmp_path / f"lookup{len(extra)}.csv"
        assert main(["lookup", "triplet", "--table", str(out), "--input",
                     str(tmp_path / "pts.csv"), "--output", str(dst)] + extra) == 0
        df = pd.read_csv(dst)
        assert np.isfinite(df[["f12", "f13", "f23", "P"]].to_numpy()).all()
        assert set(df.status) <= {"converged", "above_tolerance", "approximate"}
        if extra:
            F = df[[f"F{g}{c}" for g in (1, 2, 3) for c in "xyz"]].to_numpy()
            assert np.isfinite(F).all()
    capsys.readouterr()

    # the table --holdout 0 writes (no pair-force held-out points, the gravity
    # held-out check kept), and a count of skipped gravity cases, shown by info
    ds = read_table(out)
    bare = ds.drop_vars([n for n in ds.variables if n.startswith("holdout")])
    bare.attrs = {k: v for k, v in ds.attrs.items() if not k.startswith("holdout_")}
    bare.attrs["gravity_holdout_cases_skipped"] = 1
    write_table(bare, tmp_path / "bare.nc", command="test", solver_settings={})
    assert main(["info", "--table", str(tmp_path / "bare.nc")]) == 0
    assert "1 held-out gravity case(s) outside the table's grid: skipped" in \
        capsys.readouterr().out
    assert main(["lookup", "triplet", "--table", str(tmp_path / "bare.nc"), "--input",
                 str(tmp_path / "pts.csv"), "--output", str(tmp_path / "bare.csv")]) == 0


@pytest.mark.slow
def test_generate_coalescence_quick_resumes_after_kill(tmp_path, capsys):
    """From scratch: the uninterrupted run and, side by side, the same command killed
    once its first chunk is on disk, then rerun (one core each)."""
    def kill_when(ck):
        return any((ck / "pair").glob("chunk_*.npz"))

    ref, ref_ck = tmp_path / "reference.nc", tmp_path / "ck-reference"
    reference = _start("coalescence", ref, ref_ck, 1, tmp_path / "reference.log")
    try:
        out = tmp_path / "resumed.nc"
        at_kill, after, _ = _kill_then_rerun("coalescence", out, tmp_path / "ck", 1,
                                             kill_when)
    finally:
        _finish(reference, tmp_path / "reference.log")
    _assert_reused(at_kill, after, ref_ck, tmp_path / "ck")
    _, tb = _assert_same_tables(ref, out)
    assert (tb["status_pair"].values == Status.CONVERGED).all()
    assert np.isfinite(tb["V_coal_pair"].values).all()
    chunks = __import__("json").loads(tb.attrs["chunks_pair"])
    assert chunks["reused_from_checkpoints"] == len(at_kill)
    assert chunks["computed"] + chunks["reused_from_checkpoints"] == len(after)
    assert main(["info", "--table", str(out)]) == 0
    assert "interpolation_error_pair" in capsys.readouterr().out
