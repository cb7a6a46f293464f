"""Event-generating integer functions (Modelica 3.7.2): floor, ceil, integer, div, mod, rem. Small Modelica models
built to FMUs and simulated by fmpy (its CVode on the Model Exchange interface, and the FMU's own Co-Simulation
solver), against closed forms evaluated with numpy away from the event instants; the event instants against the
hand-computed ones (a state integrating a piecewise constant input is exact only if the events are located)."""

from pathlib import Path

import numpy as np
import pytest

from cosim.compile import build_fmu, lower
from cosim.errors import ModelicaError
from modelica_support import away, event_instants, fmu_builder, simulate, write_package

MSL = Path("/work/shared/msl/ModelicaStandardLibrary-4.1.0")

MODELS = """
  model Saw "functions of time only: time events"
    Real x(start = 0, fixed = true);
    output Real f;
    output Real y;
    output Real r;
    output Real d;
  equation
    f = floor(3*time);
    y = mod(time, 0.3);
    der(x) = mod(time, 0.25);
    r = rem(-time, 0.4);
    d = div(1 - time, 0.3);
  end Saw;

  model Osc "functions of a state z = 1.5 sin(t): state events"
    Real z(start = 0, fixed = true);
    Real v(start = 1.5, fixed = true);
    Real w(start = 0, fixed = true);
    output Integer n;
    output Real c;
    output Real d;
  equation
    der(z) = v;
    der(v) = -z;
    n = integer(z);
    c = ceil(z);
    d = div(z, 0.5);
    der(w) = d;
  end Osc;

  model Ramp "integer() of a state ramp"
    Real z(start = 0.3, fixed = true);
    Real w(start = 0, fixed = true);
    output Integer n;
  equation
    der(z) = 2;
    n = integer(z);
    der(w) = n;
  end Ramp;

  function f
    input Real a;
    output Real b;
  algorithm
    b := mod(a, 0.5) + 10*floor(a) + 100*div(a, 0.3) + 1000*rem(-a, 0.3) + 1e4*integer(2*a) + 1e5*ceil(a);
  end f;

  model Direct "inside functions, noEvent and smooth, of parameters: evaluated directly, no event"
    parameter Real p = 1.7;
    parameter Real tab[3] = {mod(i + 1, 2.0) for i in 1:3} "as Blocks.Sources.BooleanTable's table";
    parameter Real q = div(-p, 0.5);
    output Real y;
    output Real z;
    output Real w;
    output Real g;
  equation
    y = f(time - 0.5);
    z = noEvent(ceil(2*time)) + smooth(0, floor(3*time));
    w = noEvent(div(-time, 0.3)) + noEvent(mod(-time, 0.3));
    g = tab[1] + 10*tab[2] + 100*tab[3] + 1000*rem(p, 0.3) + q;
  end Direct;

  model Square "a relation on mod(), nested functions, a for-equation, a when-clause"
    Real x(start = 0, fixed = true);
    output Real s;
    output Integer k;
    output Integer k2(start = 0);
    output Real y[3];
  equation
    s = if mod(time, 0.5) < 0.2 then 1 else 0;
    der(x) = s;
    k = mod(integer(time/0.1), 3);
    when time >= 0.55 then
      k2 = integer(10*time);
    end when;
    for i in 1:3 loop
      y[i] = floor(i*time);
    end for;
  end Square;

  model PulseLike "Modelica.Blocks.Sources.Pulse's equations: integer() in an initial algorithm"
    parameter Real period = 0.3;
    parameter Real startTime = 0.1;
    parameter Real width = 0.12;
    Real x(start = 0, fixed = true);
    Integer count;
    discrete Real T_start;
    output Real y;
  initial algorithm
    count := integer((time - startTime)/period);
    T_start := startTime + count*period;
  equation
    when time >= (pre(count) + 1)*period + startTime then
      count = pre(count) + 1;
      T_start = time;
    end when;
    y = if time < startTime then 0 else if time < T_start + width then 2 else 0;
    der(x) = y;
  end PulseLike;
"""


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    return write_package(tmp_path_factory.mktemp("integer_events"), MODELS)


@pytest.fixture(scope="module")
def fmu(package):
    return fmu_builder(package)


def integral_of_piecewise_constant(t, edges, values):
    """int_0^t of a function equal to values[j] on (edges[j], edges[j+1])."""
    return np.array([sum(v * max(0.0, min(tt, b) - a) for a, b, v in zip(edges[:-1], edges[1:], values))
                     for tt in t])


FMI_TYPES = ["ModelExchange", "CoSimulation"]


def saw_instants(stop):
    """Where floor(3t), mod(t, 0.3), mod(t, 0.25), rem(-t, 0.4) and div(1 - t, 0.3) jump (div truncates:
    (1 - t)/0.3 crosses 3, 2, 1 and -1, but not 0)."""
    instants = [k / 3 for k in range(1, 5)] + [0.3 * k for k in range(1, 5)] + [0.25 * k for k in range(1, 6)]
    instants += [0.4 * k for k in range(1, 4)] + [0.1, 0.4, 0.7, 1.3]
    return np.unique(np.round([i for i in instants if i <= stop], 12))


@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_floor_mod_rem_div_of_time_jump_at_their_time_events(fmu, package, fmi_type):
    assert lower(package, "T.Saw").events.n_indicators == 0  # all on time: time events, no indicator
    r = simulate(fmu("Saw"), fmi_type, ["x", "f", "y", "r", "d"], 1.45)
    t = r["time"]
    expected = saw_instants(1.45)
    if fmi_type == "ModelExchange":
        np.testing.assert_allclose(event_instants(r), expected, atol=1e-12)
    ok = away(t, expected)
    np.testing.assert_array_equal(r["f"][ok], np.floor(3 * t[ok]))
    np.testing.assert_allclose(r["y"][ok], np.mod(t[ok], 0.3), atol=1e-12)
    np.testing.assert_allclose(r["r"][ok], np.fmod(-t[ok], 0.4), atol=1e-12)  # C fmod truncates, as rem does
    np.testing.assert_array_equal(r["d"][ok], np.trunc((1 - t[ok]) / 0.3))
    # x integrates the sawtooth mod(t, 0.25): k whole teeth of area 0.25^2/2 and the part of the current one
    k = np.floor(t / 0.25)
    np.testing.assert_allclose(r["x"], k * 0.25**2 / 2 + (t - 0.25 * k) ** 2 / 2, atol=1e-8)


def osc_crossings(stop):
    """Where z = 1.5 sin(t) crosses -1, -0.5, 0, 0.5, 1 (the bounds of integer(z), ceil(z), div(z, 0.5)), t > 0."""
    times = [base + 2 * np.pi * j for level in (-1, -0.5, 0, 0.5, 1) for j in range(-1, 3)
             for base in (np.arcsin(level / 1.5), np.pi - np.arcsin(level / 1.5))]
    return np.unique(np.round([tt for tt in times if 1e-9 < tt < stop], 12))


@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_integer_ceil_div_of_an_oscillating_state_are_state_events_at_its_crossings(fmu, package, fmi_type):
    assert lower(package, "T.Osc").events.n_indicators == 6  # two per function of the state
    r = simulate(fmu("Osc"), fmi_type, ["z", "n", "c", "d", "w"], 7.0)
    t = r["time"]
    crossings = osc_crossings(7.0)
    if fmi_type == "ModelExchange":  # plus one just after t = 0, where z leaves 0 upwards (ceil goes from 0 to 1)
        found = event_instants(r)
        assert found[0] < 1e-12
        np.testing.assert_allclose(found[1:], crossings, atol=1e-7)
    z = 1.5 * np.sin(t)
    np.testing.assert_allclose(r["z"], z, atol=1e-7)
    ok = away(t, np.concatenate([[0.0], crossings]))
    np.testing.assert_array_equal(r["n"][ok], np.floor(z[ok]))
    np.testing.assert_array_equal(r["c"][ok], np.ceil(z[ok]))
    np.testing.assert_array_equal(r["d"][ok], np.trunc(z[ok] / 0.5))
    edges = np.concatenate([[0.0], crossings, [7.0]])
    values = np.trunc(3 * np.sin(0.7 * edges[:-1] + 0.3 * edges[1:]))  # inside (not at the peaks, z = 1.5)
    np.testing.assert_allclose(r["w"], integral_of_piecewise_constant(t, edges, values), atol=1e-6)


@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_integer_of_a_state_ramp_counts_where_the_ramp_crosses_integers(fmu, fmi_type):
    r = simulate(fmu("Ramp"), fmi_type, ["z", "n", "w"], 2.0)
    t = r["time"]
    crossings = (np.arange(1, 5) - 0.3) / 2  # z = 0.3 + 2t reaches 1, 2, 3, 4
    if fmi_type == "ModelExchange":
        np.testing.assert_allclose(event_instants(r), crossings, atol=1e-9)
    ok = away(t, crossings)
    np.testing.assert_array_equal(r["n"][ok], np.floor(0.3 + 2 * t[ok]))
    edges = np.concatenate([[0.0], crossings, [2.0]])
    np.testing.assert_allclose(r["w"], integral_of_piecewise_constant(t, edges, np.arange(0, 5)), atol=1e-8)


def test_inside_functions_no_event_and_smooth_they_are_evaluated_directly(fmu, package):
    assert lower(package, "T.Direct").events is None  # no event memory, no indicator, no time event
    r = simulate(fmu("Direct"), "ModelExchange", ["y", "z", "w", "g"], 1.0)
    t = r["time"]
    a = t - 0.5
    expected = (np.mod(a, 0.5) + 10 * np.floor(a) + 100 * np.trunc(a / 0.3) + 1000 * np.fmod(-a, 0.3)
                + 1e4 * np.floor(2 * a) + 1e5 * np.ceil(a))
    # at a jump the last bit of an argument decides the side: compare where no argument is within 1e-9 of one
    ok = ~np.any([np.abs(q - np.round(q)) < 1e-9 for q in (a / 0.5, a, a / 0.3, 2 * a, 2 * t, 3 * t, t / 0.3)], axis=0)
    np.testing.assert_allclose(r["y"][ok], expected[ok], atol=1e-9)
    np.testing.assert_array_equal(r["z"][ok], np.ceil(2 * t[ok]) + np.floor(3 * t[ok]))
    np.testing.assert_allclose(r["w"][ok], np.trunc(-t[ok] / 0.3) + np.mod(-t[ok], 0.3), atol=1e-12)
    tab = np.mod(np.arange(1, 4) + 1, 2.0)
    np.testing.assert_allclose(r["g"], tab @ [1, 10, 100] + 1000 * np.fmod(1.7, 0.3) + np.trunc(-1.7 / 0.5),
                               atol=1e-12)


@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_a_relation_on_mod_nested_functions_a_for_equation_and_a_when_clause(fmu, fmi_type):
    r = simulate(fmu("Square"), fmi_type, ["x", "s", "k", "k2", "y[1]", "y[2]", "y[3]"], 1.05)
    t = r["time"]
    # s is 1 on the first 0.2 of each 0.5: x counts 0.2 per whole period and the part of the current one
    np.testing.assert_allclose(r["x"], np.floor(t / 0.5) * 0.2 + np.minimum(np.mod(t, 0.5), 0.2), atol=1e-12)
    # integer(time/0.1) at every 0.1 (mod(time, 0.5) and s's relation at 0.2, 0.5, 0.7, 1 among them), the when
    # at 0.55, floor(3*time) at 1/3 and 2/3
    instants = np.unique(np.round(np.concatenate([0.1 * np.arange(1, 11), [0.55, 1 / 3, 2 / 3]]), 12))
    if fmi_type == "ModelExchange":
        np.testing.assert_allclose(event_instants(r), instants, atol=1e-12)
    ok = away(t, instants)
    np.testing.assert_array_equal(r["s"][ok], np.mod(t[ok], 0.5) < 0.2)
    np.testing.assert_array_equal(r["k"][ok], np.mod(np.floor(t[ok] / 0.1), 3))
    np.testing.assert_array_equal(r["k2"][ok], np.where(t[ok] >= 0.55, 5, 0))  # integer(10*0.55) at the event
    for i in (1, 2, 3):
        np.testing.assert_array_equal(r[f"y[{i}]"][ok], np.floor(i * t[ok]))


def pulse_reference(t, period=0.3, start=0.1, width=0.12, amplitude=2.0):
    """The pulse, and its integral: `amplitude` on [start + j*period, start + j*period + width)."""
    phase = np.mod(t - start, period)
    y = np.where((t >= start) & (phase < width), amplitude, 0.0)
    whole = np.floor((t - start) / period)
    x = np.where(t >= start, amplitude * (whole * width + np.minimum(phase, width)), 0.0)
    return y, x


@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_pulse_equations_with_integer_in_the_initial_algorithm(fmu, fmi_type):
    r = simulate(fmu("PulseLike"), fmi_type, ["x", "y"], 1.0)
    t = r["time"]
    y, x = pulse_reference(t)
    edges = 0.1 + 0.3 * np.arange(4)
    ok = away(t, np.concatenate([edges, edges + 0.12]))
    np.testing.assert_array_equal(r["y"][ok], y[ok])
    np.testing.assert_allclose(r["x"], x, atol=1e-9)


MSL_USER_MODEL = """
  model Sources "MSL 4.1.0 sources whose initial algorithm is count := integer((time - startTime)/period)"
    Modelica.Blocks.Sources.Pulse pulse(amplitude = 2, width = 40, period = 0.3, startTime = 0.1);
    Modelica.Blocks.Sources.SawTooth saw(amplitude = 3, period = 0.25, startTime = -0.1);
    Modelica.Blocks.Sources.Trapezoid trapezoid(amplitude = 1.5, rising = 0.05, width = 0.1, falling = 0.05,
      period = 0.3, nperiod = 2, startTime = 0.05);
    Real x(start = 0, fixed = true);
    output Real y = pulse.y;
    output Real s = saw.y;
    output Real q = trapezoid.y;
  equation
    der(x) = pulse.y;
  end Sources;
"""


def trapezoid_reference(t, amplitude=1.5, rising=0.05, width=0.1, falling=0.05, period=0.3, nperiod=2, start=0.05):
    phase = np.mod(t - start, period)
    active = (t >= start) & (np.floor((t - start) / period) < nperiod)
    shape = np.interp(phase, [0, rising, rising + width, rising + width + falling, period],
                      [0, amplitude, amplitude, 0, 0])
    return np.where(active, shape, 0.0)


@pytest.fixture(scope="module")
def msl_fmu(tmp_path_factory):
    if not MSL.is_dir():
        pytest.skip(f"no Modelica Standard Library at {MSL}")
    path = write_package(tmp_path_factory.mktemp("msl_sources"), MSL_USER_MODEL)
    return build_fmu(path, "T.Sources", out_dir=path.parent / "fmus", modelica_path=[MSL])


@pytest.mark.slow
@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_msl_pulse_sawtooth_and_trapezoid_follow_their_closed_forms(msl_fmu, fmi_type):
    r = simulate(msl_fmu, fmi_type, ["x", "y", "s", "q"], 1.0)
    t = r["time"]
    y, x = pulse_reference(t)
    edges = np.concatenate([0.1 + 0.3 * np.arange(4), 0.22 + 0.3 * np.arange(3), -0.1 + 0.25 * np.arange(1, 5),
                            0.05 + 0.3 * np.arange(3)])
    ok = away(t, edges)
    np.testing.assert_array_equal(r["y"][ok], y[ok])
    np.testing.assert_allclose(r["x"], x, atol=1e-9)
    np.testing.assert_allclose(r["s"][ok], 3 * np.mod(t[ok] + 0.1, 0.25) / 0.25, atol=1e-12)
    np.testing.assert_allclose(r["q"][ok], trapezoid_reference(t[ok]), atol=1e-12)


def test_mod_by_a_variable_is_refused_by_the_front_end_naming_mod(tmp_path):
    """rumoca 0.10.2 lowers div/mod/rem only with a divisor of parameters and constants; its refusal is a
    ModelicaError naming the file and mod (rumoca gives no line)."""
    path = write_package(tmp_path, """
  model M
    Real x(start = 1);
  equation
    der(x) = -x + mod(time, x + 1);
  end M;""")
    with pytest.raises(ModelicaError, match="unsupported runtime operator `mod`") as err:
        lower(path, "T.M")
    assert err.value.file.endswith("T.mo")
