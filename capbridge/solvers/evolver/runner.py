"""Running ``evolver`` non-interactively: subprocess, temp dir, time-out, process pool.

Each run loads one datafile (or dump), reads commands from a file (``evolver -x -f``),
with stdin closed so that it can never wait at its prompt.  The process is started in a
new session; on time-out the whole process group is killed, and (Linux) the kernel kills
it if the Python thread that started it dies (a killed sweep leaves no orphan running).
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

EVOLVER = os.environ.get("CAPBRIDGE_EVOLVER", "evolver")

#: Messages from Evolver that mean the run cannot be trusted.
_ERROR_MARKERS = ("ERROR", "syntax error", "Syntax error", "Segmentation", "Internal error")


def _die_with_parent():
    """``preexec_fn``: ask the kernel to SIGKILL the child when the thread that started it
    dies (Linux ``PR_SET_PDEATHSIG``), so that a killed sweep or script leaves no
    ``evolver`` running on its own (it runs in a session of its own, which a terminal's
    Ctrl-C or a ``kill`` of the Python process does not reach).  Only an async-signal-safe
    system call runs between fork and exec."""
    if _PRCTL is not None:
        _PRCTL(1, signal.SIGKILL, 0, 0, 0)      # PR_SET_PDEATHSIG = 1


def _load_prctl():
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl
    except (OSError, AttributeError):
        return None


_PRCTL = _load_prctl()


def evolver_path():
    """Absolute path of the evolver binary, or None if it is not installed."""
    return shutil.which(EVOLVER)


def available():
    return evolver_path() is not None


class EvolverNotFound(RuntimeError):
    pass


@dataclass
class RunOutput:
    stdout: str
    stderr: str
    returncode: int | None
    elapsed: float          # wall-clock seconds
    cpu: float              # user + system CPU seconds of the child
    timed_out: bool
    workdir: str

    @property
    def error_lines(self):
        lines = (self.stdout + "\n" + self.stderr).splitlines()
        return [ln for ln in lines if any(m in ln for m in _ERROR_MARKERS)]

    @property
    def ok(self):
        return (not self.timed_out) and self.returncode == 0 and not self.error_lines


def run_evolver(datafile, commands, workdir, timeout=60.0, name="run"):
    """Run ``evolver -x -f <name>.cmd <datafile>`` in ``workdir``.

    ``datafile`` is a path (relative paths are taken in ``workdir``); ``commands`` the
    text of the command file, which should end with ``quit``.
    """
    exe = evolver_path()
    if exe is None:
        raise EvolverNotFound("Surface Evolver ('evolver') is not on PATH; "
                              "install Debian's evolver-nox")
    cmdfile = os.path.join(workdir, f"{name}.cmd")
    with open(cmdfile, "w") as fh:
        fh.write(commands)
        if not commands.rstrip().endswith("quit"):
            fh.write("\nquit\n")
    t0 = time.monotonic()
    proc = subprocess.Popen([exe, "-x", "-f", os.path.basename(cmdfile), str(datafile)],
                            cwd=workdir, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, errors="replace",
                            start_new_session=True,
                            preexec_fn=_die_with_parent if _PRCTL is not None else None)
    chunks = {"out": [], "err": []}

    def _reader(stream, key):
        for line in stream:
            chunks[key].append(line)

    readers = [threading.Thread(target=_reader, args=(proc.stdout, "out"), daemon=True),
               threading.Thread(target=_reader, args=(proc.stderr, "err"), daemon=True)]
    for t in readers:
        t.start()
    timed_out = False
    status, usage = 0, None
    deadline = t0 + timeout
    try:
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid != 0:
                break
            if time.monotonic() > deadline:
                timed_out = True
                _kill_group(proc)
                pid, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.01)
    except BaseException:
        _kill_group(proc)
        try:
            os.wait4(proc.pid, 0)
        except ChildProcessError:
            pass
        proc.returncode = -9
        raise
    proc.returncode = os.waitstatus_to_exitcode(status)
    # the evolver process is gone; kill any leftover of its group (none expected)
    _kill_group(proc)
    for t in readers:
        t.join(timeout=5)
    cpu = (usage.ru_utime + usage.ru_stime) if usage is not None else float("nan")
    return RunOutput("".join(chunks["out"]), "".join(chunks["err"]), proc.returncode,
                     time.monotonic() - t0, cpu, timed_out, workdir)


def _kill_group(proc):
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


class Workdir:
    """Temporary directory removed on exit unless ``keep`` (or env CAPBRIDGE_KEEP_RUNS)."""

    def __init__(self, keep=None, prefix="capbridge-ev-"):
        self.keep = bool(os.environ.get("CAPBRIDGE_KEEP_RUNS")) if keep is None else keep
        self.path = tempfile.mkdtemp(prefix=prefix)

    def __enter__(self):
        return self.path

    def __exit__(self, *exc):
        if not self.keep:
            shutil.rmtree(self.path, ignore_errors=True)
        return False


def default_workers():
    """Evolver processes to run at once: CAPBRIDGE_EVOLVER_WORKERS or min(2, cores)."""
    env = os.environ.get("CAPBRIDGE_EVOLVER_WORKERS")
    if env:
        return max(1, int(env))
    return max(1, min(2, os.cpu_count() or 1))


def parallel_map(fn, items, workers=None):
    """``[fn(x) for x in items]`` with up to ``workers`` Evolver runs at once (threads
    that wait on subprocesses).  Results keep the order of ``items``."""
    items = list(items)
    workers = default_workers() if workers is None else max(1, int(workers))
    if workers == 1 or len(items) <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(max_workers=workers) as ex:
        return list(ex.map(fn, items))
