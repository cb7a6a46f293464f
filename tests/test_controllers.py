"""Controllers: the shared contract over every implementation, FOC gain design and step response,
the outer loop's eqs. (1)-(2), mode switch and profiles, and the closed loop on the gripper plant."""

import importlib
import math
import pkgutil
import textwrap

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

import cosim_controllers
from cosim.controller import Controller
from cosim_controllers.foc import FOC, foc_gains
from cosim_controllers.outer import OuterLoop, staircase_current, staircase_steps
from cosim_controllers.playback import Playback
from cosim.config import load_config
from cosim.master import run


def _all_controller_classes():
    for m in pkgutil.iter_modules(cosim_controllers.__path__):
        importlib.import_module(f"cosim_controllers.{m.name}")
    seen, stack = [], list(Controller.__subclasses__())
    while stack:
        c = stack.pop()
        stack.extend(c.__subclasses__())
        if c.__module__.startswith("cosim_controllers.") and c not in seen:
            seen.append(c)
    assert seen, "no shipped controller found: the tests parametrized by them would be skipped, not run"
    return sorted(seen, key=lambda c: (c.__module__, c.__name__))


def required_parameters(cls, folder):
    """Parameters a class cannot default: the data file a Playback plays."""
    if cls is not Playback:
        return {}
    pd.DataFrame({"time": [0.0, 1e-4, 2e-4], "u": [1.0, 2.0, 3.0]}).to_csv(folder / "u.csv", index=False)
    return {"file": str(folder / "u.csv"), "column": "u"}


@pytest.mark.parametrize("cls", _all_controller_classes(), ids=lambda c: f"{c.__module__}.{c.__name__}")
def test_controller_contract(cls, tmp_path):
    required = required_parameters(cls, tmp_path)
    c = cls(rate=10000.0, **required)
    assert c.u.shape == (len(cls.inputs),) and c.y.shape == (len(cls.outputs),)
    assert c.p.dtype == np.float64 and c.x.dtype == np.float64
    assert c.compiled, "step must compile with numba"
    assert len(set(cls.inputs)) == len(cls.inputs) and len(set(cls.outputs)) == len(cls.outputs)
    for t in (0.0, 1e-4, 2e-4):
        c.step(t)
    assert np.all(np.isfinite(c.y))
    # the compiled and the plain kernels agree
    d = cls(rate=10000.0, jit=False, **required)
    for t in (0.0, 1e-4, 2e-4):
        d.step(t)
    assert_allclose(d.y, c.y, rtol=1e-12, atol=1e-12)
    with pytest.raises(TypeError, match="unknown parameter"):
        cls(rate=10000.0, no_such_parameter_xyz=1.0, **required)
    with pytest.raises(ValueError, match="rate"):
        cls(rate=-1.0, **required)


def test_playback_holds_each_sample_until_the_next(tmp_path):
    """Zero-order hold of a recorded column at instants between, on and before its time stamps (reference:
    numpy's searchsorted on the same table); the first value before the first stamp; a clear error without a
    file."""
    t_data = np.array([0.0, 0.01, 0.02, 0.05])
    v_data = np.array([0.5, 1.5, -2.0, 4.0])
    pd.DataFrame({"time": t_data, "i": v_data}).to_csv(tmp_path / "d.csv", index=False)
    c = Playback(rate=1000.0, file=str(tmp_path / "d.csv"), column="i")
    instants = np.arange(0, 70) * 1e-3
    played = []
    for t in instants:
        c.step(t)
        played.append(c.y[0])
    expected = v_data[np.maximum(np.searchsorted(t_data, instants + 1e-12, side="right") - 1, 0)]
    assert_allclose(played, expected, rtol=0, atol=0)
    with pytest.raises(ValueError, match="'file' and 'column' are required"):
        Playback(rate=1000.0)


def test_playback_drives_an_fmu_from_a_config_beside_its_data(master_dir, tmp_path, monkeypatch):
    """A config plays u.csv (a path relative to the config's folder, run from elsewhere) into the Osc FMU: the
    recorded input is the table held between its stamps."""
    t_data = np.arange(0, 21) * 0.05
    u_data = np.sin(7.0 * t_data)
    pd.DataFrame({"time": t_data, "u": u_data}).to_csv(master_dir / "play_u.csv", index=False)
    text = osc_config(master_dir, stop=1.0, rate=100, record_rate=100).read_text()
    text = text.replace('class = "ctl.py:Sine"', 'class = "cosim_controllers.playback:Playback"').replace(
        "parameters = { amp = 2.0, f = 1.0 }", 'parameters = { file = "play_u.csv", column = "u" }').replace(
        '"src.u"', '"src.y"')
    (master_dir / "play.toml").write_text(text)
    monkeypatch.chdir(tmp_path)
    result = run(load_config(master_dir / "play.toml"), progress=False)
    t = result.data["time"][:-1]  # controllers do not step at the stop instant: its row holds the last step
    expected = u_data[np.searchsorted(t_data, t + 1e-9, side="right") - 1]
    assert_allclose(result.data["src.y"][:-1], expected, rtol=0, atol=1e-15)


# -- FOC ----------------------------------------------------------------------------------------------
def test_foc_gains_approach_the_continuous_design():
    # for f_bw T << 1 the discrete design tends to Kp = L w_c, Ki = R w_c (DQCurrentController)
    R, L, wc = 0.45, 2.5e-4, 2 * math.pi * 100.0
    kp, ki = foc_gains(R, L, rate=1e6, bandwidth_hz=100.0)
    assert_allclose(kp, L * wc, rtol=1e-3)
    assert_allclose(ki * 1e6, R * wc, rtol=1e-3)


def test_foc_locked_rotor_follows_the_designed_pole():
    # discrete R-L plant sampled with ZOH, FOC at 26.6 kHz, locked rotor: i_q[k] = 1 - p**k exactly
    foc = FOC(rate=26600.0, enc_cpt=0.0)
    T, R, L = foc.dt, 0.45, 2.5e-4
    a = math.exp(-R * T / L)
    p = math.exp(-T / foc.time_constant)
    i = 0.0
    out = []
    for k in range(60):
        foc.u[:] = [1.0, 0.0, i, 0.0, 0.0]
        foc.step(k * T)
        out.append(i)
        i = a * i + (1 - a) / R * foc.y[1]
    assert_allclose(out, 1 - p ** np.arange(60), atol=1e-12)


def _foc_config(tmp, gripper_dir, iq, stop, record_rate):
    text = textwrap.dedent(f"""
        [run]
        stop = {stop}
        [fmus.plant]
        path = "{gripper_dir / 'GripperPlant.fmu'}"
        parameters = {{ gap0 = 0.05 }}
        [controllers.ref]
        class = "ctl.py:Step"
        rate = 26600
        parameters = {{ value = {iq}, t_step = 0.0 }}
        [controllers.foc]
        class = "cosim_controllers.foc:FOC"
        rate = 26600
        parameters = {{ bandwidth_hz = 1000.0, psi_m = 0.0098485 }}
        [[connections]]
        from = "ref.y"
        to = "foc.i_q_ref"
        [[connections]]
        from = "plant.i_d"
        to = "foc.i_d"
        [[connections]]
        from = "plant.i_q"
        to = "foc.i_q"
        [[connections]]
        from = "plant.theta_m"
        to = "foc.theta_m"
        [[connections]]
        from = "plant.w_m"
        to = "foc.w_m"
        [[connections]]
        from = "foc.v_d"
        to = "plant.v_d"
        [[connections]]
        from = "foc.v_q"
        to = "plant.v_q"
        [record]
        rate = {record_rate}
        signals = ["plant.i_q", "plant.i_d", "plant.w_m"]
        """)
    path = tmp / "foc.toml"
    path.write_text(text)
    return path


@pytest.mark.slow
def test_foc_iq_step_time_constant_on_the_plant(master_dir, gripper_dir, tmp_path):
    import shutil

    shutil.copy(master_dir / "ctl.py", tmp_path)
    res = run(load_config(_foc_config(tmp_path, gripper_dir, 1.0, 0.003, 26600)), progress=False)
    t, iq = res.data["time"], res.data["i_q"]
    tau_design = 1 / (2 * math.pi * 1000.0)
    # fit log(1 - i_q) = -t / tau over the first three time constants
    m = (t > 0) & (t < 3 * tau_design)
    slope = np.polyfit(t[m], np.log(1.0 - iq[m]), 1)[0]
    tau = -1.0 / slope
    assert abs(tau / tau_design - 1) < 0.05, (tau, tau_design)
    assert abs(iq[-1] - 1.0) < 0.01


@pytest.mark.slow
def test_foc_keeps_id_near_zero_while_spinning(master_dir, gripper_dir, tmp_path):
    import shutil

    shutil.copy(master_dir / "ctl.py", tmp_path)
    res = run(load_config(_foc_config(tmp_path, gripper_dir, 0.6, 0.15, 2660)), progress=False)
    late = res.data["time"] > 0.01
    assert res.data["w_m"][-1] > 100.0  # spinning (rad/s)
    assert np.max(np.abs(res.data["i_d"][late])) < 0.02  # A
    assert_allclose(res.data["i_q"][late], 0.6, atol=0.02)


# -- outer loop: eqs. (1), (2), switch, profiles ------------------------------------------------------
def _feed_speeds(loop, speeds, t0=1.0):
    """Drive the loop with an exact angle whose sample differences give ``speeds`` (rad/s)."""
    th = 0.0
    out = []
    for n, w in enumerate(speeds):
        th += w * loop.dt
        loop.u[0] = th
        loop.step(t0 + n * loop.dt)
        out.append(loop.y.copy())
    return np.array(out)


def _loop(**kw):
    args = dict(profile="impact", enc_cpt=0.0, speed_rpm=100 * 60 / (2 * math.pi), ramp_s=0.5, t_start=0.0)
    args.update(kw)
    return OuterLoop(rate=100.0, **args)


def test_impact_trigger_eq2_fires_on_a_monotone_drop():
    y = _feed_speeds(_loop(), [0, 100, 100, 100, 100, 95, 85, 80, 75])
    # at w = 95: 95 > 0.9 * 100; at w = 85: 85 <= 95 <= 100 <= 100 and 85 <= 0.9 * 100 -> switch there
    assert list(y[:, 3]) == [0, 0, 0, 0, 0, 0, 1, 1, 1]
    assert y[6, 4] == pytest.approx(1.0 + 6 * 0.01)


def test_impact_trigger_ignores_noise_and_small_drops():
    y = _feed_speeds(_loop(), [0, 100, 99, 100, 99, 100, 98, 97, 96, 95, 94])  # < 10 % over 3 samples
    assert not y[:, 3].any()
    y = _feed_speeds(_loop(), [0, 100, 100, 100, 100, 95, 99, 80, 85, 70, 75])  # large but not monotone
    assert not y[:, 3].any()


def test_trigger_is_not_armed_at_a_standing_start():
    y = _feed_speeds(_loop(), [0.0] * 10, t0=0.6)
    assert not y[:, 3].any()


def test_trigger_fires_after_a_stiff_stop_with_one_count_jitter():
    # 100 Hz speed samples in encoder counts (2048 cpt: one count a sample = 0.307 rad/s), set speed 341 counts:
    # the speed alternates 341/342 before contact, the motor stops within a sample, rebounds, stands still.
    c = 2 * math.pi / 2048 / 0.01
    counts = [0, 341, 342, 341, 342, 150, -70, -40, 10, 0, 1, 0, 0, 0, 0]
    y = _feed_speeds(_loop(speed_rpm=341 * c * 60 / (2 * math.pi)), [k * c for k in counts])
    # armed at n = 1 (341 >= 0.5 x 341). Windows (w_n-3, w_n-2, w_n-1, w_n) up to n = 12 each hold a rise:
    # n = 5 (342 341 342 150) ... n = 12 (0 1 0 0); n = 13 (1 0 0 0): 0 <= 0 <= 0 <= 1 and 0 <= 0.9 -> switch
    assert list(y[:, 3]) == [0] * 13 + [1, 1]
    assert y[13, 4] == pytest.approx(1.0 + 13 * 0.01)


def test_dead_zone_compensation_eq1():
    loop = _loop(Kp=1e-4, Ki=0.0, e_min=5.0, i_min=0.2, profile="velocity")
    y = _feed_speeds(loop, [0, 90, 90])  # e = 10 > e_min, |i_PID| = 1e-3 < i_min -> +i_min
    assert y[-1, 0] == pytest.approx(0.2)
    y = _feed_speeds(_loop(Kp=1e-4, Ki=0.0, e_min=5.0, profile="velocity"), [0, 110, 110])  # e = -10
    assert y[-1, 0] == pytest.approx(-0.2)
    y = _feed_speeds(_loop(Kp=1e-4, Ki=0.0, e_min=5.0, profile="velocity"), [0, 98, 98])  # |e| < e_min -> i_PID
    assert y[-1, 0] == pytest.approx(1e-4 * 2.0)


def test_switch_holds_the_tightening_current_then_releases():
    loop = _loop(i_tight=1.5, hold_s=0.05)
    y = _feed_speeds(loop, [0, 100, 100, 100, 100, 95, 85] + [0.0] * 8)
    n_sw = 6
    assert np.all(y[n_sw:n_sw + 5, 0] == 1.5)
    assert np.all(y[n_sw + 5:, 0] == 0.0)


def test_staircase_profile():
    assert [staircase_current(t, 0.0, 0.1, 5.0, 2.5) for t in (0.0, 4.99, 5.0, 124.9, 125.0, 244.9, 245.0, 300.0)] \
        == pytest.approx([0.1, 0.1, 0.2, 2.5, 2.4, 0.1, 0.0, 0.0])
    steps = staircase_steps(0.0, 0.1, 5.0, 2.5)
    assert len(steps) == 50 and steps[24][:1] == (2.5,) and steps[-1][0] == 0.0
    loop = OuterLoop(rate=100.0, profile="staircase", step_A=0.1, step_s=5.0, top_A=2.5)
    loop.step(12.0)
    assert loop.y[0] == pytest.approx(0.3) and loop.y[3] == 1.0


# -- outer loop closed on the gripper plant -----------------------------------------------------------
@pytest.mark.slow
def test_outer_loop_closed_on_the_plant(gripper_dir):
    cfg = load_config(EXAMPLES / "gripper_impact.toml", gripper_overrides(gripper_dir) + ["run.stop=0.6"])
    res = run(cfg, progress=False)
    d = res.data
    t = d["time"]
    w_set = 1000 * 2 * math.pi / 60
    contact = t[np.nonzero(d["F_g"] > 0.0)[0][0]]
    # the ramp is tracked: within 5 % of 1000 rpm in the last 50 ms before contact
    before = (t > contact - 0.05) & (t < contact)
    assert_allclose(d["w_m"][before], w_set, rtol=0.05)
    # the trigger fires within 3 outer-loop samples of first contact
    t_sw = d["outer.t_switch"][-1]
    assert contact <= t_sw <= contact + 3 * 0.01
    # after the switch the held current is the set-point (1 A)
    after = t >= t_sw
    assert np.all(d["outer.i_q_ref"][after] == 1.0)
    settled = t >= t_sw + 0.05
    assert_allclose(np.mean(d["i_q"][settled]), 1.0, rtol=0.02)
