"""A run's plot reads at a glance (issue #44 item 9): its title says what ran, measured signals are drawn above
their references, axes are named by their quantity, modes are labelled, a panel zooms on the impact, and a run
that stopped early shows where."""

import dataclasses
import re

import numpy as np
import pytest
from PIL import Image
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides  # noqa: F401

from cosim.cli import main
from cosim.config import load_config
from cosim.master import engine_for, summarize
from cosim.master.plot import run_figure

IMPACT = EXAMPLES / "gripper_impact.toml"


@pytest.fixture(scope="module")
def impact_run(gripper_dir):  # noqa: F811
    config = load_config(IMPACT, gripper_overrides(gripper_dir))
    result = engine_for(config).run(progress=False)
    return config, result, summarize(result, config)


def _line(ax, label):
    return next(line for line in ax.get_lines() if line.get_label().startswith(label))


def test_cosim_run_png_title_says_model_scenario_and_parameters(gripper_dir, tmp_path, capsys):  # noqa: F811
    argv = ["run", str(IMPACT), "--out", str(tmp_path / "o"), "--no-progress",
            "--set", "controllers.outer.parameters.speed_rpm=750"]
    for s in gripper_overrides(gripper_dir):
        argv += ["--set", s]
    assert main(argv) == 0
    title = " ".join(Image.open(tmp_path / "o" / "impact.png").text["Title"].split())
    # the model, the profile with the overridden speed and the tightening current and time the config sets
    assert title.startswith("GripperPlant: impact")
    assert "750 rpm" in title and "1 A for 1.5 s" in title and re.search(r"eta_g=0\.\d+", title)
    assert "--set controllers.outer.parameters.speed_rpm=750 fmus.plant.path=GripperPlant.fmu" in title


def test_measured_above_reference_named_axes_mode_labels(impact_run):
    config, result, summary = impact_run
    fig = run_figure(result, panels=config.plot.panels, config=config, summary=summary)
    axes = fig.axes
    # panel 2: the plant's i_q drawn over the loop's reference
    assert _line(axes[1], "i_q").get_zorder() > _line(axes[1], "outer.i_q_ref").get_zorder()
    assert _line(axes[2], "w_m").get_zorder() > _line(axes[2], "outer.w_set").get_zorder()
    assert axes[2].get_ylabel() == "speed [rad/s]"
    assert axes[0].get_ylabel() == "force F_g [N]"
    assert [t.get_text() for t in axes[4].get_yticklabels()] == ["0: velocity", "1: current"]


def test_zoomed_panel_holds_the_force_peak(impact_run):
    config, result, summary = impact_run
    fig = run_figure(result, panels=config.plot.panels, config=config, summary=summary)
    zoom = fig.axes[-1]
    lo, hi = zoom.get_xlim()
    t, force = result.data["time"], result.data["F_g"]
    t_peak = t[np.argmax(force)]
    t_contact = t[np.nonzero(force > 1.0)[0][0]]
    assert lo < t_contact < t_peak < hi and hi - lo < 0.1 * (config.run.stop - config.run.start)
    # the zoomed axis spans the force there, not the whole run's range of time
    assert zoom.get_ylim()[1] >= force.max() and fig.axes[0].get_xlim() == (0.0, config.run.stop)


def test_run_stopped_early_is_marked(impact_run):
    config, result, _ = impact_run
    keep = result.data["time"] <= 0.5
    stopped = {"by": "plant", "time": 0.5, "reason": "non-finite value of plant.F_g", "cause": "non-finite"}
    short = dataclasses.replace(result, data=result.data[keep], stopped=stopped)
    fig = run_figure(short, panels=config.plot.panels, config=config)
    assert "STOPPED EARLY at t = 0.5 s: non-finite value of plant.F_g" in fig.get_suptitle()
    for ax in fig.axes:
        # the full run's span with a line at the stop
        assert ax.get_xlim()[1] == config.run.stop
        assert any(list(line.get_xdata()) == [0.5, 0.5] for line in ax.get_lines())


def test_identification_plot_title_names_the_fitted_band(tmp_path):
    assert main(["haptic", "identify", "--user", "1", "--position", "3", "--out", str(tmp_path / "o")]) == 0
    title = Image.open(tmp_path / "o" / "identification.png").text["Title"]
    # the fit uses the Welch bins (1000 Hz / 4096 apart) inside 0.5-70 Hz: the 3rd to the 286th
    df = 1000.0 / 4096
    first, last = np.ceil(0.5 / df) * df, np.floor(70.0 / df) * df
    assert f"fitted {first:.2f}-{last:.1f} Hz" in title and "excitation: white-noise torque 0.1-150 Hz" in title
