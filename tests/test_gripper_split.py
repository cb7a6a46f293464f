"""Split versus whole (issue 3): PMSM + Drivetrain coupled in a plain fixed-step loop reproduce GripperPlant.

Scenario: 0.5 s, constant v_q = 2 V from rest, bare fingers on ABS with a 2.5 mm gap: the jaws accelerate, cross
the play, hit the object (~0.15 s) and settle at the stall current. The reference is the whole plant under
CVode (rtol 1e-8). The coupled loop is Jacobi with zero-order hold at the FOC period h = 37.6 us (the master's
step): each FMU takes one RK4 step with the other's outputs from the start of the step.
"""

import numpy as np
import pytest

from test_gripper_support import Rk4Fmu, load_conditions, simulate_cvode

pytestmark = pytest.mark.slow  # the gripper FMUs, built once per session

H = 1 / 26600
T_END = 0.5
V_Q = 2.0
PARAMS = dict(load_conditions()["bare_dynamic_abs"], gap0=0.0025)
SIGNALS = ("F_g", "w_m", "i_q", "x_jaw")


def run_split(fmus, h=H, t_end=T_END):
    """Jacobi/ZOH co-simulation of PMSM and Drivetrain; returns time and a dict signal -> array."""
    motor = Rk4Fmu(fmus["PMSM"], {k: v for k, v in PARAMS.items() if k in ("eta_g",)})
    drive = Rk4Fmu(fmus["Drivetrain"], PARAMS)
    try:
        xm, xd = motor.states(), drive.states()
        n = int(round(t_end / h))
        out = {s: np.empty(n + 1) for s in SIGNALS}
        times = np.arange(n + 1) * h
        for k in range(n + 1):
            t = k * h
            # outputs at the communication point t_k (both FMUs' outputs depend on their states only here,
            # except the drivetrain torque, which also depends directly on the motor speed it receives)
            om = motor.out(t, xm, _inputs(motor, v_d=0.0, v_q=V_Q, tau_load=0.0))
            od = drive.out(t, xd, _inputs(drive, theta_m=om["theta_m"], w_m=om["w_m"]))
            out["F_g"][k], out["x_jaw"][k] = od["F_g"], od["x_jaw"]
            out["w_m"][k], out["i_q"][k] = om["w_m"], om["i_q"]
            if k == n:
                break
            um = _inputs(motor, v_d=0.0, v_q=V_Q, tau_load=od["tau_load"])
            ud = _inputs(drive, theta_m=om["theta_m"], w_m=om["w_m"])
            xm = motor.rk4_step(t, xm, um, h)
            xd = drive.rk4_step(t, xd, ud, h)
        return times, out
    finally:
        motor.close()
        drive.close()


def _inputs(inst, **values):
    return [values[n] for n in inst.inputs]


def run_whole(fmus, t_end=T_END):
    t = np.array([0.0, t_end])
    res = simulate_cvode(fmus["GripperPlant"], PARAMS, t, {"v_d": 0 * t, "v_q": V_Q + 0 * t}, stop_time=t_end,
                         output_interval=1e-4, rtol=1e-8)
    return res["time"], {s: res[s] for s in SIGNALS}


def split_error(fmus):
    """Max |split - whole| / range(whole) per signal, on the split's time grid."""
    ts, split = run_split(fmus)
    tw, whole = run_whole(fmus)
    return {s: np.max(np.abs(split[s] - np.interp(ts, tw, whole[s]))) / np.ptp(whole[s]) for s in SIGNALS}, whole


def test_split_matches_whole_on_impact(gripper_fmus):
    err, whole = split_error(gripper_fmus)
    assert np.max(whole["F_g"]) > 50  # an impact happened and the force built up
    for s in SIGNALS:
        assert err[s] < 0.02, f"{s}: split vs whole {err[s]:.2%} of range"
