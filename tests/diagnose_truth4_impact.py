"""A fourth hidden-effect truth of the gripper's dynamic experiments (impact, slide, speed run), written before
issue #42's model-form candidates were evaluated and reserved for that evaluation: never used to tune anything.

The experiments, inputs, sampling, encoder truncation, noise, object placement, contact condition (``CONDITION``)
and drawn baseline (``draw_baseline``: one seed gives the same ``eta_g``, ``T_c0`` and play as the other truths)
are the first truth's (``diagnose_truth_impact.py``), so its ``write_job`` writes this truth's jobs too. Every
contact and friction law is of a form that is neither in the candidate library (``cosim/diagnose/effects.py``, the
Modelica of ``modelica/Gripper``), nor among the forms issue #42 adds (power-law/Hertz, Hunt-Crossley,
hysteretic/viscoelastic Maxwell-type contacts; Stribeck/Karnopp, Dahl, LuGre friction), nor in truths 1-3:

* motor friction: Bliman and Sorine's second-order model (Bliman and Sorine 1995, "Easy-to-use realistic dry
  friction models for automatic control", Proc. 3rd European Control Conference; Olsson et al. 1998, Eur. J.
  Control 4, sec. 3.4): a linear system in the path ``s`` (``ds = |w| dt``), ``dx1/ds = ((1 + BS_P) sgn(w) -
  x1)/(BS_ETA BS_EPS)``, ``dx2/ds = (-BS_P sgn(w) - x2)/BS_EPS``, torque ``L (x1 + x2)``: a peak of about
  ``1.13 L`` after 0.6 mrad of travel that decays to ``L`` over ``BS_EPS`` (a memory of the distance slid since
  the last reversal, not of the speed); rate-independent, no Stribeck curve;
* gear loss: a Coulomb mesh friction whose normal load is the transmitted torque, inside the motor friction's
  level ``L = T_c0 + c |tau_out|/N``, ``c = 1/eta - 1`` while the friction opposes the motor driving the load and
  ``1 - eta`` (``1 - eta_b`` with the staircase truth's ``backdrive_efficiency``) when the load drives it; the
  paper's bearing damping ``B_g`` (eq. 9) is part of ``tau_out``;
* gear mesh: backlash with a mesh stiffness that varies with the mesh position (single and double tooth contact,
  Kahraman and Singh 1990, J. Sound Vib. 142(1)): ``K_SINGLE``, ``K_DOUBLE`` over the fraction
  ``CONTACT_RATIO - 1`` of each of ``Z_MESH`` tooth pitches of the pinion, damping ``C_MESH``, never pulling;
* guides: Dieterich-Ruina rate-and-state friction (Dieterich 1979, J. Geophys. Res. 84; Ruina 1983, J.
  Geophys. Res. 88) in force units, with Dieterich's cut-off velocity (Dieterich 1986, AGU Geophys. Monogr. 37)
  and the regularisation at zero speed of Rice and Ben-Zion 1996 (PNAS 93) / Lapusta et al. 2000 (J. Geophys.
  Res. 105): ``F = A asinh(v/(2 V0_RS) exp(Psi/A))``, ``Psi = F_GUIDE + B ln(1 + V0_RS theta/D_C)``, the aging law
  ``dtheta/dt = 1 - |v| theta/D_C``. Steady sliding: ``F_ss = F_GUIDE + A ln(v/V0_RS) + B ln(1 + V0_RS/v)``
  (``F_GUIDE + (A - B) ln(v/V0_RS)`` well below ``V0_RS``); at rest the state heals as ``ln(hold time)``.
  ``A = RS_A F_GUIDE``, ``B = RS_B F_GUIDE`` (``a/mu`` about 0.02, ``b/a`` 1.5: the laboratory values of Marone
  1998, Annu. Rev. Earth Planet. Sci. 26); the state starts after a rest of ``THETA_0``;
* coating (``CONDITION``'s ``k_P``, ``k_H_ratio``, ``d_lim``, ``C_p``): a measured-style tabulated force-deflection
  loop. Loading: ``LOADING``, a layer law that locks as it thins, ``k_P d/(1 - d/d_L)`` with ``d_L = d_lim/0.9``
  (tangent ``k_P`` at zero, ``k_H`` at ``d_lim``), sampled every 0.1 mm and rounded to 1 N as a test report gives
  it, linear between the points, ``k_H`` beyond. Unloading from the largest deflection reached ``(d_m, F_m)``:
  one normalised branch ``UNLOADING`` for every reversal, ``F = F_m U(f(d)/F_m)`` (self-similar branches in the
  spirit of Masing's rule, Masing 1926, Proc. 2nd Int. Congress Appl. Mech., normalised here on the loading
  force so a branch never crosses the loading curve); reloading below ``d_m`` retraces the branch. Rate-independent
  dissipation; a small viscous ``C_p`` in parallel;
* load cell: a sigma-delta converter's sinc^3 decimation filter (Hogenauer 1981, IEEE Trans. ASSP 29(2); as in
  load-cell converters such as the ADS1232): three cascaded moving averages of ``1/F_NOTCH_NOMINAL`` each, on the
  force sampled at ``1/H_GL``.

Hidden effects, one a case (the first truth's names), each of a form not in the library: ``gear_play`` (the play
from ``draw_baseline``: 0.3-0.55 deg or 1.1-1.6 deg instead of 0.8 deg), ``contact_damping`` (a springpot, the
fractional Kelvin-Voigt element ``c D^alpha d`` of Bagley and Torvik 1983, J. Rheol. 27(3), in parallel with the
coating: ``alpha`` 0.5-0.9, ``c`` such that ``|c (j w)^alpha|`` is 100-300 N.s/m times ``w`` at the contact's
natural frequency ``sqrt(k_P/m)``), ``coating_relaxation`` (a fractional Maxwell branch, a spring ``k_r`` in series
with a springpot, ``q + tau^alpha D^alpha q = k_r tau^alpha D^alpha d`` (Koeller 1984, J. Appl. Mech. 51; its
relaxation is a Mittag-Leffler function): ``k_r`` 0.5-2 ``k_P``, ``tau`` 0.05-0.3 s, ``alpha`` 0.3-0.7),
``stiction`` (the guides' healing ``B`` raised so that after a 0.25 s rest the breakaway is 3-10 N above the
sliding level: ``B += dF/ln(1 + V0_RS 0.25 s/D_C)``, ``A`` 2 % of the resulting level), ``cogging`` (a permeance
model: the air-gap energy of a constant magnet MMF across a slotted reluctance ``R0 (1 + eps cos(N theta + phase))``,
``W = W0/(1 + eps cos(...))``, torque ``dW/dtheta``, ``eps`` 0.2-0.5, peak 1.5-4 mN.m), ``load_dependent_friction``
(the guides' normal load grows with the contact force: the whole rate-and-state force scaled by ``1 + mu_F
F_c/F_GUIDE``, ``mu_F`` 0.01-0.05), ``loadcell_filter`` (the converter at a data rate of 100-250 Hz, so a sinc^3
window of 12-30 ms, and an offset of +-1-3 N), or ``none``.

Integration: semi-implicit Euler at ``DT`` = 10 us, compiled with numba. The Bliman-Sorine states and the guides'
state by the exact solution of their ODE over a step at the step's speed; the jaw's speed implicit in the guides'
friction (a safeguarded Newton solve on the asinh's argument); the coating's deflection implicit (one strictly
increasing balance, Newton with bisection). The fractional elements use the Grünwald-Letnikov sum (Podlubny 1999,
Fractional Differential Equations, ch. 7) on a grid of ``H_GL`` = 0.1 ms with the full memory, the newest point
being the current deflection.

The checks (``tests/test_truth4_impact.py``) draw their cases from the seed 1095907558, drawn once with
``python -c "import secrets; print(secrets.randbelow(2**31))"``. ``diagnose_truth4_staircase.py`` runs this plant
on the static staircase.
"""

import math

import numpy as np
from numba import njit

from diagnose_truth2_impact import experiment_input, q_current, truth_case_functions
from diagnose_truth_impact import (B_R, C_GREASE, CONDITION, F_GUIDE, J_M, J_P, K_F, K_T, M_JF, N_COG, OMEGA_MAX,
                                   PLAY_NOMINAL, R_P, RATIO, T_MAX, draw_baseline)

__all__ = ["TRUTH4_IMPACT_EFFECTS", "simulate", "draw_truth", "make_case_impact4", "effect_signal4",
           "diagnose_case_impact4"]

TRUTH4_IMPACT_EFFECTS = ("none", "gear_play", "contact_damping", "coating_relaxation", "stiction", "cogging",
                         "load_dependent_friction", "loadcell_filter")
DT = 1e-5                                                  # s
NF = 10                                                    # fine steps per point of the fractional grid
H_GL = NF * DT                                             # s, Grünwald-Letnikov step and load-cell sampling
# motor friction: Bliman-Sorine, second order
BS_P, BS_ETA, BS_EPS = 0.25, 0.1, 2e-3                     # 1, 1, rad: f2/(f1 - f2), fast/slow length ratio, length
# gear mesh: single/double tooth contact
K_SINGLE, K_DOUBLE, C_MESH = 1500.0, 2600.0, 0.04          # N.m/rad, N.m/rad, N.m.s/rad at the gear output
CONTACT_RATIO, Z_MESH = 1.5, 36                            # 1, teeth of the pinion
# guides: rate-and-state
V0_RS, D_C = 1e-3, 1e-5                                    # m/s (reference and cut-off velocity), m
RS_A, RS_B = 0.02, 0.03                                    # direct and healing effects over the level F_GUIDE
THETA_0 = 1.0                                              # s: the guides rested this long before the record
HOLD_REF = 0.25                                            # s: the rest at which the stiction effect is drawn
# coating: loading table (m, N) with the linear parts outside the measured range, normalised unloading branch
LOADING = np.array([[-1e-3, -180.0], [0.0, 0.0], [1e-4, 19.0], [2e-4, 41.0], [3e-4, 66.0], [4e-4, 95.0],
                    [5e-4, 129.0], [6e-4, 169.0], [7e-4, 217.0], [8e-4, 277.0], [9e-4, 352.0], [1.0e-3, 450.0],
                    [1.1e-3, 582.0], [1.2e-3, 771.0], [1.3e-3, 1064.0], [1.4e-3, 1575.0], [1.5e-3, 2700.0],
                    [1.0e-2, 2700.0 + 1.8e7 * 8.5e-3]])
UNLOADING = np.array([[-1.0, -0.2], [0.0, 0.0], [0.1, 0.02], [0.2, 0.06], [0.3, 0.12], [0.4, 0.19], [0.5, 0.28],
                      [0.6, 0.39], [0.7, 0.51], [0.8, 0.66], [0.9, 0.82], [1.0, 1.0]])
# load cell
SINC_ORDER, F_NOTCH_NOMINAL = 3, 1000.0                    # 1, Hz (window 3 ms)
C_P, K_OBJ, T_COAT = CONDITION["C_p"], CONDITION["k_obj"], CONDITION["t_coat"]  # numba reads module constants


@njit(cache=True)
def gl_weights(alpha, n):
    """The Grünwald-Letnikov weights ``(-1)^j binom(alpha, j)``, j = 0..n-1 (all but the first zero at
    ``alpha`` = 0: no element)."""
    w = np.zeros(n)
    w[0] = 1.0
    for j in range(1, n):
        w[j] = w[j - 1] * (1.0 - (alpha + 1.0) / j)
    return w


@njit(cache=True)
def gl_history(values, count, first, w):
    """``sum_{j=1}^{count-first} w[j] values[count-j]``: the memory part of the Grünwald-Letnikov sum at point
    ``count`` (points ``values[:count]`` committed, those before ``first`` zero)."""
    total = 0.0
    for j in range(1, count - first + 1):
        total += w[j] * values[count - j]
    return total


@njit(cache=True)
def _table(x, table):
    """Linear interpolation in ``table`` (rows x, y; x increasing; the end segments continued) and its slope."""
    n = table.shape[0]
    i = 0
    while i < n - 2 and x > table[i + 1, 0]:
        i += 1
    slope = (table[i + 1, 1] - table[i, 1]) / (table[i + 1, 0] - table[i, 0])
    return table[i, 1] + slope * (x - table[i, 0]), slope


@njit(cache=True)
def hysteresis(delta, delta_m, F_m):
    """The coating's rate-independent force [N] at ``delta`` [m] and its slope, the largest deflection reached
    being ``delta_m`` at force ``F_m``: the loading table beyond it, the normalised unloading branch below it."""
    f, df = _table(delta, LOADING)
    if delta >= delta_m or F_m <= 0.0:
        return f, df
    u, du = _table(f / F_m, UNLOADING)
    return F_m * u, du * df


@njit(cache=True)
def _coating(delta, delta_old, delta_m, F_m, gain, offset):
    """The coating's force at ``delta`` reached from ``delta_old`` in one step, and its slope: the loop, the viscous
    ``C_p`` (backward-Euler rate) and the fractional elements, linear in ``delta`` over the step (``gain``,
    ``offset``)."""
    force, slope = hysteresis(delta, delta_m, F_m)
    return force + C_P * (delta - delta_old) / DT + gain * delta + offset, slope + C_P / DT + gain




@njit(cache=True)
def contact_step(pen, k_s, delta_old, delta_m, F_m, gain, offset):
    """The coating's deflection after one step: the root of ``coating(d) - k_s max(pen - d, 0)``, strictly
    increasing in ``d`` (slope >= C_p/DT), by Newton with bisection on a bracket grown from ``delta_old``."""
    def balance(d):
        force, slope = _coating(d, delta_old, delta_m, F_m, gain, offset)
        if pen > d:
            return force - k_s * (pen - d), slope + k_s
        return force, slope

    lo, hi, width = delta_old, delta_old, 1e-7
    while balance(lo)[0] > 0.0:
        lo -= width
        width *= 2.0
    width = 1e-7
    while balance(hi)[0] < 0.0:
        hi += width
        width *= 2.0
    d = delta_old if lo <= delta_old <= hi else 0.5 * (lo + hi)
    for _ in range(200):
        g, dg = balance(d)
        if abs(g) < 1e-9:  # N
            break
        if g > 0.0:
            hi = d
        else:
            lo = d
        if hi - lo < 1e-18:
            break
        newton = d - g / dg
        d = newton if lo < newton < hi else 0.5 * (lo + hi)
    return d


@njit(cache=True)
def rs_state(theta, v):
    """The guides' state [s] after one step at speed ``v`` by the aging law's exact solution, written so that it
    stays exact at vanishing speed (``theta + DT`` at rest)."""
    speed = abs(v)
    if speed == 0.0:
        return theta + DT
    rate = speed * DT / D_C
    if rate < 1e-8:  # the series to first order in rate (the second order is below rounding)
        return theta * (1.0 - rate) + DT * (1.0 - 0.5 * rate)
    return theta * math.exp(-rate) - D_C / speed * math.expm1(-rate)


@njit(cache=True)
def rs_exponent(theta, A, B):
    """``Psi/A`` of the rate-and-state law at state ``theta`` (level ``F_GUIDE``, healing ``B``, direct ``A``)."""
    return (F_GUIDE + B * math.log1p(V0_RS * theta / D_C)) / A


@njit(cache=True)
def rs_force(v, theta, A, B):
    """The guides' rate-and-state friction [N] at speed ``v`` [m/s] and state ``theta`` [s]: ``A asinh(y)``, ``y =
    v/(2 V0_RS) exp(Psi/A)``, taken as ``A (ln|y| + ln(1 + sqrt(1 + 1/y^2)))`` where ``|y| > 1`` (no overflow)."""
    if v == 0.0:
        return 0.0
    s, exponent = abs(v) / (2.0 * V0_RS), rs_exponent(theta, A, B)
    inverse = math.exp(-exponent) / s
    if inverse > 1.0:
        return A * math.asinh(v / (2.0 * V0_RS) * math.exp(exponent))
    return math.copysign(A * (math.log(s) + exponent + math.log1p(math.sqrt(1.0 + inverse * inverse))), v)


@njit(cache=True)
def rs_speed(R, c1, A, exponent):
    """The speed ``v`` solving ``c1 v + A asinh(v/(2 V0_RS) exp(exponent)) = R`` (the jaw's backward-Euler balance
    with the guides' friction), and that friction. Solved for ``s = asinh(...)``: ``K sinh(s) + A s = |R|``, convex
    and increasing for s >= 0, by Newton from an upper bound (monotone), bisection as a safeguard."""
    if R == 0.0:
        return 0.0, 0.0
    target = abs(R)
    K = c1 * 2.0 * V0_RS * math.exp(-exponent)
    lo, hi = 0.0, min(target / A, math.asinh(target / K))
    s = hi
    for _ in range(200):
        g = K * math.sinh(s) + A * s - target
        if g > 0.0:
            hi = s
        else:
            lo = s
        step = g / (K * math.cosh(s) + A)
        if abs(step) < 1e-13 * max(1.0, s) or hi - lo < 1e-15:
            break
        s = s - step if lo < s - step < hi else 0.5 * (lo + hi)
    v = 2.0 * V0_RS * math.exp(-exponent) * math.sinh(s)
    return math.copysign(v, R), math.copysign(A * s, R)


@njit(cache=True)
def bliman_sorine(x1, x2, w):
    """The motor friction's two states after one step at speed ``w``: the exact solution in the path ``|w| DT``."""
    if w == 0.0:
        return x1, x2
    path, sign = abs(w) * DT, 1.0 if w > 0 else -1.0
    fast, slow = sign * (1.0 + BS_P), -sign * BS_P
    return fast + (x1 - fast) * math.exp(-path / (BS_ETA * BS_EPS)), slow + (x2 - slow) * math.exp(-path / BS_EPS)


@njit(cache=True)
def mesh_torque(rel, rel_rate, play, pinion):
    """Torque at the gear output [N.m] of a backlash of total ``play`` whose mesh stiffness is ``K_DOUBLE`` over the
    fraction ``CONTACT_RATIO - 1`` of each tooth pitch (``pinion``: the pinion's angle [rad]), else ``K_SINGLE``;
    damping ``C_MESH``; never pulling."""
    engaged = abs(rel) - 0.5 * play
    if engaged <= 0.0:
        return 0.0
    phase = (pinion * Z_MESH / (2 * math.pi)) % 1.0
    stiffness = K_DOUBLE if phase < CONTACT_RATIO - 1.0 else K_SINGLE
    side = 1.0 if rel > 0 else -1.0
    return side * max(0.0, stiffness * engaged + C_MESH * side * rel_rate)


@njit(cache=True)
def cogging_torque(theta, cog):
    """Cogging torque [N.m] against positive rotation, ``dW/dtheta`` of the permeance model's energy ``W0/(1 + eps
    cos(N_COG theta + phase))``. ``cog``: W0, eps, phase; empty: none."""
    if len(cog) == 0:
        return 0.0
    angle = N_COG * theta + cog[2]
    return cog[0] * cog[1] * N_COG * math.sin(angle) / (1.0 + cog[1] * math.cos(angle)) ** 2


@njit(cache=True)
def fractional_constants(frac, points):
    """From ``frac`` (k_r [N/m], tau_r [s], alpha_r, c_d [N.s^alpha/m], alpha_d): the constants (k_r, r = (tau_r/
    H_GL)^alpha_r, c_d H_GL^-alpha_d) and the two elements' Grünwald-Letnikov weights over ``points`` points."""
    constants = np.array([frac[0], (frac[1] / H_GL) ** frac[2], frac[3] * H_GL ** -frac[4]])
    return constants, gl_weights(frac[2], points), gl_weights(frac[4], points)


@njit(cache=True)
def fractional_linear(fc, memory):
    """The fractional elements' force at the newest point as ``gain delta + offset`` (``memory``: the memory sums
    of the deflection for the branch, of the branch's force, of the deflection for the springpot). The Maxwell
    branch's GL form ``q + r (q + Hq) = k_r r (delta + Hd)`` solved for ``q``; the springpot ``c h^-alpha (delta +
    Hd)``."""
    k_r, r, scale_d = fc[0], fc[1], fc[2]
    return k_r * r / (1.0 + r) + scale_d, (k_r * r * memory[0] - r * memory[1]) / (1.0 + r) + scale_d * memory[2]


@njit(cache=True)
def branch_force(delta, fc, memory):
    """The fractional Maxwell branch's force [N] at the newest point, deflection ``delta``."""
    k_r, r = fc[0], fc[1]
    return (k_r * r * (delta + memory[0]) - r * memory[1]) / (1.0 + r)


@njit(cache=True)
def fractional_commit(delta, fc, memory, deltas, branch, count, first, w_r, w_d):
    """Commit ``delta`` and the branch's force as point ``count`` of the grid and update ``memory`` in place for the
    next point; returns (count, first), ``first`` the first point with a deflection (-1: none yet)."""
    deltas[count], branch[count] = delta, branch_force(delta, fc, memory)
    if first < 0 and delta != 0.0:
        first = count
    count += 1
    if first >= 0:
        memory[0] = gl_history(deltas, count, first, w_r)
        memory[1] = gl_history(branch, count, first, w_r)
        memory[2] = gl_history(deltas, count, first, w_d)
    return count, first


@njit(cache=True)
def fractional_forces(delta_points, frac):
    """The fractional Maxwell branch's and the springpot's forces [N] at the points of a deflection [m] given on
    the grid of ``H_GL`` (point 0 at rest), stepped as the plant steps them; for the checks."""
    n = len(delta_points)
    fc, w_r, w_d = fractional_constants(frac, n + 1)
    deltas, branch, memory = np.zeros(n + 1), np.zeros(n + 1), np.zeros(3)
    q, p = np.zeros(n), np.zeros(n)
    count, first = 1, -1
    for i in range(1, n):
        gain, offset = fractional_linear(fc, memory)
        q[i] = branch_force(delta_points[i], fc, memory)
        p[i] = gain * delta_points[i] + offset - q[i]
        count, first = fractional_commit(delta_points[i], fc, memory, deltas, branch, count, first, w_r, w_d)
    return q, p


@njit(cache=True)
def _integrate(inputs, speed_mode, steps_per_sample, eta, eta_b, T_c0, play, gap0, guide, frac, cog):
    """The plant of the module docstring over ``len(inputs)`` samples. ``inputs``: the current [A] per sample, or
    (``speed_mode``) the PI loop's motor speed reference [rad/s]. ``eta``, ``eta_b``: the mesh's efficiency
    driving and back-driven. ``guide``: A, B, mu_F; ``frac``: k_r, tau_r,
    alpha_r, c_d, alpha_d (zero stiffness and coefficient: none). Returns per sample (before its step) the contact
    force [N], motor angle [rad], q current [A] and jaw travel [m], and the contact force at every ``H_GL``."""
    n = len(inputs)
    steps = n * steps_per_sample
    out, fine = np.empty((n, 4)), np.empty(steps // NF + 1)
    m = M_JF + J_P / (2 * R_P ** 2)
    B_g = T_MAX * (1 - eta) * RATIO ** 2 / OMEGA_MAX
    k_s = 1.0 / (1.0 / K_F + 1.0 / K_OBJ)
    touch = gap0 - T_COAT
    points = steps // NF + 2
    fc, w_r, w_d = fractional_constants(frac, points)
    fractional = frac[0] > 0.0 or frac[3] > 0.0
    deltas, branch, memory = np.zeros(points), np.zeros(points), np.zeros(3)
    count, first = 1, -1  # point 0 (t = 0) committed, zero
    theta = w = x = v = delta = delta_m = F_m = F_c = integral = x1 = x2 = 0.0
    theta_rs = THETA_0
    for k in range(steps):
        j = k // steps_per_sample
        i_q, integral = q_current(speed_mode, inputs[j], w, integral, DT)
        if k % steps_per_sample == 0:
            out[j, 0], out[j, 1], out[j, 2], out[j, 3] = F_c, theta, i_q, x
        if k % NF == 0:
            fine[k // NF] = F_c
        # coating: loop, viscous part and the fractional elements, linear in delta over the step
        pen = x - touch
        gain, offset = fractional_linear(fc, memory)
        if pen > 0.0 or delta != 0.0 or offset != 0.0:
            delta = contact_step(pen, k_s, delta, delta_m, F_m, gain, offset)
        F_c = k_s * max(pen - delta, 0.0)
        if delta > delta_m:
            delta_m, F_m = delta, _table(delta, LOADING)[0]
        if (k + 1) % NF == 0 and fractional:
            count, first = fractional_commit(delta, fc, memory, deltas, branch, count, first, w_r, w_d)
        # gear mesh and the gear output's load
        tau_mesh = mesh_torque(theta / RATIO - x / R_P, w / RATIO - v / R_P, play, x / R_P)
        tau_out = tau_mesh + B_g * w / RATIO
        # motor: Bliman-Sorine friction carrying the mesh loss in its level
        x1, x2 = bliman_sorine(x1, x2, w)
        state = x1 + x2
        level = T_c0 + ((1.0 / eta - 1.0) if state * tau_out >= 0.0 else (1.0 - eta_b)) * abs(tau_out) / RATIO
        w_new = w + DT * (K_T * i_q - B_R * w - tau_out / RATIO - level * state - cogging_torque(theta, cog)) / J_M
        # jaw: rack, grease and the guides' rate-and-state friction, implicit in the speed
        scale = 1.0 + guide[2] * F_c / F_GUIDE
        R = m * v / DT + tau_mesh / (2 * R_P) - F_c
        v_new = rs_speed(R, m / DT + C_GREASE, scale * guide[0], rs_exponent(theta_rs, guide[0], guide[1]))[0]
        theta_rs = rs_state(theta_rs, v_new)
        w, v = w_new, v_new
        theta += DT * w
        x += DT * v
    return out, fine




def sinc_filter(force, window, order=SINC_ORDER):
    """A sigma-delta converter's sinc^``order`` filter on the force sampled at ``H_GL`` (zero before the record):
    ``order`` cascaded causal moving averages of ``window`` samples."""
    filtered = np.asarray(force, dtype=float)
    for _ in range(order):
        total = np.cumsum(np.concatenate([np.zeros(window), filtered]))
        filtered = (total[window:] - total[:-window]) / window
    return filtered


def cogging_coefficients(truth):
    """``cogging_torque``'s coefficients for the truth's draw (``W0`` scaled so the torque's peak is ``T_cog``
    [N.m]); empty without the effect."""
    if "T_cog" not in truth:
        return np.zeros(0)
    eps = truth["eps_cog"]
    angle = np.linspace(0.0, 2 * np.pi, 20001)
    peak = np.max(np.abs(eps * N_COG * np.sin(angle) / (1.0 + eps * np.cos(angle)) ** 2))
    return np.array([truth["T_cog"] / peak, eps, truth["phase_cog"]])


def guide_parameters(truth):
    """The guides' ``A``, ``B`` [N] and ``mu_F`` for the truth's draw (module docstring)."""
    B = RS_B * F_GUIDE + truth.get("dF_s", 0.0) / math.log1p(V0_RS * HOLD_REF / D_C)
    return np.array([RS_A * (F_GUIDE + truth.get("dF_s", 0.0)), B, truth.get("mu_F", 0.0)])


def simulate(truth, experiment="impact", gap0=None, profile=None):
    """One noise-free record of ``experiment`` for the parameters ``truth`` (a dict from :func:`draw_truth`;
    ``eta_g`` and ``T_c0`` are enough for the baseline; ``eta_b``, the back-driven efficiency, is ``eta_g`` unless
    given: the staircase truth's effect), the object at ``gap0`` [m] of travel (default: the
    experiment's). Returns (time [s], input, load-cell reading [N] with its offset, contact force [N], motor angle
    [rad], q current [A], jaw travel [m]): the input is the current [A] per sample, or for the speed run the speed
    reference [rad/s]. ``profile``: (time [s], input) corners joined by straight lines in place of the experiment's
    input (for the tests), at the experiment's rate and over its last corner."""
    gap0, rate, time, given = experiment_input(experiment, gap0, profile)
    t = truth
    frac = np.array([t.get("k_rel", 0.0) * CONDITION["k_P"], t.get("tau_rel", 0.1), t.get("alpha_rel", 0.0),
                     t.get("c_frac", 0.0), t.get("alpha_frac", 0.0)])
    steps_per_sample = int(round(1.0 / (rate * DT)))
    out, fine = _integrate(np.ascontiguousarray(given, dtype=float), experiment == "speed", steps_per_sample,
                           t["eta_g"], t.get("eta_b", t["eta_g"]), t["T_c0"], t.get("play", PLAY_NOMINAL), gap0,
                           guide_parameters(t), frac, cogging_coefficients(t))
    window = int(round(1.0 / (t.get("f_notch", F_NOTCH_NOMINAL) * H_GL)))
    reading = sinc_filter(fine, window)[np.arange(len(time)) * steps_per_sample // NF] + t.get("F_off", 0.0)
    return time, given, reading, out[:, 0], out[:, 1], out[:, 2], out[:, 3]


def contact_frequency():
    """The contact's natural frequency [rad/s] on the coating's initial stiffness, ``sqrt(k_P/m)``, ``m`` the jaw's
    mass with the pinion's inertia: where the springpot's draw is referred to a viscous damping."""
    return math.sqrt(CONDITION["k_P"] / (M_JF + J_P / (2 * R_P ** 2)))


def draw_truth(effect, rng):
    """The drawn parameters of one case of ``effect`` (module docstring: the ranges); the baseline first, by
    ``draw_baseline``, so a seed gives the other truths' ``eta_g``, ``T_c0`` and play."""
    if effect not in TRUTH4_IMPACT_EFFECTS:
        raise ValueError(f"effect must be one of {', '.join(TRUTH4_IMPACT_EFFECTS)}; got {effect!r}")
    truth = draw_baseline(effect, rng)
    u = rng.uniform
    if effect == "contact_damping":
        truth.update(alpha_frac=float(u(0.5, 0.9)), c_eq=float(u(100.0, 300.0)))
        truth["c_frac"] = truth["c_eq"] * contact_frequency() ** (1.0 - truth["alpha_frac"])
    elif effect == "coating_relaxation":
        truth.update(k_rel=float(u(0.5, 2.0)), tau_rel=float(u(0.05, 0.3)), alpha_rel=float(u(0.3, 0.7)))
    elif effect == "stiction":
        truth["dF_s"] = float(u(3.0, 10.0))
    elif effect == "cogging":
        truth.update(T_cog=float(u(1.5e-3, 4e-3)), eps_cog=float(u(0.2, 0.5)), phase_cog=float(u(0, 2 * np.pi)))
    elif effect == "load_dependent_friction":
        truth["mu_F"] = float(u(0.01, 0.05))
    elif effect == "loadcell_filter":
        truth.update(f_notch=float(u(100.0, 250.0)), F_off=float(rng.choice([-1.0, 1.0]) * u(1.0, 3.0)))
    return truth


# make_case_impact4(effect, rng, noise, trials, experiment) -> (records, truth dict), measured as the first truth's
# measured_records does; effect_signal4(case, experiment) -> the RMS change the hidden effect alone makes
# (hidden_effect_signal); diagnose_case_impact4(effect, seed, folder, experiment, workers) -> one row of the
# diagnosis with the whole library, truth_model 4: reserved for the evaluation of issue #42, run only once the code
# under evaluation is final.
make_case_impact4, effect_signal4, diagnose_case_impact4 = truth_case_functions(draw_truth, simulate, 4)
