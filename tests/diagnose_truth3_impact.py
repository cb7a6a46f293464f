"""A third hidden-effect truth of the gripper's dynamic experiments (impact, slide, speed run), never used to tune
anything: written after the second truth's results were seen, to judge workflow changes made in response to them.

The experiments, inputs, sampling, encoder truncation, noise, object placement, contact condition (``CONDITION``)
and drawn baseline (``draw_baseline``: one seed gives the same ``eta_g``, ``T_c0`` and play as the other truths)
are the first truth's (``diagnose_truth_impact.py``), so its ``write_job`` writes this truth's jobs too. Every
part of the plant uses a textbook formulation that differs from the first truth, the second truth
(``diagnose_truth2_impact.py``) and the candidates' Modelica:

* motor friction: Generalized Maxwell-Slip (Al-Bender, Lampaert and Swevers 2005, IEEE TAC 50(11)): four
  elements of weights ``GMS_WEIGHTS`` and presliding angles ``GMS_PHI`` that stick (spring ``k_i``) or slip (the
  element force attracted to ``w_i s(w)`` at rate ``GMS_C``); Stribeck ``s(w) = T_c0 (1 + 0.15 exp(-sqrt(|w|/W_S)))``;
* gear loss: the efficiency on the transmitted torque with a smooth power-flow switch ``tanh(P/P_TH)`` (the
  "power threshold" of Simscape Driveline's Simple Gear, the block the paper used) plus the paper's churning /
  bearing drag ``B_g`` (eq. 9) acting outside the efficiency. There is no loss at standstill, so a held load
  creeps at the power ``P_TH``: ``P_TH`` = 10 uW keeps that below 0.05 N/s, and the switch's steep slope is taken
  linearly implicit in the motor's step;
* gear mesh: backlash whose flanks meet by a Hunt-Crossley impact law (Hunt and Crossley 1975, ASME J. Appl.
  Mech. 42): ``tau = K_MESH delta (1 + 1.5 ALPHA_HC d(delta)/dt)``, never pulling, ``K_MESH`` = 2500 N.m/rad;
* guides: Dahl's model (Dahl 1976, AIAA J. 14) in force units with exponent 2, ``dF/dx = SIGMA0_G |u| u``,
  ``u = 1 - F sgn(v)/L(v)``, and a rational Stribeck level ``L = F_GUIDE + (F_s - F_GUIDE)/(1 + (v/v_s)^2)``;
* coating (``CONDITION``'s ``k_P``, ``k_H_ratio``, ``d_lim``, ``C_p``, ``C_h``): Fung's exponential stiffening
  (Fung 1967, Am. J. Physiol. 213), ``F = k_P d0 (exp(delta/d0) - 1)``, ``d0 = d_lim/ln(k_H/k_P)``, tangent
  ``k_P`` at zero and ``k_H`` at ``d_lim`` (continued linearly beyond); damping stiffness-proportional
  (Rayleigh-like) ``C = C_p (k_t/k_P)^beta``, ``beta = ln(C_h/C_p)/ln(k_H/k_P)``, so ``C_p`` at zero, ``C_h`` at
  ``d_lim``. At the impact's sampled peaks (about 290-360 N, 0.6 mm) its tangent is 6-7 ``k_P``; the two-region law's
  impacts (peaks 180-210 N) stay in its soft region;
* load cell: a 1000 Hz first-order anti-alias filter, exact per step.

Hidden effects, one a case (the first truth's names): ``gear_play`` (play from ``draw_baseline``: 0.3-0.55 deg or
1.1-1.6 deg instead of 0.8 deg), ``contact_damping`` (Lankarani and Nikravesh 1990, ASME J. Mech. Des. 112:
``chi E(delta) d(delta)/dt / v_impact``, ``chi = 3(1 - e^2)/4``, restitution ``e`` 0.93-0.98, the impact speed
taken at each touch: about 100-330 N.s/m at 0.5 mm for this impact's 0.066 m/s), ``coating_relaxation`` (a
power-law relaxation spectrum ``H(tau) ~ tau^-alpha``, ``alpha`` 0.2-0.6, over 0.01-1 s, as five log-spaced Prony
terms of total stiffness 0.5-2 ``k_P``, Tustin-integrated; ``G(t)`` falls roughly as ``t^-alpha`` inside the band),
``stiction`` (the guides' Stribeck breakaway ``F_s`` 3-10 N, ``v_s`` 0.5-2 mm/s), ``cogging`` (a detent of harmonics
1-3 of the 24 a revolution, modulated by a rotor eccentricity ``1 + eps cos(theta + phase)``, ``eps`` 0.1-0.3,
peak 1.5-4 mN.m), ``load_dependent_friction`` (the guide level grows by ``mu_F F_REF (|F|/F_REF)^0.9``, ``mu_F``
0.01-0.05, ``F_REF`` 50 N), ``loadcell_filter`` (a 2-sample moving average of the 100 Hz conversions after a 4-15 Hz
first-order filter, offset +-1-3 N) or ``none``.

Integration: semi-implicit Euler at ``DT`` = 10 us, compiled with numba; the GMS elements and the Dahl state by the
exact solution of their ODE over a step at the step's speed; the coating's deflection implicit (backward-Euler
rate, Tustin Prony terms), found by a safeguarded Newton solve on a bracket the law's minimum slope guarantees.
"""

import math

import numpy as np
from numba import njit

from diagnose_truth2_impact import diagnose_records, experiment_input, q_current
from diagnose_truth_impact import (B_R, C_GREASE, CONDITION, F_GUIDE, FORCE_NOISE, J_M, J_P, K_F, K_T, M_JF,
                                   N_COG, OMEGA_MAX, PLAY_NOMINAL, R_P, RATE_HZ, RATIO, T_MAX, draw_baseline,
                                   hidden_effect_signal, measured_records)

__all__ = ["TRUTH3_IMPACT_EFFECTS", "simulate", "draw_truth", "make_case_impact3", "effect_signal3",
           "diagnose_case_impact3"]

TRUTH3_IMPACT_EFFECTS = ("none", "gear_play", "contact_damping", "coating_relaxation", "stiction", "cogging",
                         "load_dependent_friction", "loadcell_filter")
DT = 1e-5                                                  # s
# motor friction: GMS (weights sum to one; stiffness of element i is w_i T_c0 / phi_i)
GMS_WEIGHTS = np.array([0.4, 0.3, 0.2, 0.1])               # 1
GMS_PHI = np.array([2e-4, 5e-4, 1e-3, 3e-3])               # rad, presliding angle of each element
GMS_C = 5.0                                                # N.m/s, attraction rate of a slipping element
GMS_SIGMA1 = 0.015                                         # N.m.s/rad, micro-damping of the stuck elements (all)
STRIBECK_M, W_S = 1.15, 0.1                                # static/Coulomb, rad/s
# gear: efficiency with a power threshold, Hunt-Crossley flanks
P_TH = 1e-5                                                # W, power of the tanh switch
K_MESH, ALPHA_HC = 2500.0, 0.1                             # N.m/rad, s/rad (restitution 1 - ALPHA_HC v)
# guides: Dahl, exponent 2
SIGMA0_G = 2e6                                             # N/m, initial presliding stiffness
V_S_G = 1e-3                                               # m/s, Stribeck velocity (no drop without the effect)
F_REF = 50.0                                               # N, contact force at which mu_F |F|^0.9 equals mu_F F
# contact and sensor
V_IMPACT_MIN = 1e-3                                        # m/s, floor of the impact speed in Lankarani-Nikravesh
PRONY_TAU = np.logspace(-2.0, 0.0, 5)                      # s, relaxation times of the power law's Prony terms
F_LC_NOMINAL = 1000.0                                      # Hz, anti-alias filter of the load cell


def fung_d0():
    """Fung's length ``d0`` [m]: tangent ``k_P`` at zero deflection reaches ``k_H`` at ``d_lim``."""
    return CONDITION["d_lim"] / math.log(CONDITION["k_H_ratio"])


@njit(cache=True)
def _fung(delta, k_P, d0, d_lim):
    """Fung's elastic force and tangent stiffness at ``delta`` (linear below zero and beyond ``d_lim``)."""
    if delta <= 0.0:
        return k_P * delta, k_P
    e = math.exp(min(delta, d_lim) / d0)
    force, tangent = k_P * d0 * (e - 1.0), k_P * e
    if delta > d_lim:
        force += tangent * (delta - d_lim)
    return force, tangent


@njit(cache=True)
def _coating(delta, delta_old, damping, q, prony_k, coat):
    """The coating's force at ``delta`` reached from ``delta_old`` in one step, and its slope in ``delta``:
    Fung's elastic force, ``damping`` times the backward-Euler rate, the Prony terms by Tustin (``q`` their
    forces at the step's start). ``coat``: k_s, k_P, d0, d_lim, C_p, beta, chi (see ``_coat_array``)."""
    force, slope = _fung(delta, coat[1], coat[2], coat[3])
    force += damping * (delta - delta_old) / DT
    slope += damping / DT
    for j in range(len(q)):
        h = DT / (2.0 * PRONY_TAU[j])
        force += ((1.0 - h) * q[j] + prony_k[j] * (delta - delta_old)) / (1.0 + h)
        slope += prony_k[j] / (1.0 + h)
    return force, slope


@njit(cache=True)
def _root(lo, hi, pen, spring, delta_old, damping, q, prony_k, coat):
    """Root in [lo, hi] of ``spring (pen - d) - coating(d)`` (strictly decreasing in ``d``): Newton, falling back to
    bisection whenever a step leaves the bracket; converged on the residual at the current iterate."""
    d = min(max(delta_old, lo), hi)
    for _ in range(200):
        force, slope = _coating(d, delta_old, damping, q, prony_k, coat)
        g, dg = spring * (pen - d) - force, -spring - slope
        if abs(g) < 1e-8:  # N
            break
        if g > 0:
            lo = d
        else:
            hi = d
        if hi - lo < 1e-16:
            break
        newton = d - g / dg
        d = newton if lo < newton < hi else 0.5 * (lo + hi)
    return d


@njit(cache=True)
def _contact(pen, delta_old, q, prony_k, coat, v_impact):
    """The coating's deflection after one step and the contact force, updating the Prony forces ``q`` in place.
    First the free coating (no object): the root of its own force; if the object pushes further in, the root of the
    series balance finger/object spring = coating. Damping coefficients are taken at ``delta_old`` so the force is
    monotonic in ``delta`` with slope at least ``k_P + C_p/DT``, which bounds both roots."""
    k_s, k_P, d0, d_lim, C_p, beta, chi = coat[0], coat[1], coat[2], coat[3], coat[4], coat[5], coat[6]
    elastic_old = _fung(delta_old, k_P, d0, d_lim)[0]
    damping = C_p * math.exp(beta * min(max(delta_old, 0.0), d_lim) / d0) + chi * max(elastic_old, 0.0) / v_impact
    min_slope = k_P + 0.5 * C_p / DT
    start = _coating(delta_old, delta_old, damping, q, prony_k, coat)[0]
    if start == 0.0:
        free = delta_old
    elif start > 0.0:
        free = _root(delta_old - start / min_slope, delta_old, 0.0, 0.0, delta_old, damping, q, prony_k, coat)
    else:
        free = _root(delta_old, delta_old - start / min_slope, 0.0, 0.0, delta_old, damping, q, prony_k, coat)
    delta = free
    if pen > free:
        hi = min(pen, free + k_s * (pen - free) / (k_s + min_slope))
        delta = _root(free, hi, pen, k_s, delta_old, damping, q, prony_k, coat)
    for j in range(len(q)):
        h = DT / (2.0 * PRONY_TAU[j])
        q[j] = ((1.0 - h) * q[j] + prony_k[j] * (delta - delta_old)) / (1.0 + h)
    return delta, k_s * max(pen - delta, 0.0)


@njit(cache=True)
def _gms(force, slipping, w, level, T_c0):
    """Motor friction torque after one step of the Generalized Maxwell-Slip model, updating each element's force and
    state (0 stuck, +-1 slipping that way) in place. A stuck element loads its spring with the motion and slips
    once its force reaches its share of the Stribeck level in the direction of motion (a force beyond the share
    against the motion only unloads); a slipping one is attracted to that share (exact exponential at the step's
    speed) and sticks again when the speed reverses."""
    total = 0.0
    for i in range(len(force)):
        cap = GMS_WEIGHTS[i] * level
        if slipping[i] != 0.0 and slipping[i] * w <= 0.0:
            slipping[i] = 0.0
        if slipping[i] == 0.0:
            force[i] += GMS_WEIGHTS[i] * T_c0 / GMS_PHI[i] * w * DT
            total += GMS_WEIGHTS[i] * GMS_SIGMA1 * w
            if abs(force[i]) >= cap and force[i] * w > 0.0:  # loaded to its share in the direction of motion
                slipping[i] = 1.0 if w > 0 else -1.0
        else:
            target = slipping[i] * cap
            force[i] = target + (force[i] - target) * math.exp(-GMS_C * DT / cap)
        total += force[i]
    return total


@njit(cache=True)
def _mesh_torque(rel, rel_rate, play):
    """Torque at the gear output [N.m] of a backlash of total ``play`` whose flanks meet by Hunt-Crossley's law
    (linear stiffness ``K_MESH``, damping ``1.5 ALPHA_HC K_MESH delta``), never pulling."""
    delta = abs(rel) - 0.5 * play
    if delta <= 0.0:
        return 0.0
    side = 1.0 if rel > 0 else -1.0
    return side * max(0.0, K_MESH * delta * (1.0 + 1.5 * ALPHA_HC * side * rel_rate))


@njit(cache=True)
def _efficiency_factor(power, eta):
    """Motor-side torque over the ideal ``tau_out/N``: ``1/eta`` when the motor drives the load (``power`` > 0),
    ``eta`` when the load drives the motor, blended by ``tanh(power/P_TH)`` (one at standstill); and its slope in
    ``power``, for the linearly implicit step that keeps the switch stable at this small ``P_TH``."""
    s = math.tanh(power / P_TH)
    factor = 1.0 + (1.0 / eta - 1.0) * max(s, 0.0) - (1.0 - eta) * max(-s, 0.0)
    return factor, ((1.0 / eta - 1.0) if s > 0 else (1.0 - eta)) * (1.0 - s * s) / P_TH


@njit(cache=True)
def _dahl(F, v, level):
    """Guide friction [N] after one step at jaw speed ``v`` by Dahl's law with exponent 2: ``u = 1 - F sgn(v)/L``
    obeys ``du/dt = -SIGMA0_G |v| |u| u / L``, whose exact solution is ``u/(1 + a |u|)``."""
    if v == 0.0:
        return F
    sign = 1.0 if v > 0 else -1.0
    u = 1.0 - F * sign / level
    u /= 1.0 + SIGMA0_G * abs(v) * DT / level * abs(u)
    return sign * level * (1.0 - u)


@njit(cache=True)
def _cogging(theta, cog):
    """Detent torque [N.m] against positive rotation: harmonics 1-3 of the 24 a revolution times a rotor
    eccentricity ``1 + eps cos(theta + phase)``. ``cog``: scale, (amplitude, phase) x 3, eps, phase; empty: none."""
    if len(cog) == 0:
        return 0.0
    detent = 0.0
    for h in range(3):
        detent += cog[1 + 2 * h] * math.sin((h + 1) * N_COG * theta + cog[2 + 2 * h])
    return cog[0] * detent * (1.0 + cog[7] * math.cos(theta + cog[8]))


@njit(cache=True)
def _lag_step(y, force, decay):
    """The load cell's first-order filter one step on, exact for a force held over the step."""
    return force + (y - force) * decay


@njit(cache=True)
def _integrate(inputs, speed_mode, steps_per_sample, eta, T_c0, play, gap0, coat, prony_k, guide, cog, lc_decay):
    """The plant of the module docstring over ``len(inputs)`` samples. ``inputs``: the current [A] per sample, or
    (``speed_mode``) the PI loop's motor speed reference [rad/s]. ``guide``: F_s, v_s, mu_F. Returns per sample
    (before its step): filtered load cell [N], contact force [N], motor angle [rad], q current [A], jaw travel [m]."""
    n = len(inputs)
    out = np.empty((n, 5))
    m = M_JF + J_P / (2 * R_P ** 2)
    B_g = T_MAX * (1 - eta) * RATIO ** 2 / OMEGA_MAX  # eq. (9), here a churning drag outside the efficiency
    gms_force, gms_slipping, q = np.zeros(4), np.zeros(4), np.zeros(len(prony_k))
    theta = w = x = v = delta = F_c = F_g = y_lc = integral = 0.0
    v_impact = V_IMPACT_MIN
    for k in range(n * steps_per_sample):
        j = k // steps_per_sample
        i_q, integral = q_current(speed_mode, inputs[j], w, integral, DT)
        if k % steps_per_sample == 0:
            out[j, 0], out[j, 1], out[j, 2], out[j, 3], out[j, 4] = y_lc, F_c, theta, i_q, x
        pen = x - (gap0 - coat[7])
        if pen > 0.0 and F_c == 0.0:
            v_impact = max(v, V_IMPACT_MIN)  # a new touch: Lankarani-Nikravesh's impact speed
        if pen > 0.0 or delta != 0.0:
            delta, F_c = _contact(pen, delta, q, prony_k, coat, v_impact)
        tau_out = _mesh_torque(theta / RATIO - x / R_P, w / RATIO - v / R_P, play)
        factor, slope = _efficiency_factor(tau_out * w / RATIO, eta)
        tau_in = tau_out / RATIO * factor + B_g * w / RATIO ** 2
        level = T_c0 * (1.0 + (STRIBECK_M - 1.0) * math.exp(-math.sqrt(abs(w) / W_S)))
        T_f = _gms(gms_force, gms_slipping, w, level, T_c0)
        stiff = DT * slope * (tau_out / RATIO) ** 2  # the loss's growth with w over the step, taken implicitly
        w_new = w + DT * (K_T * i_q - B_R * w - T_f - tau_in - _cogging(theta, cog)) / (J_M + stiff)
        g_level = F_GUIDE + (guide[0] - F_GUIDE) / (1.0 + (v / guide[1]) ** 2) \
            + guide[2] * F_REF * (F_c / F_REF) ** 0.9
        F_g = _dahl(F_g, v, g_level)
        v_new = v + DT * (tau_out / (2 * R_P) - C_GREASE * v - F_c - F_g) / m
        y_lc = _lag_step(y_lc, F_c, lc_decay)
        w, v = w_new, v_new
        theta += DT * w
        x += DT * v
    return out


def _coat_array(truth):
    """The contact's constants for ``_contact`` and ``_integrate``: k_s (finger and object in series), k_P, d0,
    d_lim, C_p, beta, chi (Lankarani-Nikravesh, zero without the effect), t_coat."""
    c = CONDITION
    restitution = truth.get("e_LN", 1.0)
    return np.array([1.0 / (1.0 / K_F + 1.0 / c["k_obj"]), c["k_P"], fung_d0(), c["d_lim"], c["C_p"],
                     math.log(c["C_h"] / c["C_p"]) / math.log(c["k_H_ratio"]), 0.75 * (1.0 - restitution ** 2),
                     c["t_coat"]])


def prony_stiffnesses(truth):
    """The Prony terms' stiffnesses [N/m] at ``PRONY_TAU``: a power-law spectrum ``H(tau) ~ tau^-alpha`` sampled at
    log-spaced times (weights ``tau^-alpha``; an unbounded spectrum would give ``G(t) ~ t^-alpha``), of total
    ``k_rel k_P``. Empty without the effect."""
    if "k_rel" not in truth:
        return np.zeros(0)
    weights = PRONY_TAU ** -truth["alpha_rel"]
    return truth["k_rel"] * CONDITION["k_P"] * weights / weights.sum()


def cogging_coefficients(truth):
    """``_cogging``'s coefficients for the truth's draw, scaled so the torque's peak over a revolution is
    ``T_cog`` [N.m]; empty without the effect."""
    if "T_cog" not in truth:
        return np.zeros(0)
    t = truth
    cog = np.array([1.0, 1.0, t["phase_cog"], t["ratio_cog2"], t["phase_cog2"], t["ratio_cog3"], t["phase_cog3"],
                    t["eps_cog"], t["phase_ecc"]])
    peak = max(abs(_cogging(a, cog)) for a in np.linspace(0.0, 2 * np.pi, 24 * 256, endpoint=False))
    cog[0] = t["T_cog"] / peak
    return cog


def load_cell_reading(filtered, lag_samples, moving_average, offset):
    """The reading from the filtered force at the record's samples: with ``moving_average`` the mean of the last
    two conversions (``lag_samples`` record samples apart, the load cell's 100 Hz), then the offset [N]."""
    if not moving_average:
        return filtered + offset
    previous = np.concatenate([np.full(lag_samples, filtered[0]), filtered[:-lag_samples]])
    return 0.5 * (filtered + previous) + offset


def simulate(truth, experiment="impact", gap0=None, profile=None):
    """One noise-free record of ``experiment`` for the parameters ``truth`` (a dict from :func:`draw_truth`;
    ``eta_g`` and ``T_c0`` are enough for the baseline), the object at ``gap0`` [m] of travel (default: the
    experiment's). Returns (time [s], input, load-cell reading [N] with its offset, contact force [N], motor angle
    [rad], q current [A], jaw travel [m]): the input is the current [A] per sample, or for the speed run the speed
    reference [rad/s]. ``profile``: (time [s], input) corners joined by straight lines in place of the experiment's
    input (for the tests), at the experiment's rate and over its last corner."""
    gap0, rate, time, given = experiment_input(experiment, gap0, profile)
    t = truth
    guide = np.array([t.get("F_sj", F_GUIDE), t.get("v_s", V_S_G), t.get("mu_F", 0.0)])
    lc_decay = math.exp(-2 * math.pi * t.get("f_lc", F_LC_NOMINAL) * DT)
    out = _integrate(np.ascontiguousarray(given, dtype=float), experiment == "speed", int(round(1.0 / (rate * DT))),
                     t["eta_g"], t["T_c0"], t.get("play", PLAY_NOMINAL), gap0, _coat_array(t), prony_stiffnesses(t),
                     guide, cogging_coefficients(t), lc_decay)
    reading = load_cell_reading(out[:, 0], int(round(rate / RATE_HZ)), "f_lc" in t, t.get("F_off", 0.0))
    return time, given, reading, out[:, 1], out[:, 2], out[:, 3], out[:, 4]


def draw_truth(effect, rng):
    """The drawn parameters of one case of ``effect`` (module docstring: the ranges), by the Modelica's names where
    there is one; the baseline first, by ``draw_baseline``, so a seed gives the other truths' baseline."""
    if effect not in TRUTH3_IMPACT_EFFECTS:
        raise ValueError(f"effect must be one of {', '.join(TRUTH3_IMPACT_EFFECTS)}; got {effect!r}")
    truth = draw_baseline(effect, rng)
    u = rng.uniform
    if effect == "contact_damping":
        truth["e_LN"] = float(u(0.93, 0.98))
    elif effect == "coating_relaxation":
        truth.update(k_rel=float(u(0.5, 2.0)), alpha_rel=float(u(0.2, 0.6)))
    elif effect == "stiction":
        truth.update(F_sj=float(u(3.0, 10.0)), v_s=float(u(5e-4, 2e-3)))
    elif effect == "cogging":
        truth.update(T_cog=float(u(1.5e-3, 4e-3)), phase_cog=float(u(0, 2 * np.pi)), ratio_cog2=float(u(0.1, 0.3)),
                     phase_cog2=float(u(0, 2 * np.pi)), ratio_cog3=float(u(0.05, 0.15)),
                     phase_cog3=float(u(0, 2 * np.pi)), eps_cog=float(u(0.1, 0.3)), phase_ecc=float(u(0, 2 * np.pi)))
    elif effect == "load_dependent_friction":
        truth["mu_F"] = float(u(0.01, 0.05))
    elif effect == "loadcell_filter":
        truth.update(f_lc=float(u(4.0, 15.0)), F_off=float(rng.choice([-1.0, 1.0]) * u(1.0, 3.0)))
    return truth


def make_case_impact3(effect, rng, noise=FORCE_NOISE, trials=1, experiment="impact"):
    """A random hidden-effect case of this truth in the first truth's structure (``make_case`` there): (records,
    truth dict), the records measured as ``diagnose_truth_impact.measured_records`` does."""
    truth = draw_truth(effect, rng)
    return measured_records(simulate, truth, rng, noise, trials, experiment), truth


def effect_signal3(case, experiment="impact"):
    """RMS change the hidden effect alone makes to the case's noise-free records
    (``diagnose_truth_impact.hidden_effect_signal``)."""
    return hidden_effect_signal(simulate, case, experiment)


def diagnose_case_impact3(effect, seed, folder, experiment="impact", workers=2):
    """Diagnose this truth's case (``effect``, ``seed``) of ``experiment`` with the whole library of the
    experiment's model (``diagnose_truth2_impact.diagnose_records``); one row, ``truth_model`` 3."""
    case = make_case_impact3(effect, np.random.default_rng(seed), experiment=experiment)
    return {**diagnose_records(case, seed, folder, experiment, workers),
            "experiment": experiment, "truth_model": 3, "effect_signal": effect_signal3(case, experiment)}
