"""``cosim sensitivity`` (issue 43, item 2): the Sobol indices against the Ishigami function's, known in closed form,
and a reduced job through the real machinery (the campaign's trials on Dask): the same points and outputs from one
and two workers, and a factor that does not reach a coating has a total index of exactly zero there.

Ishigami, f = sin x1 + a sin^2 x2 + b x3^4 sin x1 on [-pi, pi]^3 (Ishigami and Homma 1990; the variances as in
Sobol' and Levitan 1999): V = a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2, V1 = (1 + b pi^4/5)^2 / 2, V2 = a^2/8,
V13 = b^2 pi^8 (1/18 - 1/50); S1 = (V1, V2, 0) / V, ST = (V1 + V13, V2, V13) / V.
"""

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.campaign.sobol import Factor, sample_points, sobol_indices
from cosim.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
A, B = 7.0, 0.1


def _ishigami_truth():
    pi4, pi8 = math.pi**4, math.pi**8
    v = A**2 / 8 + B * pi4 / 5 + B**2 * pi8 / 18 + 0.5
    v1, v2, v13 = (1 + B * pi4 / 5) ** 2 / 2, A**2 / 8, B**2 * pi8 * (1 / 18 - 1 / 50)
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


def test_indices_of_the_ishigami_function_match_the_closed_form():
    factors = [Factor(n, -math.pi, math.pi) for n in ("x1", "x2", "x3")]
    points = sample_points(factors, 4096, seed=1)
    assert len(points) == 4096 * (3 + 2)
    x = np.array([[p[f.name] for f in factors] for p in points])
    y = np.sin(x[:, 0]) + A * np.sin(x[:, 1]) ** 2 + B * x[:, 2] ** 4 * np.sin(x[:, 0])
    r = sobol_indices(factors, y, resamples=200, seed=1)
    s1, st = _ishigami_truth()
    np.testing.assert_allclose(r["S1"], s1, atol=0.02)
    np.testing.assert_allclose(r["ST"], st, atol=0.02)
    assert np.all(r["S1_conf"] < 0.05) and np.all(r["ST_conf"] < 0.05)
    # the truth lies inside the 95 % intervals (widened by the sample's own error of the closed form's 4 digits)
    assert np.all(np.abs(r["ST"] - st) <= r["ST_conf"] + 1e-3)


def test_a_log_scale_factor_is_sampled_uniformly_in_its_logarithm():
    points = sample_points([Factor("c", 100.0, 10000.0, "log")], 1024, seed=2)
    logs = np.log10([p["c"] for p in points])
    assert logs.min() >= 2.0 and logs.max() <= 4.0
    assert abs(np.median(logs) - 3.0) < 0.05  # the geometric middle, not the arithmetic (5050)


REDUCED = ["sensitivity.samples=2", "sensitivity.trials=2", 'sensitivity.coatings=["bare","P3"]',
           "sensitivity.currents_A=[1.0]", "sensitivity.hold_s=0.3", "sensitivity.steady_s=0.2",
           "sensitivity.batch=4"]


@pytest.fixture(scope="module")
def reduced(tmp_path_factory, gripper_fmus):
    """The shipped job on a reduced grid (2 base samples: 16 points x 2 coatings x 2 trials) on 1 and 2 workers."""
    import re

    folder = tmp_path_factory.mktemp("sensitivity")
    for name in ("gripper_impact.toml", "gripper_impact_p3.toml"):
        text = (EXAMPLES / name).read_text(encoding="utf-8")
        text = re.sub(r'path = "\.\./fmus/GripperPlant\.fmu"', f'path = "{gripper_fmus["GripperPlant"]}"', text)
        text = re.sub(r'parameters_file = "([^"]+)"', lambda m: f'parameters_file = "{EXAMPLES / m.group(1)}"', text)
        (folder / name).write_text(text, encoding="utf-8")
    for name in ("campaign_table1.toml", "sensitivity_table1.toml"):
        (folder / name).write_text((EXAMPLES / name).read_text(encoding="utf-8"), encoding="utf-8")
    outs = {}
    for workers in (1, 2):
        out = folder / f"out{workers}"
        argv = ["sensitivity", str(folder / "sensitivity_table1.toml"), "--out", str(out), "--workers", str(workers),
                "--no-progress"]
        for s in REDUCED:
            argv += ["--set", s]
        assert main(argv) == 0
        outs[workers] = out
    return outs


@pytest.mark.slow
def test_reduced_job_is_the_same_on_one_and_two_workers(reduced):
    one, two = (pd.read_parquet(reduced[w] / "points.parquet") for w in (1, 2))
    assert len(one) == 2 * (6 + 2)
    pd.testing.assert_frame_equal(one, two)
    assert pd.read_csv(reduced[1] / "indices.csv").equals(pd.read_csv(reduced[2] / "indices.csv"))
    assert (reduced[1] / "indices.png").stat().st_size > 10_000


@pytest.mark.slow
def test_a_factor_reaches_only_the_coatings_it_names(reduced):
    points = pd.read_parquet(reduced[1] / "points.parquet")
    table = pd.read_csv(reduced[1] / "indices.csv")
    bare = table[(table.coating == "bare") & table.factor.isin(["d_lim", "k_H_ratio"])]
    # Saltelli's points differing from a base point only in d_lim (or k_H) give bare the same trials exactly
    assert (bare["ST"].fillna(0.0) == 0.0).all()
    p3 = points["P3_1000rpm_1A_median_N"]
    assert p3.nunique() > len(points) // 2  # every factor reaches P3: its steady force differs between points
    summary = json.loads((reduced[1] / "summary.json").read_text())
    assert summary["points"] == 16 and summary["trials"] == 16 * 2 * 2
    assert set(summary["factors"]) == {"d_lim", "k_H_ratio", "C_h", "Kp", "Ki", "thr"}


def test_a_bad_value_of_the_reduced_grid_is_told_where_the_user_gave_it(tmp_path, capsys):
    # the grid's keys go to the campaign job as its campaign.* values: before, a problem of one was told as
    # "--set campaign.hold_s", a key the user never typed, and a TOML date there was a TypeError traceback
    for name in ("campaign_table1.toml", "gripper_impact.toml", "gripper_impact_p3.toml"):
        (tmp_path / name).symlink_to(EXAMPLES / name)
    text = (EXAMPLES / "sensitivity_table1.toml").read_text(encoding="utf-8")
    job = tmp_path / "sensitivity_table1.toml"
    job.write_text(text.replace("\nhold_s = 1.0 ", "\nhold_s = -1.0 "), encoding="utf-8")
    line = text.splitlines().index(next(t for t in text.splitlines() if t.startswith("hold_s = 1.0 "))) + 1
    out = tmp_path / "out"
    assert main(["sensitivity", str(job), "--out", str(out)]) == 2
    assert f"sensitivity_table1.toml:{line} (sensitivity.hold_s): campaign.hold_s: must be > 0; got -1.0" in \
        capsys.readouterr().err
    for value, told in (("1979-05-27", "must be a number; got datetime.date(1979, 5, 27)"),
                        ("nan", "must be a number; got nan")):
        argv = ["sensitivity", str(EXAMPLES / "sensitivity_table1.toml"), "--out", str(out),
                "--set", f"sensitivity.hold_s={value}"]
        assert main(argv) == 2
        assert f"--set sensitivity.hold_s: campaign.hold_s: {told}" in capsys.readouterr().err
    assert not out.exists()
