"""Playback of a measured signal into a plant: the master replays an experiment with its recorded inputs.

A diagnosis or calibration compares a model with a measurement; re-running the model *through the master* with
the measured input (a current staircase as the test rig commanded it, a torque profile) checks the built FMU on
the same footing as any other run. ``Playback`` reads one column of a CSV or Parquet file with a ``time`` column
[s] and outputs it as ``y``, held from one sample to the next (zero-order hold, as a DAQ's output holds it;
before the first sample: the first value).

Example config::

    [controllers.replay]
    class = "cosim_controllers.playback:Playback"
    rate = 100                               # Hz: at least the data's sample rate
    parameters = { file = "data/static_paper.csv", column = "i_ref" }

    [[connections]]
    from = "replay.y"
    to = "plant.i_ref"
"""

import numpy as np

from cosim.controller import Controller
from cosim.experiment import load_measurements

__all__ = ["Playback"]


def _playback_kernel(t, u, y, x, p):
    """p = [n, t_0 .. t_{n-1}, v_0 .. v_{n-1}]; x[0] = index of the sample held (advances with t)."""
    n = int(p[0])
    k = int(x[0])
    while k + 1 < n and p[2 + k] <= t + 1e-9:
        k += 1
    x[0] = k
    y[0] = p[1 + n + k]


class Playback(Controller):
    """Outputs one recorded column (``file``, ``column``), zero-order held between its time stamps."""

    parameters = {"file": "", "column": ""}
    path_parameters = ("file",)
    outputs = ("y",)
    kernel = staticmethod(_playback_kernel)

    def pack(self):
        file, column = self.values["file"], self.values["column"]
        if not file or not column:
            raise ValueError(f"{type(self).__name__}: parameters 'file' and 'column' are required (the data file "
                             f"and the column to play)")
        frame = load_measurements(file, [column], field=f"{type(self).__name__}.file")
        return np.concatenate([[len(frame)], frame["time"].to_numpy(), frame[column].to_numpy()])

    def initial_state(self):
        return np.zeros(1)
