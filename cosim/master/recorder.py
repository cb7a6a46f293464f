"""The recorder: the columns a run records and the rows the per-instant loop writes into them.

Both loops feed it at the recorder's instants: the Python loop calls :meth:`Recorder.record`; the
compiled loop's kernel writes the same arrays (``times``, ``values``, the row count ``rows``) in
place. After the run :meth:`Recorder.data` is what was recorded, also when the run was interrupted.
"""

import numpy as np

from cosim.config import record_columns
from cosim.fmi import value_dtype

__all__ = ["Recorder"]


class Recorder:
    """Recorded columns of a config (names, units, signal buffer slots) and the rows of one run.

    A variable recorded from one FMU only is named by itself (``F_g``); otherwise
    ``instance.variable``; a controller signal always ``instance.variable``.

    Parameters
    ----------
    config : cosim.config.Config
    layout : cosim.master.layout.Layout
        Where each recorded value lives in ``buf``.
    buf : numpy.ndarray
        The master's signal buffer.

    Attributes
    ----------
    signals : dict of str to tuple
        Column name -> (instance, variable).
    units : dict of str to str
        Unit of each column, ``time`` first.
    dtypes : dict of str to numpy.dtype
        The dtype of each column: the FMU variable's own (``cosim.fmi.value_dtype``: Integer columns
        integer, Boolean bool, Float32 float32), float64 for controller signals.
    index : numpy.ndarray of int64
        The buffer slot of each column.
    times, values, rows : numpy.ndarray
        Time (s) and values of each row; ``rows[0]`` rows written (set by :meth:`start`).
    """

    def __init__(self, config, layout, buf):
        self.signals = record_columns(config.record.signals, config.fmus)
        self.units = {"time": "s"}
        self.dtypes = {"time": np.dtype(np.float64)}
        for name, (inst, var) in self.signals.items():
            if inst in config.fmus:
                info = config.fmus[inst].info
                unit = info.variables[var].unit
                dtype = value_dtype(info.fmi_version, info.variables[var].type)
            else:
                unit = config.controllers[inst].cls.units.get(var, "")
                dtype = np.dtype(np.float64)
            self.units[name] = unit
            self.dtypes[name] = dtype
        self.index = np.array([layout.index[s] for s in self.signals.values()], dtype=np.int64)
        self.buf = buf
        self.times = self.values = self.rows = None

    def start(self, n_rows):
        """Empty rows for a run that records at most ``n_rows`` instants."""
        self.times = np.zeros(n_rows)
        self.values = np.full((n_rows, len(self.index)), np.nan)
        self.rows = np.zeros(1, dtype=np.int64)

    def record(self, t):
        """Append the row of instant ``t`` (s): the recorded slots of the signal buffer."""
        row = self.rows[0]
        self.times[row] = t
        self.values[row] = self.buf[self.index]
        self.rows[0] = row + 1

    def data(self):
        """What was recorded: a structured array, field ``time`` first, then one field per column in its dtype
        (the buffer holds Integer and Boolean values exactly as floats; Booleans as 0/1)."""
        row = int(self.rows[0])
        data = np.zeros(row, dtype=[(name, self.dtypes[name]) for name in ("time", *self.signals)])
        data["time"] = self.times[:row]
        for j, name in enumerate(self.signals):
            column = self.values[:row, j]
            data[name] = column != 0 if self.dtypes[name] == np.bool_ else column
        return data
