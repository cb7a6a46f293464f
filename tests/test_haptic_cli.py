"""``cosim haptic ...`` writes the documented tables and plots, under the output-folder rule of every command."""

import pandas as pd
import pytest

from cosim.cli import main
from cosim.outputs import MARKER


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


def test_identify_cli(tmp_path, capsys):
    assert main(["haptic", "identify", "--user", "1", "--position", "5", "--out", str(tmp_path)]) == 0
    t = pd.read_csv(tmp_path / "identification.csv")
    assert list(t.parameter) == ["m1", "b1", "bc", "kc", "m2", "bs", "ks"]
    inf = t[t.informative]
    assert (inf.rel_error.abs() < 0.05).all()
    assert (tmp_path / MARKER).is_file()
    first = (tmp_path / "identification.csv").read_bytes()
    assert main(["haptic", "identify", "--user", "1", "--position", "5", "--seed", "1", "--out", str(tmp_path)]) == 2
    assert "pass --force" in capsys.readouterr().err and (tmp_path / "identification.csv").read_bytes() == first


@pytest.mark.parametrize("command, written", [
    (["margins"], "margins.csv"), (["collisions"], "collisions.csv"), (["identify"], "identification.csv"),
    (["arm"], "arm_fits.csv")])
def test_a_users_folder_is_refused_and_kept(command, written, tmp_path, capsys):
    # issue 44: `echo precious > mine/margins.csv; cosim haptic margins --out mine` replaced the file, exit 0
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / written).write_text("precious\n")
    for force in ([], ["--force"]):
        assert main(["haptic", *command, "--out", str(mine), *force]) == 2
        assert "not a cosim output" in capsys.readouterr().err
        assert [p.name for p in mine.iterdir()] == [written] and (mine / written).read_text() == "precious\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]  # no staging folder or lock left


def test_bad_users_list(tmp_path, capsys):
    assert main(["haptic", "collisions", "--users", "1;2", "--out", str(tmp_path)]) == 2
    assert "--users" in capsys.readouterr().err
