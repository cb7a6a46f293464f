"""The third truth of the gripper's dynamic experiments (``diagnose_truth3_impact.py``) against independent
references: closed forms of its steady states and of its friction and coating laws, scipy on the hand-written
equations of the guides, the coating and the load cell, the gear's play seen by the encoder at a reversal, and the
size of every hidden effect.

The drivetrain values (``eta_g``, ``T_c0``) and the effects' draws come from one seed drawn once at random
(``python -c "import secrets; print(secrets.randbelow(2**31))"`` gave 1554713424), not picked.
"""

import math

import numpy as np
import pytest
from scipy import signal
from scipy.integrate import solve_ivp

import diagnose_truth2_impact as truth2
import diagnose_truth3_impact as truth3
from diagnose_truth3_impact import (DT, GMS_PHI, GMS_SIGMA1, GMS_WEIGHTS, P_TH, PRONY_TAU, SIGMA0_G, STRIBECK_M, W_S,
                                    simulate)
from diagnose_truth_impact import (B_R, C_GREASE, CONDITION, F_GUIDE, K_T, OMEGA_MAX, R_P, RATIO, SHOWN_IN,
                                   SPEED_PROFILE, T_MAX, check_effect_changes_record, check_play_seen_at_reversal,
                                   check_seed_gives_same_case, make_case)

SEED = 1554713424
DRAWS = [truth3.draw_truth("none", rng) for rng in [np.random.default_rng(SEED)] for _ in range(3)]
IDS = ["draw0", "draw1", "draw2"]
GAIN = RATIO / (2 * R_P)  # rack force per motor torque, ideal gear


def _bearing(eta):
    """The paper's eq. (9) bearing damping at the gear output [N.m.s/rad]."""
    return T_MAX * (1 - eta) * RATIO ** 2 / OMEGA_MAX


@pytest.mark.parametrize("draw", DRAWS, ids=IDS)
def test_free_running_speed_matches_the_closed_form_balance(draw):
    """No object within reach, 1 A held 2 s: the speed settles where ``K_T i - T_c0 = B_R w + B_g w/N^2 +
    tau_out/(N eta)``, ``tau_out = 2 r_p (C_grease v + F_guide)``, ``v = w r_p/N`` (GMS and Dahl at their Coulomb
    levels far above the Stribeck speeds, the power far above ``P_TH``, the churning drag outside the efficiency).
    After 1.95 s the transient (~0.12 s) is below 1e-6; rtol 1e-4 covers the angle difference."""
    eta, T_c0 = draw["eta_g"], draw["T_c0"]
    t, _, _, contact, theta, _, _ = simulate(draw, gap0=10.0, profile=((0.0, 1.0), (2.0, 1.0)))
    assert np.all(contact == 0.0)
    speed = (theta[-1] - theta[-11]) / (t[-1] - t[-11])
    slope = B_R + _bearing(eta) / RATIO ** 2 + 2 * R_P ** 2 * C_GREASE / (RATIO ** 2 * eta)
    np.testing.assert_allclose(speed, (K_T - T_c0 - 2 * R_P * F_GUIDE / (RATIO * eta)) / slope, rtol=1e-4)


@pytest.mark.parametrize("draw", DRAWS, ids=IDS)
def test_speed_run_current_matches_the_closed_form_balance(draw):
    """The speed run's held speeds (jaws free): the mean current over the second half of each hold is the torque
    balance at that speed over ``K_T``, with the Stribeck level ``T_c0 (1 + 0.15 exp(-sqrt(w/W_S)))`` and the
    efficiency factor ``1 + (1/eta - 1) tanh(P/P_TH)`` at the output power ``P`` (comparable to ``P_TH`` here).
    rtol 1e-4 (the PI loop's residual transient)."""
    eta, T_c0 = draw["eta_g"], draw["T_c0"]
    t, reference, _, _, _, current, _ = simulate(draw, "speed")
    for (start, w), (end, _) in zip(SPEED_PROFILE[2::2], SPEED_PROFILE[3::2]):
        window = (t >= 0.5 * (start + end)) & (t < end)
        tau_out = 2 * R_P * (C_GREASE * w * R_P / RATIO + F_GUIDE)
        factor = 1 + (1 / eta - 1) * math.tanh(tau_out * w / RATIO / P_TH)
        level = T_c0 * (1 + (STRIBECK_M - 1) * math.exp(-math.sqrt(w / W_S)))
        torque = level + B_R * w + _bearing(eta) * w / RATIO ** 2 + tau_out / RATIO * factor
        np.testing.assert_allclose(current[window].mean(), torque / K_T, rtol=1e-4)


@pytest.mark.parametrize("draw", DRAWS, ids=IDS)
def test_slow_tightening_settles_near_the_kinetic_balance_on_fungs_law(draw):
    """The object 0.2 mm from the coating, the current ramped to 1 A in 0.6 s and held. (1) The held force is the
    kinetic tightening balance ``eta (K_T i - T_c0) N/(2 r_p) - F_guide`` up to the stick-slip the Stribeck curve
    makes at creeping speeds (the rotor breaks away at the static level ``1.15 T_c0`` and slips past the kinetic
    equilibrium by about its distance to the static one), + 0.5 N; it creeps by < 0.05 N over the last 0.3 s (no
    gear loss at standstill). (2) Wherever the jaw rests, its travel is Fung's closed form: ``x = gap + F/k_s +
    d0 ln(1 + F/(k_P d0))``, to 1 nm. (3) The 1000 Hz load cell reads the contact force."""
    eta, T_c0 = draw["eta_g"], draw["T_c0"]
    kinetic = eta * (K_T - T_c0) * GAIN - F_GUIDE
    static = eta * (K_T - STRIBECK_M * T_c0) * GAIN - F_GUIDE
    t, _, reading, contact, _, _, x = simulate(draw, gap0=CONDITION["t_coat"] + 2e-4,
                                               profile=((0.0, 0.0), (0.05, 0.0), (0.65, 1.0), (1.0, 1.0)))
    assert abs(contact[-1] - kinetic) <= (kinetic - static) + 0.5, (contact[-1], static, kinetic)
    assert np.ptp(contact[-30:]) < 0.05
    k_s = 1.0 / (1.0 / truth3.K_F + 1.0 / CONDITION["k_obj"])
    d0 = CONDITION["d_lim"] / math.log(CONDITION["k_H_ratio"])
    resting = (contact > 1.0) & (np.abs(np.gradient(x, t)) < 1e-5)
    assert resting.sum() > 30
    travel = 2e-4 + contact / k_s + d0 * np.log1p(contact / (CONDITION["k_P"] * d0))
    np.testing.assert_allclose(x[resting], travel[resting], atol=1e-9)
    assert abs(reading[-1] - contact[-1]) < 1e-3


@pytest.mark.parametrize("draw", DRAWS, ids=IDS)
def test_force_held_after_the_impact_lies_in_the_static_friction_band(draw):
    """After the impact at 1 A the drivetrain holds any force between the tightening limit (the motor against the
    static friction, through ``eta``) and the back-driving limit (the load through ``eta`` against the motor and
    the static friction), plus the guides' ``F_guide``; the held force lies in that band and is constant (< 0.05 N
    over the last 0.3 s)."""
    eta, T_c0 = draw["eta_g"], draw["T_c0"]
    low = eta * (K_T - STRIBECK_M * T_c0) * GAIN - F_GUIDE
    high = (K_T + STRIBECK_M * T_c0) * GAIN / eta + F_GUIDE
    _, _, _, contact, _, _, _ = simulate(draw)
    assert low <= contact[-1] <= high, (low, contact[-1], high)
    assert np.ptp(contact[-30:]) < 0.05


def test_motor_friction_follows_the_maxwell_slip_virgin_curve_and_unloads_on_reversal():
    """The GMS friction alone, driven at a slow constant speed from rest and then back: loading follows the
    Maxwell-slip virgin curve ``sum_i min(k_i theta, w_i L)`` (``k_i = w_i T_c0/phi_i``; plus the stuck elements'
    micro-damping). Reversed by ``Delta`` from forces ``F_i`` just above their shares (as right after a breakaway,
    still relaxing to them), every element sticks and unloads: ``sum_i max(F_i - k_i Delta, -w_i L)`` (Masing's
    rule ``T_max - 2 virgin(Delta/2)`` when ``F_i`` is the share). Tolerance: one step's spring increment; the step
    at which an element breaks away (its damping on or off) is left out."""
    T_c0, level, speed, steps = 8e-3, 8e-3 * STRIBECK_M, 1e-2, 80000
    force, slipping = np.zeros(4), np.zeros(4)
    stiffness, caps = GMS_WEIGHTS * T_c0 / GMS_PHI, GMS_WEIGHTS * level
    torque = np.array([truth3._gms(force, slipping, speed, level, T_c0) for _ in range(steps)])
    angle = speed * DT * np.arange(1, steps + 1)
    stuck = stiffness * angle[:, None] < caps
    virgin = np.minimum(stiffness * angle[:, None], caps).sum(1) + (stuck * GMS_WEIGHTS).sum(1) * GMS_SIGMA1 * speed
    clear = np.all(np.abs(stiffness * angle[:, None] - caps) > 2 * stiffness * speed * DT, axis=1)
    np.testing.assert_allclose(torque[clear], virgin[clear], atol=stiffness.max() * speed * DT)
    force *= 1.001
    start = force.copy()
    back = np.array([truth3._gms(force, slipping, -speed, level, T_c0) for _ in range(steps)])
    unloaded = start - stiffness * angle[:, None]
    still = unloaded > -caps
    unloading = np.maximum(unloaded, -caps).sum(1) - (still * GMS_WEIGHTS).sum(1) * GMS_SIGMA1 * speed
    clear = np.all(np.abs(unloaded + caps) > 2 * stiffness * speed * DT, axis=1)
    np.testing.assert_allclose(back[clear], unloading[clear], atol=2 * stiffness.max() * speed * DT)


def test_guide_friction_matches_dahls_law_integrated_by_scipy():
    """The guides' Dahl friction (exponent 2) under a sinusoidal jaw speed, stepped as the truth steps it, against
    ``solve_ivp`` of ``dF/dt = SIGMA0_G v |u| u``, ``u = 1 - F sgn(v)/L``. The exact step at the step's speed is
    first order in the speed's change: tolerance 1 % of the level."""
    level, amplitude, f = 2.0, 2e-3, 5.0
    time = np.arange(int(0.4 / DT)) * DT
    speeds = amplitude * np.sin(2 * np.pi * f * time)
    F, stepped = 0.0, np.empty(len(time))
    for k, v in enumerate(speeds):
        stepped[k] = F
        F = truth3._dahl(F, v, level)

    def rate(t, y):
        v = amplitude * np.sin(2 * np.pi * f * t)
        u = 1 - y[0] * np.sign(v) / level
        return [SIGMA0_G * v * abs(u) * u]

    reference = solve_ivp(rate, (0, time[-1]), [0.0], t_eval=time[::50], method="LSODA", rtol=1e-9, atol=1e-9,
                          max_step=1e-4).y[0]
    np.testing.assert_allclose(stepped[::50], reference, atol=0.01 * level)


def test_coating_with_relaxation_matches_scipy_on_its_equations():
    """The object pushed 0.4 mm into the coating over 5 ms and held 0.3 s, the coating with its Prony terms: the
    contact force from the truth's implicit solve against ``solve_ivp`` of the hand-written equations (the
    damper's rate from the series balance ``k_s (pen - delta) = E(delta) + C(delta) delta' + sum q_j``, ``q_j' =
    k_j delta' - q_j/tau_j``, Fung's ``E``, ``C = C_p (E'/k_P)^beta``). First-order in ``DT``: rtol 1e-3 after
    the first 10 ms."""
    truth = {**DRAWS[0], "k_rel": 1.5, "alpha_rel": 0.4}
    coat, prony_k = truth3._coat_array(truth), truth3.prony_stiffnesses(truth)
    k_s, k_P, d0, d_lim, C_p, beta = coat[:6]
    time = np.arange(int(0.3 / DT)) * DT

    def pen_at(t):
        return 4e-4 * min(t / 5e-3, 1.0)

    q, delta, force = np.zeros(len(prony_k)), 0.0, np.empty(len(time))
    for k, t in enumerate(time):
        delta, force[k] = truth3._contact(pen_at(t + DT), delta, q, prony_k, coat, 1.0)

    def rate(t, y):
        d = y[0]
        elastic = k_P * d0 * math.expm1(d / d0)
        damping = C_p * math.exp(beta * d / d0)
        d_rate = (k_s * (pen_at(t) - d) - elastic - y[1:].sum()) / damping
        return np.concatenate([[d_rate], prony_k * d_rate - y[1:] / PRONY_TAU])

    y = solve_ivp(rate, (0, time[-1] + DT), np.zeros(1 + len(prony_k)), t_eval=time + DT, method="Radau",
                  rtol=1e-9, atol=1e-13).y
    later = time > 0.01
    np.testing.assert_allclose(force[later], (k_s * (np.vectorize(pen_at)(time + DT) - y[0]))[later], rtol=1e-3)
    assert force[-1] < 0.8 * force[np.searchsorted(time, 0.006)]  # it relaxed


@pytest.mark.parametrize("f_lc", [1000.0, 8.0])
def test_load_cell_filter_matches_scipy(f_lc):
    """The load cell's first-order filter stepped with a unit force from rest against ``scipy.signal.step`` of
    ``1/(s/w + 1)``: the exact discretisation agrees to rounding."""
    decay, n = math.exp(-2 * math.pi * f_lc * DT), int(round(5.0 / (f_lc * DT)))
    y, reading = 0.0, np.empty(n)
    for k in range(n):
        reading[k] = y
        y = truth3._lag_step(y, 1.0, decay)
    _, reference = signal.step(signal.lti([1.0], [1 / (2 * np.pi * f_lc), 1.0]), T=np.arange(n) * DT)
    np.testing.assert_allclose(reading, reference, atol=1e-9)


@pytest.mark.parametrize("lag", [1, 10])
def test_load_cell_moving_average_matches_scipy(lag):
    """The effect's 2-sample moving average of the 100 Hz conversions (``lag`` record samples apart: impact 1,
    slide 10) against ``scipy.signal.lfilter([0.5, 0.5], 1)`` on the conversions (the value before the record
    taken as the record's first), plus the offset."""
    filtered = np.random.default_rng(SEED).normal(size=200)
    reading = truth3.load_cell_reading(filtered, lag, True, 1.5)
    for phase in range(lag):
        conversions = filtered[phase::lag]
        reference = signal.lfilter([0.5, 0.5], [1.0], conversions, zi=[0.5 * filtered[0]])[0] + 1.5
        np.testing.assert_allclose(reading[phase::lag], reference, atol=1e-12)
    np.testing.assert_array_equal(truth3.load_cell_reading(filtered, lag, False, 0.0), filtered)


@pytest.mark.parametrize("play_deg", [0.4, 0.8, 1.5])
def test_gear_play_shows_in_the_encoder_at_a_reversal(play_deg):
    """Jaws free, 0.3 A closing then -0.3 A opening: between steady closing and steady opening the encoder turns
    back by the jaws' travel times N/r_p plus the play times N, within 2 counts (``check_play_seen_at_reversal``)."""
    check_play_seen_at_reversal(simulate, DRAWS[0], play_deg)


def test_cogging_spectrum_is_the_drawn_detent_and_eccentricity():
    """Over one revolution the cogging torque's spectrum holds only harmonics 24, 48, 72 (amplitudes in the drawn
    ratios) and their +-1 sidebands from the eccentricity (``eps/2`` of each); its peak is the drawn ``T_cog``."""
    truth = truth3.draw_truth("cogging", np.random.default_rng(SEED))
    cog = truth3.cogging_coefficients(truth)
    angle = np.linspace(0.0, 2 * np.pi, 24 * 256, endpoint=False)
    torque = np.array([truth3._cogging(a, cog) for a in angle])
    assert abs(np.abs(torque).max() - truth["T_cog"]) < 1e-12
    spectrum = np.abs(np.fft.rfft(torque)) * 2 / len(angle)
    ratios = {24: 1.0, 48: truth["ratio_cog2"], 72: truth["ratio_cog3"]}
    for harmonic, ratio in ratios.items():
        np.testing.assert_allclose(spectrum[harmonic], cog[0] * ratio, rtol=1e-9)
        np.testing.assert_allclose(spectrum[[harmonic - 1, harmonic + 1]], cog[0] * ratio * truth["eps_cog"] / 2,
                                   rtol=1e-9)
    others = np.delete(spectrum, [h + s for h in ratios for s in (-1, 0, 1)])
    assert others.max() < 1e-12 * cog[0]


def test_a_seed_gives_the_same_case_and_the_other_truths_baseline():
    """One seed: the same records twice, and the same ``eta_g``, ``T_c0`` and play as the first and second
    truths' cases (``draw_baseline`` first)."""
    check_seed_gives_same_case(truth3.make_case_impact3, [lambda rng: make_case("gear_play", rng)[1],
                                                          lambda rng: truth2.draw_truth("gear_play", rng)], SEED)


@pytest.mark.parametrize("effect", sorted(SHOWN_IN) + ["none"])
def test_every_effect_changes_the_record_measurably(effect):
    """Each hidden effect, drawn from the seed, changes its experiment's noise-free record by more than a fifth of
    the compared channel's noise or more than a count of the encoder (RMS); ``none`` changes nothing."""
    check_effect_changes_record(truth3.make_case_impact3, truth3.effect_signal3, effect, SEED)
