"""A second hidden-effect truth of the haptic frequency-response diagnosis (issue #32 item 3), written from other
formulations than the candidates (modelica/Haptic Effects) and than the first truth (tests/diagnose_truth_haptic.py);
never used to tune anything. numpy/scipy only: no cosim.haptic.tf, no cosim.freqresp, no ``control``.

Plant: a lumped mechanical network (masses on nodes, springs and dampers on edges, either end possibly ground)
assembled into mass, damping and stiffness matrices M, D, K exactly as a finite-element code assembles elements:
``M q'' + D q' + K q = F_tau tau + F_h tau_h``. Motor torque ``tau`` [N.m] on the driven node, encoder angle
[rad] of that node out, the user's physiological tremor ``tau_h`` on the hand node. The networks come from
seed 000 Fig. 5 read as drawings, not from the printed transfer functions (eq. 2 is garbled in the seed text):

* ``none``: the 7-parameter device + user (Fig. 5 bottom, eq. 9): m1 -b1- ground, m1 -kc,bc- m2, m2 -ks,bs- ground.
* ``hand_mass``: the 11-parameter network (Fig. 5 top, eq. 2): m1 -b1- ground, m1 -kc,bc- m2, m2 -b2- ground,
  m2 -ks,bs- mh, mh -kh,bh- ground. Static compliance 1/kc + 1/ks + 1/kh (eq. 8).
* ``vibration_mode``: a compliant cable (capstan) transmission inside m1 (a two-inertia drive, e.g. Ellis,
  *Control System Design Guide*, ch. 16): m1 is split into the motor rotor J_r = a m1 (a in [0.3, 0.7]), which
  carries the torque, the encoder and b1, and the drum/link J_d = (1 - a) m1, joined by the cable k_t, b_t; the
  drum carries kc, bc to m2. The drawn frequency f_t (25-90 Hz) is the rotor-drum resonance with the link
  removed, sqrt(k_t (1/J_r + 1/J_d))/(2 pi), and zeta (0.02-0.1) its damping ratio, b_t = 2 zeta sqrt(k_t J_eff),
  J_eff = J_r J_d/(J_r + J_d). The mode is in series (the cable adds 1/k_t to the static compliance); the first
  truth and the candidate hang a side inertia m3 on m1 instead, which leaves the static gain alone.
  Found after the evaluation (docs/dev/diagnose-truth2-haptic.md): this chain is the 11-parameter network with
  its roles reassigned, so the encoder's response cannot tell it from a hand mass.
* ``loop_delay``: a transport delay T (0.5-3 ms) realised on the measurement: the encoder sample paired with
  DAC update k is the angle at k/fs - T, propagated exactly from the last DAC instant before it. For a linear
  plant at rest this equals a torque delayed by T (time invariance); the first truth switches the held torque
  T after each sample, the candidate is a (3,3) Pade filter.

Parameters: two random rows of Table I of the structure needed (read as data with
cosim.haptic.params.load_user_params, printed zeros replaced by a log-uniform draw in [1e-4, 1e-3] table units)
mixed geometrically with a uniform weight; the first truth perturbs one row by a log-normal factor.

Experiment (Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*, robust method): 5
realisations of a random-phase multisine (flat amplitude on every DFT line of a 2048-sample period at 1 kHz,
0.49-150 Hz, 0.05 N.m RMS), each applied for two periods, the first one dropped as the transient: 20.5 s as in
seed 000 Sec. II-C. The DAC holds the torque (exact ZOH discretisation, scipy.signal.cont2discrete, then
scipy.signal.dlsim). Noise: tremor torque on the hand (Gaussian, 4th-order Butterworth band 6-12 Hz, RMS drawn in
[1, 3] mN.m) and the encoder quantised to 0.03 mm at point A (1.76e-4 rad at the phi axis); the first truth uses
band-limited white noise, 1e-5 rad white sensor noise and a 2048 x 20 count encoder. Estimate: the mean over
realisations of Y/U at the excited lines and the magnitude-squared coherence across realisations; lines in
1-100 Hz kept (202 rows). The first truth uses the project's Hann-Welch H1 (4096 points). Neighbouring lines of a
multisine have independent errors, unlike Hann-Welch bins, which the workflow's noise estimate assumes; so
``estimator="welch"`` (truth set "2w" of the evaluation) estimates the same record by scipy's Welch H1 (Hann 4096,
50 %) to tell the estimator's part of the figures from the plants'.

Evaluation: ``python benchmarks/diagnose.py --experiments haptic --truths 1 2 2w --cases N --rows rows.jsonl``
diagnoses N drawn cases of each effect of each truth set with the whole library of Haptic.Device7 offered.
"""

import time
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import signal

__all__ = ["TRUTH2_EFFECTS", "SHOWN", "FS", "PERIOD", "REALISATIONS", "ENCODER_STEP", "Network", "plant_network",
           "draw_truth", "simulate", "estimate", "welch_estimate", "measure", "make_case2", "diagnose_case_haptic2",
           "diagnose_case_haptic1", "diagnose_frame_haptic", "library"]

TRUTH2_EFFECTS = ("none", "hand_mass", "vibration_mode", "loop_delay")
SHOWN = ("hand_mass", "vibration_mode", "loop_delay")  # a 1-100 Hz response shows each of them
FS = 1000.0                            # Hz, DAC and encoder rate (seed 000 Sec. II-A)
PERIOD = 2048                          # samples per multisine period: lines every 0.488 Hz
REALISATIONS = 5                       # random-phase realisations, two periods each: 20.5 s
EXCITED = (0.4, 150.0)                 # Hz, the excited band (seed 000: 0.1-150 Hz)
BAND = (1.0, 100.0)                    # Hz, the lines kept in the table
TORQUE_RMS = 0.05                      # N.m
ENCODER_STEP = 0.03e-3 / 0.17          # rad at phi: 0.03 mm nominal resolution at point A, 0.17 m from the axis
TREMOR_BAND = (6.0, 12.0)              # Hz, physiological tremor


class Network:
    """A lumped rotational network: ``nodes`` (name -> inertia [kg.m2]) and ``edges`` (kind "k" or "b", node,
    node or None for ground, value), assembled into M, D, K like finite elements."""

    def __init__(self, nodes, edges, driven, hand):
        self.names = list(nodes)
        self.inertias = np.array([nodes[n] for n in self.names], float)
        self.edges, self.driven, self.hand = list(edges), driven, hand

    def matrices(self):
        """(M, D, K), each shape (n, n): each edge adds value * [[1, -1], [-1, 1]] on its two nodes."""
        n = len(self.names)
        mats = {"b": np.zeros((n, n)), "k": np.zeros((n, n))}
        for kind, a, b, value in self.edges:
            i = self.names.index(a)
            mats[kind][i, i] += value
            if b is not None:
                j = self.names.index(b)
                mats[kind][j, j] += value
                mats[kind][i, j] -= value
                mats[kind][j, i] -= value
        return np.diag(self.inertias), mats["b"], mats["k"]

    def unit(self, node):
        e = np.zeros(len(self.names))
        e[self.names.index(node)] = 1.0
        return e

    def state_space(self):
        """(A, B, C, D): states q then q'; inputs tau (driven node), tau_h (hand node); output q[driven]."""
        M, D, K = self.matrices()
        n = len(self.names)
        Minv = np.diag(1.0 / self.inertias)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
        F = np.column_stack([self.unit(self.driven), self.unit(self.hand)])
        B = np.vstack([np.zeros((n, 2)), Minv @ F])
        C = np.concatenate([self.unit(self.driven), np.zeros(n)])[None, :]
        return A, B, C, np.zeros((1, 2))

    def receptance(self, frequency):
        """Continuous phi/tau at ``frequency`` [Hz]: e^T (K + j w D - w^2 M)^-1 e, no state space involved."""
        M, D, K = self.matrices()
        e = self.unit(self.driven)
        w = 2 * np.pi * np.atleast_1d(np.asarray(frequency, float))[:, None, None]
        dynamic = K[None] + 1j * w * D[None] - w * w * M[None]
        return np.linalg.solve(dynamic, np.broadcast_to(e.astype(complex), dynamic.shape[:2])[..., None])[
            :, self.names.index(self.driven), 0]


def plant_network(truth):
    """The network of a truth dict (:func:`draw_truth`)."""
    v, effect = truth, truth["effect"]
    device = [("b", "m1", None, v["b1"]), ("k", "m1", "m2", v["kc"]), ("b", "m1", "m2", v["bc"])]
    if effect == "hand_mass":
        edges = device + [("b", "m2", None, v["b2"]), ("k", "m2", "mh", v["ks"]), ("b", "m2", "mh", v["bs"]),
                          ("k", "mh", None, v["kh"]), ("b", "mh", None, v["bh"])]
        return Network({"m1": v["m1"], "m2": v["m2"], "mh": v["mh"]}, edges, "m1", "mh")
    user = [("k", "m2", None, v["ks"]), ("b", "m2", None, v["bs"])]
    if effect == "vibration_mode":
        jr, jd = v["rotor_share"] * v["m1"], (1 - v["rotor_share"]) * v["m1"]
        edges = [("b", "rotor", None, v["b1"]), ("k", "rotor", "m1", v["k_t"]), ("b", "rotor", "m1", v["b_t"]),
                 ("k", "m1", "m2", v["kc"]), ("b", "m1", "m2", v["bc"])] + user
        return Network({"rotor": jr, "m1": jd, "m2": v["m2"]}, edges, "rotor", "m2")
    return Network({"m1": v["m1"], "m2": v["m2"]}, device + user, "m1", "m2")


@lru_cache(maxsize=None)
def _table_rows(structure):
    """The Table I rows fitted with ``structure`` (read once: 78 reads cost seconds)."""
    from cosim.haptic.params import POSITIONS, USERS, load_user_params

    rows = [load_user_params(u, p) for u in USERS for p in POSITIONS]
    return tuple(r.values for r in rows if r.structure == structure)


def _random_row(rng, structure):
    """Two random Table I rows of ``structure`` mixed geometrically; printed zeros drawn log-uniform."""
    rows = _table_rows(structure)
    a, b = (rows[i] for i in rng.choice(len(rows), 2, replace=False))
    w = rng.uniform()
    out = {}
    for name in a:
        pair = []
        for x in (a[name], b[name]):
            if x == 0.0:
                x = 10 ** rng.uniform(-4, -3) * (1e-3 if name.startswith("m") else 1.0)
            pair.append(x)
        out[name] = float(np.exp((1 - w) * np.log(pair[0]) + w * np.log(pair[1])))
    return out


def draw_truth(effect, rng):
    """A random truth dict: the effect, the plant's values (SI), the effect's size and the tremor RMS [N.m]."""
    if effect not in TRUTH2_EFFECTS:
        raise ValueError(f"effect must be one of {TRUTH2_EFFECTS}; got {effect!r}")
    truth = {"effect": effect, **_random_row(rng, 11 if effect == "hand_mass" else 7)}
    if effect == "vibration_mode":
        share, f_t, zeta = rng.uniform(0.3, 0.7), rng.uniform(25.0, 90.0), rng.uniform(0.02, 0.1)
        j_eff = share * (1 - share) * truth["m1"]
        k_t = (2 * np.pi * f_t) ** 2 * j_eff
        truth.update(rotor_share=share, f_t=f_t, zeta_t=zeta, k_t=k_t, b_t=float(2 * zeta * np.sqrt(k_t * j_eff)))
    elif effect == "loop_delay":
        truth["T"] = rng.uniform(0.5e-3, 3e-3)
    truth["tremor_rms"] = rng.uniform(1e-3, 3e-3)
    return truth


def _multisine(rng):
    """(torque samples, excited line indices): REALISATIONS random-phase multisines, each repeated twice."""
    freqs = np.fft.rfftfreq(PERIOD, 1 / FS)
    lines = np.flatnonzero((freqs >= EXCITED[0]) & (freqs <= EXCITED[1]))
    periods = []
    for _ in range(REALISATIONS):
        spectrum = np.zeros(len(freqs), complex)
        spectrum[lines] = np.exp(2j * np.pi * rng.uniform(size=len(lines)))
        x = np.fft.irfft(spectrum, PERIOD)
        periods.append(np.tile(x * TORQUE_RMS / np.sqrt(np.mean(x ** 2)), 2))
    return np.concatenate(periods), lines


def _tremor(rng, n, rms):
    sos = signal.butter(4, TREMOR_BAND, btype="bandpass", fs=FS, output="sos")
    x = signal.sosfilt(sos, rng.normal(size=n + 2000))[2000:]   # 2 s of filter transient dropped
    return x * rms / np.sqrt(np.mean(x ** 2))


def simulate(truth, torque, tremor=None):
    """Encoder angle samples [rad, before quantisation] for held ``torque`` and ``tremor`` samples [N.m]:
    exact ZOH discretisation of the network; with a delay T the sample k is the angle at k/fs - T."""
    A, B, C, D = plant_network(truth).state_space()
    u = np.column_stack([torque, np.zeros(len(torque)) if tremor is None else tremor])
    h = 1.0 / FS
    Ad, Bd, _, _, _ = signal.cont2discrete((A, B, C, D), h, method="zoh")
    _, _, x = signal.dlsim((Ad, Bd, np.eye(len(A)), np.zeros((len(A), 2)), h), u)
    x = np.atleast_2d(x)
    T = truth.get("T", 0.0)
    if T == 0.0:
        return x @ C[0]
    d = int(np.floor(T * FS + 1e-12))
    r = T - d * h
    Ar, Br, _, _, _ = signal.cont2discrete((A, B, C, D), h - r, method="zoh")
    late = x @ Ar.T + u @ Br.T              # late[j]: the state at j h + (h - r)
    y = np.zeros(len(u))
    y[d + 1:] = late[:len(u) - d - 1] @ C[0]  # sample k reads (k - d - 1) h + h - r = k h - T
    return y


def estimate(torque, angle, lines):
    """(frequency [Hz], H, coherence) at ``lines`` from the second period of each realisation."""
    U, Y = [], []
    for m in range(REALISATIONS):
        start = (2 * m + 1) * PERIOD
        U.append(np.fft.rfft(torque[start:start + PERIOD])[lines])
        Y.append(np.fft.rfft(angle[start:start + PERIOD])[lines])
    U, Y = np.array(U), np.array(Y)
    H = np.mean(Y / U, axis=0)
    coherence = np.abs(np.sum(Y * U.conj(), 0)) ** 2 / (np.sum(np.abs(U) ** 2, 0) * np.sum(np.abs(Y) ** 2, 0))
    return np.fft.rfftfreq(PERIOD, 1 / FS)[lines], H, coherence


def welch_estimate(torque, angle):
    """(frequency [Hz], H1, coherence) of the whole record by scipy's Welch averages (Hann 4096, 50 %): the
    estimator the workflow's noise model was written for, to tell the estimator's part from the plants'."""
    f, Puu = signal.welch(torque, FS, window="hann", nperseg=4096, noverlap=2048)
    _, Pyy = signal.welch(angle, FS, window="hann", nperseg=4096, noverlap=2048)
    _, Puy = signal.csd(torque, angle, FS, window="hann", nperseg=4096, noverlap=2048)
    return f, Puy / Puu, np.abs(Puy) ** 2 / (Puu * Pyy)


def measure(truth, rng, noise=True, estimator="lines"):
    """The measured table of the identification experiment on ``truth``: a DataFrame with ``frequency`` [Hz],
    ``magnitude_db`` [dB re 1 rad/(N.m)], ``phase_deg`` [deg, unwrapped] and ``coherence``. ``estimator``:
    "lines" (the multisine's DFT at its lines, the second truth's) or "welch" (H1 of the same record)."""
    torque, lines = _multisine(rng)
    tremor = _tremor(rng, len(torque), truth["tremor_rms"]) if noise else None
    angle = simulate(truth, torque, tremor)
    if noise:
        angle = ENCODER_STEP * np.round(angle / ENCODER_STEP)
    if estimator == "lines":
        f, H, g2 = estimate(torque, angle, lines)
    elif estimator == "welch":
        f, H, g2 = welch_estimate(torque, angle)
    else:
        raise ValueError(f"estimator must be 'lines' or 'welch'; got {estimator!r}")
    keep = (f >= BAND[0]) & (f <= BAND[1])
    return pd.DataFrame({"frequency": f[keep], "magnitude_db": 20 * np.log10(np.abs(H[keep])),
                         "phase_deg": np.degrees(np.unwrap(np.angle(H[keep]))),
                         "coherence": np.clip(g2[keep], 1e-6, 1.0)})


def make_case2(effect, rng, estimator="lines"):
    """A random hidden-effect case of the second truth: (measured table, truth dict)."""
    truth = draw_truth(effect, rng)
    return measure(truth, rng, estimator=estimator), truth


# -- the diagnosis: the first truth's job (diagnose_truth_haptic.write_job) with the whole library ---------------


def library():
    """Every effect of the library that applies to Haptic.Device7 (the whole library is offered)."""
    from cosim.diagnose.effects import applicable

    from diagnose_truth_haptic import SOURCE

    return applicable(SOURCE.read_text(encoding="utf-8"), "Haptic.Device7")


def diagnose_frame_haptic(frame, truth, seed, folder, noise, workers=0):
    """Diagnose a measured table of either truth with the whole library; no FMU build. Returns the row of
    tests/diagnose_truth2.diagnose_frame (``noise``: the case's noise parameter, its units per truth)."""
    from cosim.diagnose import load_diagnose_job, run_diagnosis
    from diagnose_truth2 import diagnosis_row
    from diagnose_truth_haptic import write_job

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    job = load_diagnose_job(write_job(folder, frame, library(), workers))
    start = time.perf_counter()
    s = run_diagnosis(job, progress=False, build=False).to_json()
    return diagnosis_row(s, truth, seed, noise, time.perf_counter() - start)


def diagnose_case_haptic2(effect, seed, folder, workers=0, estimator="lines"):
    """Diagnose the second truth's case (``effect``, ``seed``); one row (noise: the tremor RMS [N.m])."""
    frame, truth = make_case2(effect, np.random.default_rng(seed), estimator)
    return diagnose_frame_haptic(frame, truth, seed, folder, truth["tremor_rms"], workers)


def diagnose_case_haptic1(effect, seed, folder, workers=0):
    """The same row for the FIRST truth's case (tests/diagnose_truth_haptic.make_case; noise: its 1e-5 rad
    white sensor noise), offered the same whole library, so both truths count side by side."""
    from diagnose_truth_haptic import make_case

    frame, truth = make_case(effect, np.random.default_rng(seed))
    return diagnose_frame_haptic(frame, truth, seed, folder, 1e-5, workers)
