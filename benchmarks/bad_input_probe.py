"""Bad inputs and faults of issue 16, tried as a user would, and counted.

    .venv/bin/python benchmarks/bad_input_probe.py [--yade] [--only ITEM] [--json PATH]

Every case is a user action (a CLI command run in-process through ``capbridge.cli.main``,
a Python API call, a tampered table, an engine option) with what a user must get:
``error`` (one line naming the value and what is allowed: ``capbridge: error: ...`` and
exit 2 on the command line, one :class:`~capbridge.validation.CapbridgeInputError` in
Python), ``flag`` (a result whose status says it is not a converged number), or
``number`` (the right number, checked against an independent answer).  Each outcome is
one of: clean error, flagged, right number, wrong number (a number, or a success status,
where an error, a flag or another number was due), traceback or cryptic error (any other
exception, exit 1, a message of several lines or without the value), crash (the process
or the YADE runner died), data lost (a file the user had was changed or removed).

``tests/test_bad_input_probe.py`` runs every case (YADE cases included) and asserts no
wrong number, traceback, crash or lost data; the closing note quotes this script's
counts.
"""
from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import shutil
import sys
import tempfile
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from capbridge.validation import CapbridgeInputError  # noqa: E402

OUTCOMES = ("clean error", "flagged", "right number", "wrong number",
            "traceback or cryptic error", "crash", "data lost")


@dataclass
class Case:
    item: str                      # the item number
    name: str
    expect: str                    # "error" | "flag" | "number"
    run: Callable                  # (tmp: Path) -> Result
    words: tuple = ()              # an error must name these
    yade: bool = False


@dataclass
class Result:
    kind: str                      # "error" | "flag" | "number" | "wrong" | "traceback" | "crash" | "lost"
    detail: str = ""
    message: str = ""


@dataclass
class Outcome:
    case: Case
    outcome: str
    detail: str = ""
    extra: dict = field(default_factory=dict)


# ------------------------------------------------------------------ running one action

def cli(*args):
    """``capbridge ARGS`` in-process -> Result: exit 2 with one error line is an error,
    3 a flag (not converged), 0 a number, anything else a traceback."""
    from capbridge.cli import main

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main([str(a) for a in args])
    except SystemExit as exc:                      # argparse
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException as exc:                   # a traceback reached the user
        return Result("traceback", f"{type(exc).__name__}: {exc}")
    text = err.getvalue().strip()
    if code == 2:
        lines = text.splitlines()
        if len(lines) == 1 and lines[0].startswith("capbridge: error: ") and \
                "Traceback" not in text:
            return Result("error", message=lines[0])
        # argparse's own errors print usage first: still one error line, exit 2
        if lines and lines[-1].startswith("capbridge") and ": error: " in lines[-1] and \
                "Traceback" not in text:
            return Result("error", message=lines[-1])
        return Result("traceback", text[-300:])
    if code == 3:
        return Result("flag", out.getvalue()[-300:], message=text)
    if code == 0:
        try:                       # a JSON answer whose status is not converged: a flag
            status = json.loads(out.getvalue()).get("status", "converged")
        except (ValueError, AttributeError):
            status = "converged"
        if status != "converged":
            return Result("flag", f"status {status}")
        return Result("number", out.getvalue())
    return Result("traceback", f"exit {code}: {text[-300:]}")


def api(fn):
    """A Python call -> Result("error") for one clean CapbridgeInputError line, the
    return value inside Result("number") otherwise (the case judges it)."""
    try:
        value = fn()
    except CapbridgeInputError as exc:
        msg = str(exc)
        if "\n" in msg or not msg.strip():
            return Result("traceback", msg)
        return Result("error", message=msg)
    except Exception as exc:
        return Result("traceback", f"{type(exc).__name__}: {exc}\n"
                                   + "".join(traceback.format_exc(limit=3))[-400:])
    r = Result("number")
    r.value = value
    return r


def judge(case, res):
    """The outcome of a case from what it returned."""
    if res.kind in ("wrong", "traceback", "crash", "lost"):
        return {"wrong": "wrong number", "traceback": "traceback or cryptic error",
                "crash": "crash", "lost": "data lost"}[res.kind]
    if res.kind == "error":
        if case.expect == "error":
            missing = [w for w in case.words if w.lower() not in res.message.lower()]
            # an option that does not exist is not the check the case asks for
            odd = "unrecognized arguments" in res.message
            return "traceback or cryptic error" if missing or odd else "clean error"
        if case.expect == "flag":
            return "clean error"      # refusing up front is as good as a flag
        return "wrong number"         # an answer was due
    if res.kind == "flag":
        return "flagged" if case.expect in ("flag", "error") else "wrong number"
    # a number
    return "right number" if case.expect == "number" else "wrong number"


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest() if Path(path).exists() else None


# ------------------------------------------------------------------ the cases

def _surrogates():
    from capbridge.dem.triplet_clusters import load_surrogate
    from capbridge.surrogate.triplet import default_table

    return load_surrogate(default_table())


_CACHE = {}


def sur():
    if "t" not in _CACHE:
        _CACHE["t"] = _surrogates()
    return _CACHE["t"]


def dbl():
    if "d" not in _CACHE:
        from capbridge.dem.bridges import default_table_path
        from capbridge.surrogate.doublet import DoubletSurrogate

        _CACHE["d"] = DoubletSurrogate().fit(default_table_path())
    return _CACHE["d"]


def _contact_cases():
    from capbridge.dem.triplet_clusters import triangle_centres
    from capbridge.status import HAS_RESULT

    def rebuilt(n=400):
        s = sur()
        rng = np.random.default_rng(7)
        d23 = rng.uniform(s.gaps_[0], s.gaps_[-1], n)
        t = rng.uniform(s.theta_[0], s.theta_[-1], n)
        z = np.zeros(n)
        V = rng.uniform(1.05, 1.9, n) * s.coalescence_volume(z, z, d23, t)["volume_coalescence"]
        C = triangle_centres(2 + z, 2 + z, 2 + d23)

        def run(_):
            r = api(lambda: [s.predict_vectors(C[k], V[k], t[k]) for k in range(n)])
            if r.kind != "number":
                return r
            ref = s.predict(z, z, d23, V, t)
            f = np.array([float(x["f23"]) for x in r.value])
            ok = np.allclose(f, ref["f23"], rtol=1e-12, equal_nan=True) and \
                np.array_equal([int(x["status"]) for x in r.value], ref["status"])
            has = np.isin(ref["status"], HAS_RESULT).mean()
            return Result("number" if ok else "wrong", f"{has:.0%} of 400 with a result")
        return run

    def overlap(depth, expect):
        def run(_):
            s = sur()
            d23 = 0.5 * (s.gaps_[0] + s.gaps_[-1])
            V = 1.3 * float(s.coalescence_volume(0, 0, d23, 30)["volume_coalescence"])
            C = triangle_centres(2 - depth, 2 - depth, 2 + d23)
            r = api(lambda: s.predict_vectors(C, V, 30.0))
            if r.kind == "number":
                ref = s.predict(0, 0, d23, V, 30.0)
                ok = np.isclose(float(r.value["f12"]), float(ref["f12"]), rtol=1e-12)
                return Result("number" if ok else "wrong")
            return r
        return Case("0", f"predict_vectors, grains 1-2 and 1-3 overlapping by {depth:g} r",
                    expect, run, words=("overlap",))

    def permuted(_):
        s = sur()
        d23 = 0.5 * (s.gaps_[0] + s.gaps_[-1])
        V = 1.3 * float(s.coalescence_volume(0, 0, d23, 30)["volume_coalescence"])
        C = triangle_centres(2 - 1e-3, 2 - 1e-3, 2 + d23)
        a = api(lambda: s.predict_vectors(C, V, 30.0))
        b = api(lambda: s.predict_vectors(C[[2, 0, 1]], V, 30.0))
        if a.kind != "number" or b.kind != "number":
            return a if a.kind != "number" else b
        ok = np.allclose(b.value["forces"], a.value["forces"][[2, 0, 1]], rtol=1e-9, atol=1e-12)
        return Result("number" if ok else "wrong")

    def doublet_overlap(_):
        r = api(lambda: dbl().predict(-1e-3, 0.05, 30.0))
        if r.kind != "number":
            return r
        ok = float(r.value["force"]) == float(dbl().predict(0.0, 0.05, 30.0)["force"])
        return Result("number" if ok else "wrong")

    return [Case("0", "predict_vectors on 400 in-table contacts rebuilt by triangle_centres",
                 "number", rebuilt()),
            overlap(1e-4, "number"), overlap(1e-2, "number"), overlap(0.05, "number"),
            overlap(0.1, "error"),
            Case("0", "predict_vectors with the grains relabelled (DEM overlap 1e-3)",
                 "number", permuted),
            Case("0", "doublet predict at a 1e-3 overlap", "number", doublet_overlap)]


def _api_cases():
    from capbridge.dem.triplet_clusters import triangle_centres

    def geometry():
        s = sur()
        d = 0.5 * (s.gaps_[0] + s.gaps_[-1])
        C = triangle_centres(2 + d, 2 + d, 2 + d)
        V = 1.3 * float(s.coalescence_volume(d, d, d, 30.0)["volume_coalescence"])
        return s, C, V, d

    def bond_list(_):
        s, C, V, _ = geometry()
        r = api(lambda: s.predict_vectors(C, V, 30.0, bond=[0.5, 1.0]))
        if r.kind != "number":
            return r
        one = s.predict_vectors(C, V, 30.0, bond=1.0)
        ok = r.value["forces"].shape == (2, 3, 3) and \
            np.allclose(r.value["forces"][1], one["forces"], rtol=1e-12)
        return Result("number" if ok else "wrong")

    def bad(name, call, words):
        return Case("5", name, "error", lambda _: api(call), words=words)

    s_ = sur
    return [
        Case("5", "predict_vectors(one geometry, bond=[0.5, 1.0])", "number", bond_list),
        bad("predict_vectors with bond of 2 and centres of 3 geometries",
            lambda: s_().predict_vectors(np.stack([geometry()[1]] * 3), geometry()[2], 30.0,
                                         bond=[0.5, 1.0]), ("broadcast",)),
        bad("triplet predict, gap as datetime64",
            lambda: s_().predict(np.datetime64("2020-01-01"), 0.05, 0.05, 0.3, 30), ("d12",)),
        bad("triplet predict, volume as datetime64",
            lambda: s_().predict(0.05, 0.05, 0.05, np.datetime64("2020-01-01"), 30),
            ("volume",)),
        bad("triplet predict, theta True", lambda: s_().predict(0.05, 0.05, 0.05, 0.3, True),
            ("theta",)),
        bad("triplet predict, gap as text", lambda: s_().predict("0.05", 0.05, 0.05, 0.3, 30),
            ("d12",)),
        bad("triplet predict, gap complex",
            lambda: s_().predict(0.05 + 1j, 0.05, 0.05, 0.3, 30), ("d12",)),
        bad("doublet predict, gap as datetime64",
            lambda: dbl().predict(np.datetime64("2020-01-01"), 0.05, 30), ("gap",)),
        bad("doublet predict, timedelta volume",
            lambda: dbl().predict(0.1, np.timedelta64(1, "s"), 30), ("volume",)),
        bad("doublet predict_si, gap overlapping 10 % of the radius",
            lambda: dbl().predict_si(1e-3, 1e-3, 0.072, -1e-4, 5e-11, 30.0), ("gap",)),
        bad("triplet predict_vectors, centres as text",
            lambda: s_().predict_vectors([["a"] * 3] * 3, 0.3, 30), ("centres",)),
        bad("triplet predict_vectors, NaN gravity direction",
            lambda: s_().predict_vectors(geometry()[1], geometry()[2], 30.0, bond=0.5,
                                         gravity=[np.nan, 0, -1]), ("gravity",)),
    ]


def _cli_cases():
    def out_csv(tmp, rows, header):
        p = tmp / "in.csv"
        p.write_text(header + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
        return p

    def keep(tmp, make):
        """Run ``make(tmp, existing)``; the existing file must be unchanged."""
        existing = tmp / "user_result.csv"
        existing.write_text("mine\n1\n")
        before = digest(existing)
        r = make(tmp, existing)
        if digest(existing) != before:
            return Result("lost", "an existing output was replaced")
        return r

    def c(item, name, expect, *args, words=()):
        return Case(item, name, expect, lambda tmp: cli(*[a(tmp) if callable(a) else a
                                                           for a in args]), words=words)

    cases = [
        c("0", "lookup doublet with a DEM overlap d = -0.01", "number", "lookup", "doublet",
          "--input", lambda t: out_csv(t, [(-0.01, 0.05, 30)], "d,V,theta"),
          "--output", lambda t: t / "o.csv"),
        c("0", "lookup doublet with d = -0.2 (not a contact)", "error", "lookup", "doublet",
          "--input", lambda t: out_csv(t, [(-0.2, 0.05, 30)], "d,V,theta"),
          "--output", lambda t: t / "o.csv", words=("-0.2",)),
        c("0", "lookup triplet with a DEM overlap d12 = -0.001", "number", "lookup",
          "triplet", "--input",
          lambda t: out_csv(t, [(-0.001, 0.0, 0.1, 0.35, 30)], "d12,d13,d23,V,theta"),
          "--output", lambda t: t / "o.csv"),
        Case("6", "lookup doublet onto an existing output without --overwrite", "error",
             lambda tmp: keep(tmp, lambda t, e: cli(
                 "lookup", "doublet", "--input", out_csv(t, [(0.1, 0.05, 30)], "d,V,theta"),
                 "--output", e)), words=("exists",)),
        c("6", "solve triplet --max-refine 1 (no error estimate)", "flag", "solve", "triplet",
          "--d12", 0.1, "--d13", 0.1, "--d23", 0.05, "--V", 0.3, "--theta", 30,
          "--max-refine", 1, words=("max-refine",)),
        c("6", "solve doublet --bond 0.5 across the axis --max-refine 1", "error", "solve",
          "doublet", "--d", 0.1, "--V", 0.05, "--theta", 30, "--bond", 0.5, "--gravity", "0,0,-1",
          "--max-refine", 1, words=("max-refine",)),
        c("6", "generate triplet --worker-timeout 0", "error", "generate", "triplet",
          "--quick", "--output", lambda t: t / "t.nc", "--worker-timeout", 0,
          words=("worker-timeout",)),
        c("6", "generate coalescence --worker-timeout -5", "error", "generate",
          "coalescence", "--quick", "--output", lambda t: t / "c.nc", "--worker-timeout", -5,
          words=("worker-timeout",)),
    ]

    def info_once(tmp):
        r = cli("info")
        if r.kind != "number":
            return r
        n = r.detail.count("holdout_max_rel_error_force_ratio1_band0:")
        return Result("number" if n == 1 else "wrong",
                      f"the doublet error model printed {n} times")
    cases.append(Case("6", "capbridge info prints the doublet error model once", "number",
                      info_once))
    return cases


def all_cases(with_yade=True):
    cases = _contact_cases() + _api_cases() + _cli_cases()
    for extra in ("_table_cases", "_engine_cases"):
        fn = globals().get(extra)
        if fn is not None:
            cases += fn(with_yade)
    return cases


def run_case(case):
    tmp = Path(tempfile.mkdtemp(prefix="capbridge_probe_"))
    try:
        res = case.run(tmp)
    except Exception as exc:               # the probe's own harness must not hide a crash
        res = Result("traceback", f"{type(exc).__name__}: {exc}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return Outcome(case, judge(case, res), res.detail or res.message)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--yade", action="store_true", help="also the YADE engine cases")
    ap.add_argument("--only", default=None, help="one issue item (0-6)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    cases = [c for c in all_cases(a.yade) if (a.only is None or c.item == a.only)
             and (a.yade or not c.yade)]
    outcomes = []
    for k, case in enumerate(cases, 1):
        o = run_case(case)
        outcomes.append(o)
        print(f"[{k:3d}/{len(cases)}] item {case.item}: {o.outcome:26s} {case.name}"
              + (f"  -- {o.detail[:160]}" if o.outcome not in
                 ("clean error", "flagged", "right number") else ""), flush=True)
    counts = {k: sum(o.outcome == k for o in outcomes) for k in OUTCOMES}
    print(f"\ntried {len(outcomes)}: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    if a.json:
        Path(a.json).write_text(json.dumps({
            "tried": len(outcomes), "counts": counts,
            "cases": [{"item": o.case.item, "name": o.case.name, "outcome": o.outcome,
                       "detail": o.detail[:500]} for o in outcomes]}, indent=1))
    bad = counts["wrong number"] + counts["traceback or cryptic error"] + counts["crash"] + \
        counts["data lost"]
    return 1 if bad else 0



# ------------------------------------------------------------------ engine options (item 4)

#: the issue's engine keywords (and neighbours), checked by the engine's own validation
ENGINE_BAD = {
    "triplet_forces='no'": {"triplet_forces": "no"},
    "coalescence='False'": {"coalescence": "False"},
    "refresh_every=2.7": {"refresh_every": 2.7},
    "coalescence_every=0": {"coalescence_every": 0},
    "coalescence_every=-5": {"coalescence_every": -5},
    "formation_gap=-1e-4": {"formation_gap": -1e-4},
    "formation_gap=nan": {"formation_gap": float("nan")},
    "skin=-1e-4": {"skin": -1e-4},
    "skin=nan": {"skin": float("nan")},
    "ratio_step=-0.1": {"ratio_step": -0.1},
    "ratio_step=nan": {"ratio_step": float("nan")},
    "gamma=72 (mN/m typed as N/m)": {"gamma": 72.0},
    "theta=nan": {"theta": float("nan")},
    "walls='all'": {"walls": "all"},
    "label=None": {"label": None},
    "water_content and bridge_volume together": {"bridge_volume": 1e-10},
}


def _engine_cases(with_yade):
    from capbridge.yade.engine_options import check_gravity, check_options

    def pure(kw):
        args = {"water_content": 0.01, "label": "cap"}
        args.update(kw)
        return lambda _: api(lambda: check_options(**args))

    word = {k: k.split("=")[0].split(" ")[0] for k in ENGINE_BAD}
    cases = [Case("4", f"CapbridgeEngine({k})", "error", pure(kw), words=(word[k],))
             for k, kw in ENGINE_BAD.items()]
    cases.append(Case("4", "NewtonIntegrator.gravity=(0, 0, nan)", "error",
                      lambda _: api(lambda: check_gravity((0.0, 0.0, float("nan")))),
                      words=("gravity",)))
    if not with_yade:
        return cases

    from capbridge.yade import yade_runtime as yr

    scenes = ROOT / "tests" / "yade_scenes"

    def options_scene():
        if "options" not in _CACHE:
            try:
                _CACHE["options"] = yr.run_yade_script(scenes / "options_capbridge.py",
                                                       ["--case", "all"], timeout=600).result
            except Exception as exc:          # the YADE process died
                _CACHE["options"] = {"_crash": f"{type(exc).__name__}: {str(exc)[-300:]}"}
        return _CACHE["options"]

    def yade_case(name):
        def run(_):
            res = options_scene()
            if "_crash" in res:
                return Result("crash", res["_crash"])
            got = res[name]
            if name == "valid":
                return Result("number" if got["stage"] == "ran" else "traceback", str(got))
            if got.get("type") == "CapbridgeInputError" and "\n" not in got["message"]:
                return Result("error", message=got["message"])
            msg = got.get("message", "")
            if got["stage"] == "run" and "ERROR:" in msg:
                # what only a running scene knows (gravity) stops the first step; YADE's
                # PyRunner reports any engine error as "ERROR: <line>" and its stack: the
                # line must be the engine's own CapbridgeInputError
                line = msg.split("ERROR:", 1)[1].strip().splitlines()[0]
                if f"CapbridgeInputError: {line}" in msg:
                    return Result("error", message=line)
            if got["stage"] == "ran":
                return Result("wrong", "the scene ran with it")
            return Result("traceback", f"{got.get('type')}: {got.get('message', '')[:300]}")
        return run

    names = _scene_case_names(scenes / "options_capbridge.py")
    for name in names:
        cases.append(Case("4", f"YADE scene, engine made with case {name!r}",
                          "number" if name == "valid" else "error", yade_case(name),
                          yade=True))

    def erase(_):
        try:
            res = yr.run_yade_script(scenes / "erase_capbridge.py", ["--case", "both"],
                                     timeout=600).result
        except Exception as exc:
            return Result("crash", f"{type(exc).__name__}: {str(exc)[-300:]}")
        a, r = res["all"], res["resume"]
        if a["error"] or r["error"]:
            return Result("crash", str(a["error"] or r["error"])[:300])
        ok = a["after"]["total_force"] == 0.0 and a["after"]["budget"]["balance_error"] < 1e-12
        return Result("number" if ok else "wrong")
    cases.append(Case("4", "YADE: every wet grain erased (the engine idles, then resumes)",
                      "number", erase, yade=True))
    return cases


def _scene_case_names(path):
    """The CASES keys of a scene file, read without running YADE."""
    import ast

    tree = ast.parse(Path(path).read_text())
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            target = node.targets[0] if isinstance(node, ast.Assign) else node.target
            if getattr(target, "id", None) == "CASES":
                return [k.value for k in node.value.keys]
    return []


# ------------------------------------------------------------------ tampered tables (item 3)

def _tamper(src, dst, edit):
    """A copy of ``src`` at ``dst`` with ``edit(netCDF4.Dataset)`` applied in place."""
    import netCDF4

    shutil.copy(src, dst)
    with netCDF4.Dataset(dst, "a") as nc:
        edit(nc)
    return dst


def _set_units(var, units):
    return lambda nc: nc[var].setncattr("units", units)


def _set_attr(name, value):
    return lambda nc: nc.setncattr(name, value)


def _del_checksums(nc):
    for k in ("table_sha256", "data_sha256"):
        if k in nc.ncattrs():
            nc.delncattr(k)


def _and(*edits):
    def run(nc):
        for e in edits:
            e(nc)
    return run


def _scale(var, factor, index=None):
    def run(nc):
        v = nc[var]
        a = v[:]
        if index is None:
            v[:] = a * factor
        else:
            a[index] = a[index] * factor
            v[:] = a
    return run


def _negate_node(var):
    """One finite, positive node of ``var`` made negative."""
    def run(nc):
        v = nc[var]
        a = np.ma.filled(v[:].astype(float), np.nan)
        k = np.flatnonzero(np.isfinite(a.ravel()) & (a.ravel() > 0))[0]
        a.ravel()[k] *= -1
        v[:] = a
    return run


def _table_cases(with_yade):
    data = ROOT / "data"
    dbl_t, tri_t, coal_t = (data / "doublet_table.nc", data / "triplet_table.nc",
                            data / "triplet_coalescence.nc")
    lookup_doublet = ("lookup", "doublet", "--input", "{pts_d}", "--output", "{out}",
                      "--table", "{t}")
    lookup_triplet = ("lookup", "triplet", "--input", "{pts_t}", "--output", "{out}",
                      "--table", "{t}")
    lookup_triplet_c = ("lookup", "triplet", "--input", "{pts_t}", "--output", "{out}",
                        "--coalescence-table", "{t}")

    edits = [
        # (name, table, edit, command, allowed?)  -- every one must be refused
        ("triplet f12 units 'N'", tri_t, _set_units("f12", "N"), lookup_triplet),
        ("triplet theta units 'radian'", tri_t, _set_units("theta", "radian"), lookup_triplet),
        ("coalescence theta units 'radian'", coal_t, _set_units("theta", "radian"),
         lookup_triplet_c),
        ("coalescence V_coal_pair units 'mm3'", coal_t, _set_units("V_coal_pair", "mm3"),
         lookup_triplet_c),
        ("doublet force units 'N'", dbl_t, _set_units("force", "N"), lookup_doublet),
        ("triplet error model replaced (holdout max 1e-9)", tri_t,
         _set_attr("holdout_max_rel_error_pair_force_by_volume", "1e-9"), ("info", "--table", "{t}")),
        ("doublet error model replaced (holdout max 1e-9)", dbl_t,
         _set_attr("holdout_max_rel_error_force_ratio1_band0", 1e-9), ("info", "--table", "{t}")),
        ("doublet grid attribute edited", dbl_t, _set_attr("grid", "{}"), lookup_doublet),
        ("triplet checksums deleted", tri_t, _del_checksums, lookup_triplet),
        ("coalescence checksums deleted", coal_t, _del_checksums, lookup_triplet_c),
        ("doublet checksums deleted", dbl_t, _del_checksums, lookup_doublet),
    ]
    physical = [
        # checksum deleted AND the user allows unverified tables: the physics still refuses
        ("negative V_coal_pair node", coal_t, _negate_node("V_coal_pair"), lookup_triplet_c),
        ("triplet gravity response x10", tri_t, _scale("force_gravity_gradient", 10.0),
         lookup_triplet),
        ("triplet f12 sign-flipped", tri_t, _scale("f12", -1.0), lookup_triplet),
        ("doublet weight share x10", dbl_t, _scale("weight_share_axial", 10.0), lookup_doublet),
        ("triplet units 'N' on f12", tri_t, _set_units("f12", "N"), lookup_triplet),
    ]

    def make(name, table, edit, command, allow):
        def run(tmp):
            t = _tamper(table, tmp / table.name, _and(_del_checksums, edit) if allow else edit)
            pts_d = tmp / "pd.csv"
            pts_d.write_text("d,V,theta\n0.1,0.05,30\n")
            pts_t = tmp / "pt.csv"
            pts_t.write_text("d12,d13,d23,V,theta\n0.0,0.0,0.1,0.35,30\n")
            before = digest(t)
            args = [a.format(t=t, pts_d=pts_d, pts_t=pts_t, out=tmp / "o.csv") for a in command]
            if allow:
                args.append("--allow-unverified-table")
            r = cli(*args)
            if digest(t) != before:
                return Result("lost", "the table file was changed")
            return r
        return Case("3", f"table: {name}" + (" (checksum deleted, unverified allowed)"
                                              if allow else ""), "error", run)

    return [make(*e, False) for e in edits] + [make(*p, True) for p in physical]


if __name__ == "__main__":
    sys.exit(main())
