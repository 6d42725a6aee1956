"""Resumable, parallel sweeps of a vectorised solver over the points of a table.

:func:`run_sweep` is solver-agnostic: it cuts the flattened grid into chunks, calls a
module-level ``solve_chunk(**chunk_inputs)`` on each (in worker processes, in-process,
or on a Dask cluster), checkpoints every finished chunk atomically and reassembles the
full-length arrays in the original order.

Checkpoint directory layout
---------------------------
``manifest.json``
    The solver's name and optional ``settings`` (what makes a chunk's outputs valid),
    and, for information, ``N``, ``chunk_size``, input names and a SHA-256 of all
    inputs of the last sweep.  A directory made by another solver or with other
    settings is refused (:class:`CheckpointMismatchError`): its chunks would be wrong
    answers.  Other inputs (a changed grid, chunk size or number of points) are not a
    mismatch: reuse is decided chunk by chunk.
``chunk_<index>_<hash>.npz``
    One finished chunk: its inputs (``in__<name>``), its outputs (``out__<name>``) and
    its position (``meta__index/start/stop``).  ``<hash>`` is a SHA-256 prefix of the
    chunk's inputs.  A chunk of a new sweep whose inputs hash to that of a stored file,
    and whose stored inputs are bitwise equal to its own, is reused (whatever its
    index); only the others are computed.  Files are written to a temporary name and
    ``os.replace``-d, so a kill (even SIGKILL) never leaves a half-written chunk under a
    final name; a file that cannot be read or does not match its inputs is recomputed,
    never trusted.  Nothing in the directory is ever deleted by a sweep.
``failures.json``
    The chunks whose solver raised in the last run (absent when none did).  Failed
    chunks are *not* checkpointed: a rerun retries them.
``.tmp-*``
    Leftovers of a run killed while writing; harmless and safe to delete.

Faults
------
Worker processes die with the process that started them (``PR_SET_PDEATHSIG`` on
Linux, and a watchdog thread everywhere): killing the sweep leaves no orphan.  On a
Dask cluster, a sweep that has had no worker for ``worker_timeout`` seconds (default
:data:`DASK_WORKER_TIMEOUT`) marks its pending chunks failed and returns; it warns
after :data:`DASK_WORKER_WARN` seconds.  A scheduler that does not answer within
``connect_timeout`` seconds is a :class:`SchedulerUnavailableError`.
"""
from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import hashlib
import json
import logging
import os
import pickle
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from capbridge.tables.atomic import atomic_target
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError

__all__ = ["run_sweep", "SweepResult", "ChunkFailure", "CheckpointMismatchError",
           "SweepFailedError", "SchedulerUnavailableError", "DASK_WORKER_TIMEOUT"]

log = logging.getLogger(__name__)

MANIFEST_NAME = "manifest.json"
FAILURES_NAME = "failures.json"
_FORMAT = "capbridge-sweep-1"
_VALID_STATUS = np.array(sorted(int(s) for s in Status))
#: the manifest keys that make stored chunk outputs valid (other keys are informative)
_BINDING_KEYS = ("format", "solver", "settings")

DASK_WORKER_TIMEOUT = 600.0   #: [s] without any Dask worker before pending chunks fail
DASK_WORKER_WARN = 30.0       #: [s] without any Dask worker before a warning
DASK_CONNECT_TIMEOUT = 20.0   #: [s] to reach a Dask scheduler given by address
_DASK_POLL = 1.0              #: [s] between checks of the cluster while waiting


class CheckpointMismatchError(CapbridgeInputError):
    """The checkpoint directory belongs to a different solver or settings."""


class SchedulerUnavailableError(CapbridgeInputError):
    """The Dask scheduler given by address did not answer."""


class SweepFailedError(RuntimeError):
    """Some chunks of a sweep failed: nothing may be computed from their placeholders."""


@dataclasses.dataclass
class ChunkFailure:
    """A chunk whose solver raised (or returned something unusable)."""

    index: int       #: chunk index
    start: int       #: first point (inclusive) in the flattened inputs
    stop: int        #: last point (exclusive)
    error: str       #: ``"ExceptionType: message"``
    traceback: str   #: full traceback text (may be empty)

    def as_dict(self):
        return dataclasses.asdict(self)


class SweepResult(dict):
    """``dict`` name -> full-length array (inputs, outputs and ``status``).

    Extra attributes: ``failures`` (list of :class:`ChunkFailure`), ``computed``
    (indices of the chunks solved in this run), ``reused`` (indices loaded from
    checkpoints) and ``n_chunks``.
    """

    def __init__(self, arrays, *, failures=(), computed=(), reused=(), n_chunks=0,
                 checkpoint_dir=None, desc="sweep"):
        super().__init__(arrays)
        self.failures = list(failures)
        self.computed = sorted(computed)
        self.reused = sorted(reused)
        self.n_chunks = int(n_chunks)
        self.checkpoint_dir = checkpoint_dir
        self.desc = desc

    def raise_if_failed(self):
        """Raise :class:`SweepFailedError` ("N chunks failed, rerun to retry") if any
        chunk failed; return ``self`` otherwise.

        Call it before using the outputs for anything else: failed points hold
        placeholders (NaN, status NOT_CONVERGED), never results.
        """
        if not self.failures:
            return self
        first = self.failures[0]
        kept = (f"the {len(self.computed) + len(self.reused)} finished chunks are kept in "
                f"{self.checkpoint_dir}; rerun the same command to retry the failed ones"
                if self.checkpoint_dir is not None else
                "rerun to retry (with a checkpoint directory, finished chunks are kept)")
        raise SweepFailedError(
            f"{self.desc}: {len(self.failures)} of {self.n_chunks} chunks failed "
            f"(first: chunk {first.index}, points {first.start}:{first.stop}: "
            f"{first.error.splitlines()[0] if first.error else '?'}); {kept}")


# --------------------------------------------------------------------------------------
# hashing, validation and files
# --------------------------------------------------------------------------------------


def _hash_arrays(arrays: Mapping[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(b"\0")
        h.update(a.dtype.str.encode())
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _check_inputs(inputs: Mapping[str, Any]) -> tuple[dict[str, np.ndarray], int]:
    if not isinstance(inputs, Mapping) or not inputs:
        raise ValueError("inputs must be a non-empty dict name -> 1-D array")
    out, n = {}, None
    for name, value in inputs.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"input names must be non-empty strings, got {name!r}")
        if name == "status":
            raise ValueError("'status' is reserved for the solver output")
        a = np.asarray(value)
        if a.ndim != 1:
            raise ValueError(f"input {name!r} must be 1-D, got shape {a.shape}")
        if a.dtype.hasobject:
            raise ValueError(f"input {name!r} has object dtype; use a numeric dtype")
        if n is None:
            n = len(a)
        elif len(a) != n:
            lengths = {k: len(np.asarray(v)) for k, v in inputs.items()}
            raise ValueError(f"inputs must have equal lengths, got {lengths}")
        out[name] = np.ascontiguousarray(a)
    return out, int(n)


def _validate_outputs(out: Any, m: int, input_names) -> dict[str, np.ndarray]:
    """Outputs of one chunk as a dict of 1-D arrays of length ``m`` (else ValueError)."""
    if not isinstance(out, Mapping):
        raise ValueError(f"solve_chunk must return a dict, got {type(out).__name__}")
    if "status" not in out:
        raise ValueError("solve_chunk output has no 'status' array")
    res = {}
    for name, value in out.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"output names must be non-empty strings, got {name!r}")
        if name in input_names:
            raise ValueError(f"output {name!r} has the name of an input")
        a = np.asarray(value)
        if a.ndim != 1 or len(a) != m:
            raise ValueError(f"output {name!r} has shape {a.shape}, expected ({m},)")
        if a.dtype.hasobject:
            raise ValueError(f"output {name!r} has object dtype")
        res[name] = a
    st = res["status"]
    if st.dtype.kind not in "iu":
        raise ValueError(f"'status' must be an integer array, got dtype {st.dtype}")
    bad = ~np.isin(st, _VALID_STATUS)
    if bad.any():
        raise ValueError(f"'status' has codes outside capbridge.status.Status: "
                         f"{sorted(set(st[bad].tolist()))}")
    return res


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _atomic_write(path: Path, write: Callable[[Any], None], mode: str = "wb") -> None:
    """Write ``path`` through a temp file in the same directory, then ``os.replace``."""
    with atomic_target(path) as tmp:
        with open(tmp, mode) as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
    _fsync_dir(path.parent)


def _chunk_path(ckdir: Path, index: int, chunk_hash: str) -> Path:
    return ckdir / f"chunk_{index:06d}_{chunk_hash[:16]}.npz"


def _save_chunk(path: Path, index, start, stop, chunk_inputs, outputs) -> None:
    arrays = {f"in__{k}": v for k, v in chunk_inputs.items()}
    arrays.update({f"out__{k}": v for k, v in outputs.items()})
    arrays["meta__index"] = np.int64(index)
    arrays["meta__start"] = np.int64(start)
    arrays["meta__stop"] = np.int64(stop)
    _atomic_write(path, lambda f: np.savez(f, **arrays))


def _load_chunk(path: Path, chunk_inputs):
    """Outputs stored in ``path`` if it is a sound checkpoint of these inputs, else None.

    The stored inputs must equal ``chunk_inputs`` bitwise (names, dtypes, values); the
    chunk's position in the sweep that wrote it does not matter.
    """
    try:
        # open the file ourselves: np.load leaks its handle on a truncated zip
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
        stored_in = {k[4:]: v for k, v in data.items() if k.startswith("in__")}
        if set(stored_in) != set(chunk_inputs):
            raise ValueError("input names differ")
        for k, v in chunk_inputs.items():
            s = stored_in[k]
            if s.dtype != v.dtype or s.shape != v.shape or s.tobytes() != v.tobytes():
                raise ValueError(f"stored input {k!r} differs")
        outputs = {k[5:]: v for k, v in data.items() if k.startswith("out__")}
        m = len(next(iter(chunk_inputs.values())))
        return _validate_outputs(outputs, m, chunk_inputs)
    except Exception as exc:  # corrupt, truncated or foreign: recompute
        log.warning("checkpoint %s is unusable (%s: %s); recomputing",
                    path.name, type(exc).__name__, exc)
        return None


def _solver_name(fn) -> str:
    base = getattr(fn, "func", fn)  # functools.partial
    return f"{getattr(base, '__module__', '?')}.{getattr(base, '__qualname__', repr(base))}"


def _prepare_manifest(ckdir: Path, manifest: dict) -> None:
    """Refuse a directory of another solver or settings; record this sweep's manifest.

    Only :data:`_BINDING_KEYS` decide: other inputs are matched chunk by chunk.
    """
    path = ckdir / MANIFEST_NAME
    if path.exists():
        try:
            old = json.loads(path.read_text())
            if not isinstance(old, dict):
                raise ValueError("not a JSON object")
        except (OSError, ValueError) as exc:
            raise CheckpointMismatchError(
                f"checkpoint manifest {path} is unreadable ({exc}); choose another "
                f"checkpoint directory (nothing in this one was changed)") from None
        diffs = [k for k in _BINDING_KEYS if old.get(k) != manifest[k]]
        if diffs:
            detail = "; ".join(f"{k}: stored {old.get(k)!r}, this sweep {manifest[k]!r}"
                               for k in diffs)
            raise CheckpointMismatchError(
                f"checkpoint directory {ckdir} belongs to a different solver or settings "
                f"({detail}); its chunks do not answer this sweep. Choose another "
                f"checkpoint directory (nothing in this one was changed).")
        if all(old.get(k) == v for k, v in manifest.items()):
            return
    text = json.dumps(manifest, indent=1, sort_keys=True)
    _atomic_write(path, lambda f: f.write(text), mode="w")


def _stored_chunks(ckdir: Path) -> dict[str, list[Path]]:
    """Chunk files of a checkpoint directory by the hash prefix in their names."""
    found: dict[str, list[Path]] = {}
    for p in ckdir.glob("chunk_*_*.npz"):
        found.setdefault(p.stem.rsplit("_", 1)[-1], []).append(p)
    return found


# --------------------------------------------------------------------------------------
# execution back-ends; each yields (index, outputs | None, error | None, traceback)
# --------------------------------------------------------------------------------------


def _run_chunk(solve_chunk, index, chunk_inputs):
    """Call the solver on one chunk; exceptions (not KeyboardInterrupt) are returned."""
    try:
        return index, solve_chunk(**chunk_inputs), None, ""
    except Exception as exc:
        return index, None, f"{type(exc).__name__}: {exc}", traceback.format_exc()


def _iter_serial(solve_chunk, tasks) -> Iterator[tuple]:
    for index, chunk_inputs in tasks:
        yield _run_chunk(solve_chunk, index, chunk_inputs)


def _failure(index, exc, prefix=""):
    return (index, None, f"{prefix}{type(exc).__name__}: {exc}",
            "".join(traceback.format_exception(exc)))


def _die_with_parent(parent_pid: int) -> None:
    """Worker initializer: end this process when ``parent_pid`` goes away.

    A killed sweep must not leave workers computing for nobody (or waiting forever on
    the task queue).  Linux's ``PR_SET_PDEATHSIG`` kills at once; a daemon thread
    polling the parent id covers other systems and a parent that died before the
    ``prctl`` call.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, 9, 0, 0, 0)  # PR_SET_PDEATHSIG = 1, SIGKILL = 9
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch():
        while True:
            time.sleep(1.0)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="capbridge-parent-watch", daemon=True).start()


def _pool(n):
    return cf.ProcessPoolExecutor(max_workers=n, initializer=_die_with_parent,
                                  initargs=(os.getpid(),))


def _iter_processes(solve_chunk, tasks, n_jobs) -> Iterator[tuple]:
    ex = _pool(max(1, min(n_jobs, len(tasks))))
    clean, broken = False, []
    try:
        futures = {ex.submit(_run_chunk, solve_chunk, i, ci): i for i, ci in tasks}
        for fut in cf.as_completed(futures):
            try:
                yield fut.result()
            except cf.process.BrokenProcessPool:
                broken.append(futures[fut])  # a worker died (crash, OOM kill...)
            except Exception as exc:
                yield _failure(futures[fut], exc)
        clean = True
    finally:
        ex.shutdown(wait=clean, cancel_futures=not clean)
    if broken:
        # only the chunk(s) running in the dead worker are guilty; retry every victim
        # in its own single-use process so that a crashing chunk takes down only itself
        log.warning("a worker process died; retrying %d chunk(s) one process each",
                    len(broken))
        retry = set(broken)
        yield from _iter_isolated(solve_chunk, [t for t in tasks if t[0] in retry],
                                  n_jobs)


def _iter_isolated(solve_chunk, tasks, n_jobs) -> Iterator[tuple]:
    pending, active = list(tasks), {}
    try:
        while pending or active:
            while pending and len(active) < n_jobs:
                i, ci = pending.pop(0)
                ex = _pool(1)
                active[ex.submit(_run_chunk, solve_chunk, i, ci)] = (i, ex)
            done, _ = cf.wait(active, return_when=cf.FIRST_COMPLETED)
            for fut in done:
                i, ex = active.pop(fut)
                try:
                    result = fut.result()
                except Exception as exc:
                    result = _failure(i, exc, "worker process died: ")
                ex.shutdown(wait=True)
                yield result
    finally:
        for fut, (_, ex) in active.items():
            ex.shutdown(wait=False, cancel_futures=True)


def _n_workers(client) -> int:
    try:
        return len(client.scheduler_info().get("workers", {}))
    except Exception:  # scheduler gone or busy: no worker we can count on
        return 0


def _iter_dask(solve_chunk, tasks, scheduler, worker_timeout=DASK_WORKER_TIMEOUT,
               connect_timeout=DASK_CONNECT_TIMEOUT) -> Iterator[tuple]:
    try:
        from dask.distributed import Client, wait
    except ImportError as exc:
        raise ImportError(
            "run_sweep(scheduler=...) needs dask.distributed: "
            "pip install 'capbridge[dask]' (or 'dask[distributed]')") from exc
    own = isinstance(scheduler, str)
    if own:
        try:
            client = Client(scheduler, timeout=connect_timeout)
        except (OSError, TimeoutError, ValueError) as exc:
            first = str(exc).splitlines()[0] if str(exc) else ""
            raise SchedulerUnavailableError(
                f"Dask scheduler {scheduler!r} did not answer within {connect_timeout:g} s "
                f"({type(exc).__name__}: {first}); give the address of a running "
                f"scheduler, e.g. tcp://host:8786") from None
    else:
        client = scheduler  # an existing Client is reused
    futures, clean = [], False
    try:
        futures = [client.submit(_run_chunk, solve_chunk, i, ci, pure=False)
                   for i, ci in tasks]
        index_of = {fut.key: i for fut, (i, _) in zip(futures, tasks)}
        pending, idle_since, warned = set(futures), None, False
        while pending:
            try:
                done, pending = wait(pending, timeout=_DASK_POLL,
                                     return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = set()
            except Exception:  # e.g. FuturesCancelledError: the scheduler was lost
                done = {f for f in pending
                        if f.done() or f.status in ("cancelled", "lost", "error")}
                pending = pending - done
            for fut in done:
                try:
                    yield fut.result()
                except Exception as exc:  # e.g. KilledWorker, CancelledError
                    yield _failure(index_of[fut.key], exc)
                finally:
                    fut.release()
            if done or _n_workers(client) > 0:
                idle_since, warned = None, False
                continue
            now = time.monotonic()
            idle_since = idle_since or now
            if now - idle_since >= DASK_WORKER_WARN and not warned:
                warned = True
                log.warning("no Dask worker for %.0f s; %d chunk(s) waiting (they fail "
                            "after %.0f s without a worker)", now - idle_since,
                            len(pending), worker_timeout)
            if now - idle_since >= worker_timeout:
                msg = (f"no Dask worker on the cluster for {worker_timeout:g} s "
                       f"(worker_timeout)")
                log.error("%s: %d pending chunk(s) marked failed", msg, len(pending))
                for fut in pending:
                    yield index_of[fut.key], None, f"NoWorkers: {msg}", ""
                break
        clean = not pending
    finally:
        if futures and not clean:
            try:
                client.cancel(futures)
            except Exception:
                pass
        if own:
            client.close()


def _missing(dtype: np.dtype, m: int) -> np.ndarray:
    """Fill values of a failed chunk: NaN (integers promoted to float64), NaT, or zeros."""
    if dtype.kind in "fc":
        return np.full(m, np.nan, dtype)
    if dtype.kind in "biu":
        return np.full(m, np.nan, np.float64)
    if dtype.kind in "mM":
        return np.full(m, np.datetime64("NaT") if dtype.kind == "M"
                       else np.timedelta64("NaT"), dtype)
    return np.zeros(m, dtype)


# --------------------------------------------------------------------------------------
# the sweep
# --------------------------------------------------------------------------------------


def run_sweep(solve_chunk: Callable[..., Mapping[str, Any]],
              inputs: Mapping[str, Any], *,
              checkpoint_dir: str | os.PathLike | None,
              chunk_size: int = 256,
              n_jobs: int | None = None,
              scheduler: Any = None,
              progress: bool = True,
              desc: str = "sweep",
              settings: Mapping[str, Any] | None = None,
              worker_timeout: float = DASK_WORKER_TIMEOUT,
              connect_timeout: float = DASK_CONNECT_TIMEOUT) -> SweepResult:
    """Solve ``solve_chunk`` over all points of ``inputs``, in parallel and resumably.

    Parameters
    ----------
    solve_chunk : callable
        ``solve_chunk(**chunk_inputs) -> dict name -> 1-D array`` of the chunk's length,
        including an integer ``"status"`` array (:class:`capbridge.status.Status`).
        Must be a picklable module-level function (or a ``functools.partial`` of one)
        unless ``n_jobs=1``.  Output names must differ from input names.
    inputs : dict name -> 1-D array
        The flattened grid points; all arrays of the same length ``N``.
    checkpoint_dir : path or None
        Directory of the checkpoints (created if needed); see the module docstring.
        ``None`` disables checkpointing (nothing is resumable).
    chunk_size : int
        Points per chunk (the unit of work, of checkpointing and of failure).
    n_jobs : int or None
        Worker processes (``concurrent.futures.ProcessPoolExecutor``); ``None`` uses
        ``os.cpu_count()``; ``1`` runs in-process (debugging, tests: a
        ``KeyboardInterrupt`` raised by the solver then stops the sweep, keeping the
        chunks finished so far).
    scheduler : str or dask.distributed.Client, optional
        A Dask scheduler address (e.g. ``"tcp://127.0.0.1:8786"``) or a live Client;
        chunks then run on that cluster (``n_jobs`` is ignored) and this process writes
        the checkpoints.
    progress : bool
        Show a tqdm progress bar (points) on stderr.
    desc : str
        Label of the progress bar.
    settings : dict, optional
        JSON-serialisable description of the solver settings, stored in the manifest:
        a checkpoint directory made with other settings is refused.
    worker_timeout : float
        Dask only: seconds without any worker on the cluster after which the pending
        chunks are marked failed (default :data:`DASK_WORKER_TIMEOUT`, 600 s).
    connect_timeout : float
        Dask only: seconds to reach a scheduler given by address.

    Returns
    -------
    SweepResult
        A dict name -> full-length array: the inputs, then the outputs, in the original
        point order; ``status`` is int8.  ``.failures`` lists the chunks whose solver
        raised: their points have status ``NOT_CONVERGED`` and NaN outputs (an integer
        output column is then promoted to float64).  A sweep never stops on a solver
        exception; failed chunks are logged, not checkpointed, and retried by a rerun.
        Call ``.raise_if_failed()`` before computing anything from the outputs.

    Raises
    ------
    CheckpointMismatchError
        ``checkpoint_dir`` holds a sweep of another solver or other settings, or its
        manifest is unreadable, or it cannot be created or written.
    SchedulerUnavailableError
        ``scheduler`` is an address that does not answer.
    """
    from tqdm import tqdm

    arrays, n = _check_inputs(inputs)
    chunk_size = int(chunk_size)
    if chunk_size < 1:
        raise ValueError(f"chunk_size must be >= 1, got {chunk_size}")
    if n_jobs is None:
        n_jobs = os.cpu_count() or 1
    n_jobs = int(n_jobs)
    if n_jobs < 1:
        raise ValueError(f"n_jobs must be >= 1, got {n_jobs}")
    if scheduler is not None or n_jobs > 1:
        try:
            pickle.dumps(solve_chunk)
        except Exception as exc:
            raise TypeError(
                f"solve_chunk {solve_chunk!r} cannot be pickled ({exc}); it must be a "
                f"module-level function to run in other processes (or use n_jobs=1)"
            ) from exc

    bounds = [(s, min(s + chunk_size, n)) for s in range(0, n, chunk_size)]
    chunks = [{k: v[s:e] for k, v in arrays.items()} for s, e in bounds]
    hashes = [_hash_arrays(c) for c in chunks]

    ckdir = None
    if checkpoint_dir is not None:
        ckdir = Path(checkpoint_dir)
        try:
            ckdir.mkdir(parents=True, exist_ok=True)
            _check_writable_dir(ckdir)
        except OSError as exc:
            raise CheckpointMismatchError(
                f"checkpoint directory {ckdir} cannot be used: "
                f"{exc.strerror or exc} ({type(exc).__name__})") from None
        if settings is not None:
            settings = json.loads(json.dumps(settings, sort_keys=True, default=str))
        _prepare_manifest(ckdir, {
            "format": _FORMAT,
            "N": n,
            "chunk_size": chunk_size,
            "input_names": sorted(arrays),
            "input_dtypes": {k: arrays[k].dtype.str for k in sorted(arrays)},
            "inputs_hash": _hash_arrays(arrays),
            "solver": _solver_name(solve_chunk),
            "settings": settings,
        })

    results: dict[int, dict[str, np.ndarray]] = {}
    reused: list[int] = []
    if ckdir is not None:
        stored = _stored_chunks(ckdir)
        for i, c in enumerate(chunks):
            own = _chunk_path(ckdir, i, hashes[i])
            candidates = sorted(stored.get(hashes[i][:16], []), key=lambda p: p != own)
            for path in candidates:
                out = _load_chunk(path, c)
                if out is not None:
                    results[i] = out
                    reused.append(i)
                    break
    pending = [i for i in range(len(bounds)) if i not in results]
    if reused:
        log.info("%s: %d of %d chunks reused from %s", desc, len(reused), len(bounds), ckdir)

    failures: dict[int, ChunkFailure] = {}
    computed: list[int] = []

    def fail(i, error, tb):
        s, e = bounds[i]
        failures[i] = ChunkFailure(i, s, e, error, tb)
        # one line for the user; the traceback goes to failures.json and the debug log
        where = f" (traceback in {ckdir / FAILURES_NAME})" if ckdir is not None and tb else ""
        log.error("%s: chunk %d (points %d:%d) failed: %s%s", desc, i, s, e,
                  error.splitlines()[0] if error else "?", where)
        if tb:
            log.debug("%s: chunk %d traceback:\n%s", desc, i, tb)

    bar = tqdm(total=n, initial=sum(bounds[i][1] - bounds[i][0] for i in reused),
               desc=desc, unit="pt", file=sys.stderr, disable=not progress,
               dynamic_ncols=True)
    try:
        if pending:
            tasks = [(i, {k: v.copy() for k, v in chunks[i].items()}) for i in pending]
            if scheduler is not None:
                stream = _iter_dask(solve_chunk, tasks, scheduler, worker_timeout,
                                    connect_timeout)
            elif n_jobs == 1:
                stream = _iter_serial(solve_chunk, tasks)
            else:
                stream = _iter_processes(solve_chunk, tasks, n_jobs)
            try:
                for i, out, error, tb in stream:
                    s, e = bounds[i]
                    if error is None:
                        try:
                            out = _validate_outputs(out, e - s, arrays)
                        except ValueError as exc:
                            error, tb = f"invalid solver output: {exc}", ""
                    if error is None:
                        if ckdir is not None:
                            _save_chunk(_chunk_path(ckdir, i, hashes[i]), i, s, e,
                                        chunks[i], out)
                        results[i] = out
                        computed.append(i)
                    else:
                        fail(i, error, tb)
                    bar.update(e - s)
                    if failures:
                        bar.set_postfix(failed=len(failures), refresh=False)
            finally:
                close = getattr(stream, "close", None)
                if close is not None:
                    close()
    finally:
        bar.close()

    # reference outputs: those of the first successful chunk
    ref = next((results[i] for i in range(len(bounds)) if i in results), None)
    computed_now = set(computed)
    if ref is not None:
        for i in sorted(results):
            if set(results[i]) != set(ref):
                out = results.pop(i)
                for lst in (computed, reused):
                    if i in lst:
                        lst.remove(i)
                if ckdir is not None and i in computed_now:
                    # written by this run and inconsistent: a rerun recomputes it
                    _chunk_path(ckdir, i, hashes[i]).unlink(missing_ok=True)
                fail(i, f"outputs {sorted(out)} differ from those of chunk "
                        f"{min(results)}: {sorted(ref)}", "")

    if ckdir is not None:
        fpath = ckdir / FAILURES_NAME
        if failures:
            text = json.dumps([failures[i].as_dict() for i in sorted(failures)], indent=1)
            _atomic_write(fpath, lambda f: f.write(text), mode="w")
        elif fpath.exists():
            fpath.unlink()

    out_arrays: dict[str, np.ndarray] = {k: v.copy() for k, v in arrays.items()}
    names = list(ref) if ref is not None else ["status"]
    for name in names:
        parts = []
        for i, (s, e) in enumerate(bounds):
            if i in results:
                parts.append(results[i][name])
            elif name == "status":
                parts.append(np.full(e - s, int(Status.NOT_CONVERGED), np.int8))
            else:
                parts.append(_missing(ref[name].dtype, e - s))
        if name == "status":
            out_arrays[name] = (np.concatenate(parts) if parts
                                else np.empty(0, np.int8)).astype(np.int8)
        else:
            out_arrays[name] = np.concatenate(parts) if parts else ref[name][:0].copy()

    if failures:
        pts = sum(f.stop - f.start for f in failures.values())
        log.warning("%s: %d of %d chunks failed (%d points set to NOT_CONVERGED)",
                    desc, len(failures), len(bounds), pts)
    return SweepResult(out_arrays, failures=[failures[i] for i in sorted(failures)],
                       computed=computed, reused=reused, n_chunks=len(bounds),
                       checkpoint_dir=ckdir, desc=desc)


def _check_writable_dir(path: Path) -> None:
    """Raise ``OSError`` unless a file can be created in ``path`` (``os.access`` says
    yes to root even where writing fails)."""
    import tempfile

    with tempfile.NamedTemporaryFile(dir=path, prefix=".tmp-probe-"):
        pass
