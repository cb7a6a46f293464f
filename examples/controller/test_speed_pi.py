"""Tests of SpeedPI (speed_pi.py): its kernel against the PI's closed form, and a run through ``cosim run``.

    python3 -m pytest examples/controller
"""

import math
from pathlib import Path

import numpy as np
import pytest
from speed_pi import SpeedPI

import cosim

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent


@pytest.mark.parametrize("jit", [True, False])
def test_kernel_is_the_pi_closed_form(jit):
    pi = SpeedPI(rate=1000.0, jit=jit, Kp=0.01, Ki=0.5, speed_rpm=100.0, t_step=0.0)
    e = 100.0 * 2.0 * math.pi / 60.0  # rad/s: the motor stands still
    for k in range(10):
        pi.step(k / 1000.0)
        # the k-th sample: the proportional part plus k integral increments Ki e T
        assert pi.y[0] == pytest.approx(0.01 * e + k * 0.5 * e / 1000.0, rel=1e-12)
        assert pi.y[1] == pytest.approx(e, rel=1e-12)


def test_output_saturates_and_the_integral_stops():
    pi = SpeedPI(rate=1000.0, jit=False, Kp=0.01, Ki=0.5, i_max=0.2, speed_rpm=300.0, t_step=0.0)
    for k in range(1000):
        pi.step(k / 1000.0)
    assert pi.y[0] == 0.2
    # the integral stopped below i_max: the first sample past the set speed already lowers the output
    assert pi.x[0] < 0.2
    pi.u[0] = 1.1 * 300.0 * 2.0 * math.pi / 60.0
    pi.step(1.0)
    assert pi.y[0] < 0.2 - 0.01 * 0.1 * 300.0 * 2.0 * math.pi / 60.0 + 1e-12


def test_the_step_before_t_step_is_zero():
    pi = SpeedPI(rate=1000.0, jit=False, t_step=0.01)
    pi.step(0.005)
    assert pi.y[0] == 0.0 and pi.y[1] == 0.0


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory):
    """GripperPlant.fmu: the one ``cosim build`` made in fmus/, else built here from modelica/ (a fresh checkout)."""
    built = ROOT / "fmus" / "GripperPlant.fmu"
    if built.is_file():
        return built
    (fmu,) = cosim.build(ROOT / "modelica" / "Gripper" / "package.mo", "Gripper.GripperPlant",
                         out=tmp_path_factory.mktemp("fmus"))
    return fmu


def test_cosim_run_reaches_and_holds_the_speed(plant_fmu, tmp_path):
    out = tmp_path / "speed"
    result = cosim.run(HERE / "speed_pi.toml", set={"fmus.plant.path": str(plant_fmu)}, out=out, progress=False)
    data = result.frame()
    t, w = data.index.to_numpy(), data["w_m"].to_numpy()
    w_set = 300.0 * 2.0 * math.pi / 60.0
    assert data.attrs["units"]["w_m"] == "rad/s"
    # the integral removes the steady error (friction, the gear's load): within 1 % over the last 0.1 s
    assert np.mean(w[t >= 0.2]) == pytest.approx(w_set, rel=0.01)
    assert np.all(w[t < 0.01] == 0.0)  # nothing moves before the step
    assert data["x_jaw"].iloc[-1] < 0.006  # the jaws never reached the object
    assert (out / "speed.png").is_file()
