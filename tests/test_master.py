"""The co-simulation master: exact instants, ME integration against an independent reference,
ME-to-ME wiring, recorder output, determinism, Ctrl-C, and the shipped gripper configs end to end."""

import json
import math
from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg
from numpy.testing import assert_allclose, assert_array_equal
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

from cosim.cli import main
from cosim.config import load_config
from cosim.master import Engine, TimeBase, read_results, run, run_config


# -- time base ------------------------------------------------------------------------------------
def test_time_base_of_non_dividing_rates():
    tb = TimeBase({"foc": 26600, "rec": 1000, "outer": 100, "odd": 13})
    assert tb.base == 1729000  # lcm(26600, 1000, 100, 13)
    assert {n: c.period for n, c in tb.clocks.items()} == {"foc": 65, "rec": 1729, "outer": 17290, "odd": 133000}
    assert TimeBase({"a": 26.6e3, "b": "0.5"}).base == 26600


def test_instants_do_not_drift_over_1e7_steps():
    # the time of tick k is the correctly rounded k / base: equal to the exact rational, at every k
    tb = TimeBase({"foc": 26600, "rec": 1000}, start=0.0)
    ks = np.r_[np.arange(0, 2000), np.arange(10**7 - 2000, 10**7 + 1)] * tb.clocks["foc"].period
    for k in ks.tolist():
        assert tb.time(k) == float(Fraction(k, 133000))
    # a running sum of h would be off by many ulps by then
    h, t = 1 / 26600, 0.0
    for _ in range(10**5):
        t += h
    assert t != tb.time(10**5 * 5)
    assert tb.time(10**7 * 5) == 10**7 / 26600


def test_controllers_called_exactly_at_their_instants(master_dir):
    import sys

    cfg_path = osc_config(master_dir, extra="""
        [controllers.p1]
        class = "ctl.py:Probe"
        rate = 1000

        [controllers.p2]
        class = "ctl.py:Probe"
        rate = 300

        [controllers.p3]
        class = "ctl.py:Probe"
        rate = 7
        jit = false

        [[connections]]
        from = "plant.y"
        to = "p1.u"

        [[connections]]
        from = "p1.y"
        to = "p2.u"
        """, stop=3.0, rate=1000, record_rate=100)
    cfg = load_config(cfg_path)
    engine = Engine(cfg)
    result = engine.run(progress=False)
    assert result.calls == {"src": 3000, "p1": 3000, "p2": 900, "p3": 21}
    module = sys.modules[cfg.controllers["p1"].cls.__module__]
    calls = {name: module.CALLS[id(engine.controllers[name])] for name in ("p1", "p2", "p3")}
    for name, rate in (("p1", 1000), ("p2", 300), ("p3", 7)):
        expected = [float(Fraction(j, rate)) for j in range(len(calls[name]))]
        assert calls[name] == expected  # exact, not approximately
    assert len(result.data) == 301 and result.data["time"][-1] == 3.0
    # p1 runs before p2 at shared instants (dependency order): p2 sees p1's output of the same instant
    assert list(engine.layout.ctrl_order).index("p1") < list(engine.layout.ctrl_order).index("p2")


# -- integration against an independent reference ----------------------------------------------------
def _osc_zoh_reference(t_rec, k=9.0, c=0.5, amp=2.0, f=1.0, rate=1000):
    """Exact discretisation of the oscillator with its input held between the source's instants."""
    A = np.array([[0.0, 1.0], [-k, -c]])
    B = np.array([0.0, 1.0])
    T = 1.0 / rate
    M = scipy.linalg.expm(np.block([[A, B[:, None]], [np.zeros((1, 3))]]) * T)
    Ad, Bd = M[:2, :2], M[:2, 2]
    n = int(round(t_rec[-1] * rate))
    x = np.array([1.0, 0.0])
    xs = [x]
    for j in range(n):
        x = Ad @ x + Bd * amp * math.sin(2 * math.pi * f * j / rate)
        xs.append(x)
    xs = np.array(xs)
    idx = np.rint(t_rec * rate).astype(int)
    return 2 * xs[idx, 0], xs[idx, 1]


@pytest.mark.parametrize("solver", ['[solver]\nmethod = "rk4"\nsubsteps = 1', '[solver]\nmethod = "rk4"\nsubsteps = 4'])
def test_me_integration_matches_exact_zoh_solution(master_dir, solver):
    cfg = load_config(osc_config(master_dir, solver=solver, stop=3.0))
    res = run(cfg, progress=False)
    y_ref, v_ref = _osc_zoh_reference(res.data["time"])
    rng = np.ptp(y_ref)
    # RK4 at 1 ms on a 3 rad/s oscillator: local error ~ (h w)^5 -> 1e-4 of range is a loose bound
    assert_allclose(res.data["y"], y_ref, atol=1e-4 * rng, rtol=0)
    assert_allclose(res.data["v_out"], v_ref, atol=1e-4 * np.ptp(v_ref), rtol=0)
    assert np.max(np.abs(res.data["y"] - y_ref)) < 1e-8 * rng  # in fact RK4 is far tighter here


@pytest.mark.parametrize("kind", ["ME", "CS"])
def test_fmi2_fmu_me_and_cs(master_dir, kind):
    # the hand-written FMI 2.0 FMU: ME integrated by the master, CS stepping itself (10 RK4 steps per doStep)
    cfg = load_config(osc_config(master_dir, stop=2.0), ["fmus.plant.path=Osc2.fmu", f"fmus.plant.kind={kind}",
                                                         'record.signals=["plant.y", "src.u"]'])
    assert cfg.fmus["plant"].info.fmi_version == 2
    res = run(cfg, progress=False)
    y_ref, _ = _osc_zoh_reference(res.data["time"])
    assert_allclose(res.data["y"], y_ref, atol=1e-4 * np.ptp(y_ref), rtol=0)


def _zoh_chain(u_samples, rate, k=9.0, c=0.5):
    """Exact ZOH response (y = 2 x at the instants) of the oscillator to samples held between instants."""
    A = np.array([[0.0, 1.0], [-k, -c]])
    M = scipy.linalg.expm(np.block([[A, np.array([[0.0], [1.0]])], [np.zeros((1, 3))]]) / rate)
    x = np.array([1.0, 0.0])
    ys = []
    for u in u_samples:
        ys.append(2 * x[0])
        x = M[:2, :2] @ x + M[:2, 2] * u
    return np.array(ys)


def test_cs_fmu_feeding_an_me_fmu(master_dir):
    # src (1 kHz sine) -> Osc2 as Co-Simulation (FMI 2) -> y held -> Osc as Model Exchange (FMI 3)
    cfg = load_config(osc_config(master_dir, stop=1.0, record_rate=1000, extra="""
        [fmus.cs]
        path = "Osc2.fmu"
        kind = "CS"
        parameters = { k = 9.0 }
        """), ['connections=[{from = "src.u", to = "cs.u"}, {from = "cs.y", to = "plant.u"}]',
               'record.signals=["cs.y", "plant.y", "src.u"]'])
    res = run(cfg, progress=False)
    n = len(res.data)
    u = [2.0 * math.sin(2 * math.pi * j / 1000) for j in range(n)]
    y_cs = _zoh_chain(u, 1000)
    y_me = _zoh_chain(y_cs, 1000)
    assert_allclose(res.data["cs.y"], y_cs, atol=1e-6 * np.ptp(y_cs))
    assert_allclose(res.data["plant.y"], y_me, atol=1e-6 * np.ptp(y_me))


def test_implicit_solver_option_matches(master_dir):
    cfg = load_config(osc_config(master_dir, solver='[solver]\nmethod = "bdf"\nrtol = 1e-9\natol = 1e-11',
                                 stop=1.0, rate=100, record_rate=100))
    res = run(cfg, progress=False)
    y_ref, _ = _osc_zoh_reference(res.data["time"], rate=100)
    assert_allclose(res.data["y"], y_ref, atol=1e-4 * np.ptp(y_ref), rtol=0)


def test_gain_and_offset_routing(master_dir):
    # gain 0 and offset 0.5: the plant sees a constant 0.5 N
    cfg = load_config(osc_config(master_dir, stop=1.0), ["connections.0.gain=0.0", "connections.0.offset=0.5"])
    res = run(cfg, progress=False)
    y_ref, _ = _osc_zoh_reference(res.data["time"], amp=0.0)
    x_static = 0.5 / 9.0  # the constant force shifts the equilibrium: superpose its step response
    A = np.array([[0.0, 1.0], [-9.0, -0.5]])
    resp = np.array([(scipy.linalg.expm(A * t) @ np.array([-x_static, 0.0]))[0] + x_static for t in res.data["time"]])
    assert_allclose(res.data["y"], y_ref + 2 * resp, atol=1e-8)


@pytest.mark.slow
def test_split_plant_equals_the_whole_plant(gripper_dir):
    # GripperPlant vs PMSM + Drivetrain integrated together: same equations, same scheme
    sets = ["run.stop=0.45"]
    whole = run(load_config(EXAMPLES / "gripper_impact.toml", gripper_overrides(gripper_dir) + sets), progress=False)
    split = run(load_config(EXAMPLES / "gripper_impact_split.toml", gripper_overrides(gripper_dir, True) + sets),
                progress=False)
    assert whole.data["F_g"].max() > 50.0  # the run includes the impact
    for name in ("F_g", "i_q", "i_d", "w_m", "x_jaw", "outer.i_q_ref"):
        rng = np.ptp(whole.data[name]) or 1.0
        assert_allclose(split.data[name], whole.data[name], atol=1e-9 * rng, rtol=0, err_msg=name)


# -- outputs -----------------------------------------------------------------------------------------
def test_results_parquet_csv_summary_plot(master_dir, tmp_path):
    out = tmp_path / "out"
    result, summary, files = run_config(osc_config(master_dir), out=out, csv=True, progress=False)
    names = sorted(p.name for p in files)
    assert names == ["results.csv", "results.parquet", "signals.png", "summary.json"]
    data, units, meta = read_results(out / "results.parquet")
    assert data.dtype.names == ("time", "y", "v_out", "src.u")
    assert units == {"time": "s", "y": "m", "v_out": "m/s", "src.u": ""}
    assert json.loads(meta["cosim.config"])["fmus"]["plant"]["parameters"] == {"k": 9.0}
    assert_array_equal(data["y"], result.data["y"])
    csv = np.loadtxt(out / "results.csv", delimiter=",", skiprows=1)
    assert_allclose(csv[:, 1], result.data["y"], rtol=1e-9)
    s = json.loads((out / "summary.json").read_text())
    assert s["controller_calls"] == {"src": 2000} and s["interrupted"] is False


def test_determinism(master_dir):
    cfg = load_config(osc_config(master_dir, stop=1.0))
    a = run(cfg, progress=False).data
    b = run(cfg, progress=False).data
    assert a.tobytes() == b.tobytes()


def test_ctrl_c_keeps_what_was_recorded(master_dir, tmp_path, capsys):
    cfg = osc_config(master_dir, extra="""
        [controllers.probe]
        class = "ctl.py:Probe"
        rate = 100
        jit = false
        parameters = { interrupt_at = 0.5 }
        """, stop=2.0)
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out)]) == 130
    assert "interrupted" in capsys.readouterr().err
    data, _, meta = read_results(out / "results.parquet")
    assert meta["cosim.interrupted"] == "true"
    assert data["time"][-1] == pytest.approx(0.49) and len(data) == 50
    assert json.loads((out / "summary.json").read_text())["interrupted"] is True


def test_progress_bar_on_stderr(master_dir, capsys):
    run(load_config(osc_config(master_dir, stop=0.5)), progress=True)
    assert "sim s" in capsys.readouterr().err


# -- shipped gripper configs end to end (shortened) ----------------------------------------------------
@pytest.mark.slow
def test_static_config_end_to_end(gripper_dir, tmp_path):
    out = tmp_path / "static"
    sets = gripper_overrides(gripper_dir) + ["controllers.outer.parameters.step_A=0.5",
                                             "controllers.outer.parameters.step_s=0.15", "run.stop=1.5"]
    args = ["run", str(EXAMPLES / "gripper_static.toml"), "--out", str(out), "--no-progress"]
    assert main(args + [x for s in sets for x in ("--set", s)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert list(s["force_up_N"]) == ["0.5", "1.0", "1.5", "2.0", "2.5"]
    assert list(s["force_down_N"]) == ["2.0", "1.5", "1.0", "0.5", "0.0"]
    assert s["residual_force_N"] == s["force_down_N"]["0.0"]
    assert s["max_force_N"] >= max(s["force_up_N"].values()) > 20.0
    assert (out / "static.png").stat().st_size > 10_000


@pytest.mark.slow
def test_impact_config_end_to_end(gripper_dir, tmp_path):
    out = tmp_path / "impact"
    sets = gripper_overrides(gripper_dir) + ["run.stop=0.9", "controllers.outer.parameters.hold_s=0.5"]
    args = ["run", str(EXAMPLES / "gripper_impact.toml"), "--out", str(out), "--no-progress", "--csv"]
    assert main(args + [x for s in sets for x in ("--set", s)]) == 0
    s = json.loads((out / "summary.json").read_text())
    for key in ("peak_force_N", "min_force_after_peak_N", "steady_force_N"):
        assert isinstance(s[key], float)
    assert s["peak_force_N"] > s["steady_force_N"] > 10.0
    assert s["t_switch_s"] is not None and s["t_switch_s"] >= s["t_contact_s"]
    data, units, _ = read_results(out / "results.parquet")
    assert units["F_g"] == "N" and units["i_q"] == "A" and units["w_m"] == "rad/s"
