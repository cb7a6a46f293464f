"""A second hidden-effect truth of the gripper's dynamic experiments (impact, slide, speed run), written from other
textbook formulations than the candidates' Modelica and than ``diagnose_truth_impact.py``; never used to tune
anything (issue #32 item 3).

The experiments, inputs, outputs, sampling and noise are those of the first truth (``diagnose_truth_impact.py``:
``T_STEP``, ``I_STEP``, ``SLIDE_PROFILE``, ``SPEED_PROFILE``, the PI speed loop, the 100 Hz load cell with 0.5 N
noise, the 2048 cpt encoder truncated to whole counts, the 1 kHz current of the slide and speed run, the current
noise), so its ``write_job`` writes the diagnosis job of a case of this module. What differs is the plant, each
part against the candidates' Modelica and the first truth:

* motor friction: LuGre (Canudas de Wit et al. 1995) in its normalised form, ``T_f = L (z/PHI_M + SIGMA1_M
  dz/dt)``, ``dz/dt = w - |w| z/(PHI_M mu(w))``, Stribeck ``mu = 1 + 0.1 exp(-(w/W_S_M)^2)``, viscous ``B_R``
  (Modelica: elasto-plastic bristle of presliding ``phi_b``; first truth: Karnopp with a Dahl state);
* gear loss: torque-proportional inside the LuGre level, ``L = T_c0 + c |tau_out|/N`` with ``c = 1/eta - 1`` when
  the motor drives the load and ``1 - eta`` when the load back-drives it (sign of ``z tau_out``), ``tau_out`` the
  gear output's load (mesh shaft and bearing damping ``B_g``, eq. 9) (Modelica: an efficiency by power flow on
  its own bristle; first truth: a Karnopp band);
* gear mesh: Nordin and Gutman's (2002) "physical" backlash, a Kelvin-Voigt shaft (``K_MESH``, ``C_MESH``) in
  series with a dead zone whose position inside the play is a state, so the torque never jumps and never pulls
  (Modelica: a rigid gear with an elastic play stop; first truth: a dead-band spring with clamped damping);
* guides: LuGre in force units (bristles ``SIGMA0_G``, damping ``SIGMA1_G``) with a Stribeck breakaway ``F_s``
  (``F_GUIDE`` without the effect) and a level growing by ``mu_F F_contact`` (Modelica: a regularised Coulomb, the
  effects' elasto-plastic bristles; first truth: Karnopp);
* coating: one smooth nonlinear law instead of two linear regions: a Hertz-like soft region ``F ~ delta^1.2``
  (tangent stiffness ``k_P`` at 0.3 mm) plus a softplus stiffening to ``k_H`` past ``d_lim``, its damping
  blended from ``C_p`` to ``C_h`` by a logistic of the same width (both: two linear regions, damping switched);
* contact damping (effect): Tsuji's (Hertz-Mindlin) ``c (delta/0.5 mm)^0.25`` on the coating's deflection rate
  (candidate: Hunt-Crossley ``lambda F v``; first truth: ``c_hc pen^p v``, p 1.2-1.8);
* coating relaxation (effect): two Prony (Maxwell) terms by backward Euler (candidate: one Maxwell branch;
  first truth: one Prony term by the recursive exponential integrator);
* cogging (effect): a detent torque interpolated linearly in a 64-point FEM-like table over one slot pitch
  (harmonics 1-3, ``diagnose_truth2.cogging_table``) (candidate: one sinusoid; first truth: spline derivative of a
  tabulated energy with harmonics 1-2);
* load cell: second order (``f_lc``, ``zeta_lc``; 500 Hz and 0.7 without the effect) (candidate: first-order lag
  and offset; first truth: ideal).

Hidden effects and their drawn sizes (ranges of the plant, as the first truth's where it has the effect):
``gear_play`` (play 0.3-0.55 deg or 1.1-1.6 deg instead of 0.8 deg), ``contact_damping`` (Tsuji ``c`` 100-300
N.s/m at 0.5 mm), ``coating_relaxation`` (two Prony terms of total stiffness 0.5-2 ``k_P``, split 30-70 %, time
constants 0.03-0.1 s and 0.15-0.4 s), ``stiction`` (guide breakaway ``F_s`` 3-10 N, Stribeck velocity 0.5-2
mm/s), ``cogging`` (table peak 1.5-4 mN.m at a random phase), ``load_dependent_friction`` (``mu_F`` 0.01-0.05),
``loadcell_filter`` (``f_lc`` 4-15 Hz, ``zeta_lc`` 0.5-1, offset +-1-3 N) or ``none``. Every case draws ``eta``
0.62-0.74 and ``T_c0`` 6-10 mN.m (the baseline's free parameters, as the first truth).

Integration: semi-implicit Euler at ``DT`` = 10 us compiled with numba; the bristle states by the exact solution
of their linear ODE over a step (stable at any slip speed), the coating's deflection by backward Euler (a
safeguarded Newton solve of the series balance finger/object spring = coating force at every step).
"""

import math

import numpy as np
from numba import njit

from diagnose_truth2 import cogging_table
# the paper's values (docs/models/gripper.md) come from the first truth
from diagnose_truth_impact import (B_R, C_GREASE, CONDITION, CURRENT_NOISE, DURATION, F_GUIDE, FORCE_NOISE, I_STEP,
                                   J_M, J_P, K_F, K_IW, K_PW, K_T, M_JF, OMEGA_MAX, PLAY_NOMINAL, R_P, RATE_HZ, RATIO,
                                   SLIDE_GAP0, SLIDE_PROFILE, SLIDE_RATE_HZ, SPEED_PROFILE, T_MAX, T_STEP,
                                   _experiment, draw_baseline, hidden_effect_signal, measured_records)

__all__ = ["TRUTH2_IMPACT_EFFECTS", "SHOWN_BY", "simulate", "make_case_impact2", "effect_signal2",
           "diagnose_case_impact2", "diagnose_case_impact1", "library"]

TRUTH2_IMPACT_EFFECTS = ("none", "gear_play", "contact_damping", "coating_relaxation", "stiction", "cogging",
                         "load_dependent_friction", "loadcell_filter")
# docs/guide/diagnose.md, "Which experiment shows which effect": the effects each experiment is said to show
SHOWN_BY = {"impact": ("gear_play", "contact_damping", "coating_relaxation", "load_dependent_friction"),
            "slide": ("stiction",), "speed": ("cogging",)}

DT = 1e-5                                         # s
# this truth's own elements
K_MESH, C_MESH = 1000.0, 0.05                     # N.m/rad, N.m.s/rad: mesh shaft at the gear output
PHI_M, SIGMA1_M, STRIBECK_M, W_S_M = 1e-3, 1.1, 1.1, 0.2  # rad, s/rad, static/Coulomb, rad/s: motor LuGre
SIGMA0_G = 1e7                                    # N/m: guide bristles (1 um of presliding at 10 N)
SIGMA1_G = math.sqrt(SIGMA0_G * (M_JF + J_P / (2 * R_P ** 2)))  # N.s/m: bristle damping ratio 0.5 on the jaw
V_S_G = 1e-3                                      # m/s: guide Stribeck velocity without the effect
DELTA_REF, HERTZ_N, W_TRANS = 3e-4, 1.2, 1e-4     # m, 1, m: coating's soft-region law and region transition
F_LC_NOMINAL, ZETA_LC_NOMINAL = 500.0, 0.7        # Hz, 1: load cell without the effect


@njit(cache=True)
def _coating(delta, delta_prev, q1, q2, k_P, k_H, d_lim, C_p, C_h, c_tsuji, k1, tau1, k2, tau2):
    """The coating's force at deflection ``delta`` [m] reached from ``delta_prev`` in one step (backward Euler
    rates), and its derivative in ``delta``; also the two Prony forces it implies."""
    rate = (delta - delta_prev) / DT
    if delta > 0:
        soft = k_P * DELTA_REF / HERTZ_N * (delta / DELTA_REF) ** HERTZ_N
        d_soft = k_P * (delta / DELTA_REF) ** (HERTZ_N - 1)
    else:
        soft, d_soft = k_P * delta, k_P
    u = (delta - d_lim) / W_TRANS
    sig = 1.0 / (1.0 + math.exp(-u)) if u > -50 else 0.0
    splus = u + math.log1p(math.exp(-u)) if u > 0 else math.log1p(math.exp(u))
    elastic = soft + (k_H - k_P) * W_TRANS * splus
    d_elastic = d_soft + (k_H - k_P) * sig
    C = C_p + (C_h - C_p) * sig
    dC = (C_h - C_p) * sig * (1 - sig) / W_TRANS
    tsuji = c_tsuji * (max(delta, 0.0) / 5e-4) ** 0.25
    d_tsuji = 0.25 * tsuji / delta if delta > 1e-12 else 0.0
    p1 = (q1 + k1 * (delta - delta_prev)) / (1 + DT / tau1)
    p2 = (q2 + k2 * (delta - delta_prev)) / (1 + DT / tau2)
    force = elastic + (C + tsuji) * rate + p1 + p2
    d_force = d_elastic + (dC + d_tsuji) * rate + (C + tsuji) / DT + k1 / (1 + DT / tau1) + k2 / (1 + DT / tau2)
    return force, d_force, p1, p2


@njit(cache=True)
def _contact(pen, delta_prev, q1, q2, k_s, k_P, k_H, d_lim, C_p, C_h, c_tsuji, k1, tau1, k2, tau2):
    """Coating deflection where the finger/object springs ``k_s*(pen - delta)`` (never pulling) meet the coating's
    force: safeguarded Newton on a strictly decreasing balance. Returns (delta, contact force, q1, q2)."""
    def balance(d):
        f, df, p1, p2 = _coating(d, delta_prev, q1, q2, k_P, k_H, d_lim, C_p, C_h, c_tsuji, k1, tau1, k2, tau2)
        if pen - d > 0:
            return k_s * (pen - d) - f, -k_s - df
        return -f, -df
    lo, hi, width = delta_prev, delta_prev, 1e-6
    while balance(lo)[0] < 0:
        lo -= width
        width *= 2
    width = 1e-6
    while balance(hi)[0] > 0:
        hi += width
        width *= 2
    d = min(max(delta_prev, lo), hi)
    for _ in range(200):
        g, dg = balance(d)
        if abs(g) < 1e-9:  # N: converged at d
            break
        if g > 0:
            lo = d
        else:
            hi = d
        step = d - g / dg
        d = step if lo < step < hi else 0.5 * (lo + hi)
        if hi - lo < 1e-15:
            break
    f, df, p1, p2 = _coating(d, delta_prev, q1, q2, k_P, k_H, d_lim, C_p, C_h, c_tsuji, k1, tau1, k2, tau2)
    return d, k_s * max(pen - d, 0.0), p1, p2


@njit(cache=True)
def _bristle(z, speed, sigma0, level):
    """LuGre's bristle after one step at ``speed``: the exact solution of dz/dt = speed - sigma0 |speed| z / level."""
    a = sigma0 * abs(speed) / level
    if a == 0.0:
        return z
    z_ss = speed / a
    return z_ss + (z - z_ss) * math.exp(-a * DT)


@njit(cache=True)
def q_current(speed_mode, given, w, integral, dt):
    """A step's q current [A] and the speed loop's integral after it: the given current, or on the speed run the
    PI speed loop's output (gains ``K_PW``, ``K_IW``) on the speed reference ``given`` [rad/s]."""
    if not speed_mode:
        return given, integral
    return K_PW * (given - w) + K_IW * integral, integral + dt * (given - w)


@njit(cache=True)
def _load_cell_step(y, dy, force, w_lc, zeta_lc):
    """The second-order load cell ``y'' = w_lc^2 (force - y) - 2 zeta_lc w_lc y'`` one step on (semi-implicit
    Euler): its reading and rate."""
    dy += DT * (w_lc ** 2 * (force - y) - 2 * zeta_lc * w_lc * dy)
    return y + DT * dy, dy


@njit(cache=True)
def _integrate(inputs, speed_mode, steps_per_sample, eta, T_c0, play, gap0, t_coat, k_s, k_P, k_H, d_lim, C_p,
               C_h, c_tsuji, k1, tau1, k2, tau2, F_s, v_s, mu_F, cog_y, cog_period, f_lc, zeta_lc):
    """The plant of the module docstring at ``DT`` over ``len(inputs)`` samples. ``inputs``: the current [A] per
    sample, or (``speed_mode``) the motor speed reference [rad/s] of the PI loop. Returns per sample (before the
    sample's step): load-cell reading [N], contact force [N], motor angle [rad], q current [A], jaw travel [m]."""
    n = len(inputs)
    out = np.empty((n, 5))
    m = M_JF + J_P / (2 * R_P ** 2)
    B_g = T_MAX * (1 - eta) * RATIO ** 2 / OMEGA_MAX  # eq. (9): bearing damping at the gear output
    c_drive, c_back = 1 / eta - 1, 1 - eta
    w_lc = 2 * math.pi * f_lc
    n_cog = len(cog_y)
    theta = w = x = v = z_m = z_g = t_b = delta = q1 = q2 = y_lc = dy_lc = F_c = integral = 0.0
    for k in range(n * steps_per_sample):
        j = k // steps_per_sample
        i_q, integral = q_current(speed_mode, inputs[j], w, integral, DT)
        if k % steps_per_sample == 0:
            out[j, 0], out[j, 1], out[j, 2], out[j, 3], out[j, 4] = y_lc, F_c, theta, i_q, x
        # contact: coating in series with the finger/object springs
        delta, F_c, q1, q2 = _contact(x - (gap0 - t_coat), delta, q1, q2, k_s, k_P, k_H, d_lim, C_p, C_h, c_tsuji,
                                      k1, tau1, k2, tau2)
        # Nordin-Gutman backlash: Kelvin-Voigt shaft in series with a dead zone at position t_b
        rel, rel_rate = theta / RATIO - x / R_P, w / RATIO - v / R_P
        t_b_new = min(max(t_b + DT * (rel_rate + K_MESH / C_MESH * (rel - t_b)), -play / 2), play / 2)
        tau = K_MESH * (rel - t_b) + C_MESH * (rel_rate - (t_b_new - t_b) / DT)
        t_b = t_b_new
        tau_out = tau + B_g * w / RATIO  # the gear output's load: mesh shaft and bearing
        # motor: LuGre with the torque-proportional gear loss in its level
        cog = 0.0
        if n_cog:
            u = (theta % cog_period) / cog_period * n_cog
            i0 = int(u) % n_cog
            cog = cog_y[i0] + (cog_y[(i0 + 1) % n_cog] - cog_y[i0]) * (u - int(u))
        level = T_c0 + (c_drive if z_m * tau_out >= 0 else c_back) * abs(tau_out) / RATIO
        z_new = _bristle(z_m, w, 1 / PHI_M, 1 + (STRIBECK_M - 1) * math.exp(-(w / W_S_M) ** 2))
        T_f = level * (z_new / PHI_M + SIGMA1_M * (z_new - z_m) / DT)
        z_m = z_new
        w_new = w + DT * (K_T * i_q - B_R * w - tau_out / RATIO - cog - T_f) / J_M
        # jaw: rack, grease, LuGre guides (force units) with Stribeck breakaway and a load-dependent level
        g_level = F_GUIDE + mu_F * F_c + (F_s - F_GUIDE) * math.exp(-(v / v_s) ** 2)
        zg_new = _bristle(z_g, v, SIGMA0_G, g_level)
        F_guide = SIGMA0_G * zg_new + SIGMA1_G * (zg_new - z_g) / DT
        z_g = zg_new
        v_new = v + DT * (tau / (2 * R_P) - C_GREASE * v - F_c - F_guide) / m
        y_lc, dy_lc = _load_cell_step(y_lc, dy_lc, F_c, w_lc, zeta_lc)
        w, v = w_new, v_new
        theta += DT * w
        x += DT * v
    return out


def experiment_input(experiment, gap0=None, profile=None):
    """The input every gripper truth plays in ``experiment``: (the object's travel ``gap0`` [m], default the
    experiment's; the sample rate [Hz]; the sample times [s]; the input per sample, the q current [A] or on the
    speed run the speed reference [rad/s]). ``profile``: (time [s], input) corners joined by straight lines in
    place of the experiment's input, over its last corner."""
    _experiment(experiment)
    gap0 = (CONDITION["gap0"] if experiment == "impact" else SLIDE_GAP0) if gap0 is None else gap0
    rate = RATE_HZ if experiment == "impact" else SLIDE_RATE_HZ
    duration = {"impact": DURATION, "slide": SLIDE_PROFILE[-1][0], "speed": SPEED_PROFILE[-1][0]}[experiment]
    time = np.arange(int(round((profile[-1][0] if profile else duration) * rate))) / rate
    if profile:
        given = np.interp(time, *zip(*profile))
    elif experiment == "impact":
        given = np.where(time >= T_STEP - 1e-12, I_STEP, 0.0)
    else:
        given = np.interp(time, *zip(*(SPEED_PROFILE if experiment == "speed" else SLIDE_PROFILE)))
    return gap0, rate, time, given


def simulate(truth, experiment="impact", gap0=None, profile=None):
    """One noise-free record of ``experiment`` for the parameters ``truth`` (a dict from
    :func:`make_case_impact2`; ``eta_g`` and ``T_c0`` are enough for the baseline), the object at ``gap0`` [m] of
    travel (default: the experiment's). Returns (time [s], input, load-cell reading [N] with its offset, contact
    force [N], motor angle [rad], q current [A], jaw travel [m]): the input is the current [A] per sample, or for
    the speed run the speed reference [rad/s]. ``profile``: (time [s], input) corners joined by straight lines in
    place of the experiment's input (for the tests), at the experiment's rate and over its last corner."""
    gap0, rate, time, given = experiment_input(experiment, gap0, profile)
    c, t = CONDITION, truth
    k_rel = t.get("k_rel", 0.0) * c["k_P"]
    cog = cogging_table(t["T_cog"], t["phase_cog"])[1] if "T_cog" in t else np.zeros(0)
    out = _integrate(np.ascontiguousarray(given, dtype=float), experiment == "speed",
                     int(round(1.0 / (rate * DT))), t["eta_g"], t["T_c0"], t.get("play", PLAY_NOMINAL), gap0,
                     c["t_coat"], 1.0 / (1.0 / K_F + 1.0 / c["k_obj"]), c["k_P"], c["k_H_ratio"] * c["k_P"],
                     c["d_lim"], c["C_p"], c["C_h"], t.get("c_tsuji", 0.0), k_rel * t.get("split", 0.5),
                     t.get("tau_rel1", 0.05), k_rel * (1 - t.get("split", 0.5)), t.get("tau_rel2", 0.2),
                     t.get("F_sj", F_GUIDE), t.get("v_s", V_S_G), t.get("mu_F", 0.0), np.asarray(cog, dtype=float),
                     2 * np.pi / 24, t.get("f_lc", F_LC_NOMINAL), t.get("zeta_lc", ZETA_LC_NOMINAL))
    return time, given, out[:, 0] + t.get("F_off", 0.0), out[:, 1], out[:, 2], out[:, 3], out[:, 4]


def draw_truth(effect, rng):
    """The drawn parameters of one case of ``effect`` (module docstring: the ranges), by the Modelica's names where
    there is one."""
    if effect not in TRUTH2_IMPACT_EFFECTS:
        raise ValueError(f"effect must be one of {', '.join(TRUTH2_IMPACT_EFFECTS)}; got {effect!r}")
    truth = draw_baseline(effect, rng)
    if effect == "contact_damping":
        truth["c_tsuji"] = float(rng.uniform(100.0, 300.0))
    elif effect == "coating_relaxation":
        truth.update(k_rel=float(rng.uniform(0.5, 2.0)), split=float(rng.uniform(0.3, 0.7)),
                     tau_rel1=float(rng.uniform(0.03, 0.1)), tau_rel2=float(rng.uniform(0.15, 0.4)))
    elif effect == "stiction":
        truth.update(F_sj=float(rng.uniform(3.0, 10.0)), v_s=float(rng.uniform(5e-4, 2e-3)))
    elif effect == "cogging":
        truth.update(T_cog=float(rng.uniform(1.5e-3, 4e-3)), phase_cog=float(rng.uniform(0, 2 * np.pi)))
    elif effect == "load_dependent_friction":
        truth["mu_F"] = float(rng.uniform(0.01, 0.05))
    elif effect == "loadcell_filter":
        truth.update(f_lc=float(rng.uniform(4.0, 15.0)), zeta_lc=float(rng.uniform(0.5, 1.0)),
                     F_off=float(rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 3.0)))
    return truth


def make_case_impact2(effect, rng, noise=FORCE_NOISE, trials=1, experiment="impact"):
    """A random hidden-effect case of this truth in the first truth's structure (``make_case`` of
    diagnose_truth_impact.py): (records, truth dict), the records as :func:`measured_records` gives them."""
    truth = draw_truth(effect, rng)
    return measured_records(simulate, truth, rng, noise, trials, experiment), truth


def effect_signal2(case, experiment="impact"):
    """RMS change the hidden effect alone makes to the case's noise-free records (:func:`hidden_effect_signal`)."""
    return hidden_effect_signal(simulate, case, experiment)


# -- the evaluation: diagnose drawn cases of both truths and count them side by side -------------------------------

MODELS = {"impact": "Gripper.GripperCurrentDriven", "slide": "Gripper.GripperCurrentDriven",
          "speed": "Gripper.GripperSpeedControlled"}


def library(experiment):
    """Every effect of the library that applies to the model of ``experiment`` (the whole library is offered),
    and every form with ``diagnose_truth2.OFFER_FORMS``."""
    import diagnose_truth2
    from cosim.diagnose.effects import applicable
    from diagnose_truth import SOURCE

    text = SOURCE.read_text(encoding="utf-8")
    return applicable(text, MODELS[experiment]) + (
        applicable(text, MODELS[experiment], forms=True) if diagnose_truth2.OFFER_FORMS else [])


def diagnose_records(case, seed, folder, experiment, workers=2, max_nfev=20):
    """Diagnose ``case`` ((records, truth) of any truth) with the first truth's ``write_job`` offering the
    whole library of the experiment's model, no FMU build. Returns one row with the keys of
    ``diagnose_truth2.diagnose_frame`` (``noise``: the compared channel's noise sd)."""
    import time
    from pathlib import Path

    from cosim.diagnose import load_diagnose_job, run_diagnosis
    from diagnose_truth import SOURCE
    from diagnose_truth2 import diagnosis_row
    from diagnose_truth_impact import write_job

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    truth = case[1]
    job = load_diagnose_job(write_job(folder, SOURCE, case, library(experiment), workers, max_nfev, experiment))
    start = time.perf_counter()
    s = run_diagnosis(job, progress=False, build=False).to_json()
    return diagnosis_row(s, truth, seed, CURRENT_NOISE if experiment == "speed" else FORCE_NOISE,
                         time.perf_counter() - start)


def diagnose_case_impact2(effect, seed, folder, experiment="impact", workers=2):
    """Diagnose this truth's case (``effect``, ``seed``) of ``experiment``; one row (:func:`diagnose_records`)."""
    case = make_case_impact2(effect, np.random.default_rng(seed), experiment=experiment)
    return {**diagnose_records(case, seed, folder, experiment, workers), "experiment": experiment,
            "truth_model": 2, "effect_signal": effect_signal2(case, experiment)}


def diagnose_case_impact1(effect, seed, folder, experiment="impact", workers=2):
    """The same row for the first truth's case (``diagnose_truth_impact.make_case``), for the side-by-side count."""
    from diagnose_truth_impact import effect_signal, make_case

    case = make_case(effect, np.random.default_rng(seed), experiment=experiment)
    return {**diagnose_records(case, seed, folder, experiment, workers), "experiment": experiment,
            "truth_model": 1, "effect_signal": effect_signal(case, experiment)}


def truth_case_functions(draw_truth, simulate, truth_model):
    """A further gripper truth's ``make_case``, ``effect_signal`` and ``diagnose_case`` (the signatures and rows of
    :func:`make_case_impact2`, :func:`effect_signal2`, :func:`diagnose_case_impact2`, ``truth_model`` in its rows)
    from its ``draw_truth`` (effect, rng -> truth dict) and ``simulate`` (as :func:`simulate`)."""
    def make_case(effect, rng, noise=FORCE_NOISE, trials=1, experiment="impact"):
        truth = draw_truth(effect, rng)
        return measured_records(simulate, truth, rng, noise, trials, experiment), truth

    def effect_signal(case, experiment="impact"):
        return hidden_effect_signal(simulate, case, experiment)

    def diagnose_case(effect, seed, folder, experiment="impact", workers=2):
        case = make_case(effect, np.random.default_rng(seed), experiment=experiment)
        return {**diagnose_records(case, seed, folder, experiment, workers), "experiment": experiment,
                "truth_model": truth_model, "effect_signal": effect_signal(case, experiment)}

    return make_case, effect_signal, diagnose_case


def diagnose_experiments_case(draw_truth, simulate, truth_model):
    """A case function (effect, seed, folder, workers) -> row for ``benchmarks/diagnose.py``: one gripper of a
    truth (its ``draw_truth`` and ``simulate``, as :func:`truth_case_functions` takes them) measured by an impact
    and a slide, diagnosed in one job of both (``[[experiments]]``) with the whole library of the current-driven
    model offered; the row also says which records showed the first finding (``shown_by``)."""
    def diagnose_case(effect, seed, folder, workers=2):
        import time
        from pathlib import Path

        from cosim.diagnose import load_diagnose_job, run_diagnosis
        from diagnose_truth import SOURCE
        from diagnose_truth2 import diagnosis_row
        from diagnose_truth_impact import write_experiments_job

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        rng = np.random.default_rng(seed)
        truth = draw_truth(effect, rng)
        records = {e: measured_records(simulate, truth, rng, FORCE_NOISE, 1, e)[0] for e in ("impact", "slide")}
        job = load_diagnose_job(write_experiments_job(folder, SOURCE, records, library("impact"), workers))
        start = time.perf_counter()
        s = run_diagnosis(job, progress=False, build=False).to_json()
        return {**diagnosis_row(s, truth, seed, FORCE_NOISE, time.perf_counter() - start),
                "experiment": "impact+slide", "truth_model": truth_model, "shown_by": s["shown_by"]}
    return diagnose_case
