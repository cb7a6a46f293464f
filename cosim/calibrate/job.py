"""Calibration jobs: ``cosim calibrate job.toml`` reads a TOML job (model, data, free parameters, cost), fits
with multi-start, and writes ``calibration.json``, ``parameters.toml`` and before/after plots.

Job schema (paths relative to the job file)::

    [model]       source = "x.mo", name = "Pkg.Model", parameters = {name = value}   # fixed values
                  parameters_file = "upstream/parameters.toml"   # fixed values of another calibration
                  (or fmu = "x.fmu" for a model with no Modelica source: finite differences through the FMU)
    [data]        path = "x.csv|x.parquet", inputs = {model_input = "column"}, start, stop, decimate
    [fit]         signals = [{output = "F_g", column = "F_g", noise = 0.5}], segments = [[t0, t1]],
                  steady_s (only the last steady_s seconds of each constant-input run enter the cost),
                  method = "rk4"|"implicit_euler"|"single_shooting", substeps, max_iter
    [parameters.NAME]  start, min, max
    [multistart]  count, seed, scheduler   # scheduler: a Dask address; empty = a local cluster
"""

import math
from dataclasses import dataclass
from pathlib import Path

from cosim.calibrate.problem import METHODS
from cosim.paramfile import parameters_file_key
from cosim.tomldoc import bounded_parameters, number, read_toml, sections, signal_tables, string, values

__all__ = ["CalibrationJob", "load_job", "run_job"]

_SCHEMA = {
    "model": ("source", "name", "fmu", "parameters", "parameters_file"),
    "data": ("path", "inputs", "start", "stop", "decimate"),
    "fit": ("signals", "segments", "steady_s", "method", "substeps", "max_iter"),
    "multistart": ("count", "seed", "scheduler"),
}


@dataclass(frozen=True)
class CalibrationJob:
    """A validated calibration job (see the module docstring for the TOML form)."""

    path: Path
    source: Path
    model: str
    fmu: Path
    fixed: dict
    data_path: Path
    inputs: dict
    window: tuple
    decimate: int
    signals: tuple  # of (output, column, noise)
    segments: tuple
    steady_s: float
    method: str
    substeps: int
    max_iter: int
    free: dict  # name -> FreeParameter
    starts: int
    seed: int
    scheduler: str
    upstream: tuple = ()  # of cosim.paramfile.ParametersFile: the parameters file [model] read


def load_job(path, overrides=()):
    """Read and validate a calibration job; every problem is reported at once with file:line and key.

    Parameters
    ----------
    path : str or Path
        The TOML job.
    overrides : sequence of str, optional
        ``--set key=value`` overrides, applied before validation.

    Returns
    -------
    CalibrationJob

    Raises
    ------
    ConfigError
        Every problem of the job, each with file:line (or ``--set key``) and key.
    """
    path = Path(path)
    data, problems = read_toml(path, overrides, what="job")
    tables = sections(data, problems, _SCHEMA)
    base = path.parent
    model_t, data_t, fit_t, ms_t = (tables[s] for s in ("model", "data", "fit", "multistart"))
    source, name, fmu = _model(model_t, base, problems)
    data_path = string(problems, data_t, "path", ("data",))
    inputs = data_t.get("inputs", {})
    if not isinstance(inputs, dict) or not all(isinstance(v, str) for v in inputs.values()):
        problems.add(("data", "inputs"), "must map model inputs to data columns, e.g. {i_ref = \"i_ref\"}")
        inputs = {}
    start = number(problems, data_t, "start", ("data",), default=-math.inf) if "start" in data_t else -math.inf
    stop = number(problems, data_t, "stop", ("data",), default=math.inf) if "stop" in data_t else math.inf
    decimate = number(problems, data_t, "decimate", ("data",), default=1, positive=True, integer=True)
    signals = signal_tables(problems, fit_t, "signals", ("fit",), default_noise=1.0)
    segments = _segments(fit_t, problems)
    steady_s = number(problems, fit_t, "steady_s", ("fit",), positive=True) if "steady_s" in fit_t else 0.0
    method = fit_t.get("method", "rk4")
    if not isinstance(method, str) or method not in METHODS:
        problems.add(("fit", "method"), f"must be one of {', '.join(METHODS)}; got {method!r}")
    substeps = number(problems, fit_t, "substeps", ("fit",), default=1, positive=True, integer=True)
    max_iter = number(problems, fit_t, "max_iter", ("fit",), default=200, positive=True, integer=True)
    free = bounded_parameters(data, problems)
    count = number(problems, ms_t, "count", ("multistart",), default=1, positive=True, integer=True)
    seed = number(problems, ms_t, "seed", ("multistart",), default=0, integer=True)
    scheduler = string(problems, ms_t, "scheduler", ("multistart",), default="")
    upstream = parameters_file_key(model_t, ("model",), base, problems)
    upstream = () if upstream is None else (upstream,)
    # a calibration this one builds on: its values are fixed here (the job's own parameters override them; a
    # parameter the job frees keeps its start)
    fixed = {**{n: v for u in upstream for n, v in u.values.items() if n not in free},
             **values(problems, model_t, "parameters", ("model",))}
    problems.raise_if_any()
    return CalibrationJob(
        path=path, source=source, model=name, fmu=fmu, fixed=fixed, data_path=base / data_path, inputs=dict(inputs),
        window=(start, stop), decimate=decimate, signals=tuple(signals), segments=segments, steady_s=steady_s,
        method=method, substeps=substeps, max_iter=max_iter, free=free, starts=count, seed=seed, scheduler=scheduler,
        upstream=upstream)


def _model(model_t, base, problems):
    """``[model]``: (Modelica source, model name, None) or (None, the FMU's path as the name, FMU path)."""
    if "fmu" in model_t:
        fmu = string(problems, model_t, "fmu", ("model",))
        if "source" in model_t or "name" in model_t:
            problems.add(("model", "fmu"), "give either fmu or source + name, not both")
        elif fmu is not None and not (base / fmu).is_file():
            problems.add(("model", "fmu"), f"no such FMU: {base / fmu} (build it with `cosim build`)")
        return base, str(base / (fmu or "")), base / (fmu or "")
    source = string(problems, model_t, "source", ("model",))
    name = string(problems, model_t, "name", ("model",))
    if source is not None and not (base / source).is_file():
        problems.add(("model", "source"), f"no such Modelica file: {base / source}")
    return base / (source or ""), name, None


def _segments(fit_t, problems):
    """``fit.segments``: a list of ``[start, stop]`` time windows (s), start < stop; default the whole record."""
    segments = fit_t.get("segments", [[-math.inf, math.inf]])
    if not (isinstance(segments, list) and segments
            and all(isinstance(s, list) and len(s) == 2 and all(_is_time(t) for t in s) and s[0] < s[1]
                    for s in segments)):
        problems.add(("fit", "segments"), f"must be a list of [start, stop] time windows in s, start < stop; "
                                          f"got {segments!r}")
        return ((-math.inf, math.inf),)
    return tuple((float(a), float(b)) for a, b in segments)


def _is_time(t):
    return isinstance(t, (int, float)) and not isinstance(t, bool) and not math.isnan(t)


def run_job(path, out=None, overrides=(), progress=True, force=False):
    """Run a calibration job: :func:`cosim.calibrate.calibrate` (the parameters are described there).

    ``out`` must be new, empty, or a previous cosim output (replaced only with ``force``); it is checked before
    the fit, the results are written beside it and moved into place at the end
    (:func:`cosim.outputs.output_folder`). Without ``out`` nothing is written."""
    from dataclasses import replace

    from cosim.calibrate.multistart import fit_multistart
    from cosim.calibrate.report import write_results
    from cosim.calibrate.result import calibration_result
    from cosim.master.run import SignalsHeld, interrupt_on_signals
    from cosim.outputs import output_folder

    job = load_job(path, overrides)
    if out is None:
        return calibration_result(job, *fit_multistart(job, progress=progress))
    held = SignalsHeld(out)  # a Ctrl-C while the fit is written waits for the files
    with interrupt_on_signals(), held, output_folder(out, "calibrate", force=force) as staging:
        best, runs = fit_multistart(job, progress=progress)
        held.start()
        result = calibration_result(job, best, runs)
        write_results(result, job, best, staging)
    return replace(result, out=Path(out))
