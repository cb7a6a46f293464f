"""Initialisation: initial equations with states, derivatives (steady state ``der(x) = 0``), algebraic variables
and parameters, solved into ``x0(p)``, against equilibria solved by hand (tests/models/arrays/Arrays.mo)."""

import subprocess
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from cosim.compile import lower
from cosim.errors import StructureError
from modelica_support import write_package

MODELS = Path(__file__).resolve().parent / "models" / "arrays" / "Arrays.mo"


def _x0(m, **changed):
    p = np.array([changed.get(q.name, q.start) for q in m.parameters])
    return np.array(m.x0(p), dtype=float).ravel(), p


def _rod_equilibrium(N, G, G_amb, T_left, T_amb):
    """0 = G (T_left - T1) - G (T1 - T2); 0 = G (T[i-1] - 2 Ti + T[i+1]); 0 = G (T[N-1] - TN) - G_amb (TN - T_amb)."""
    M = np.zeros((N, N))
    rhs = np.zeros(N)
    for i in range(N):
        M[i, i] = -2 * G
        if i > 0:
            M[i, i - 1] = G
        if i < N - 1:
            M[i, i + 1] = G
    M[-1, -1] = -G - G_amb
    rhs[0] = -G * T_left
    rhs[-1] = -G_amb * T_amb
    return np.linalg.solve(M, rhs)


@pytest.mark.parametrize("changed", [{}, {"T_left": 350.0, "G_amb": 2.0, "G": 3.0}])
def test_steady_state_rod_starts_at_the_hand_solved_equilibrium(changed):
    m = lower(MODELS, "Arrays.RodSteady")
    x0, p = _x0(m, **changed)
    values = {q.name: q.start for q in m.parameters} | changed
    expected = _rod_equilibrium(10, values["G"], values["G_amb"], values["T_left"], values["T_amb"])
    np.testing.assert_allclose(x0, expected, rtol=1e-12)
    assert np.max(np.abs(np.array(m.ode(x0, [], p, 0.0)))) < 1e-9
    if not changed:  # the heat flow through a chain of 10 conductances G and one G_amb: 100 K / 4 K/W
        assert x0[0] == pytest.approx(400 - 25 / 5.0, rel=1e-12)


@pytest.mark.parametrize("q, a", [(0.3, 0.2), (0.5, 0.1), (0.05, 0.4)])
def test_nonlinear_steady_state_is_solved_by_newton_from_the_start_value(q, a):
    # 0 = q - a sqrt(h)  =>  h = (q / a)^2
    m = lower(MODELS, "Arrays.Tank")
    x0, _ = _x0(m, q=q, a=a)
    assert x0[0] == pytest.approx((q / a) ** 2, rel=1e-10)
    assert any("Newton" in note for note in m.notes)


@pytest.mark.parametrize("F, k", [(5.0, 100.0), (-2.0, 40.0)])
def test_initial_equations_mixing_states_derivatives_algebraics_and_parameters(F, k):
    # der(v) = 0 and spring + 2 der(x) = F with der(x) = v, spring = k x, m der(v) = F - spring - d v:
    # F - k x - d v = 0 and k x + 2 v = F  =>  v (d - 2) = 0  =>  v = 0, x = F / k; w is fixed at its start 0.
    m = lower(MODELS, "Arrays.Mixed")
    assert [s.name for s in m.states] == ["x", "v", "w"]
    x0, _ = _x0(m, F=F, k=k)
    np.testing.assert_allclose(x0, [F / k, 0.0, 0.0], atol=1e-14)


@pytest.mark.parametrize("k", [2.0, 0.5])
def test_initial_equations_on_der_of_an_expression_and_on_an_algebraic_variable(k):
    # der(x1 - x2) = -k x1 + 1 - (x1 - x2) = 0 with x2 at its start 0.5  =>  x1 = (1 + 0.5) / (k + 1);
    # power = y^2 = 4 k, Newton from y = 3  =>  y = 2 sqrt(k); z keeps its start.
    m = lower(MODELS, "Arrays.Indirect")
    assert [s.name for s in m.states] == ["x1", "x2", "y", "z"]
    np.testing.assert_allclose(_x0(m, k=k)[0], [1.5 / (k + 1), 0.5, 2 * np.sqrt(k), 1.0], rtol=1e-12)


def test_explicit_initial_equation_keeps_its_value_and_other_states_their_start():
    m = lower(MODELS, "Arrays.Explicit")
    np.testing.assert_array_equal(_x0(m)[0], [0.8, 2.0])
    np.testing.assert_array_equal(_x0(m, x0=1.5)[0], [3.0, 2.0])
    assert [s.start for s in m.states] == [0.8, 2.0]


@pytest.mark.parametrize("model, p, expected", [
    ("Arrays.Tank", [2.0, 0.5, 0.2], [6.25]),
    ("Arrays.Mixed", [1.5, 40.0, 3.0, -2.0], [-0.05, 0.0, 0.0]),
])
def test_x0_generates_c_code_that_agrees(tmp_path, model, p, expected):
    # The Newton iterations are CasADi expressions, so x0(p) compiles to plain C (CasADi's rootfinders do not).
    m = lower(MODELS, model)
    generator = ca.CodeGenerator("x0.c", {"main": True})
    generator.add(m.x0)
    generator.generate(f"{tmp_path}/")
    subprocess.run(["gcc", "-O1", str(tmp_path / "x0.c"), "-o", str(tmp_path / "x0"), "-lm"], check=True)
    run = subprocess.run([str(tmp_path / "x0"), "x0"], input=" ".join(map(str, p)), capture_output=True,
                         text=True, check=True)
    np.testing.assert_allclose([float(v) for v in run.stdout.split()], expected, rtol=1e-12, atol=1e-15)


BAD = {
    "too many": ("""
  model M
    Real x(start = 1);
    Real y(start = 0, fixed = true);
  equation
    der(x) = -x + y;
    der(y) = -y;
  initial equation
    der(x) = 0;
    x = 2;
  end M;""", "3 equations for the 2 unknowns", 9),  # y is fixed and reached through der(x)
    "singular": ("""
  model M
    Real a(start = 1);
    Real b(start = 0);
  equation
    der(a) = b - a;
    der(b) = a - b;
  initial equation
    der(a) = 0;
    der(b) = 0;
  end M;""", "singular", 9),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_initial_equations_that_do_not_determine_the_states_name_file_and_line(tmp_path, case):
    body, expected, line = BAD[case]
    with pytest.raises(StructureError) as err:
        lower(write_package(tmp_path, body), "T.M")
    assert expected in str(err.value)
    assert err.value.file.endswith("T.mo") and err.value.line == line, str(err.value)


def test_a_fixed_start_of_a_state_that_index_reduction_demoted_still_holds(tmp_path):
    """Two masses and a relative position preferred as the state (the MSL's dampers): the masses' fixed starts
    hold through it (s_rel = s2 - s1 = 1.0 - (-0.5)), not the relative position's own guess 0."""
    path = write_package(tmp_path, """
  model M
    Real s1(start = -0.5, fixed = true);
    Real v1(start = 0, fixed = true);
    Real s2(start = 1.0, fixed = true);
    Real v2(start = 0, fixed = true);
    Real s_rel(start = 0, stateSelect = StateSelect.prefer);
    Real v_rel(start = 0, stateSelect = StateSelect.prefer);
    Real f;
  equation
    s_rel = s2 - s1;
    v_rel = der(s_rel);
    der(s1) = v1;
    der(s2) = v2;
    f = 10*s_rel + v_rel;
    der(v1) = f;
    der(v2) = -f;
  end M;""")
    m = lower(path, "T.M")
    x0 = dict(zip([s.name for s in m.states], m.initial_state()))
    assert "s_rel" in x0 and "s2" not in x0  # the preferred state was kept, s2 demoted
    assert x0["s_rel"] == pytest.approx(1.5, abs=1e-12)
    assert x0["s1"] == pytest.approx(-0.5, abs=1e-12)


def test_an_initial_equation_on_an_output_through_a_limiter_is_solved_at_the_start_values(tmp_path):
    """The MSL's PI block initialised by its output (initType = InitialOutput) behind a relation that events hold
    between events: the relation is evaluated from the values at the start. y = k*(x + e) with e = min(u, 2)
    (u = 3 at t = 0, so e = 2) and y = 5 give x = 5/k - 2."""
    path = write_package(tmp_path, """
  model M
    parameter Real k = 2;
    Real x(start = 0);
    Real u = 3 - time;
    Real e = if u > 2 then 2 else u;
    Real y;
  equation
    der(x) = e;
    y = k*(x + e);
  initial equation
    y = 5;
  end M;""")
    m = lower(path, "T.M")
    assert m.initial_state() == pytest.approx([5 / 2 - 2], abs=1e-12)


def test_an_equation_of_one_state_keeps_it_when_another_reaches_it_through_an_algebraic_variable(tmp_path):
    """Three initial equations: two on states a and b, one on an output y = a + b + c that reaches them; the
    output's equation takes the third state c (a = 1, b = 2, y = 10 give c = 7), whichever order rumoca gives."""
    path = write_package(tmp_path, """
  model M
    Real y;
    Real a(start = 0);
    Real b(start = 0);
    Real c(start = 0);
  equation
    y = a + b + c;
    der(a) = -a;
    der(b) = -b;
    der(c) = -c;
  initial equation
    y = 10;
    a = 1;
    b = 2;
  end M;""")
    m = lower(path, "T.M")
    assert dict(zip([s.name for s in m.states], m.initial_state())) == pytest.approx({"a": 1, "b": 2, "c": 7})


def test_a_fixed_start_of_an_algebraic_variable_is_an_initial_equation(tmp_path):
    """The MSL's PID_Controller example starts its inertia with a(fixed = true, start = 0): the spring then
    starts deflected to hold the force, x0 = F/k (with v fixed at 0), not at its start value 0."""
    path = write_package(tmp_path, """
  model M
    parameter Real k = 4;
    parameter Real F = 2;
    Real x(start = 0);
    Real v(start = 0, fixed = true);
    Real a(start = 0, fixed = true);
  equation
    der(x) = v;
    der(v) = a;
    a = F - k*x;
  end M;""")
    m = lower(path, "T.M")
    assert dict(zip([s.name for s in m.states], m.initial_state())) == pytest.approx({"x": 0.5, "v": 0.0})


def test_a_parameter_declared_fixed_false_is_computed_by_the_initial_equations(tmp_path):
    """parameter t0(fixed = false) with the initial equation t0 = 2 k + time (the MSL's harmonic analysis
    blocks take t0 = time): computed at initialisation from k, then constant; der(x) = -t0 x decays at 2 k."""
    path = write_package(tmp_path, """
  model M
    parameter Real k = 2;
    parameter Real t0(fixed = false);
    Real x(start = 1, fixed = true);
  initial equation
    t0 = 2*k + time;
  equation
    der(x) = -t0*x;
  end M;""")
    m = lower(path, "T.M")
    for k in (2.0, 3.0):
        x0 = dict(zip([s.name for s in m.states], np.array(m.x0([k]), dtype=float).ravel()))
        assert x0 == pytest.approx({"t0": 2 * k, "x": 1.0})
        assert m.derivatives([x0[s.name] for s in m.states], [], [k]) == pytest.approx(
            [0.0 if s.name == "t0" else -2 * k for s in m.states])


_PARALLEL = """
  model M
    parameter Real C1 = 1e-3;
    parameter Real C2 = 2e-3;
    parameter Real R = 10;
    Real v1(start = 2, fixed = true);
    Real v2(start = V2, fixed = true);
    parameter Real V2 = 2;
    Real i1;
    Real i2;
  equation
    C1*der(v1) = i1;
    C2*der(v2) = i2;
    v1 = v2;
    i1 + i2 = -v1/R;
  end M;"""


def test_fixed_starts_the_other_initial_equations_imply_are_left_out_when_they_agree(tmp_path):
    """Two capacitors in parallel, both v(fixed = true) (the MSL's GenerationOfFMUs): one start is enough when
    they agree; v then decays with tau = R (C1 + C2)."""
    m = lower(write_package(tmp_path, _PARALLEL), "T.M")
    assert m.initial_state() == pytest.approx([2.0])
    assert any("left out" in note for note in m.notes)
    assert m.derivatives([2.0], []) == pytest.approx([-2.0 / (10 * 3e-3)])


def test_fixed_starts_that_contradict_each_other_are_refused(tmp_path):
    with pytest.raises(StructureError, match="contradict each other"):
        lower(write_package(tmp_path, _PARALLEL.replace("parameter Real V2 = 2;", "parameter Real V2 = 3;")),
              "T.M")


def test_an_initial_state_that_is_not_a_number_is_refused(tmp_path):
    """x(start = b/a) with a = b = 0 is 0/0: refused with the state's name and line, not NaN in the FMU."""
    path = write_package(tmp_path, """
  model M
    parameter Real a = 0;
    parameter Real b = 0;
    Real x(start = b/a, fixed = true);
  equation
    der(x) = -x;
  end M;""")
    with pytest.raises(StructureError, match="initial value of x is not a number") as err:
        lower(path, "T.M")
    assert err.value.line == 5


_FILTER = """
  model M
    parameter Real f = 2;
    parameter Real u = 0.5;
    parameter Real c(fixed = false);
    parameter Real r(fixed = false);
    Real x;
    Real y(start = 1);
  initial equation
    c = 1.5*f;
    r = -sqrt(c)*f;
    der(x) = 0;
    der(y) = 0;
  equation
    der(x) = r*(x - u);
    der(y) = r*(y^3 + y - u);
  end M;"""


@pytest.mark.parametrize("f, u", [(2.0, 0.5), (0.5, -3.0)])
def test_a_parameter_computed_by_an_initial_equation_is_found_before_the_states_it_is_a_coefficient_of(
        tmp_path, f, u):
    """The MSL's Filter: its pole r is a parameter(fixed = false) computed by an initial equation, and its states
    start in steady state, der(x) = r (x - u) = 0. Solved together with x from r's start 0, the Jacobian is
    singular (the build refused a NaN); sorted, r comes first: x = u, and y^3 + y = u (one real root)."""
    m = lower(write_package(tmp_path, _FILTER), "T.M")
    x0 = dict(zip([s.name for s in m.states], _x0(m, f=f, u=u)[0]))
    y = next(z.real for z in np.roots([1, 0, 1, -u]) if abs(z.imag) < 1e-12)
    assert x0 == pytest.approx({"c": 1.5 * f, "r": -np.sqrt(1.5 * f) * f, "x": u, "y": y}, rel=1e-10, abs=1e-12)


def test_an_initial_problem_newton_does_not_solve_is_refused(tmp_path):
    """der(x) = x^2 + 1 = 0 has no real solution: refused with the equation's line, not the last Newton iterate."""
    path = write_package(tmp_path, """
  model M
    parameter Real p = 1;
    Real x(start = 1);
  initial equation
    der(x) = 0;
  equation
    der(x) = x^2 + p;
  end M;""")
    with pytest.raises(StructureError, match="not solved by Newton's method") as err:
        lower(path, "T.M")
    assert err.value.line == 6


def test_fixed_starts_that_contradict_each_other_are_refused_in_a_nonlinear_initial_problem(tmp_path):
    """The parallel capacitors' contradicting starts (2 and 3) beside a nonlinear steady state z^3 + z = v1: the
    left-out start is checked on Newton's solution too."""
    body = _PARALLEL.replace("parameter Real V2 = 2;", "parameter Real V2 = 3;\n    Real z(start = 1);")
    body = body.replace("  equation\n", "  initial equation\n    der(z) = 0;\n  equation\n    der(z) = v1 - z^3 - z;\n")
    with pytest.raises(StructureError, match="contradict each other"):
        lower(write_package(tmp_path, body), "T.M")
