"""Each compiler test model, built to an FMU and simulated by fmpy (CVode), against a reference written by hand
from the model's physics and integrated by scipy (solve_ivp, tight tolerances).

Tolerance: max error below 1e-3 of the signal's range, as the compiler issue asks. Inputs are constant unless a
test says otherwise: fmpy applies ME inputs only at output points, so a time-varying input is compared with a
fine output interval (1e-4 s), stated where used.
"""

import numpy as np
import pytest
from fmpy import simulate_fmu
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

RTOL = 1e-3  # of the signal's range


def simulate(fmu, stop, outputs, start_values=None, input=None, interval=1e-3):
    return simulate_fmu(str(fmu), stop_time=stop, output=outputs, start_values=start_values or {}, input=input,
                        output_interval=interval, relative_tolerance=1e-9, solver="CVode",
                        fmi_type="ModelExchange")


def reference(rhs, x0, t):
    sol = solve_ivp(rhs, (t[0], t[-1]), x0, t_eval=t, rtol=1e-10, atol=1e-12, method="LSODA")
    assert sol.success, sol.message
    return sol.y


def assert_close_to_range(actual, expected, name):
    span = np.ptp(expected) or max(abs(expected).max(), 1.0)
    err = np.max(np.abs(actual - expected)) / span
    assert err < RTOL, f"{name}: max error {err:.2e} of range (limit {RTOL})"


def test_mass_spring_damper_with_time_varying_input(compiler_fmu):
    # Input F = 2 sin(5 t) N sampled on a 1e-4 s grid (fmpy applies inputs at output points).
    m, k, d = 0.5, 200.0, 1.5
    t_in = np.arange(0, 2.0 + 1e-9, 1e-4)
    signal = np.array(list(zip(t_in, 2 * np.sin(5 * t_in))), dtype=[("time", float), ("F", float)])
    res = simulate(compiler_fmu("MassSpringDamper"), 2.0, ["x", "v"], input=signal, interval=1e-4)
    ref = reference(lambda t, s: [s[1], (2 * np.sin(5 * t) - k * s[0] - d * s[1]) / m], [0.01, 0.0], res["time"])
    assert_close_to_range(res["x"], ref[0], "x")
    assert_close_to_range(res["v"], ref[1], "v")


def test_drive_with_gear_play_and_friction_reduces_redundant_states(compiler_fmu):
    # Hand-derived: the ideal gear ties motor and gear-side inertia, so
    # (Jm + Jg/n^2) dw_m = tau_m + tau_p/n, Jl dw_l = -tau_p - tau_c tanh(w_l/w_s),
    # tau_p = c (d -+ b/2) outside the dead band |d| <= b/2, d = phi_l - phi_m/n.
    Jm, Jg, Jl, n, c, b, tau_c, w_s, tau_m = 0.01, 0.02, 0.3, 4.0, 50.0, 0.02, 0.3, 0.1, 0.5

    def rhs(t, s):
        phi_m, w_m, phi_l, w_l = s
        dphi = phi_l - phi_m / n
        tau_p = c * (dphi - b / 2) if dphi > b / 2 else c * (dphi + b / 2) if dphi < -b / 2 else 0.0
        return [w_m, (tau_m + tau_p / n) / (Jm + Jg / n**2), w_l, (-tau_p - tau_c * np.tanh(w_l / w_s)) / Jl]

    res = simulate(compiler_fmu("Drive"), 3.0, ["w_load", "w_motor"], start_values={"tau_m": tau_m})
    ref = reference(rhs, [0, 0, 0, 0], res["time"])
    assert_close_to_range(res["w_motor"], ref[1], "w_motor")
    assert_close_to_range(res["w_load"], ref[3], "w_load")


def test_pmsm_dq_with_user_function(compiler_fmu):
    p, Rs, Ld, Lq, psi, J, B = 4, 0.45, 0.3e-3, 0.25e-3, 0.0066, 1e-5, 1e-5
    v_d, v_q, tau_l = 0.1, 2.0, 0.001

    def rhs(t, s):
        i_d, i_q, w, theta = s
        we = p * w
        tau = 1.5 * p * (psi * i_q + (Ld - Lq) * i_d * i_q)
        return [(v_d - Rs * i_d + we * Lq * i_q) / Ld, (v_q - Rs * i_q - we * (Ld * i_d + psi)) / Lq,
                (tau - B * w - tau_l) / J, w]

    start = {"v_d": v_d, "v_q": v_q, "tau_load": tau_l}
    res = simulate(compiler_fmu("PMSM"), 0.05, ["i_d", "i_q", "w"], start_values=start, interval=1e-5)
    ref = reference(rhs, [0, 0, 0, 0], res["time"])
    for k, name in enumerate(["i_d", "i_q", "w"]):
        assert_close_to_range(res[name], ref[k], name)


def test_algebraic_chain_outputs_and_state_output(compiler_fmu):
    u, x0 = 0.3, 0.5
    res = simulate(compiler_fmu("AlgebraicChain"), 2.0, ["x", "y1", "y2", "y3"], start_values={"u": u})
    x = u + (x0 - u) * np.exp(-res["time"])  # der(x) = -x + u, solved by hand
    assert_close_to_range(res["x"], x, "x")
    assert_close_to_range(res["y1"], 2 * x, "y1")
    assert_close_to_range(res["y2"], 2 * x + np.sin(x), "y2")
    assert_close_to_range(res["y3"], (2 * x + np.sin(x)) * 2 * x, "y3")


def test_nonlinear_algebraic_loop_solved_by_newton(compiler_fmu):
    u = 0.2

    def z_of(x):
        return brentq(lambda z: z + np.sin(z) + 0.2 * (z**3 + z) - x, -10, 10, xtol=1e-14)

    res = simulate(compiler_fmu("NonlinearLoop"), 3.0, ["z"], start_values={"u": u})
    ref = reference(lambda t, s: [-z_of(s[0]) + u], [1.0], res["time"])
    assert_close_to_range(res["z"], np.array([z_of(x) for x in ref[0]]), "z")


@pytest.mark.parametrize("k", [2.0, 3.0])
def test_dependent_parameters_follow_a_tunable_one(compiler_fmu, k):
    res = simulate(compiler_fmu("DependentParameters"), 1.0, ["x"], start_values={"k": k})
    c2 = 0.5 * (k * k + 1)  # c = k^2 + 1, c2 = c/2
    assert_close_to_range(res["x"], np.exp(-c2 * res["time"]), "x")


def test_initial_equation_integer_parameter_extends_and_math_functions(compiler_fmu):
    n = 3

    def rhs(t, s):
        x = s[0]
        return [-n * x + max(0.1, abs(x)) * np.sign(x) * np.exp(-x * x) + np.arctan2(x, 2) * np.sqrt(1 + x * x)
                - np.log(1 + x * x) + min(x, 0.0)]

    res = simulate(compiler_fmu("InitialAndInteger"), 2.0, ["y"])
    ref = reference(rhs, [2 * 0.25], res["time"])  # initial equation x = 2*x0
    assert_close_to_range(res["y"], ref[0], "y")


def test_one_function_called_at_two_sites_uses_each_sites_arguments(compiler_fmu):
    # der(x) = (u - x)|u - x|/tc at each site: the first with u = 1, tc = 0.5, the second with u = -0.5, tc = 2.
    # Every call site inlines the function with its own arguments; a body shared between sites would give the
    # second state the first one's rate.
    def rhs(t, s):
        return [(1.0 - s[0]) * abs(1.0 - s[0]) / 0.5, (-0.5 - s[1]) * abs(-0.5 - s[1]) / 2.0]

    res = simulate(compiler_fmu("TwoCalls"), 2.0, ["x1", "x2"])
    ref = reference(rhs, [0.2, 0.3], res["time"])
    assert_close_to_range(res["x1"], ref[0], "x1")
    assert_close_to_range(res["x2"], ref[1], "x2")
