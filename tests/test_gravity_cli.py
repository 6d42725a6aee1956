"""`capbridge lookup/solve doublet/triplet --bond --gravity` and `info` (issue 10).

The lookups run on the shipped tables with the synthetic gravity response of
test_gravity_surrogate (written to netCDF files here); the Surface Evolver solves are
replaced by stand-ins that record their arguments (no Evolver run in these tests).
"""
import json

import numpy as np
import pandas as pd
import pytest

from capbridge.cli import DEFAULT_COALESCENCE_TABLE, main
from capbridge.tables.netcdf_io import write_table
from capbridge.solvers.triplet import triplet_geometry
from capbridge.solvers.young_laplace_gravity import solve_doublet_gravity
from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.surrogate.triplet import TripletSurrogate
from test_gravity_surrogate import (DTHETA, DV, add_synthetic_holdout, needs_tables,
                                    synthetic_doublet_table, synthetic_triplet_table)

pytestmark = needs_tables


def _write(ds, path):
    return str(write_table(ds, path, command="tests/test_gravity_cli.py",
                           solver_settings=json.loads(ds.attrs["solver_settings"])))


@pytest.fixture(scope="module")
def doublet_file(tmp_path_factory):
    return _write(synthetic_doublet_table(), tmp_path_factory.mktemp("d") / "d.nc")


@pytest.fixture(scope="module")
def triplet_file(tmp_path_factory):
    ds = synthetic_triplet_table()
    sur = TripletSurrogate().fit(ds, coalescence_table=DEFAULT_COALESCENCE_TABLE)
    return _write(add_synthetic_holdout(ds, sur), tmp_path_factory.mktemp("t") / "t.nc")


def _csv(path, columns, rows):
    pd.DataFrame(rows, columns=columns).to_csv(path, index=False)
    return str(path)


@pytest.mark.slow
def test_lookup_doublet_bond_gives_the_force_vectors(tmp_path, doublet_file, capsys):
    rows = [(0.05, 0.05, 30.0), (0.2, 0.02, 45.0), (0.0, 0.1, 0.0)]
    out = tmp_path / "o.csv"
    assert main(["lookup", "doublet", "--input", _csv(tmp_path / "p.csv", ["d", "V", "theta"],
                                                      rows),
                 "--output", str(out), "--table", doublet_file, "--bond", "2.14",
                 "--gravity", "-0.6,0,-0.8"]) == 0
    df = pd.read_csv(out)
    cols = [f"F{g}{c}" for g in (1, 2) for c in "xyz"]
    assert all(c in df.columns for c in cols) and "status" in df.columns
    sur = DoubletSurrogate().fit(doublet_file)
    r = sur.predict_vectors(df.d, df.V, df.theta, bond=2.14, gravity=(-0.6, 0, -0.8))
    np.testing.assert_allclose(df[cols[:3]].values, r["F1"], rtol=1e-12)
    np.testing.assert_allclose(df[cols[3:]].values, r["F2"], rtol=1e-12)
    # the grains carry the weight: F1 + F2 = V*/(2 pi) Bo g_hat
    W = df.V.values[:, None] / (2 * np.pi) * 2.14 * np.array([-0.6, 0.0, -0.8])
    np.testing.assert_allclose(df[cols[:3]].values + df[cols[3:]].values, W, atol=1e-12)
    # without --bond the output is the zero-gravity one, without vector columns
    out0 = tmp_path / "o0.csv"
    assert main(["lookup", "doublet", "--input", str(tmp_path / "p.csv"), "--output",
                 str(out0), "--table", doublet_file]) == 0
    df0 = pd.read_csv(out0)
    assert "F1x" not in df0.columns
    np.testing.assert_allclose(df0.F, df.F, rtol=1e-12)


@pytest.mark.slow
def test_lookup_doublet_out_of_range_rows_are_reported(tmp_path, doublet_file, capsys):
    sur = DoubletSurrogate().fit(doublet_file)
    d0 = float(sur.predict(0.0, DV, DTHETA)["rupture_gap"])
    out = tmp_path / "o.csv"
    assert main(["lookup", "doublet", "--input",
                 _csv(tmp_path / "p.csv", ["d", "V", "theta"], [(1.02 * d0, DV, DTHETA)]),
                 "--output", str(out), "--table", doublet_file, "--bond", "1",
                 "--gravity", "1,0,0"]) == 0
    assert pd.read_csv(out).status[0] == "out_of_range"
    assert "beyond the rupture distance without gravity" in capsys.readouterr().err


@pytest.mark.slow
def test_lookup_triplet_bond_gives_the_force_vectors(tmp_path, triplet_file):
    rows = [(0.05, 0.12, 0.15, 0.35, 30.0), (0.1, 0.1, 0.1, 0.4, 40.0)]
    out = tmp_path / "o.csv"
    assert main(["lookup", "triplet", "--input",
                 _csv(tmp_path / "p.csv", ["d12", "d13", "d23", "V", "theta"], rows),
                 "--output", str(out), "--table", triplet_file, "--bond", "0.5",
                 "--gravity", "-1,0,0"]) == 0
    df = pd.read_csv(out)
    cols = [f"F{g}{c}" for g in (1, 2, 3) for c in "xyz"]
    sur = TripletSurrogate().fit(triplet_file, coalescence_table=DEFAULT_COALESCENCE_TABLE)
    cen = np.stack([triplet_geometry(*r[:3]).centres for r in rows])
    r = sur.predict_vectors(cen, df.V, df.theta, bond=0.5, gravity=(-1, 0, 0))
    np.testing.assert_allclose(df[cols].values, r["forces"].reshape(-1, 9), rtol=1e-12)
    assert list(df.status) == ["converged", "converged"] or \
        set(df.status) <= {"converged", "above_tolerance"}


@pytest.mark.parametrize("extra, words", [
    (["--bond", "-0.5"], ["--bond=-0.5", "[0, 2.5]"]),
    (["--bond", "2.6"], ["--bond=2.6", "[0, 2.5]"]),
    (["--bond", "nan"], ["--bond=nan", "[0, 2.5]"]),
    (["--bond", "1", "--gravity", "0,0,0"], ["--gravity", "not all zero"]),
    (["--bond", "1", "--gravity", "1,2"], ["--gravity", "X,Y,Z"]),
    (["--bond", "1", "--gravity", "a,b,c"], ["--gravity", "X,Y,Z"]),
    (["--gravity", "0,0,-1"], ["--gravity", "needs --bond", "[0, 2.5]"]),
])
@pytest.mark.parametrize("what", ["doublet", "triplet"])
def test_lookup_bad_gravity_input(tmp_path, capsys, doublet_file, triplet_file, what,
                                  extra, words):
    if what == "doublet":
        args = ["--input", _csv(tmp_path / "p.csv", ["d", "V", "theta"], [(0.05, 0.05, 30)]),
                "--table", doublet_file]
    else:
        args = ["--input", _csv(tmp_path / "p.csv", ["d12", "d13", "d23", "V", "theta"],
                                [(0.05, 0.12, 0.15, 0.35, 30.0)]), "--table", triplet_file]
    code = main(["lookup", what, *args, "--output", str(tmp_path / "o.csv"), *extra])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and err.startswith("capbridge: error:")
    for w in words:
        assert w in err
    assert not (tmp_path / "o.csv").exists()


def test_solve_doublet_axial_gravity_is_the_exact_solver(capsys):
    assert main(["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30",
                 "--bond", "2.14", "--gravity=-1,0,0"]) == 0
    out = json.loads(capsys.readouterr().out)
    ex = solve_doublet_gravity(0.1, 0.05, 30.0, 2.14, gravity_axis=-1.0)
    assert out["method"].startswith("exact")
    assert out["F1"] == pytest.approx([float(ex["force1"]), 0, 0], rel=1e-12)
    assert out["F2"] == pytest.approx([-float(ex["force2"]), 0, 0], rel=1e-12)
    W = 0.05 / (2 * np.pi) * 2.14
    assert out["F1"][0] + out["F2"][0] == pytest.approx(-W, rel=1e-6)


def test_solve_doublet_oblique_gravity_uses_evolver(monkeypatch, capsys):
    import capbridge.solvers.evolver as ev
    from capbridge.status import Status

    seen = {}

    class Fake:
        status, reason, refinement, cpu_time = Status.CONVERGED, "", 2, 1.0
        converged = True
        forces = np.array([[0.4, 0.0, -0.01], [-0.4, 0.0, -0.01]])
        force_error = np.zeros((2, 3))

    def fake(centres, radii, thetas, volume, topology, **kw):
        seen.update(centres=centres, radii=radii, thetas=thetas, volume=volume,
                    topology=topology, **kw)
        return Fake()

    monkeypatch.setattr(ev, "minimise_bridge", fake)
    assert main(["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30",
                 "--ratio", "2", "--bond", "0.5", "--gravity", "0,3,-4",
                 "--max-refine", "2"]) == 0
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert "Surface Evolver" in cap.err and out["method"].startswith("Surface Evolver")
    assert seen["centres"] == [[0.0, 0.0, 0.0], [3.1, 0.0, 0.0]]
    assert seen["radii"] == [1.0, 2.0] and seen["topology"] == "doublet"
    assert seen["bond"] == 0.5 and seen["max_refine"] == 2
    np.testing.assert_allclose(seen["gravity_dir"], (0.0, 0.6, -0.8), rtol=1e-12)
    assert out["F1"] == [0.4, 0.0, -0.01]


@pytest.mark.parametrize("extra, words", [
    (["--bond", "5.5"], ["--bond=5.5", "[0, 5]"]),
    (["--bond", "1", "--gravity", "0,0,0"], ["--gravity", "not all zero"]),
    (["--gravity", "1,0,0"], ["needs --bond"]),
])
def test_solve_bad_gravity_input(capsys, extra, words):
    for cmd in (["solve", "doublet", "--d", "0.1", "--V", "0.05", "--theta", "30"],
                ["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "0.1",
                 "--V", "0.4", "--theta", "30"]):
        assert main(cmd + extra) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1
        for w in words:
            assert w in err
    assert main(["solve", "doublet", "--d", "0.1", "--P", "-3", "--theta", "30",
                 "--bond", "1"]) == 2
    assert "--V" in capsys.readouterr().err


def test_solve_triplet_passes_gravity_to_evolver(monkeypatch, capsys):
    import capbridge.solvers.triplet_evolver as te

    seen = {}

    def fake(volume, geom, theta, topology, **kw):
        seen.update(volume=volume, theta=theta, topology=topology, **kw)
        return {"status": "converged", "status_code": 0, "reason": "", "forces": np.zeros((3, 3)),
                "force_error": None, "force_error_rel": None, "pair_forces": None,
                "pair_residual": None, "pressure": None, "energy_extrapolated": None,
                "energy_error": None, "refinement": 1, "n_facets": 0, "cpu_time": 0.0,
                "warnings": []}

    monkeypatch.setattr(te, "evolver_triplet", fake)
    assert main(["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "0.1",
                 "--V", "0.4", "--theta", "30", "--bond", "2.14",
                 "--gravity=-1,0,1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert seen["bond"] == 2.14 and seen["topology"] == "coalesced"
    np.testing.assert_allclose(seen["gravity_dir"], np.array([-1, 0, 1]) / np.sqrt(2))
    assert out["bond"] == 2.14
    # without --bond: no gravity arguments at all (the solver's own default, Bo = 0)
    seen.clear()
    assert main(["solve", "triplet", "--d12", "0.1", "--d13", "0.1", "--d23", "0.1",
                 "--V", "0.4", "--theta", "30"]) == 0
    assert "bond" not in seen and "gravity_dir" not in seen


@pytest.mark.slow
def test_info_prints_the_gravity_content(capsys, doublet_file, triplet_file):
    assert main(["info", "--table", triplet_file]) == 0
    out = capsys.readouterr().out
    assert "gravity: response on v = [0.85, 1.25, 2.0]" in out
    assert "validated [0, 2.14]" in out
    rows = [line.split() for line in out.splitlines() if line.strip().startswith("Bo = ")]
    assert [float(r[2]) for r in rows] == [0.0, 0.05, 0.5, 2.14, 2.5]
    assert float(rows[-1][5].rstrip(",")) > 0.1 > float(rows[-2][5].rstrip(","))
    assert main(["info", "--table", doublet_file]) == 0
    out = capsys.readouterr().out
    assert ("rupture_gap_gravity (rupture_bond 5, rupture_gravity_axis 2, rupture_ratio 2, "
            "rupture_theta 4, rupture_volume 5)") in out
    assert "weight_share_axial" in out


def test_help_documents_the_gravity_options(capsys):
    for what in ("doublet", "triplet"):
        with pytest.raises(SystemExit):
            main(["lookup", what, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "--bond BO" in text and "--gravity X,Y,Z" in text
        assert "direction along which gravity pulls" in text


@pytest.mark.parametrize("args, words", [
    (["--theta", "95"], "theta=95.0 deg is outside"),
    (["--theta", "30", "--ratio", "0.5"], "ratio=0.5 is outside"),
    (["--theta", "30", "--d", "nan"], "gap d* (--d)=nan"),
])
def test_solve_doublet_bond_off_axis_checks_inputs_before_evolver(args, words, capsys,
                                                                  monkeypatch):
    import capbridge.solvers.evolver as ev

    def never(*a, **k):
        raise AssertionError("Surface Evolver must not run on bad input")

    monkeypatch.setattr(ev, "minimise_bridge", never)
    base = {"--d": "0.1", "--V": "0.05"}
    for k in ("--d",):
        if k in args:
            base.pop(k)
    argv = ["solve", "doublet", "--bond", "1"] + [x for kv in base.items() for x in kv] + args
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
