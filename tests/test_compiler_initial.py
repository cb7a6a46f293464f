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
  end M;""", "2 equations for the 1 unknowns", 9),
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
