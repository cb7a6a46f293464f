"""Re-run of the built FMUs through the master with the measured inputs.

The diagnosis fits and scores on the lowered Modelica equations (CVODES); the baseline's and the winner's FMUs are
then re-run as any ``cosim run`` would run them (the FMU's generated C code, the master's implicit solver, the
measured inputs played by :class:`cosim_controllers.playback.Playback`), so the reported gap before and after is that of
the FMUs a user gets. Each run's config is built in code (:func:`rerun_data`, :func:`cosim.config.config_from_data`)
and written to ``OUT/rerun/`` (``baseline.toml``, ``<effect>.toml``, with the played inputs ``inputs.csv`` and
paths relative to the folder): ``cosim run`` on them repeats the check.
"""

import numbers
import os
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["rerun_data", "rerun"]

_COMMENT = "Re-run of a diagnosis model with the measured inputs (written by cosim diagnose; cosim run repeats it)"


def rerun_data(fmu, parameters, inputs_csv, input_names, outputs, rate, stop, rtol):
    """The tables of a run config: ``fmu`` (as ``plant``) with ``parameters``, each input played from
    ``inputs_csv`` at ``rate`` [Hz], ``outputs`` recorded at ``rate``, to ``stop`` [s], BDF with ``rtol`` (the
    stiff contact needs an implicit solver, so the Python engine).

    Parameters
    ----------
    fmu, inputs_csv : str
        Paths, relative to the config's folder or absolute.
    parameters : dict
        FMU parameter -> value.
    input_names, outputs : list of str
        The FMU's inputs played and outputs recorded.
    rate, stop, rtol : float

    Returns
    -------
    dict
        For :func:`cosim.config.config_from_data` (and :func:`cosim.tomldoc.toml_text`).
    """
    return {
        "run": {"start": 0.0, "stop": float(stop), "engine": "python"},
        "solver": {"method": "bdf", "rtol": float(rtol), "atol": float(rtol) * 1e-3},
        "fmus": {"plant": {"path": Path(fmu).as_posix(), "parameters": {
            k: float(v) if isinstance(v, numbers.Real) and not isinstance(v, bool) else v
            for k, v in parameters.items()}}},
        "controllers": {f"play_{name}": {"class": "cosim_controllers.playback:Playback", "rate": float(rate),
                                         "parameters": {"file": Path(inputs_csv).as_posix(), "column": name}}
                        for name in input_names},
        "connections": [{"from": f"play_{name}.y", "to": f"plant.{name}"} for name in input_names],
        "record": {"rate": float(rate), "signals": [f"plant.{o}" for o in outputs]},
    }


def rerun(runs, experiment, input_names, outputs, folder, rtol):
    """Run each FMU of ``runs`` (label -> (FMU path, parameters)) through the master along ``experiment`` (a
    :class:`cosim.experiment.Experiment`: its time base and inputs); returns label -> the recorded ``outputs`` at
    the experiment's instants, shape (len(outputs), N).

    Writes ``folder/inputs.csv`` and ``folder/<label>.toml`` for each run."""
    from cosim.config import config_from_data
    from cosim.master import run
    from cosim.tomldoc import toml_text

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    inputs_csv = folder / "inputs.csv"
    frame = pd.DataFrame(experiment.inputs, columns=list(input_names))
    frame.insert(0, "time", experiment.time)
    frame.to_csv(inputs_csv, index=False)
    rate = 1.0 / float(np.median(np.diff(experiment.time)))
    predicted = {}
    for label, (fmu, parameters) in runs.items():
        path = folder / f"{label}.toml"
        data = rerun_data(os.path.relpath(fmu, folder), parameters, inputs_csv.name, input_names, outputs, rate,
                          float(experiment.time[-1]), rtol)
        path.write_text(toml_text(data, _COMMENT), encoding="utf-8")
        result = run(config_from_data(data, path), progress=False)
        column = {key: name for name, key in result.signals.items()}
        t = result.column("time")
        predicted[label] = np.array([np.interp(experiment.time, t, result.column(column[("plant", o)]))
                                     for o in outputs])
    return predicted
