"""The alternative forms of the gripper's contact and guide-friction laws (``Gripper.Forms``, issue 42 item 1),
each lowered inside a probe model driven by a given penetration and velocity and compared with the form's
equations written out here: the power-law coating's series balance solved by scipy's brentq, Hunt and Crossley's
force, the Bouc-Wen and Dahl state equations integrated by scipy's solve_ivp (and Dahl's closed form at constant
speed), the Stribeck curve in closed form; and each form that contains the baseline equals
``Components.FingerContact`` / ``Components.RegularisedCoulomb`` at its neutral value.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from cosim.compile import lower

from diagnose_truth import SOURCE

# A coated finger (the paper's P2 coating, k_P = 1.8e5 N/m) on the ABS cylinder, its coating touching at x = 1 mm.
COATED = {"gap0": 0.002, "t_coat": 0.001, "k_f": 1.46e6, "k_obj": 3.53e7, "k_P": 1.8e5, "k_H_ratio": 100.0,
          "d_lim": 0.0015, "C_p": 2000.0, "C_h": 2000.0, "w_tr": 5e-6}
K_S = 1 / (1 / COATED["k_f"] + 1 / COATED["k_obj"])
TOUCH = COATED["gap0"] - COATED["t_coat"]
CONTACTS = ("Components.FingerContact", "Forms.PowerLawCoatingContact", "Forms.HuntCrossleyContact",
            "Forms.HystereticCoatingContact")
GUIDES = ("Components.RegularisedCoulomb", "Forms.StribeckCurveGuide", "Forms.DahlGuide")


def _probe(block, slot):
    """A probe model: the block's inputs are the probe's, its outputs the probe's."""
    name = "Probe_" + block.replace(".", "_")
    ports = ("input Real x(unit = \"m\"); input Real v(unit = \"m/s\"); output Real F(unit = \"N\"); "
             "output Real delta_c(unit = \"m\");\n      equation b.x = x; b.v = v; F = b.F; delta_c = b.delta_c;"
             if slot == "contact" else
             "input Real v(unit = \"m/s\"); output Real F(unit = \"N\");\n      equation b.v = v; F = b.F;")
    return name, f"  model {name}\n    Gripper.{block} b;\n    {ports}\n  end {name};\n"


@pytest.fixture(scope="module")
def probes(tmp_path_factory):
    """Every block of CONTACTS and GUIDES lowered in its probe model (one copy of the package)."""
    folder = tmp_path_factory.mktemp("forms")
    text = SOURCE.read_text(encoding="utf-8")
    made = [(_probe(b, "contact"), b) for b in CONTACTS] + [(_probe(b, "guide"), b) for b in GUIDES]
    end = text.rindex("end Gripper;")
    (folder / "package.mo").write_text(text[:end] + "".join(p for (_, p), _ in made) + text[end:], encoding="utf-8")
    return {block: lower(folder / "package.mo", f"Gripper.{name}") for (name, _), block in made}


def _values(model, **given):
    """The model's parameter values with ``given`` (block parameter -> value) set."""
    p = model.parameter_values.copy()
    for name, value in given.items():
        p[model.index("parameters", f"b.{name}")] = value
    return p


def _static(model, p, x, v=0.0):
    """Outputs at jaw position x and velocity v, the states at their start."""
    return model.output_values(model.initial_state(p), [x, v], p)


def _run(model, p, x_of_t, v_of_t, times):
    """Outputs along a given motion: the model's own ODE integrated by solve_ivp (its states only)."""
    def rhs(t, s):
        return model.derivatives(s, [x_of_t(t), v_of_t(t)] if len(model.inputs) == 2 else [v_of_t(t)], p, t)
    x0 = model.initial_state(p)
    sol = solve_ivp(rhs, (times[0], times[-1]), x0, t_eval=times, method="LSODA", rtol=1e-9, atol=1e-12,
                    max_step=1e-3)
    u = (lambda t: [x_of_t(t), v_of_t(t)]) if len(model.inputs) == 2 else (lambda t: [v_of_t(t)])
    return np.array([model.output_values(sol.y[:, k], u(t), p, t) for k, t in enumerate(times)])


def _power_law_force(pen, n, k_P=COATED["k_P"], d_lim=COATED["d_lim"]):
    """The series balance k_s*(pen - d) = k_P*d_lim*(d/d_lim)^n below the region boundary, by brentq."""
    if pen <= 0:
        return 0.0
    F_lim = k_P * d_lim
    if pen > d_lim + F_lim / K_S:  # second region: linear with slope k_H past d_lim
        k_H = COATED["k_H_ratio"] * k_P
        d = (K_S * pen + (k_H - k_P) * d_lim) / (K_S + k_H)
        return K_S * (pen - d)
    d = brentq(lambda d: K_S * (pen - d) - F_lim * (d / d_lim) ** n, 0.0, pen, xtol=1e-16, rtol=1e-14)
    return K_S * (pen - d)


PENETRATIONS = np.array([-1e-4, 1e-6, 5e-5, 3e-4, 1e-3, 1.6e-3, 1.9e-3, 2.5e-3])


@pytest.mark.parametrize("n", [1.0, 1.5, 2.2, 3.0])
def test_power_law_coating_solves_its_series_balance(probes, n):
    """The static force of the power-law coating in series with the finger and the object, at penetrations from
    out of contact to past the region boundary, agrees with brentq on the balance to 1e-9 of the force."""
    m = probes["Forms.PowerLawCoatingContact"]
    p = _values(m, **COATED, n_c=n)
    forces = [_static(m, p, TOUCH + pen)[0] for pen in PENETRATIONS]
    assert_allclose(forces, [_power_law_force(pen, n) for pen in PENETRATIONS], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("form", ["Forms.PowerLawCoatingContact", "Forms.HystereticCoatingContact"])
def test_contact_forms_contain_the_baseline(probes, form):
    """At n_c = 1 (power law) and a_h = 0 (hysteresis) the form's force and coating deflection are the baseline
    FingerContact's, moving or at rest, at every penetration."""
    base, m = probes["Components.FingerContact"], probes[form]
    pb, pm = _values(base, **COATED), _values(m, **COATED)
    for pen in PENETRATIONS:
        for v in (-0.02, 0.0, 0.01):
            assert_allclose(_static(m, pm, TOUCH + pen, v), _static(base, pb, TOUCH + pen, v), rtol=1e-9, atol=1e-12)


def test_hunt_crossley_force(probes):
    """F = F_s*(1 + lambda_c*v) with F_s the power-law elastic force, never pulling (Hunt and Crossley)."""
    m = probes["Forms.HuntCrossleyContact"]
    p = _values(m, **COATED, n_c=1.5, lambda_c=40.0)
    for pen in PENETRATIONS:
        for v in (-0.05, -0.01, 0.0, 0.02):
            expected = max(0.0, _power_law_force(pen, 1.5) * (1 + 40.0 * v))
            assert_allclose(_static(m, p, TOUCH + pen, v)[0], expected, rtol=1e-9, atol=1e-9)


def test_hysteretic_coating_follows_bouc_wen(probes):
    """Pressed 1 mm in and let back out (a triangle of 0.2 s), the force is (1 - a_h)*F_el + a_h*z/c_1 with z from
    the Bouc-Wen equation integrated by solve_ivp here, and it is lower unloading than loading (a loop)."""
    m = probes["Forms.HystereticCoatingContact"]
    a_h, z_y = 0.4, 2e-4
    p = _values(m, **{**COATED, "C_p": 0.0, "C_h": 0.0}, a_h=a_h, z_y=z_y)
    rate, half = 1e-3 / 0.1, 0.1
    pen_of_t = lambda t: rate * (t if t <= half else 2 * half - t)  # noqa: E731
    v_of_t = lambda t: rate if t <= half else -rate  # noqa: E731
    times = np.linspace(0.0, 0.19, 96)
    got = _run(m, p, lambda t: TOUCH + pen_of_t(t), v_of_t, times)[:, 0]

    def z_rate(t, z):
        v = v_of_t(t)
        return [v * (1 - 0.5 * (1 + np.sign(v * z[0])) * abs(z[0]) / z_y)]
    z = solve_ivp(z_rate, (0.0, 0.19), [0.0], t_eval=times, rtol=1e-10, atol=1e-14, max_step=1e-3).y[0]
    c_1 = 1 / COATED["k_f"] + 1 / COATED["k_obj"] + 1 / COATED["k_P"]
    F_el = np.array([pen_of_t(t) / c_1 for t in times])  # stays in the first region (1 mm < p_lim)
    assert_allclose(got, np.maximum(0.0, (1 - a_h) * F_el + a_h * z / c_1), rtol=1e-5, atol=1e-4)
    loading, unloading = got[times < half], got[times > half]
    assert np.interp(0.05, times[times < half], loading) > np.interp(0.15, times[times > half], unloading) + 1.0


def test_stribeck_curve_guide(probes):
    """The Stribeck curve with viscous friction in closed form; F_sg = F_c, d_vg = 0 is the baseline's
    regularised Coulomb friction."""
    m, base = probes["Forms.StribeckCurveGuide"], probes["Components.RegularisedCoulomb"]
    F_c, v_s, F_s, v_st, d_v = 0.0785, 1e-4, 0.25, 2e-3, 3.0
    p = _values(m, F_c=F_c, v_s=v_s, F_sg=F_s, v_sg=v_st, d_vg=d_v)
    neutral, pb = _values(m, F_c=F_c, v_s=v_s, F_sg=F_c, d_vg=0.0), _values(base, F_c=F_c, v_s=v_s)
    for v in (-0.02, -1e-3, -5e-5, 0.0, 2e-5, 3e-4, 4e-3, 0.05):
        expected = (F_c + (F_s - F_c) * np.exp(-(v / v_st) ** 2)) * np.tanh(v / v_s) + d_v * v
        assert_allclose(m.output_values([], [v], p)[0], expected, rtol=1e-12, atol=1e-15)
        assert_allclose(m.output_values([], [v], neutral)[0], base.output_values([], [v], pb)[0], rtol=1e-12,
                        atol=1e-15)


def test_dahl_guide(probes):
    """At a constant speed from rest the force is Dahl's closed form F_c*(1 - exp(-x/x_d)); along a sine of the
    velocity it follows dF/dt = (F_c/x_d)*(v - |v|*F/F_c) integrated by solve_ivp here."""
    m = probes["Forms.DahlGuide"]
    F_c, x_d = 0.0785, 2e-5
    p = _values(m, F_c=F_c, x_d=x_d)
    times = np.linspace(0.0, 0.02, 41)
    got = _run(m, p, lambda t: 0.0, lambda t: 5e-3, times)[:, 0]
    assert_allclose(got, F_c * (1 - np.exp(-5e-3 * times / x_d)), rtol=1e-6, atol=1e-9)
    v_of_t = lambda t: 2e-3 * np.sin(2 * np.pi * 5 * t)  # noqa: E731
    times = np.linspace(0.0, 0.4, 161)
    got = _run(m, p, lambda t: 0.0, v_of_t, times)[:, 0]
    ref = solve_ivp(lambda t, f: [F_c / x_d * (v_of_t(t) - abs(v_of_t(t)) * f[0] / F_c)], (0.0, 0.4), [0.0],
                    t_eval=times, rtol=1e-10, atol=1e-14, max_step=1e-3).y[0]
    assert_allclose(got, ref, rtol=1e-6, atol=1e-8)
