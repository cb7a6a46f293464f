"""Re-run of the built FMUs through the master with the measured inputs.

The diagnosis fits and scores on the lowered Modelica equations (CVODES); the baseline's and the winner's FMUs are
then re-run as any ``cosim run`` would run them (the FMU's generated C code, the master's implicit solver, the
measured inputs played by :class:`controllers.playback.Playback`), so the reported gap before and after is that of
the FMUs a user gets. The run configs go to ``OUT/rerun/`` (``baseline.toml``, ``<effect>.toml``, with the played
inputs ``inputs.csv`` and paths relative to the folder): ``cosim run`` on them repeats the check.
"""

import os
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["rerun_config_text", "rerun"]


def _toml_value(v):
    return repr(float(v)) if isinstance(v, (int, float, np.floating)) else f'"{v}"'


def rerun_config_text(fmu, parameters, inputs_csv, input_names, outputs, rate, stop, rtol):
    """A run config: ``fmu`` (as ``plant``) with ``parameters``, each input played from ``inputs_csv`` at ``rate``
    [Hz], ``outputs`` recorded at ``rate``, BDF with ``rtol``."""
    params = ", ".join(f"{k} = {_toml_value(v)}" for k, v in parameters.items())
    lines = [
        "# Re-run of a diagnosis model with the measured inputs (written by cosim diagnose; cosim run repeats it)",
        "[run]", "start = 0.0", f"stop = {stop!r}", 'engine = "python"   # BDF: the stiff contact needs an implicit '
        'solver', "", "[solver]", 'method = "bdf"', f"rtol = {rtol!r}", f"atol = {rtol * 1e-3!r}", "",
        "[fmus.plant]", f'path = "{Path(fmu).as_posix()}"', f"parameters = {{ {params} }}", ""]
    for name in input_names:
        lines += [f"[controllers.play_{name}]", 'class = "controllers.playback:Playback"', f"rate = {rate!r}",
                  f'parameters = {{ file = "{Path(inputs_csv).as_posix()}", column = "{name}" }}', "",
                  "[[connections]]", f'from = "play_{name}.y"', f'to = "plant.{name}"', ""]
    lines += ["[record]", f"rate = {rate!r}", "signals = [" + ", ".join(f'"plant.{o}"' for o in outputs) + "]", ""]
    return "\n".join(lines)


def rerun(runs, experiment, input_names, outputs, folder, rtol):
    """Run each FMU of ``runs`` (label -> (FMU path, parameters)) through the master along ``experiment`` (a
    :class:`cosim.experiment.Experiment`: its time base and inputs); returns label -> the recorded ``outputs`` at
    the experiment's instants, shape (len(outputs), N).

    Writes ``folder/inputs.csv`` and ``folder/<label>.toml`` for each run."""
    from cosim.config import load_config
    from cosim.master import run

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
        path.write_text(rerun_config_text(os.path.relpath(fmu, folder), parameters, inputs_csv.name, input_names,
                                          outputs, rate, float(experiment.time[-1]), rtol), encoding="utf-8")
        result = run(load_config(path), progress=False)
        column = {key: name for name, key in result.signals.items()}
        t = result.column("time")
        predicted[label] = np.array([np.interp(experiment.time, t, result.column(column[("plant", o)]))
                                     for o in outputs])
    return predicted
