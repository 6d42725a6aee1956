"""Bad input and faults (issue 11): never a traceback, never a silent wrong number,
never lost work.  Each test failed before the hardening and passes after it.

Sections follow the issue: 1. lost work in the generator, 2. tracebacks for user
errors, 3. numbers where an error or a flag was due, 4. messages, 5. provenance.
A quick table is made once per module, the hard way (a first run loses a rupture
chunk, the rerun finishes it); the other tests damage copies of it.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from capbridge import cli
from capbridge.cli import main
from capbridge.tables import doublet as dt
from capbridge.tables.netcdf_io import (TableError, TableExistsError, read_table,
                                           write_table)
from capbridge.tables.sweep import (SchedulerUnavailableError, SweepFailedError,
                                       run_sweep)
from capbridge.solvers.young_laplace import rupture_distance, solve_doublet
from capbridge.status import Status
from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.validation import CapbridgeInputError, check_range

TESTS_DIR = Path(__file__).resolve().parent
ROOT = TESTS_DIR.parent


# ------------------------------------------------------------------------------ helpers

def run(args, capsys):
    """``main(args)`` -> (exit code, stdout, stderr); a traceback fails the test."""
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_clean_error(code, err, *words, expect=2):
    """One line ``capbridge: error: ...`` naming ``words``, the expected exit code."""
    assert code == expect, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("capbridge: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)


def solve_slowly(x, y):
    """Toy sweep solver (picklable): logs its pid, sleeps, returns x*y."""
    log = os.environ.get("CAPBRIDGE_TEST_PIDLOG")
    if log:
        with open(log, "a") as f:
            f.write(f"{os.getpid()}\n")
    time.sleep(float(os.environ.get("CAPBRIDGE_TEST_SLEEP", "0")))
    return {"F": x * y, "status": np.zeros(len(x), np.int8)}


def _alive(pid):
    """Whether ``pid`` runs (a zombie waiting for its reaper counts as dead)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            state = next(line for line in f if line.startswith("State:"))
    except (OSError, StopIteration):
        return False
    return "Z" not in state.split()[1]


# ------------------------------------------------------ the quick table, made the hard way

@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A quick table made by the CLI after a first run whose rupture phase lost a chunk.

    Returns a dict with the table path, the checkpoint directory and what the two runs
    did (exit codes, messages, chunks computed by each).
    """
    tmp = tmp_path_factory.mktemp("made")
    table, ck = tmp / "quick.nc", tmp / "ck"
    real = dt.rupture_chunk
    calls = []

    def flaky(volume, theta, ratio):
        calls.append(float(theta[0]))
        if fail[0] and np.any(theta >= 45.0):
            raise RuntimeError("simulated crash in the rupture solve")
        return real(volume, theta, ratio)

    # the same solver for the checkpoint manifest as the real one
    flaky.__module__, flaky.__qualname__ = real.__module__, real.__qualname__
    args = ["generate", "doublet", "--quick", "--jobs", "1", "--holdout", "10",
            "--no-progress", "--output", str(table), "--checkpoint-dir", str(ck)]
    fail = [True]
    import io
    from contextlib import redirect_stderr

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(dt, "rupture_chunk", flaky)
        err1 = io.StringIO()
        with redirect_stderr(err1):
            code1 = main(args)
        calls_first = list(calls)
        after_fail = {"table": table.exists(), "bridges": (ck / "bridges").exists()}
        calls.clear()
        fail[0] = False
        err2 = io.StringIO()
        with redirect_stderr(err2):
            code2 = main(args)
    return {"table": table, "ck": ck, "code1": code1, "err1": err1.getvalue(),
            "code2": code2, "calls1": calls_first, "calls2": list(calls),
            "after_fail": after_fail}


@pytest.fixture(scope="module")
def table(made):
    assert made["code2"] == 0, made
    return made["table"]


def _copy(src, dst):
    shutil.copyfile(src, dst)
    return dst


# ============================================================ 1. lost work in the generator

def test_failed_phase_stops_and_rerun_recomputes_only_failed_chunks(made):
    # first run: one of the 2 rupture chunks failed -> stop before the bridge sweep
    # (nothing solved on placeholder gaps), one clear line, exit 3
    assert made["code1"] == 3
    last = made["err1"].strip().splitlines()[-1]
    assert last.startswith("capbridge: error: rupture distances: 1 of 2 chunks failed")
    assert "rerun" in last and "Traceback" not in made["err1"]
    assert made["after_fail"] == {"table": False, "bridges": False}
    # the rerun reuses the good chunk and recomputes only the failed one
    assert made["code2"] == 0
    assert len(made["calls1"]) == 2 and made["calls2"] == made["calls1"][1:]
    ds = read_table(made["table"])
    assert (ds["status"].values == Status.CONVERGED).all()


def test_changed_grid_reuses_matching_chunks(tmp_path):
    """A checkpoint directory of another grid is resumed chunk by chunk, not refused."""
    ck = tmp_path / "ck"
    x = np.arange(40.0)
    run_sweep(solve_slowly, {"x": x, "y": x}, checkpoint_dir=ck, chunk_size=10, n_jobs=1,
              progress=False)
    y = x.copy()
    y[35] = -1.0
    res = run_sweep(solve_slowly, {"x": x, "y": y}, checkpoint_dir=ck, chunk_size=10,
                    n_jobs=1, progress=False)
    assert res.reused == [0, 1, 2] and res.computed == [3]
    np.testing.assert_array_equal(res["F"], x * y)
    assert len(list(ck.glob("chunk_*.npz"))) == 5      # nothing of the user's deleted


def test_no_overwrite_of_another_grid(table, tmp_path, capsys, monkeypatch):
    other = tmp_path / "other.nc"
    ds = read_table(table).isel(theta=[0, 1])
    write_table(ds, other, command="test", solver_settings={})
    before = other.read_bytes()
    # default output (the shipped table's place) and an explicit one: refused at once
    monkeypatch.setattr(cli, "DEFAULT_TABLE", other)
    t0 = time.monotonic()
    for extra in ([], ["--output", str(other)]):
        code, _, err = run(["generate", "doublet", "--quick", "--jobs", "1",
                            "--no-progress", "--checkpoint-dir", str(tmp_path / "ck")] + extra,
                           capsys)
        assert_clean_error(code, err, "another grid", "--overwrite")
    assert time.monotonic() - t0 < 10 and not (tmp_path / "ck").exists()
    assert other.read_bytes() == before
    with pytest.raises(TableExistsError, match="overwrite=True"):
        write_table(read_table(table), other, command="test", solver_settings={})
    write_table(read_table(table), other, command="test", solver_settings={}, overwrite=True)
    assert read_table(other).sizes == read_table(table).sizes


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_files_honour_the_umask(table, tmp_path, mask):
    old = os.umask(mask)
    try:
        path = write_table(read_table(table), tmp_path / "t.nc", command="t",
                           solver_settings={})
        run_sweep(solve_slowly, {"x": np.ones(3), "y": np.ones(3)},
                  checkpoint_dir=tmp_path / "ck", chunk_size=3, n_jobs=1, progress=False)
    finally:
        os.umask(old)
    expected = 0o666 & ~mask
    assert path.stat().st_mode & 0o777 == expected
    for f in (tmp_path / "ck").iterdir():
        assert f.stat().st_mode & 0o777 == expected, f


def test_workers_die_with_their_parent(tmp_path):
    pidlog = tmp_path / "pids"
    script = textwrap.dedent(f"""
        import sys, numpy as np
        sys.path.insert(0, {str(TESTS_DIR)!r})
        import test_hardening as t
        from capbridge.tables.sweep import run_sweep
        x = np.arange(8.0)
        run_sweep(t.solve_slowly, {{"x": x, "y": x}}, checkpoint_dir=None, chunk_size=1,
                  n_jobs=2, progress=False)
        """)
    env = dict(os.environ, CAPBRIDGE_TEST_PIDLOG=str(pidlog), CAPBRIDGE_TEST_SLEEP="30",
               PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", script], env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            pids = {int(p) for p in pidlog.read_text().split()} if pidlog.exists() else set()
            if len(pids) >= 2:
                break
            time.sleep(0.2)
        assert len(pids) >= 2, "workers did not start"
        proc.kill()          # SIGKILL: no cleanup in the parent
        proc.wait(10)
        deadline = time.monotonic() + 10
        while any(_alive(p) for p in pids) and time.monotonic() < deadline:
            time.sleep(0.2)
        left = [p for p in pids if _alive(p)]
    finally:
        if proc.poll() is None:
            proc.kill()
    for p in left:           # do not leave them behind if the test fails
        os.kill(p, signal.SIGKILL)
    assert not left, f"orphaned workers {left}"


@pytest.mark.slow
def test_dask_without_workers_fails_after_the_timeout(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as c, \
            distributed.Client(c) as client:
        t0 = time.monotonic()
        res = run_sweep(solve_slowly, {"x": np.ones(4), "y": np.ones(4)},
                        checkpoint_dir=tmp_path / "ck", chunk_size=2, scheduler=client,
                        progress=False, worker_timeout=2.0)
        waited = time.monotonic() - t0
    assert 2.0 <= waited < 30
    assert len(res.failures) == 2 and "no Dask worker" in res.failures[0].error
    assert (res["status"] == Status.NOT_CONVERGED).all()
    with pytest.raises(SweepFailedError, match="2 of 2 chunks failed.*rerun"):
        res.raise_if_failed()


def test_lost_dask_scheduler_keeps_finished_chunks(tmp_path, monkeypatch):
    """The scheduler goes away mid-sweep: the sweep returns (no wait), the chunks
    finished before are checkpointed, and a rerun computes only the others."""
    import threading

    distributed = pytest.importorskip("distributed")
    monkeypatch.setenv("CAPBRIDGE_TEST_SLEEP", "0.5")
    ck, x = tmp_path / "ck", np.arange(8.0)
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                       dashboard_address=None)
    client = distributed.Client(cluster)

    def close_after_first_chunk():
        # close the scheduler once a chunk is checkpointed (not after a fixed time: a
        # loaded machine may not finish a chunk in any given time)
        t_end = time.monotonic() + 30
        while time.monotonic() < t_end and not list(ck.glob("chunk_*.npz")):
            time.sleep(0.05)
        cluster.close()

    threading.Thread(target=close_after_first_chunk, daemon=True).start()
    t0 = time.monotonic()
    try:
        res = run_sweep(solve_slowly, {"x": x, "y": x}, checkpoint_dir=ck, chunk_size=1,
                        scheduler=client, progress=False, worker_timeout=20)
    finally:
        client.close()
        cluster.close()
    assert time.monotonic() - t0 < 20
    assert res.failures and 1 <= len(res.computed) < 8
    with pytest.raises(SweepFailedError, match="rerun"):
        res.raise_if_failed()
    monkeypatch.setenv("CAPBRIDGE_TEST_SLEEP", "0")
    again = run_sweep(solve_slowly, {"x": x, "y": x}, checkpoint_dir=ck, chunk_size=1,
                      n_jobs=1, progress=False)
    assert again.reused == res.computed and again.computed == [f.index for f in res.failures]
    np.testing.assert_array_equal(again["F"], x * x)


@pytest.mark.slow
def test_scheduler_that_does_not_answer(tmp_path):
    pytest.importorskip("distributed")
    t0 = time.monotonic()
    with pytest.raises(SchedulerUnavailableError, match="did not answer within 2 s"):
        run_sweep(solve_slowly, {"x": np.ones(2), "y": np.ones(2)}, checkpoint_dir=None,
                  scheduler="tcp://127.0.0.1:9", connect_timeout=2.0, progress=False)
    assert time.monotonic() - t0 < 30
    assert issubclass(SchedulerUnavailableError, CapbridgeInputError)  # CLI: one line


# ======================================================= 2. tracebacks for user errors

def _damaged_tables(table, tmp):
    """name -> path of tables a user may point at by mistake."""
    raw = Path(table).read_bytes()
    out = {"missing": tmp / "missing.nc", "directory": tmp}
    (tmp / "truncated.nc").write_bytes(raw[: len(raw) // 2])
    out["truncated"] = tmp / "truncated.nc"
    (tmp / "junk.nc").write_bytes(b"not a table\n" * 10)
    out["junk"] = tmp / "junk.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(tmp / "foreign.nc")
    out["foreign"] = tmp / "foreign.nc"
    write_table(read_table(table).drop_vars("force"), tmp / "incomplete.nc", command="t",
                solver_settings={})
    out["incomplete"] = tmp / "incomplete.nc"
    return out


@pytest.mark.parametrize("kind", ["missing", "directory", "truncated", "junk", "foreign",
                                  "incomplete"])
@pytest.mark.parametrize("command", ["info", "lookup", "demo"])
def test_bad_tables_give_one_line(table, tmp_path, capsys, kind, command):
    bad = _damaged_tables(table, tmp_path)[kind]
    pts = tmp_path / "p.csv"
    pts.write_text("d,V,theta\n0.05,0.01,20\n")
    args = {"info": ["info", "--table", str(bad)],
            "lookup": ["lookup", "doublet", "--input", str(pts), "--output",
                       str(tmp_path / "o.csv"), "--table", str(bad)],
            "demo": ["demo", "--table", str(bad), "--output-dir", str(tmp_path / "demo")]}
    code, out, err = run(args[command], capsys)
    assert_clean_error(code, err)
    assert not (tmp_path / "o.csv").exists()


CSV_CASES = {
    "not a number": ("d,V,theta\n0.05,0.01,20\n0.05,abc,20\n", ["line 3", "'V'", "abc"]),
    "boolean": ("d,V,theta\nTrue,0.01,20\n", ["line 2", "'d'", "True"]),
    "underscore": ("d,V,theta\n0.05,1_0,20\n", ["'V'", "not a number"]),
    "empty cell": ("d,V,theta\n0.05,,20\n", ["line 2", "'V'"]),
    "empty file": ("", ["empty"]),
    "header only": ("d,V,theta\n", ["no points"]),
    "duplicate column": ("d,V,theta,V\n0.05,0.01,20,0.02\n", ["duplicate", "'V'"]),
    "extra field": ("d,V,theta\n0.05,0.01,20\n0.05,0.01,20,7\n", ["line 3", "4 fields"]),
    "output name F": ("d,V,theta,F\n0.05,0.01,20,1\n", ["'F'", "outputs"]),
    "output name status": ("d,V,theta,status\n0.05,0.01,20,x\n", ["'status'"]),
    "missing column": ("d,theta\n0.05,20\n", ["missing column", "'V'"]),
}


@pytest.mark.parametrize("case", sorted(CSV_CASES))
def test_bad_csv_gives_one_line(table, tmp_path, capsys, case):
    text, words = CSV_CASES[case]
    src = tmp_path / "in.csv"
    src.write_text(text)
    code, _, err = run(["lookup", "doublet", "--input", str(src), "--output",
                        str(tmp_path / "o.csv"), "--table", str(table)], capsys)
    assert_clean_error(code, err, *words)
    assert not (tmp_path / "o.csv").exists()


def test_non_utf8_and_missing_input(table, tmp_path, capsys):
    src = tmp_path / "latin1.csv"
    src.write_bytes("d,V,theta,note\n0.05,0.01,20,caf\xe9\n".encode("latin-1"))
    for path, word in ((src, "UTF-8"), (tmp_path / "nope.csv", "does not exist"),
                       (tmp_path, "directory")):
        code, _, err = run(["lookup", "doublet", "--input", str(path), "--output",
                            str(tmp_path / "o.csv"), "--table", str(table)], capsys)
        assert_clean_error(code, err, word)


@pytest.mark.parametrize("where, word", [("missing", "does not exist"),
                                         ("directory", "is a directory"),
                                         ("unwritable", "cannot be written"),
                                         ("exists", "--overwrite")])
def test_output_paths_checked_before_computing(table, tmp_path, capsys, where, word):
    src = tmp_path / "in.csv"
    src.write_text("d,V,theta\n0.05,0.01,20\n")
    out = {"missing": tmp_path / "no" / "o.csv", "directory": tmp_path,
           "unwritable": Path("/proc/capbridge-o.csv"), "exists": tmp_path / "in2.csv"}[where]
    if where == "exists":
        out.write_text("mine\n")
    code, _, err = run(["lookup", "doublet", "--input", str(src), "--output", str(out),
                        "--table", str(table)], capsys)
    assert_clean_error(code, err, word)
    if where == "exists":
        assert out.read_text() == "mine\n"
    # the generator checks its output before any sweep (no checkpoint appears)
    gen_out = {"missing": tmp_path / "no" / "t.nc", "directory": tmp_path,
               "unwritable": Path("/proc/capbridge-t.nc"), "exists": None}[where]
    if gen_out is not None:
        code, _, err = run(["generate", "doublet", "--quick", "--jobs", "1", "--no-progress",
                            "--output", str(gen_out), "--checkpoint-dir",
                            str(tmp_path / "gen-ck")], capsys)
        assert_clean_error(code, err, word)
        assert not (tmp_path / "gen-ck").exists()


@pytest.mark.parametrize("args, word", [
    (["export-yade", "--directory", "D", "--n-gaps", "0"], "--n-gaps"),
    (["generate", "doublet", "--quick", "--holdout", "-1"], "--holdout"),
    (["generate", "doublet", "--quick", "--jobs", "0"], "--jobs"),
    (["generate", "doublet", "--quick", "--ratios", "0.5"], "--ratios"),
    (["solve", "doublet", "--d", "x", "--V", "0.1", "--theta", "0"], "--d"),
    (["reproduce", "miot2021", "--max-refine", "-2"], "--max-refine"),
])
def test_unchecked_arguments_are_checked(args, word, capsys, tmp_path):
    args = [str(tmp_path / a) if a == "D" else a for a in args]
    with pytest.raises(SystemExit) as e:
        main(args)
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert_clean_error(2, err, word)
    assert not (tmp_path / "D").exists()


def test_checkpoint_directory_problems(tmp_path, capsys, table):
    afile = tmp_path / "ck"
    afile.write_text("I am a file")
    out = tmp_path / "t.nc"
    code, _, err = run(["generate", "doublet", "--quick", "--jobs", "1", "--no-progress",
                        "--output", str(out), "--checkpoint-dir", str(afile)], capsys)
    assert_clean_error(code, err, "checkpoint directory")
    other = tmp_path / "other"
    run_sweep(solve_slowly, {"x": np.ones(2), "y": np.ones(2)}, checkpoint_dir=other / "rupture",
              n_jobs=1, progress=False)       # a directory of another solver
    code, _, err = run(["generate", "doublet", "--quick", "--jobs", "1", "--no-progress",
                        "--output", str(out), "--checkpoint-dir", str(other)], capsys)
    assert_clean_error(code, err, "different solver", "another checkpoint directory")
    assert (other / "rupture" / "manifest.json").exists()     # nothing deleted


@pytest.mark.parametrize("kw, word", [({"refine": 0}, "refine"),
                                      ({"refine": 2.5}, "refine"),
                                      ({"theta_step": 0}, "theta_step"),
                                      ({"theta_step": float("nan")}, "theta_step"),
                                      ({"out_of_range": "wrap"}, "out_of_range")])
def test_surrogate_arguments(kw, word):
    with pytest.raises(CapbridgeInputError, match=word):
        DoubletSurrogate(**kw)


def test_unknown_variables(table):
    sur = DoubletSurrogate().fit(table)
    with pytest.raises(CapbridgeInputError, match="unknown.*forse.*allowed"):
        sur.predict(0.05, 0.01, 20.0, variables=("forse",))


def test_internal_errors_are_one_line_and_debug_shows_them(capsys, monkeypatch):
    def boom(args):
        raise ZeroDivisionError("simulated bug")

    monkeypatch.setattr(cli, "cmd_info_table", boom)
    code, _, err = run(["info"], capsys)
    assert_clean_error(code, err, "internal error", "--debug", expect=1)
    with pytest.raises(ZeroDivisionError):
        main(["--debug", "info"])


# ========================================== 3. numbers where an error or a flag was due

@pytest.mark.parametrize("radius", ["-1", "nan", "0", "4"])
def test_coalescence_radius(radius, capsys):
    code, out, err = run(["coalescence", "--d12", "0.175", "--d13", "0.175", "--d23",
                          "0.075", "--theta", "30", "--radius", radius], capsys)
    assert_clean_error(code, err, "--radius")
    assert out == ""


@pytest.mark.slow
def test_clip_keeps_the_state(table, tmp_path, capsys):
    sur_clip = DoubletSurrogate(out_of_range="clip").fit(table)
    vmin = float(sur_clip.volume_[0])
    # theta beyond the table: an error even with clipping (another bridge)
    for th in (60.0, 120.0):
        with pytest.raises(CapbridgeInputError, match="theta.*exact solver"):
            sur_clip.predict(0.01, 0.01, th)
    # V* below the table, gap beyond its own (exact) rupture distance: no bridge
    v = vmin / 8
    d_exact = float(rupture_distance(v, 20.0)["gap"])
    assert int(solve_doublet(1.2 * d_exact, v, 20.0)["status"]) == Status.RUPTURED
    r = sur_clip.predict(1.2 * d_exact, v, 20.0)
    assert int(r["status"]) == Status.RUPTURED and float(r["force"]) == 0.0
    # ... and well inside it: a force flagged as extrapolated; the clipped rupture
    # distance follows V^(1/3) (within 5 % of the exact one)
    r = sur_clip.predict(0.3 * d_exact, v, 20.0)
    assert int(r["status"]) == Status.EXTRAPOLATED and float(r["force"]) > 0
    assert float(r["rupture_gap"]) == pytest.approx(d_exact, rel=0.05)
    # CLI: the hint names --clip; with --clip, theta outside is still refused
    src = tmp_path / "p.csv"
    src.write_text(f"d,V,theta\n0.05,{vmin / 8},20\n")
    code, _, err = run(["lookup", "doublet", "--input", str(src), "--output",
                        str(tmp_path / "o.csv"), "--table", str(table)], capsys)
    assert_clean_error(code, err, "--clip")
    assert "out_of_range" not in err
    src.write_text("d,V,theta\n0.05,0.01,120\n")
    code, _, err = run(["lookup", "doublet", "--input", str(src), "--output",
                        str(tmp_path / "o.csv"), "--table", str(table), "--clip"], capsys)
    assert_clean_error(code, err, "theta")


def _edit(path, fn, drop_checksum=False):
    with netCDF4.Dataset(path, "r+") as nc:
        fn(nc)
        if drop_checksum:
            for key in ("data_sha256", "table_sha256"):
                if key in nc.ncattrs():
                    nc.delncattr(key)


@pytest.mark.parametrize("edit, word", [
    ("force x10", "checksum"),
    ("force x10 no checksum", "force"),
    ("theta in radians", "units"),
    ("volume in mm3", "units"),
    ("reversed theta", "strictly increasing"),
])
def test_edited_tables_are_refused(table, tmp_path, capsys, edit, word):
    path = _copy(table, tmp_path / "edited.nc")

    def x10(nc):
        nc["force"][0, 1, 2, :] = nc["force"][0, 1, 2, :] * 10

    def reverse(nc):
        nc["theta"][:] = nc["theta"][:][::-1]

    fn, drop = {"force x10": (x10, False), "force x10 no checksum": (x10, True),
                "theta in radians": (lambda nc: nc["theta"].setncattr("units", "radian"), True),
                "volume in mm3": (lambda nc: nc["volume"].setncattr("units", "mm3"), True),
                "reversed theta": (reverse, True)}[edit]
    _edit(path, fn, drop)
    with pytest.raises(TableError, match=word):
        DoubletSurrogate().fit(path)
    code, _, err = run(["info", "--table", str(path)], capsys)
    assert_clean_error(code, err, word)


def test_refinement_coarser_than_the_error_model_is_refused(table):
    with pytest.raises(CapbridgeInputError, match="theta_step.*error model"):
        DoubletSurrogate(theta_step=30).fit(table)
    with pytest.raises(CapbridgeInputError, match="refine.*error model"):
        DoubletSurrogate(refine=2).fit(table)
    DoubletSurrogate(refine=8, theta_step=0.25).fit(table)      # finer is fine


def test_evolver_status_above_tolerance():
    from types import SimpleNamespace

    from capbridge.solvers.evolver.minimise import BridgeResult, Settings, _set_final_status

    s = Settings()
    assert s.flag_above_tolerance            # on by default
    for est, expected in (({"energy_rel": 1e-4, "force_rel": 1e-4}, Status.CONVERGED),
                          ({"energy_rel": 1e-4, "force_rel": 10 * s.ftol},
                           Status.ABOVE_TOLERANCE),
                          ({"energy_rel": np.inf, "force_rel": np.inf},
                           Status.ABOVE_TOLERANCE)):
        res = SimpleNamespace(error_estimate=est, warnings=[], status=None, reason="")
        _set_final_status(res, s)
        assert res.status == expected
        # switched off (the default is on): the old status, but the reason still says so
        old = SimpleNamespace(error_estimate=est, warnings=[], status=None, reason="")
        _set_final_status(old, Settings(flag_above_tolerance=False))
        assert old.status == Status.CONVERGED
        assert ("above tolerance" in old.reason) == (expected == Status.ABOVE_TOLERANCE)
    r = BridgeResult(status=Status.ABOVE_TOLERANCE, reason="x")
    assert r.converged and not r.within_tolerance     # numbers there, precision not
    assert int(Status.ABOVE_TOLERANCE) == 7 and int(Status.EXTRAPOLATED) == 6


@pytest.mark.evolver
def test_evolver_single_level_is_not_converged():
    from capbridge.solvers.evolver import doublet_force
    from capbridge.solvers.evolver.minimise import Settings

    F, r = doublet_force(0.1, 0.05, 30.0, settings=Settings(max_refine=0, min_refine=0,
                                                            flag_above_tolerance=True))
    assert r.status == Status.ABOVE_TOLERANCE and np.isinf(r.error_estimate["force_rel"])
    assert np.isfinite(F) and "above tolerance" in r.reason


@pytest.mark.parametrize("kw, word", [({"radius1": 1.0}, "radius1"),
                                      ({"radius2": 2000.0}, "radius2"),
                                      ({"surface_tension": 72.0}, "surface_tension"),
                                      ({"volume": 5e-5}, "predict_si")])
def test_predict_si_catches_unit_slips(table, kw, word):
    sur = DoubletSurrogate().fit(table)
    args = dict(radius1=1e-3, radius2=1e-3, surface_tension=0.072, gap=1e-5, volume=1e-11,
                theta=20.0)
    f = sur.predict_si(**args)["force"]
    assert 0 < float(f) < 2 * np.pi * 0.072 * 1e-3
    with pytest.raises(CapbridgeInputError, match=word):
        sur.predict_si(**(args | kw))


@pytest.mark.slow
def test_lookup_theta2_by_the_exact_solver(table, tmp_path, capsys):
    src = tmp_path / "p.csv"
    src.write_text("d,V,theta,theta2,tag\n0.05,0.01,20,20,a\n0.05,0.01,20,40,b\n"
                   "2.0,0.01,20,40,c\n")
    out = tmp_path / "o.csv"
    code, _, err = run(["lookup", "doublet", "--input", str(src), "--output", str(out),
                        "--table", str(table)], capsys)
    assert code == 0, err
    import pandas as pd

    df = pd.read_csv(out)
    assert list(df["method"]) == ["table", "exact", "exact"]
    assert list(df["tag"]) == ["a", "b", "c"]
    ex = solve_doublet(0.05, 0.01, 20.0, 1.0, 40.0)
    assert df["F"][1] == pytest.approx(float(ex["force"]), rel=1e-12)
    assert df["d_rupt"][1] == pytest.approx(float(rupture_distance(0.01, 20.0, 1.0, 40.0)["gap"]))
    assert list(df["status"]) == ["converged", "converged", "ruptured"] and df["F"][2] == 0
    # theta2 = theta: the table, within its error of the exact equal-angle answer
    assert df["F"][0] == pytest.approx(float(solve_doublet(0.05, 0.01, 20.0)["force"]), rel=0.02)


# ================================================================== 4. messages

def test_messages(capsys, monkeypatch):
    with pytest.raises(CapbridgeInputError, match=r"\[0, inf\)"):
        check_range("gap", -1.0, 0.0)
    # negative numbers in exponent form are values, not options
    code, out, err = run(["solve", "doublet", "--d", "0.1", "--P", "-3.2e0", "--theta",
                          "30"], capsys)
    assert code in (0, 3) and json.loads(out)["d"] == 0.1, err
    # coalescence: blame the default search limit, not an option never given
    code, _, err = run(["coalescence", "--d12", "1.5", "--d13", "1.5", "--d23", "1.5",
                        "--theta", "0"], capsys)
    assert_clean_error(code, err, "default search limit --v-max 2.5")
    # solve: the requested volume is echoed even when the solve fails
    import capbridge.solvers.young_laplace as yl

    def not_converged(gap, volume, theta, ratio=1.0, theta2=None):
        nan = np.float64(np.nan)
        return {"volume": nan, "force": nan, "pressure": nan, "beta1": nan, "beta2": nan,
                "neck_radius": nan, "area": nan, "energy": nan,
                "status": np.int8(Status.NOT_CONVERGED)}

    monkeypatch.setattr(yl, "solve_doublet", not_converged)
    code, out, _ = run(["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30"],
                       capsys)
    r = json.loads(out)
    assert code == 3 and r["V"] == 0.05 and r["status"] == "not_converged"


# ================================================================= 5. provenance

def test_provenance(table):
    ds = read_table(table)
    commit = ds.attrs["git_commit"]
    assert len(commit.split("+")[0]) == 40 or commit.startswith("unknown")
    libs = json.loads(ds.attrs["library_versions"])
    assert {"numpy", "scipy", "xarray", "netCDF4", "python"} <= set(libs)
    assert str(table.parent) not in ds.attrs["capbridge_command"]
    assert "--output quick.nc" in ds.attrs["capbridge_command"]
    assert str(table.parent) not in ds.attrs["history"]
    grid = json.loads(ds.attrs["grid"])
    for name in ("ratio", "theta", "volume", "s"):
        np.testing.assert_array_equal(grid[name], ds[name].values)
    with netCDF4.Dataset(table) as nc:
        for name in ("ratio", "theta", "volume", "s"):
            assert "_FillValue" not in nc[name].ncattrs(), name
    assert len(ds.attrs["data_sha256"]) == 64
