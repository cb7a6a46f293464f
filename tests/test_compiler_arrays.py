"""Arrays, for-equations, array built-ins and functions with algorithm sections (loops, if statements, array
arguments and results), lowered by the compiler and compared with numpy / scipy written by hand from the
models' equations (tests/models/arrays/Arrays.mo)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cosim.compile import lower
from cosim.errors import ModelicaError, UnsupportedConstructError
from modelica_support import write_package

MODELS = Path(__file__).resolve().parent / "models" / "arrays" / "Arrays.mo"


def _defaults(m):
    return np.array([p.start for p in m.parameters])


def _call(f, *args):
    return np.array(f(*args), dtype=float).ravel()


def test_rod_of_ten_cells_with_for_equations_matches_solve_ivp():
    # C dT1 = G (T_left - T1) - G (T1 - T2); C dTi = G (T[i-1] - 2 Ti + T[i+1]);
    # C dTN = G (T[N-1] - TN) - G_amb (TN - T_amb); T_mean = mean(T).
    N, C, G, G_amb, T_left, T_amb = 10, 2.0, 5.0, 0.5, 400.0, 300.0

    def rhs(t, T):
        Q = np.empty(N)
        Q[0] = G * (T_left - T[0]) - G * (T[0] - T[1])
        Q[1:-1] = G * (T[:-2] - 2 * T[1:-1] + T[2:])
        Q[-1] = G * (T[-2] - T[-1]) - G_amb * (T[-1] - T_amb)
        return Q / C

    m = lower(MODELS, "Arrays.Rod")
    assert [s.name for s in m.states] == [f"T[{i}]" for i in range(1, N + 1)]
    assert [s.start for s in m.states] == [300.0] * N
    p = _defaults(m)
    t_eval = np.linspace(0, 20, 41)
    x0 = np.full(N, 300.0)
    ref = solve_ivp(rhs, (0, 20), x0, t_eval=t_eval, rtol=1e-10, atol=1e-10)
    got = solve_ivp(lambda t, x: _call(m.ode, x, [], p, t), (0, 20), x0, t_eval=t_eval, rtol=1e-10, atol=1e-10)
    assert ref.success and got.success
    assert np.max(np.abs(got.y - ref.y)) < 1e-6 * np.ptp(ref.y)
    names = [v.name for v in m.observed]
    observed = np.array([_call(m.observe, got.y[:, k], [], p, t) for k, t in enumerate(t_eval)])
    np.testing.assert_allclose(observed[:, names.index("T_mean")], ref.y.mean(axis=0), rtol=1e-9)
    np.testing.assert_allclose(observed[:, names.index("Q_left")], G * (T_left - ref.y[0]), rtol=1e-6, atol=1e-6)


def test_array_parameters_builtins_and_matrix_vector_products_match_numpy():
    A = np.array([[-2, 1, 0], [0.5, -3, 1], [0, 1, -1.5]])
    b, c, w = np.linspace(1, 2, 3), np.array([1.0, -1, 2]), np.full(3, 0.25)
    m = lower(MODELS, "Arrays.LinearSystem")
    pnames = [q.name for q in m.parameters]
    assert pnames[:9] == [f"A[{i},{j}]" for i in (1, 2, 3) for j in (1, 2, 3)]  # row-major element names
    np.testing.assert_array_equal(_defaults(m)[:9], A.ravel())
    np.testing.assert_array_equal(_defaults(m)[9:12], b)
    assert [s.start for s in m.states] == [1.0, 0.5, -0.5]
    rng = np.random.default_rng(3)
    for _ in range(5):
        # tunable array parameters: a perturbed A and b reach the equations
        A2, b2 = A + rng.normal(0, 0.1, A.shape), b + rng.normal(0, 0.1, 3)
        p = np.concatenate([A2.ravel(), b2, c, w])
        x, u = rng.normal(size=3), rng.normal()
        np.testing.assert_allclose(_call(m.ode, x, [u], p, 0.0), A2 @ x + b2 * u, rtol=1e-12)
        out = dict(zip([o.name for o in m.outputs], _call(m.out, x, [u], p, 0.0)))
        assert out["y"] == pytest.approx(c @ x, rel=1e-12)
        assert out["s"] == pytest.approx(x.sum() + w @ x + 3 - 3, rel=1e-12)
        assert out["last"] == x[2]
        np.testing.assert_allclose([out[f"row[{i}]"] for i in (1, 2, 3)], A2[1] * x, rtol=1e-12)
        np.testing.assert_allclose([out["pair[1]"], out["pair[2]"]], A2[:2, 1:3] @ x[1:3], rtol=1e-12)


def test_matrix_states_nested_for_equations_and_more_builtins_match_numpy():
    A, v = np.array([[1.0, 2], [3, 4]]), np.array([1.0, 2, 3])
    m = lower(MODELS, "Arrays.MoreArrays")
    assert [s.name for s in m.states][:4] == ["m[1,1]", "m[1,2]", "m[2,1]", "m[2,2]"]
    assert [s.start for s in m.states] == [1, 0, 0.5, 2, 1, 1, 1, 1]
    p = _defaults(m)
    x = np.random.default_rng(7).normal(size=8)
    M, chain = x[:4].reshape(2, 2), x[4:]
    expected = np.concatenate([(-A @ M).ravel(), [-chain[0]], chain[:-1] - chain[1:]])
    np.testing.assert_allclose(_call(m.ode, x, [], p, 0.0), expected, rtol=1e-12)
    out = dict(zip([o.name for o in m.outputs], _call(m.out, x, [], p, 0.0)))
    np.testing.assert_array_equal([out[f"joined[{i}]"] for i in range(1, 6)], [1, 2, 3, 7, 8])
    assert out["weighted"] == pytest.approx(chain @ np.arange(1, 5), rel=1e-12)
    np.testing.assert_array_equal([out["row[1]"], out["row[2]"]], A[1])
    skew = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    np.testing.assert_array_equal([[out[f"sk[{i},{j}]"] for j in (1, 2, 3)] for i in (1, 2, 3)], skew)
    grid = [[10 * i + j + M[i - 1, 0] for j in (1, 2, 3)] for i in (1, 2)]
    np.testing.assert_allclose([[out[f"grid[{i},{j}]"] for j in (1, 2, 3)] for i in (1, 2)], grid, rtol=1e-14)


def test_functions_with_for_loops_over_array_arguments_match_numpy():
    c = np.array([0.5, -1, 2, 3])
    m = lower(MODELS, "Arrays.FunctionLoops")
    names = [o.name for o in m.outputs]
    p = _defaults(m)
    for x, t in [(0.2, 0.0), (-0.7, 1.3), (1.9, 2.5), (0.3, 0.1)]:
        out = dict(zip(names, _call(m.out, [x], [], p, t)))
        assert out["p"] == pytest.approx(np.polyval(c, x), rel=1e-12)
        assert out["n"] == pytest.approx(np.linalg.norm([x, 2 * x, np.cos(t)]), rel=1e-12)
        assert out["k"] == pytest.approx(np.clip(x, -0.3, 0.3), rel=1e-12)
        np.testing.assert_allclose([out[f"cs[{i}]"] for i in range(1, 5)], np.cumsum(c), rtol=1e-12)
        v = np.array([x - 0.5, 2, -1, x])
        assert out["tot"] == pytest.approx(v[v > 0].sum() + 2 * v.sum(), rel=1e-12)
        assert out["prod"] == pytest.approx(np.prod(v[v > 0]), rel=1e-12)
        w, a, b = [x, -2 * x, 3, x - 2], 0.0, 0.0
        for i in range(4):
            a += sum(w[i] * w[j] for j in range(i + 1))
            if w[i] > 0:
                b += w[i]
                a += b
            else:
                b -= 1
        assert (out["pa"], out["pb"]) == (pytest.approx(a, rel=1e-12), pytest.approx(b, rel=1e-12))
    assert _call(m.ode, [0.2], [], p, 1.0)[0] == pytest.approx(1 - 0.2 + 0.5 * np.sin(3.0), rel=1e-12)


def test_der_of_expressions_follows_the_hand_derived_ode():
    # rate = der(phi2 - phi1) = w2 - w1; der(k z) = -z  =>  z' = -z / k:
    # J1 w1' = tau + c (phi2 - phi1) + d (w2 - w1), J2 w2' = -c (phi2 - phi1) - d (w2 - w1).
    J1, J2, c, d, k, tau = 0.5, 1.5, 40.0, 0.8, 2.0, 1.0

    def rhs(t, s):
        phi1, phi2, w1, w2, z = s
        spring = c * (phi2 - phi1) + d * (w2 - w1)
        return [w1, w2, (tau + spring) / J1, -spring / J2, -z / k]

    m = lower(MODELS, "Arrays.DerExpression")
    assert [s.name for s in m.states] == ["phi1", "phi2", "w1", "w2", "z"]
    x0 = [0.0, 0.1, 0.0, 0.0, 1.0]
    assert [s.start for s in m.states] == x0
    p = _defaults(m)
    t_eval = np.linspace(0, 3, 61)
    ref = solve_ivp(rhs, (0, 3), x0, t_eval=t_eval, rtol=1e-10, atol=1e-12)
    got = solve_ivp(lambda t, x: _call(m.ode, x, [], p, t), (0, 3), x0, t_eval=t_eval, rtol=1e-10, atol=1e-12)
    assert ref.success and got.success
    np.testing.assert_allclose(got.y, ref.y, rtol=0, atol=1e-7)
    rate = [_call(m.observe, got.y[:, j], [], p, t)[[v.name for v in m.observed].index("rate")]
            for j, t in enumerate(t_eval)]
    np.testing.assert_allclose(rate, ref.y[3] - ref.y[2], atol=1e-7)


REJECTED = {
    "while": ("""
  function halve
    input Real x;
    output Real y;
  algorithm
    y := x;
    while y > 1 loop
      y := y/2;
    end while;
  end halve;
  model M
    Real x(start = 1);
  equation
    der(x) = -halve(x);
  end M;""", "while-statement", 7),
    "for over array elements": ("""
  function total
    input Real v[:];
    output Real s;
  algorithm
    s := 0;
    for e in v loop
      s := s + e;
    end for;
  end total;
  model M
    Real x(start = 1);
  equation
    der(x) = -total({x, 2*x});
  end M;""", "for-loop over the elements of an array", 7),
    "model algorithm with a loop": ("""
  model M
    Real x[2](each start = 1);
    Real y;
  algorithm
    y := 0;
    for i in 1:2 loop
      y := y + x[i];
    end for;
  equation
    der(x) = -x*y;
  end M;""", "algorithm section of a model is not supported", 5),
    "der of an expression in a declaration": ("""
  model M
    Real x(start = 1);
    Real z(start = 0);
    Real y = der(x + z);
  equation
    der(x) = -x;
    der(z) = 1;
  end M;""", "der() of this expression is not supported: write der() of a variable here", 5),
    "der of an expression in a for-equation": ("""
  model M
    Real x[2](each start = 1);
    Real y[2](each start = 0);
  equation
    for i in 1:2 loop
      der(x[i] + y[i]) = -x[i];
      der(y[i]) = 1;
    end for;
  end M;""", "der() of this expression is not supported", 7),
    "break": ("""
  function total
    input Real v[:];
    output Real s;
  algorithm
    s := 0;
    for i in 1:size(v, 1) loop
      if v[i] < 0 then
        break;
      end if;
      s := s + v[i];
    end for;
  end total;
  model M
    Real x(start = 1);
  equation
    der(x) = -total({x, -1, x});
  end M;""", "break-statement in function total", 9),
    "three-dimensional array": ("""
  model M
    parameter Real a[2, 2, 2] = fill(1.0, 2, 2, 2);
    Real x(start = 1);
  equation
    der(x) = -x*a[1, 1, 1];
  end M;""", "dimensions [2, 2, 2]", 3),
    "relation with events in a for-equation": ("""
  model M
    Real x[2](each start = 1);
  equation
    for i in 1:2 loop
      der(x[i]) = if x[i] > 0.5 then -i else 0;
    end for;
  end M;""", "relation generating events inside a for-equation", 6),
}


@pytest.mark.parametrize("construct", sorted(REJECTED))
def test_rejected_array_and_function_constructs_name_file_and_line(tmp_path, construct):
    body, expected, line = REJECTED[construct]
    with pytest.raises(ModelicaError) as err:
        lower(write_package(tmp_path, body), "T.M")
    assert expected in str(err.value)
    assert err.value.file.endswith("T.mo") and err.value.line == line, str(err.value)
    assert isinstance(err.value, UnsupportedConstructError), type(err.value)


def test_arrays_of_one_element_are_elements_named_with_their_index(tmp_path):
    """The MSL's filters and KinematicPTP declare x[n] and deltaq[:] = {1}: an array of one element is the
    variable x[1] (with its derivative), not a scalar x. der(x[1]) = -a[1] x[1] decays as exp(-a t)."""
    path = write_package(tmp_path, """
  model M
    parameter Real a[:] = {2};
    parameter Real b[1] = a;
    Real x[1](each start = 3, each fixed = true);
  equation
    der(x) = -b .* x;
  end M;""")
    m = lower(path, "T.M")
    assert [s.name for s in m.states] == ["x[1]"] and [p.name for p in m.parameters] == ["a[1]"]
    x0 = m.initial_state()
    assert x0 == pytest.approx([3.0])
    assert m.derivatives(x0, [], [2.0]) == pytest.approx([-6.0])


def test_element_wise_operators_follow_numpy(tmp_path):
    """.* ./ .+ .- .^ on arrays of two elements (the MSL's Blocks.Math.Product and filters use them)."""
    path = write_package(tmp_path, """
  model M
    parameter Real a[2] = {1.5, 2.5};
    parameter Real b[2] = {0.5, 4};
    output Real y[2];
  equation
    y = (a .* b) ./ (a .+ b) .- a .^ b;
  end M;""")
    m = lower(path, "T.M")
    a, b = np.array([1.5, 2.5]), np.array([0.5, 4.0])
    assert m.output_values([], []) == pytest.approx(a * b / (a + b) - a**b, rel=1e-14)


def test_a_matrix_output_of_a_function_assigned_element_by_element(tmp_path):
    """The MSL's Bessel filter coefficients: output Real c2[integer(order/2), 2] filled one element at a time
    (rumoca first fills it with a two-index comprehension, which is the 2x2 matrix, not a column of 4)."""
    path = write_package(tmp_path, """
  function f
    input Integer order;
    output Real c2[integer(order/2), 2];
  algorithm
    c2[1, 1] := 1;
    c2[1, 2] := 2;
    c2[2, 1] := 3;
    c2[2, 2] := 4;
  end f;
  model M
    parameter Real c[2, 2] = f(4);
    output Real y[2, 2] = c;
  end M;""")
    m = lower(path, "T.M")
    assert dict(zip([o.name for o in m.outputs], m.output_values([], []))) == {
        "y[1,1]": 1.0, "y[1,2]": 2.0, "y[2,1]": 3.0, "y[2,2]": 4.0}


FIRST_DIFFERENCE = """
  model M
    function firstDifference "the MSL's Matrices.isEqual, a while loop that ends early by moving its index"
      input Real a[:];
      input Real b[:];
      output Integer k;
    protected
      Integer i = 1;
    algorithm
      k := 0;
      while i <= size(a, 1) loop
        if abs(a[i] - b[i]) > 0 then
          k := i;
          i := size(a, 1);
        end if;
        i := i + 1;
      end while;
    end firstDifference;
    parameter Real t[4] = {T};
    Real x(start = 0, fixed = true);
  equation
    der(x) = firstDifference(t, {0, 1, 1, 0});
  end M;"""


def _first_difference(t, b=(0, 1, 1, 0)):
    differ = np.flatnonzero(np.asarray(t, dtype=float) != b)
    return int(differ[0]) + 1 if differ.size else 0


@pytest.mark.parametrize("t", [[0, 1, 1, 0], [0.5, 1, 1, 0], [0, 1, 0.5, 0], [0, 1, 1, 2]])
def test_a_while_loop_that_leaves_early_reads_no_element_past_its_end(tmp_path, t):
    """rumoca unrolls the while loop into guarded passes; the guard of the pass after the end (i = 5) is false,
    and the pass's a[5] is not evaluated (it stopped the build: a subscript outside the array). Where the loop's
    course was decided on the parameters' values, those parameters are constants of the FMU; an element the
    result follows at run time stays tunable, and a new value of it gives the result of the new table."""
    path = write_package(tmp_path, FIRST_DIFFERENCE.replace("{T}", "{" + ", ".join(map(str, t)) + "}"))
    m = lower(path, "T.M")
    assert _call(m.ode, [0.0], [], _defaults(m), 0.0) == pytest.approx([_first_difference(t)])
    tuned = list(t)
    for p in m.parameters:
        tuned[int(p.name[2:-1]) - 1] = 7.0
    assert _call(m.ode, [0.0], [], [7.0] * len(m.parameters), 0.0) == pytest.approx([_first_difference(tuned)])
