"""Static-curve calibration of the gripper on synthetic data with known truth.

The data come from the project's own current-driven gripper model with known eta_g and T_c0, integrated by
fixed-step RK4 at 50 us (the fit integrates with CVODES, BDF and variable step), sampled at 100 Hz like the
paper's load cell, plus 0.3 N sensor noise. The fit must recover the truth within two standard errors."""

import numpy as np
import pytest

from cosim.calibrate import Calibrator
from cosim.calibrate.problem import Transcription
from cosim.compile import lower
from cosim.experiment import Experiment, steady_mask

from conftest import ROOT

pytestmark = pytest.mark.slow  # the gripper's static staircase fit

TRUTH = {"eta_g": 0.62, "T_c0": 0.011}
FIXED = {"gap0": 0.0, "k_obj": 1.234e9}  # static condition: fingers pinned to aluminium cylinders
NOISE = 0.3  # N


@pytest.fixture(scope="module")
def gripper():
    return lower(ROOT / "modelica" / "Gripper" / "package.mo", "Gripper.GripperCurrentDriven")


def staircase(step_s=0.5, top=1.0):
    levels = np.round(np.concatenate([np.arange(0, top + 1e-9, 0.1), np.arange(top - 0.1, -1e-9, -0.1)]), 3)
    t = np.round(np.arange(0, len(levels) * step_s, 0.01), 6)
    return t, levels[np.minimum((t // step_s).astype(int), len(levels) - 1)]


def test_static_staircase_recovers_efficiency_and_friction(gripper):
    t, current = staircase()
    shape = Experiment(t, current[:, None], np.zeros((len(t), 1)), np.ones(1), np.ones(len(t), bool))
    truth = Transcription(gripper, shape, ["F_g"], list(TRUTH), fixed=FIXED, substeps=200)  # RK4, h = 50 us
    force = truth.evaluate(np.array(list(TRUTH.values())))[3][0]
    measured = force + NOISE * np.random.default_rng(4).standard_normal(len(t))
    mask = steady_mask(t, current[:, None], 0.2, min_hold_s=0.0)
    data = Experiment(t, current[:, None], measured[:, None], np.array([1 / NOISE]), mask)
    # T_c0 starts between two staircase levels (k_t x 0.25 A): the cost has kinks where T_c0 = k_t x level.
    fit = Calibrator(gripper, ["F_g"], {"eta_g": (0.75, 0.3, 1.0), "T_c0": (0.0098, 1e-4, 0.05)}, fixed=FIXED,
                     method="single_shooting").fit(data)
    for name, value in TRUTH.items():
        assert abs(fit.parameters_[name] - value) < 2 * fit.std_errors_[name], (fit.parameters_, fit.std_errors_)
    assert fit.cost_after_ < 0.7 * mask.sum()  # about N/2 when the model is right
