"""Tests of capbridge.tables.sweep (resumable parallel sweeps) with toy solvers."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from capbridge.tables.sweep import (CheckpointMismatchError, SweepResult,
                                       run_sweep)
from capbridge.status import Status

TESTS_DIR = Path(__file__).resolve().parent
ROOT = TESTS_DIR.parent

# ---------------------------------------------------------------- toy solvers (picklable)
# Behaviour switches come from environment variables so that the *same* function (same
# name in the checkpoint manifest) can be interrupted, slowed down or made to fail.


def _log_call(x):
    log = os.environ.get("CAPBRIDGE_TEST_CALLLOG")
    if log:
        fd = os.open(log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, f"{float(x[0])!r}\n".encode())
        finally:
            os.close(fd)


def solve_product(x, y):
    """F = x*y, all converged; env switches: interrupt, sleep, call log."""
    stop_at = os.environ.get("CAPBRIDGE_TEST_INTERRUPT_AT")
    if stop_at is not None and x[0] >= float(stop_at):
        raise KeyboardInterrupt("simulated kill")
    delay = float(os.environ.get("CAPBRIDGE_TEST_SLEEP", "0"))
    if delay:
        time.sleep(delay)
    _log_call(x)
    return {"F": x * y, "n": np.full(len(x), 7, np.int32),
            "status": np.full(len(x), Status.CONVERGED, np.int64)}


def solve_fails_on_negative(x, y):
    """Raises for any chunk holding a negative y."""
    _log_call(x)
    if np.any(y < 0):
        raise RuntimeError(f"no bridge for y={y.min()}")
    return {"F": x * y, "n": np.ones(len(x), np.int32), "status": np.zeros(len(x), np.int8)}


def solve_crashes_in_worker(x, y):
    """Kills its worker process (as a segfault or the OOM killer would) on chunk x >= 100.

    Never exits the test process itself (guarded by the parent's pid).
    """
    if x[0] >= 100 and x[0] < 150 and str(os.getppid()) == os.environ.get(
            "CAPBRIDGE_TEST_PARENT"):
        os._exit(3)
    return {"F": x * y, "status": np.zeros(len(x), np.int8)}


def solve_no_status(x, y):
    return {"F": x * y}


def _calls(path):
    p = Path(path)
    return sorted(float(v) for v in p.read_text().split()) if p.exists() else []


@pytest.fixture
def calllog(tmp_path, monkeypatch):
    path = tmp_path / "calls.log"
    monkeypatch.setenv("CAPBRIDGE_TEST_CALLLOG", str(path))
    for var in ("CAPBRIDGE_TEST_INTERRUPT_AT", "CAPBRIDGE_TEST_SLEEP"):
        monkeypatch.delenv(var, raising=False)
    return path


def _inputs(n=1000, seed=0):
    rng = np.random.default_rng(seed)
    # x strictly increasing so that x[0] identifies a chunk in the call log
    return {"x": np.arange(n, dtype=float) + rng.random(n) * 0.5,
            "y": rng.normal(size=n)}


def _chunk_files(d):
    return sorted(Path(d).glob("chunk_*.npz"))


def _check_product(res, inp):
    assert isinstance(res, SweepResult)
    assert list(res)[:2] == ["x", "y"]
    np.testing.assert_array_equal(res["x"], inp["x"])
    np.testing.assert_array_equal(res["y"], inp["y"])
    np.testing.assert_array_equal(res["F"], inp["x"] * inp["y"])
    assert res["status"].dtype == np.int8
    assert (res["status"] == Status.CONVERGED).all()
    assert len(res["F"]) == len(inp["x"])


# ---------------------------------------------------------------- results and order


def test_serial_equals_direct_computation(tmp_path, calllog):
    inp = _inputs(1000)
    res = run_sweep(solve_product, inp, checkpoint_dir=tmp_path / "ck", chunk_size=64,
                    n_jobs=1, progress=False)
    _check_product(res, inp)
    np.testing.assert_array_equal(res["n"], 7)
    assert res.n_chunks == 16 and res.computed == list(range(16)) and res.reused == []
    assert res.failures == []
    assert len(_chunk_files(tmp_path / "ck")) == 16
    manifest = json.loads((tmp_path / "ck" / "manifest.json").read_text())
    assert manifest["N"] == 1000 and manifest["chunk_size"] == 64
    assert manifest["input_names"] == ["x", "y"]
    assert len(_calls(calllog)) == 16


def test_process_pool_preserves_order(tmp_path, calllog):
    inp = _inputs(777, seed=1)
    perm = np.random.default_rng(2).permutation(777)
    inp = {k: v[perm] for k, v in inp.items()}  # unsorted grid: order must survive
    res = run_sweep(solve_product, inp, checkpoint_dir=tmp_path / "ck", chunk_size=50,
                    n_jobs=2, progress=False)
    _check_product(res, inp)
    assert res.n_chunks == 16 and len(_calls(calllog)) == 16


def test_no_checkpoint_dir_and_progress_bar_on_stderr(capsys, calllog):
    inp = _inputs(100)
    res = run_sweep(solve_product, inp, checkpoint_dir=None, chunk_size=30, n_jobs=1,
                    desc="toy")
    _check_product(res, inp)
    err = capsys.readouterr()
    assert "toy" in err.err and "toy" not in err.out


def test_input_validation(tmp_path):
    with pytest.raises(ValueError, match="equal lengths"):
        run_sweep(solve_product, {"x": np.ones(3), "y": np.ones(4)},
                  checkpoint_dir=tmp_path, n_jobs=1, progress=False)
    with pytest.raises(ValueError, match="1-D"):
        run_sweep(solve_product, {"x": np.ones((2, 2))}, checkpoint_dir=tmp_path,
                  n_jobs=1, progress=False)
    with pytest.raises(TypeError, match="pickled"):
        run_sweep(lambda x: {"status": np.zeros(len(x), int)}, {"x": np.ones(3)},
                  checkpoint_dir=None, n_jobs=2, progress=False)


def test_empty_inputs(tmp_path):
    res = run_sweep(solve_product, {"x": np.zeros(0), "y": np.zeros(0)},
                    checkpoint_dir=tmp_path / "ck", n_jobs=1, progress=False)
    assert len(res["x"]) == 0 and res["status"].dtype == np.int8


# ---------------------------------------------------------------- resuming


def test_resume_after_interrupt_computes_only_missing(tmp_path, calllog, monkeypatch):
    inp = _inputs(500)
    ck = tmp_path / "ck"
    monkeypatch.setenv("CAPBRIDGE_TEST_INTERRUPT_AT", "200")  # dies in chunk 4
    with pytest.raises(KeyboardInterrupt):
        run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
                  progress=False)
    assert len(_chunk_files(ck)) == 4
    first = _calls(calllog)
    assert len(first) == 4
    monkeypatch.delenv("CAPBRIDGE_TEST_INTERRUPT_AT")
    res = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
                    progress=False)
    _check_product(res, inp)
    assert res.reused == [0, 1, 2, 3] and res.computed == list(range(4, 10))
    calls = _calls(calllog)
    assert len(calls) == 10 and sorted(calls) == sorted(inp["x"][::50].tolist())


def test_resume_after_deleting_chunks(tmp_path, calllog):
    inp = _inputs(640)
    ck = tmp_path / "ck"
    full = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=64, n_jobs=1,
                     progress=False)
    files = _chunk_files(ck)
    for i in (1, 5, 9):
        files[i].unlink()
    calllog.unlink()
    res = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=64, n_jobs=2,
                    progress=False)
    assert res.computed == [1, 5, 9]
    assert _calls(calllog) == sorted(inp["x"][[64, 320, 576]].tolist())
    for k in full:
        np.testing.assert_array_equal(res[k], full[k])
        assert res[k].dtype == full[k].dtype


def test_complete_rerun_computes_nothing(tmp_path, calllog):
    inp = _inputs(300)
    ck = tmp_path / "ck"
    run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=100, n_jobs=1,
              progress=False)
    calllog.unlink()
    res = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=100, n_jobs=1,
                    progress=False)
    _check_product(res, inp)
    assert res.computed == [] and res.reused == [0, 1, 2] and not calllog.exists()


@pytest.mark.parametrize("damage", ["truncate", "garbage", "empty", "wrong_inputs"])
def test_corrupt_chunk_is_recomputed(tmp_path, calllog, damage):
    inp = _inputs(400)
    ck = tmp_path / "ck"
    run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=100, n_jobs=1,
              progress=False)
    victim = _chunk_files(ck)[2]
    data = victim.read_bytes()
    if damage == "truncate":
        victim.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        victim.write_bytes(b"not a zip file" * 10)
    elif damage == "empty":
        victim.write_bytes(b"")
    else:  # a sound file whose stored inputs are not this chunk's
        with np.load(victim) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["in__x"] = arrays["in__x"] + 1.0
        with open(victim, "wb") as f:
            np.savez(f, **arrays)
    calllog.unlink()
    res = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=100, n_jobs=1,
                    progress=False)
    _check_product(res, inp)
    assert res.computed == [2] and res.reused == [0, 1, 3]
    assert _calls(calllog) == [float(inp["x"][200])]
    with np.load(victim) as z:  # rewritten soundly
        np.testing.assert_array_equal(z["in__x"], inp["x"][200:300])


def test_other_solver_or_settings_are_refused(tmp_path, calllog):
    inp = _inputs(200)
    ck = tmp_path / "ck"
    run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
              progress=False)
    with pytest.raises(CheckpointMismatchError, match="solver"):
        run_sweep(solve_fails_on_negative, inp, checkpoint_dir=ck, chunk_size=50,
                  n_jobs=1, progress=False)
    with pytest.raises(CheckpointMismatchError, match="settings"):
        run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
                  progress=False, settings={"tol": 1e-9})
    assert isinstance(CheckpointMismatchError("x"), ValueError)
    before = sorted(p.name for p in ck.iterdir())
    (ck / "manifest.json").write_text("{ broken")
    with pytest.raises(CheckpointMismatchError, match="unreadable"):
        run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
                  progress=False)
    assert sorted(p.name for p in ck.iterdir()) == before   # nothing deleted


def test_other_inputs_reuse_matching_chunks(tmp_path, calllog):
    """A changed grid or chunk size is no mismatch: chunks whose inputs are unchanged
    (bitwise) are reused, whatever their index; only the others are computed."""
    inp = _inputs(200)
    ck = tmp_path / "ck"
    run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
              progress=False)
    calllog.write_text("")
    other = {k: v.copy() for k, v in inp.items()}
    other["y"][120] += 1.0                                   # chunk 2 changes
    res = run_sweep(solve_product, other, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
                    progress=False)
    _check_product(res, other)
    assert res.computed == [2] and res.reused == [0, 1, 3]
    calllog.write_text("")
    shifted = {k: v[50:] for k, v in inp.items()}          # same chunks, new indices
    res = run_sweep(solve_product, shifted, checkpoint_dir=ck, chunk_size=50, n_jobs=1,
                    progress=False)
    _check_product(res, shifted)
    assert res.computed == [] and _calls(calllog) == []
    res = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=40, n_jobs=1,
                    progress=False)                          # other cut: all recomputed
    _check_product(res, inp)
    assert len(res.computed) == 5


def test_sigkill_keeps_finished_chunks(tmp_path):
    """A real SIGKILL mid-sweep: finished chunks survive and the rerun completes."""
    ck = tmp_path / "ck"
    out = tmp_path / "out.npz"
    script = textwrap.dedent(f"""
        import sys, numpy as np
        sys.path.insert(0, {str(TESTS_DIR)!r}); sys.path.insert(0, {str(ROOT)!r})
        import test_sweep
        from capbridge.tables.sweep import run_sweep
        inp = test_sweep._inputs(400)
        res = run_sweep(test_sweep.solve_product, inp, checkpoint_dir={str(ck)!r},
                        chunk_size=10, n_jobs=1, progress=False)
        np.savez({str(out)!r}, **res)
        print(len(res.computed), len(res.reused))
    """)
    env = dict(os.environ, CAPBRIDGE_TEST_SLEEP="0.03")
    env.pop("CAPBRIDGE_TEST_INTERRUPT_AT", None)
    env.pop("CAPBRIDGE_TEST_CALLLOG", None)
    proc = subprocess.Popen([sys.executable, "-c", script], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 20
        while len(_chunk_files(ck)) < 5 and time.time() < deadline:
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait(10)
    assert proc.returncode == -signal.SIGKILL
    done = len(_chunk_files(ck))
    assert 5 <= done < 40
    for f in _chunk_files(ck):  # every file under a final name is whole
        with np.load(f) as z:
            assert len(z["out__F"]) == 10
    env.pop("CAPBRIDGE_TEST_SLEEP")
    rerun = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                           text=True, timeout=60)
    assert rerun.returncode == 0, rerun.stderr
    computed, reused = map(int, rerun.stdout.split())
    assert reused >= done and computed + reused == 40
    inp = _inputs(400)
    with np.load(out) as z:
        np.testing.assert_array_equal(z["F"], inp["x"] * inp["y"])
        assert (z["status"] == Status.CONVERGED).all()


# ---------------------------------------------------------------- failures


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_failing_chunk_is_not_converged(tmp_path, calllog, caplog, n_jobs):
    inp = _inputs(300)
    inp["y"] = np.abs(inp["y"])
    inp["y"][130] = -1.0  # chunk 2 of chunk_size 50
    inp["y"][290] = -1.0  # chunk 5
    ck = tmp_path / "ck"
    res = run_sweep(solve_fails_on_negative, inp, checkpoint_dir=ck, chunk_size=50,
                    n_jobs=n_jobs, progress=False)
    bad = np.zeros(300, bool)
    bad[100:150] = bad[250:300] = True
    assert (res["status"][bad] == Status.NOT_CONVERGED).all()
    assert (res["status"][~bad] == Status.CONVERGED).all()
    assert np.isnan(res["F"][bad]).all()
    np.testing.assert_array_equal(res["F"][~bad], (inp["x"] * inp["y"])[~bad])
    assert res["n"].dtype == np.float64  # integer output promoted to hold NaN
    assert np.isnan(res["n"][bad]).all() and (res["n"][~bad] == 1).all()
    assert [f.index for f in res.failures] == [2, 5]
    f = res.failures[0]
    assert (f.start, f.stop) == (100, 150)
    assert "RuntimeError" in f.error and "no bridge" in f.error
    assert "Traceback" in f.traceback
    assert "no bridge" in caplog.text
    recorded = json.loads((ck / "failures.json").read_text())
    assert [r["index"] for r in recorded] == [2, 5]
    assert len(_chunk_files(ck)) == 4  # failures are not checkpointed
    # a rerun retries only the failed chunks (and, once they succeed, clears the record)
    calllog.unlink()
    res2 = run_sweep(solve_fails_on_negative, inp, checkpoint_dir=ck, chunk_size=50,
                     n_jobs=1, progress=False)
    assert res2.computed == [] and res2.reused == [0, 1, 3, 4]
    assert [f.index for f in res2.failures] == [2, 5]
    assert len(_calls(calllog)) == 2


def test_dead_worker_fails_only_its_chunk(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("CAPBRIDGE_TEST_PARENT", str(os.getpid()))
    inp = _inputs(600)
    res = run_sweep(solve_crashes_in_worker, inp, checkpoint_dir=tmp_path / "ck",
                    chunk_size=50, n_jobs=2, progress=False)
    assert [f.index for f in res.failures] == [2]
    assert "worker process died" in res.failures[0].error
    bad = np.zeros(600, bool)
    bad[100:150] = True
    assert (res["status"][bad] == Status.NOT_CONVERGED).all()
    assert (res["status"][~bad] == Status.CONVERGED).all()
    np.testing.assert_array_equal(res["F"][~bad], (inp["x"] * inp["y"])[~bad])
    assert len(_chunk_files(tmp_path / "ck")) == 11


def test_invalid_output_is_a_failure(tmp_path):
    inp = _inputs(100)
    res = run_sweep(solve_no_status, inp, checkpoint_dir=tmp_path / "ck", chunk_size=50,
                    n_jobs=1, progress=False)
    assert len(res.failures) == 2 and "status" in res.failures[0].error
    assert (res["status"] == Status.NOT_CONVERGED).all()
    assert set(res) == {"x", "y", "status"}


# ---------------------------------------------------------------- Dask


def test_dask_scheduler_path(tmp_path, calllog):
    distributed = pytest.importorskip("dask.distributed")
    inp = _inputs(300)
    ck = tmp_path / "ck"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        res = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=40,
                        scheduler=cluster.scheduler_address, progress=False)
        _check_product(res, inp)
        assert res.computed == list(range(8))
        assert len(_chunk_files(ck)) == 8
        # a failing chunk on the cluster is recorded, not raised
        bad = dict(inp, y=np.where(np.arange(300) == 5, -1.0, np.abs(inp["y"])))
        res_bad = run_sweep(solve_fails_on_negative, bad, checkpoint_dir=tmp_path / "b",
                            chunk_size=40, scheduler=cluster.scheduler_address,
                            progress=False)
        assert [f.index for f in res_bad.failures] == [0]
        assert (res_bad["status"][:40] == Status.NOT_CONVERGED).all()
    # the checkpoints written through Dask are reused by a local run
    res2 = run_sweep(solve_product, inp, checkpoint_dir=ck, chunk_size=40, n_jobs=1,
                     progress=False)
    assert res2.computed == [] and res2.reused == list(range(8))
