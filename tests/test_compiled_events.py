"""Events of Model Exchange FMUs in the compiled engine (issue 28), on the C test FMUs of tests/fmus:
state events against the bouncing ball's closed form, time events against the Ticker's, step events,
terminateSimulation, an event iteration that does not settle; and the compiled engine against the Python
engine (cosim.master.plant, written apart with the same rules), which must agree to the last bit."""

import textwrap

import numpy as np
import pytest

from cosim.config import load_config
from cosim.errors import EventError
from cosim.master import run
from fmus.reference import ball_state, bounce_times, ticker_state


def _config(tmp_path, fmu, signals, stop, kind="ME", parameters="", max_step=0.01, rate=100):
    """A config with the one FMU ``m`` recording ``signals`` at ``rate`` Hz, RK4 steps of at most ``max_step``."""
    path = tmp_path / "events.toml"
    path.write_text(textwrap.dedent(f"""
        [run]
        stop = {stop}

        [solver]
        max_step = {max_step}

        [fmus.m]
        path = "{fmu}"
        kind = "{kind}"
        parameters = {{ {parameters} }}

        [record]
        rate = {rate}
        signals = [{", ".join(f'"m.{s}"' for s in signals)}]
        """))
    return path


def _run(path, engine):
    result = run(load_config(path, [f"run.engine={engine}"]), progress=False)
    assert result.engine == engine, result.engine_note
    return result


def _both(path):
    """Run with both engines; they must give the same rows, bit for bit, and stop the same way."""
    comp, py = _run(path, "compiled"), _run(path, "python")
    assert comp.data.dtype.names == py.data.dtype.names
    for name in comp.data.dtype.names:
        np.testing.assert_array_equal(comp.data[name], py.data[name], err_msg=name)
    assert comp.stopped == py.stopped
    assert comp.events == py.events  # (time, instance, kind) of every event, times to the bit
    return comp


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_follows_the_closed_form(third_party_fmu, tmp_path, version):
    """Impacts between the 100 Hz instants are located to 1e-10 s: an impact time off by d would put h off
    by about (1 + e) |v| d, so h to 1e-8 m at every instant is every bounce time to about 1e-9 s."""
    path = _config(tmp_path, third_party_fmu("BouncingBall", version), ["h", "v"], stop=3.0)
    r = _both(path)
    h, v, _, _ = ball_state(r.data["time"])
    assert len(r.data) == 301
    assert [kind for _, _, kind in r.events] == ["state"] * 11
    np.testing.assert_allclose([t for t, _, _ in r.events], bounce_times(), atol=1e-9)
    np.testing.assert_allclose(r.data["h"], h, atol=1e-8)
    np.testing.assert_allclose(r.data["v"], v, atol=1e-7)


def test_bouncing_ball_with_substeps_and_another_restitution(third_party_fmu, tmp_path):
    """Several RK4 steps per instant (max_step 2 ms, instants at 100 Hz) and e = 0.5."""
    path = _config(tmp_path, third_party_fmu("BouncingBall"), ["h"], stop=3.0, parameters="e = 0.5",
                   max_step=0.002)
    r = _run(path, "compiled")
    h, _, _, _ = ball_state(r.data["time"], e=0.5)
    np.testing.assert_allclose(r.data["h"], h, atol=1e-8)


def test_ticker_time_events(third_party_fmu, tmp_path):
    """The counter steps at k * 0.3 s (nextEventTime), between the 100 Hz instants; x integrates it exactly."""
    path = _config(tmp_path, third_party_fmu("Ticker"), ["x"], stop=1.6, parameters="period = 0.3")
    r = _both(path)
    _, x = ticker_state(r.data["time"], period=0.3)
    np.testing.assert_allclose(r.data["x"], x, atol=1e-12)


def test_sawtooth_step_events(third_party_fmu, tmp_path):
    """CompletedIntegratorStep asks for event mode once x >= 1: x falls back by 1 within one step."""
    path = _config(tmp_path, third_party_fmu("Sawtooth"), ["x"], stop=3.5, max_step=0.005)
    r = _both(path)
    t, x = r.data["time"], r.data["x"]
    assert x.max() < 1 + 0.005 and x.min() >= 0
    np.testing.assert_allclose(x[t < 0.99], t[t < 0.99], atol=1e-12)
    np.testing.assert_allclose(x[(t > 1.01) & (t < 1.99)], t[(t > 1.01) & (t < 1.99)] - 1, atol=1e-9)


def test_sawtooth_step_events_between_instants(third_party_fmu, tmp_path):
    """Instants at 7.5 Hz, 14 RK4 steps between two of them: each step event (x reaches 1 at t = 1, 2, 3 s,
    mid-interval) happens once and the next step starts from the reset state."""
    path = _config(tmp_path, third_party_fmu("Sawtooth"), ["x"], stop=3.5, rate=7.5)
    r = _run(path, "compiled")
    assert [kind for _, _, kind in r.events] == ["step"] * 3
    np.testing.assert_allclose([t for t, _, _ in r.events], [1.0, 2.0, 3.0], atol=1e-12)
    t = r.data["time"]
    np.testing.assert_allclose(r.data["x"], t - np.floor(t + 1e-12), atol=1e-12)


@pytest.mark.parametrize("version, kind", [(3, "ME"), (2, "ME"), (3, "CS")])
def test_stopper_terminates_and_keeps_the_rows(third_party_fmu, tmp_path, version, kind):
    """terminateSimulation at 0.615 s: the rows up to the last instant before it are kept, and the result says
    who asked and when."""
    path = _config(tmp_path, third_party_fmu("Stopper", version), ["x"], stop=1.0, kind=kind,
                   parameters="t_stop = 0.615")
    r = _both(path)
    assert r.stopped["by"] == "m"
    assert r.stopped["time"] == pytest.approx(0.615 if kind == "ME" else 0.62, abs=1e-12)
    assert r.data["time"][-1] == pytest.approx(0.61)
    np.testing.assert_allclose(r.data["x"], r.data["time"], atol=1e-12)


def test_event_iteration_that_does_not_settle_is_an_event_error(third_party_fmu, tmp_path):
    path = _config(tmp_path, third_party_fmu("Chatter"), ["x"], stop=1.0)
    for engine in ("compiled", "python"):
        with pytest.raises(EventError, match=r"m: the event iteration at t=0\.5 s did not settle"):
            run(load_config(path, [f"run.engine={engine}"]), progress=False)


def test_zeno_ball_is_an_event_error(third_party_fmu, tmp_path):
    """With v_min = 0 the ball never rests: its impacts accumulate at a finite time, more than
    MAX_EVENTS_AT_ONE_TIME in a row closer than CHATTER_WINDOW; both engines stop with the same message."""
    path = _config(tmp_path, third_party_fmu("BouncingBall"), ["h"], stop=3.0, parameters="v_min = 0.0")
    messages = []
    for engine in ("compiled", "python"):
        with pytest.raises(EventError, match=r"m: more than 100 events in a row less than 1e-08 s apart") as err:
            run(load_config(path, [f"run.engine={engine}"]), progress=False)
        messages.append(str(err.value))
    assert messages[0] == messages[1]
