"""``cosim haptic margins`` writes the documented table and plot."""

import pandas as pd

from cosim.cli import main


def test_margins_cli(tmp_path):
    assert main(["haptic", "margins", "--out", str(tmp_path)]) == 0
    t = pd.read_csv(tmp_path / "margins.csv")
    assert list(t.columns) == ["user", "position", "model", "K_CR_Nm_per_rad", "PM_deg", "f_cross_Hz", "zeta",
                               "overshoot", "settling_s"]
    assert len(t) == 78
    assert (tmp_path / "margins.png").stat().st_size > 1000
    r = t[(t.user == 1) & (t.position == 3)].iloc[0]
    assert r.model == 11 and abs(r.PM_deg - 40) < 2
