"""The FMU exporter (cosim/compile/export.py and its C wrapper): continuous FMUs against closed forms with fmpy's
CVode and Euler, the defects of the former DaeBuilder export (event indicators, stale outputs), and hybrid FMUs
built from hand-written EventParts (bouncing ball, time events, terminate, assert) against closed forms."""

import tempfile
import warnings
from pathlib import Path

import casadi as ca
import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Model, fmi3Float64
from fmpy.validation import validate_fmu
from scipy.integrate import solve_ivp

from cosim.compile import build_fmu
from cosim.compile.export import export_fmu
from cosim.compile.model import DiscreteVariable, EventPart, LoweredModel, ModelVariable
from cosim.errors import ModelicaError
from fmus.reference import bounce_times
from modelica_support import fmu_builder, simulate, write_package

MODELS = Path(__file__).resolve().parent / "models" / "export" / "ExportTests.mo"
G = 9.81


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("export_fmus")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {name: build_fmu(MODELS, f"ExportTests.{name}", out_dir=out)
                for name in ("Linear", "Stateless", "Annotated")}


def _simulate(fmu, solver, stop_time, step=1e-4, **kwargs):
    """fmpy's own simulation of the Model Exchange interface (fmpy prefers Co-Simulation when an FMU has both);
    Euler takes one step per output interval, so the interval is the step."""
    if solver == "Euler":
        kwargs.update(step_size=step, output_interval=step)
    else:
        kwargs.update(relative_tolerance=1e-10, output_interval=0.01)
    return fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", stop_time=stop_time, solver=solver, **kwargs)


def _open(fmu, log=None):
    """An FMU3Model instantiated, initialised and in continuous-time mode (events iterated as fmpy does)."""
    md = fmpy.read_model_description(str(fmu))
    unzipped = fmpy.extract(str(fmu), unzipdir=tempfile.mkdtemp(dir=Path(fmu).parent))  # removed with tmp_path
    model = FMU3Model(guid=md.guid, unzipDirectory=unzipped,
                      modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName="test")
    model.instantiate(logMessage=log)
    model.enterInitializationMode(startTime=0.0)
    model.exitInitializationMode()
    while model.updateDiscreteStates()[0]:
        pass
    model.enterContinuousTimeMode()
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    return md, model, vrs


# ---- continuous models ----------------------------------------------------------------------------------------

def test_linear_fmu_is_valid_and_matches_the_closed_form_with_cvode(fmus):
    assert validate_fmu(str(fmus["Linear"])) == []
    r = _simulate(fmus["Linear"], "CVode", 2.0, output=["y"])
    t = r["time"]
    assert np.max(np.abs(r["y"] - (np.exp(-2 * t) + np.sin(3 * t) / 3))) < 1e-7


def test_linear_fmu_with_euler_converges_to_the_closed_form_at_first_order(fmus):
    errors = []
    for step in (1e-3, 1e-4):
        r = _simulate(fmus["Linear"], "Euler", 2.0, step=step, output=["y"])
        t = r["time"]
        errors.append(np.max(np.abs(r["y"] - (np.exp(-2 * t) + np.sin(3 * t) / 3))))
    assert errors[1] < 5e-4
    assert 8 < errors[0] / errors[1] < 12  # first order: ten times smaller steps, ten times smaller error


def test_tunable_parameter_changes_the_solution(fmus):
    r = _simulate(fmus["Linear"], "CVode", 1.0, output=["x1"], start_values={"a": 0.5})
    assert np.max(np.abs(r["x1"] - np.exp(-0.5 * r["time"]))) < 1e-7


def test_states_not_set_start_from_x0_of_the_actual_parameters(fmus):
    r = _simulate(fmus["Linear"], "CVode", 1.0, output=["x1"], start_values={"x10": 2.0})
    assert np.max(np.abs(r["x1"] - 2.0 * np.exp(-2.0 * r["time"]))) < 1e-7
    r = _simulate(fmus["Linear"], "CVode", 1.0, output=["x1"], start_values={"x10": 2.0, "x1": 3.0})
    assert np.max(np.abs(r["x1"] - 3.0 * np.exp(-2.0 * r["time"]))) < 1e-7  # a state set by the importer wins


def test_model_description_has_units_states_and_structure(fmus):
    md = fmpy.read_model_description(str(fmus["Linear"]))
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["x1"].initial == "exact" and float(by_name["x1"].start) == 1.0
    assert by_name["v"].description == "Oscillator velocity"
    assert by_name["a"].causality == "parameter" and by_name["a"].variability == "tunable"
    assert [v.variable.name for v in md.outputs] == ["y"]
    deps = {d.variable.name: sorted(x.name for x in d.dependencies) for d in md.derivatives}
    assert deps == {"der(x1)": ["x1"], "der(q)": ["v"], "der(v)": ["q"]}
    assert sorted(x.name for x in md.outputs[0].dependencies) == ["q", "x1"]


def test_get_event_indicators_is_ok_without_indicators(fmus):
    _, model, _ = _open(fmus["Linear"])
    assert model.getEventIndicators(None, 0) == 0  # fmi3OK
    model.terminate()
    model.freeInstance()


def test_stateless_fmu_outputs_follow_set_time_and_inputs(fmus):
    assert validate_fmu(str(fmus["Stateless"])) == []
    _, model, vr = _open(fmus["Stateless"])
    assert model.getFloat64([vr["y"]]) == [0.0]
    model.setTime(0.5)
    assert model.getFloat64([vr["y"]]) == [1.5]
    model.setFloat64([vr["u"]], [2.0])
    assert model.getFloat64([vr["y"]]) == [5.5]
    model.setTime(1.0)
    assert model.getFloat64([vr["y"]]) == [7.0]
    model.terminate()
    model.freeInstance()


def test_outputs_and_derivatives_follow_set_continuous_states(fmus):
    _, model, vr = _open(fmus["Linear"])
    assert model.getFloat64([vr["y"]]) == [1.0]
    model.setContinuousStates((fmi3Float64 * 3)(2.0, 0.5, 0.25), 3)  # x1, q, v in declaration order
    assert model.getFloat64([vr["y"]]) == [2.5]
    xdot = (fmi3Float64 * 3)()
    model.getContinuousStateDerivatives(xdot, 3)
    assert list(xdot) == [-4.0, 0.25, -4.5]  # -a x1, v, -w^2 q
    model.terminate()
    model.freeInstance()


def test_stateless_fmu_simulates_with_euler(fmus):
    r = _simulate(fmus["Stateless"], "Euler", 1.0, step=0.01, output=["y"])
    assert np.allclose(r["y"], 3 * r["time"], atol=1e-12)


@pytest.mark.parametrize("fmi_version", [3, 2])
def test_experiment_annotation_is_the_default_experiment(fmus, tmp_path, fmi_version):
    fmu = fmus["Annotated"] if fmi_version == 3 else build_fmu(MODELS, "ExportTests.Annotated", out_dir=tmp_path,
                                                               fmi_version=2)
    experiment = fmpy.read_model_description(str(fmu)).defaultExperiment
    # The annotation's numbers, not the comment's (99) nor the documentation string's (7).
    given = (experiment.startTime, experiment.stopTime, experiment.stepSize, experiment.tolerance)
    assert tuple(float(v) for v in given) == (0.5, 2.5, 0.25, 1e-7)
    assert fmpy.read_model_description(str(fmus["Linear"])).defaultExperiment is None  # no annotation, none
    # fmpy, asked for no span nor tolerance, runs the FMU's: 0.5 to 2.5 s at 1e-7 (it takes stepSize as the
    # output interval of Co-Simulation only, and only without a fixedInternalStepSize).
    r = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange")
    assert (r["time"][0], r["time"][-1]) == (0.5, 2.5)
    assert np.allclose(r["x"], np.exp(-(r["time"] - 0.5)), rtol=1e-5, atol=0)


# ---- hybrid models from hand-written EventParts ---------------------------------------------------------------

def _lowered(name, states, x0, xdot, outputs, y, parameters, p, x, t, m, events):
    """A LoweredModel of ODE ``xdot(x, p, t, m)`` without inputs, as the compiler would produce it."""
    u = ca.SX.sym("u", 0)
    args = [x, u, p, t, m]
    return LoweredModel(
        name=name, states=tuple(states), inputs=(), outputs=tuple(outputs), parameters=tuple(parameters),
        ode=ca.Function("ode", args, [xdot]), out=ca.Function("out", args, [y]),
        observe=ca.Function("observe", args, [ca.SX(0, 1)]), observed=(), x0=ca.Function("x0", [p], [x0]),
        events=events(x, u, p, t, m))


def _bouncing_ball(e=0.8, h0=1.0):
    """x = [h, v]; m = [n (Integer bounce count), r (held relation h < 0)]; indicator h; at an event where r
    rises, reinit(v, -e v) and n + 1."""
    x, p, t, m = ca.SX.sym("x", 2), ca.SX.sym("p", 1), ca.SX.sym("t"), ca.SX.sym("m", 2)
    h, v = x[0], x[1]

    def events(x, u, p, t, m):
        rises = ca.if_else(h < 0, 1, 0) * (1 - m[1])
        update = ca.Function("update", [x, u, p, t, m],
                             [ca.vertcat(h, ca.if_else(rises, -p[0] * v, v)),
                              ca.vertcat(m[0] + rises, ca.if_else(h < 0, 1, 0)), ca.SX(0)])
        return EventPart(
            discretes=(DiscreteVariable("n", "integer", description="bounces", causality="output"),),
            n_memory=2, n_indicators=1,
            indicators=ca.Function("indicators", [x, u, p, t, m], [h]), update=update,
            initial=ca.Function("initial", [x, u, p, t], [ca.vertcat(0, ca.if_else(h < 0, 1, 0))]),
            next_time=ca.Function("next_time", [t, p, m], [ca.inf]))

    return _lowered("Ball", [ModelVariable("h", "m", "height", h0), ModelVariable("v", "m/s", "velocity", 0.0)],
                    ca.DM([h0, 0.0]), ca.vertcat(v, -G), [ModelVariable("h", "m", "height", h0)], h,
                    [ModelVariable("e", "1", "restitution", e)], p, x, t, m, events)


def _event_times(result, name):
    """The time of the first recorded row at each new value of counter ``name``."""
    n = result[name]
    return np.array([result["time"][np.argmax(n >= k)] for k in range(1, int(n[-1]) + 1)])


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    return export_fmu(_bouncing_ball(), tmp_path_factory.mktemp("ball") / "Ball.fmu")


def test_bouncing_ball_fmu_is_valid_and_declares_its_indicator(ball):
    assert validate_fmu(str(ball)) == []
    md = fmpy.read_model_description(str(ball))
    assert md.numberOfEventIndicators == 1
    n = next(v for v in md.modelVariables if v.name == "n")
    assert (n.type, n.variability, n.causality) == ("Int64", "discrete", "output")


def test_bouncing_ball_bounce_times_with_cvode(ball):
    r = _simulate(ball, "CVode", 3.0, output=["h", "n"])
    expected = bounce_times(e=0.8, v_min=0.0, stop=3.0)
    assert r["n"].dtype.kind == "i" and r["n"][-1] == len(expected)
    assert np.max(np.abs(_event_times(r, "n") - expected)) < 1e-6
    assert r["h"].min() > -1e-6


def test_bouncing_ball_bounce_times_with_euler_converge_at_first_order(ball):
    errors = []
    for step in (1e-3, 1e-4):
        r = _simulate(ball, "Euler", 3.0, step=step, output=["h", "n"])
        expected = bounce_times(e=0.8, v_min=0.0, stop=3.0)
        assert r["n"][-1] == len(expected)
        errors.append(np.max(np.abs(_event_times(r, "n") - expected)))
    # Euler finds an event at the end of the step that crosses it, and its height lags by about g t dt / 2:
    # measured 22 dt over 3 s
    assert errors[1] < 30 * 1e-4
    assert 7 < errors[0] / errors[1] < 13


def test_integer_variable_has_its_fmi_type(ball):
    messages = []
    _, model, vr = _open(ball, log=lambda env, status, category, message: messages.append(message.decode()))
    assert model.getInt64([vr["n"]]) == [0]
    with pytest.raises(FMICallException):
        model.getFloat64([vr["n"]])
    assert "is a Int64 variable, not Float64" in messages[-1]
    with pytest.raises(FMICallException):
        model.setInt64([vr["n"]], [5])  # a discrete variable is computed by the model, not set
    assert "cannot be set now" in messages[-1]
    with pytest.raises(FMICallException):
        model.getInt32([vr["n"]])
    assert "no variable of this type" in messages[-1]
    model.setContinuousStates((fmi3Float64 * 2)(-1e-3, -4.0), 2)  # just below the floor, falling
    z = (fmi3Float64 * 1)()
    model.getEventIndicators(z, 1)
    assert z[0] == -1e-3
    model.enterEventMode()
    need_update, terminate, _, states_changed, time_defined, _ = model.updateDiscreteStates()
    assert (need_update, terminate, states_changed, time_defined) == (True, False, True, False)
    assert model.getInt64([vr["n"]]) == [1] and model.getFloat64([vr["v"]]) == [pytest.approx(3.2)]
    need_update, _, _, states_changed, _, _ = model.updateDiscreteStates()
    assert (need_update, states_changed) == (False, False)
    model.terminate()
    model.freeInstance()


def _clock(status_when=None, first=0.3, period=0.4):
    """der(s) = k, where Integer k counts time events at first + j period (next_time); Boolean odd = k odd.
    ``status_when``: (k, status) makes update return that status once k reaches it."""
    x, p, t, m = ca.SX.sym("x", 1), ca.SX.sym("p", 2), ca.SX.sym("t"), ca.SX.sym("m", 3)

    def events(x, u, p, t, m):
        fire = ca.if_else(t >= m[2], 1, 0)
        k = m[0] + fire
        status = ca.SX(0) if status_when is None else ca.if_else(k >= status_when[0], status_when[1], 0)
        return EventPart(
            discretes=(DiscreteVariable("k", "integer", causality="output"),
                       DiscreteVariable("odd", "boolean", causality="output")),
            n_memory=3, n_indicators=0, indicators=ca.Function("indicators", [x, u, p, t, m], [ca.SX(0, 1)]),
            update=ca.Function("update", [x, u, p, t, m], [x, ca.vertcat(k, ca.fmod(k, 2), m[2] + fire * p[1]),
                                                             status]),
            initial=ca.Function("initial", [x, u, p, t], [ca.vertcat(0, 0, p[0])]),
            next_time=ca.Function("next_time", [t, p, m], [m[2]]),
            messages=("Clock.mo:7: k must stay below 2", "Clock.mo:9: two ticks are enough"))

    return _lowered("Clock", [ModelVariable("s")], ca.DM([0.0]), m[0], [ModelVariable("s")], x[0],
                    [ModelVariable("first", "s", start=first), ModelVariable("period", "s", start=period)],
                    p, x, t, m, events)


def test_time_events_with_cvode_and_euler(tmp_path):
    fmu = export_fmu(_clock(), tmp_path / "Clock.fmu")
    assert validate_fmu(str(fmu)) == []
    for solver in ("CVode", "Euler"):
        r = _simulate(fmu, solver, 1.0, step=1e-3, output=["s", "k", "odd"])
        # s = 0 until 0.3, slope 1 until 0.7, slope 2 after: s(1) = 0.4 + 0.6
        assert r["s"][-1] == pytest.approx(1.0, abs=1e-9)
        assert list(r["time"][np.flatnonzero(np.diff(r["k"])) + 1]) == pytest.approx([0.3, 0.7], abs=1e-12)
        at = np.searchsorted(r["time"], 0.5)
        assert (r["k"][at], bool(r["odd"][at]), r["k"][-1], bool(r["odd"][-1])) == (1, True, 2, False)
        assert r["odd"].dtype == bool


def _events_at(model, times):
    """Enter event mode at each time and return the flags of one fmi3UpdateDiscreteStates pass at the last."""
    for t in times:
        model.setTime(t)
        model.enterEventMode()
        flags = model.updateDiscreteStates()
    return flags


def test_terminate_stops_the_simulation_and_logs_its_message(tmp_path):
    fmu = export_fmu(_clock(status_when=(2, 1)), tmp_path / "Clock.fmu")
    r = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", stop_time=2.0, relative_tolerance=1e-10, output=["k"])
    assert r["time"][-1] == pytest.approx(0.7, abs=1e-12)  # fmpy stops at the event, before recording after it
    messages = []
    _, model, vr = _open(fmu, log=lambda env, status, category, message: messages.append(message.decode()))
    assert _events_at(model, [0.3])[1] is False
    assert _events_at(model, [0.7])[1] is True
    assert model.getInt64([vr["k"]]) == [2]
    assert messages[-1] == "t = 0.69999999999999996: the model called terminate(): Clock.mo:9: two ticks are enough"
    model.freeInstance()


def test_failed_assert_is_an_error_with_its_message(tmp_path):
    fmu = export_fmu(_clock(status_when=(2, 2)), tmp_path / "Clock.fmu")
    messages = []
    _, model, _ = _open(fmu, log=lambda env, status, category, message: messages.append((status, message.decode())))
    _events_at(model, [0.3])
    with pytest.raises(FMICallException, match="fmi3UpdateDiscreteStates"):
        _events_at(model, [0.7])
    fmi3_error = 3
    assert messages[-1] == (fmi3_error, "t = 0.69999999999999996: assertion failed: Clock.mo:7: k must stay below 2")
    model.freeInstance()


# ---- hybrid models end to end: Modelica (tests/models/hybrid, the compiler's) -> FMU -> fmpy --------------------

@pytest.mark.parametrize("solver, tolerance", [("CVode", 1e-6), ("Euler", 30 * 1e-4)])  # Euler: see above
def test_modelica_bouncing_ball_fmu_bounces_at_the_closed_form_times(hybrid_fmu, solver, tolerance):
    assert validate_fmu(str(hybrid_fmu("BouncingBall"))) == []
    r = _simulate(hybrid_fmu("BouncingBall"), solver, 3.0, step=1e-4, output=["bounces"])
    expected = bounce_times(e=0.8, v_min=0.0, stop=3.0)
    assert r["bounces"].dtype.kind == "i" and r["bounces"][-1] == len(expected)
    assert np.max(np.abs(_event_times(r, "bounces") - expected)) < tolerance


@pytest.mark.parametrize("solver", ["CVode", "Euler"])
def test_modelica_step_counter_fmu_counts_its_time_events(hybrid_fmu, solver):
    r = _simulate(hybrid_fmu("StepCounter"), solver, 1.1, step=1e-3, output=["steps"])
    assert r["steps"][-1] == 4
    assert _event_times(r, "steps") == pytest.approx([0.25, 0.5, 0.75, 1.0], abs=1e-12)


@pytest.mark.parametrize("solver", ["CVode", "Euler"])
def test_modelica_terminate_stops_the_fmu_at_its_event(hybrid_fmu, solver):
    r = _simulate(hybrid_fmu("Stop"), solver, 2.0, step=1e-4, output=["T"])
    # CVode locates T = 0.7 to its root tolerance; Euler finds it at the end of the step that crosses it
    assert r["time"][-1] == pytest.approx(0.7, abs=1e-9 if solver == "CVode" else 1e-4)


def test_terminal_when_clauses_fire_once_at_fmi3_terminate(hybrid_fmu):
    md, model, vrs = _open(hybrid_fmu("Terminal"))
    model.setTime(2.0)
    model.setContinuousStates((fmi3Float64 * 1)(0.25), 1)  # an importer's x at the end, set by hand
    names = ["x_end", "y"]
    assert list(model.getFloat64([vrs[n] for n in names])) == [0.0, 0.0]  # terminal() false until the end
    model.terminate()
    # after fmi3Terminate: x_end = x, y = 2 x_end, and the counter raised once (FMI 3 lets the final values be read)
    assert list(model.getFloat64([vrs[n] for n in names])) == [0.25, 0.5]
    assert list(model.getInt64([vrs["n_end"]])) == [1]
    model.freeInstance()


@pytest.mark.parametrize("solver, tolerance", [("CVode", 1e-6), ("Euler", 5e-4)])
def test_modelica_relay_fmu_exposes_enumeration_and_booleans_with_their_types(hybrid_fmu, solver, tolerance):
    md = fmpy.read_model_description(str(hybrid_fmu("Relay")))
    types = {v.name: v.type for v in md.modelVariables if v.variability == "discrete"}
    assert types == {"dir": "Int64", "up": "Boolean", "rises": "Int64", "late": "Boolean"}
    r = _simulate(hybrid_fmu("Relay"), solver, 3.0, step=1e-4, output=["dir", "up", "rises", "late"])
    # Hand-computed (as in test_compiler_events): x = 0.5 + t reaches 0.9 at 0.4, 0.1 at 1.2, 0.9 at 2.0, 0.1 at
    # 2.8; dir is the enumeration's ordinal (Up = 1, Down = 2). Euler: each event up to one step late, adding up.
    changes = {name: np.flatnonzero(np.diff(r[name].astype(float))) + 1 for name in ("dir", "rises", "late")}
    assert r["time"][changes["dir"]] == pytest.approx([0.4, 1.2, 2.0, 2.8], abs=tolerance)
    assert list(r["dir"][changes["dir"]]) == [2, 1, 2, 1] and r["dir"].dtype.kind == "i"
    assert list(r["up"][changes["dir"]]) == [False, True, False, True] and r["up"].dtype == bool
    assert r["time"][changes["rises"]] == pytest.approx([1.2, 2.8], abs=tolerance)
    assert r["time"][changes["late"]] == pytest.approx([0.9], abs=1e-12)  # a time event at its instant


def _thermostat_switch_times(stop=12.0, P=2.0, k=0.1, Ta=10.0, low=19.0, high=21.0):
    """scipy on the hand-written equations: heater on from the start (initial()), off above 21, on below 19."""
    times, t, T, on = [], 0.0, 20.0, True
    while True:
        def crossing(tt, s, on=on):
            return s[0] - (high if on else low)
        crossing.terminal = True
        sol = solve_ivp(lambda tt, s: [(P if on else 0.0) - k * (s[0] - Ta)], (t, stop), [T], events=crossing,
                        rtol=1e-12, atol=1e-12)
        if sol.status != 1:
            return np.array(times)
        t, T, on = sol.t_events[0][0], sol.y_events[0][0][0], not on
        times.append(t)


@pytest.mark.parametrize("solver, tolerance", [("CVode", 1e-6), ("Euler", 3 * 1e-3)])  # Euler: 3 steps (1.9 measured)
def test_modelica_thermostat_fmu_switches_where_scipy_does(hybrid_fmu, solver, tolerance):
    """CVode locates each crossing of T = 21 exactly at 0; the FMU reports an indicator at exactly 0 on its former
    side, so the event comes where the relation T > Thi has flipped (else the heater never switched off)."""
    r = _simulate(hybrid_fmu("Thermostat"), solver, 12.0, step=1e-3, output=["switches"])
    expected = _thermostat_switch_times()
    assert len(expected) == 6 and r["switches"][-1] == 6
    assert np.max(np.abs(_event_times(r, "switches") - expected)) < tolerance


_FUNCTION_ASSERT = """
  function rate
    input Real f;
    output Real r;
  algorithm
    assert(f > 0, "Cut-off frequency f must be positive");
    r := 2*f;
  end rate;
  model M
    parameter Real f = 1.5;
    Real x(start = 1, fixed = true);
  equation
    der(x) = -rate(f)*x;
  end M;"""


def test_an_assert_inside_a_function_is_checked_with_the_call_sites_values(tmp_path):
    """The MSL's filter functions check their arguments (assert(f_cut > 0, ...)): the FMU runs for f = 1.5
    (x = exp(-2 f t)) and stops at initialisation with the assert's file, line and message for f = -1."""
    fmu = build_fmu(write_package(tmp_path, _FUNCTION_ASSERT), "T.M", out_dir=tmp_path / "out")
    r = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output=["x"], fmi_type="ModelExchange", relative_tolerance=1e-8)
    assert r["x"][-1] == pytest.approx(np.exp(-3.0), rel=1e-6)
    messages = []
    with pytest.raises(FMICallException, match="fmi3UpdateDiscreteStates"):
        fmpy.simulate_fmu(str(fmu), stop_time=1.0, start_values={"f": -1.0}, fmi_type="ModelExchange",
                          logger=lambda env, status, category, message: messages.append(message.decode()))
    assert messages[-1].endswith("T.mo:6: Cut-off frequency f must be positive")


def test_an_assert_inside_a_function_that_always_fails_refuses_the_build(tmp_path):
    body = _FUNCTION_ASSERT.replace("assert(f > 0", "assert(1 < 0")
    with pytest.raises(ModelicaError, match="fails whatever the values: Cut-off") as err:
        build_fmu(write_package(tmp_path, body), "T.M", out_dir=tmp_path / "out")
    assert err.value.line == 6


_BRANCHES = """
  function root
    input Real u;
    output Real r;
  algorithm
    assert(u >= 0, "root needs u >= 0");
    r := sqrt(u);
  end root;
  model Rise
    parameter Real b = 0;
    Real s(start = -1, fixed = true);
    Real y = if s >= 0 then root(s - b) else 0;
    Real z(start = 0, fixed = true);
  equation
    der(s) = 1;
    der(z) = y;
  end Rise;
  model Sampled
    Real x = cos(time);
    discrete Real d(start = 1, fixed = true);
  equation
    when sample(0, 0.1) then
      d = root(x);
    end when;
  end Sampled;"""


@pytest.fixture(scope="module")
def branch_fmu(tmp_path_factory):
    return fmu_builder(write_package(tmp_path_factory.mktemp("branches"), _BRANCHES))


def test_an_assert_in_a_function_called_in_an_untaken_branch_does_not_fire(branch_fmu):
    """s = t - 1: root(s) is called only once s >= 0, so its assert(u >= 0) holds; before, it fired at t = 0.
    The untaken branch's NaN reaches neither y, nor z = 2/3 (t - 1)^1.5, nor the Jacobian at t = 0."""
    r = simulate(branch_fmu("Rise"), "ModelExchange", ["y", "z"], 2.0)
    t = r["time"]
    assert np.max(np.abs(r["y"] - np.sqrt(np.maximum(t - 1, 0)))) < 1e-7
    assert np.max(np.abs(r["z"] - 2 / 3 * np.maximum(t - 1, 0) ** 1.5)) < 1e-7
    _, model, vr = _open(branch_fmu("Rise"))
    assert model.getDirectionalDerivative([vr["der(z)"]], [vr["s"]], [1.0]) == [0.0]
    model.terminate()
    model.freeInstance()


def test_an_assert_in_a_function_called_in_a_taken_branch_fires_with_its_message(branch_fmu):
    """root(s - 0.5) fails as soon as its branch is taken, at s = 0 (t = 1)."""
    messages = []
    with pytest.raises(FMICallException, match="fmi3UpdateDiscreteStates"):
        simulate(branch_fmu("Rise"), "ModelExchange", ["y"], 2.0, start_values={"b": 0.5},
                 logger=lambda env, status, category, message: messages.append(message.decode()))
    assert messages[-1].startswith("t = 1") and messages[-1].endswith("T.mo:6: root needs u >= 0")


def test_an_assert_in_a_function_called_in_a_when_clause_fires_when_the_clause_does(branch_fmu):
    """d = root(cos t) at the samples of 0.1: cos t < 0 from pi/2, so the first failing sample is t = 1.6 (not the
    crossing at pi/2). Before, an assert in a when-clause's function was left out."""
    messages = []
    with pytest.raises(FMICallException, match="fmi3UpdateDiscreteStates"):
        simulate(branch_fmu("Sampled"), "ModelExchange", ["d"], 2.0,
                 logger=lambda env, status, category, message: messages.append(message.decode()))
    assert messages[-1].startswith("t = 1.6") and messages[-1].endswith("T.mo:6: root needs u >= 0")


_SMALL_OSCILLATOR = """
  model Small
    Real x(start = 1e-6, fixed = true, nominal = 1e-6);
    Real v(start = 0, fixed = true, nominal = 1e-6);
  equation
    der(x) = v;
    der(v) = -100*x;
  end Small;"""


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_a_states_nominal_scales_the_importers_absolute_tolerance(tmp_path, fmi_version):
    """x = 1e-6 cos(10 t): with the nominals 1e-6 in the model description and from GetNominalsOfContinuousStates,
    fmpy's CVode (absolute tolerance rtol * nominal) follows it to 3.2e-4 of its amplitude; with nominal 1 (before)
    the error was 12.6 times the amplitude (ElasticBearing's w_rel, nominal 1e-4, was off by 0.77 % of its range)."""
    fmu = build_fmu(write_package(tmp_path, _SMALL_OSCILLATOR), "T.Small", out_dir=tmp_path / "out",
                    fmi_version=fmi_version)
    nominals = {v.name: v.nominal for v in fmpy.read_model_description(str(fmu)).modelVariables}
    assert float(nominals["x"]) == 1e-6 and float(nominals["v"]) == 1e-6
    r = fmpy.simulate_fmu(str(fmu), stop_time=10.0, fmi_type="ModelExchange", relative_tolerance=1e-6,
                          output_interval=0.01, output=["x"])
    assert np.max(np.abs(r["x"] - 1e-6 * np.cos(10 * r["time"]))) < 1e-3 * 1e-6
