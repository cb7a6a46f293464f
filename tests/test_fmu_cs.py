"""The FMU's Co-Simulation interface and the services masters use to roll back and linearise
(cosim/compile/fmu_c/fmi3_cs.c over the model core's model_do_step, model_directional, model_state_*):
fmpy validates and runs every shipped FMU through both interfaces; the embedded solvers against closed forms
(their order of convergence included), events inside ``fmi3DoStep`` against the bouncing ball's closed form,
directional derivatives against central finite differences, FMU state restored bitwise."""

import tempfile
import warnings
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3Float64
from fmpy.validation import validate_fmu

from cosim.compile import build_fmu
from cosim.compile.build import build_all, read_model_list
from fmus.reference import ball_state, bounce_times

ROOT = Path(__file__).resolve().parent.parent
MODELS_TOML = ROOT / "modelica" / "models.toml"
EXPORT_MODELS = ROOT / "tests" / "models" / "export" / "ExportTests.mo"

# A constant input for each shipped model that moves it (the defaults are all zero: nothing would move)
INPUTS = {"GripperPlant": {"v_q": 1.0}, "PMSM": {"v_q": 1.0, "tau_load": 0.002},
          "Drivetrain": {"theta_m": 0.5, "w_m": 20.0}, "HapticDevice11": {"tau": 0.05}, "HapticDevice7": {"tau": 0.05},
          "HapticDeviceArm": {"tau": 0.05}, "HapticArm": {"F": 1.0}}


@pytest.fixture(scope="module")
def shipped(tmp_path_factory):
    """Every model of modelica/models.toml built as `cosim build` does (its cs_step): name -> FMU path."""
    out = tmp_path_factory.mktemp("shipped_fmus")
    list(build_all(MODELS_TOML, out_dir=out))
    return {entry["name"]: out / f"{entry['name']}.fmu" for entry in read_model_list(MODELS_TOML)}


@pytest.fixture(scope="module")
def linear(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return build_fmu(EXPORT_MODELS, "ExportTests.Linear", out_dir=tmp_path_factory.mktemp("linear"))


def _linear_y(t):
    """ExportTests.Linear: y = exp(-a t) + sin(w t) / w at a = 2, w = 3."""
    return np.exp(-2 * t) + np.sin(3 * t) / 3


def _cs(fmu, stop, interval, output=None, **start):
    """fmpy's Co-Simulation run: one doStep per output interval."""
    return fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=stop, output_interval=interval,
                             output=output, start_values=start)


def _open(fmu, cls, log=None, **start):
    """An instance of ``cls`` (FMU3Slave or FMU3Model) with start values set, initialised; and its value
    references by name. A Co-Simulation instance is then in Step Mode (events iterated inside)."""
    md = fmpy.read_model_description(str(fmu))
    # a directory of its own: overwriting a loaded library crashes the process
    unzipped = fmpy.extract(str(fmu), unzipdir=tempfile.mkdtemp(dir=Path(fmu).parent))
    instance = cls(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.modelExchange.modelIdentifier,
                   instanceName="test")
    instance.instantiate(logMessage=log)
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    for name, value in start.items():
        (instance.setInt64 if name == "_cs_method" else instance.setFloat64)([vrs[name]], [value])
    instance.enterInitializationMode(startTime=0.0)
    instance.exitInitializationMode()
    return md, instance, vrs


# ---- every shipped FMU, both interfaces ------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(INPUTS))
def test_shipped_fmu_is_valid_and_runs_as_me_with_cvode_and_euler_and_as_cs(shipped, name):
    fmu, inputs = shipped[name], INPUTS[name]
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    step = next(e.get("cs_step") for e in read_model_list(MODELS_TOML) if e["name"] == name)
    assert float(md.coSimulation.fixedInternalStepSize) == step
    ref = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-10,
                            stop_time=0.02, output_interval=1e-3, start_values=inputs)
    names = [n for n in ref.dtype.names[1:] if np.ptp(ref[n]) > 0]
    assert names  # the input moves the model

    def worst(result, rows=slice(None)):
        return max(np.max(np.abs(result[n] - ref[rows][n])) / np.ptp(ref[n]) for n in names)

    # Euler: one step per output interval; 1 us is stable for the stiffest (the gear mesh), first order
    euler = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="Euler", stop_time=2e-3,
                              output_interval=1e-6, start_values=inputs)
    assert worst(euler[::1000], slice(0, 3)) < 1e-2
    # RK4 at 1 us converges to CVode (the drivetrain's play and friction kinks limit its order: 3.5e-4
    # measured); at the model's default step every run stays within 10 % of the output range (9 % measured on
    # the Drivetrain, driven here by an angle and a speed that do not match, its worst case)
    assert worst(_cs(fmu, 0.02, 1e-3, _cs_step=1e-6, **inputs)) < 1e-3
    assert worst(_cs(fmu, 0.02, 1e-3, **inputs)) < 0.1


# ---- embedded solvers against closed forms ------------------------------------------------------------------------

def test_cs_rk4_matches_the_closed_form_at_fourth_order(linear):
    md = fmpy.read_model_description(str(linear))
    assert float(md.coSimulation.fixedInternalStepSize) == 1e-3 and md.coSimulation.canHandleVariableCommunicationStepSize
    errors = [np.max(np.abs((r := _cs(linear, 2.0, 0.1, _cs_step=step))["y"] - _linear_y(r["time"])))
              for step in (0.02, 0.01)]
    assert 14 < errors[0] / errors[1] < 18  # half the step, 1/16 the error
    r = _cs(linear, 2.0, 0.01)  # the default step, 1e-3 s
    assert np.max(np.abs(r["y"] - _linear_y(r["time"]))) < 1e-11


def test_cs_implicit_euler_converges_at_first_order(linear):
    errors = [np.max(np.abs((r := _cs(linear, 2.0, 0.1, _cs_step=step, _cs_method=1))["y"] - _linear_y(r["time"])))
              for step in (1e-3, 1e-4)]
    assert errors[1] < 1e-3
    assert 9 < errors[0] / errors[1] < 11


def test_cs_implicit_euler_is_stable_on_the_gripper_contact_where_rk4_diverges(shipped):
    """The fingers 5 um into a stiff object (the test_gripper_energy start), 20 ms: at 0.5 ms RK4 blows up, the
    implicit Euler (Newton with the exact Jacobian, halving the step where a contact or friction kink stops
    Newton) stays within 13 % of the output ranges (measured; 2 % at the FOC step, where RK4 gives 1e-4)."""
    fmu = shipped["GripperPlant"]
    start = {"gap0": 0.0, "drive.jaw.x": 5e-6, "motor.phi": 0.3, "motor.w": 30.0, "motor.i_q": 0.5, "v_q": 1.0}
    ref = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", relative_tolerance=1e-10, stop_time=0.02,
                            output_interval=1e-4, start_values=start)[::10]
    names = ("i_q", "w_m", "x_jaw", "F_g")
    assert np.ptp(ref["F_g"]) > 50  # N: the contact is loaded
    with np.errstate(all="ignore"):
        rk4 = _cs(fmu, 0.02, 1e-3, names, _cs_step=5e-4, **start)
    assert not np.all(np.isfinite(rk4["F_g"])) or np.max(np.abs(rk4["F_g"])) > 1e6
    implicit = _cs(fmu, 0.02, 1e-3, names, _cs_step=5e-4, _cs_method=1, **start)
    assert max(np.max(np.abs(implicit[n] - ref[n])) / np.ptp(ref[n]) for n in names) < 0.2


def test_cs_bouncing_ball_matches_the_closed_form_with_events_inside_do_step(hybrid_fmu):
    """RK4 is exact on the ball's parabolas, so what is left is the location of each impact (to 1e-10 s),
    whatever the internal step; the bounces count is exact at every communication point."""
    expected = bounce_times(e=0.8, v_min=0.0, stop=3.0)
    for step in (1e-2, 1e-3):
        r = _cs(hybrid_fmu("BouncingBall"), 3.0, 0.01, ["h", "v", "bounces"], _cs_step=step)
        h, v, n, _ = ball_state(r["time"], e=0.8, v_min=1e-6)  # the Modelica ball has no rest speed
        assert r["bounces"][-1] == len(expected) and np.array_equal(r["bounces"], n)
        assert np.max(np.abs(r["h"] - h)) < 1e-8 and np.max(np.abs(r["v"] - v)) < 1e-8


def test_cs_time_events_are_stepped_onto_and_terminate_returns_early(hybrid_fmu):
    _, slave, vr = _open(hybrid_fmu("StepCounter"), FMU3Slave)
    counts = []
    for k in range(11):  # a communication point on each event and between
        assert slave.doStep(k * 0.1, 0.1) == (False, False, False, pytest.approx((k + 1) * 0.1, abs=1e-15))
        counts.append(slave.getInt64([vr["steps"]])[0])
    assert counts == [0, 0, 1, 1, 2, 2, 2, 3, 3, 4, 4]  # instants 0.25, 0.5, 0.75, 1.0
    slave.freeInstance()
    _, slave, vr = _open(hybrid_fmu("Stop"), FMU3Slave)
    handling, terminate, early, last = slave.doStep(0.0, 2.0)
    assert (handling, terminate, early) == (False, True, True)
    assert last == pytest.approx(0.7, abs=1e-9) and slave.getFloat64([vr["T"]])[0] == pytest.approx(0.7, abs=1e-9)
    assert slave.doStep(last, 0.1)[1:3] == (True, False)  # stays terminated
    slave.freeInstance()


def test_cs_inputs_set_between_steps_are_seen_at_the_next_step_start(hybrid_fmu):
    """Hybrid.Inputs: n counts the rising edges of input b, der(x) = k: each doStep begins with an event iteration."""
    _, slave, vr = _open(hybrid_fmu("Inputs"), FMU3Slave)
    seen = []
    for k, b in enumerate((0.0, 1.0, 1.0, 0.0, 1.0)):
        slave.setFloat64([vr["b"], vr["k"]], [b, 2.0])
        slave.doStep(k * 0.1, 0.1)
        seen.append(slave.getInt64([vr["n"]])[0])
    assert seen == [0, 1, 1, 1, 2]
    assert slave.getFloat64([vr["x"]])[0] == pytest.approx(1.0, abs=1e-12)  # 0.5 s at k = 2
    slave.freeInstance()


# ---- directional derivatives ---------------------------------------------------------------------------------------

def test_directional_derivatives_equal_central_differences(shipped):
    """The gripper plant (8 states, 2 inputs, nonlinear) at a moving state: every column of d(der(x), y) /
    d(x, u) from fmi3GetDirectionalDerivative against central differences of step 1e-6 (relative)."""
    md, model, vr = _open(shipped["GripperPlant"], FMU3Model)
    model.enterContinuousTimeMode()
    states = [d.variable.derivative for d in md.derivatives]
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    unknowns = [d.variable.valueReference for d in md.derivatives] + [o.variable.valueReference for o in md.outputs]
    knowns = [v.valueReference for v in states + inputs]
    n = len(states)

    def evaluate(z):
        model.setContinuousStates((fmi3Float64 * n)(*z[:n]), n)
        model.setFloat64([v.valueReference for v in inputs], list(z[n:]))
        return np.array(model.getFloat64(unknowns))

    # i_d, i_q, rotor angle and speed, drag and mesh deflections, jaw position and speed; v_d, v_q
    z0 = np.array([0.3, 2.0, 12.0, 150.0, 1e-3, 1e-4, 4e-3, 5e-3, 0.5, 6.0])
    evaluate(z0)
    exact = np.array([model.getDirectionalDerivative(unknowns, knowns, list(np.eye(len(z0))[k]))
                      for k in range(len(z0))]).T
    fd = np.zeros_like(exact)
    for k in range(len(z0)):
        dz = np.eye(len(z0))[k] * 1e-6 * max(1.0, abs(z0[k]))
        fd[:, k] = (evaluate(z0 + dz) - evaluate(z0 - dz)) / (2 * dz[k])
    assert np.count_nonzero(exact) > 20
    np.testing.assert_allclose(exact, fd, rtol=1e-6, atol=1e-9)  # 2e-8 relative measured
    # a seed over several knowns is the sum of the columns; an unknown that is a state is the seed itself
    seed = np.linspace(0.5, 1.5, len(z0))
    evaluate(z0)
    assert model.getDirectionalDerivative(unknowns, knowns, list(seed)) == pytest.approx(exact @ seed, rel=1e-12)
    assert model.getDirectionalDerivative([knowns[2]], knowns, list(seed)) == [seed[2]]
    model.freeInstance()


# ---- FMU state ------------------------------------------------------------------------------------------------------

def _run(slave, vr, t0, n, h=0.01):
    rows = []
    for k in range(n):
        slave.doStep(t0 + k * h, h)
        rows.append(slave.getFloat64([vr["h"], vr["v"]]) + [float(slave.getInt64([vr["bounces"]])[0])])
    return np.array(rows)


def test_fmu_state_restored_and_deserialised_repeats_the_run_bitwise(hybrid_fmu, linear):
    """The ball from 0.3 s to 1.3 s crosses two impacts (events inside doStep): after the state saved at 0.3 s is
    restored, and after it went through bytes, the same doSteps give the same bits."""
    messages = []
    _, slave, vr = _open(hybrid_fmu("BouncingBall"), FMU3Slave, log=lambda *a: messages.append(a[-1].decode()))
    _run(slave, vr, 0.0, 30)
    state = slave.getFMUState()
    first = _run(slave, vr, 0.3, 100)
    assert first[-1, 2] == 2
    slave.setFMUState(state)
    assert np.array_equal(_run(slave, vr, 0.3, 100), first)
    data = slave.serializeFMUState(state)
    slave.freeFMUState(state)
    restored = slave.deserializeFMUState(data)
    slave.setFMUState(restored)
    assert np.array_equal(_run(slave, vr, 0.3, 100), first)
    # a state of another model is refused: by its size, or (cut to the size) by the model sizes it starts with
    _, other, _ = _open(linear, FMU3Slave, log=lambda *a: messages.append(a[-1].decode()))
    size = len(other.serializeFMUState(other.getFMUState()))
    assert size != len(data)
    with pytest.raises(FMICallException):
        other.deserializeFMUState(data)
    with pytest.raises(FMICallException):
        other.setFMUState(other.deserializeFMUState((data + bytes(size))[:size]))
    assert "saved by another model" in messages[-1]
    other.freeInstance()
    slave.freeInstance()


def test_fmu_state_of_a_model_exchange_instance_restores_time_states_and_inputs(linear):
    _, model, vr = _open(linear, FMU3Model)
    model.enterContinuousTimeMode()
    model.setTime(0.5)
    model.setContinuousStates((fmi3Float64 * 3)(2.0, 0.5, 0.25), 3)
    state = model.getFMUState()
    model.setTime(0.9)
    model.setContinuousStates((fmi3Float64 * 3)(1.0, 1.0, 1.0), 3)
    model.setFloat64([vr["a"]], [4.0])
    model.setFMUState(model.deserializeFMUState(model.serializeFMUState(state)))
    x, xdot = (fmi3Float64 * 3)(), (fmi3Float64 * 3)()
    model.getContinuousStates(x, 3)
    model.getContinuousStateDerivatives(xdot, 3)
    assert (list(x), list(xdot)) == ([2.0, 0.5, 0.25], [-4.0, 0.25, -4.5])  # -a x1, v, -w^2 q at a = 2
    assert model.getFloat64([vr["time"], vr["y"]]) == [0.5, 2.5]
    model.freeFMUState(state)
    model.freeInstance()


def test_solver_settings_are_checked(linear):
    messages = []
    md = fmpy.read_model_description(str(linear))
    by_name = {v.name: v for v in md.modelVariables}
    assert (by_name["_cs_step"].variability, by_name["_cs_method"].type) == ("fixed", "Int64")
    with pytest.raises(FMICallException):
        _open(linear, FMU3Slave, log=lambda *a: messages.append(a[-1].decode()), _cs_method=2)
    assert "_cs_method = 2 is not allowed (expected 0 (RK4) or 1 (implicit Euler))" in messages[-1]
    with pytest.raises(FMICallException):
        _open(linear, FMU3Slave, log=lambda *a: messages.append(a[-1].decode()), _cs_step=-1.0)
    assert "_cs_step = -1 is not allowed" in messages[-1]


def test_model_list_checks_the_solver_keys(tmp_path):
    from cosim.errors import ConfigError

    models = tmp_path / "models.toml"
    models.write_text('[[model]]\nname = "A"\nmodel = "P.A"\nsource = "P/package.mo"\ncs_step = 0\n'
                      'cs_method = "bdf"\n')
    with pytest.raises(ConfigError) as err:
        read_model_list(models)
    assert "models.toml:2: model[0] cs_step must be a positive step in s, not 0" in str(err.value)
    assert "cs_method must be one of rk4, implicit_euler, not 'bdf'" in str(err.value)
