"""Events of third-party-style Model Exchange FMUs (tests/fmus, FMI 2.0 and 3.0) in the master's Python engine:
state events located to EVENT_TOL, against the closed form (tests/fmus/reference.py) and fmpy's own CVode run."""

import json

import fmpy
import numpy as np
import pytest

from cosim.config import load_config
from cosim.errors import EventError
from cosim.master import run
from cosim.master.plant import EVENT_TOL
from fmus.reference import ball_state, bounce_times, ticker_state


def _ball_config(tmp_path, fmu, stop=3.0, rate=100, extra=""):
    cfg = tmp_path / "ball.toml"
    cfg.write_text(f"""
[run]
stop = {stop}
engine = "python"

[fmus.ball]
path = "{fmu}"
{extra}

[record]
rate = {rate}
signals = ["ball.h", "ball.v", "ball.bounces", "ball.flying"]
""")
    return cfg


def _state_events(result):
    return np.array([t for t, _, kind in result.events if kind == "state"])


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("step", ["substeps", "max_step=0.1"])
def test_bouncing_ball_rk4_bounce_times_match_the_closed_form(tmp_path, third_party_fmu, version, step):
    overrides = ["solver.max_step=0.1"] if step != "substeps" else []
    cfg = load_config(_ball_config(tmp_path, third_party_fmu("BouncingBall", version)), overrides)
    result = run(cfg)
    expected = bounce_times()
    assert len(expected) == 11
    np.testing.assert_allclose(_state_events(result), expected, atol=1e-6)
    h, v, n, flying = ball_state(result.data["time"])
    np.testing.assert_allclose(result.data["h"], h, atol=1e-6)
    np.testing.assert_allclose(result.data["v"], v, atol=1e-6)
    assert result.data["h"].min() >= 0.0  # never below the floor (the old master ended 43 m below it)
    assert result.data["bounces"].dtype == np.int32 and (result.data["bounces"] == n).all()
    assert result.data["flying"].dtype == np.bool_ and (result.data["flying"] == flying).all()


@pytest.mark.parametrize("method, tol", [("radau", 1e-6), ("lsoda", 1e-4), ("bdf", 1e-3)])
def test_bouncing_ball_implicit_solvers_locate_with_solve_ivp_events(tmp_path, third_party_fmu, method, tol):
    # the location is solve_ivp's root to EVENT_TOL; the tolerance is the solver's accuracy at rtol 1e-6
    cfg = load_config(_ball_config(tmp_path, third_party_fmu("BouncingBall", 3)), [f"solver.method={method}"])
    result = run(cfg)
    np.testing.assert_allclose(_state_events(result), bounce_times(), atol=tol)
    assert result.data["h"].min() >= 0.0
    assert result.data["bounces"][-1] == 11 and not result.data["flying"][-1]


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_matches_fmpy_cvode(tmp_path, third_party_fmu, version):
    fmu = third_party_fmu("BouncingBall", version)
    ref = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-10,
                            stop_time=3, output_interval=0.01, output=["h", "bounces"])
    fmpy_events = ref["time"][1:][np.diff(ref["bounces"]) != 0]
    result = run(load_config(_ball_config(tmp_path, fmu)))
    np.testing.assert_allclose(_state_events(result), fmpy_events, atol=1e-6)
    # the same output instants in both: the trajectories agree
    grid = np.round(ref["time"], 9)
    _, first = np.unique(grid, return_index=True)
    ours = dict(zip(np.round(result.data["time"], 9), result.data["h"]))
    common = [i for i in first if grid[i] in ours]
    assert len(common) == 301
    np.testing.assert_allclose([ours[grid[i]] for i in common], ref["h"][common], atol=1e-6)


def test_event_location_tolerance_is_stated(tmp_path, third_party_fmu):
    # each bounce lands in the bracket's far end: within EVENT_TOL (plus the drift of earlier ones) of the closed form
    result = run(load_config(_ball_config(tmp_path, third_party_fmu("BouncingBall", 3))))
    err = _state_events(result) - bounce_times()
    assert EVENT_TOL == 1e-10
    assert err[0] >= 0 and err[0] <= EVENT_TOL + 1e-15
    assert np.abs(err).max() < 1e-8


def test_zeno_ball_is_an_event_error_naming_the_fmu_and_time(tmp_path, third_party_fmu):
    # v_min = 0: the ball never rests, the impacts pile up at t1 (1 + 2 e / (1 - e)) = 2.5586 s (geometric series)
    cfg = load_config(_ball_config(tmp_path, third_party_fmu("BouncingBall", 3), extra="parameters = { v_min = 0.0 }"))
    t_zeno = bounce_times()[0] * (1 + 2 * 0.7 / (1 - 0.7))
    with pytest.raises(EventError, match=r"ball: more than 100 events in a row .* at t=2\.5586") as err:
        run(cfg)
    t_error = float(str(err.value).split("at t=")[1].split(" s")[0])
    assert abs(t_error - t_zeno) < 1e-6


def _config(tmp_path, body, name="run.toml"):
    cfg = tmp_path / name
    cfg.write_text(body)
    return cfg


def test_time_events_between_instants_ticker(tmp_path, third_party_fmu):
    # period 0.123 s: every event falls between the 100 Hz instants; steps end exactly at k * period
    body = f"""
[run]
stop = 1.0
engine = "python"
[fmus.tick]
path = "{third_party_fmu("Ticker", 3)}"
parameters = {{ period = 0.123 }}
[record]
rate = 100
signals = ["tick.x", "tick.counter"]
"""
    for method in ("rk4", "radau"):
        result = run(load_config(_config(tmp_path, body), [f"solver.method={method}"]))
        times = [t for t, inst, kind in result.events if kind == "time" and inst == "tick"]
        np.testing.assert_allclose(times, 0.123 * np.arange(1, 9), rtol=0, atol=1e-15)
        counter, x = ticker_state(result.data["time"], period=0.123)
        assert result.data["counter"].dtype == np.int32
        assert (result.data["counter"] == counter).all()
        np.testing.assert_allclose(result.data["x"], x, atol=1e-9)


def test_step_events_sawtooth(tmp_path, third_party_fmu):
    # CompletedIntegratorStep asks for event mode once x >= 1: x := x - 1, resets += 1, so x + resets = time
    body = f"""
[run]
stop = 3.5
engine = "python"
[fmus.saw]
path = "{third_party_fmu("Sawtooth", 3)}"
[record]
rate = 100
signals = ["saw.x", "saw.resets"]
"""
    result = run(load_config(_config(tmp_path, body)))
    d = result.data
    np.testing.assert_allclose(d["x"] + d["resets"], d["time"], atol=1e-9)
    assert d["resets"][-1] == 3 and d["x"].max() < 1.0 + 0.01 + 1e-9
    assert [k for _, _, k in result.events] == ["step"] * 3


def test_unsettled_event_iteration_is_an_event_error(tmp_path, third_party_fmu):
    body = f"""
[run]
stop = 1.0
engine = "python"
[fmus.chat]
path = "{third_party_fmu("Chatter", 3)}"
parameters = {{ t_chatter = 0.4 }}
[record]
signals = ["chat.x"]
"""
    with pytest.raises(EventError, match=r"chat: the event iteration at t=0\.4 s did not settle in 100 passes"):
        run(load_config(_config(tmp_path, body)))


@pytest.mark.parametrize("engine", ["python", "compiled"])
@pytest.mark.parametrize("kind, version", [("ME", 3), ("ME", 2), ("CS", 3), ("CS", 2)])
def test_terminate_simulation_keeps_rows_and_says_why(tmp_path, third_party_fmu, kind, version, engine, capsys):
    from cosim.cli import main
    from cosim.master import read_results

    cfg = _config(tmp_path, f"""
[run]
stop = 2.0
[fmus.stop]
path = "{third_party_fmu("Stopper", version)}"
kind = "{kind}"
parameters = {{ t_stop = 0.7 }}
[record]
rate = 10
signals = ["stop.x"]
""")
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out), "--no-progress", "--set", f"run.engine={engine}"]) == 0
    assert "stopped at t=0.7 s: stop asked to terminate" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped"]["by"] == "stop" and abs(summary["stopped"]["time"] - 0.7) < 1e-9
    data, _, meta = read_results(out / "results.parquet")
    # the rows of the instants before the stop are kept (the stop at 0.7 s ends the interval from 0.6 s)
    np.testing.assert_allclose(data["time"], np.arange(7) / 10, atol=1e-12)
    np.testing.assert_allclose(data["x"], data["time"], atol=1e-9)
    assert json.loads(meta["cosim.stopped"])["by"] == "stop"


def test_events_between_controller_instants_hold_the_controller_outputs(tmp_path, third_party_fmu):
    # a 10 Hz playback drives Feedthrough.u_f64 (x integrates it) while the ball bounces between its instants:
    # the bounces stay at their closed-form times and x is the integral of the held steps
    csv = tmp_path / "u.csv"
    csv.write_text("time,u\n" + "".join(f"{k / 10},{k + 1}\n" for k in range(31)))
    cfg = _config(tmp_path, f"""
[run]
stop = 3.0
engine = "python"
[fmus.ball]
path = "{third_party_fmu("BouncingBall", 3)}"
[fmus.ft]
path = "{third_party_fmu("Feedthrough", 3)}"
[controllers.replay]
class = "cosim_controllers.playback:Playback"
rate = 10
parameters = {{ file = "u.csv", column = "u" }}
[[connections]]
from = "replay.y"
to = "ft.u_f64"
[solver]
max_step = 0.1
[record]
rate = 10
signals = ["ball.h", "ft.x"]
""")
    result = run(load_config(cfg))
    np.testing.assert_allclose(_state_events(result), bounce_times(), atol=1e-6)
    assert result.calls["replay"] == 30
    k = np.arange(31)
    np.testing.assert_allclose(result.data["x"], 0.1 * k * (k + 1) / 2, atol=1e-9)  # sum of u_j * 0.1, u_j = j + 1


def test_event_outputs_routed_continuously_to_another_me_fmu(tmp_path, third_party_fmu):
    # ball.h drives Feedthrough.u_f64 at every derivative evaluation (ME-to-ME): ft.x = integral of h, across
    # the bounces; reference: the closed-form h integrated by the trapezoid rule on a 1 us grid
    cfg = _config(tmp_path, f"""
[run]
stop = 3.0
engine = "python"
[fmus.ball]
path = "{third_party_fmu("BouncingBall", 2)}"
[fmus.ft]
path = "{third_party_fmu("Feedthrough", 3)}"
[[connections]]
from = "ball.h"
to = "ft.u_f64"
[record]
rate = 10
signals = ["ft.x", "ft.y_f64"]
""")
    result = run(load_config(cfg))
    np.testing.assert_allclose(_state_events(result), bounce_times(), atol=1e-6)
    fine = np.linspace(0, 3, 3_000_001)
    h = ball_state(fine)[0]
    integral = np.concatenate([[0], np.cumsum((h[1:] + h[:-1]) / 2 * np.diff(fine))])
    np.testing.assert_allclose(result.data["x"], integral[::100_000], atol=1e-7)
    np.testing.assert_allclose(result.data["y_f64"], 2 * ball_state(result.data["time"])[0], atol=1e-9)


def test_stop_during_initialisation_writes_an_empty_result(tmp_path, third_party_fmu, capsys):
    # t_stop = 0: the Stopper asks to terminate in the event iteration that ends its initialisation
    from cosim.cli import main

    cfg = _config(tmp_path, f"""
[run]
stop = 1.0
engine = "python"
[fmus.stop]
path = "{third_party_fmu("Stopper", 3)}"
parameters = {{ t_stop = 0.0 }}
[record]
rate = 10
signals = ["stop.x"]
""")
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out), "--no-progress"]) == 0
    assert "stopped at t=0 s: stop asked to terminate" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped"]["time"] == 0.0 and summary["rows"] == 0


def test_step_events_between_instants_restart_from_the_new_states(tmp_path, third_party_fmu):
    # 7.5 Hz instants, 0.01 s RK4 steps: a reset inside an interval; the next steps start from the reset state
    body = f"""
[run]
stop = 3.5
engine = "python"
[fmus.saw]
path = "{third_party_fmu("Sawtooth", 3)}"
[solver]
max_step = 0.01
[record]
rate = 7.5
signals = ["saw.x", "saw.resets"]
"""
    result = run(load_config(_config(tmp_path, body)))
    assert [k for _, _, k in result.events] == ["step"] * 3
    np.testing.assert_allclose([t for t, _, _ in result.events], [1, 2, 3], atol=0.01 + 1e-9)
    d = result.data
    np.testing.assert_allclose(d["x"] + d["resets"], d["time"], atol=1e-9)
