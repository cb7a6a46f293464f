"""Issue 44 items: controller parameters refused when the controller is built (before a run), a run's rows kept
through faults of writing and plotting and through Ctrl-C while they are written, no temporary folder left by a
campaign or one of its trials, a campaign's Ctrl-C without the workers' tracebacks.

References are independent of the code under test: hand-written physically wrong values, the rows a run of
known length and record rate has, the signal number the shell expects (128 + 2).
"""

import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np
import pytest
from test_campaign import GRID, ROOT, job_path  # noqa: F401
from test_controllers import _all_controller_classes, required_parameters
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

from cosim_controllers.dc_drive import DcCurrentPI, DcSpeedPI
from cosim_controllers.foc import FOC
from cosim_controllers.haptic import AdaptiveWall, UserIntent, VirtualWall
from cosim_controllers.outer import ImpactSummary, OuterLoop
from cosim.cli import main
from cosim.errors import OutputWarning, ParameterError
from cosim.master import read_results
from cosim.outputs import MARKER

# -- controller parameters, checked when the controller is built -------------------------------------------------

WRONG = [  # values a user may type that no run can use: (class, key, value)
    (OuterLoop, "hold_s", -1.0),  # issue 44: ran the whole impact, then died in the summary
    (OuterLoop, "hold_s", 0.0),
    (OuterLoop, "thr", 1.5),  # eq. (2) compares a speed with thr times an earlier one: a ratio up to 1
    (OuterLoop, "enc_cpt", 2048.5),
    (OuterLoop, "ramp_s", math.nan),
    (FOC, "R_s", 0.0),
    (FOC, "pole_pairs", 2.5),
    (FOC, "bandwidth_hz", 13300.0),  # half of 26.6 kHz
    (VirtualWall, "K", -10.0),
    (AdaptiveWall, "position", 7),
    (AdaptiveWall, "B3", -0.1),
    (UserIntent, "accel_s", 0.0),
    (DcCurrentPI, "L", -2e-4),
    (DcSpeedPI, "crossover_hz", 1000.0),  # a tenth of its 10 kHz rate
]


@pytest.mark.parametrize("cls, key, value", WRONG, ids=[f"{c.__name__}.{k}={v}" for c, k, v in WRONG])
def test_a_wrong_parameter_value_is_a_typed_error_naming_the_key(cls, key, value):
    with pytest.raises(ParameterError) as err:
        cls(rate=26600.0 if cls is FOC else 10000.0, jit=False, **{key: value})
    assert err.value.key == key and err.value.controller == cls.__name__
    assert err.value.received is value and f"parameter {key!r}: expected " in str(err.value)


@pytest.mark.parametrize("cls", _all_controller_classes(), ids=lambda c: f"{c.__module__}.{c.__name__}")
def test_every_numeric_parameter_of_a_shipped_controller_has_limits(cls, tmp_path):
    numeric = [n for n, d in cls.parameters.items() if isinstance(d, (int, float)) and not isinstance(d, bool)]
    assert sorted(set(numeric) - set(cls.limits)) == []
    required = required_parameters(cls, tmp_path)
    for name in numeric:  # NaN is never a parameter value
        with pytest.raises(ParameterError, match=f"parameter {name!r}"):
            cls(rate=10000.0, jit=False, **required, **{name: math.nan})
    with pytest.raises(ParameterError, match="'rate'"):
        cls(rate=math.inf, **required)


def test_a_wrong_parameter_stops_cosim_run_before_the_run(tmp_path, capsys, gripper_dir):  # noqa: F811
    # issue 44: `cosim run examples/gripper_impact.toml --set controllers.outer.parameters.hold_s=-1` simulated
    # the whole run, then ValueError: zero-size array to reduction operation minimum, exit 1, nothing written
    out = tmp_path / "o"
    sets = [a for s in gripper_overrides(gripper_dir) for a in ("--set", s)]
    code = main(["run", str(EXAMPLES / "gripper_impact.toml"), *sets, "--set", "controllers.outer.parameters.hold_s=-1",
                 "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "--set controllers.outer.parameters.hold_s" in err
    assert "OuterLoop: parameter 'hold_s': expected a number in (0, inf) s; received -1" in err


def test_the_impact_summary_of_a_peak_after_the_tightening():
    # a hold shorter than the rise of the force: the peak (t = 2 s) comes after the tightening ends (1.5 s)
    data = np.zeros(4, dtype=[("time", float), ("F", float), ("t_sw", float)])
    data["time"] = [0.0, 1.0, 2.0, 3.0]
    data["F"] = [0.0, 5.0, 10.0, 3.0]
    data["t_sw"] = 1.0
    s = ImpactSummary.summarize(data, {"hold_s": 0.5}, {"force": "F", "t_switch": "t_sw"})
    assert s["peak_force_N"] == 10.0 and s["min_force_after_peak_N"] is None and s["t_contact_s"] == 1.0


# -- the rows are written whatever happens while writing -----------------------------------------------------------

def test_a_plot_that_cannot_be_drawn_is_a_warning_and_the_rows_are_written(master_dir, tmp_path, capsys):  # noqa: F811
    # a recorded signal swinging over +-1e308 (finite, so the run goes on): matplotlib cannot compute its ticks
    big = '[controllers.big]\nclass = "ctl.py:Sine"\nrate = 100\nparameters = { amp = 1e308, f = 1.0 }\n'
    cfg = osc_config(master_dir, stop=1.0, extra=big)
    out = tmp_path / "res"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["run", str(cfg), "--out", str(out), "--no-progress", "--set", 'record.signals=["big.u"]']) == 0
    messages = [str(w.message) for w in caught if w.category is OutputWarning]
    assert messages[0].startswith("signals.png was not made (ValueError")
    data, _, _ = read_results(out / "results.parquet")
    np.testing.assert_allclose(data["time"], np.arange(101) / 100, atol=1e-12)
    assert data["big.u"].max() > 0.99e308 and data["big.u"].min() < -0.99e308  # the swing, every row kept
    assert sorted(os.listdir(out)) == [MARKER, "results.parquet", "summary.json"]
    assert "wrote" in capsys.readouterr().out


def test_ctrl_c_while_the_results_are_written_finishes_the_write(master_dir, tmp_path, capsys,  # noqa: F811
                                                                  monkeypatch):
    # issue 44: a Ctrl-C while a finished run was written gave exit 130 and nothing written. A real SIGINT is
    # sent to this process at the instant results.parquet starts being written.
    import pyarrow.parquet as pq

    write_table = pq.write_table

    def ctrl_c_then_write(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        return write_table(*args, **kwargs)

    monkeypatch.setattr(pq, "write_table", ctrl_c_then_write)
    cfg = osc_config(master_dir, stop=2.0)
    out = tmp_path / "res"
    # Python's own handler, as a `cosim` process has it (a test worker may have inherited SIGINT ignored)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        assert main(["run", str(cfg), "--out", str(out), "--no-progress"]) == 130
        restored = signal.getsignal(signal.SIGINT)
    finally:
        signal.signal(signal.SIGINT, before)
    err = capsys.readouterr().err
    assert f"finishing writing the results into {out}" in err and "interrupted (SIGINT)" in err
    data, _, _ = read_results(out / "results.parquet")
    np.testing.assert_allclose(data["time"], np.arange(201) / 100, atol=1e-12)  # every row of the 2 s run
    assert json.loads((out / "summary.json").read_text())["rows"] == 201 and (out / "signals.png").is_file()
    assert restored is signal.default_int_handler


# -- no temporary folder outlives its command -----------------------------------------------------------------------

def _temporary_folder(monkeypatch, tmp_path):
    """This process's and its children's temporary folder, empty: what a command leaves in it is seen."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setenv("TMPDIR", str(folder))
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_one_campaign_trial_leaves_no_temporary_folder(job_path, tmp_path, monkeypatch, capsys):  # noqa: F811
    # issue 44: every `cosim campaign ... --trial K` left a cosim-plant-* folder (the FMU unpacked for the trials)
    folder = _temporary_folder(monkeypatch, tmp_path)
    sets = [a for s in GRID for a in ("--set", s)]
    assert main(["campaign", str(job_path), "--trial", "3", *sets]) == 0
    assert "peak_force_N = " in capsys.readouterr().out
    assert os.listdir(folder) == []


@pytest.mark.slow
def test_ctrl_c_on_a_campaign_is_clean_and_no_campaign_leaves_a_temporary_folder(job_path, tmp_path,  # noqa: F811
                                                                                  monkeypatch):
    # issue 44: Ctrl-C printed two 25-line tracebacks of the Dask workers before the campaign's own message, and
    # every campaign left a cosim-plant-* folder a worker. Ctrl-C as a terminal sends it: to the whole group.
    folder = _temporary_folder(monkeypatch, tmp_path)
    out = tmp_path / "cut"
    sets = [a for s in GRID for a in ("--set", s)]
    proc = subprocess.Popen([sys.executable, "-m", "cosim", "campaign", str(job_path), "--out", str(out), *sets,
                             "--workers", "2", "--no-progress"], cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 240
    while not list(out.glob("parts/*.parquet")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().endswith("the same command resumes")
    assert [p for p in os.listdir(folder) if p.startswith("cosim-")] == []
    assert main(["campaign", str(job_path), "--out", str(out), *sets, "--workers", "2", "--no-progress"]) == 0
    assert [p for p in os.listdir(folder) if p.startswith("cosim-")] == []


def test_ctrl_c_as_the_run_ends_keeps_every_row(master_dir, tmp_path, capsys, monkeypatch):  # noqa: F811
    # a real SIGINT at the instant the loop has ended and the FMUs are being closed, before anything is written
    from cosim.master.plant import PlantSystem

    close = PlantSystem.close

    def ctrl_c_then_close(self):
        os.kill(os.getpid(), signal.SIGINT)
        return close(self)

    monkeypatch.setattr(PlantSystem, "close", ctrl_c_then_close)
    out = tmp_path / "res"
    assert main(["run", str(osc_config(master_dir, stop=2.0)), "--out", str(out), "--no-progress"]) == 130
    assert "interrupted (SIGINT)" in capsys.readouterr().err
    data, _, _ = read_results(out / "results.parquet")
    np.testing.assert_allclose(data["time"], np.arange(201) / 100, atol=1e-12)


def test_ctrl_c_while_a_calibration_is_written_finishes_the_write(tmp_path, capsys, monkeypatch):
    # a real SIGINT to this process at the instant the fit's plot starts (calibration.json is written before it)
    import cosim.calibrate.report as report
    from test_calibrate import write_job

    plot = report._plot

    def ctrl_c_then_plot(*args):
        os.kill(os.getpid(), signal.SIGINT)
        return plot(*args)

    monkeypatch.setattr(report, "_plot", ctrl_c_then_plot)
    out = tmp_path / "fit"
    assert main(["calibrate", str(write_job(tmp_path)), "--out", str(out), "--no-progress"]) == 130
    assert "interrupted (SIGINT)" in capsys.readouterr().err
    assert sorted(os.listdir(out)) == [MARKER, "calibration.json", "fit.png", "parameters.toml"]
    fit = json.loads((out / "calibration.json").read_text())
    assert fit["cost_after"] < fit["cost_before"]
