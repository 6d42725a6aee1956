"""`capbridge demo` (the body of `make demo`) without its YADE part: the doublet lookups
beside the exact solver and the paper's coalesced triplet from the shipped tables, with
their figures and CSV files.  The YADE packing is run by `make demo` itself (and the
engine by tests/test_yade_*.py)."""
import pandas as pd
import pytest

from capbridge.cli import DEFAULT_TRIPLET_TABLE, main
from capbridge.cli.demo import DEMO_THETAS, DEMO_TRIPLET_V


@pytest.mark.skipif(not DEFAULT_TRIPLET_TABLE.exists(), reason="no shipped triplet table")
def test_demo_without_yade(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["demo", "--no-yade", "--output-dir", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    for name in ("doublet_force_vs_gap.png", "doublet_force_vs_gap.csv",
                 "triplet_force_vs_volume.png", "triplet_forces.csv"):
        assert (out / name).stat().st_size > 0, name
    assert not (out / "wet_packing.png").exists()
    # doublets: the table within its error model of the exact solver
    doublets = pd.read_csv(out / "doublet_force_vs_gap.csv")
    assert doublets["rel_err"].dropna().max() < 3.5e-3
    assert "median relative error" in printed
    # triplets: every angle and volume printed with a status; theta = 60 deg answered
    tri = pd.read_csv(out / "triplet_forces.csv")
    assert len(tri) == len(DEMO_THETAS) * len(DEMO_TRIPLET_V)
    assert set(tri["status"]) <= {"converged", "above_tolerance", "not_converged"}
    at60 = tri[tri["theta_deg"] == 60]
    assert at60["status"].eq("converged").all()
    assert (at60["f23"] > at60["f12"]).all() and (at60["f12"] > 0).all()
    # no number where the table has no coalesced body: NaN with its status, never silent
    missing = tri[tri["f12"].isna()]
    assert (missing["status"] != "converged").all()
    assert "coalesced triplets" in printed and "wet packing" not in printed


def test_demo_skips_the_triplets_on_request(tmp_path, capsys):
    code = main(["demo", "--no-yade", "--triplet-table", "none",
                 "--output-dir", str(tmp_path)])
    assert code == 0
    assert not (tmp_path / "triplet_forces.csv").exists()
    assert (tmp_path / "doublet_force_vs_gap.png").exists()


def test_demo_refuses_a_missing_triplet_table(tmp_path, capsys):
    code = main(["demo", "--no-yade", "--triplet-table", str(tmp_path / "no.nc"),
                 "--output-dir", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "triplet table" in err and "--triplet-table none" in err
    assert not (tmp_path / "o").exists()
