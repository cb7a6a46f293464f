"""``cosim campaign``: a reduced grid (2 cells x 5 trials, 0.3 s of tightening: the machinery, not the physics) end
to end with its statistics recomputed by hand from trials.parquet; the same trials from 1 and 2 workers, after an
interruption and through a real ``dask scheduler`` / ``dask worker``; one trial re-run alone; bad input.

References: numpy's percentiles on the rows of trials.parquet (the table is checked against them, not against
the code that wrote it), the paper's Table 1 IQRs written here by hand, the issue's column list.
"""

import json
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.campaign import load_campaign, run_campaign, run_one_trial
from cosim.cli import main
from cosim.errors import ConfigError

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
# 2 cells (bare and P3 at 1000 rpm, 1 A) x 5 trials; 0.3 s of tightening, steady force over its last 0.2 s
GRID = ["campaign.trials=5", "campaign.hold_s=0.3", "campaign.steady_s=0.2", 'campaign.coatings=["bare","P3"]',
        "campaign.speeds_rpm=[1000]", "campaign.currents_A=[1.0]", "campaign.batch=2"]
# issue #30, item 4
COLUMNS_ISSUE = ["coating", "speed_rpm", "current_A", "trial", "seed"]
RESULTS_ISSUE = ["peak_force_N", "min_force_after_peak_N", "steady_force_N", "bounced", "t_contact_s"]
# the paper's Table 1 (steady-force IQR, N) at 1000 rpm, 1 A
PAPER_IQR = {"bare": 7.7, "P3": 6.04}


@pytest.fixture(scope="module")
def job_path(tmp_path_factory, gripper_fmus):
    """The shipped job and impact configs copied beside each other, the configs pointed at the session's FMU."""
    folder = tmp_path_factory.mktemp("campaign_job")
    for name in ("gripper_impact.toml", "gripper_impact_p3.toml"):
        text = (EXAMPLES / name).read_text(encoding="utf-8")
        text, n = re.subn(r'path = "\.\./fmus/GripperPlant\.fmu"', f'path = "{gripper_fmus["GripperPlant"]}"', text)
        assert n == 1
        text = re.sub(r'parameters_file = "([^"]+)"', lambda m: f'parameters_file = "{EXAMPLES / m.group(1)}"', text)
        (folder / name).write_text(text, encoding="utf-8")
    job = folder / "campaign_table1.toml"
    job.write_text((EXAMPLES / "campaign_table1.toml").read_text(encoding="utf-8"), encoding="utf-8")
    return job


@pytest.fixture(scope="module")
def one_worker(job_path, tmp_path_factory):
    """The reduced grid on a local cluster of one worker: (output folder, summary)."""
    out = tmp_path_factory.mktemp("campaign_runs") / "one"
    return out, run_campaign(job_path, out=out, overrides=GRID, workers=1, progress=False)


def _trials(out):
    return pd.read_parquet(Path(out) / "trials.parquet")


@pytest.mark.slow
def test_reduced_grid_end_to_end_statistics_by_hand(one_worker):
    out, summary = one_worker
    trials = _trials(out)
    drawn = [c for c in trials.columns if c not in COLUMNS_ISSUE + RESULTS_ISSUE]
    assert list(trials.columns) == COLUMNS_ISSUE + drawn + RESULTS_ISSUE
    assert len(drawn) >= 6  # placement, play, encoder, friction, gear, controller phase, load cell
    assert len(trials) == 10 and summary.trials == 10
    assert set(trials["seed"]) == set(trials["seed"].unique()) and trials["seed"].nunique() == 10
    table = pd.read_csv(out / "table1.csv")
    assert list(table.columns) == ["coating", "speed_rpm", "current_A", "n", "median_N", "q1_N", "q3_N", "iqr_N",
                                   "outlier_share"]
    for row in table.itertuples():
        f = trials[(trials.coating == row.coating) & (trials.current_A == row.current_A)]["steady_force_N"]
        f = f[np.isfinite(f)].to_numpy()
        q1, med, q3 = np.percentile(f, [25, 50, 75])
        assert row.n == len(f)
        np.testing.assert_allclose([row.median_N, row.q1_N, row.q3_N, row.iqr_N], [med, q1, q3, q3 - q1],
                                   rtol=1e-12)  # the same numbers, written to CSV and read back
        outside = np.sum((f < q1 - 1.5 * (q3 - q1)) | (f > q3 + 1.5 * (q3 - q1)))
        assert row.outlier_share == pytest.approx(outside / len(f))
        # physics, loosely: a tightening force of tens of N after a peak above it
        assert 10.0 < med < 300.0
        assert (trials[trials.coating == row.coating]["peak_force_N"] >= f.min() - 1.0).all()
    md = (out / "table1.md").read_text(encoding="utf-8")
    for c, iqr in PAPER_IQR.items():
        assert f"{iqr:.2f}" in md, c
    assert (out / "boxplots.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert s["run"]["ran"] == 10 and 0.0 <= s["run"]["overhead_share"] < 0.5


@pytest.mark.slow
def test_same_trials_from_two_workers(job_path, one_worker, tmp_path):
    out, _ = one_worker
    summary = run_campaign(job_path, out=tmp_path / "two", overrides=GRID, workers=2, progress=False)
    assert summary.run["workers"] == 2
    pd.testing.assert_frame_equal(_trials(tmp_path / "two"), _trials(out))
    assert (tmp_path / "two" / "table1.csv").read_text() == (out / "table1.csv").read_text()


@pytest.mark.slow
def test_interrupted_run_resumes_to_the_same_trials(job_path, one_worker, tmp_path):
    out = tmp_path / "cut"
    sets = [a for s in GRID for a in ("--set", s)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim", "campaign", str(job_path), "--out", str(out), *sets,
                             "--workers", "1", "--no-progress"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 240
    while not list(out.glob("parts/*.parquet")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    kept = len(list(out.glob("parts/*.parquet")))
    assert 1 <= kept < 6  # 2 cells x 5 trials in batches of 2: 6 parts in all
    assert "the same command resumes" in err
    summary = run_campaign(job_path, out=out, overrides=GRID, workers=1, progress=False)
    assert summary.run["resumed"] >= 2 and summary.run["resumed"] + summary.run["ran"] == 10
    pd.testing.assert_frame_equal(_trials(out), _trials(one_worker[0]))


@pytest.mark.slow
def test_real_dask_scheduler_and_worker_processes(job_path, one_worker, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    procs = [subprocess.Popen(dask + ["--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
                                      str(file)], cwd=ROOT, env=env, stderr=subprocess.DEVNULL)]
    try:
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file",
                                       str(file), "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                                       "--host", "127.0.0.1"], cwd=ROOT, env=env, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 60
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        summary = run_campaign(job_path, out=tmp_path / "remote", overrides=GRID, scheduler=address, progress=False)
        assert summary.run["workers"] == 1
        pd.testing.assert_frame_equal(_trials(tmp_path / "remote"), _trials(one_worker[0]))
    finally:
        for p in procs[::-1]:
            p.terminate()
            p.wait(timeout=30)


@pytest.mark.slow
def test_one_trial_alone_gives_its_row_and_a_cosim_run_command(job_path, one_worker, tmp_path):
    row, command = run_one_trial(job_path, 7, GRID)
    trials = _trials(one_worker[0])
    pd.testing.assert_frame_equal(pd.DataFrame([row]), trials.iloc[[7]].reset_index(drop=True), check_dtype=False)
    expected = trials.iloc[7]
    argv = shlex.split(command)
    assert argv[:4] == ["python", "-m", "cosim", "run"]
    out = tmp_path / "alone"
    subprocess.run([sys.executable, *argv[1:], "--out", str(out), "--no-progress"], cwd=ROOT, check=True,
                   env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True)
    s = json.loads((out / "summary.json").read_text())
    # the same co-simulation: the same recorded force, so the same peak and contact time
    assert s["peak_force_N"] == pytest.approx(expected["peak_force_N"], rel=1e-12)
    assert s["t_contact_s"] == pytest.approx(expected["t_contact_s"], rel=1e-12)


# Bare fingers at 750 rpm, 0.5 A, trial 6: a trial of the shipped job whose trigger fires 0.18 s after contact,
# later than the job's margin allows (found by running the cell's trials in order at the static calibration's force
# scale; at the datasheet scale it was trial 65, one of 10 of the cell's 100 trials that the full campaign left
# without a steady force before the runner ran such trials to their end).
LATE = ["campaign.trials=100", "campaign.hold_s=0.3", "campaign.steady_s=0.2", "campaign.margin_s=0.05",
        'campaign.coatings=["bare"]', "campaign.speeds_rpm=[750]", "campaign.currents_A=[0.5]"]


def test_a_late_trigger_is_run_to_the_end_of_its_tightening(job_path, tmp_path):
    """The row's steady force is the mean of the 100 Hz load-cell samples over the last steady_s of tightening,
    recomputed here from the force of the printed ``cosim run`` command (its own run) plus the drawn noise's mean."""
    row, command = run_one_trial(job_path, 6, LATE)
    argv = shlex.split(command)
    out = tmp_path / "late"
    subprocess.run([sys.executable, *argv[1:], "--out", str(out), "--no-progress"], cwd=ROOT, check=True,
                   env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True)
    s = json.loads((out / "summary.json").read_text())
    assert s["t_switch_s"] - row["t_contact_s"] > 0.1  # later than the job's margin allows
    data = pd.read_parquet(out / "results.parquet")
    end = s["t_switch_s"] + 0.3
    assert data["time"].iloc[-1] >= end
    samples = end - np.arange(20)[::-1] / 100.0
    expected = np.mean(np.interp(samples, data["time"], data["F_g"])) + row["load_cell_noise_N"]
    assert row["steady_force_N"] == pytest.approx(expected, abs=1e-9)


@pytest.mark.slow
def test_resume_against_a_changed_job_is_refused_naming_the_change(job_path, one_worker):
    out, _ = one_worker
    t0 = time.monotonic()
    with pytest.raises(ConfigError, match=r"job\.trials: 5 -> 4"):
        run_campaign(job_path, out=out, overrides=GRID + ["campaign.trials=4"], workers=1, progress=False)
    assert time.monotonic() - t0 < 30  # refused before any cluster starts


def _job_text(job_path):
    return job_path.read_text(encoding="utf-8")


def test_unknown_coating_and_coating_without_parameters_are_refused(job_path, tmp_path):
    with pytest.raises(ConfigError, match=r"unknown coating 'P4'.*bare, P1, P2, P3"):
        load_campaign(job_path, ['campaign.coatings=["bare","P4"]'])
    text = re.sub(r"\[coatings\.P1\]\nconfig = .*\nparameters = .*\n", "", _job_text(job_path))
    assert "[coatings.P1]" not in text
    bad = job_path.parent / "no_p1.toml"
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=r"no_p1\.toml.*coating 'P1' has no parameters"):
        load_campaign(bad)
    with pytest.raises(ConfigError, match=r"sources\.free_travel\.reason: is required"):
        load_campaign(job_path, ['sources.free_travel.reason=""'])


def test_coating_parameters_are_checked_against_the_plant_fmu_at_load(job_path, tmp_path, capsys):
    # a made-up name and a negative stiffness in the file, a percent efficiency by --set: before, the job loaded
    # and the first trial's run config failed on a Dask worker after the output folder was made
    text = _job_text(job_path).replace('[coatings.bare]\nconfig = "gripper_impact.toml"\n',
                                       '[coatings.bare]\nconfig = "gripper_impact.toml"\nparameters = { k_PP = 3 }\n')
    text = text.replace('[coatings.P3]\nconfig = "gripper_impact_p3.toml"\n',
                        '[coatings.P3]\nconfig = "gripper_impact_p3.toml"\nparameters = { k_P = -1 }\n')
    bad = job_path.parent / "bad_coatings.toml"
    bad.write_text(text, encoding="utf-8")
    line = {key: text.splitlines().index(f"parameters = {{ {key} }}") + 1 for key in ("k_PP = 3", "k_P = -1")}
    out = tmp_path / "out"
    sets = [a for s in [*GRID, "coatings.bare.parameters.eta_g=68"] for a in ("--set", s)]
    assert main(["campaign", str(bad), "--out", str(out), "--workers", "1", "--no-progress", *sets]) == 2
    err = capsys.readouterr().err
    assert (f"bad_coatings.toml:{line['k_PP = 3']}: coatings.bare.parameters.k_PP: GripperPlant.fmu has no "
            "parameter 'k_PP'; did you mean 'k_P'") in err
    # a stiffness is not negative: [0, inf] N/m, as the run config's fmus.plant.parameters.k_P says
    assert (f"bad_coatings.toml:{line['k_P = -1']}: coatings.P3.parameters.k_P: -1.0 is outside the range "
            "GripperPlant.fmu declares for k_P: [0, inf] N/m") in err
    assert ("--set coatings.bare.parameters.eta_g: coatings.bare.parameters.eta_g: 68.0 is outside the range "
            "GripperPlant.fmu declares for eta_g: [0, 1] (no unit: a ratio); a percentage? 68 % is 0.68") in err
    assert not out.exists()
    # a made-up name by --set alone on the shipped job: refused the same way
    assert main(["campaign", str(job_path), "--out", str(out), "--set", "coatings.bare.parameters.k_PP=3"]) == 2
    assert ("--set coatings.bare.parameters.k_PP: coatings.bare.parameters.k_PP: GripperPlant.fmu has no parameter "
            "'k_PP'; did you mean 'k_P'") in capsys.readouterr().err
    assert not out.exists()


def test_the_jobs_parameters_file_is_checked_against_the_plant_fmus_at_load(job_path, tmp_path, capsys):
    # a calibration of another model (a name GripperPlant lacks) and an efficiency in percent, in the job's
    # parameters file: before, the job loaded and the first trial failed on a Dask worker
    calibrated = tmp_path / "other.toml"
    calibrated.write_text("[parameters]\nR_winding = 0.5\neta_g = 63.0\n", encoding="utf-8")
    out = tmp_path / "out"
    sets = [a for s in [*GRID, f"campaign.parameters_file={calibrated}"] for a in ("--set", s)]
    assert main(["campaign", str(job_path), "--out", str(out), "--no-progress", *sets]) == 2
    err = capsys.readouterr().err
    assert "--set campaign.parameters_file: campaign.parameters_file: GripperPlant.fmu has no parameter 'R_winding'" in err
    assert ("campaign.parameters_file: 63.0 is outside the range GripperPlant.fmu declares for eta_g: [0, 1] (no unit: "
            "a ratio); a percentage? 63 % is 0.63") in err
    assert err.count("R_winding") == 1  # both coatings run the same plant FMU: said once
    assert not out.exists()


def test_scheduler_that_does_not_answer_is_a_clear_error_within_seconds(job_path, tmp_path):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    with pytest.raises(ConfigError, match=rf"no Dask scheduler answered at 'tcp://127\.0\.0\.1:{port}'"):
        run_campaign(job_path, out=tmp_path / "x", overrides=GRID, scheduler=f"tcp://127.0.0.1:{port}",
                     progress=False)
    assert time.monotonic() - t0 < 15


def test_a_trial_draws_the_same_values_whatever_the_grid_around_it(tmp_path):
    from cosim.campaign.draws import draw, trial_list

    full = load_campaign(EXAMPLES / "campaign_table1.toml")
    small = load_campaign(EXAMPLES / "campaign_table1.toml", GRID)
    assert len(trial_list(full)) == 4 * 3 * 5 * 100  # the paper's 6,000 impacts
    by_identity = {(s.coating, s.speed_rpm, s.current_A, s.trial): s for s in trial_list(full)}
    for s in trial_list(small):
        twin = by_identity[(s.coating, s.speed_rpm, s.current_A, s.trial)]
        assert s.seed == twin.seed and draw(small, s)[0] == draw(full, twin)[0]
    values = [draw(full, s)[0] for s in trial_list(full)[:200]]
    assert len({v["free_travel"] for v in values}) == 200  # every trial its own draw
    # the shipped uniform sources stay inside the bounds the job declares
    for name in ("free_travel", "play_position", "encoder_phase", "controller_phase"):
        src = full.source(name)
        assert all(src.a <= v[name] <= src.b for v in values), name
    # without a source, its value is 0 and the other sources' values do not move
    text = (EXAMPLES / "campaign_table1.toml").read_text(encoding="utf-8")
    cut = re.sub(r"\[sources\.gear_efficiency\]\n(?:.+\n)+?reason = .*\n", "", text)
    assert "gear_efficiency]" not in cut
    lean_path = tmp_path / "campaign_no_gear.toml"
    lean_path.write_text(cut.replace('config = "gripper_impact', f'config = "{EXAMPLES}/gripper_impact'),
                         encoding="utf-8")
    lean = load_campaign(lean_path)
    spec = trial_list(full)[0]
    a, b = draw(full, spec)[0], draw(lean, spec)[0]
    assert b["gear_efficiency"] == 0.0 and a["gear_efficiency"] != 0.0
    assert {k: v for k, v in a.items() if k != "gear_efficiency"} == {
        k: v for k, v in b.items() if k != "gear_efficiency"}
