"""The fourth truth of the gripper's dynamic experiments (``diagnose_truth4_impact.py``) against independent
references: closed forms of its steady states and of its friction, coating, fractional and load-cell laws, scipy on
the hand-written equations of the motor friction and the guides' state, the gear's play seen by the encoder at a
reversal, and the size of every hidden effect. No diagnosis is run on this truth here: it is reserved for the
evaluation of issue #42.

The drivetrain values (``eta_g``, ``T_c0``) and the effects' draws come from one seed drawn once at random
(``python -c "import secrets; print(secrets.randbelow(2**31))"`` gave 1095907558), not picked.
"""

import math

import numpy as np
import pytest
from scipy import signal
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import gamma

import diagnose_truth2_impact as truth2
import diagnose_truth3_impact as truth3
import diagnose_truth4_impact as truth4
from diagnose_truth4_impact import (BS_EPS, BS_ETA, BS_P, D_C, DT, H_GL, LOADING, RS_A, RS_B, UNLOADING, V0_RS,
                                    simulate)
from diagnose_truth_impact import (B_R, C_GREASE, CONDITION, F_GUIDE, K_F, K_T, N_COG, OMEGA_MAX, R_P, RATIO,
                                   SHOWN_IN, SPEED_PROFILE, T_MAX, check_effect_changes_record,
                                   check_play_seen_at_reversal, check_seed_gives_same_case, make_case)

SEED = 1095907558
DRAWS = [truth4.draw_truth("none", rng) for rng in [np.random.default_rng(SEED)] for _ in range(3)]
IDS = ["draw0", "draw1", "draw2"]
A_G, B_G = RS_A * F_GUIDE, RS_B * F_GUIDE  # the guides' direct and healing effects without an effect


def _steady_guides(v):
    """Dieterich-Ruina steady sliding with the cut-off velocity ``V0_RS``: ``F_GUIDE + A ln(v/V0) + B ln(1 +
    V0/v)``."""
    return F_GUIDE + A_G * math.log(v / V0_RS) + B_G * math.log1p(V0_RS / v)


def _motor_balance(w, eta, T_c0):
    """Motor torque [N.m] the steady free run at motor speed ``w`` takes: drag, rotor damping, the gear output's
    load (grease, guides, bearing damping eq. 9) and the mesh loss ``(1/eta - 1)`` of it inside the friction."""
    v = w * R_P / RATIO
    tau_out = 2 * R_P * (C_GREASE * v + _steady_guides(v)) + T_MAX * (1 - eta) * RATIO ** 2 / OMEGA_MAX * w / RATIO
    return T_c0 + B_R * w + tau_out / (RATIO * eta)


@pytest.mark.parametrize("draw", DRAWS, ids=IDS)
def test_free_running_speed_matches_the_closed_form_balance(draw):
    """No object within reach, 1 A held 2 s: the speed settles where ``K_T i`` equals the steady torque balance
    (Bliman-Sorine at its Coulomb level, the guides on their steady rate-and-state curve), solved by brentq.
    After 1.9 s the transient (~0.12 s) has died out; rtol 1e-4 covers the mesh stiffness's switching."""
    eta, T_c0 = draw["eta_g"], draw["T_c0"]
    t, _, _, contact, theta, _, _ = simulate(draw, gap0=10.0, profile=((0.0, 1.0), (2.0, 1.0)))
    assert np.all(contact == 0.0)
    speed = (theta[-1] - theta[-11]) / (t[-1] - t[-11])
    expected = brentq(lambda w: _motor_balance(w, eta, T_c0) - K_T, 1.0, 2000.0, xtol=1e-12)
    np.testing.assert_allclose(speed, expected, rtol=1e-4)


@pytest.mark.parametrize("draw", DRAWS, ids=IDS)
def test_speed_run_current_matches_the_closed_form_balance(draw):
    """The speed run's held speeds (jaws free, 0.6-1.3 mm/s, near the guides' reference speed): the mean current
    over the last quarter of each hold is the steady torque balance at that speed over ``K_T``. rtol 1e-5 (the PI
    loop's residual transient; over the second half of the first hold, which starts the jaws from their healed rest
    and closes the play, it is 1.5e-4)."""
    eta, T_c0 = draw["eta_g"], draw["T_c0"]
    t, _, _, _, _, current, _ = simulate(draw, "speed")
    for (start, w), (end, _) in zip(SPEED_PROFILE[2::2], SPEED_PROFILE[3::2]):
        window = (t >= 0.25 * start + 0.75 * end) & (t < end)
        np.testing.assert_allclose(current[window].mean(), _motor_balance(w, eta, T_c0) / K_T, rtol=1e-5)


def test_guides_steady_friction_is_dieterich_ruinas():
    """At the steady state ``theta = D_C/v`` of the aging law the guides' friction is ``F_GUIDE + A ln(v/V0) + B
    ln(1 + V0/v)`` over six decades of speed (the regularisation's error ``A/(4 y^2)`` is below rounding), and far
    below the cut-off it is the textbook ``mu_ss = mu0 + (a - b) ln(v/v0)`` (to ``B v/V0``); odd in ``v``."""
    for v in np.logspace(-7, -1, 25):
        force = truth4.rs_force(v, D_C / v, A_G, B_G)
        np.testing.assert_allclose(force, _steady_guides(v), rtol=1e-12)
        assert truth4.rs_force(-v, D_C / v, A_G, B_G) == -force
        if v < 1e-5:
            assert abs(force - (F_GUIDE + (A_G - B_G) * math.log(v / V0_RS))) <= B_G * v / V0_RS * 1.01


def test_guides_state_follows_the_aging_law_integrated_by_scipy():
    """The state stepped at a constant speed decays exponentially to ``D_C/v`` (closed form); under a sinusoidal
    speed it matches ``solve_ivp`` of ``dtheta/dt = 1 - |v| theta/D_C`` (the exact step at the step's speed is first
    order in the speed's change: rtol 1e-3); at rest it grows by the time."""
    v, theta, states = 2e-4, 1.0, []
    for _ in range(2000):
        theta = truth4.rs_state(theta, v)
        states.append(theta)
    time = DT * np.arange(1, 2001)
    np.testing.assert_allclose(states, D_C / v + (1.0 - D_C / v) * np.exp(-v * time / D_C), rtol=1e-12)
    assert truth4.rs_state(0.3, 0.0) == 0.3 + DT

    def speed(t):
        return 1e-3 * np.sin(2 * np.pi * 20.0 * t)

    time = np.arange(5000) * DT
    theta, stepped = 0.05, np.empty(len(time))
    for k, t in enumerate(time):
        stepped[k] = theta
        theta = truth4.rs_state(theta, speed(t))
    reference = solve_ivp(lambda t, y: [1 - abs(speed(t)) * y[0] / D_C], (0, time[-1]), [0.05], t_eval=time[::25],
                          method="LSODA", rtol=1e-10, atol=1e-12, max_step=1e-5).y[0]
    np.testing.assert_allclose(stepped[::25], reference, rtol=1e-3)


@pytest.mark.parametrize("R", [-50.0, -0.05, 1e-4, 0.06, 0.5, 20.0, 900.0])
def test_jaw_speed_solves_the_implicit_balance_with_the_guides(R):
    """The jaw's implicit step: the speed returned satisfies ``c1 v + A asinh(v/(2 V0) exp(Psi/A)) = R``
    (numpy's arcsinh on the returned speed, or its logarithmic form where that overflows), and below the
    healed level ``Psi`` the jaw creeps at most at ``V0 exp((|R| - Psi)/A)``: it sticks."""
    c1, theta = 0.085 / DT + C_GREASE, 0.5
    exponent = truth4.rs_exponent(theta, A_G, B_G)
    v, friction = truth4.rs_speed(R, c1, A_G, exponent)
    y = v / (2 * V0_RS) * math.exp(exponent)
    asinh = np.arcsinh(y) if abs(y) < 1e100 else math.copysign(math.log(2 * abs(y)), y)
    assert abs(c1 * v + A_G * asinh - R) < 1e-9 * max(1.0, abs(R))
    assert abs(friction - A_G * asinh) < 1e-9 * max(1.0, abs(R))
    level = A_G * exponent
    if abs(R) < level:
        assert abs(v) <= V0_RS * math.exp((abs(R) - level) / A_G) * 1.01


def test_motor_friction_matches_bliman_sorine_integrated_by_scipy():
    """The motor's Bliman-Sorine friction under a sinusoidal speed, stepped as the truth steps it, against
    ``solve_ivp`` of the hand-written equations in time, ``dx1/dt = |w| ((1 + P) sgn(w) - x1)/(eta eps)``, ``dx2/dt
    = |w| (-P sgn(w) - x2)/eps``. After a reversal from rest the friction peaks near ``1.13`` of its level (the
    closed form ``(1 + P)(1 - e^(-s/(eta eps))) - P (1 - e^(-s/eps))`` maximised over the path) and settles to it.
    The exact step at the step's start speed lags by half a step; compared so, to 1e-4 of the level."""
    amplitude, f = 0.5, 2.0
    time = np.arange(int(0.6 / DT)) * DT
    speeds = amplitude * np.sin(2 * np.pi * f * time)
    x1 = x2 = 0.0
    stepped = np.empty(len(time))
    for k, w in enumerate(speeds):
        stepped[k] = x1 + x2
        x1, x2 = truth4.bliman_sorine(x1, x2, w)

    def rate(t, y):
        w = amplitude * np.sin(2 * np.pi * f * t)
        return [abs(w) * ((1 + BS_P) * np.sign(w) - y[0]) / (BS_ETA * BS_EPS), abs(w) * (-BS_P * np.sign(w) - y[1])
                / BS_EPS]

    # the step takes the speed at its start: the stepped states lag the exact ones by half a step
    y = solve_ivp(rate, (0, time[-1]), [0.0, 0.0], t_eval=np.maximum(time[::100] - DT / 2, 0.0), method="LSODA",
                  rtol=1e-10, atol=1e-12, max_step=1e-4).y
    np.testing.assert_allclose(stepped[::100], y[0] + y[1], atol=1e-4)
    path = np.linspace(0.0, 10 * BS_EPS, 100001)
    curve = (1 + BS_P) * (1 - np.exp(-path / (BS_ETA * BS_EPS))) - BS_P * (1 - np.exp(-path / BS_EPS))
    first_half = time < 0.5 / f
    np.testing.assert_allclose(stepped[first_half].max(), curve.max(), atol=1e-3)
    assert 1.1 < curve.max() < 1.15 and abs(stepped[np.searchsorted(time, 0.24)] - 1.0) < 1e-3


@pytest.mark.parametrize("alpha, p", [(0.3, 1.0), (0.5, 2.0), (0.8, 1.5)])
def test_grunwald_letnikov_sum_gives_the_power_laws_fractional_derivative(alpha, p):
    """The truth's Grünwald-Letnikov weights and memory sum on ``t^p``: ``D^alpha t^p = Gamma(p + 1)/Gamma(p + 1 -
    alpha) t^(p - alpha)`` at t = 0.1 s on the truth's grid ``H_GL``, to 0.5 %, the error halving with the step
    (first order)."""
    t_end, exact = 0.1, gamma(p + 1) / gamma(p + 1 - alpha) * 0.1 ** (p - alpha)
    errors = []
    for h in (H_GL, H_GL / 2):
        n = int(round(t_end / h))
        values = (np.arange(n + 1) * h) ** p
        w = truth4.gl_weights(alpha, n + 1)
        estimate = h ** -alpha * (values[n] + truth4.gl_history(values, n, 0, w))
        errors.append(estimate / exact - 1)
    assert abs(errors[0]) < 5e-3
    assert 1.8 < errors[0] / errors[1] < 2.2


@pytest.mark.slow
@pytest.mark.parametrize("f", [5.0, 40.0])
def test_fractional_elements_have_their_closed_form_frequency_responses(f):
    """A sinusoidal deflection on the truth's grid, in sinusoidal steady state after 3 s: the springpot's force is
    the fractional Kelvin-Voigt term ``c (j w)^alpha``, the fractional Maxwell branch's ``k_r (j w tau)^alpha/(1 +
    (j w tau)^alpha)`` (amplitude and phase by least squares on the last two periods; GL is first order:
    rtol 2 %, 0.02 rad)."""
    frac = np.array([2e5, 0.1, 0.5, 800.0, 0.7])
    time = np.arange(int(3.0 / H_GL)) * H_GL
    deflection = 1e-4 * np.sin(2 * np.pi * f * time)
    branch, springpot = truth4.fractional_forces(deflection, frac)
    last = time > 3.0 - 2 / f
    basis = np.column_stack([np.sin(2 * np.pi * f * time[last]), np.cos(2 * np.pi * f * time[last])])
    jw = 2j * np.pi * f
    for force, expected in ((springpot, frac[3] * jw ** frac[4]),
                            (branch, frac[0] * (jw * frac[1]) ** frac[2] / (1 + (jw * frac[1]) ** frac[2]))):
        (s, c), *_ = np.linalg.lstsq(basis, force[last] / 1e-4, rcond=None)
        np.testing.assert_allclose(abs(s + 1j * c), abs(expected), rtol=0.02)
        assert abs(np.angle(s + 1j * c) - np.angle(expected)) < 0.02


def _loading(d):
    return np.interp(d, LOADING[:, 0], LOADING[:, 1])


def test_coating_follows_its_tabulated_loop_under_a_slow_push():
    """The object pushed 0.9 mm into the coating, pulled back to 0.4 mm, pushed again to 1.0 mm and released, over
    0.8 s: wherever the push moves slowly the contact force is the series balance ``k_s (pen - d) = F(d)`` solved by
    brentq on the tables (loading ``LOADING``; below the largest deflection ``F_m U(f(d)/F_m)`` by ``UNLOADING``),
    to 0.3 N (the viscous ``C_p`` at these rates); the reloading retraces the unloading branch."""
    k_s = 1.0 / (1.0 / K_F + 1.0 / CONDITION["k_obj"])
    corners = ((0.0, 0.0), (0.2, 9e-4), (0.4, 4e-4), (0.6, 1.0e-3), (0.8, 0.0))
    time = np.arange(int(0.8 / DT)) * DT
    pens = np.interp(time, *zip(*corners))
    delta = delta_m = F_m = 0.0
    forces, checks = np.empty(len(time)), []
    for k, pen in enumerate(pens):
        delta = truth4.contact_step(pen, k_s, delta, delta_m, F_m, 0.0, 0.0)
        forces[k] = k_s * max(pen - delta, 0.0)
        if delta > delta_m:
            delta_m, F_m = delta, _loading(delta)
        if k % 4000 == 0 and pen > 1e-5:
            checks.append((k, pen, delta_m, F_m))
    for k, pen, d_m, f_m in checks:
        def law(d):
            if d >= d_m or f_m <= 0:
                return _loading(d)
            return f_m * np.interp(_loading(d) / f_m, UNLOADING[:, 0], UNLOADING[:, 1])
        d = brentq(lambda d: k_s * (pen - d) - law(d), -1e-4, pen)
        assert abs(forces[k] - k_s * (pen - d)) < 0.3, (time[k], forces[k], k_s * (pen - d))
    way_in, way_back, again = (time < 0.2), (time > 0.2) & (time < 0.4), (time > 0.4) & (time < 0.6)
    at = 4e-4 + 1e-6
    back = np.interp(at, pens[way_back][::-1], forces[way_back][::-1])
    assert back < 0.6 * np.interp(at, pens[way_in], forces[way_in])  # unloading well below loading
    reloaded = pens[again] < 8.5e-4  # below the largest deflection reached: the branch is retraced
    np.testing.assert_allclose(forces[again][reloaded], np.interp(pens[again][reloaded], pens[way_back][::-1],
                                                                  forces[way_back][::-1]), atol=0.5)
    assert forces[-1] == 0.0


def _bspline_step(u):
    """The unit-step response of a sinc^3 filter of window 1 per stage (``u`` in windows): the quadratic B-spline's
    integral."""
    u = np.clip(u, 0.0, 3.0)
    return np.where(u < 1, u ** 3 / 6, np.where(u < 2, (-2 * u ** 3 + 9 * u ** 2 - 9 * u + 3) / 6,
                                               1 - (3 - u) ** 3 / 6))


@pytest.mark.parametrize("window", [10, 40])
def test_load_cell_sinc_filter_matches_its_closed_form_and_scipy(window):
    """The converter's sinc^3 filter: its unit-step response is the quadratic B-spline's integral sampled at the
    grid (closed form, the window in samples), and on a random force it is ``scipy.signal.lfilter`` of three
    ``window``-tap boxcars."""
    n = 5 * window
    step = truth4.sinc_filter(np.ones(n), window)
    k = np.arange(n)
    # sampled: the three boxcars of window samples give the discrete B-spline, its sum at k + 1 samples
    discrete = np.convolve(np.convolve(np.ones(window), np.ones(window)), np.ones(window)) / window ** 3
    np.testing.assert_allclose(step, np.cumsum(np.concatenate([discrete, np.zeros(n)]))[:n], atol=1e-12)
    np.testing.assert_allclose(step, _bspline_step((k + 1) / window), atol=1.5 / window)
    force = np.random.default_rng(SEED).normal(size=400)
    reference = force
    for _ in range(3):
        reference = signal.lfilter(np.ones(window) / window, [1.0], reference)
    np.testing.assert_allclose(truth4.sinc_filter(force, window), reference, atol=1e-12)


def test_cogging_is_the_derivative_of_the_permeance_energy():
    """The drawn cogging torque is the angle derivative of ``W0/(1 + eps cos(N theta + phase))`` (central
    differences of the energy, 1e-6 of the peak), its peak over a revolution is the drawn ``T_cog``, and it has no
    mean."""
    truth = truth4.draw_truth("cogging", np.random.default_rng(SEED))
    cog = truth4.cogging_coefficients(truth)
    angle = np.linspace(0.0, 2 * np.pi, N_COG * 2000, endpoint=False)
    torque = np.array([truth4.cogging_torque(a, cog) for a in angle])
    h = 1e-7
    energy = lambda a: cog[0] / (1 + truth["eps_cog"] * np.cos(N_COG * a + truth["phase_cog"]))  # noqa: E731
    np.testing.assert_allclose(torque, (energy(angle + h) - energy(angle - h)) / (2 * h), atol=1e-6 * truth["T_cog"])
    np.testing.assert_allclose(np.abs(torque).max(), truth["T_cog"], rtol=1e-4)
    assert abs(torque.mean()) < 1e-9 * truth["T_cog"]


@pytest.mark.parametrize("play_deg", [0.4, 0.8, 1.5])
def test_gear_play_shows_in_the_encoder_at_a_reversal(play_deg):
    """Jaws free, 0.3 A closing then -0.3 A opening: between steady closing and steady opening the encoder turns
    back by the jaws' travel times N/r_p plus the play times N, within 2 counts (``check_play_seen_at_reversal``)."""
    check_play_seen_at_reversal(simulate, DRAWS[0], play_deg)


def test_a_seed_gives_the_same_case_and_the_other_truths_baseline():
    """One seed: the same records twice, and the same ``eta_g``, ``T_c0`` and play as the first, second and third
    truths' cases (``draw_baseline`` first)."""
    check_seed_gives_same_case(truth4.make_case_impact4, [lambda rng: make_case("gear_play", rng)[1],
                                                          lambda rng: truth2.draw_truth("gear_play", rng),
                                                          lambda rng: truth3.draw_truth("gear_play", rng)], SEED)


@pytest.mark.parametrize("effect", sorted(SHOWN_IN) + ["none"])
def test_every_effect_changes_the_record_measurably(effect):
    """Each hidden effect, drawn from the seed, changes its experiment's noise-free record by more than a fifth of
    the compared channel's noise or more than a count of the encoder (RMS); ``none`` changes nothing."""
    check_effect_changes_record(truth4.make_case_impact4, truth4.effect_signal4, effect, SEED)
