"""The alternative forms of the gripper's contact, guide-friction, drive-friction and gear-loss laws
(``Gripper.Forms``, issue 42 item 1, issue 51 item 2), each lowered inside a probe model driven by a given
penetration and velocity (a shaft speed and a transmitted torque) and compared with the form's equations written
out here: the power-law coating's series balance solved by scipy's brentq, Hunt and Crossley's force, the Bouc-Wen,
Dahl and LuGre state equations integrated by scipy's solve_ivp (and Dahl's closed form at constant speed), the
Stribeck curve in closed form, for the guides and as the drive's steady friction torque, the gear's efficiencies
at full sliding; and each form that contains the baseline equals ``Components.FingerContact`` /
``Components.RegularisedCoulomb`` / ``Components.BristleFriction`` / ``Components.MeshEfficiency`` at its neutral
value.
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
DRAGS = ("Components.BristleFriction", "Forms.StribeckDrag", "Forms.LuGreDrag")
MESHES = ("Components.MeshEfficiency", "Forms.LoadExponentMeshLoss")
PORTS = {  # the probe's ports and equations by the slot the block fills
    "contact": "input Real x(unit = \"m\"); input Real v(unit = \"m/s\"); output Real F(unit = \"N\"); "
               "output Real delta_c(unit = \"m\");\n      equation b.x = x; b.v = v; F = b.F; delta_c = b.delta_c;",
    "guide": "input Real v(unit = \"m/s\"); output Real F(unit = \"N\");\n      equation b.v = v; F = b.F;",
    "drag": "input Real w(unit = \"rad/s\"); output Real tau_f(unit = \"N.m\");\n      equation b.w = w; "
            "tau_f = b.tau_f;",
    "mesh": "input Real w(unit = \"rad/s\"); input Real tau_out(unit = \"N.m\"); output Real tau_f(unit = \"N.m\");"
            "\n      equation b.w = w; b.tau_out = tau_out; tau_f = b.tau_f;",
}


def _probe(block, slot):
    """A probe model: the block's inputs are the probe's, its outputs the probe's."""
    name = "Probe_" + block.replace(".", "_")
    return name, f"  model {name}\n    Gripper.{block} b;\n    {PORTS[slot]}\n  end {name};\n"


@pytest.fixture(scope="module")
def probes(tmp_path_factory):
    """Every block of CONTACTS, GUIDES, DRAGS and MESHES lowered in its probe model (one copy of the package)."""
    folder = tmp_path_factory.mktemp("forms")
    text = SOURCE.read_text(encoding="utf-8")
    made = [(_probe(b, slot), b) for blocks, slot in ((CONTACTS, "contact"), (GUIDES, "guide"), (DRAGS, "drag"),
                                                      (MESHES, "mesh")) for b in blocks]
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


# The drive's friction at the motor shaft: the plant's no-load drag T_c0 (0.2 A dead zone) and its bristle, a
# breakaway 2.5 times it (the survey's static/Coulomb ratios are 1-3) and a Stribeck speed of 0.5 rad/s.
DRAG = {"T_c": 7.88e-3, "phi_b": 1e-3, "tau_b": 1e-4, "s_ba": 0.5, "d_pre": 0.0, "w_pre": 1.0}
T_S, W_S, D_V = 0.02, 0.5, 2e-4
SPEEDS = (-3.0, -0.3, 0.05, 0.2, 0.6, 4.0)


def _stribeck_torque(w):
    """Armstrong-Helouvry's steady friction: (T_c + (T_s - T_c)*exp(-(w/w_s)^2))*sgn(w) + d_v*w."""
    return (DRAG["T_c"] + (T_S - DRAG["T_c"]) * np.exp(-(w / W_S) ** 2)) * np.sign(w) + D_V * w


@pytest.mark.parametrize("form", ["Forms.StribeckDrag", "Forms.LuGreDrag"])
def test_drive_friction_forms_slide_on_the_stribeck_curve(probes, form):
    """Run from rest at a constant motor speed for 40 of the bristle's time constants, the drive's friction torque
    is the Stribeck curve with viscous friction in closed form, at speeds below, about and above w_s, both ways."""
    m = probes[form]
    p = _values(m, **DRAG, T_s=T_S, w_s=W_S, d_v=D_V)
    for w in SPEEDS:
        settle = 40 * (DRAG["phi_b"] * T_S / DRAG["T_c"] + abs(w) * DRAG["tau_b"]) / abs(w)
        got = _run(m, p, lambda t: 0.0, lambda t, w=w: w, np.array([0.0, settle]))[-1, 0]
        assert_allclose(got, _stribeck_torque(w), rtol=1e-6)


def _speed(t):
    """A motor speed that reverses, with a bias: 0.4*sin(2*pi*3*t) + 0.1 rad/s."""
    return 0.4 * np.sin(2 * np.pi * 3 * t) + 0.1


def test_stribeck_drag_contains_the_baseline(probes):
    """At T_s = T_c and d_v = 0 the Stribeck drag is the baseline's BristleFriction along a speed that reverses
    (with the presliding damping on)."""
    base, m = probes["Components.BristleFriction"], probes["Forms.StribeckDrag"]
    given = {**DRAG, "d_pre": 0.01}
    times = np.linspace(0.0, 0.6, 121)
    neutral = _run(m, _values(m, **given, T_s=DRAG["T_c"], w_s=W_S, d_v=0.0), lambda t: 0.0, _speed, times)
    assert_allclose(neutral, _run(base, _values(base, **given), lambda t: 0.0, _speed, times), rtol=1e-9,
                    atol=1e-12)


def test_lugre_drag_follows_its_state_equation(probes):
    """Along a speed that reverses, the LuGre drag is T_c*s + sigma_1*phi_b*ds/dt*exp(-(w/w_pre)^2) + d_v*w with
    ds/dt = (w - |w|*s*T_c/g(w))/(phi_b + |w|*tau_b) integrated by solve_ivp here (Canudas de Wit et al. 1995 in
    the bristle's units, its rate bounded as the baseline's)."""
    m = probes["Forms.LuGreDrag"]
    given = {**DRAG, "d_pre": 0.01, "w_pre": 1.0}
    p = _values(m, **given, T_s=T_S, w_s=W_S, d_v=D_V)
    times = np.linspace(0.0, 0.6, 121)
    got = _run(m, p, lambda t: 0.0, _speed, times)[:, 0]

    def rate(t, s):
        w = _speed(t)
        g = DRAG["T_c"] + (T_S - DRAG["T_c"]) * np.exp(-(w / W_S) ** 2)
        return (w - abs(w) * s * DRAG["T_c"] / g) / (DRAG["phi_b"] + abs(w) * DRAG["tau_b"])
    s = solve_ivp(rate, (0.0, 0.6), [0.0], t_eval=times, method="LSODA", rtol=1e-10, atol=1e-13, max_step=1e-3).y[0]
    ds = np.array([rate(t, x) for t, x in zip(times, s)])
    w = _speed(times)
    expected = DRAG["T_c"] * s + 0.01 * DRAG["phi_b"] * ds * np.exp(-w ** 2) + D_V * w
    assert_allclose(got, expected, rtol=1e-5, atol=1e-8)


MESH = {"eta": 0.68, "phi_b": 1e-3, "tau_b": 1e-4, "s_ba": 0.5}


@pytest.mark.parametrize("n_L", [0.6, 1.0, 1.3, 2.0])
def test_load_exponent_mesh_efficiencies(probes, n_L):
    """Sliding (bristle at +-1), the gear's efficiency is 1 - (1 - eta)*(|tau_out|/T_n)^(n_L - 1) driving
    (tau_out = that times tau_in) and back-driven (tau_in = that times tau_out): eta at T_n = 0.13 N.m."""
    m = probes["Forms.LoadExponentMeshLoss"]
    p = _values(m, **MESH, n_L=n_L, T_n=0.13)
    for tau_out in (0.01, 0.03, 0.13, 0.25):  # the loss fraction stays below its 0.95 cap
        loss = (1 - MESH["eta"]) * (tau_out / 0.13) ** (n_L - 1)
        for sign in (1.0, -1.0):
            driving = sign * tau_out + m.output_values([sign], [sign * 2.0, sign * tau_out], p)[0]
            back = -sign * tau_out + m.output_values([sign], [sign * 2.0, -sign * tau_out], p)[0]
            assert_allclose(sign * tau_out / driving, 1 - loss, rtol=1e-12)
            assert_allclose(back / (-sign * tau_out), 1 - loss, rtol=1e-12)


def test_load_exponent_mesh_contains_the_baseline(probes):
    """At n_L = 1 the loss torque and the bristle's rate are MeshEfficiency's, in every state of the bristle."""
    base, m = probes["Components.MeshEfficiency"], probes["Forms.LoadExponentMeshLoss"]
    pb, pm = _values(base, **MESH), _values(m, **MESH, n_L=1.0)
    for s in (-1.0, -0.4, 0.0, 0.7, 1.0):
        for w, tau_out in ((0.5, 0.02), (-2.0, 0.05), (1e-3, -0.1), (0.0, 0.0)):
            assert_allclose(m.output_values([s], [w, tau_out], pm), base.output_values([s], [w, tau_out], pb),
                            rtol=1e-12, atol=1e-15)
            assert_allclose(m.derivatives([s], [w, tau_out], pm, 0.0), base.derivatives([s], [w, tau_out], pb, 0.0),
                            rtol=1e-12, atol=1e-15)
