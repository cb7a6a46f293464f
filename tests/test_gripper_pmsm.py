"""PMSM FMU against hand-derived motor behaviour (issue 3): locked rotor, free run at 24 V, L_q/R_s.

References: gripper_params.csv values in ``PAPER`` (k_t = 0.13 N.m / 3.3 A, no-load speed 5600 rpm) and the
first-order RL response i(t) = v/R (1 - exp(-t R/L)) of a locked rotor.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from test_gripper_support import PAPER, Rk4Fmu

pytestmark = pytest.mark.slow  # the gripper FMUs, built once per session


@pytest.fixture()
def pmsm(gripper_fmus):
    inst = Rk4Fmu(gripper_fmus["PMSM"])
    yield inst
    inst.close()


def _run(inst, v_q, tau_load_fn, t_end, h):
    """RK4 with v_d = 0, constant v_q and tau_load = tau_load_fn(x) re-evaluated at every stage."""
    names = inst.state_names
    iq, w = names.index("motor.i_q"), names.index("motor.w")
    x = inst.states()
    ts, xs = [0.0], [x.copy()]

    def f(t, xx):
        u = {"v_d": 0.0, "v_q": v_q, "tau_load": tau_load_fn(xx[iq], xx[w])}
        return inst.deriv(t, xx, [u[n] for n in inst.inputs])

    n = int(round(t_end / h))
    for k in range(n):
        t = k * h
        k1 = f(t, x)
        k2 = f(t + h / 2, x + h / 2 * k1)
        k3 = f(t + h / 2, x + h / 2 * k2)
        k4 = f(t + h, x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        ts.append((k + 1) * h)
        xs.append(x.copy())
    return np.array(ts), np.array(xs), iq, w


def test_locked_rotor_current_and_torque(pmsm):
    # Lock the rotor by applying the hand-computed reaction k_t*i_q as load torque: the rotor stays at rest
    # only if the model's air-gap torque equals k_t*i_q (power-invariant Park, T = P*Psi_m*i_q = k_t*i_q).
    v_q = 0.9  # V -> 2 A locked
    k_t, R, L = PAPER["k_t"], PAPER["R_s"], PAPER["L_q"]
    t, x, iq, w = _run(pmsm, v_q, lambda i_q, w_: k_t * i_q, t_end=6e-3, h=5e-6)
    # steady state i_q = v_q / R_s (10.8 time constants: exp(-10.8) = 2e-5)
    assert_allclose(x[-1, iq], v_q / R, rtol=1e-4)
    # the rotor did not move: with a torque error e, w(6 ms) would be e*k_t*i*t/J = e*47 rad/s
    assert np.max(np.abs(x[:, w])) < 1e-6 * 47
    # the whole transient is the first-order RL step (RK4 at h = tau/111: error far below 1e-6)
    assert_allclose(x[:, iq], v_q / R * (1 - np.exp(-t * R / L)), atol=1e-6 * v_q / R)


def test_electrical_time_constant(pmsm):
    k_t, R, L = PAPER["k_t"], PAPER["R_s"], PAPER["L_q"]
    t, x, iq, _ = _run(pmsm, 0.45, lambda i_q, w_: k_t * i_q, t_end=3e-3, h=2e-6)
    i = x[:, iq] / (0.45 / R)
    # time to reach 1 - 1/e of the final value, interpolated; reference L_q/R_s = 0.556 ms
    tau = np.interp(1 - np.exp(-1), i, t)
    assert_allclose(tau, L / R, rtol=5e-3)


def test_free_run_reaches_no_load_speed(pmsm):
    # 24 V on q, no load: the datasheet no-load speed is 5600 rpm (paper Sec. 2); within 5 %.
    t, x, _, w = _run(pmsm, 24.0, lambda i_q, w_: 0.0, t_end=0.06, h=1e-5)
    w_end = x[-1, w]
    assert abs(x[-1, w] - x[-200, w]) < 1e-3 * w_end  # settled (mechanical time constant ~3 ms)
    assert_allclose(w_end, PAPER["omega_nl"], rtol=0.05)
