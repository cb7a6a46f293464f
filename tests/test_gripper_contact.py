"""Finger contacts of the gripper plant (issue 3): coating force-deflection slopes, contact opening, steady
gripping force at a held current.

References: the paper's stiffnesses (k_f FEM 1.46e6 N/m, k_cyl 3.53e7 N/m, k_P1..3, k_H = 100 k_P; values in
``PAPER``) combined by hand as springs in series, and the torque balance of the drive written out below.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from test_gripper_support import PAPER, Rk4Fmu, load_conditions, simulate_cvode

pytestmark = pytest.mark.slow  # the gripper FMUs, built once per session

CONDITIONS = load_conditions()


def _force_at(dt, x0, i_x, i_v, x, v=0.0):
    """Gripping force of the Drivetrain FMU with the jaw state set to position x and velocity v."""
    s = x0.copy()
    s[i_x], s[i_v] = x, v
    return dt.out(0.0, s, [0.0, 0.0])["F_g"]


@pytest.mark.parametrize("coating", ["P1", "P2", "P3"])
def test_coating_slopes(gripper_fmus, coating):
    """Coating deflection = penetration - F*(1/k_f + 1/k_obj): its force-deflection slope is k_P up to the region
    boundary d_lim, then k_H = 100 k_P (each within 1 %)."""
    cond = dict(CONDITIONS[f"{coating}_dynamic_abs"])
    dt = Rk4Fmu(gripper_fmus["Drivetrain"], cond)
    try:
        x0 = dt.states()
        i_x, i_v = dt.state_names.index("drive.jaw.x"), dt.state_names.index("drive.jaw.v")
        k_P, k_H = PAPER["k_P"][coating], PAPER["k_H_ratio"] * PAPER["k_P"][coating]
        c_rest = 1 / PAPER["k_f"] + 1 / PAPER["k_cyl"]  # finger and ABS cylinder in series with the coating
        touch = cond["gap0"] - cond["t_coat"]  # jaw position where the coating touches the object
        d_lim = cond["d_lim"]
        # penetrations giving coating deflections at 20 %/60 % of d_lim and 0.2/0.6 mm past it
        pen_lim = d_lim + k_P * d_lim * c_rest
        pens = {
            "P": [0.2 * pen_lim, 0.6 * pen_lim],
            "H": [pen_lim + 2e-4 * (1 + k_H * c_rest), pen_lim + 6e-4 * (1 + k_H * c_rest)],
        }
        for region, (p1, p2) in pens.items():
            f1, f2 = (_force_at(dt, x0, i_x, i_v, touch + p) for p in (p1, p2))
            d1, d2 = p1 - f1 * c_rest, p2 - f2 * c_rest
            slope = (f2 - f1) / (d2 - d1)
            assert_allclose(slope, k_P if region == "P" else k_H, rtol=0.01)
    finally:
        dt.close()


@pytest.mark.parametrize("condition", ["bare_dynamic_abs", "P3_dynamic_abs", "bare_static_al"])
def test_contact_opens_and_cannot_pull(gripper_fmus, condition):
    cond = dict(CONDITIONS[condition])
    dt = Rk4Fmu(gripper_fmus["Drivetrain"], cond)
    try:
        x0 = dt.states()
        i_x, i_v = dt.state_names.index("drive.jaw.x"), dt.state_names.index("drive.jaw.v")
        touch = cond["gap0"] - cond["t_coat"]
        assert _force_at(dt, x0, i_x, i_v, touch - 1e-6) == 0.0  # gap open: no force
        assert _force_at(dt, x0, i_x, i_v, touch - 1e-6, v=0.1) == 0.0  # approaching, not yet touching
        assert _force_at(dt, x0, i_x, i_v, touch + 1e-9, v=-0.5) == 0.0  # separating fast: never pulls
        # continuous at first touch: a tiny penetration at closing speed gives a tiny force
        assert 0 < _force_at(dt, x0, i_x, i_v, touch + 1e-9, v=0.03) < 0.01
    finally:
        dt.close()


@pytest.mark.parametrize("condition", ["bare_dynamic_abs", "P3_dynamic_abs", "P3_static_al"])
@pytest.mark.parametrize("current", [1.0, 2.0])
def test_steady_gripping_force_torque_balance(gripper_fmus, condition, current):
    """Close on the object at a constant voltage v_q = R_s*i (the current is i once at rest) and compare the
    steady force with the hand-derived balance: motor torque k_t*i minus the no-load drag T_c0 (closing motion:
    friction opposes closing), times eta_g*28 through the gear (power flows motor -> load), shared by the two
    racks of the pinion (2*r_p*F_g); the guide friction is regularised and vanishes at rest."""
    eta = 0.68
    cond = dict(CONDITIONS[condition], eta_g=eta)
    t = np.array([0.0, 5.0])
    res = simulate_cvode(
        gripper_fmus["GripperPlant"], cond, t, {"v_d": 0 * t, "v_q": PAPER["R_s"] * current + 0 * t}, stop_time=5.0
    )
    F_hand = eta * PAPER["ratio"] * (PAPER["k_t"] * current - PAPER["T_c0"]) / (2 * PAPER["r_p"])
    assert_allclose(res["F_g"][-1], F_hand, rtol=0.01)
    assert_allclose(res["i_q"][-1], current, rtol=1e-3)
