"""``cosim haptic margins`` writes the documented table and plot."""

import pandas as pd
import pytest

from cosim.cli import main


@pytest.mark.slow
def test_margins_cli(tmp_path):
    assert main(["haptic", "margins", "--out", str(tmp_path)]) == 0
    t = pd.read_csv(tmp_path / "margins.csv")
    assert list(t.columns) == ["user", "position", "model", "K_CR_Nm_per_rad", "PM_deg", "f_cross_Hz", "zeta",
                               "overshoot", "settling_s"]
    assert len(t) == 78
    assert (tmp_path / "margins.png").stat().st_size > 1000
    r = t[(t.user == 1) & (t.position == 3)].iloc[0]
    assert r.model == 11 and abs(r.PM_deg - 40) < 2


def test_identify_cli(tmp_path):
    assert main(["haptic", "identify", "--user", "1", "--position", "5", "--out", str(tmp_path)]) == 0
    t = pd.read_csv(tmp_path / "identification.csv")
    assert list(t.parameter) == ["m1", "b1", "bc", "kc", "m2", "bs", "ks"]
    inf = t[t.informative]
    assert (inf.rel_error.abs() < 0.05).all()


def test_bad_users_list(tmp_path, capsys):
    assert main(["haptic", "collisions", "--users", "1;2", "--out", str(tmp_path)]) == 2
    assert "--users" in capsys.readouterr().err
