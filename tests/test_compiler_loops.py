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
# A comparator with positive feedback: y = tanh(k (u + a y)) with k a = 2 > 1 has, for |u| below U_SWITCH, two
# stable solutions (a lower and an upper branch) and an unstable one between. Its branches in closed form:
# u = atanh(y)/k - a y; a branch ends where du/dy = 0, at |y| = sqrt(1 - 1/(k a)).
COMPARATOR = """
  model M
    parameter Real k = 2;
    parameter Real a = 1;
    input Real u(start = -2);
    Real y(start = -1) "on the lower branch at the start";
    output Real out = y;
  equation
    y = tanh(k*(u + a*y));
  end M;"""
Y_FOLD = np.sqrt(1 - 1 / 2.0)
U_SWITCH = np.arctanh(Y_FOLD) / 2 - Y_FOLD  # where the upper branch ends (-0.266); the lower ends at -U_SWITCH


def _on_branch(u, upper):
    """The comparator's solution on its upper or lower branch at u (scipy's brentq on the closed form u(y))."""
    f = lambda y: np.arctanh(y) / 2 - y - u  # noqa: E731
    return brentq(f, Y_FOLD, 1 - 1e-15) if upper else brentq(f, -1 + 1e-15, -Y_FOLD)


class _Comparator:
    """The comparator's FMU as a Co-Simulation instance (FMI 3.0): set the input, step 0.01 s (a step ends at an
    accepted point), read the output."""

    def __init__(self, tmp_path):
        from fmpy.fmi3 import FMU3Slave

        fmu = build_fmu(write_package(tmp_path, COMPARATOR), "T.M", out_dir=tmp_path / "out")
        md = fmpy.read_model_description(str(fmu))
        self.slave = FMU3Slave(guid=md.guid, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="c",
                               unzipDirectory=fmpy.extract(str(fmu), unzipdir=str(tmp_path / "unzipped")))
        self.slave.instantiate()
        self.vrs = {v.name: v.valueReference for v in md.modelVariables}
        self.start()

    def start(self):
        self.slave.enterInitializationMode(startTime=0.0)
        self.slave.exitInitializationMode()
        self.time = 0.0

    def out_at(self, u):
        self.slave.setFloat64([self.vrs["u"]], [u])
        self.slave.doStep(self.time, 0.01)
        self.time += 0.01
        return self.slave.getFloat64([self.vrs["out"]])[0]

    def close(self):
        self.slave.terminate()
        self.slave.freeInstance()


def test_a_loop_with_two_solutions_follows_its_branch_from_the_last_solution(tmp_path):
    """u swept up from -2 to 2 and back in steps of 0.05: the output stays on the lower branch up to -U_SWITCH,
    on the upper one down to U_SWITCH (hysteresis), each value the closed form's root on that branch."""
    comparator = _Comparator(tmp_path)
    out_at = comparator.out_at
    sweep = np.round(np.concatenate([np.arange(-2, 2, 0.05), np.arange(2, -2, -0.05)]), 10)
    upper = False
    for k, u in enumerate(sweep):
        rising = k < len(sweep) // 2
        upper = (upper or u > -U_SWITCH) if rising else (upper and u >= U_SWITCH)
        assert out_at(u) == pytest.approx(_on_branch(u, upper), abs=1e-9), (u, rising)
    # both branches were met inside the band, each from its side
    assert out_at(0.0) == pytest.approx(_on_branch(0.0, upper=False), abs=1e-9)
    comparator.close()


def test_fmu_state_and_reset_restore_the_branch_the_loop_was_on(tmp_path):
    """Inside the band (u = 0) the output is the branch the last solution was on: the one at the saved state after
    fmi3SetFMUState (serialised too), the start values' (lower) after fmi3Reset."""
    comparator = _Comparator(tmp_path)
    slave, out_at = comparator.slave, comparator.out_at
    lower_0, upper_0 = _on_branch(0.0, upper=False), _on_branch(0.0, upper=True)
    assert out_at(0.0) == pytest.approx(lower_0, abs=1e-9)
    state, lower_time = slave.getFMUState(), comparator.time
    assert out_at(2.0) == pytest.approx(_on_branch(2.0, upper=True), abs=1e-9)
    assert out_at(0.0) == pytest.approx(upper_0, abs=1e-9)
    saved_upper, upper_time = slave.serializeFMUState(slave.getFMUState()), comparator.time
    slave.setFMUState(state)
    comparator.time = lower_time
    assert out_at(0.0) == pytest.approx(lower_0, abs=1e-9)
    slave.setFMUState(slave.deserializeFMUState(saved_upper))
    comparator.time = upper_time
    assert out_at(0.0) == pytest.approx(upper_0, abs=1e-9)
    slave.reset()
    comparator.start()
    assert out_at(0.0) == pytest.approx(lower_0, abs=1e-9)
    comparator.close()


def test_homotopy_starts_a_loop_on_the_solution_its_simplified_model_continues_to(tmp_path):
    """The comparator at u = 0 from y = 0 (its unstable middle solution is 0) with homotopy(actual, simplified =
    1): the build continues from the simplified model's y = 1 to the upper branch, as Modelica tools initialise;
    without homotopy() Newton's method from 0 stays at the middle solution."""
    body = COMPARATOR.replace("input Real u(start = -2);", "input Real u(start = 0);").replace(
        'Real y(start = -1) "on the lower branch at the start";', "Real y(start = 0);")
    continued = body.replace("y = tanh(k*(u + a*y));", "y = homotopy(tanh(k*(u + a*y)), 1);")
    for text, expected in ((continued, _on_branch(0.0, upper=True)), (body, 0.0)):
        fmu = build_fmu(write_package(tmp_path, text), "T.M", out_dir=tmp_path / "out")
        result = fmpy.simulate_fmu(str(fmu), stop_time=0.1, output_interval=0.1, output=["out"])
        np.testing.assert_allclose(result["out"], expected, rtol=0, atol=1e-9)


def test_a_solve_at_an_earlier_time_starts_from_the_branch_that_was_on_then(tmp_path):
    """Model Exchange: an integrator's trial point past the branch's end (u = 2 at t = 1) moves the loop to the
    upper branch for later points only: a retry at t = 0.5 (a rejected step) sees the lower branch as it was,
    the same calls giving the same numbers; after fmi3CompletedIntegratorStep at u = 2 the upper branch holds."""
    from fmpy.fmi3 import FMU3Model

    fmu = build_fmu(write_package(tmp_path, COMPARATOR), "T.M", out_dir=tmp_path / "out")
    md = fmpy.read_model_description(str(fmu))
    model = FMU3Model(guid=md.guid, modelIdentifier=md.modelExchange.modelIdentifier, instanceName="m",
                      unzipDirectory=fmpy.extract(str(fmu), unzipdir=str(tmp_path / "unzipped")))
    model.instantiate()
    model.enterInitializationMode(startTime=0.0)
    model.exitInitializationMode()
    model.enterContinuousTimeMode()
    vrs = {v.name: v.valueReference for v in md.modelVariables}

    def out(t, u):
        model.setTime(t)
        model.setFloat64([vrs["u"]], [u])
        return model.getFloat64([vrs["out"]])[0]

    lower_0, upper_0 = _on_branch(0.0, upper=False), _on_branch(0.0, upper=True)
    for _ in range(2):
        assert out(1.0, 2.0) == pytest.approx(_on_branch(2.0, upper=True), abs=1e-9)
        assert out(1.2, 0.0) == pytest.approx(upper_0, abs=1e-9)  # later than the trial point: its branch
        assert out(0.5, 0.0) == pytest.approx(lower_0, abs=1e-9)  # earlier: the branch before it
    out(1.0, 2.0)
    model.completedIntegratorStep()
    assert out(1.5, 0.0) == pytest.approx(upper_0, abs=1e-9)
    assert out(1.2, 0.0) == pytest.approx(upper_0, abs=1e-9)  # before nothing kept now: the accepted point's
    model.terminate()
    model.freeInstance()
