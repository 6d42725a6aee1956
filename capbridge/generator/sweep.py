"""Resumable, parallel sweeps of a vectorised solver over the points of a table.

:func:`run_sweep` is solver-agnostic: it cuts the flattened grid into chunks, calls a
module-level ``solve_chunk(**chunk_inputs)`` on each (in worker processes, in-process,
or on a Dask cluster), checkpoints every finished chunk atomically and reassembles the
full-length arrays in the original order.

Checkpoint directory layout
---------------------------
``manifest.json``
    ``N``, ``chunk_size``, input names, a SHA-256 of all inputs, the solver's name and
    optional ``settings``.  A directory made by a different sweep is refused
    (:class:`CheckpointMismatchError`).
``chunk_<index>_<hash>.npz``
    One finished chunk: its inputs (``in__<name>``), its outputs (``out__<name>``) and
    its position (``meta__index/start/stop``).  ``<hash>`` is a SHA-256 prefix of the
    chunk's inputs.  Files are written to a temporary name and ``os.replace``-d, so a
    kill (even SIGKILL) never leaves a half-written chunk under a final name; a file
    that cannot be read or does not match its inputs is recomputed, never trusted.
``failures.json``
    The chunks whose solver raised in the last run (absent when none did).  Failed
    chunks are *not* checkpointed: a rerun retries them.
``.tmp-*``
    Leftovers of a run killed while writing; harmless and safe to delete.
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
import traceback
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from capbridge.generator.atomic import atomic_target
from capbridge.status import Status

__all__ = ["run_sweep", "SweepResult", "ChunkFailure", "CheckpointMismatchError"]

log = logging.getLogger(__name__)

MANIFEST_NAME = "manifest.json"
FAILURES_NAME = "failures.json"
_FORMAT = "capbridge-sweep-1"
_VALID_STATUS = np.array(sorted(int(s) for s in Status))


class CheckpointMismatchError(ValueError):
    """The checkpoint directory belongs to a different sweep."""


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

    def __init__(self, arrays, *, failures=(), computed=(), reused=(), n_chunks=0):
        super().__init__(arrays)
        self.failures = list(failures)
        self.computed = sorted(computed)
        self.reused = sorted(reused)
        self.n_chunks = int(n_chunks)


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


def _load_chunk(path: Path, index, start, stop, chunk_inputs):
    """Outputs stored in ``path`` if it is a sound checkpoint of this chunk, else None."""
    try:
        # open the file ourselves: np.load leaks its handle on a truncated zip
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
        if (int(data["meta__index"]), int(data["meta__start"]),
                int(data["meta__stop"])) != (index, start, stop):
            raise ValueError("chunk position differs")
        stored_in = {k[4:]: v for k, v in data.items() if k.startswith("in__")}
        if set(stored_in) != set(chunk_inputs):
            raise ValueError("input names differ")
        for k, v in chunk_inputs.items():
            s = stored_in[k]
            if s.dtype != v.dtype or s.shape != v.shape or s.tobytes() != v.tobytes():
                raise ValueError(f"stored input {k!r} differs")
        outputs = {k[5:]: v for k, v in data.items() if k.startswith("out__")}
        return _validate_outputs(outputs, stop - start, chunk_inputs)
    except Exception as exc:  # corrupt, truncated or foreign: recompute
        log.warning("checkpoint %s is unusable (%s: %s); recomputing",
                    path.name, type(exc).__name__, exc)
        return None


def _solver_name(fn) -> str:
    base = getattr(fn, "func", fn)  # functools.partial
    return f"{getattr(base, '__module__', '?')}.{getattr(base, '__qualname__', repr(base))}"


def _prepare_manifest(ckdir: Path, manifest: dict) -> None:
    path = ckdir / MANIFEST_NAME
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise CheckpointMismatchError(
                f"checkpoint manifest {path} is unreadable ({exc}); delete the directory "
                f"or choose another checkpoint_dir") from exc
        diffs = [k for k in manifest if old.get(k) != manifest[k]]
        if diffs:
            detail = "; ".join(f"{k}: stored {old.get(k)!r}, this sweep {manifest[k]!r}"
                               for k in diffs)
            raise CheckpointMismatchError(
                f"checkpoint directory {ckdir} belongs to a different sweep ({detail}). "
                f"Use a new checkpoint_dir, or delete this one to start over.")
        return
    text = json.dumps(manifest, indent=1, sort_keys=True)
    _atomic_write(path, lambda f: f.write(text), mode="w")


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


def _iter_processes(solve_chunk, tasks, n_jobs) -> Iterator[tuple]:
    ex = cf.ProcessPoolExecutor(max_workers=max(1, min(n_jobs, len(tasks))))
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
                ex = cf.ProcessPoolExecutor(max_workers=1)
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


def _iter_dask(solve_chunk, tasks, scheduler) -> Iterator[tuple]:
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:
        raise ImportError(
            "run_sweep(scheduler=...) needs dask.distributed: "
            "pip install 'capbridge[dask]' (or 'dask[distributed]')") from exc
    own = isinstance(scheduler, str)
    client = Client(scheduler) if own else scheduler  # an existing Client is reused
    futures, clean = [], False
    try:
        futures = [client.submit(_run_chunk, solve_chunk, i, ci, pure=False)
                   for i, ci in tasks]
        index_of = {fut.key: i for fut, (i, _) in zip(futures, tasks)}
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except Exception as exc:  # e.g. KilledWorker, CancelledError
                yield _failure(index_of[fut.key], exc)
            finally:
                fut.release()
        clean = True
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
              settings: Mapping[str, Any] | None = None) -> SweepResult:
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

    Returns
    -------
    SweepResult
        A dict name -> full-length array: the inputs, then the outputs, in the original
        point order; ``status`` is int8.  ``.failures`` lists the chunks whose solver
        raised: their points have status ``NOT_CONVERGED`` and NaN outputs (an integer
        output column is then promoted to float64).  A sweep never stops on a solver
        exception; failed chunks are logged, not checkpointed, and retried by a rerun.

    Raises
    ------
    CheckpointMismatchError
        ``checkpoint_dir`` holds a sweep with other inputs, chunk size, solver or
        settings.
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
        ckdir.mkdir(parents=True, exist_ok=True)
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
        for i, ((s, e), c) in enumerate(zip(bounds, chunks)):
            path = _chunk_path(ckdir, i, hashes[i])
            if path.exists():
                out = _load_chunk(path, i, s, e, c)
                if out is not None:
                    results[i] = out
                    reused.append(i)
    pending = [i for i in range(len(bounds)) if i not in results]
    if reused:
        log.info("%s: %d of %d chunks reused from %s", desc, len(reused), len(bounds), ckdir)

    failures: dict[int, ChunkFailure] = {}
    computed: list[int] = []

    def fail(i, error, tb):
        s, e = bounds[i]
        failures[i] = ChunkFailure(i, s, e, error, tb)
        log.error("%s: chunk %d (points %d:%d) failed: %s\n%s", desc, i, s, e, error, tb)

    bar = tqdm(total=n, initial=sum(bounds[i][1] - bounds[i][0] for i in reused),
               desc=desc, unit="pt", file=sys.stderr, disable=not progress,
               dynamic_ncols=True)
    try:
        if pending:
            tasks = [(i, {k: v.copy() for k, v in chunks[i].items()}) for i in pending]
            if scheduler is not None:
                stream = _iter_dask(solve_chunk, tasks, scheduler)
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
    if ref is not None:
        for i in sorted(results):
            if set(results[i]) != set(ref):
                out = results.pop(i)
                for lst in (computed, reused):
                    if i in lst:
                        lst.remove(i)
                if ckdir is not None:  # do not trust it again: a rerun recomputes it
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
                       computed=computed, reused=reused, n_chunks=len(bounds))
