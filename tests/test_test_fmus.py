"""The C test FMUs of tests/fmus (third-party style, FMI 2.0 and 3.0, Model Exchange and Co-Simulation) pass
fmpy's validation and, simulated by fmpy's own solvers, follow their closed forms (tests/fmus/reference.py).
These FMUs are the independent reference the master's event tests rely on."""

import fmpy
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from fmus.build import names
from fmus.reference import ball_state, bounce_times, ticker_state


def _jumps(result, name):
    """Instants at which the discrete output ``name`` changes in an fmpy result."""
    values = result[name].astype(float)
    return result["time"][1:][np.diff(values) != 0]


@pytest.mark.parametrize("name, version", names())
def test_validates(third_party_fmu, name, version):
    assert validate_fmu(str(third_party_fmu(name, version))) == []


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_me_cvode_bounce_times(third_party_fmu, version):
    r = fmpy.simulate_fmu(str(third_party_fmu("BouncingBall", version)), fmi_type="ModelExchange", solver="CVode",
                          relative_tolerance=1e-10, stop_time=3, output_interval=0.01,
                          output=["h", "v", "bounces", "flying"])
    expected = bounce_times()
    assert len(expected) == 11
    np.testing.assert_allclose(_jumps(r, "bounces"), expected, atol=1e-6)
    assert r["bounces"].dtype == np.int32 and r["bounces"][-1] == 11
    assert r["flying"].dtype == np.bool_ and not r["flying"][-1] and r["flying"][0]
    h, v, _, _ = ball_state(r["time"])
    np.testing.assert_allclose(r["h"], h, atol=1e-5)


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_me_euler_bounce_times(third_party_fmu, version):
    """fmpy's Euler takes one step per output interval and only notices a crossing at the end of a step: each
    impact is late by up to a step and the ball rebounds a little faster, so the error grows with the bounces."""
    r = fmpy.simulate_fmu(str(third_party_fmu("BouncingBall", version)), fmi_type="ModelExchange", solver="Euler",
                          step_size=1e-4, stop_time=3, output_interval=1e-4, output=["h", "bounces"])
    times = _jumps(r, "bounces")
    expected = bounce_times()
    assert len(times) == len(expected)
    assert 0 <= times[0] - expected[0] <= 1e-4
    np.testing.assert_allclose(times, expected, atol=1e-2)


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_cs_follows_closed_form(third_party_fmu, version):
    """RK4 is exact on the parabola and the impacts are located to 1e-12 s inside doStep."""
    r = fmpy.simulate_fmu(str(third_party_fmu("BouncingBall", version)), fmi_type="CoSimulation", stop_time=3,
                          output_interval=0.01, output=["h", "v", "bounces", "flying"])
    h, v, n, flying = ball_state(r["time"])
    np.testing.assert_allclose(r["h"], h, atol=1e-9)
    np.testing.assert_allclose(r["v"], v, atol=1e-8)
    np.testing.assert_array_equal(r["bounces"], n)
    np.testing.assert_array_equal(r["flying"], flying)


@pytest.mark.parametrize("fmi_type, solver", [("ModelExchange", "CVode"), ("ModelExchange", "Euler"),
                                              ("CoSimulation", None)])
def test_ticker_time_events(third_party_fmu, fmi_type, solver):
    """The counter steps exactly at k * 0.25 s (nextEventTime) and x integrates it."""
    kwargs = {"solver": solver} if solver else {}
    r = fmpy.simulate_fmu(str(third_party_fmu("Ticker")), fmi_type=fmi_type, stop_time=1.6, output_interval=0.01,
                          output=["x", "counter"], **kwargs)
    if fmi_type == "ModelExchange":
        np.testing.assert_allclose(_jumps(r, "counter"), [0.25, 0.5, 0.75, 1.0, 1.25, 1.5], atol=1e-12)
    counter, x = ticker_state(r["time"])
    after = np.r_[r["time"][1:] != r["time"][:-1], True]   # at an event instant fmpy records before and after
    np.testing.assert_array_equal(r["counter"][after], counter[after])
    np.testing.assert_allclose(r["x"], x, atol=1e-9)
    assert r["counter"].dtype == np.int32


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("fmi_type, solver", [("ModelExchange", "CVode"), ("ModelExchange", "Euler"),
                                              ("CoSimulation", None)])
def test_stopper_terminates(third_party_fmu, version, fmi_type, solver):
    """The run ends at t_stop = 0.615 s, between two output points, with x = t_stop."""
    kwargs = {"solver": solver} if solver else {}
    if fmi_type == "CoSimulation" and version == 3:
        kwargs["early_return_allowed"] = True
    r = fmpy.simulate_fmu(str(third_party_fmu("Stopper", version)), fmi_type=fmi_type, stop_time=1,
                          output_interval=0.01, start_values={"t_stop": 0.615}, output=["x"], **kwargs)
    assert r["time"][-1] == pytest.approx(0.615, abs=1e-12)
    assert r["x"][-1] == pytest.approx(0.615, abs=1e-9)


@pytest.mark.parametrize("fmi_type", ["ModelExchange", "CoSimulation"])
def test_feedthrough_types(third_party_fmu, fmi_type):
    """Each output follows its input through the FMU with its own FMI type, an Int64 beyond 2^31 included."""
    dtype = [("time", np.float64), ("u_f64", np.float64), ("u_f32", np.float32), ("u_i32", np.int32),
             ("u_i64", np.int64), ("u_b", np.bool_)]
    signals = np.array([(0.0, 1.0, 1.5, 7, 3_000_000_000, False), (0.5, 1.0, 1.5, 7, 3_000_000_000, False),
                        (0.5, -2.0, 0.1, -4, -5, True), (1.0, -2.0, 0.1, -4, -5, True)], dtype=dtype)
    r = fmpy.simulate_fmu(str(third_party_fmu("Feedthrough")), fmi_type=fmi_type, stop_time=1, output_interval=0.1,
                          input=signals)
    assert {r.dtype[n] for n in ("y_f32", "y_i32", "y_i64", "y_b")} == {np.dtype(t) for t in ("f4", "i4", "i8", "?")}
    first, last = r[0], r[-1]
    assert (first["y_f64"], first["y_f32"], first["y_i32"], first["y_i64"], first["y_b"]) == (
        2.0, np.float32(3.0), 8, 9_000_000_000, True)
    assert (last["y_f64"], last["y_f32"], last["y_i32"], last["y_i64"], last["y_b"]) == (
        -4.0, np.float32(2) * np.float32(0.1), -3, -15, False)
    np.testing.assert_allclose(r["x"], np.where(r["time"] <= 0.5, r["time"], 0.5 - 2 * (r["time"] - 0.5)), atol=1e-9)


@pytest.mark.parametrize("fmi_type, solver", [("ModelExchange", "CVode"), ("ModelExchange", "Euler"),
                                              ("CoSimulation", None)])
def test_sawtooth_step_events(third_party_fmu, fmi_type, solver):
    """x falls by 1 at the step event after it reaches 1: x + resets = time throughout, x never far above 1."""
    kwargs = {"solver": solver} if solver else {}
    r = fmpy.simulate_fmu(str(third_party_fmu("Sawtooth")), fmi_type=fmi_type, stop_time=3.5, output_interval=0.01,
                          output=["x", "resets"], **kwargs)
    np.testing.assert_allclose(r["x"] + r["resets"], r["time"], atol=1e-9)
    assert r["resets"][-1] == 3 and r["x"].max() < 1 + 3.5 / 50   # fmpy's CVode steps at most (stop - start) / 50


def test_chatter_never_settles(third_party_fmu):
    """Model Exchange: at t_chatter every fmi3UpdateDiscreteStates asks for another pass (fmpy itself would
    loop for ever, so the FMU is driven by hand); Co-Simulation: doStep fails."""
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi3 import FMU3Model

    path = str(third_party_fmu("Chatter"))
    md = read_model_description(path)
    fmu = FMU3Model(guid=md.guid, unzipDirectory=extract(path), modelIdentifier="Chatter")
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0)
    fmu.exitInitializationMode()
    assert fmu.updateDiscreteStates() == (False, False, False, False, True, 0.5)
    fmu.enterContinuousTimeMode()
    fmu.setTime(0.5)
    fmu.enterEventMode()
    needs = [fmu.updateDiscreteStates()[0] for _ in range(1000)]
    assert all(needs) and fmu.getBoolean([4]) == [False]   # an even number of flips
    fmu.terminate()
    fmu.freeInstance()
    with pytest.raises(FMICallException):
        fmpy.simulate_fmu(path, fmi_type="CoSimulation", stop_time=1, output_interval=0.01)
