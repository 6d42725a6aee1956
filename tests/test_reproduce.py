"""`capbridge reproduce miot2021 --quick`: the pipeline end to end on coarse meshes."""
import json

import pandas as pd
import pytest

from capbridge.cli import main


@pytest.mark.evolver
@pytest.mark.slow
def test_reproduce_quick_writes_everything(tmp_path, capsys):
    out = tmp_path / "miot"
    rc = main(["reproduce", "miot2021", "--quick", "--no-progress", "--output-dir", str(out)])
    assert rc == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["claims"].endswith("CLAIMS.md")
    for name in ("CLAIMS.md", "summary.json", "triplet_forces.csv", "coalescence_volumes.csv",
                 "coalescence_gravity.csv", "coalescence_force_jumps.csv", "energies.csv",
                 "doublet_fig3.csv", "fig03_doublet.png", "fig06_09_force_vs_volume.png",
                 "fig10_vcoal_theta.png", "fig11_13_gravity_gamma.png"):
        assert (out / name).exists() and (out / name).stat().st_size > 0, name
    claims = (out / "CLAIMS.md").read_text()
    assert "| claim | paper | ours | difference |" in claims
    assert "14-14.5 ul" in claims and "QUICK" in claims
    s = json.loads((out / "summary.json").read_text())
    assert s["V_coal_exact_ul"]["0.0"] == pytest.approx(13.139, abs=0.01)
    ft = pd.read_csv(out / "triplet_forces.csv")
    assert {"regime", "theta_deg", "V_ul", "F_top_star", "F_top_mN", "status"} <= set(ft.columns)
    ex = ft[ft["method"].str.startswith("exact")]
    assert (ex["status"] == "converged").all() and len(ex) > 10
    ev = ft[ft["method"].str.startswith("Surface")]
    assert ev["status"].isin(["converged", "above_tolerance"]).sum() >= 3
    jumps = pd.read_csv(out / "coalescence_force_jumps.csv")
    j0 = jumps[(jumps["theta_deg"] == 0) & (~jumps["gravity"])]
    assert len(j0) == 1 and j0["change_pct"].iloc[0] < 0       # drops at theta = 0
