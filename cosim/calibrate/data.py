"""Measured data for calibration and diagnosis: a CSV or Parquet table with ``time`` and named channels,
checked before anything is fitted (monotonic time, no NaN, the channels the job names)."""

from pathlib import Path

import numpy as np
import pandas as pd

from cosim.errors import ConfigError

__all__ = ["load_measurements", "check_measurements"]


def load_measurements(path, channels, field="data.path", sparse=(), abscissa="time", unit="s"):
    """Read ``path`` (``.csv`` or ``.parquet``) and check it holds ``time`` and every name in ``channels``.

    Parameters
    ----------
    path : str or Path
    channels : iterable of str
        Column names the job needs (model inputs and measured outputs).
    sparse : iterable of str
        Channels that may be empty (NaN) at some rows: outputs sampled slower than the rest.
    field : str
        The job key that named the file, for error messages.
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
    (channels in ``sparse`` may be NaN where they were not sampled, but must hold some values and no inf)."""
    missing = [c for c in [abscissa, *channels] if c not in frame.columns]
    if missing:
        raise ConfigError(
            f"{where}: missing column(s) {', '.join(missing)}; the file has {', '.join(map(str, frame.columns))}")
    frame = frame[[abscissa, *dict.fromkeys(channels)]].astype(float)
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
