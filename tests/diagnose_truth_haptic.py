"""Hidden-effect frequency responses for the haptic half of the discrepancy workflow, written independently of the
Modelica device, of its lowering and of the candidates' Modelica.

Each case simulates the identification experiment of seed 000 Sec. II-C on a "true" plant: a white-noise motor
torque (0.1-150 Hz, 0.05 N.m RMS, 20 s at 1 kHz, held by the DAC) drives the plant; the encoder angle is quantised
to the encoder's resolution (below) with a little white noise (1e-5 rad: vibration pickup); the frequency response
phi/tau is estimated with the project's Welch H1 estimate (4096-point Hann, 50 % overlap), so the scatter is the
one a user gets. The measured table keeps 1-100 Hz (above 100 Hz the quantisation noise swamps the 1/f^2 roll-off
of the response at this torque).

True plants (all at the phi axis, SI):

* ``none``: a 7-parameter device + user (seed 000 eq. 9), the transfer function of cosim.haptic.tf.tf_7.
* ``hand_mass``: an 11-parameter device + user (eq. 2, ``tf_11``): the hand mass mh held by kh, bh behind the skin
  ks, bs, and the stylus friction b2.
* ``vibration_mode``: the 7-parameter plant plus an inertia m3 hung on the motor-side inertia m1 by k3, b3,
  written here as a hand-built mass-damper-spring state space (numpy): a second mode at f3 = sqrt(k3/m3)/(2 pi).
* ``loop_delay``: the 7-parameter plant with the torque delayed by T exactly: the sampled response of a plant
  whose held input switches T after each sample, integrated exactly (no Pade approximation).

Parameters are random: a random row of Table I (cosim/data/phantom_user_params.csv) of the structure needed, each
value scaled by a log-normal factor (sd 0.15), values printed as 0 replaced by 0.0005 table units; f3 uniform in
[25, 90] Hz with m3/m1 in [0.3, 1.5] and damping ratio in [0.02, 0.1]; T uniform in [0.5, 3] ms.

Encoder: 2048 counts per motor turn, and a motor-to-phi cable reduction taken as 20:1 (neither is in seed 000;
the reduction was chosen so that the resolution, 2 pi/(2048 * 20) = 1.53e-4 rad = 0.026 mm at point A, is of the
order of the ~0.03 mm nominal resolution quoted for the device).
"""

import json
from pathlib import Path

import control
import numpy as np
import pandas as pd
from scipy import linalg

from cosim.freqresp import simulate_lti, welch_tf, white_noise
from cosim.haptic.params import PARAMS_11, PARAMS_7, POSITIONS, USERS, load_user_params
from cosim.haptic.tf import tf_11, tf_7

__all__ = ["TRUTH_EFFECTS", "FS", "ENCODER_STEP", "random_plant", "measure", "make_case", "second_mode_ss",
           "delayed_response", "SOURCE", "write_job"]

TRUTH_EFFECTS = ("none", "hand_mass", "vibration_mode", "loop_delay")
FS = 1000.0                                   # Hz, the loop and sampling rate of seed 000
ENCODER_STEP = 2 * np.pi / (2048 * 20.0)      # rad of phi per encoder count
BAND = (1.0, 100.0)                           # Hz, the measured table's band


def _table_rows(structure):
    rows = []
    for user in USERS:
        for position in POSITIONS:
            row = load_user_params(user, position, zero_as=0.0005)
            if row.structure == structure:
                rows.append(row.values)
    return rows


def _random_row(rng, structure, spread=0.15):
    rows = _table_rows(structure)
    row = rows[rng.integers(len(rows))]
    names = PARAMS_11 if structure == 11 else PARAMS_7
    return {n: float(row[n] * np.exp(rng.normal(0.0, spread))) for n in names}


def second_mode_ss(values):
    """(A, B, C, D) of the 7-parameter plant with an inertia m3 hung on m1 by k3, b3 (states: angles of m1, m2,
    m3, then their velocities; input the motor torque on m1 [N.m]; output the angle of m1 [rad])."""
    v = values
    M = np.diag([v["m1"], v["m2"], v["m3"]])
    K = np.array([[v["kc"] + v["k3"], -v["kc"], -v["k3"]],
                  [-v["kc"], v["kc"] + v["ks"], 0.0],
                  [-v["k3"], 0.0, v["k3"]]])
    Bv = np.array([[v["b1"] + v["bc"] + v["b3"], -v["bc"], -v["b3"]],
                   [-v["bc"], v["bc"] + v["bs"], 0.0],
                   [-v["b3"], 0.0, v["b3"]]])
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Minv @ K, -Minv @ Bv]])
    B = np.concatenate([np.zeros(3), Minv[:, 0]])[:, None]
    C = np.zeros((1, 6))
    C[0, 0] = 1.0
    return A, B, C, np.zeros((1, 1))


def _hold_integrals(A, B, t):
    """(exp(A t), integral_0^t exp(A s) ds B) from one matrix exponential."""
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A * t, B * t
    E = linalg.expm(M)
    return E[:n, :n], E[:n, n:]


def delayed_response(A, B, C, u, fs, delay):
    """Samples y[k] = C x(k/fs) of a plant (D = 0) whose held input u[k] acts from k/fs + ``delay`` on, exactly.

    With delay = d/fs + r (0 <= r < 1/fs), over one period the plant sees u[k-d-1] for r seconds, then u[k-d]:
    x[k+1] = e^{Ah} x[k] + G1 u[k-d-1] + G0 u[k-d], G0 = int_0^{h-r} e^{As} ds B, G1 = e^{A(h-r)} int_0^r e^{As} ds B.
    """
    h = 1.0 / fs
    d = int(np.floor(delay * fs + 1e-12))
    r = delay - d * h
    Ad, _ = _hold_integrals(A, B, h)
    E_late, G0 = _hold_integrals(A, B, h - r)
    _, early = _hold_integrals(A, B, r)
    G1 = E_late @ early
    u = np.asarray(u, float)
    padded = np.concatenate([np.zeros(d + 1), u])   # padded[k + 1] = u[k - d]: zero before the record starts
    x = np.zeros(A.shape[0])
    y = np.empty(len(u))
    for k in range(len(u)):
        y[k] = C[0] @ x
        x = Ad @ x + G1[:, 0] * padded[k] + G0[:, 0] * padded[k + 1]
    return y


def random_plant(effect, rng):
    """A random true plant: (function torque samples -> encoder samples before quantisation, truth dict)."""
    if effect == "hand_mass":
        values = _random_row(rng, 11)
        return (lambda u: simulate_lti(tf_11(values), u, FS)), {"effect": effect, **values}
    values = _random_row(rng, 7)
    truth = {"effect": effect, **values}
    if effect == "none":
        return (lambda u: simulate_lti(tf_7(values), u, FS)), truth
    if effect == "vibration_mode":
        f3, ratio, zeta = rng.uniform(25.0, 90.0), rng.uniform(0.3, 1.5), rng.uniform(0.02, 0.1)
        m3 = ratio * values["m1"]
        k3 = m3 * (2 * np.pi * f3) ** 2
        truth.update(m3=m3, k3=k3, b3=2 * zeta * np.sqrt(k3 * m3), f3=f3)
        A, B, C, D = second_mode_ss(truth)
        return (lambda u: simulate_lti(control.ss(A, B, C, D), u, FS)), truth
    if effect == "loop_delay":
        truth["T"] = rng.uniform(0.5e-3, 3e-3)
        A, B, C, _ = _plant_ss(values)
        return (lambda u: delayed_response(A, B, C, u, FS, truth["T"])), truth
    raise ValueError(f"effect must be one of {TRUTH_EFFECTS}; got {effect!r}")


def _plant_ss(values):
    sys = control.ss(tf_7(values))
    return tuple(np.asarray(m) for m in (sys.A, sys.B, sys.C, sys.D))


def measure(plant, seed, duration=20.0, torque_rms=0.05, noise_rad=1e-5):
    """Simulate the identification experiment on ``plant`` and return the measured table (a DataFrame with
    ``frequency`` [Hz], ``magnitude_db`` [dB re 1 rad/(N.m)], ``phase_deg`` [deg, unwrapped], ``coherence``)."""
    u = white_noise(duration, FS, band=(0.1, 150.0), rms=torque_rms, seed=seed)
    y = plant(u) + np.random.default_rng(seed + 1).normal(0.0, noise_rad, len(u))
    y = ENCODER_STEP * np.round(y / ENCODER_STEP)
    fr = welch_tf(u, y, FS, window="hann", nperseg=4096).band(*BAND)
    return pd.DataFrame({"frequency": fr.f, "magnitude_db": 20 * np.log10(np.abs(fr.H)),
                         "phase_deg": np.degrees(np.unwrap(np.angle(fr.H))), "coherence": fr.coherence})


def make_case(effect, rng):
    """A random hidden-effect case: (measured table, truth dict)."""
    plant, truth = random_plant(effect, rng)
    return measure(plant, int(rng.integers(1 << 30))), truth


# -- the diagnosis job of a measured table (tests and benchmark, both truths) ------------------------------------

SOURCE = Path(__file__).resolve().parent.parent / "modelica" / "Haptic" / "package.mo"
JOB = """
[model]
source = "{source}"
name = "Haptic.Device7"
[data]
path = "data.csv"
[experiment]
kind = "frequency"
input = "tau"
sample_rate = 1000.0
[compare]
signals = [{{ output = "phi", noise = 0.02 }}]
max_nfev = 100
{parameters}
[candidates]
effects = {effects}
[parallel]
workers = {workers}
"""
# The baseline's free parameters (start, min, max): Table I-like starts, bounds well beyond Table I's ranges
BASELINE = {"m1": (8e-4, 2e-4, 4e-3), "b1": (0.04, 1e-3, 0.5), "bc": (0.04, 1e-4, 0.5), "kc": (80.0, 5.0, 400.0),
            "m2": (2e-3, 2e-4, 0.02), "bs": (0.05, 1e-5, 1.0), "ks": (2.0, 0.05, 300.0)}


def write_job(folder, frame, effects, workers=0):
    """Write ``frame`` (the measured table) and a diagnosis job of Haptic.Device7 offering ``effects`` into
    ``folder``; returns the job's path."""
    folder = Path(folder)
    frame.to_csv(folder / "data.csv", index=False)
    tables = "".join(f"[parameters.{n}]\nstart = {a!r}\nmin = {lo!r}\nmax = {hi!r}\n"
                     for n, (a, lo, hi) in BASELINE.items())
    path = folder / "job.toml"
    path.write_text(JOB.format(source=SOURCE.as_posix(), effects=json.dumps(list(effects)), parameters=tables,
                               workers=workers))
    return path
