"""Hybrid Modelica models end to end: tests/models/hybrid -> `cosim build` -> our FMI 3.0 ME FMU -> `cosim run`
(both engines), against closed forms, scipy's own event location on hand-written equations, and fmpy's CVode and
Euler runs of the same FMU."""

import json
import subprocess
import sys
from pathlib import Path

import fmpy
import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from cosim.config import load_config
from cosim.errors import FmiCallError
from cosim.master import run
from fmus.reference import bounce_times

ENGINES = ["python", "compiled"]


def _config(tmp_path, fmu, signals, stop, rate=100, engine="python"):
    cfg = tmp_path / f"{fmu.stem}.toml"
    cfg.write_text(f"""
[run]
stop = {stop}
engine = "{engine}"

[fmus.plant]
path = "{fmu}"

[record]
rate = {rate}
signals = {json.dumps([f"plant.{s}" for s in signals])}
""")
    return cfg


def _events(result, kind="state"):
    """Event instants of one kind, one per instant: a relation that flips at an event and flips back within
    the location tolerance (the ball leaving the floor right after its impact) counts once."""
    times = [t for t, _, k in result.events if k == kind]
    return np.array([t for i, t in enumerate(times) if i == 0 or t - times[i - 1] > 1e-6])


@pytest.mark.parametrize("engine", ENGINES)
def test_modelica_bouncing_ball_bounces_at_the_closed_form_times_in_cosim_run(tmp_path, hybrid_fmu, engine):
    fmu = hybrid_fmu("BouncingBall")
    result = run(load_config(_config(tmp_path, fmu, ["h", "v", "bounces"], 3.0, engine=engine)))
    expected = bounce_times(e=0.8, v_min=0.0, stop=3.0)
    np.testing.assert_allclose(_events(result), expected, atol=1e-6)
    assert result.data["bounces"].dtype.kind == "i"
    assert result.data["bounces"][-1] == len(expected)
    assert result.data["h"].min() > -1e-6


@pytest.mark.parametrize("solver, tolerance", [("CVode", 1e-6), ("Euler", 3e-3)])
def test_modelica_bouncing_ball_event_times_agree_with_fmpy(tmp_path, hybrid_fmu, solver, tolerance):
    """fmpy's Euler (fixed step 1e-4 s) finds an event at the end of the step that crosses it: its error grows
    with each bounce's accumulated drift, hence the looser tolerance."""
    fmu = hybrid_fmu("BouncingBall")
    kwargs = {"step_size": 1e-4, "output_interval": 1e-4} if solver == "Euler" else {
        "relative_tolerance": 1e-10, "output_interval": 1e-3}
    ref = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", stop_time=3.0, solver=solver, output=["bounces"],
                            **kwargs)
    theirs = np.array([ref["time"][np.argmax(ref["bounces"] >= k)] for k in range(1, ref["bounces"][-1] + 1)])
    result = run(load_config(_config(tmp_path, fmu, ["bounces"], 3.0)))
    n = result.data["bounces"]
    ours = _events(result)
    assert len(theirs) == n[-1] == len(ours)
    np.testing.assert_allclose(ours, theirs, atol=tolerance)


def _thermostat_reference(stop):
    """Switching times of dT/dt = P on - k (T - Ta), on below 19, off above 21, from T = 20 with the heater on
    (the when {T < Tlo, initial()} fires at initialisation), by scipy with its own event functions."""
    P, k, Ta, lo, hi = 2.0, 0.1, 10.0, 19.0, 21.0
    t, T, on, switches = 0.0, 20.0, True, []
    while t < stop:
        def cross(_, y, level=hi if on else lo):
            return y[0] - level
        cross.terminal = True
        sol = solve_ivp(lambda _, y: [(P if on else 0.0) - k * (y[0] - Ta)], (t, stop), [T], events=cross,
                        rtol=1e-12, atol=1e-12)
        if not sol.t_events[0].size:
            return np.array(switches)
        t, T, on = sol.t_events[0][0], sol.y_events[0][0][0], not on
        switches.append(t)
    return np.array(switches)


@pytest.mark.parametrize("engine", ENGINES)
def test_modelica_thermostat_switches_where_scipy_does(tmp_path, hybrid_fmu, engine):
    stop = 20.0
    result = run(load_config(_config(tmp_path, hybrid_fmu("Thermostat"), ["T", "switches"], stop, engine=engine)))
    expected = _thermostat_reference(stop)
    assert len(expected) >= 4
    np.testing.assert_allclose(_events(result), expected, atol=1e-6)
    assert result.data["T"].min() > 19.0 - 1e-6 and result.data["T"].max() < 21.0 + 1e-6
    # when change(on) does not fire at initialisation (a when-clause is active there only through initial())
    assert result.data["switches"][-1] == len(expected)


def test_modelica_sample_and_hold_holds_exp_at_the_sample_instants(tmp_path, hybrid_fmu):
    result = run(load_config(_config(tmp_path, hybrid_fmu("SampleHold"), ["y"], 1.0, rate=1000)))
    t, y = result.data["time"], result.data["y"]
    samples = _events(result, "time")
    # the lattice 0.1 + 0.2 k in floating point: 0.1 + 0.2 is 0.30000000000000004, after the row at 0.3
    np.testing.assert_allclose(samples, 0.1 + 0.2 * np.arange(5), atol=1e-12)
    taken = np.searchsorted(samples, t, side="right") - 1
    held = np.where(taken < 0, 0.0, np.exp(-samples[np.maximum(taken, 0)]))
    np.testing.assert_allclose(y, held, atol=1e-9)


def test_modelica_step_counter_counts_time_events_as_an_integer_column(tmp_path, hybrid_fmu):
    out = tmp_path / "out"
    cfg = _config(tmp_path, hybrid_fmu("StepCounter"), ["steps"], 1.1)
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(cfg), "--out", str(out)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    data = pd.read_parquet(out / "results.parquet")
    assert data["steps"].dtype.kind == "i"
    np.testing.assert_array_equal(data["steps"], np.floor(data["time"] / 0.25 + 1e-9).astype(int))


def test_modelica_assert_stops_the_run_with_its_file_line_and_message(tmp_path, hybrid_fmu):
    with pytest.raises(FmiCallError) as err:
        run(load_config(_config(tmp_path, hybrid_fmu("Overheat"), ["T"], 2.0)))
    assert "Hybrid.mo:" in str(err.value) and "temperature above limit" in str(err.value)


def test_modelica_terminate_stops_the_run_and_keeps_the_rows(tmp_path, hybrid_fmu):
    result = run(load_config(_config(tmp_path, hybrid_fmu("Stop"), ["T"], 2.0)))
    assert result.stopped["time"] == pytest.approx(0.7, abs=1e-9)
    assert "done heating" in result.stopped["reason"]
    assert 0.69 <= result.data["time"][-1] <= 0.7


def test_shipped_hybrid_example_builds_and_runs_from_the_command_line(tmp_path):
    """examples/hybrid_ball.toml as docs/guide/build.md shows it: cosim build FILE --model, then cosim run."""
    root = Path(__file__).resolve().parent.parent
    fmus = tmp_path / "fmus"
    built = subprocess.run([sys.executable, "-m", "cosim", "build", str(root / "examples/hybrid/BouncingBall.mo"),
                            "--model", "BouncingBall", "--out", str(fmus)], capture_output=True, text=True, cwd=root)
    assert built.returncode == 0, built.stderr
    out = tmp_path / "out"
    ran = subprocess.run([sys.executable, "-m", "cosim", "run", str(root / "examples/hybrid_ball.toml"), "--out",
                          str(out), "--set", f'fmus.ball.path="{fmus / "BouncingBall.fmu"}"'],
                         capture_output=True, text=True, cwd=root)
    assert ran.returncode == 0, ran.stderr
    data = pd.read_parquet(out / "results.parquet")
    expected = bounce_times(e=0.8, v_min=0.0, stop=3.0)
    assert data["bounces"].dtype.kind == "i" and data["bounces"].iloc[-1] == len(expected)
    np.testing.assert_array_equal(data["bounces"], np.searchsorted(expected, data["time"], side="right"))
    assert json.loads((out / "summary.json").read_text())["events"] == 2 * len(expected)
