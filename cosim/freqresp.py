"""Frequency responses, generic: excitations, sampled LTI simulation, Welch estimates, model responses (ZOH).

The estimate follows MATLAB's ``tfestimate`` (H1 = P_xy / P_xx) and ``mscohere`` with the windows the seed
papers used; the exact zero-order-hold frequency response lets a model be compared with data that were
sampled through a hold (the plant input is a DAC output held over each sample period).
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal

import control

__all__ = [
    "FrequencyResponse",
    "white_noise",
    "coloured_noise",
    "simulate_lti",
    "welch_tf",
    "zoh_freq_response",
    "model_response",
]


@dataclass(frozen=True)
class FrequencyResponse:
    """An estimated frequency response.

    Attributes
    ----------
    f : numpy.ndarray, shape (n,)
        Frequencies, Hz.
    H : numpy.ndarray of complex, shape (n,)
        Output/input response at ``f``.
    coherence : numpy.ndarray, shape (n,)
        Magnitude-squared coherence at ``f`` (0..1).
    """

    f: np.ndarray
    H: np.ndarray
    coherence: np.ndarray

    def band(self, fmin, fmax):
        """Return the part with ``fmin <= f <= fmax`` (Hz)."""
        k = (self.f >= fmin) & (self.f <= fmax)
        return FrequencyResponse(self.f[k], self.H[k], self.coherence[k])


def white_noise(duration, fs, band=(0.1, 150.0), rms=1.0, seed=0, order=4):
    """Gaussian white noise band-limited to ``band`` (Butterworth band-pass, zero phase), scaled to ``rms``.

    Parameters
    ----------
    duration : float
        Length, s.
    fs : float
        Sample rate, Hz.
    band : (float, float), optional
        Pass band, Hz (default 0.1-150 Hz, seed 000 Sec. II-C).
    rms : float, optional
        RMS of the result (default 1).
    seed : int, optional
        Seed of the generator (default 0).
    order : int, optional
        Butterworth order of each edge (default 4).

    Returns
    -------
    numpy.ndarray, shape (round(duration * fs),)
    """
    n = int(round(duration * fs))
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    sos = signal.butter(order, band, btype="bandpass", fs=fs, output="sos")
    x = signal.sosfiltfilt(sos, x)
    return x * (rms / np.sqrt(np.mean(x**2)))


def coloured_noise(duration, fs, cutoff=30.0, order=13, peak=5.0, seed=0):
    """Gaussian white noise low-passed by a Butterworth filter, scaled so that ``max |x| = peak``.

    Seed 001 Sec. II-D: 30 Hz, 13th order, forces <= 5 N, 60 s at 1 kHz.

    Parameters
    ----------
    duration : float
        s.
    fs : float
        Hz.
    cutoff : float, optional
        Hz (default 30).
    order : int, optional
        Filter order (default 13).
    peak : float, optional
        Largest absolute value of the result (default 5).
    seed : int, optional

    Returns
    -------
    numpy.ndarray, shape (round(duration * fs),)
    """
    n = int(round(duration * fs))
    rng = np.random.default_rng(seed)
    sos = signal.butter(order, cutoff, btype="lowpass", fs=fs, output="sos")
    x = signal.sosfilt(sos, rng.standard_normal(n))
    return x * (peak / np.max(np.abs(x)))


def simulate_lti(G, u, fs):
    """Sample the output of the continuous plant G driven by ``u`` held constant over each sample (ZOH).

    Parameters
    ----------
    G : control.TransferFunction or control.StateSpace
        Continuous-time SISO plant, starting at rest.
    u : array_like, shape (n,)
        Input samples.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    numpy.ndarray, shape (n,)
        ``y[k]`` = output at ``t = k / fs`` (before the input sample ``u[k]`` acts).
    """
    sysd = control.c2d(control.ss(G), 1.0 / fs, "zoh")
    A, B, C, D = (np.asarray(m) for m in (sysd.A, sysd.B, sysd.C, sysd.D))
    _, y, _ = signal.dlsim((A, B, C, D, 1.0 / fs), np.asarray(u, dtype=float))
    return np.asarray(y).ravel()


def welch_tf(u, y, fs, window="hann", nperseg=4096, noverlap=None):
    """Estimate H = P_uy / P_uu and the coherence by Welch's method (as MATLAB's tfestimate / mscohere).

    Parameters
    ----------
    u, y : array_like, shape (n,)
        Input and output records.
    fs : float
        Sample rate, Hz.
    window : str, optional
        Window name for scipy.signal.get_window (default ``"hann"``; ``"hamming"`` for seed 001).
    nperseg : int, optional
        Segment length (default 4096).
    noverlap : int, optional
        Overlap in samples (default nperseg // 2, i.e. 50 %).

    Returns
    -------
    FrequencyResponse
        From 0 to fs/2 with resolution fs / nperseg (the 0 Hz bin is dropped).
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if u.shape != y.shape or u.ndim != 1:
        raise ValueError(f"u and y must be 1-D of equal length; got shapes {u.shape} and {y.shape}")
    if nperseg > len(u):
        raise ValueError(f"nperseg = {nperseg} is longer than the record ({len(u)} samples)")
    noverlap = nperseg // 2 if noverlap is None else noverlap
    win = signal.get_window(window, nperseg)
    kw = dict(fs=fs, window=win, nperseg=nperseg, noverlap=noverlap, detrend=False)
    f, puu = signal.welch(u, **kw)
    _, puy = signal.csd(u, y, **kw)
    _, coh = signal.coherence(u, y, **kw)
    return FrequencyResponse(f[1:], (puy / puu)[1:], coh[1:])


def zoh_freq_response(A, B, C, D, f, fs):
    """Exact frequency response of a continuous state-space plant sampled through a zero-order hold.

    Parameters
    ----------
    A, B, C, D : array_like
        Continuous SISO state-space matrices, shapes (n, n), (n, 1), (1, n), (1, 1).
    f : array_like, shape (m,)
        Frequencies, Hz.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    numpy.ndarray of complex, shape (m,)
        G_zoh(exp(j 2 pi f / fs)).
    """
    A = np.atleast_2d(np.asarray(A, dtype=float))
    n = A.shape[0]
    B = np.asarray(B, dtype=float).reshape(n, 1)
    C = np.asarray(C, dtype=float).reshape(1, n)
    D = float(np.asarray(D, dtype=float).ravel()[0]) if np.size(D) else 0.0
    T = 1.0 / fs
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A * T
    M[:n, n:] = B * T
    E = linalg.expm(M)
    Ad, Bd = E[:n, :n], E[:n, n:]
    z = np.exp(2j * np.pi * np.asarray(f, dtype=float) * T)
    eye = np.eye(n)
    lhs = z[:, None, None] * eye[None, :, :] - Ad[None, :, :]
    rhs = np.broadcast_to(Bd.astype(complex), (len(z), n, 1))
    x = np.linalg.solve(lhs, rhs)[:, :, 0]
    return x @ C.ravel() + D


def model_response(ss, f, fs=None):
    """Frequency response of a state-space plant: continuous, or through a zero-order hold at ``fs``.

    Parameters
    ----------
    ss : tuple of numpy.ndarray
        Continuous SISO (A, B, C, D), shapes (n, n), (n, 1), (1, n), (1, 1).
    f : array_like, shape (m,)
        Frequencies, Hz.
    fs : float, optional
        Sample rate of the hold, Hz (default None: the continuous response C (sI - A)^-1 B + D).

    Returns
    -------
    numpy.ndarray of complex, shape (m,)
    """
    A, B, C, D = ss
    if fs is None:
        s = 2j * np.pi * np.asarray(f, dtype=float)
        n = A.shape[0]
        x = np.linalg.solve(s[:, None, None] * np.eye(n)[None] - A[None], np.broadcast_to(B.astype(complex), (len(s), n, 1)))
        return x[:, :, 0] @ C.ravel() + D[0, 0]
    return zoh_freq_response(A, B, C, D, f, fs)
