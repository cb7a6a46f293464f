"""Shared fixtures and helpers of the master/config/controller/FMI tests (no tests here).

FMUs are built once per session with ``cosim.compile.build_fmu``: a small driven oscillator whose
equations the tests integrate independently with scipy, and the three gripper FMUs.
"""

import textwrap
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"

OSC_MO = textwrap.dedent(
    """
    package MasterTests "Small models for the master's tests"
      model Osc "Damped oscillator driven by an input force; y = 2 x"
        parameter Real k(unit = "N/m") = 4.0 "Stiffness";
        parameter Real c(unit = "N.s/m") = 0.5 "Damping";
        input Real u(unit = "N") "Force";
        output Real y(unit = "m") "Twice the position";
        output Real v_out(unit = "m/s") "Velocity";
        Real x(unit = "m", start = 1.0, fixed = true) "Position";
        Real v(unit = "m/s", start = 0.0, fixed = true) "Velocity";
      equation
        der(x) = v;
        der(v) = -k*x - c*v + u;
        y = 2*x;
        v_out = v;
      end Osc;
    end MasterTests;
    """
)

# controllers used by the tests, loaded from a file by the configs ("ctl.py:Name")
CTL_PY = textwrap.dedent(
    '''
    import math
    import numpy as np
    from controllers.base import Controller

    def _sine(t, u, y, x, p):
        y[0] = p[0] * math.sin(2.0 * math.pi * p[1] * t)

    class Sine(Controller):
        """Source: amp * sin(2 pi f t)."""
        parameters = {"amp": 1.0, "f": 1.0}
        outputs = ("u",)
        kernel = staticmethod(_sine)

    def _step(t, u, y, x, p):
        y[0] = p[0] if t >= p[1] else 0.0

    class Step(Controller):
        """Source: value after t_step."""
        parameters = {"value": 1.0, "t_step": 0.0}
        outputs = ("y",)
        kernel = staticmethod(_step)

    def _hold(t, u, y, x, p):
        y[0] = u[0]

    CALLS = {}

    class Probe(Controller):
        """Passes its input through and logs the time of every call (plain Python)."""
        parameters = {"interrupt_at": -1.0}
        inputs = ("u",)
        outputs = ("y",)
        kernel = staticmethod(_hold)

        def step(self, t):
            if 0.0 <= self.values["interrupt_at"] <= t:
                raise KeyboardInterrupt
            CALLS.setdefault(id(self), []).append(t)
            super().step(t)
    '''
)


@pytest.fixture(scope="session")
def master_dir(tmp_path_factory):
    """A folder with Osc.fmu, the test controllers (ctl.py) and the gripper FMUs."""
    from cosim.compile import build_fmu

    d = tmp_path_factory.mktemp("master")
    (d / "MasterTests.mo").write_text(OSC_MO)
    (d / "ctl.py").write_text(CTL_PY)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        build_fmu(d / "MasterTests.mo", "MasterTests.Osc", out_dir=d)
    return d


@pytest.fixture(scope="session")
def gripper_dir(tmp_path_factory):
    """A folder with GripperPlant.fmu, PMSM.fmu and Drivetrain.fmu built from modelica/Gripper."""
    from cosim.compile import build_fmu

    d = tmp_path_factory.mktemp("gripper_master")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in ("GripperPlant", "PMSM", "Drivetrain"):
            build_fmu(ROOT / "modelica" / "Gripper" / "package.mo", f"Gripper.{name}", out_dir=d)
    return d


def osc_config(folder, extra="", stop=2.0, rate=1000, record_rate=100, solver="", amp=2.0, f=1.0):
    """Write an Osc + Sine config into ``folder`` and return its path."""
    text = textwrap.dedent(
        f"""
        [run]
        stop = {stop}

        {solver}

        [fmus.plant]
        path = "Osc.fmu"
        parameters = {{ k = 9.0 }}

        [controllers.src]
        class = "ctl.py:Sine"
        rate = {rate}
        parameters = {{ amp = {amp}, f = {f} }}

        [[connections]]
        from = "src.u"
        to = "plant.u"

        [record]
        rate = {record_rate}
        signals = ["plant.y", "plant.v_out", "src.u"]
        """
    ) + textwrap.dedent(extra)
    path = Path(folder) / "osc.toml"
    path.write_text(text)
    return path


def gripper_overrides(gripper_dir, split=False):
    """``--set`` items pointing a shipped gripper config at the session's FMUs."""
    if split:
        return [f"fmus.plant.path={gripper_dir / 'PMSM.fmu'}", f"fmus.drive.path={gripper_dir / 'Drivetrain.fmu'}"]
    return [f"fmus.plant.path={gripper_dir / 'GripperPlant.fmu'}"]
