"""Measured experiments, shared by calibration, diagnosis and playback: reading and checking a measured table, the
:class:`Experiment` a fit compares a model with, the steady part of each hold of a staircase, and the alignment
of a job's data with a model's inputs and outputs."""

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from cosim.errors import ConfigError

__all__ = ["Experiment", "load_measurements", "check_measurements", "constant_runs", "steady_mask",
           "align_experiment"]


@dataclass(frozen=True)
class Experiment:
    """What was measured, aligned for fitting.

    Attributes
    ----------
    time : ndarray, shape (N,)
        Sample instants in s, strictly increasing.
    inputs : ndarray, shape (N, n_inputs)
        Model inputs in the model's input order, held from each sample to the next.
    measured : ndarray, shape (N, n_signals)
        Measured values of the fitted outputs; NaN where a channel was not sampled (multi-rate data: a
        100 Hz load cell beside a current logged at the controller rate).
    weights : ndarray, shape (n_signals,)
        Residual weights (1/noise standard deviation gives a cost in units of noise variance).
    mask : ndarray of bool, shape (N,)
        Samples that enter the cost (the chosen segments).
    """

    time: np.ndarray
    inputs: np.ndarray
    measured: np.ndarray
    weights: np.ndarray
    mask: np.ndarray

    def residual_weights(self):
        """Weight of each (signal, sample): the signal's weight where it was measured, 0 where NaN or masked."""
        sampled = np.isfinite(self.measured.T) & self.mask[None, :]
        return self.weights[:, None] * sampled

    def measured_or_zero(self):
        """Measured values with the unsampled entries (NaN) set to 0; their weight is 0."""
        return np.nan_to_num(self.measured.T, nan=0.0)

    def fitted_entries(self):
        """Number of (signal, sample) pairs that enter the cost."""
        return int(np.count_nonzero(self.residual_weights()))


def load_measurements(path, channels, field="data.path", sparse=(), abscissa="time", unit="s"):
    """Read ``path`` (``.csv`` or ``.parquet``) and check it holds ``time`` and every name in ``channels``.

    Parameters
    ----------
    path : str or Path
    channels : iterable of str
        Column names the job needs (model inputs and measured outputs).
    field : str
        The job key that named the file, for error messages.
    sparse : iterable of str
        Channels that may be empty (NaN) at some rows: outputs sampled slower than the rest.
    abscissa, unit : str
        The strictly increasing column the samples are ordered by and its unit (``frequency``, ``Hz`` for a
        frequency response).

    Returns
    -------
    pandas.DataFrame
        Sorted by time, float columns.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{field}: no such data file: {path}")
    suffix = path.suffix.lower()
    try:
        if suffix == ".csv":
            frame = pd.read_csv(path, comment="#")
        elif suffix in (".parquet", ".pq"):
            frame = pd.read_parquet(path)
        else:
            raise ConfigError(f"{field}: {path} is neither .csv nor .parquet")
    except (ValueError, OSError) as err:
        raise ConfigError(f"{field}: cannot read {path}: {err}") from err
    return check_measurements(frame, channels, f"{field} ({path.name})", sparse, abscissa, unit)


def check_measurements(frame, channels, where="data", sparse=(), abscissa="time", unit="s"):
    """Check a measured table: ``time`` (or ``abscissa``) strictly increasing, named channels present and finite
    (channels in ``sparse`` may be NaN where they were not sampled, but must hold some values and no inf).

    Parameters
    ----------
    frame : pandas.DataFrame
    channels : iterable of str
        Columns that must be present.
    where : str
        The file or key named in error messages.
    sparse : iterable of str
        Channels that may be NaN at some rows.
    abscissa, unit : str
        The strictly increasing column and its unit.

    Returns
    -------
    pandas.DataFrame
        The abscissa and ``channels`` as float columns, index reset.
    """
    missing = [c for c in [abscissa, *channels] if c not in frame.columns]
    if missing:
        raise ConfigError(
            f"{where}: missing column(s) {', '.join(missing)}; the file has {', '.join(map(str, frame.columns))}")
    frame = frame[[abscissa, *dict.fromkeys(channels)]]
    for column in frame.columns:
        numbers = pd.to_numeric(frame[column], errors="coerce")
        text = np.flatnonzero(numbers.isna().to_numpy() & frame[column].notna().to_numpy())
        if text.size:
            raise ConfigError(f"{where}: column {column!r} must hold numbers; got {frame[column].iloc[text[0]]!r} "
                              f"at data row {text[0]} (row 0: the first under the header)")
    frame = frame.astype(float)
    for column in frame.columns:
        values = frame[column].to_numpy()
        if column in sparse:
            if np.isinf(values).any() or np.isnan(values).all():
                raise ConfigError(f"{where}: column {column!r} has inf values or no value at all")
            continue
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ConfigError(f"{where}: column {column!r} has {bad.size} NaN/inf value(s), first at row {bad[0]}")
    steps = np.diff(frame[abscissa].to_numpy())
    if (steps <= 0).any():
        row = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise ConfigError(f"{where}: {abscissa} is not strictly increasing at row {row} ({abscissa[0]} = "
                          f"{frame[abscissa].iloc[row]:g} {unit} after {frame[abscissa].iloc[row - 1]:g} {unit})")
    return frame.reset_index(drop=True)


def constant_runs(inputs):
    """(start, end) sample indices (end exclusive) of the runs of constant input.

    Parameters
    ----------
    inputs : ndarray, shape (N, n_inputs)

    Returns
    -------
    list of (int, int)
    """
    changes = np.flatnonzero(np.any(np.diff(inputs, axis=0) != 0, axis=1)) + 1
    starts = np.concatenate([[0], changes])
    ends = np.concatenate([changes, [len(inputs)]])
    return list(zip(starts, ends))


def steady_mask(time, inputs, seconds, min_hold_s=None):
    """Samples in the last ``seconds`` of each hold: the settled part of a staircase.

    Parameters
    ----------
    time : ndarray, shape (N,)
    inputs : ndarray, shape (N, n_inputs)
    seconds : float
        Length of the steady part at the end of each hold, s.
    min_hold_s : float, optional
        Shortest run of constant input that counts as a hold (default ``seconds``); 0 keeps every run (the
        calibration's ``fit.steady_s``).

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    min_hold_s = seconds if min_hold_s is None else min_hold_s
    mask = np.zeros(len(time), bool)
    for a, b in constant_runs(inputs):
        if time[b - 1] - time[a] + 1e-9 >= min_hold_s * 0.999:
            mask[a:b] = time[a:b] >= time[b - 1] - seconds + 1e-9
    return mask


def align_experiment(job, inputs, outputs, path=None, *, signals_key="fit.signals", min_samples=3, uniform=False,
                     duration=None, from_zero=False, segments=((-math.inf, math.inf),), steady_s=0.0):
    """A job's data aligned with a model: the :class:`Experiment` a calibration or a diagnosis fits.

    The job (a calibration or a diagnosis job) gives the data file, its ``window`` and ``decimate``, the column
    of each model input (``inputs``) and the compared ``signals`` (output, column, noise). The keywords say what
    differs between the two: calibration keeps the defaults and passes its ``segments`` and ``steady_s``;
    diagnosis asks for 10 samples, a uniform time base, data covering the experiment's ``duration`` and time
    from 0.

    Parameters
    ----------
    job : cosim.calibrate.job.CalibrationJob or cosim.diagnose.job.DiagnoseJob
        Read: ``path``, ``model``, ``data_path``, ``inputs``, ``signals``, ``window``, ``decimate``.
    inputs, outputs : list of str
        The model's inputs and outputs, in model order.
    path : path-like, optional
        The data file (default ``job.data_path``).
    signals_key : str, default "fit.signals"
        The job key of the compared signals, for error messages.
    min_samples : int, default 3
        Fewest samples the data window may hold.
    uniform : bool, default False
        Require one sample interval (within 25 %): channels on different clocks are an error.
    duration : float, optional
        Time the data must cover, s (less 1.5 sample intervals).
    from_zero : bool, default False
        Shift the time base to start at 0.
    segments : sequence of (float, float), default everything
        Time windows (s, on the returned time base) whose samples enter the cost.
    steady_s : float, default 0
        When > 0, only the last ``steady_s`` of each run of constant inputs enter the cost.

    Returns
    -------
    Experiment
        Inputs in model order, measured columns in the order of ``job.signals``, weights 1/noise.
    """
    path = job.data_path if path is None else path
    missing = [u for u in inputs if u not in job.inputs]
    if missing:
        raise ConfigError(f"{job.path}: data.inputs must give a column for every input of {job.model}; missing "
                          f"{', '.join(missing)}")
    for output, _, _ in job.signals:
        if output not in outputs:
            raise ConfigError(f"{job.path}: {signals_key}: {job.model} has no output {output!r}; it has "
                              f"{', '.join(outputs)}")
    measured = [c for _, c, _ in job.signals]  # may be NaN where not sampled (a 100 Hz load cell, a 1 kHz log)
    frame = load_measurements(path, [*job.inputs.values(), *measured], sparse=measured)
    t0, t1 = job.window
    frame = frame[(frame["time"] >= t0) & (frame["time"] <= t1)].iloc[::job.decimate].reset_index(drop=True)
    if len(frame) < min_samples:
        raise ConfigError(f"{path}: the data window [{t0}, {t1}] s holds {len(frame)} samples; need >= "
                          f"{min_samples}")
    time = frame["time"].to_numpy()
    _check_time_base(path, time, uniform, duration)
    if from_zero:
        time = time - time[0]
    values = frame[[job.inputs[u] for u in inputs]].to_numpy()
    mask = np.zeros(len(time), bool)
    for a, b in segments:
        mask |= (time >= a) & (time <= b)
    if steady_s:
        mask &= steady_mask(time, values, steady_s, min_hold_s=0.0)
    return Experiment(time=time, inputs=values, measured=frame[measured].to_numpy(),
                      weights=np.array([1.0 / noise for _, _, noise in job.signals]), mask=mask)


def _check_time_base(path, time, uniform, duration):
    """A ConfigError when ``uniform`` and the sample interval varies, or when the data cover less than
    ``duration``."""
    dt = np.diff(time)
    if uniform and np.max(np.abs(dt - np.median(dt))) > 0.25 * np.median(dt):
        k = int(np.argmax(np.abs(dt - np.median(dt))))
        raise ConfigError(f"{path}: the time base is not uniform (sample interval {np.median(dt):g} s, "
                          f"but {dt[k]:g} s between t = {time[k]:g} and {time[k + 1]:g} s): channels sampled on "
                          f"different clocks must be resampled onto one time base first")
    if duration is not None and time[-1] - time[0] < duration - 1.5 * np.median(dt):
        raise ConfigError(f"{path}: the data cover {time[-1] - time[0]:g} s but the experiment "
                          f"(experiment.duration) lasts {duration:g} s")
