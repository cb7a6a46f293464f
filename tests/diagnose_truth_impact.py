"""Hidden-effect impact data for the discrepancy workflow's tests and benchmark: a reduced gripper written from the
gripper paper's equations (3-11) in numpy, independently of the Modelica plant and of the candidates' Modelica.

The experiment: the q current steps from 0 to ``I_STEP`` at ``T_STEP`` and is held; the P2-coated fingers close
5 mm onto the ABS cylinders (condition ``P2_dynamic_abs`` of cosim/data/gripper_conditions.csv), hit, and the
gear holds the force the impact leaves. Measured as on the paper's test bench: the load cell at 100 Hz with
Gaussian noise, the 2048 cpt motor encoder (whole counts, truncated) at the same instants.

Formulation (each element written differently from the Modelica):

* motor: ``J*dw/dt = k_t*i - B_r*w - tau_f - tau_L``, ``tau_L`` the gear's load referred to the motor;
* drag ``T_c0`` and the mesh loss are one *Karnopp* friction on the motor shaft: its capacity is the drag plus
  ``(1/eta - 1)*|tau_L|`` when the motor drives the load and ``(1 - eta)*|tau_L|`` when the load drives it;
  inside the speed window ``W_STICK`` the shaft sticks while the torque it must hold lies inside that band. While
  sliding, the friction is that capacity times a *Dahl* state ``s`` that turns towards the direction of motion
  over the presliding angle ``PHI_DAHL`` (the Modelica: elasto-plastic bristle states with their own law);
* play: a *dead-band spring* at the gear output (stiffness ``C_PLAY`` while engaged; damping ``D_PLAY`` no larger
  than the spring torque, so the torque is continuous at engagement and never pulls), bearing damping
  ``B_g = T_max*(1 - eta)*N^2/omega_max`` (eq. 9);
* jaws: rack and pinion, grease ``4*eta_grease*S/d*v`` (eq. 11) and guide friction as a Karnopp friction (window
  ``V_STICK``, static level = sliding level unless the effect ``stiction`` raises it; both levels grow by
  ``mu_F`` times the contact force with the effect ``load_dependent_friction``);
* contact: finger, coating and object springs in series, the coating two-region; Kelvin-Voigt damping switched
  (not blended) between ``C_p`` and ``C_h`` at the region boundary, clamped so the contact cannot pull.

Hidden effects: ``gear_play`` (play 0.3-0.55 deg or 1.1-1.6 deg instead of 0.8 deg), ``contact_damping`` (a
dissipative law ``c_hc*pen^p_hc*v`` with an exponent ``p_hc`` in [1.2, 1.8], not the candidate's force-proportional
Hunt-Crossley term), ``coating_relaxation`` (one Prony term: an internal coating force ``q`` updated by the
recursive exponential integrator of finite-element viscoelasticity, not the candidate's dashpot state),
``stiction`` (Karnopp breakaway ``F_s`` 3-10 N above the sliding guide friction, against the candidate's
elasto-plastic bristle with a Stribeck curve), ``cogging`` (a detent energy tabulated over one period with a second
harmonic, its torque a spline derivative: :class:`TabulatedCogging`; the candidate is one sinusoid),
``load_dependent_friction`` (the guide's Karnopp levels, static and sliding, raised by ``mu_F`` times the contact
force; the candidate: a bristle friction of level ``mu_F*F_g``), or ``none``. Every case draws ``eta`` and
``T_c0`` near their nominal values (the baseline's free parameters, with the Modelica's presliding angle ``phi_b``
on the impact: see ``PHI_B_START``).

Integration: semi-implicit Euler with a fixed step ``DT`` (stable for the stiffest element, the dead-band spring
on the jaw, and for the contact damping; a quarter of it changes the sampled force by <= 0.1 N).
"""

import math

import numpy as np

from diagnose_truth import free_and_candidates

__all__ = ["TRUTH_EFFECTS", "CONDITION", "FORCE_NOISE", "COUNTS", "simulate", "draw_baseline", "draw_truth",
           "make_case", "record_of", "effect_signal", "measured_records", "hidden_effect_signal", "write_job",
           "write_experiments_job", "SHOWN_IN",
           "check_seed_gives_same_case", "check_effect_changes_record", "check_play_seen_at_reversal"]

TRUTH_EFFECTS = ("none", "gear_play", "contact_damping", "coating_relaxation", "stiction", "cogging",
                 "load_dependent_friction")

# the paper's values (Table 1, Sec. 3; docs/models/gripper.md) where the Modelica plant takes them
K_T, J_M, B_R = 0.0393939394, 1.01e-5, 1.01e-5    # N.m/A, kg.m2 (rotor + gear input), N.m.s/rad
RATIO, T_MAX, OMEGA_MAX = 28.0, 0.13, 628.3185    # 1, N.m, rad/s
PLAY_NOMINAL, C_PLAY, D_PLAY = math.radians(0.8), 1000.0, 0.05  # rad, N.m/rad, N.m.s/rad (gear output)
R_P, J_P, M_JF = 0.008957, 7.94e-7, 0.08          # m, kg.m2, kg
C_GREASE = 4 * 0.2 * 2e-4 / 5e-5                  # N.s/m, eq. (11): n_s*eta*S/d
F_GUIDE = 0.0785                                  # N, sliding guide friction per jaw
K_F = 1.46e6                                      # N/m, finger
# contact condition P2_dynamic_abs (cosim/data/gripper_conditions.csv)
CONDITION = {"gap0": 0.0075, "t_coat": 0.0025, "k_obj": 3.53e7, "k_P": 1.8e5, "k_H_ratio": 100.0,
             "d_lim": 0.0015, "C_p": 10.0, "C_h": 2000.0}

T_STEP, I_STEP, DURATION = 0.05, 1.0, 1.0         # s, A, s
RATE_HZ, FORCE_NOISE, COUNTS = 100.0, 0.5, 2048   # Hz, N (1 sd), counts per revolution
DT = 1e-5                                         # s, integrator step
W_STICK, V_STICK = 1e-3, 1e-5                     # rad/s, m/s: Karnopp stick windows
PHI_DAHL = 1e-3                                   # rad, presliding angle of the motor-shaft friction
# The jobs free the Modelica's presliding angle phi_b (an estimate there, 1 mrad) with eta_g and T_c0, within a
# factor two of it: its elasto-plastic bristle and this Dahl law rebound differently after the impact at the same
# angle (at 1 mrad the Modelica's rebound is 3-5 counts off, the same in every trial; at 0.6-0.7 mrad the force
# is closer), a gap above the encoder's floor that any candidate bending the rebound took for a missing effect.
# Free down to 0.1 mrad, phi_b bent a detent torque's rest angles away; free on the slide, it traded with the
# guides' sliding friction F_cj, so the slide keeps eta_g and T_c0 only (docs/dev/diagnose-history.md, ninth round).
PHI_B_START = 1e-3                                # rad
N_COG = 24                                        # cogging periods per revolution (motor geometry, as the Modelica's)
PLACEMENT = 1e-4                                  # m: scatter of the object's position over repeated trials
# The slide (``experiment="slide"``), an attempt to show the guides' breakaway: 0.3 A moves the jaws a little,
# 0.1 A stops them with the play closed on the driving flank, a ramp to 0.55 A restarts them against the guides,
# 0.1 A stops them again, a ramp to 0.8 A restarts them and closes them on the object 15 mm away. Diagnosed as a
# staircase (every sample compared) whose holds put the two restarts in different folds. (time [s], current [A])
SLIDE_PROFILE = ((0.0, 0.3), (0.1, 0.3), (0.1, 0.1), (0.25, 0.1), (0.65, 0.55), (0.65, 0.1), (0.9, 0.1),
                 (1.4, 0.8), (1.7, 0.8))
SLIDE_GAP0 = 0.015                                # m, travel to the object in the slide
SLIDE_RATE_HZ = 1000.0                            # Hz: the slide's current and encoder (the load cell stays at 100 Hz)
# The speed run (``experiment="speed"``), the classic cogging measurement: jaws free, a PI speed loop of ~30 Hz
# bandwidth (not the paper's 100 Hz PID: an identification run) holds four slow motor speeds for 0.35 s each; a
# torque periodic in the rotor angle shows as a ripple of the current the loop takes. The current sensor has
# CURRENT_NOISE; current and encoder at SLIDE_RATE_HZ, no load cell. (time [s], motor speed reference [rad/s])
SPEED_PROFILE = ((0.0, 0.0), (0.05, 0.0), (0.05, 2.0), (0.4, 2.0), (0.4, 3.5), (0.75, 3.5), (0.75, 2.5),
                 (1.1, 2.5), (1.1, 4.0), (1.45, 4.0))
K_PW, K_IW = 0.05, 2.5                            # A.s/rad, A/rad: the speed loop (the Modelica's defaults)
CURRENT_NOISE = 0.01                              # A (1 sd): the q current as the drive measures it
EXPERIMENTS = ("impact", "slide", "speed")


def simulate(eta=0.68, T_c0=7.88e-3, play=PLAY_NOMINAL, F_s=F_GUIDE, c_hc=0.0, p_hc=1.5, k_prony=0.0,
             tau_prony=0.1, cogging=None, mu_F=0.0, current=I_STEP, gap0=CONDITION["gap0"], rate_hz=RATE_HZ,
             duration=DURATION, profile=None, speeds=None):
    """Noise-free force [N] and motor angle [rad] at ``rate_hz`` for a q-current step to ``current`` [A] at
    ``T_STEP``, or for ``profile``: (time [s], current [A]) corners joined by straight lines; the current is held
    between samples, as the replay plays it. With ``speeds`` ((time [s], motor speed [rad/s]) corners, held
    between samples) a PI speed loop (``K_PW``, ``K_IW``) sets the current at every step. Returns (time, i, F,
    theta), ``i`` the current at each sample.

    Parameters: mesh efficiency ``eta`` [1], drag ``T_c0`` [N.m], total play ``play`` [rad], guide breakaway
    ``F_s`` [N] per jaw, guide friction ``mu_F`` [1] per unit contact force, extra contact damping
    ``c_hc*pen^p_hc`` [N.s/m, pen in m], Prony stiffness ``k_prony`` [N/m] and time constant ``tau_prony`` [s] of
    the coating, ``cogging(theta)`` a motor cogging torque [N.m] against positive rotation, ``gap0`` [m] the
    travel from the start to the object."""
    c = {**CONDITION, "gap0": gap0}
    k_s = 1.0 / (1.0 / K_F + 1.0 / c["k_obj"])
    k_P, k_H, d_lim = c["k_P"], c["k_H_ratio"] * c["k_P"], c["d_lim"]
    B_g = T_MAX * (1 - eta) * RATIO ** 2 / OMEGA_MAX
    m = M_JF + J_P / (2 * R_P ** 2)
    decay = math.exp(-DT / tau_prony)
    gain = k_prony * (1 - decay) * tau_prony / DT  # Prony increment per unit coating deflection change
    steps_per_sample = int(round(1.0 / (rate_hz * DT)))
    n = int(round(duration * rate_hz))
    time = np.arange(n) / rate_hz
    currents = np.interp(time, *zip(*profile)) if profile else np.where(time >= T_STEP - 1e-12, current, 0.0)
    references = np.interp(time, *zip(*speeds)) if speeds else None
    theta = w = x = v = q = delta = s = F_contact = speed_error = 0.0
    out = np.empty((n, 2))
    for k in range(n * steps_per_sample):
        if speeds:
            w_ref = references[k // steps_per_sample]
            i_q = K_PW * (w_ref - w) + K_IW * speed_error
            speed_error += DT * (w_ref - w)
        else:
            i_q = currents[k // steps_per_sample]
        if k % steps_per_sample == 0:
            out[k // steps_per_sample] = F_contact, theta
            currents[k // steps_per_sample] = i_q
        # dead-band spring at the gear output
        rel = theta / RATIO - x / R_P
        rel_rate = w / RATIO - v / R_P
        engaged = abs(rel) - play / 2
        tau_bl = 0.0
        if engaged > 0:
            side = 1.0 if rel > 0 else -1.0
            spring = C_PLAY * engaged
            tau_bl = side * (spring + min(max(D_PLAY * side * rel_rate, -spring), spring))
        tau_L = (tau_bl + B_g * w / RATIO) / RATIO
        # motor shaft: Karnopp friction with the efficiency band
        drive = K_T * i_q - B_R * w - tau_L - (cogging(theta) if cogging else 0.0)
        if abs(w) < W_STICK:
            direction = 1.0 if drive > 0 else -1.0
            band = T_c0 + ((1 / eta - 1) if direction * tau_L > 0 else (1 - eta)) * abs(tau_L)
            if abs(drive) <= band:
                w_new, s = 0.0, drive / band  # stuck: the friction holds the torque, its state says how much
            else:
                w_new = w + DT * (drive - direction * band) / J_M
        else:
            capacity = T_c0 + ((1 / eta - 1) if s * tau_L > 0 else (1 - eta)) * abs(tau_L)
            w_new = w + DT * (drive - s * capacity) / J_M
            if w_new * w < 0:
                w_new = 0.0
        # contact: finger + object springs in series with the two-region coating and its Prony term
        pen = x - (c["gap0"] - c["t_coat"])
        carried = decay * q - gain * delta
        delta_new = (k_s * max(pen, 0.0) - carried) / (k_s + k_P + gain)
        if delta_new > d_lim:
            delta_new = (k_s * max(pen, 0.0) - carried - (k_P - k_H) * d_lim) / (k_s + k_H + gain)
        F_el = k_s * (max(pen, 0.0) - delta_new)
        if pen <= 0 or F_el < 0:  # not touching: the free coating relaxes under its internal force alone
            delta_new = -carried / (k_P + gain)
            F_el = 0.0
        q = carried + gain * delta_new
        delta = delta_new
        C = c["C_p"] if delta < d_lim else c["C_h"]
        F_contact = max(0.0, F_el + (C + c_hc * max(pen, 0.0) ** p_hc) * v) if pen > 0 else 0.0
        # jaw: rack force, grease, Karnopp guide friction
        F_jaw = tau_bl / (2 * R_P) - C_GREASE * v - F_contact
        sliding = F_GUIDE + mu_F * F_contact
        if abs(v) < V_STICK:
            direction = 1.0 if F_jaw > 0 else -1.0
            v_new = 0.0 if abs(F_jaw) <= F_s + mu_F * F_contact else v + DT * (F_jaw - direction * sliding) / m
        else:
            v_new = v + DT * (F_jaw - (sliding if v > 0 else -sliding)) / m
            if v_new * v < 0:
                v_new = 0.0
        # Dahl state of the motor-shaft friction: turns towards the direction of motion over PHI_DAHL
        if w_new != 0.0:
            sign = 1.0 if w_new > 0 else -1.0
            s = sign + (s - sign) * math.exp(-abs(w_new) * DT / PHI_DAHL)
        w, v = w_new, v_new
        theta += DT * w
        x += DT * v
    return time, currents, out[:, 0], out[:, 1]


class TabulatedCogging:
    """Cogging as a motor designer gets it from a field solver: the detent energy tabulated over one cogging
    period (64 points), its torque the derivative of a periodic cubic spline through the table (against positive
    rotation). The energy has a fundamental of torque amplitude ``T_1`` [N.m] and a second harmonic ``T_2``;
    the candidate has the fundamental only."""

    def __init__(self, T_1, phase_1, T_2, phase_2, n=N_COG, points=64):
        from scipy.interpolate import CubicSpline

        self.period = 2 * np.pi / n
        x = np.linspace(0.0, self.period, points + 1)
        energy = T_1 / n * (1 - np.cos(n * x + phase_1)) + T_2 / (2 * n) * (1 - np.cos(2 * n * x + phase_2))
        energy[-1] = energy[0]
        self.torque = CubicSpline(x, energy, bc_type="periodic").derivative()

    def __call__(self, theta):
        return float(self.torque(theta % self.period))


def draw_baseline(effect, rng):
    """The truth dict's start for a case of ``effect``: the baseline's free parameters (``eta_g``, ``T_c0``) near
    their nominal values and, for ``gear_play``, the play. Both impact truths draw them here, first and in this
    order, so one seed gives a case of either truth the same baseline."""
    truth = {"effect": effect, "eta_g": float(rng.uniform(0.62, 0.74)), "T_c0": float(rng.uniform(6e-3, 1e-2))}
    if effect == "gear_play":
        truth["play"] = math.radians(rng.uniform(0.3, 0.55) if rng.random() < 0.5 else rng.uniform(1.1, 1.6))
    return truth


def make_case(effect, rng, noise=FORCE_NOISE, trials=1, experiment="impact"):
    """A random hidden-effect case: one gripper with one draw of its parameters and ``trials`` repeated impacts
    (the paper's protocol repeats each condition), slides (``experiment="slide"``: ``SLIDE_PROFILE``) or speed
    runs (``"speed"``: ``SPEED_PROFILE``). Trial 0 has the object at ``CONDITION["gap0"]`` (slide and speed run:
    ``SLIDE_GAP0``); each further trial places it anew within ``PLACEMENT`` of that, so the rotor comes to rest at
    another angle. Returns (records, truth dict), each record (time, input, measured channel, measured angle,
    {"gap0": travel [m]}): the current and the force (``noise`` [N]), or for the speed run the speed reference
    and the current (``CURRENT_NOISE``). The slide's and speed run's rows are at ``SLIDE_RATE_HZ``, the slide's
    force NaN between the load cell's samples at ``RATE_HZ``.

    The truth dict holds the drawn parameters under the names of the Modelica parameters they correspond to
    where there is one (``eta_g``, ``T_c0``, ``play``, ``F_sj``)."""
    truth = draw_truth(effect, rng)
    return measured_records(record_of, truth, rng, noise, trials, experiment), truth


def draw_truth(effect, rng):
    """One gripper's drawn parameters with the hidden ``effect`` (the truth dict of :func:`make_case`)."""
    if effect not in TRUTH_EFFECTS:
        raise ValueError(f"truth effect must be one of {', '.join(TRUTH_EFFECTS)}; got {effect!r}")
    truth = draw_baseline(effect, rng)
    if effect == "contact_damping":
        truth["p_hc"] = float(rng.uniform(1.2, 1.8))
        c_ref = rng.uniform(100.0, 300.0)  # N.s/m at 0.5 mm penetration
        truth["c_hc"] = float(c_ref / 5e-4 ** truth["p_hc"])
        truth["c_at_0.5mm"] = float(c_ref)
    elif effect == "coating_relaxation":
        truth["k_rel"] = float(rng.uniform(0.5, 2.0))
        truth["tau_rel"] = float(rng.uniform(0.05, 0.3))
    elif effect == "stiction":
        truth["F_sj"] = float(rng.uniform(3.0, 10.0))
    elif effect == "load_dependent_friction":
        truth["mu_F"] = float(rng.uniform(0.01, 0.05))
    elif effect == "cogging":
        truth["T_cog"], truth["phase_cog"] = float(rng.uniform(1.5e-3, 4e-3)), float(rng.uniform(-np.pi, np.pi))
        truth["T_cog2"] = float(truth["T_cog"] * rng.uniform(0.1, 0.3))
        truth["phase_cog2"] = float(rng.uniform(-np.pi, np.pi))
    return truth


def effect_signal(case, experiment="impact"):
    """How much the hidden effect alone changes the case's records (:func:`hidden_effect_signal`): an upper bound
    on the evidence a diagnosis can find, since the baseline's free parameters may absorb part of it."""
    return hidden_effect_signal(record_of, case, experiment)


def record_of(truth, experiment, gap0):
    """One noise-free record of ``experiment`` for a truth dict from :func:`make_case`, the object at ``gap0`` [m],
    in the form the other truths' ``simulate`` gives it: (time [s], input, load-cell reading [N] (ideal: the
    contact force), contact force [N], motor angle [rad], q current [A], None: the jaw travel is not kept)."""
    t, i, force, theta = _run(experiment, gap0, _simulate_arguments(truth))
    given = np.interp(t, *zip(*SPEED_PROFILE)) if experiment == "speed" else i
    return t, given, force, force, theta, i, None


def measured_records(simulate, truth, rng, noise, trials, experiment):
    """The records a gripper truth's ``simulate`` (truth dict, experiment, travel [m] -> (time, input, load-cell
    reading, contact force, motor angle, q current, jaw travel)) gives for ``truth``, measured on the test bench:
    each (time, input, measured channel, measured angle, {"gap0": travel [m]}); the load-cell reading with
    ``noise`` [N] at 100 Hz (NaN between its samples on the slide), or on the speed run the current with
    ``CURRENT_NOISE``; the angle in whole encoder counts (truncated). Trial 0 has the object at the experiment's
    distance, further trials within ``PLACEMENT`` of it."""
    _experiment(experiment)
    records = []
    for k in range(trials):
        placed = (CONDITION["gap0"] if experiment == "impact" else SLIDE_GAP0) + \
            (rng.uniform(-PLACEMENT, PLACEMENT) if k else 0.0)
        t, given, reading, _, theta, current, _ = simulate(truth, experiment, placed)
        angle = np.floor(theta * COUNTS / (2 * np.pi)) * (2 * np.pi / COUNTS)
        if experiment == "speed":
            records.append((t, given, current + rng.normal(0.0, CURRENT_NOISE, len(t)), angle, {"gap0": placed}))
            continue
        sampled = np.arange(len(t)) % (int(round(SLIDE_RATE_HZ / RATE_HZ)) if experiment == "slide" else 1) == 0
        measured = np.full(len(t), np.nan)
        measured[sampled] = reading[sampled] + rng.normal(0.0, noise, int(sampled.sum()))
        records.append((t, given, measured, angle, {"gap0": placed}))
    return records


def hidden_effect_signal(simulate, case, experiment):
    """RMS change the hidden effect alone makes to a case's noise-free records under a gripper truth's
    ``simulate`` (the truth with the effect less the truth without it, same ``eta_g``, ``T_c0``, object
    positions): (compared channel, motor angle [rad]); the compared channel is the load cell at its samples [N],
    or the current [A] on the speed run. Zero for ``none``."""
    records, truth = case
    if truth["effect"] == "none":
        return 0.0, 0.0
    base = {"eta_g": truth["eta_g"], "T_c0": truth["T_c0"]}
    column = 5 if experiment == "speed" else 2
    channel, angle = [], []
    for record in records:
        run_1, run_0 = simulate(truth, experiment, record[4]["gap0"]), simulate(base, experiment, record[4]["gap0"])
        channel.append((run_1[column] - run_0[column])[np.isfinite(record[2])])
        angle.append(run_1[4] - run_0[4])
    return (float(np.sqrt(np.mean(np.concatenate(channel) ** 2))),
            float(np.sqrt(np.mean(np.concatenate(angle) ** 2))))


# effect -> the experiment whose record the gripper truths' checks size it on
SHOWN_IN = {"gear_play": "impact", "contact_damping": "impact", "coating_relaxation": "impact",
            "load_dependent_friction": "impact", "loadcell_filter": "impact", "stiction": "slide", "cogging": "speed"}


def check_seed_gives_same_case(make_case, other_draws, seed):
    """A check every further gripper truth runs: one seed gives the same two-trial ``gear_play`` case of
    ``make_case`` twice, the same ``eta_g``, ``T_c0`` and play as each of ``other_draws`` (rng -> truth dict: the
    other truths, ``draw_baseline`` first), a whole impact record and the angle in whole counts."""
    one = make_case("gear_play", np.random.default_rng(seed), trials=2)
    two = make_case("gear_play", np.random.default_rng(seed), trials=2)
    for a, b in zip(one[0], two[0]):
        for column in range(4):
            np.testing.assert_array_equal(a[column], b[column])
        assert a[4] == b[4]
    for draw in other_draws:
        other = draw(np.random.default_rng(seed))
        for key in ("eta_g", "T_c0", "play"):
            assert one[1][key] == other[key], key
    t, _, measured, angle, _ = one[0][0]
    count = 2 * np.pi / COUNTS
    assert np.all(np.isfinite(measured)) and len(t) == int(RATE_HZ)
    assert np.all(np.abs(angle / count - np.round(angle / count)) < 1e-6)


def check_effect_changes_record(make_case, effect_signal, effect, seed):
    """A check every further gripper truth runs: ``effect``, drawn from ``seed``, changes the noise-free record of
    the experiment that shows it (``SHOWN_IN``) by more than a fifth of the compared channel's noise or more than a
    count of the encoder (RMS); ``none`` changes nothing."""
    experiment = SHOWN_IN.get(effect, "impact")
    channel, angle = effect_signal(make_case(effect, np.random.default_rng(seed), experiment=experiment), experiment)
    if effect == "none":
        assert (channel, angle) == (0.0, 0.0)
        return
    noise = CURRENT_NOISE if experiment == "speed" else FORCE_NOISE
    assert channel > 0.2 * noise or angle > 2 * np.pi / COUNTS, (channel, angle * COUNTS / (2 * np.pi))


def check_play_seen_at_reversal(simulate, draw, play_deg):
    """A check every further gripper truth runs with its ``simulate`` (truth dict, experiment, gap0, profile -> the
    record with the jaw travel last): jaws free, 0.3 A closing then -0.3 A opening, the encoder turns back between
    steady closing and steady opening by the jaws' travel times N/r_p plus the play ``play_deg`` times N, within 2
    counts (two truncated readings; the mesh's deflection under the rack's small load is negligible)."""
    count = 2 * np.pi / COUNTS
    profile = ((0.0, 0.3), (0.3, 0.3), (0.3, -0.3), (0.6, -0.3))
    t, _, _, _, theta, _, x = simulate({**draw, "play": math.radians(play_deg)}, experiment="slide", gap0=10.0,
                                       profile=profile)
    angle = np.floor(theta / count) * count
    closing, opening = np.searchsorted(t, 0.29), len(t) - 1
    assert x[opening] < x[closing] and theta[opening] < theta[closing]
    seen = (angle[closing] - angle[opening]) - (x[closing] - x[opening]) * RATIO / R_P
    assert abs(seen - math.radians(play_deg) * RATIO) < 2 * count, (seen / count, play_deg * RATIO)


def _simulate_arguments(truth):
    """The :func:`simulate` keywords of a truth dict from :func:`make_case` (drawn parameters by Modelica name)."""
    kw = {"eta": truth["eta_g"], "T_c0": truth["T_c0"]}
    if "play" in truth:
        kw["play"] = truth["play"]
    if "c_hc" in truth:
        kw["c_hc"], kw["p_hc"] = truth["c_hc"], truth["p_hc"]
    if "k_rel" in truth:
        kw["k_prony"], kw["tau_prony"] = truth["k_rel"] * CONDITION["k_P"], truth["tau_rel"]
    if "F_sj" in truth:
        kw["F_s"] = truth["F_sj"]
    if "mu_F" in truth:
        kw["mu_F"] = truth["mu_F"]
    if "T_cog" in truth:
        kw["cogging"] = TabulatedCogging(truth["T_cog"], truth["phase_cog"], truth["T_cog2"], truth["phase_cog2"])
    return kw


def _run(experiment, gap0, kw):
    """One noise-free record of :func:`simulate`: the impact, or the slide or speed run at ``SLIDE_RATE_HZ``."""
    if experiment == "speed":
        return simulate(gap0=gap0, speeds=SPEED_PROFILE, duration=SPEED_PROFILE[-1][0], rate_hz=SLIDE_RATE_HZ, **kw)
    if experiment == "slide":
        return simulate(gap0=gap0, profile=SLIDE_PROFILE, duration=SLIDE_PROFILE[-1][0], rate_hz=SLIDE_RATE_HZ,
                        **kw)
    return simulate(gap0=gap0, **kw)


def _experiment(name):
    """Check that ``name`` is one of ``EXPERIMENTS``."""
    if name not in EXPERIMENTS:
        raise ValueError(f"experiment must be one of {', '.join(EXPERIMENTS)}; got {name!r}")


JOB = """
[model]
source = "{source}"
name = "Gripper.{model}"
parameters = {parameters}
[data]
{data}
inputs = {{ {input} = "{input}" }}
[experiment]
kind = "{kind}"
duration = {duration}{hold}
[compare]
signals = [{{ output = "{channel}", column = "{channel}", noise = {floor} }},
           {{ output = "theta_m", column = "theta_m", noise = {angle_floor} }}]
rtol = 1e-6
max_nfev = {max_nfev}
"""


def write_job(folder, source, case, effects, workers=0, max_nfev=20, experiment="impact"):
    """Write ``case`` (from :func:`make_case`) as data.csv (data0.csv, data1.csv, ...: one per record, with its
    object position in data.records) and the diagnosis job for it into ``folder``; returns the job path. The
    slide and the speed run are staircase jobs (every sample compared, holds of at least 0.1 s), the impact an
    impact job; the speed run's model is ``Gripper.GripperSpeedControlled`` (input ``w_ref``, compared ``i_q``),
    the others' ``Gripper.GripperCurrentDriven`` (input ``i_ref``, compared ``F_g``). Noise floors: 0.1 N under
    the force estimate, 2 mA under the current's, one encoder count under the angle's (the truncated counts are
    not a zero-mean noise: their bias of half a count is part of the floor). Free: ``eta_g``, ``T_c0`` and, on
    the impact, ``phi_b``."""
    import pandas as pd

    _experiment(experiment)
    speed = experiment == "speed"
    given, channel = ("w_ref", "i_q") if speed else ("i_ref", "F_g")
    records, _ = case
    names = ["data.csv"] if len(records) == 1 else [f"data{k}.csv" for k in range(len(records))]
    for name, (t, u, y, angle, _) in zip(names, records):
        pd.DataFrame({"time": t, given: u, channel: y, "theta_m": angle}).to_csv(folder / name, index=False)
    data = f'path = "{names[0]}"' if len(records) == 1 else "records = [" + ", ".join(
        f'{{ path = "{name}", parameters = {{ gap0 = {r[4]["gap0"]!r} }} }}' for name, r in zip(names, records)) + "]"
    impact = experiment == "impact"
    fixed = {**CONDITION, "play": PLAY_NOMINAL, **({} if impact else {"gap0": SLIDE_GAP0}),
             **({"K_pw": K_PW, "K_iw": K_IW} if speed else {})}
    parameters = "{ " + ", ".join(f"{k} = {v!r}" for k, v in fixed.items()) + " }"
    path = folder / "job.toml"
    path.write_text(JOB.format(source=source.as_posix(), parameters=parameters, data=data,
                               model="GripperSpeedControlled" if speed else "GripperCurrentDriven", input=given,
                               channel=channel, kind="impact" if impact else "staircase",
                               hold="" if impact else "\nmin_hold_s = 0.1", duration=records[0][0][-1],
                               floor=0.002 if speed else 0.1, angle_floor=2 * np.pi / COUNTS, max_nfev=max_nfev)
                    + free_and_candidates(0.68, 7.88e-3, effects, workers, phi_b=PHI_B_START if impact else None))
    return path


EXPERIMENT_TABLE = """
[[experiments]]
name = "{name}"
kind = "{kind}"
path = "{name}.csv"
inputs = {{ i_ref = "i_ref" }}
duration = {duration}{hold}
parameters = {{ gap0 = {gap0!r} }}
"""


def write_experiments_job(folder, source, records, effects, workers=0, max_nfev=20):
    """Write the records of one gripper's impact and slide (``records``: experiment -> one record of
    :func:`measured_records`) as ``<experiment>.csv`` and one diagnosis job of both (``[[experiments]]``, each
    as :func:`write_job` sets it up, the object's distance fixed per experiment) into ``folder``; returns the
    job path. Free, shared by both: ``eta_g``, ``T_c0`` and ``phi_b``."""
    import pandas as pd

    tables = []
    for name, (t, u, y, angle, placed) in records.items():
        if name == "speed":
            raise ValueError("the speed run has another model (GripperSpeedControlled): not in a job with these")
        pd.DataFrame({"time": t, "i_ref": u, "F_g": y, "theta_m": angle}).to_csv(folder / f"{name}.csv", index=False)
        tables.append(EXPERIMENT_TABLE.format(name=name, kind="impact" if name == "impact" else "staircase",
                                              duration=t[-1], hold="" if name == "impact" else "\nmin_hold_s = 0.1",
                                              gap0=placed["gap0"]))
    fixed = {**CONDITION, "play": PLAY_NOMINAL}
    model = (f'[model]\nsource = "{source.as_posix()}"\nname = "Gripper.GripperCurrentDriven"\n'
             "parameters = { " + ", ".join(f"{k} = {v!r}" for k, v in fixed.items()) + " }\n")
    compare = ('[compare]\nsignals = [{ output = "F_g", column = "F_g", noise = 0.1 }, '
               f'{{ output = "theta_m", column = "theta_m", noise = {2 * np.pi / COUNTS!r} }}]\n'
               f"rtol = 1e-6\nmax_nfev = {max_nfev}\n")
    path = folder / "job.toml"
    path.write_text(model + "".join(tables) + compare
                    + free_and_candidates(0.68, 7.88e-3, effects, workers, phi_b=PHI_B_START))
    return path
