"""Find Debian's YADE and run YADE scenes from Python (tests, CLI, benchmarks).

Two ways to run a scene were checked with YADE 2023.02a (Debian bookworm,
``yade-double``):

``launcher``
    ``yade -n -x scene.py args...``.  ``/usr/bin/yade`` is a Python script run by
    ``/usr/bin/python3``; it puts ``<libdir>/yade-double/py`` on ``sys.path``, imports
    the compiled modules and executes the scene with the whole YADE namespace
    (``O``, ``sphere``, the engines...) in its globals.  Only Debian's packages are on
    its path (numpy 1.24, scipy; no xarray/pandas/netCDF4) unless ``PYTHONPATH`` adds
    more: :func:`run_yade_script` adds the project root and, by default, the venv's
    ``site-packages`` (numpy 1.26 then shadows Debian's 1.24; YADE's modules, built
    against 1.24, work with it: numpy 1.x keeps ABI compatibility forwards).
``python``
    Any Python 3.11 with the YADE py directory on ``sys.path`` imports YADE as a plain
    module: ``import yade; from yade import *``.  :func:`ensure_yade_importable` does
    the path set-up.  Nothing of the launcher runs (no remote-control servers, no
    ``yade.runtime.opts``), which is what scripts and tests want.  The project's venv
    interpreter (``.venv/bin/python``) is used by default.

A scene written for both ways starts with::

    from capbridge.yade import yade_runtime
    yade_runtime.ensure_yade_importable()
    from yade import *              # harmless again under the launcher
    from yade import utils

and reports its result with :func:`emit_result`, one JSON line on stdout that
:func:`run_yade_script` picks out of YADE's own chatter.  Under the launcher the
scene runs in the launcher's own globals: rebinding names it uses afterwards
(``opts``, ``args``, ``par``...) makes it fail after the scene ends (seen with
``opts``), so scenes name their parsers differently.

Files read by YADE engines (``M(r=...)`` capillary files, ``capillaryfile.txt``) are
opened relative to the working directory of the YADE process: pass ``cwd``.
"""
from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

#: Marker that starts the result line a scene prints (see :func:`emit_result`).
RESULT_MARKER = "CAPBRIDGE_RESULT "

#: Root of the capbridge source tree (the directory holding the ``capbridge`` package).
PROJECT_ROOT = Path(__file__).resolve().parents[2]

_DEFAULT_EXECUTABLES = ("yade", "yade-2023.02a", "yadedaily")


class YadeNotFound(RuntimeError):
    """No usable YADE installation."""


class YadeRunError(RuntimeError):
    """A YADE scene failed, timed out or printed no result.

    Attributes ``returncode``, ``stdout``, ``stderr`` and ``cmd`` keep the details.
    """

    def __init__(self, message, *, cmd=None, returncode=None, stdout="", stderr=""):
        super().__init__(message)
        self.cmd = cmd
        self.returncode = returncode
        self.stdout = stdout
        self.stderr = stderr


@dataclasses.dataclass(frozen=True)
class YadeInstallation:
    """Where YADE lives and how to start it."""

    executable: str       #: the launcher script, e.g. /usr/bin/yade
    interpreter: str      #: the Python that runs the launcher (its shebang)
    py_dir: str           #: directory holding the ``yade`` package (.../yade-double/py)
    version: str          #: e.g. "2023.02a"
    features: tuple       #: build features listed by the launcher (CGAL, OPENMP, ...)

    def as_dict(self):
        return dataclasses.asdict(self)


def _parse_launcher(path):
    """Read interpreter, py dir, version and features out of the launcher script."""
    text = Path(path).read_text(errors="replace")
    first = text.splitlines()[0] if text else ""
    interpreter = first[2:].strip().split()[0] if first.startswith("#!") else sys.executable
    if interpreter.endswith("env"):  # "#!/usr/bin/env python3"
        interpreter = shutil.which(first.split()[-1]) or sys.executable
    py_dir = None
    m = re.search(r"sys\.path\.insert\(\s*\d+\s*,\s*['\"]([^'\"]+/py)['\"]\s*\)", text)
    if m:
        py_dir = m.group(1)
    version, features = None, ()
    m = re.search(r"features\s*,\s*version\s*,\s*debugbuild\s*=\s*'([^']*)'\.split\(' '\)\s*,\s*'([^']*)'",
                  text)
    if m:
        features = tuple(dict.fromkeys(f for f in m.group(1).split(" ") if f))
        version = m.group(2)
    if py_dir is None:
        m = re.search(r"libPATH\s*=\s*'([^']+)'", text)
        suffix = re.search(r"prefix\s*,\s*suffix\s*=.*?,\s*'([^']*)'", text)
        if m and suffix:
            py_dir = f"/usr/{m.group(1)}/yade{suffix.group(1)}/py"
    return interpreter, py_dir, version, features


def find_yade(executable=None):
    """Locate YADE.  Returns a :class:`YadeInstallation` or ``None``.

    Looks at ``executable``, then ``$CAPBRIDGE_YADE``, then ``yade`` on ``PATH``.  The
    interpreter, version and the directory of the ``yade`` Python package are read from
    the launcher script (Debian's launcher is a Python file); nothing is executed.

    >>> inst = find_yade()
    >>> inst is None or inst.py_dir.endswith("/py")
    True
    """
    candidates = [executable, os.environ.get("CAPBRIDGE_YADE")]
    candidates += [shutil.which(name) for name in _DEFAULT_EXECUTABLES]
    for cand in candidates:
        if not cand:
            continue
        path = shutil.which(cand) or cand
        if not os.path.isfile(path):
            continue
        try:
            interpreter, py_dir, version, features = _parse_launcher(path)
        except (OSError, UnicodeDecodeError, IndexError):
            continue
        if not py_dir or not os.path.isfile(os.path.join(py_dir, "yade", "__init__.py")):
            continue
        return YadeInstallation(executable=path, interpreter=interpreter, py_dir=py_dir,
                                version=version or "unknown", features=features)
    return None


def ensure_yade_importable(installation=None):
    """Make ``import yade`` work in the running interpreter; return the installation.

    Inserts the YADE py directory into ``sys.path`` and sets ``OMP_NUM_THREADS`` to 1
    unless set (it must be fixed before YADE's libraries load OpenMP, as the launcher
    does).  Under the launcher, ``yade`` is already imported and nothing changes.
    Raises :class:`YadeNotFound` if YADE is not installed.
    """
    if "yade" in sys.modules:
        return installation or find_yade()
    inst = installation or find_yade()
    if inst is None:
        raise YadeNotFound("YADE not found: install Debian's 'yade' package "
                           "or set CAPBRIDGE_YADE to the launcher")
    if inst.py_dir not in sys.path:
        sys.path.insert(1, inst.py_dir)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    return inst


def emit_result(obj, stream=None):
    """Print ``obj`` as the scene's JSON result line (read by :func:`run_yade_script`).

    Non-finite floats are written as JSON ``NaN``/``Infinity`` (Python's json accepts
    them back).
    """
    stream = stream or sys.stdout
    stream.write(RESULT_MARKER + json.dumps(obj, default=_json_default) + "\n")
    stream.flush()


def float_list(text):
    """Comma-separated floats, for scene arguments (negatives allowed: "-1e-6,0,1e-4").

    >>> float_list("-1e-6, 0,2.5,")
    [-1e-06, 0.0, 2.5]
    """
    return [float(x) for x in text.split(",") if x.strip()]


def two_fixed_spheres(r1, r2, gap, ip2, contact_law, capillary, *, detection=2.0, dt=1e-9):
    """Set up the two-sphere test scenes: call after YADE is imported.

    Two fixed spheres of radii ``r1``, ``r2`` [m] on the z axis (sphere 0 at the origin,
    sphere 1 at surface gap ``gap`` [m] above it), one ``FrictMat``; engines: collider
    and ``Ig2_Sphere_Sphere_ScGeom`` with detection factor ``detection``, the contact
    physics ``ip2`` and law ``contact_law``, then the ``capillary`` engine, then
    ``NewtonIntegrator(damping=0)``; time step ``dt``.  Returns the body ids ``(b0, b1)``.
    """
    import yade
    from yade import utils, wrapper as w

    O = yade.Omega()
    mat = O.materials.append(w.FrictMat(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5))
    b0 = O.bodies.append(utils.sphere((0, 0, 0), r1, fixed=True, material=mat))
    b1 = O.bodies.append(utils.sphere((0, 0, r1 + r2 + gap), r2, fixed=True, material=mat))
    O.engines = [
        w.ForceResetter(),
        w.InsertionSortCollider([w.Bo1_Sphere_Aabb(aabbEnlargeFactor=detection)], verletDist=0),
        w.InteractionLoop([w.Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=detection)],
                          [ip2], [contact_law]),
        capillary,
        w.NewtonIntegrator(damping=0.0),
    ]
    O.dt = dt
    return b0, b1


def box_engines(capillary, damping=0.3, gravity=(0, 0, -9.81)):
    """The engines of the test packings in a box of ``Box`` bodies (call after YADE is
    imported): collider, sphere-sphere and box-sphere contacts with the Cundall-Strack
    law, the ``capillary`` engine (e.g. ``cap.pyrunner()``), then ``NewtonIntegrator``
    with ``damping`` and ``gravity``."""
    from yade import wrapper as w
    return [w.ForceResetter(),
            w.InsertionSortCollider([w.Bo1_Sphere_Aabb(), w.Bo1_Box_Aabb()]),
            w.InteractionLoop([w.Ig2_Sphere_Sphere_ScGeom(), w.Ig2_Box_Sphere_ScGeom()],
                              [w.Ip2_FrictMat_FrictMat_FrictPhys()],
                              [w.Law2_ScGeom_FrictPhys_CundallStrack()]),
            capillary,
            w.NewtonIntegrator(damping=damping, gravity=gravity)]


def _json_default(o):
    try:
        import numpy as np
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    if hasattr(o, "__len__") and hasattr(o, "__getitem__"):  # minieigen vectors
        return [float(x) for x in o]
    return str(o)


def venv_site_packages():
    """``site-packages`` of the interpreter running this code if it is a venv, else None."""
    if sys.prefix == getattr(sys, "base_prefix", sys.prefix):
        return None
    for p in sys.path:
        if p.startswith(sys.prefix) and p.rstrip("/").endswith("site-packages"):
            return p
    return None


@dataclasses.dataclass
class YadeRun:
    """Outcome of :func:`run_yade_script`."""

    cmd: list
    returncode: int
    stdout: str
    stderr: str
    elapsed: float
    result: object = None   #: the decoded JSON of the last result line, if any


def _tail(text, n=40):
    lines = text.strip().splitlines()
    return "\n".join(lines[-n:])


def run_yade_script(script_path, args=(), timeout=300.0, *, mode="python", cwd=None,
                    env=None, installation=None, python=None, threads=1,
                    require_result=True, with_venv=True):
    """Run a YADE scene in a fresh process and return a :class:`YadeRun`.

    Parameters
    ----------
    script_path : path of the scene (a ``.py`` file).
    args : extra command-line arguments; the scene sees them in ``sys.argv[1:]``.
    timeout : seconds before the process is killed (then :class:`YadeRunError`).
    mode : ``"python"`` (default) runs ``python scene.py`` with the YADE py dir on the
        path (``python`` defaults to the interpreter running this function, e.g. the
        project venv); ``"launcher"`` runs ``yade -n -x scene.py`` (Debian's
        ``/usr/bin/python3``; the venv's site-packages are added to ``PYTHONPATH`` when
        ``with_venv``).
    cwd : working directory of the process (YADE opens its capillary files there).
    env : extra environment variables.
    threads : ``OMP_NUM_THREADS`` for the process.
    require_result : raise if the scene printed no :func:`emit_result` line.

    The project root is always put on ``PYTHONPATH`` so scenes can import capbridge.
    Raises :class:`YadeNotFound` or :class:`YadeRunError` (with the stderr tail).
    """
    inst = installation or find_yade()
    if inst is None:
        raise YadeNotFound("YADE not found (Debian package 'yade')")
    script_path = str(Path(script_path).resolve())
    run_env = dict(os.environ)
    paths = [str(PROJECT_ROOT)]
    if mode == "launcher" and with_venv and venv_site_packages():
        paths.append(venv_site_packages())
    if mode == "python":
        paths.append(inst.py_dir)
    old = run_env.get("PYTHONPATH")
    run_env["PYTHONPATH"] = os.pathsep.join(paths + ([old] if old else []))
    run_env["OMP_NUM_THREADS"] = str(int(threads))
    run_env.pop("DISPLAY", None)      # headless: no Qt, whatever the caller's session
    run_env["PYTHONUNBUFFERED"] = "1"
    if env:
        run_env.update({k: str(v) for k, v in env.items()})
    if mode == "python":
        cmd = [python or sys.executable, script_path, *map(str, args)]
    elif mode == "launcher":
        cmd = [inst.executable, "-n", "-x", script_path, *map(str, args)]
    else:
        raise ValueError(f"mode must be 'python' or 'launcher', not {mode!r}")
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, cwd=cwd, env=run_env, capture_output=True, text=True,
                              timeout=timeout, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout.decode(errors="replace") if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        err = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else (exc.stderr or "")
        raise YadeRunError(f"YADE scene {script_path} timed out after {timeout} s\n"
                           f"--- stderr tail ---\n{_tail(err)}",
                           cmd=cmd, stdout=out, stderr=err) from None
    elapsed = time.perf_counter() - t0
    run = YadeRun(cmd=cmd, returncode=proc.returncode, stdout=proc.stdout,
                  stderr=proc.stderr, elapsed=elapsed)
    for line in proc.stdout.splitlines():
        if line.startswith(RESULT_MARKER):
            run.result = json.loads(line[len(RESULT_MARKER):])
    if proc.returncode != 0:
        raise YadeRunError(f"YADE scene {script_path} failed (exit {proc.returncode})\n"
                           f"--- stderr tail ---\n{_tail(proc.stderr)}\n"
                           f"--- stdout tail ---\n{_tail(proc.stdout, 10)}",
                           cmd=cmd, returncode=proc.returncode, stdout=proc.stdout,
                           stderr=proc.stderr)
    if require_result and run.result is None:
        raise YadeRunError(f"YADE scene {script_path} printed no result line "
                           f"({RESULT_MARKER.strip()})\n--- stderr tail ---\n{_tail(proc.stderr)}",
                           cmd=cmd, returncode=proc.returncode, stdout=proc.stdout,
                           stderr=proc.stderr)
    return run


def main(argv=None):
    """``python -m capbridge.yade.yade_runtime``: print what was found, as JSON."""
    inst = find_yade()
    print(json.dumps(inst.as_dict() if inst else None, indent=2))
    return 0 if inst else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
