"""Events of third-party-style Model Exchange FMUs (tests/fmus, FMI 2.0 and 3.0) in the master's Python engine:
state events located to EVENT_TOL, against the closed form (tests/fmus/reference.py) and fmpy's own CVode run."""

import fmpy
import numpy as np
import pytest

from cosim.config import load_config
from cosim.errors import EventError
from cosim.master import run
from cosim.master.plant import EVENT_TOL
from fmus.reference import ball_state, bounce_times


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
