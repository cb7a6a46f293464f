"""Hybrid models at the lowered level: the EventPart functions driven by a small event-driven integration written
here (scipy solve_ivp with event functions built from ``indicators``, ``next_time`` for time events, ``update``
repeated until the memory settles), against independent references: closed forms, scipy on hand-written
equations with their own event functions, hand-computed samples.

The FMU exporter and the master consume the same functions; this tests the compiler's part alone.
"""

import subprocess
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from cosim.compile import lower

HYBRID = Path(__file__).resolve().parent / "models" / "hybrid" / "Hybrid.mo"
# The crossing is located by scipy's brentq to a few ulps; the step past it is this long (an importer's
# bracket), so an event time is known to about this.
PAST = 1e-12


def hybrid(name):
    return lower(HYBRID, f"Hybrid.{name}")


class Stopped(Exception):
    """update returned a nonzero status: terminate() (1) or failed assertion k (2 + k)."""


def _settle(model, x, u, p, t, m, limit=20):
    """Event iteration: update until the memory stops changing; a failed assert or terminate() raises."""
    ev = model.events
    for _ in range(limit):
        x_new, m_new, status = ev.update(x, u, p, t, m)
        x_new, m_new, status = np.array(x_new).ravel(), np.array(m_new).ravel(), int(status)
        if status:
            message = "terminate()" if status == 1 else ev.messages[status - 2]
            raise Stopped(f"t = {t:.9g}: {message} (status {status})")
        if np.array_equal(m_new, m) and np.array_equal(x_new, x):
            return x_new, m_new
        x, m = x_new, m_new
    raise AssertionError(f"event iteration did not settle at t = {t}")


def integrate(model, t_end, p=None, u=(), max_events=200):
    """Event-driven integration of a lowered hybrid model. Returns (event times, [(t, x, m) after each event
    iteration], the last solve_ivp segment's dense output list [(t0, t1, sol, m)])."""
    ev = model.events
    p = model.parameter_values if p is None else np.asarray(p, dtype=float)
    t = 0.0
    x = model.initial_state(p)
    m = np.array(ev.initial(x, u, p, t)).ravel()
    x, m = _settle(model, x, u, p, t, m)
    events, states, segments = [], [(t, x, m)], []
    while t < t_end and len(events) < max_events:
        t_next = min(float(ev.next_time(t, p, m)), t_end)
        mm = m.copy()
        functions = []
        for k in range(ev.n_indicators):
            def crossing(tt, xx, k=k):
                return float(ev.indicators(xx, u, p, tt, mm)[k])
            crossing.terminal = True
            functions.append(crossing)
        sol = solve_ivp(lambda tt, xx: np.array(model.ode(xx, u, p, tt, mm)).ravel(), (t, t_next), x,
                        events=functions or None, rtol=1e-11, atol=1e-12, dense_output=True)
        assert sol.success, sol.message
        if sol.status == 1:  # a state event: step just past the crossing
            t = float(sol.t[-1]) + PAST
            x = sol.sol(t)
        else:
            t, x = t_next, sol.y[:, -1]
        segments.append((sol.t[0], t, sol.sol, mm))
        if sol.status == 1 or t == t_next < t_end:
            x, m = _settle(model, x, u, p, t, m)
            events.append(t)
            states.append((t, x, m))
    return np.array(events), states, segments


def changes(states, slot):
    """Times at which memory slot ``slot`` changed in an event iteration, and its new values."""
    times = [t for (_, _, m0), (t, _, m1) in zip(states, states[1:]) if m1[slot] != m0[slot]]
    values = [m1[slot] for (_, _, m0), (_, _, m1) in zip(states, states[1:]) if m1[slot] != m0[slot]]
    return np.array(times), values


def value_at(segments, model, group, name, times):
    """Output/observed value ``name`` at ``times`` from the integration's segments (memory of each segment)."""
    function = model.out if group == "outputs" else model.observe
    k = model.index(group, name)
    p = model.parameter_values
    values = []
    for time in times:
        t0, t1, sol, m = next(s for s in segments if s[0] <= time <= s[1])
        values.append(float(function(sol(time), [], p, time, m)[k]))
    return np.array(values)


def test_continuous_model_keeps_four_argument_functions():
    model = lower(Path(__file__).parent / "models" / "compiler" / "CompilerTests.mo", "CompilerTests.MassSpringDamper")
    assert model.events is None
    assert model.ode.n_in() == 4 and model.out.n_in() == 4 and model.observe.n_in() == 4


def test_bouncing_ball_bounce_times_match_the_closed_form():
    model = hybrid("BouncingBall")
    ev = model.events
    assert [(d.name, d.kind, d.causality) for d in ev.discretes] == [("bounces", "integer", "output")]
    assert ev.n_indicators == 1 and model.ode.n_in() == 5
    _, states, _ = integrate(model, 3.6)
    e, g, h0 = 0.8, 9.81, 1.0
    t1 = np.sqrt(2 * h0 / g)
    k = np.arange(1, 11)
    closed = t1 * (1 + 2 * np.array([sum(e**j for j in range(1, n)) for n in k]))  # flight 2 e^j v1 / g
    times, bounces = changes(states, 0)
    assert bounces == list(range(1, 11))
    assert_allclose(times, closed, atol=1e-6)
    v_after = [s[1][1] for s in states if s[0] in times]
    assert_allclose(v_after, g * t1 * e**k, rtol=1e-6)  # reinit(v, -e*pre(v))


def test_thermostat_switching_times_match_scipy_on_hand_written_equations():
    model = hybrid("Thermostat")
    assert {d.name: d.kind for d in model.events.discretes} == {"on": "boolean", "switches": "integer"}
    _, states, _ = integrate(model, 12.0)
    # initial() switches the heater on; then off above 21, on below 19.
    P, k, Ta = 2.0, 0.1, 10.0
    ref, t, T, on = [], 0.0, 20.0, True
    while True:
        def crossing(tt, s, on=on):
            return s[0] - (21.0 if on else 19.0)
        crossing.terminal = True
        sol = solve_ivp(lambda tt, s: [(P if on else 0.0) - k * (s[0] - Ta)], (t, 12.0), [T], events=crossing,
                        rtol=1e-12, atol=1e-12)
        if sol.status != 1:
            break
        t, T, on = sol.t_events[0][0], sol.y_events[0][0][0], not on
        ref.append(t)
    assert len(ref) == 6
    times, on = changes(states, 0)
    assert_allclose(times, ref, atol=1e-6)
    assert states[0][2][0] == 1.0 and on == [0.0, 1.0] * 3  # initial() switched it on
    _, switches = changes(states, 1)
    assert switches == list(range(1, 7))  # every change of `on` after initialisation


def test_sample_and_hold_holds_the_hand_computed_samples():
    model = hybrid("SampleHold")
    assert any(n.startswith("sample(start = 0.1 s, interval = 0.2 s) is fixed at build time") for n in model.notes)
    events, states, segments = integrate(model, 1.0)
    instants = 0.1 + 0.2 * np.arange(5)
    assert_allclose(events, instants, atol=1e-15)  # time events on the exact lattice
    held = [s[2][0] for s in states[1:]]
    assert_allclose(held, np.exp(-instants), rtol=1e-9)
    times = np.array([0.05, 0.15, 0.45, 0.95])
    expected = [0.0, np.exp(-0.1), np.exp(-0.3), np.exp(-0.9)]
    assert_allclose(value_at(segments, model, "outputs", "y", times), expected, rtol=1e-9)


def test_step_counter_integer_output_counts_time_instants():
    model = hybrid("StepCounter")
    events, states, _ = integrate(model, 1.1)
    assert_allclose(events, [0.25, 0.5, 0.75, 1.0], atol=1e-15)
    assert [s[2][1] for s in states] == [0, 1, 2, 3, 4]
    assert [s[2][0] for s in states] == [0.25, 0.5, 0.75, 1.0, 1.25]


@pytest.mark.parametrize("t_on", [0.35, 0.6])
def test_if_on_time_is_a_time_event_that_follows_its_parameter(t_on):
    model = hybrid("TimeSwitch")
    ev = model.events
    assert ev.n_indicators == 0
    p = [t_on]
    m = np.array(ev.initial([0.0], [], p, 0.0)).ravel()
    assert float(ev.next_time(0.0, p, m)) == t_on
    x_new, m_new, _ = ev.update([0.0], [], p, t_on, m)
    assert float(m_new[0]) == 1.0  # time > t_on, limit from the right at t_on
    assert float(ev.next_time(t_on, p, np.array(m_new).ravel())) == np.inf
    events, states, _ = integrate(model, 1.0, p=p)
    assert_allclose(events, [t_on])
    assert_allclose(states[-1][1], [0.0], atol=1e-12)
    _, _, segments = integrate(model, 1.0, p=p)
    t0, t1, sol, _ = segments[-1]
    assert_allclose(sol(t1), [1.0 - t_on], atol=1e-9)  # x = max(0, t - t_on)


def test_if_on_a_state_generates_an_event_and_matches_scipy_with_its_own_event():
    model = hybrid("StateIf")
    events, states, segments = integrate(model, 3.0)

    def crossing(t, s):
        return s[0] - 0.5
    crossing.terminal = True
    first = solve_ivp(lambda t, s: [-s[0]], (0, 3), [1.0], events=crossing, rtol=1e-12, atol=1e-12)
    t_cross = first.t_events[0][0]
    assert_allclose(events, [t_cross], atol=1e-9)  # ln 2
    times = np.linspace(0.1, 2.9, 15)
    expected = np.where(times < t_cross, np.exp(-times), 0.5 * np.exp(-0.5 * (times - t_cross)))
    assert_allclose(value_at(segments, model, "outputs", "x", times), expected, rtol=1e-8)


def test_failed_assert_stops_with_file_line_and_message():
    model = hybrid("Overheat")
    with pytest.raises(Stopped, match=r"Hybrid\.mo:78: temperature above limit") as err:
        integrate(model, 1.0)
    assert "t = 0.5: " in str(err.value) and "(status 2)" in str(err.value)
    assert model.events.messages[0].endswith("Hybrid.mo:78: temperature above limit")


def test_terminate_gives_status_1():
    model = hybrid("Stop")
    ev = model.events
    p = model.parameter_values
    m = np.array(ev.initial([0.0], [], p, 0.0)).ravel()
    _, _, status = ev.update([0.69], [], p, 0.69, m)
    assert int(status) == 0
    _, _, status = ev.update([0.71], [], p, 0.71, m)
    assert int(status) == 1 and ev.messages[-1].endswith("Hybrid.mo:89: done heating")


def test_enumeration_vector_when_on_an_algebraic_variable_edge_and_a_boolean_on_time():
    model = hybrid("Relay")
    kinds = {d.name: (d.kind, d.start) for d in model.events.discretes}
    assert kinds == {"dir": ("enumeration", 1.0), "up": ("boolean", 0.0), "rises": ("integer", 0.0),
                     "late": ("boolean", 0.0)}
    _, states, _ = integrate(model, 3.0)
    # Hand-computed: x = 0.5 + t rises to 0.9 (y = 1.8) at 0.4, falls to 0.1 (y = 0.2) at 1.2, rises to 0.9 at
    # 2.0, falls to 0.1 at 2.8; Up = 1, Down = 2.
    times, dirs = changes(states, 0)
    assert_allclose(times, [0.4, 1.2, 2.0, 2.8], atol=1e-9)
    assert dirs == [2.0, 1.0, 2.0, 1.0]
    times, rises = changes(states, 2)
    assert_allclose(times, [1.2, 2.8], atol=1e-9)
    assert rises == [1.0, 2.0]  # edge(up), not at initialisation
    assert states[0][2][1] == 1.0  # up = (dir == Up) from the start values
    times, late = changes(states, 3)
    assert_allclose(times, [0.9], atol=1e-15)  # a time event, at its exact instant
    assert late == [1.0]


def test_event_on_a_variable_of_a_nonlinear_loop():
    model = hybrid("LoopEvent")
    _, states, _ = integrate(model, 1.0)
    crossing = 0.5 + 0.5 * np.sin(0.5)  # x where z + 0.5 sin z = x gives z = 0.5; x = t
    times, xc = changes(states, 0)
    assert_allclose(times, [crossing], atol=1e-9)
    assert_allclose(xc, [crossing], atol=1e-9)


def test_no_event_and_smooth_give_no_indicator():
    model = hybrid("NoEvents")
    assert model.events is None and model.ode.n_in() == 4
    assert_allclose(model.derivatives([1.0], []), [-1.0])
    assert_allclose(model.derivatives([0.4], []), [-0.2])
    assert_allclose(model.derivatives([3.0], []), [-2.0])  # smooth(0, ...) adds x - 2


def test_elsewhen_reinit_in_each_branch_and_an_if_inside_a_sampled_when():
    model = hybrid("Branches")
    _, states, _ = integrate(model, 1.0)
    # x = 1 - t: the when-branch at t = 0.5 (d = pre(x) = 0.5, v = 3), the elsewhen at 0.8 (d = 2, v = 4);
    # sample(0, 0.3) ticks at 0, 0.3, 0.6, 0.9 (the first in the event iteration after initialisation), x < 0.5
    # at the last two.
    times, d = changes(states, 0)
    assert_allclose(times, [0.5, 0.8], atol=1e-9)
    assert_allclose(d, [0.5, 2.0], atol=1e-9)
    assert [s[1][1] for s in states if s[0] in times] == [3.0, 4.0]
    times, ticks = changes([(-1.0, None, np.zeros(model.events.n_memory))] + states, 1)
    assert_allclose(times, [0.0, 0.3, 0.6, 0.9], atol=1e-15)
    assert ticks == [1, 2, 3, 4]
    times, low = changes(states, 2)
    assert_allclose(times, [0.6, 0.9], atol=1e-15)
    assert low == [1, 2]


@pytest.mark.parametrize("name", ["Branches", "LoopEvent", "Overheat"])
def test_event_functions_generate_c_that_computes_the_same_values(tmp_path, name):
    # The FMU carries these functions as CasADi-generated C: compile them with gcc, load them back with
    # casadi.external, and compare with the functions evaluated in Python at points around the events.
    model = hybrid(name)
    ev = model.events
    functions = [model.ode, model.out, model.observe, ev.indicators, ev.update, ev.initial, ev.next_time]
    generator = ca.CodeGenerator(f"{name}.c")
    for f in functions:
        generator.add(f)
    generator.generate(str(tmp_path) + "/")
    library = tmp_path / f"{name}.so"
    subprocess.run(["gcc", "-O2", "-shared", "-fPIC", str(tmp_path / f"{name}.c"), "-o", str(library), "-lm"],
                   check=True)
    p = model.parameter_values
    rng = np.random.default_rng(1)
    for t in (0.0, 0.3, 0.5, 0.9):
        x = rng.uniform(0.0, 1.0, len(model.states))
        m = np.array(ev.initial(x, [], p, 0.0)).ravel()
        for f in functions:
            args = {"next_time": (t, p, m), "initial": (x, [], p, t)}.get(f.name(), (x, [], p, t, m))
            compiled = ca.external(f.name(), str(library))
            for a, b in zip(_as_list(f(*args)), _as_list(compiled(*args))):
                assert_allclose(np.array(b, dtype=float), np.array(a, dtype=float), rtol=1e-14, atol=1e-14)


def _as_list(result):
    return list(result) if isinstance(result, (tuple, list)) else [result]


def test_when_initial_fires_once_at_initialisation():
    model = hybrid("InitialWhen")
    ev = model.events
    m = np.array(ev.initial([0.0], [], model.parameter_values, 0.0)).ravel()
    assert m[0] == 6.0  # n = pre(n) + 1 with pre(n) = start = 5, once
    _, states, _ = integrate(model, 1.0)
    assert [s[2][0] for s in states] == [6.0]  # not again in the event iteration after initialisation


def test_if_equation_with_a_state_branch_and_a_time_branch():
    model = hybrid("IfEquation")
    events, states, segments = integrate(model, 2.0)
    # Hand-computed: x = exp(-t) down to 0.5 at ln 2 (a state event), then y = 0 holds x = 0.5 until the time
    # event at 0.9 (time < 0.9 is false from 0.9 on), then x = 0.5 exp(-0.5 (t - 0.9)).
    assert_allclose(events[:2], [np.log(2), 0.9], atol=1e-9)
    times = np.array([0.3, 0.8, 1.5, 2.0])
    expected = [np.exp(-0.3), 0.5, 0.5 * np.exp(-0.3), 0.5 * np.exp(-0.55)]
    x = [segments[next(i for i, s in enumerate(segments) if s[0] <= t <= s[1])][2](t)[0] for t in times]
    assert_allclose(x, expected, rtol=1e-8)


def test_initial_equations_of_discrete_variables():
    model = hybrid("InitialValues")
    assert {d.name: d.start for d in model.events.discretes} == {"k": 3.0, "d": 3.0}
    m = np.array(model.events.initial([2.0], [], model.parameter_values, 0.0)).ravel()
    assert list(m[:2]) == [3.0, 4.0]  # d = 2 x at the state given
    _, states, _ = integrate(model, 1.0)
    times, k = changes(states, 0)
    assert_allclose(times, [np.log(1.5)], atol=1e-9)  # x = 1.5 exp(-t) reaches 1
    assert k == [4.0]
    assert_allclose(states[-1][2][1], 1.0, atol=1e-9)  # d = x at the event


def test_boolean_and_integer_inputs_keep_their_kind_and_a_when_fires_on_the_input():
    model = hybrid("Inputs")
    assert [(u.name, u.kind) for u in model.inputs] == [("b", "boolean"), ("k", "integer")]
    ev = model.events
    m = np.array(ev.initial([0.0], [0.0, 2.0], [], 0.0)).ravel()
    assert_allclose(np.array(model.ode([0.0], [0.0, 2.0], [], 0.0, m)).ravel(), [2.0])
    counts = []
    for b in (1.0, 1.0, 0.0, 1.0):  # the importer sets the input and runs the event iteration at each change
        for _ in range(3):
            m = np.array(ev.update([0.0], [b, 2.0], [], 0.0, m)[1]).ravel()
        counts.append(m[0])
    assert counts == [1.0, 1.0, 1.0, 2.0]


def test_numeric_helpers_of_a_hybrid_model_hold_the_relation_at_its_initial_value():
    """der(x) = -x above 0.5 and -0.5 x below: the numeric helpers evaluate the relation at the given state
    (the memory at initialisation) unless a memory is passed; the linearisation holds it."""
    model = lower(HYBRID, "Hybrid.StateIf")
    assert_allclose(model.derivatives([1.0], []), [-1.0])
    assert_allclose(model.derivatives([0.2], []), [-0.1])
    above = model.events.initial([1.0], [], model.parameter_values, 0.0)
    assert_allclose(model.derivatives([0.2], [], m=above), [-0.2])


def test_terminal_passes_fire_each_terminal_when_clause_once():
    model = hybrid("Terminal")
    ev = model.events
    p = model.parameter_values
    m = np.array(ev.initial([1.0], [], p, 0.0)).ravel()
    x, m = _settle(model, np.array([1.0]), [], p, 0.0, m)
    x_half = np.exp(-0.5)  # closed form of der(x) = -x at t = 0.5
    x_pass, m_pass = _settle(model, np.array([x_half]), [], p, 0.5, m)
    assert np.array_equal(m_pass, m)  # terminal() is false in ordinary event passes
    for _ in range(3):  # passes with terminal() true, repeated as an importer does until m settles
        x_end, m_end, status = ev.terminal([x_half], [], p, 0.5, m)
        m = np.array(m_end).ravel()
        assert int(status) == 0
    assert m[0] == x_half and m[1] == 1.0  # x_end = x and n_end = pre(n_end) + 1, once
    assert float(model.out([x_half], [], p, 0.5, m)[0]) == 2 * x_half  # y = 2 x_end


def test_a_model_without_terminal_has_no_terminal_pass():
    assert hybrid("Stop").events.terminal is None
