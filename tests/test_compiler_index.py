"""Index reduction of higher-index models (constraints between states differentiated with CasADi, dummy
derivatives): each model written in Modelica, built with cosim, simulated by fmpy's CVode and compared with scipy
on the equations written by hand in minimal coordinates."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from cosim.compile import lower
from cosim.errors import StructureError
from modelica_support import fmu_builder, simulate, write_package

MODELS = """
  model Pendulum "index 3: a point mass on a massless rod of length L, in Cartesian coordinates"
    parameter Real L = 1.5;
    parameter Real g = 9.81;
    parameter Real m = 2.0;
    parameter Real theta0 = 0.9;
    Real x(start = L*sin(theta0), fixed = true);
    Real y(start = -L*cos(theta0));
    Real vx(start = 0, fixed = true);
    Real vy(start = 0);
    Real lambda "rod force per unit length";
    output Real theta = atan2(x, -y);
  equation
    der(x) = vx;
    der(y) = vy;
    m*der(vx) = -lambda*x;
    m*der(vy) = -lambda*y - m*g;
    x^2 + y^2 = L^2;
  end Pendulum;
  model Coupled "index 2: two inertias whose speeds a constraint ties, driven and damped"
    parameter Real J1 = 0.5, J2 = 1.5, d = 0.8;
    Real w1(start = 1.0, fixed = true);
    Real w2;
    Real tau "torque the coupling transmits";
  equation
    J1*der(w1) = 2*sin(3*time) - tau;
    J2*der(w2) = tau - d*w2;
    w1 = w2;
  end Coupled;
  model ZeroCapacitance "a capacitance evaluated to 0: its voltage is no state (the MSL's NOR gates)"
    parameter Real C = 0 annotation(Evaluate = true);
    parameter Real R1 = 2;
    parameter Real R2 = 3;
    Real v(start = 1);
    Real w(start = 0.5) "the voltage across a nonlinear element, v = w + w^3";
    Real x(start = 1, fixed = true);
    Real i1;
    Real i2;
    Real i3;
  equation
    der(x) = -x + v;
    i1 = (sin(time) - v)/R1;
    v = w + w^3;
    i2 = w^3/R2;
    i3 = C*der(v);
    i1 = i2 + i3;
  end ZeroCapacitance;
"""


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    return write_package(tmp_path_factory.mktemp("index"), MODELS)


def test_pendulum_in_cartesian_coordinates_follows_the_angle_equation(package):
    """theta'' = -g/L sin(theta) by scipy; the position and velocity constraints hold to rounding (the demoted
    y and vy are computed from them), and lambda is the rod's tension m (g cos(theta) + L theta'^2) / L."""
    L, g, m, theta0 = 1.5, 9.81, 2.0, 0.9
    model = lower(package, "T.Pendulum")
    assert [s.name for s in model.states] == ["x", "vx"]
    result = simulate(fmu_builder(package)("Pendulum"), "ModelExchange", ["theta", "x", "y", "vx", "vy", "lambda"],
                      10.0)
    t = result["time"]
    ref = solve_ivp(lambda _, z: [z[1], -g / L * np.sin(z[0])], (0, t[-1]), [theta0, 0.0], t_eval=t, rtol=1e-12,
                    atol=1e-12)
    assert np.max(np.abs(result["theta"] - ref.y[0])) < 1e-6
    assert np.max(np.abs(result["x"] ** 2 + result["y"] ** 2 - L ** 2)) < 1e-12
    assert np.max(np.abs(result["x"] * result["vx"] + result["y"] * result["vy"])) < 1e-12
    tension = m * (g * np.cos(ref.y[0]) + L * ref.y[1] ** 2) / L
    assert np.max(np.abs(result["lambda"] - tension)) < 1e-5 * np.ptp(tension)


def test_two_inertias_tied_by_a_speed_constraint_move_as_one(package):
    """(J1 + J2) w' = 2 sin(3 t) - d w by scipy; tau = J2 w' + d w."""
    J1, J2, d = 0.5, 1.5, 0.8
    result = simulate(fmu_builder(package)("Coupled"), "ModelExchange", ["w1", "w2", "tau"], 5.0)
    t = result["time"]
    ref = solve_ivp(lambda s, w: [(2 * np.sin(3 * s) - d * w[0]) / (J1 + J2)], (0, t[-1]), [1.0], t_eval=t,
                    rtol=1e-12, atol=1e-12)
    w = ref.y[0]
    assert np.max(np.abs(result["w1"] - w)) < 1e-7 and np.max(np.abs(result["w2"] - w)) < 1e-7
    tau = J2 * (2 * np.sin(3 * t) - d * w) / (J1 + J2) + d * w
    assert np.max(np.abs(result["tau"] - tau)) < 1e-6


def test_a_state_whose_derivative_has_coefficient_zero_is_an_algebraic_variable(package):
    """With C = 0, w^3/R2 = (sin(t) - w - w^3)/R1 is 5 w^3 + 3 w = 3 sin(t) (brentq), v = w + w^3, and
    x' = -x + v by scipy. The current balance is no constraint on v to differentiate: it goes through the
    nonlinear element, where index reduction stops (the NOR gates' transistors)."""
    model = lower(package, "T.ZeroCapacitance")
    assert [s.name for s in model.states] == ["x"]
    result = simulate(fmu_builder(package)("ZeroCapacitance"), "ModelExchange", ["x", "v"], 5.0)
    t = result["time"]

    def v_of(s):
        w = brentq(lambda w: 5 * w ** 3 + 3 * w - 3 * np.sin(s), -2, 2, xtol=1e-15)
        return w + w ** 3

    ref = solve_ivp(lambda s, x: [-x[0] + v_of(s)], (0, t[-1]), [1.0], t_eval=t, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(result["v"] - [v_of(s) for s in t])) < 1e-10
    assert np.max(np.abs(result["x"] - ref.y[0])) < 1e-7


def test_a_constraint_through_a_nonlinear_loop_is_refused_with_its_line(tmp_path):
    """v is fixed by x through w (two equations in w alone): reducing it would need the derivative of the loop
    that computes w, which is not implemented; the build stops at one of the two equations, never with numbers."""
    path = write_package(tmp_path, """
  model ThroughLoop
    Real x(start = 1, fixed = true);
    Real v(start = 2);
    Real w(start = 1);
    Real i;
  equation
    der(x) = -x + w;
    der(v) = i;
    w + w^3 = v;
    w^3 + x*w = 2*x;
  end ThroughLoop;""")
    with pytest.raises(StructureError, match="goes through the nonlinear algebraic loop in w") as err:
        lower(path, "T.ThroughLoop")
    assert err.value.file.endswith("T.mo") and err.value.line in (11, 12), str(err.value)
