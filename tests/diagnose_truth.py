"""Hidden-effect data for the discrepancy workflow's tests and benchmark: a quasi-static gripper written
independently of the Modelica plant and of the candidates' Modelica.

Formulation (not the Modelica one): the current staircase is slow against the drivetrain, so each step ends in
static equilibrium; the force follows a Karnopp-type stick/slip rule on the force balance of one jaw, with
efficiencies applied by the direction of power flow, Coulomb drag at the motor shaft and friction held at rest
(no bristles, no ODE). Tightening reaches ``F_up``, releasing drops to ``F_down``; between the two the drivetrain
is stuck and the force stays. The force then approaches each new level with a first-order transient (time
constant ``tau_mech``), and the load cell is sampled at 100 Hz with Gaussian noise.

Effects: ``backdrive_efficiency`` (eta_b != eta_d on the release branch), ``load_dependent_friction`` (guide
friction mu_F*F while sliding and held at rest), ``loadcell_filter`` (a discrete first-order low-pass and an
offset, applied to the sampled force). ``none``: the baseline's physics. Not among ``TRUTH_EFFECTS`` (the benchmark's
cells), a law of another form: ``load_exponent_mesh``, a gear loss that grows as the transmitted torque to the
power n_L, its efficiency 1 - (1 - eta)*(|tau_out|/T_N)^(n_L - 1) in both directions of power flow.
"""

import json
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

__all__ = ["K_T", "GAIN", "T_N", "staircase", "load_efficiency", "quasi_static_force", "make_case", "TRUTH_EFFECTS",
           "write_job", "free_and_candidates"]

K_T = 0.0393939394           # N.m/A, torque constant at the motor shaft
RATIO, R_P = 28.0, 0.008957  # gear ratio, pinion radius [m]
GAIN = RATIO / (2 * R_P)     # jaw force per motor torque, N per N.m (two jaws)
F_GUIDE = 0.0785             # N, sliding guide friction per jaw (the plant's default)
T_N = 0.13                   # N.m, gear input torque at which a load-exponent gear loss has the efficiency eta

TRUTH_EFFECTS = ("none", "backdrive_efficiency", "load_dependent_friction", "loadcell_filter")


# Rising in 0.25 A steps, releasing in 0.15 A steps: the release branch carries the evidence of the effects that
# change the held force (a low back-driven efficiency holds it down to the last few levels), so it gets the finer
# steps; with 0.25 A release steps that evidence fell into one segment and the held-out score could not see it.
LEVELS = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 1.35, 1.2, 1.05, 0.9, 0.75, 0.6, 0.45, 0.3, 0.15, 0.0)


def staircase(levels=LEVELS, step_s=0.7, rate_hz=100.0, ramp_s=0.35):
    """Time [s] and current [A] of a current staircase sampled at ``rate_hz``: each level is reached by a
    ramp of ``ramp_s`` (held between samples) and then held; a level lasts ``step_s`` in all."""
    per = int(round(step_s * rate_hz))
    ramp = int(round(ramp_s * rate_hz))
    current = [np.full(per, levels[0])]
    for a, b in zip(levels[:-1], levels[1:]):
        frac = np.minimum(np.arange(1, per + 1) / max(ramp, 1), 1.0)
        current.append(np.round(a + (b - a) * frac, 6))
    current = np.concatenate(current)
    return np.arange(len(current)) / rate_hz, current


def load_efficiency(tau_in, eta, n_L, driving):
    """The gear's efficiency at the input torque ``tau_in`` [N.m] (> 0) when its loss fraction is
    (1 - eta)*(tau_out/T_N)^(n_L - 1) of the torque passed on, tau_out: driving, tau_out = (1 - k)*tau_in, back-driven,
    tau_in = (1 - k)*tau_out, each solved for tau_out by brentq."""
    def loss(tau_out):
        return (1 - eta) * (tau_out / T_N) ** (n_L - 1)
    if driving:
        tau_out = brentq(lambda x: x - (1 - loss(x)) * tau_in, 1e-15, tau_in, xtol=1e-15, rtol=1e-13)
    else:  # (1 - loss(x))*x rises up to its maximum at x_top (n_L > 1), or without bound (n_L < 1)
        x_top = T_N * (n_L * (1 - eta)) ** (-1 / (n_L - 1)) if n_L > 1 else 100 * tau_in
        tau_out = brentq(lambda x: (1 - loss(x)) * x - tau_in, tau_in, x_top, xtol=1e-15, rtol=1e-13)
    return 1 - loss(tau_out)


def quasi_static_force(current, eta_d, T_c0, eta_b=None, mu_F=0.0, n_L=1.0):
    """Steady force after each distinct current level, by the stick/slip rule (one value per run); ``n_L`` != 1: the
    efficiencies of a load-exponent gear loss (:func:`load_efficiency`, eta_d at T_N both ways)."""
    eta_b = eta_d if eta_b is None else eta_b
    changes = np.flatnonzero(np.diff(current) != 0) + 1
    runs = np.split(current, changes)
    F, levels = 0.0, []
    for run in runs:
        i = run[0]
        up, down = K_T * i - T_c0, K_T * i + T_c0
        eff_d = eta_d if n_L == 1 or up <= 0 else load_efficiency(up, eta_d, n_L, True)
        eff_b = eta_b if n_L == 1 or down <= 0 else load_efficiency(down, eta_d, n_L, False)
        drive = eff_d * (K_T * i - T_c0) * GAIN          # rack force available when tightening
        f_up = (drive - F_GUIDE) / (1 + mu_F)
        f_down = ((K_T * i + T_c0) * GAIN / eff_b + F_GUIDE) / (1 - mu_F)
        if f_up > F:
            F = f_up
        elif f_down < F:
            F = max(f_down, 0.0)
        levels.append(F)
    return np.repeat(levels, [len(r) for r in runs])


def make_case(effect, rng, noise=0.2, levels=LEVELS, step_s=0.7, rate_hz=100.0, tau_mech=0.02):
    """A random hidden-effect case: returns (time, current, measured force, truth dict)."""
    t, i = staircase(levels, step_s, rate_hz)
    truth = {"effect": effect, "eta_d": rng.uniform(0.6, 0.8), "T_c0": rng.uniform(4e-3, 1.2e-2)}
    kw = {}
    if effect == "backdrive_efficiency":
        sign = rng.choice([-1.0, 1.0])
        truth["eta_b"] = float(np.clip(truth["eta_d"] + sign * rng.uniform(0.12, 0.25), 0.3, 0.97))
        kw["eta_b"] = truth["eta_b"]
    elif effect == "load_dependent_friction":
        truth["mu_F"] = rng.uniform(0.1, 0.25)
        kw["mu_F"] = truth["mu_F"]
    elif effect == "load_exponent_mesh":
        truth["n_L"] = rng.uniform(1.3, 1.7)
        kw["n_L"] = truth["n_L"]
    F = quasi_static_force(i, truth["eta_d"], truth["T_c0"], **kw)
    # first-order approach of each new level (the mechanical transient), exact for a piecewise-constant target
    a = np.exp(-1.0 / (rate_hz * tau_mech))
    y = np.empty_like(F)
    y[0] = F[0]
    for k in range(1, len(F)):
        y[k] = a * y[k - 1] + (1 - a) * F[k]
    if effect == "loadcell_filter":
        truth["tau_lc"] = rng.uniform(0.02, 0.08)
        truth["F_off"] = rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 3.0)
        b = np.exp(-1.0 / (rate_hz * truth["tau_lc"]))
        z = np.empty_like(y)
        z[0] = y[0]
        for k in range(1, len(y)):
            z[k] = b * z[k - 1] + (1 - b) * y[k]
        y = z + truth["F_off"]
    return t, i, y + rng.normal(0.0, noise, len(t)), truth


SOURCE = Path(__file__).resolve().parent.parent / "modelica" / "Gripper" / "package.mo"

# The diagnosis job the tests and benchmarks/diagnose.py run on a case: the baseline GripperCurrentDriven on the
# stiff object with eta_g and T_c0 free (the truth's eta_d and T_c0), with the presliding damping of the shipped
# static job (examples/diagnose_static.toml: the replays do not resolve the rotor's ringing on its bristle).
JOB = """
[model]
source = "{source}"
name = "Gripper.GripperCurrentDriven"
parameters = {{ gap0 = 0.0, play = 0.0, k_obj = 1.2e9, t_coat = 0.0, k_P = 1e12, C_p = 2000.0, d_pre = 0.01 }}
[data]
path = "data.csv"
inputs = {{ i_ref = "i_ref" }}
[experiment]
kind = "staircase"
steady_s = 0.3
[compare]
signals = [{{ output = "F_g", noise = 0.1 }}]
rtol = 1e-5
max_nfev = 20
"""


def free_and_candidates(eta_g, T_c0, effects, workers, phi_b=None):
    """The end of a gripper diagnosis job: ``eta_g`` and ``T_c0`` [N.m] free from these starts (and, when given, the
    presliding angle ``phi_b`` [rad] within a factor two of its start), the candidate ``effects`` (forms among them
    listed under ``candidates.forms``) and the number of Dask ``workers``."""
    from cosim.diagnose import EFFECTS

    presliding = "" if phi_b is None else \
        f"[parameters.phi_b]\nstart = {phi_b!r}\nmin = {phi_b / 2!r}\nmax = {2 * phi_b!r}\n"
    forms = [n for n in effects if n in EFFECTS and EFFECTS[n].is_form]  # an unknown name: the job says so
    listed = f"effects = {json.dumps([n for n in effects if n not in forms])}\n" + \
        (f"forms = {json.dumps(forms)}\n" if forms else "")
    return (f"[parameters.eta_g]\nstart = {eta_g!r}\nmin = 0.3\nmax = 1.0\n"
            f"[parameters.T_c0]\nstart = {T_c0!r}\nmin = 1e-4\nmax = 0.05\n" + presliding +
            f"[candidates]\n{listed}[parallel]\nworkers = {workers}\n")


def write_job(folder, frame, effects, workers=2, extra=""):
    """Write ``frame`` (time, i_ref, F_g) as ``folder/data.csv`` and the job diagnosing it as ``folder/job.toml``
    (``extra``: TOML text appended); returns the job's path."""
    folder = Path(folder)
    frame.to_csv(folder / "data.csv", index=False)
    path = folder / "job.toml"
    path.write_text(JOB.format(source=SOURCE.as_posix()) + free_and_candidates(0.7, 8e-3, effects, workers) + extra)
    return path
