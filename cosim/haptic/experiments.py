"""The papers' identification experiments, simulated, and the arm-model plots and robust-stability check.

* `device_experiment`: seed 000 Sec. II-C: white-noise torque 0.1-150 Hz for 20 s at 1 kHz through the
  device + user plant (an LTI model or any ``simulate(u) -> y`` callable, e.g. an FMU), Welch estimate with a
  4096-point Hann window and 50 % overlap, fit of the 11- or 7-parameter model.
* `arm_experiment`: seed 001 Sec. II-D/E: coloured noise (Gaussian, 13th-order Butterworth low-pass at 30 Hz,
  |F| <= 5 N) for 60 s at 1 kHz on the arm, Welch with 32 Hamming segments and 50 % overlap, coherence-weighted
  fit of M, k1, k2, b1, b2 over 0.6-30 Hz.
* `arm_robust_stability`: the virtual wall (K, B, ZOH at the loop rate) rendered through a rigid device mass on
  the nominal arm of Table II with the multiplicative uncertainty of Table IV (seed 001 eq. 8).
"""

from dataclasses import dataclass

import numpy as np
import control

from cosim.freqresp import coloured_noise, simulate_lti, welch_tf, white_noise
from cosim.haptic.ident import ArmFit, DeviceUserFit
from cosim.haptic.params import R_POINT_A, load_arm_params, load_uncertainty_weight
from cosim.haptic.tf import tf_arm, uncertainty_weight_tf

__all__ = [
    "device_experiment",
    "arm_experiment",
    "arm_segment_length",
    "RobustCheck",
    "arm_robust_stability",
    "plot_arm_models",
]


def _plant_output(plant, u, fs):
    if callable(plant) and not isinstance(plant, (control.TransferFunction, control.StateSpace)):
        return np.asarray(plant(u), dtype=float)
    return simulate_lti(plant, u, fs)


def device_experiment(plant, structure, fs=1000.0, duration=20.0, band=(0.1, 150.0), torque_rms=0.05,
                      noise_rad=1e-5, seed=0, position=None):
    """Simulate seed 000's identification experiment and fit the device + user model.

    Parameters
    ----------
    plant : control.TransferFunction or callable
        The plant phi/tau, or a function mapping the torque samples (N.m, held over each period) to the
        encoder samples (rad).
    structure : {11, 7}
        Model to fit.
    fs : float, optional
        Sample rate, Hz (default 1000).
    duration : float, optional
        s (default 20).
    band : (float, float), optional
        Excitation band, Hz (default 0.1-150).
    torque_rms : float, optional
        N.m (default 0.05).
    noise_rad : float, optional
        Standard deviation of white measurement noise added to the encoder, rad (default 1e-5).
    seed : int, optional
    position : int, optional
        Grasp position whose Table I median starts the fit.

    Returns
    -------
    (FrequencyResponse, DeviceUserFit)
    """
    u = white_noise(duration, fs, band=band, rms=torque_rms, seed=seed)
    y = _plant_output(plant, u, fs)
    y = y + np.random.default_rng(seed + 1).normal(0.0, noise_rad, len(y))
    fr = welch_tf(u, y, fs, window="hann", nperseg=4096)
    return fr, DeviceUserFit(structure, fs=fs, position=position).fit(fr)


def arm_segment_length(n_samples, segments=32):
    """Segment length giving ``segments`` half-overlapping Welch segments over ``n_samples`` (2n/(segments+1))."""
    return int(2 * n_samples // (segments + 1))


def arm_experiment(plant, fs=1000.0, duration=60.0, peak_force=5.0, noise_m=2e-5, seed=0):
    """Simulate seed 001's experiment on an arm and fit the five-parameter model.

    Parameters
    ----------
    plant : ArmParams, control.TransferFunction or callable
        The arm (X/F, m/N), or a function mapping force samples (N) to position samples (m).
    fs : float, optional
        Hz (default 1000).
    duration : float, optional
        s (default 60).
    peak_force : float, optional
        N (default 5).
    noise_m : float, optional
        Standard deviation of the position measurement noise, m (default 2e-5).
    seed : int, optional

    Returns
    -------
    (FrequencyResponse, ArmFit)
    """
    if hasattr(plant, "k1") and hasattr(plant, "M"):
        plant = tf_arm(plant)
    F = coloured_noise(duration, fs, cutoff=30.0, order=13, peak=peak_force, seed=seed)
    x = _plant_output(plant, F, fs)
    x = x + np.random.default_rng(seed + 1).normal(0.0, noise_m, len(x))
    fr = welch_tf(F, x, fs, window="hamming", nperseg=arm_segment_length(len(F)))
    return fr, ArmFit(fs=fs).fit(fr)


@dataclass(frozen=True)
class RobustCheck:
    """Robust stability of the wall on the uncertain arm.

    Attributes
    ----------
    axis, level : str
    nominal_stable : bool
        Closed loop with the nominal arm is stable.
    peak : float
        max |W_u T| over the checked band.
    f_peak_Hz : float
    robust : bool
        nominal_stable and peak < 1.
    band_Hz : (float, float)
    """

    axis: str
    level: str
    nominal_stable: bool
    peak: float
    f_peak_Hz: float
    robust: bool
    band_Hz: tuple


def arm_robust_stability(axis="X", level="max", K=10.0, B=0.0, rate=1000.0, r=R_POINT_A, band=(0.6, 30.0),
                         device_mass=0.066, device_damping=1.4):
    """Check the virtual wall rendered through the device on the uncertain arm of seed 001.

    The wall stiffness K (N.m/rad) and damping B (N.m.s/rad, backward-difference velocity) at the phi axis
    become K/r^2, B/r^2 at the stylus, sampled with a ZOH at ``rate``. The device is a rigid mass
    ``device_mass`` (kg) with viscous friction ``device_damping`` (N.s/m) at point A (defaults: m1 + m2 ~ 1.9
    g.m2 and b1 ~ 0.04 N.m.s/rad of seed 000 Table I, divided by r^2); the arm is X/F = H (1 + W_u Delta),
    |Delta| <= 1, with H of Table II and W_u of Table IV (seed 001 eq. 8).

    Pulling Delta out of the loop gives the interconnection q = -W_u Z H / (1 + Z H) p with
    Z = C + m s^2 + b s the impedance the arm sees, so the loop is robustly stable when it is nominally stable
    (closed-loop poles of the sampled nominal loop inside the unit circle) and max |W_u Z H/(1 + Z H)| < 1.
    The sampled wall enters Z as C(e^{jwT}) (1 - e^{-jwT})/(jwT) (hold), accurate well below Nyquist; W_u is
    fitted only over 0.6-30 Hz, so the peak is taken over ``band``.

    Returns
    -------
    RobustCheck
    """
    H = tf_arm(load_arm_params(axis, "nominal"))
    T = 1.0 / rate
    k_lin, b_lin = K / r**2, B / r**2
    s = control.tf("s")
    P = control.minreal(H / (1 + (device_mass * s**2 + device_damping * s) * H), verbose=False)
    Pz = control.c2d(P, T, "zoh")
    C = k_lin + b_lin / T * control.tf([1, -1], [1, 0], dt=T)  # K + B (1 - z^-1)/T
    cl = control.feedback(C * Pz, 1)
    nominal_stable = bool(np.max(np.abs(cl.poles())) < 1.0)
    W = uncertainty_weight_tf(load_uncertainty_weight(axis, level))
    f = np.logspace(np.log10(band[0]), np.log10(band[1]), 2000)
    w = 2 * np.pi * f
    z = np.exp(1j * w * T)
    Cf = (k_lin + b_lin / T * (1 - 1 / z)) * (1 - 1 / z) / (1j * w * T)
    Z = Cf + device_mass * (1j * w) ** 2 + device_damping * 1j * w
    Hf = H(1j * w)
    mag = np.abs(W(1j * w) * Z * Hf / (1 + Z * Hf))
    i = int(np.argmax(mag))
    return RobustCheck(axis, level, nominal_stable, float(mag[i]), float(f[i]), bool(nominal_stable and mag[i] < 1.0),
                       tuple(band))


def plot_arm_models(path, band=(0.6, 30.0)):
    """Bode plots of the Table II nominal arm models and |W_u| of Table IV over ``band`` to one PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = np.logspace(np.log10(0.1), np.log10(100), 800)
    fb = np.logspace(np.log10(band[0]), np.log10(band[1]), 400)
    fig, ax = plt.subplots(3, 1, figsize=(7, 10))
    for i, axis in enumerate("XYZ"):
        H = tf_arm(load_arm_params(axis, "nominal"))(2j * np.pi * f)
        ax[0].semilogx(f, 20 * np.log10(np.abs(H)), color=f"C{i}", label=f"{axis} nominal (Table II)")
        ax[1].semilogx(f, np.degrees(np.unwrap(np.angle(H))), color=f"C{i}")
        for level, ls in (("max", "--"), ("67ci", "-")):
            w = load_uncertainty_weight(axis, level)
            W = uncertainty_weight_tf(w)(2j * np.pi * fb)
            lab = f"{axis} {level}" + (" (garbled pole pair)" if w.garbled else "")
            ax[2].semilogx(fb, 20 * np.log10(np.abs(W)), color=f"C{i}", ls=ls, label=lab)
    ax[0].set_ylabel("|X/F| (dB re 1 m/N)")
    ax[1].set_ylabel("phase (deg)")
    ax[2].set_ylabel("|W_u| (dB)")
    ax[2].axhline(0, color="k", lw=0.8)
    ax[2].set_xlabel("frequency (Hz)")
    ax[0].legend()
    ax[2].legend(fontsize=7, ncol=2)
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    ax[0].set_title("Fu arm: nominal models (Table II) and uncertainty weights (Table IV)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
