"""Helpers for the gripper tests (no tests here): FMU builds, a fixed-step RK4 driver over FMI 3 ME, conditions.

The references the tests compare against are written by hand in each test (analytic formulas, values of
``../shared/data/gripper_params.csv`` copied into :data:`PAPER`); this module only runs the FMUs.
"""

import csv
import ctypes
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
GRIPPER_MO = ROOT / "modelica" / "Gripper" / "package.mo"
CONDITIONS_CSV = ROOT / "cosim" / "data" / "gripper_conditions.csv"

# Values of gripper_params.csv (seed 002) used as references, in SI units: kind paper / derived / estimate.
PAPER = {
    "k_t": 0.13 / 3.3,  # nominal torque / nominal current (estimate row k_t)
    "omega_nl": 5600 * 2 * np.pi / 60,  # paper: no-load speed
    "R_s": 0.45,  # estimate
    "L_q": 2.5e-4,  # estimate
    "ratio": 28.0,  # paper
    "play": np.deg2rad(0.8),  # paper
    "r_p": 0.008957,  # estimate (33.5 mm/s at 1000 rpm)
    "k_f": 1.46e6,  # paper (FEM)
    "k_cyl": 3.53e7,  # paper
    "k_P": {"P1": 5e6, "P2": 1.8e5, "P3": 3.5e4},  # paper
    "k_H_ratio": 100.0,  # paper
    "T_c0": 0.2 * 0.13 / 3.3,  # dead zone 0.2 A (paper) times k_t
}


def build_gripper_fmus(out_dir, names=("GripperPlant", "PMSM", "Drivetrain")):
    """Build the named ``Gripper.<name>`` models into ``out_dir``; returns a dict name -> FMU path."""
    from cosim.compile import build_fmu

    paths = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in names:
            paths[name] = build_fmu(GRIPPER_MO, f"Gripper.{name}", out_dir=out_dir)
    return paths


def load_conditions(path=CONDITIONS_CSV):
    """Read the shipped contact-condition parameter sets: dict condition -> dict parameter -> value."""
    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(row for row in f if not row.startswith("#")):
            out.setdefault(row["condition"], {})[row["parameter"]] = float(row["value"])
    return out


class Rk4Fmu:
    """One FMI 3 Model-Exchange instance stepped by the caller (classic RK4 helpers).

    Parameters
    ----------
    path : path-like
        FMU file.
    params : dict of str to float, optional
        Parameter values set before initialisation.
    """

    def __init__(self, path, params=None):
        from fmpy import extract, read_model_description
        from fmpy.fmi3 import FMU3Model

        self.md = read_model_description(str(path))
        self._dir = extract(str(path), unzipdir=tempfile.mkdtemp(prefix="gripper_fmu_"))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU3Model(
            guid=self.md.guid,
            unzipDirectory=self._dir,
            modelIdentifier=self.md.modelExchange.modelIdentifier,
            instanceName="gripper",
        )
        self.fmu.instantiate()
        for name, value in (params or {}).items():
            self.fmu.setFloat64([self.vr[name]], [float(value)])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.fmu.enterContinuousTimeMode()
        self.state_names = [d.variable.derivative.name for d in self.md.derivatives]
        self.n = len(self.state_names)
        self.inputs = [v.name for v in self.md.modelVariables if v.causality == "input"]
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        self._vr_in = [self.vr[n] for n in self.inputs]
        self._vr_out = [self.vr[n] for n in self.outputs]
        self._x = np.zeros(self.n)
        self._dx = np.zeros(self.n)
        self._px = self._x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._pdx = self._dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    def states(self):
        """Current continuous states, shape (n,)."""
        self.fmu.getContinuousStates(self._px, self.n)
        return self._x.copy()

    def deriv(self, t, x, u):
        """State derivatives at time ``t``, states ``x`` and inputs ``u`` (sequence in :attr:`inputs` order)."""
        self.fmu.setTime(t)
        if self._vr_in:
            self.fmu.setFloat64(self._vr_in, list(u))
        self._x[:] = x
        self.fmu.setContinuousStates(self._px, self.n)
        self.fmu.getContinuousStateDerivatives(self._pdx, self.n)
        return self._dx.copy()

    def out(self, t, x, u):
        """Outputs (dict name -> value) at time ``t``, states ``x`` and inputs ``u``."""
        self.deriv(t, x, u)
        return dict(zip(self.outputs, self.fmu.getFloat64(self._vr_out)))

    def get(self, names):
        return self.fmu.getFloat64([self.vr[n] for n in names])

    def rk4_step(self, t, x, u, h):
        """One classic RK4 step with inputs held at ``u``."""
        k1 = self.deriv(t, x, u)
        k2 = self.deriv(t + h / 2, x + h / 2 * k1, u)
        k3 = self.deriv(t + h / 2, x + h / 2 * k2, u)
        k4 = self.deriv(t + h, x + h * k3, u)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self._dir, ignore_errors=True)


def simulate_cvode(path, params, t_in, u_in, stop_time, output_interval=1e-3, rtol=1e-6):
    """CVode run of an FMU (fmpy) with piecewise-constant inputs ``u_in`` (dict name -> values at ``t_in``)."""
    from fmpy import simulate_fmu

    signal = None
    if u_in:
        dtype = [("time", np.float64)] + [(n, np.float64) for n in u_in]
        signal = np.zeros(len(t_in), dtype=dtype)
        signal["time"] = t_in
        for n, v in u_in.items():
            signal[n] = v
    return simulate_fmu(
        str(path),
        start_values=dict(params or {}),
        input=signal,
        stop_time=stop_time,
        output_interval=output_interval,
        relative_tolerance=rtol,
        solver="CVode",
        fmi_type="ModelExchange",
    )
