"""`capbridge lookup triplet` / `solve triplet` / `info` on the shipped triplet table."""
import json

import numpy as np
import pandas as pd
import pytest

from capbridge.cli import DEFAULT_COALESCENCE_TABLE, DEFAULT_TRIPLET_TABLE, main
from capbridge.surrogate.triplet import TripletSurrogate

# the CLI reads the shipped tables: missing, they fail the tests (conftest.py)
pytestmark = pytest.mark.usefixtures("shipped_triplet_table", "coalescence_table")


def _csv(path, rows):
    pd.DataFrame(rows, columns=["d12", "d13", "d23", "V", "theta"]).to_csv(path, index=False)
    return str(path)


@pytest.mark.slow
def test_lookup_triplet_matches_the_api_and_permutes(tmp_path, capsys):
    rows = [(0.05, 0.1, 0.15, 0.35, 30.0), (0.1, 0.05, 0.15, 0.35, 30.0),
            (0.15, 0.1, 0.05, 0.35, 30.0)]
    out = tmp_path / "out.csv"
    assert main(["lookup", "triplet", "--input", _csv(tmp_path / "p.csv", rows),
                 "--output", str(out)]) == 0
    df = pd.read_csv(out)
    assert list(df.columns[:5]) == ["d12", "d13", "d23", "V", "theta"]
    sur = TripletSurrogate().fit(DEFAULT_TRIPLET_TABLE, coalescence_table=DEFAULT_COALESCENCE_TABLE)
    r = sur.predict(df.d12, df.d13, df.d23, df.V, df.theta)
    np.testing.assert_allclose(df.f12, r["f12"], rtol=1e-12)
    # row 2 swaps grains 2 and 3 of row 1: f12 <-> f13; row 3 relabels 1 <-> 3
    assert df.f12[1] == pytest.approx(df.f13[0], rel=1e-9)
    assert df.f23[1] == pytest.approx(df.f23[0], rel=1e-9)
    assert df.f23[2] == pytest.approx(df.f12[0], rel=1e-9)
    assert set(df.status) <= {"converged", "above_tolerance"}


@pytest.mark.parametrize("row, words", [
    ((-0.1, 0.1, 0.1, 0.3, 30.0), "d12"),            # overlapping grains
    ((0.1, 0.1, 0.1, 0.3, 95.0), "theta"),           # theta outside [0, 90)
    ((0.1, 0.1, 0.1, -0.3, 30.0), "V"),              # negative volume
    ((0.1, 0.1, 0.5, 0.3, 30.0), "range"),           # gap outside the table
])
def test_lookup_triplet_bad_rows_fail_in_one_line(tmp_path, capsys, row, words):
    code = main(["lookup", "triplet", "--input", _csv(tmp_path / "p.csv", [row]),
                 "--output", str(tmp_path / "o.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("capbridge: error:") and "\n" not in err
    assert words in err
    assert not (tmp_path / "o.csv").exists()


def test_lookup_triplet_nan_cell_names_row_and_column(tmp_path, capsys):
    p = tmp_path / "p.csv"
    p.write_text("d12,d13,d23,V,theta\n0.1,0.1,0.1,abc,30\n")
    assert main(["lookup", "triplet", "--input", str(p), "--output",
                 str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "V" in err and "2" in err


def test_solve_triplet_refuses_impossible_geometry(capsys):
    assert main(["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "3",
                 "--V", "0.2", "--theta", "0"]) == 2
    assert "triangle" in capsys.readouterr().err
    assert main(["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "0.1",
                 "--V", "nan", "--theta", "0"]) == 2


@pytest.mark.evolver
def test_solve_triplet_json_balances(capsys):
    assert main(["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "0.1",
                 "--V", "0.3", "--theta", "60", "--max-refine", "2"]) == 0
    r = json.loads(capsys.readouterr().out)
    F = np.array(r["forces"])
    assert np.linalg.norm(F.sum(axis=0)) < 1e-2 * np.abs(F).max()
    f = r["pair_forces"]
    assert f["12"] == pytest.approx(f["13"], rel=1e-2) == pytest.approx(f["23"], rel=1e-2)


def test_info_describes_the_triplet_table(capsys):
    assert main(["info", "--table", str(DEFAULT_TRIPLET_TABLE)]) == 0
    out = capsys.readouterr().out
    assert "Surface Evolver" in out and "held-out" in out and "CPU s" in out


def test_info_gives_the_unequal_radii_error(capsys):
    """``info`` states the measured error of the unequal-radii approximation (issue 18:
    the held-out and the unequal-radii errors are in ``capbridge info``)."""
    from capbridge.surrogate.triplet import UNEQUAL_RADII_ERROR as U

    assert main(["info", "--table", str(DEFAULT_TRIPLET_TABLE)]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if "unequal radii" in x)
    assert f"{U['median']:.1%}" in line and f"{U['max']:.1%}" in line
    assert "computed domain" not in out          # the shipped table covers its cube


def test_generate_triplet_packings_grid_refuses_quick(capsys):
    assert main(["generate", "triplet", "--grid", "packings", "--quick"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--grid packings" in err
