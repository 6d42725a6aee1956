"""The `capbridge` command: JSON and CSV outputs, and clear refusals of bad input."""
import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from capbridge.cli import main
from capbridge.solvers.young_laplace import solve_doublet


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_solve_doublet_json(capsys):
    code, out, _ = run(["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30"], capsys)
    assert code == 0
    r = json.loads(out)
    for key in ("F", "P", "beta1", "beta2", "status"):
        assert key in r
    assert r["status"] == "converged"
    assert r["F"] == pytest.approx(float(solve_doublet(0.1, 0.05, 30)["force"]), rel=1e-12)


def test_solve_doublet_beyond_rupture(capsys):
    code, out, _ = run(["solve", "doublet", "--d", "0.5", "--V", "0.001", "--theta", "0"], capsys)
    r = json.loads(out)
    assert code == 0 and r["status"] == "ruptured" and r["F"] == 0.0


@pytest.mark.parametrize("args, word", [
    (["--d", "0.1", "--V", "-0.05", "--theta", "30"], "volume"),
    (["--d", "0.1", "--V", "nan", "--theta", "30"], "volume"),
    (["--d", "0.1", "--V", "0.05", "--theta", "120"], "theta"),
    (["--d", "-0.1", "--V", "0.05", "--theta", "30"], "gap"),
    (["--d", "0.1", "--V", "0.05", "--theta", "30", "--ratio", "0.5"], "ratio"),
])
def test_solve_doublet_refuses_bad_input(args, word, capsys):
    code, out, err = run(["solve", "doublet"] + args, capsys)
    assert code != 0 and out == ""
    assert word in err and "allowed range" in err


@pytest.mark.slow
def test_lookup_doublet_csv(tmp_path, capsys):
    src = tmp_path / "points.csv"
    pd.DataFrame({"d": [0.0, 0.05, 0.1, 2.0], "V": [0.01, 0.02, 0.05, 0.05],
                  "theta": [0, 20, 40, 10], "extra": ["a", "b", "c", "d"]}).to_csv(src, index=False)
    dst = tmp_path / "out.csv"
    code, _, _ = run(["lookup", "doublet", "--input", str(src), "--output", str(dst)], capsys)
    assert code == 0
    df = pd.read_csv(dst)
    assert list(df.columns[:4]) == ["d", "V", "theta", "extra"]
    for col in ("F", "P", "beta1", "beta2", "status"):
        assert col in df.columns
    assert list(df["status"]) == ["converged"] * 3 + ["ruptured"]
    exact = solve_doublet(df["d"][:3].to_numpy(), df["V"][:3].to_numpy(), df["theta"][:3].to_numpy())
    np.testing.assert_allclose(df["F"][:3], exact["force"], rtol=5e-3)
    assert df["F"][3] == 0.0


@pytest.mark.parametrize("frame, word", [
    ({"d": [0.1], "theta": [10]}, "missing column"),
    ({"d": [0.1], "V": [-1.0], "theta": [10]}, "volume"),
    ({"d": [0.1], "V": [0.01], "theta": [99]}, "theta"),
    ({"d": [-0.1], "V": [0.01], "theta": [10]}, "gap"),     # -0.01 is a DEM contact
    ({"d": [0.1], "V": [50.0], "theta": [10]}, "outside the table"),
])
def test_lookup_refuses_bad_rows(tmp_path, frame, word, capsys):
    src = tmp_path / "bad.csv"
    pd.DataFrame(frame).to_csv(src, index=False)
    code, _, err = run(["lookup", "doublet", "--input", str(src), "--output", str(tmp_path / "o.csv")],
                       capsys)
    assert code != 0 and word in err
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.slow
def test_generate_quick_table_then_lookup(tmp_path, capsys):
    table = tmp_path / "quick.nc"
    code, out, _ = run(["generate", "doublet", "--quick", "--output", str(table), "--jobs", "1",
                        "--holdout", "40", "--no-progress"], capsys)
    assert code == 0 and "converged: 216" in out
    from capbridge.surrogate.doublet import DoubletSurrogate

    r = DoubletSurrogate().fit(table).predict(0.05, 0.01, 20.0)
    assert abs(r["force"] / solve_doublet(0.05, 0.01, 20.0)["force"] - 1) < 0.02


def test_entry_point_runs():
    exe = [sys.executable, "-m", "capbridge.cli", "solve", "doublet", "--d", "0.05", "--V", "0.01",
           "--theta", "0"]
    done = subprocess.run(exe, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["status"] == "converged"


def test_solve_doublet_suction_control(capsys):
    code, out, _ = run(["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30"], capsys)
    vol = json.loads(out)
    code, out, _ = run(["solve", "doublet", "--d", "0.1", "--P", str(vol["P"]), "--theta", "30"], capsys)
    sx = json.loads(out)
    assert code == 0 and sx["status"] == "converged"
    assert sx["V"] == pytest.approx(0.05, rel=1e-8) and sx["F"] == pytest.approx(vol["F"], rel=1e-8)
    code, _, err = run(["solve", "doublet", "--d", "0.1", "--theta", "30"], capsys)
    assert code != 0 and "exactly one of --V" in err


# ------------------------------------------------- issue 16, item 6: smaller CLI defects

def run_exit(args, capsys):
    """``run`` for errors argparse reports (SystemExit): (exit code, stdout, stderr)."""
    try:
        code = main(args)
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def _one_error_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("capbridge: error:"), err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("argv", [
    ["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "0.1", "--V", "0.3",
     "--theta", "60"],
    # gravity off the axis: Surface Evolver, whose minimum refinement is 2
    ["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30", "--bond", "0.5",
     "--gravity", "0,0,-1"],
])
def test_solve_refuses_max_refine_below_two_up_front(argv, capsys):
    """Level 1 alone has no error estimate (triplet: forces 5 % off with
    force_error_rel null; doublet off the axis: always not_converged): refused in one
    line naming the value and the range, before any Evolver run."""
    code, out, err = run_exit(argv + ["--max-refine", "1"], capsys)
    line = _one_error_line(err)
    assert code == 2 and out == ""
    assert "--max-refine" in line and "1 is outside the allowed range [2, 6]" in line
    from capbridge.cli import build_parser

    assert build_parser().parse_args(argv + ["--max-refine", "2"]).max_refine == 2


def test_info_shows_the_doublet_error_model_once(capsys):
    from capbridge.cli import DEFAULT_TABLE

    code, out, _ = run(["info", "--table", str(DEFAULT_TABLE)], capsys)
    assert code == 0
    keys = [ln.split(":")[0].strip() for ln in out.splitlines()
            if ln.strip().startswith("holdout_")]
    assert "holdout_max_rel_error_force_ratio1_band0" in keys
    assert len(keys) == len(set(keys)), "error model printed twice"
    assert out.count("error model") == 1


@pytest.mark.slow
@pytest.mark.parametrize("what", ["doublet", "triplet", "coalescence"])
def test_worker_timeout_on_every_generate_with_a_scheduler(what, tmp_path, capsys):
    """--worker-timeout on every `generate` that takes --scheduler: with no Dask worker
    the sweep fails its chunks after that many seconds (exit 3, one line, no table)."""
    import time

    distributed = pytest.importorskip("distributed")
    out = tmp_path / f"{what}.nc"
    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=None) as cluster:
        t0 = time.monotonic()
        code, _, err = run(["generate", what, "--quick", "--no-progress", "--output",
                            str(out), "--scheduler", cluster.scheduler_address,
                            "--worker-timeout", "2"], capsys)
        waited = time.monotonic() - t0
    assert code == 3, err
    assert 2.0 <= waited < 60
    line = [ln for ln in err.splitlines() if ln.startswith("capbridge: error:")]
    assert len(line) == 1 and "chunks failed" in line[0] and "rerun" in line[0]
    assert "Traceback" not in err and not out.exists()
    code, _, err = run_exit(["generate", what, "--quick", "--worker-timeout", "0"], capsys)
    assert code == 2 and "--worker-timeout" in _one_error_line(err)
    assert "0.0 is outside the allowed range (0, inf)" in err
