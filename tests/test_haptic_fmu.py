"""The Haptic FMUs equal the papers' transfer functions (seed 000 eqs. 2, 9; seed 001 eq. 1) within 0.1 dB / 1 deg.

References are the formulas evaluated directly with python-control polynomials (cosim.haptic.tf), not
the Modelica source; the FMU is linearised by central differences through its FMI 3 ME interface.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from cosim.haptic.fmu import fmu_parameters, linearize_fmu, simulate_fmu
from cosim.freqresp import model_response
from cosim.haptic.experiments import device_experiment
from cosim.haptic.params import PARAMS_11, load_arm_params, load_user_params
from cosim.haptic.tf import tf_arm, tf_device_arm, tf_user

pytestmark = pytest.mark.slow  # the four Haptic FMUs, built for this module

ROOT = Path(__file__).resolve().parent.parent
SOURCE = ROOT / "modelica" / "Haptic" / "package.mo"
F = np.logspace(np.log10(0.5), np.log10(70.0), 300)  # seed 000 analysis band


@pytest.fixture(scope="module")
def haptic_fmu(tmp_path_factory):
    from cosim.compile import build_fmu

    out = tmp_path_factory.mktemp("haptic_fmus")
    built = {}

    def get(name):
        model = {"HapticDevice11": "Device11", "HapticDevice7": "Device7", "HapticDeviceArm": "DeviceArm",
                 "HapticArm": "Arm"}[name]
        if name not in built:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                path = build_fmu(SOURCE, f"Haptic.{model}", out_dir=out)
            built[name] = path
        return built[name]

    return get


def _compare(H, R):
    db = np.abs(20 * np.log10(np.abs(H) / np.abs(R)))
    deg = np.abs(np.degrees(np.angle(H / R)))
    assert db.max() < 0.1, f"magnitude differs by {db.max():.3g} dB"
    assert deg.max() < 1.0, f"phase differs by {deg.max():.3g} deg"


@pytest.mark.parametrize("user,position", [(1, 1), (1, 3), (1, 4), (1, 6), (5, 5), (9, 1), (8, 2)])
def test_device_user_fmu_equals_paper_tf(haptic_fmu, user, position):
    p = load_user_params(user, position, zero_as=5e-4)  # user 8 pos 2 prints m2 = 0
    name, par = fmu_parameters(p)
    ss = linearize_fmu(haptic_fmu(name), par)
    _compare(model_response(ss, F), tf_user(p)(2j * np.pi * F))


@pytest.mark.parametrize("axis", ["X", "Z"])
def test_device_arm_fmu_equals_tf(haptic_fmu, axis):
    dev = load_user_params(1, 1).values
    a = load_arm_params(axis)
    name, par = fmu_parameters(a, device=dev)
    ss = linearize_fmu(haptic_fmu(name), par)
    _compare(model_response(ss, F), tf_device_arm(dev, a)(2j * np.pi * F))


def test_arm_fmu_equals_fu_eq1(haptic_fmu):
    a = load_arm_params("Y", 3)
    name, par = fmu_parameters(a)
    ss = linearize_fmu(haptic_fmu(name), par, inputs=("F",), output="x")
    f = np.logspace(np.log10(0.6), np.log10(30.0), 100)
    _compare(model_response(ss, f), tf_arm(a)(2j * np.pi * f))


def test_every_physical_parameter_is_tunable(haptic_fmu):
    import fmpy

    md = fmpy.read_model_description(str(haptic_fmu("HapticDevice11")))
    tunable = {v.name: v for v in md.modelVariables if v.causality == "parameter" and v.variability == "tunable"}
    assert set(PARAMS_11) <= set(tunable)
    assert all(tunable[n].unit for n in PARAMS_11)
    assert tunable["kc"].unit == "N.m/rad" and tunable["m1"].unit == "kg.m2"


def test_user_intent_inputs_static(haptic_fmu):
    # statics: the hand reference phi_ref moves every spring's rest point (phi -> phi_ref); a hand torque tau_h
    # loads only kh (phi = tau_h / kh), since the device side is unloaded
    p = load_user_params(1, 3)
    name, par = fmu_parameters(p)
    A, B, C, D = linearize_fmu(haptic_fmu(name), par, inputs=("tau", "phi_ref", "tau_h"))
    x_ref = np.linalg.solve(A, -B[:, 1])
    assert_allclose((C @ x_ref)[0], 1.0, rtol=1e-9)
    x_h = np.linalg.solve(A, -B[:, 2])
    assert_allclose((C @ x_h)[0], 1 / p["kh"], rtol=1e-9)


def test_lowered_model_jacobian_equals_fmu(haptic_fmu):
    # the CasADi functions of the lowered model (exact derivatives) against the FMU's finite differences
    import casadi as ca
    from cosim.compile import lower

    p = load_user_params(1, 5)
    name, par = fmu_parameters(p)
    A_fmu, B_fmu, _, _ = linearize_fmu(haptic_fmu(name), par)
    m = lower(SOURCE, "Haptic.Device7")
    x = ca.SX.sym("x", len(m.states))
    u = ca.SX.sym("u", len(m.inputs))
    pv = np.array([par.get(q.name, q.start) for q in m.parameters])
    A = ca.Function("A", [x, u], [ca.jacobian(m.ode(x, u, pv, 0.0), x)])(np.zeros(len(m.states)), np.zeros(len(m.inputs)))
    assert_allclose(np.array(A), A_fmu, rtol=1e-6, atol=1e-6 * np.abs(A_fmu).max())


def test_identification_through_fmu(haptic_fmu):
    # seed 000 experiment run through the FMU (RK4, ZOH torque at 1 kHz) recovers the generating row
    p = load_user_params(1, 3)
    name, par = fmu_parameters(p)
    path = haptic_fmu(name)
    fr, fit = device_experiment(lambda u: simulate_fmu(path, u, 1000.0, par), 11, position=3, seed=5)
    for k in ("m1", "kc", "m2", "ks", "kh", "mh"):
        assert_allclose(fit.params_[k], p[k], rtol=0.05, err_msg=k)
