"""`capbridge coalescence`: JSON keys, layouts and errors."""
import json

import pytest

from capbridge.cli import main


def run(capsys, *argv):
    rc = main(list(argv))
    out = capsys.readouterr()
    return rc, out.out, out.err


BASE = ("coalescence", "--d12", "0.175", "--d13", "0.175", "--d23", "0.075")


@pytest.mark.slow
def test_paper_triplet_json(capsys):
    rc, out, _ = run(capsys, *BASE, "--theta", "30", "--radius", "4e-3")
    assert rc == 0
    d = json.loads(out)
    for key in ("V_coal", "criterion", "criterion_description", "beta", "opening_angle",
                "alpha", "criteria", "F_bridge", "V_coal_per_bridge", "units", "inputs",
                "V_coal_ul"):
        assert key in d
    assert d["criterion"] == "caps"
    assert d["V_coal_ul"] == pytest.approx(20.58, abs=0.01)
    assert d["V_coal"] == pytest.approx(d["V_coal_ul"] / 64)
    assert d["alpha"]["grain 1"] == pytest.approx(28.49, abs=0.01)
    assert d["beta"]["12"]["grain 1"] == pytest.approx(d["alpha"]["grain 1"], abs=1e-5)
    assert set(d["V_coal_per_bridge"]) == {"12", "13"}
    assert "energy" not in d


@pytest.mark.slow
def test_other_layout_and_fractions(capsys):
    rc, out, _ = run(capsys, *BASE, "--theta", "0", "--bridges", "12,13,23")
    assert rc == 0
    d = json.loads(out)
    assert set(d["V_coal_per_bridge"]) == {"12", "13", "23"}
    assert set(d["opening_angle"]) == {"grain 1", "grain 2", "grain 3"}
    rc, out, _ = run(capsys, *BASE, "--theta", "0", "--fractions", "2,1")
    d2 = json.loads(out)
    assert d2["V_coal_per_bridge"]["12"] == pytest.approx(2 * d2["V_coal_per_bridge"]["13"])


@pytest.mark.parametrize("extra, words", [
    (("--theta", "95"), "theta"),
    (("--theta", "-5"), "theta"),
    (("--theta", "30", "--bridges", "14"), "bridge 14"),
    (("--theta", "30", "--fractions", "1,2,3"), "fractions"),
    (("--theta", "30", "--fractions", "a,b"), "fractions"),
])
def test_bad_input_clear_error(capsys, extra, words):
    rc, out, err = run(capsys, *BASE, *extra)
    assert rc == 2 and out == ""
    assert "error" in err and words in err


def test_negative_gap(capsys):
    rc, _, err = run(capsys, "coalescence", "--d12", "-0.1", "--d13", "0.1", "--d23", "0.1",
                     "--theta", "0")
    assert rc == 2 and "d12" in err


def test_missing_argument_exits_nonzero(capsys):
    with pytest.raises(SystemExit) as e:
        main(["coalescence", "--d12", "0.1"])
    assert e.value.code != 0


@pytest.mark.evolver
def test_energy_option(capsys):
    rc, out, _ = run(capsys, *BASE, "--theta", "60", "--energy", "--energy-fractions",
                     "1.0,1.2", "--max-refine", "2")
    assert rc == 0
    e = json.loads(out)["energy"]
    assert {"V_cross", "note", "volumes", "E_uncoalesced", "E_coalesced"} <= set(e)
    assert len(e["volumes"]) == 2 and all(s in ("converged", "above_tolerance") for s in e["coalesced_status"])
    # the coalesced body is lower in energy than the two bridges at and above V_coal
    assert all(c < u for c, u in zip(e["E_coalesced"], e["E_uncoalesced"]))
    assert e["V_cross"] is None and "lower energy" in e["note"]
