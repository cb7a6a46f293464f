"""Nonlinear algebraic loops whose unknowns have no start values: Newton's method from 0 meets a singular
Jacobian, so the generated iterations start from the loop's solution at the model's start point
(cosim/compile/guess.py). Checked against the loop solved by scipy at every instant."""

import fmpy
import numpy as np
import pytest
from scipy.optimize import brentq

from cosim.compile import build_fmu, lower
from modelica_support import write_package

# A resistor heated by its own loss through a thermal conductance (the MSL's Analog.Examples.Resistor, written
# out): v = R_actual i with R_actual guessed 0 makes the Jacobian at the start values singular.
HEATED_RESISTOR = """
  model M
    parameter Real R = 100;
    parameter Real alpha = 0.01;
    parameter Real T_ref = 293.15;
    parameter Real G = 0.05;
    parameter Real T_amb = 293.15;
    Real v = 20*sin(2*3.141592653589793*time);
    Real i;
    Real R_actual;
    Real T(start = 288.15) "a temperature starts at 288.15 K, as SI.Temperature does";
    Real P;
  equation
    v = R_actual*i;
    R_actual = R*(1 + alpha*(T - T_ref));
    P = v*i;
    P = G*(T - T_amb);
  end M;"""


def _temperature(v, R=100.0, alpha=0.01, T_ref=293.15, G=0.05, T_amb=293.15):
    """T of the heated resistor: G (T - T_amb) = v^2 / (R (1 + alpha (T - T_ref))), the root above T_amb."""
    return brentq(lambda T: G * (T - T_amb) - v**2 / (R * (1 + alpha * (T - T_ref))), T_amb, T_amb + 1e4)


def test_a_loop_newton_cannot_start_from_zero_starts_from_its_solution_at_the_start_point(tmp_path):
    path = write_package(tmp_path, HEATED_RESISTOR)
    model = lower(path, "T.M")
    assert any("Levenberg-Marquardt" in note and "R_actual" in note for note in model.notes)
    fmu = build_fmu(path, "T.M", out_dir=tmp_path / "out")
    result = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=["T", "i"])
    v = 20 * np.sin(2 * np.pi * result["time"])
    expected = np.array([_temperature(x) for x in v])
    # Newton's 30 iterations converge to machine precision here; 1e-9 K is far below any model error
    np.testing.assert_allclose(result["T"], expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result["i"], v / (100 * (1 + 0.01 * (expected - 293.15))), rtol=1e-12)


def test_a_loop_that_converges_from_its_start_values_keeps_them(tmp_path):
    """With start values near the root the generated code is as before: no note, same iterations."""
    body = HEATED_RESISTOR.replace("Real R_actual;", "Real R_actual(start = 100);").replace(
        "Real T(start = 288.15)", "Real T(start = 300)")
    model = lower(write_package(tmp_path, body), "T.M")
    assert not any("Levenberg-Marquardt" in note for note in model.notes)
    assert model.observe([], [], model.parameter_values, 0.0)[model.index("observed", "T")] == pytest.approx(293.15)  # v = 0 at t = 0: no heating


def test_a_loop_undefined_at_its_start_values_is_solved_from_nonzero_values(tmp_path):
    """A diode heated by its own loss (the MSL's HeatingDiode, written out): vt = k T/q with T guessed 0 divides
    by zero at the start values. Reference: the loop solved for T by scipy at every instant."""
    path = write_package(tmp_path, """
  model M
    parameter Real Is = 1e-6;
    parameter Real k_q = 8.617e-5 "k/q, V/K";
    parameter Real Rth = 20 "K/W";
    parameter Real T_amb = 300;
    Real v = 0.4 + 0.1*time;
    Real vt;
    Real i;
    Real T;
  equation
    vt = k_q*T;
    i = Is*(exp(v/vt) - 1);
    T = T_amb + Rth*v*i;
  end M;""")
    fmu = build_fmu(path, "T.M", out_dir=tmp_path / "out")
    result = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.05, output=["T"])

    def temperature(v):
        return brentq(lambda T: T - 300 - 20 * v * 1e-6 * (np.exp(v / (8.617e-5 * T)) - 1), 300, 400)

    expected = [temperature(0.4 + 0.1 * t) for t in result["time"]]
    np.testing.assert_allclose(result["T"], expected, rtol=0, atol=1e-9)


# z^2 = u: the root z = sqrt(u) (from z = 1) for u > 0, no real root for u < 0, where Newton's iterations
# z <- (z + u/z)/2 never settle. x integrates z: x(t) = sqrt(u) t while u > 0.
NO_REAL_ROOT = """
  model M
    input Real u(start = {u0});
    Real z(start = 1);
    Real x(start = 0, fixed = true);
    output Real y = z;
  equation
    z*z = u;
    der(x) = z;
  end M;"""


def test_a_loop_without_a_solution_at_run_time_is_an_error_naming_the_loop_not_a_number(tmp_path):
    from fmpy.fmi1 import FMICallException

    fmu = build_fmu(write_package(tmp_path, NO_REAL_ROOT.format(u0=4)), "T.M", out_dir=tmp_path / "out")
    ran = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.1, output=["x", "y"])
    np.testing.assert_allclose(ran["y"], 2.0, rtol=1e-12)  # sqrt(4)
    np.testing.assert_allclose(ran["x"], 2.0 * ran["time"], rtol=1e-9, atol=1e-12)
    signal = np.array([(0.0, 4.0), (0.5, 4.0), (0.5, -1.0), (1.0, -1.0)], dtype=[("time", float), ("u", float)])
    logged = []
    for fmi_type in ("CoSimulation", "ModelExchange"):
        with pytest.raises(FMICallException):
            fmpy.simulate_fmu(str(fmu), fmi_type=fmi_type, stop_time=1.0, output_interval=0.1, input=signal,
                              logger=lambda *args: logged.append(args[-1].decode()), output=["y"])
        assert any("Newton's method did not converge on the nonlinear algebraic loop in z (equations at "
                   f"{tmp_path / 'T.mo'}:8)" in message for message in logged), logged


def test_a_loop_without_a_solution_at_the_start_point_warns_naming_the_loop(tmp_path):
    from cosim.errors import LoopWarning

    path = write_package(tmp_path, NO_REAL_ROOT.format(u0=-1))
    named = r"nonlinear algebraic loop in z \(equations at .*T\.mo:8\) has no solution"
    with pytest.warns(LoopWarning, match=named):
        model = lower(path, "T.M")
    # built all the same: where the loop has a root the model gives it
    assert model.output_values([0.0], [9.0])[0] == pytest.approx(3.0, rel=1e-12)
    assert np.isnan(model.output_values([0.0], [-1.0])[0])  # no root: not a number, and loops says which
    converged = np.array(model.loops([0.0], [-1.0], model.parameter_values, 0.0), dtype=float).ravel()
    assert list(converged) == [0.0]


def test_a_loop_that_needs_more_than_the_first_iterations_is_solved_by_the_retry(tmp_path):
    """exp(z) = u from z = 10 towards z = log(u) = -40: Newton's step z - 1 + u exp(-z) goes down by about 1 a
    step, so the first 30 iterations end near z = -20 and the 70 more reach the root (log(u), closed form)."""
    path = write_package(tmp_path, """
  model M
    input Real u(start = 22026.465794806718) "exp(10): z = 10 at the start values";
    Real z(start = 10);
    output Real y = z;
  equation
    exp(z) = u;
  end M;""")
    fmu = build_fmu(path, "T.M", out_dir=tmp_path / "out")
    for u in (np.exp(10.0), np.exp(-40.0)):
        result = fmpy.simulate_fmu(str(fmu), stop_time=0.1, output_interval=0.1, start_values={"u": u},
                                   output=["y"])
        np.testing.assert_allclose(result["y"], np.log(u), rtol=1e-12)


def test_a_loop_whose_newton_iterations_cycle_is_solved_by_the_damped_retry(tmp_path):
    """0.01 v + sat(v) = c with c = 2 - t, from v = 100: past c = 1.01 the root c / 1.01 lies where sat is
    linear, but a full Newton step from the outer branches jumps between v = (c - 1)/0.01 and (c + 1)/0.01 for
    ever (the MSL's OpAmpDetailed output-current limit stopped AmplifierWithOpAmpDetailed at t = 1.28e-5 s so).
    The retry halves a step that does not lower the residual (closed form on both branches)."""
    path = write_package(tmp_path, """
  function sat
    input Real u;
    output Real y;
  algorithm
    if u > 1 then
      y := 1;
    elseif u < -1 then
      y := -1;
    else
      y := u;
    end if;
  end sat;
  model M
    Real v(start = 100);
    Real c = 2 - time;
  equation
    0.01*v + sat(v) = c;
  end M;""")
    fmu = build_fmu(path, "T.M", out_dir=tmp_path / "out")
    result = fmpy.simulate_fmu(str(fmu), stop_time=2.0, output_interval=0.01, output=["v", "c"])
    c = result["c"]
    np.testing.assert_allclose(result["v"], np.where(c > 1.01, (c - 1) / 0.01, c / 1.01), rtol=0, atol=1e-9)
