"""Frequency-response experiments of the discrepancy workflow (``experiment.kind = "frequency"``).

The measured data are a frequency response output/input (e.g. encoder angle ``phi`` [rad] over motor torque
``tau`` [N.m]) in a table with the columns ``frequency`` [Hz, strictly increasing, > 0], ``magnitude_db``
[dB re 1 output unit per input unit], ``phase_deg`` [deg, any branch: the model's phase is compared modulo
360 deg] and ``coherence`` [1, in (0, 1]: the magnitude-squared coherence of the estimate, which shapes its
noise over frequency]. The workflow compares two real channels, the magnitude in dB and the phase in deg:
together the complex logarithm of the response, whose error is about the same in both parts for a Welch estimate
(1 dB of magnitude scatter goes with ~6.6 deg of phase scatter).

The model's response comes from the lowered Modelica model linearised at its rest point (exact CasADi
Jacobians), evaluated through a zero-order hold at ``experiment.sample_rate`` (the exact response of a sampled
experiment whose input is held by a DAC), or continuous when the sample rate is 0.
"""

from dataclasses import dataclass

import numpy as np

from cosim.freqresp import model_response, zoh_freq_response
from cosim.diagnose.fitting import check_parameters
from cosim.errors import ConfigError
from cosim.experiment import load_measurements

__all__ = ["COLUMNS", "DEG_PER_DB", "FrequencyExperiment", "FrequencyReplay", "load_frequency_experiment",
           "frequency_noise", "response"]

COLUMNS = ("magnitude_db", "phase_deg", "coherence")
_HANN_SECOND_DIFFERENCE = 2.5  # variance of a second difference of Hann-Welch estimate errors, in sigma^2
DEG_PER_DB = float(np.degrees(np.log(10) / 20))  # the same complex-log error in phase (deg) as 1 dB in magnitude


@dataclass(frozen=True)
class FrequencyExperiment:
    """A measured frequency response, aligned for the workflow.

    Attributes
    ----------
    frequency : ndarray, shape (N,)
        Hz. The workflow's abscissa (``time`` is an alias, so the time-domain machinery of segments and folds
        applies unchanged).
    measured : ndarray, shape (N, 2)
        Magnitude [dB] and phase [deg].
    coherence : ndarray, shape (N,)
        Magnitude-squared coherence of the estimate.
    input, output : str
        The model input excited and the output measured.
    sample_rate : float
        Hz: the model is compared through a zero-order hold at this rate (0: continuous).
    mask : ndarray of bool, shape (N,)
        Every point.
    """

    frequency: np.ndarray
    measured: np.ndarray
    coherence: np.ndarray
    input: str
    output: str
    sample_rate: float
    mask: np.ndarray

    @property
    def time(self):
        """The abscissa of the workflow: frequency [Hz]."""
        return self.frequency


def load_frequency_experiment(job, model):
    """The job's measured frequency response checked against ``model`` (a LoweredModel): the input and output
    exist, the columns are there and finite, frequencies are positive and strictly increasing; the
    ``data.start``/``data.stop`` window [Hz] and ``data.decimate`` are applied."""
    inputs, outputs = [u.name for u in model.inputs], [o.name for o in model.outputs]
    if job.input not in inputs:
        raise ConfigError(f"{job.path}: experiment.input: {job.model} has no input {job.input!r}; it has "
                          f"{', '.join(inputs)}")
    output = job.signals[0][0]
    if output not in outputs:
        raise ConfigError(f"{job.path}: compare.signals: {job.model} has no output {output!r}; it has "
                          f"{', '.join(outputs)}")
    frame = load_measurements(job.data_path, COLUMNS, abscissa="frequency", unit="Hz")
    f = frame["frequency"].to_numpy()
    if f[0] <= 0:
        raise ConfigError(f"data.path ({job.data_path.name}): frequency must be > 0 Hz; row 0 holds {f[0]:g} Hz")
    g2 = frame["coherence"].to_numpy()
    if ((g2 <= 0) | (g2 > 1)).any():
        row = int(np.flatnonzero((g2 <= 0) | (g2 > 1))[0])
        raise ConfigError(f"data.path ({job.data_path.name}): coherence must be in (0, 1]; row {row} holds "
                          f"{g2[row]:g}")
    f0, f1 = job.window
    frame = frame[(f >= f0) & (f <= f1)].iloc[::job.decimate].reset_index(drop=True)
    if len(frame) < 10:
        raise ConfigError(f"{job.path}: the data window [{f0}, {f1}] Hz holds {len(frame)} frequencies; need >= 10")
    return FrequencyExperiment(frequency=frame["frequency"].to_numpy(),
                               measured=frame[["magnitude_db", "phase_deg"]].to_numpy(),
                               coherence=frame["coherence"].to_numpy(),
                               input=job.input, output=output, sample_rate=job.sample_rate,
                               mask=np.ones(len(frame), bool))


def frequency_noise(experiment, floor):
    """Noise level (1 sd) of the magnitude [dB] and the phase [deg] at each frequency.

    The random error of an H1 estimate grows as sqrt((1 - coherence)/coherence) (Bendat & Piersol: relative
    sd sqrt((1 - g2)/(2 n g2)) for n averages), so sigma_c(f) = s_c sqrt((1 - g2)/g2); the level s_c of each
    channel is estimated from the data's own scatter: the robust scale (MAD) of second differences of
    neighbouring frequencies, each divided by the local shape. Second differences cancel the response's own
    slope across bins. Their variance is 2.5 sigma^2, not 6 sigma^2: in a Hann-window Welch estimate the errors
    of neighbouring bins correlate (4/9 at one bin, 1/36 at two: the squared correlations of the window's
    spectral kernel, -2/3 and 1/6), and 6 - 8 (4/9) + 2 (1/36) = 2.5 (checked on simulated estimates: the
    normalised residual of the true model has RMS 0.9-1.0). Floored by ``floor`` (dB, deg).

    Returns
    -------
    sigma : ndarray, shape (2, N)
    median : ndarray, shape (2,)
        The median of sigma over frequency, before the floor (what the report prints as "estimated").
    """
    g2 = np.clip(experiment.coherence, 1e-6, 1 - 1e-12)
    shape = np.sqrt((1 - g2) / g2)
    local = np.sqrt((shape[2:] ** 2 + 4 * shape[1:-1] ** 2 + shape[:-2] ** 2) / 6)
    d = np.diff(experiment.measured, n=2, axis=0) / local[:, None]
    scale = 1.4826 * np.median(np.abs(d - np.median(d, axis=0)), axis=0) / np.sqrt(_HANN_SECOND_DIFFERENCE)
    estimated = scale[:, None] * shape[None, :]
    return np.maximum(estimated, np.asarray(floor, float)[:, None]), np.median(estimated, axis=1)


def response(abcd, frequency, sample_rate):
    """Complex response of the state-space ``abcd`` at ``frequency`` [Hz]: through a ZOH at ``sample_rate`` [Hz],
    continuous when it is 0.

    Evaluated in modal form, sum_i c_i b_i g_i / (z - mu_i), from one eigendecomposition of A (a fit calls this
    thousands of times; a matrix exponential per call costs ~10x more): ZOH poles mu = exp(lambda h) with input
    gains g = (exp(lambda h) - 1)/lambda, or s - lambda when continuous. When the eigenvectors are nearly
    dependent (repeated poles) the direct solves of cosim.freqresp are used instead."""
    A, B, C, D = abcd
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8:
        return zoh_freq_response(*abcd, frequency, sample_rate) if sample_rate > 0 else \
            model_response(abcd, frequency)
    residues = (C @ V).ravel() * np.linalg.solve(V, B.astype(complex)).ravel()
    if sample_rate > 0:
        h = 1.0 / sample_rate
        mu = np.exp(lam * h)
        small = np.abs(lam * h) < 1e-9
        gain = np.where(small, h, (mu - 1) / np.where(small, 1.0, lam))
        z = np.exp(2j * np.pi * np.asarray(frequency, float) * h)
        return (residues * gain / (z[:, None] - mu[None, :])).sum(axis=1) + D[0, 0]
    s = 2j * np.pi * np.asarray(frequency, float)
    return (residues / (s[:, None] - lam[None, :])).sum(axis=1) + D[0, 0]


class FrequencyReplay:
    """The model's frequency response (magnitude dB, phase deg) for values of the ``free`` parameters; the
    same interface as :class:`cosim.diagnose.fitting.Replay`, so :func:`~cosim.diagnose.fitting.fit_samples`
    and the workflow's scoring serve both kinds.

    Parameters
    ----------
    model : cosim.compile.LoweredModel
    experiment : FrequencyExperiment
    outputs : list of str
        The measured output (one).
    free : list of str
    scale : ndarray, shape (len(free),)
    fixed : dict
        name -> value held at other than the model default.
    rtol : float
        Unused (no integration); accepted for the common interface.
    """

    def __init__(self, model, experiment, outputs, free, scale, fixed=None, rtol=None):
        check_parameters(model, [*free, *(fixed or {})])
        names = [p.name for p in model.parameters]
        self.free = list(free)
        self.scale = np.asarray(scale, float)
        self.experiment = experiment
        self._values = model.parameter_values.copy()
        for name, value in (fixed or {}).items():
            self._values[names.index(name)] = value
        self._where = [names.index(n) for n in self.free]
        self._abcd = model.linearization(experiment.input, outputs[0])
        self.evaluations = 0

    def evaluate(self, q):
        """Magnitude [dB] and phase [deg], shape (2, N), for scaled parameters ``q`` (value / scale); the phase
        is taken on the measured branch (the difference wrapped into (-180, 180] deg)."""
        values = self._values.copy()
        values[self._where] = np.asarray(q, float) * self.scale
        e = self.experiment
        H = response(self._abcd(values), e.frequency, e.sample_rate)
        self.evaluations += 1
        phase = np.degrees(np.angle(H))
        measured = e.measured[:, 1]
        phase = measured + (phase - measured + 180.0) % 360.0 - 180.0
        return np.vstack([20 * np.log10(np.abs(H)), phase])

    def outputs(self, values):
        """Magnitude [dB] and phase [deg], shape (2, N), for parameter ``values`` (dict or array in ``free``
        order)."""
        if isinstance(values, dict):
            values = [values[n] for n in self.free]
        return self.evaluate(np.asarray(values, float) / self.scale)
