"""Calibration jobs: ``cosim calibrate job.toml`` reads a TOML job (model, data, free parameters, cost), fits
with multi-start, and writes ``calibration.json``, ``parameters.toml`` and before/after plots.

Job schema (paths relative to the job file)::

    [model]       source = "x.mo", name = "Pkg.Model", parameters = {name = value}   # fixed values
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
from cosim.tomldoc import bounded_parameters, number, read_toml, sections

__all__ = ["CalibrationJob", "load_job", "run_job"]

_SCHEMA = {
    "model": ("source", "name", "fmu", "parameters"),
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
    free: dict  # name -> (start, min, max)
    starts: int
    seed: int
    scheduler: str


def load_job(path, overrides=()):
    """Read and validate a calibration job; every problem is reported at once with file:line and key."""
    path = Path(path)
    data, problems = read_toml(path, overrides, what="job")
    tables = sections(data, problems, _SCHEMA)
    base = path.parent
    model_t, data_t, fit_t, ms_t = (tables[s] for s in ("model", "data", "fit", "multistart"))
    fmu = None
    if "fmu" in model_t:
        fmu = base / str(model_t["fmu"])
        if "source" in model_t or "name" in model_t:
            problems.add(("model", "fmu"), "give either fmu or source + name, not both")
        elif not fmu.is_file():
            problems.add(("model", "fmu"), f"no such FMU: {fmu} (build it with `cosim build`)")
    else:
        for key in ("source", "name"):
            if not isinstance(model_t.get(key), str):
                problems.add(("model", key), "is required (a string), or give fmu = \"x.fmu\"")
    source = base / model_t.get("source", "")
    if isinstance(model_t.get("source"), str) and not source.is_file():
        problems.add(("model", "source"), f"no such Modelica file: {source}")
    if not isinstance(data_t.get("path"), str):
        problems.add(("data", "path"), "is required: a CSV or Parquet file with `time` and the measured channels")
    inputs = data_t.get("inputs", {})
    if not isinstance(inputs, dict) or not all(isinstance(v, str) for v in inputs.values()):
        problems.add(("data", "inputs"), "must map model inputs to data columns, e.g. {i_ref = \"i_ref\"}")
        inputs = {}
    start = number(problems, data_t, "start", ("data",), default=-math.inf) if "start" in data_t else -math.inf
    stop = number(problems, data_t, "stop", ("data",), default=math.inf) if "stop" in data_t else math.inf
    decimate = number(problems, data_t, "decimate", ("data",), default=1, positive=True, integer=True)
    signals = []
    for k, s in enumerate(fit_t.get("signals", [])):
        where = ("fit", "signals", k)
        if not isinstance(s, dict) or not isinstance(s.get("output"), str):
            problems.add(where, "must be a table {output = \"F_g\", column = \"F_g\", noise = 0.5}")
            continue
        for key in sorted(set(s) - {"output", "column", "noise"}):
            problems.add(where + (key,), "unknown key; allowed: output, column, noise")
        noise = number(problems, s, "noise", where, default=1.0, positive=True)
        signals.append((s["output"], s.get("column", s["output"]), noise))
    if not signals:
        problems.add(("fit", "signals"), "name at least one output to fit: [{output = \"F_g\", noise = 0.5}]")
    segments = fit_t.get("segments", [[-math.inf, math.inf]])
    if not (isinstance(segments, list) and all(isinstance(s, list) and len(s) == 2 and s[0] < s[1]
                                               for s in segments)):
        problems.add(("fit", "segments"), "must be a list of [start, stop] time windows in s")
        segments = [[-math.inf, math.inf]]
    steady_s = number(problems, fit_t, "steady_s", ("fit",), positive=True) if "steady_s" in fit_t else 0.0
    method = fit_t.get("method", "rk4")
    if method not in METHODS:
        problems.add(("fit", "method"), f"must be one of {', '.join(METHODS)}; got {method!r}")
    substeps = number(problems, fit_t, "substeps", ("fit",), default=1, positive=True, integer=True)
    max_iter = number(problems, fit_t, "max_iter", ("fit",), default=200, positive=True, integer=True)
    free = bounded_parameters(data, problems)
    count = number(problems, ms_t, "count", ("multistart",), default=1, positive=True, integer=True)
    seed = number(problems, ms_t, "seed", ("multistart",), default=0, integer=True)
    scheduler = ms_t.get("scheduler", "")
    problems.raise_if_any()
    return CalibrationJob(
        path=path, source=source, model=model_t.get("name", str(fmu)), fmu=fmu, fixed=dict(model_t.get("parameters", {})),
        data_path=base / data_t["path"], inputs=dict(inputs), window=(start, stop), decimate=decimate,
        signals=tuple(signals), segments=tuple(tuple(s) for s in segments), steady_s=steady_s, method=method, substeps=substeps,
        max_iter=max_iter, free=free, starts=count, seed=seed, scheduler=scheduler)


def run_job(path, out="out/calibration", overrides=(), progress=True, force=False):
    """Run a calibration job and write its results to ``out``; returns the result dict of calibration.json.

    ``out`` must be new, empty, or a previous cosim output (replaced only with ``force``); it is checked before
    the fit, the results are written beside it and moved into place at the end
    (:func:`cosim.outputs.output_folder`)."""
    from cosim.calibrate.multistart import fit_multistart
    from cosim.calibrate.report import write_results
    from cosim.master.run import interrupt_on_signals
    from cosim.outputs import output_folder

    job = load_job(path, overrides)
    with output_folder(out, "calibrate", force=force) as staging, interrupt_on_signals():
        result = fit_multistart(job, progress=progress)
        summary = write_results(job, result, staging)
    return summary
