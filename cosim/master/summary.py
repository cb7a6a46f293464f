"""summary.json: the facts of a run, plus the experiment keys of the summary its config names.

The experiment keys come from a summary plugin that a controller class provides (``Class.summaries``,
chosen by ``[summary] kind`` and ``controller``; see docs/config.md): this module knows no experiment.
"""

import math
import warnings

from cosim.errors import OutputWarning

__all__ = ["summarize"]


def summarize(result, config):
    """Return the summary dict of a run (run facts plus the experiment keys of ``config.summary``).

    Parameters
    ----------
    result : cosim.master.engine.RunResult
    config : cosim.config.Config

    Returns
    -------
    dict
        Run facts (config, overrides, times, rows, controller calls, solver, engine; ``parameters_files``: per
        FMU instance, the parameters file read, its SHA-256 and provenance; ``stopped`` with
        the instance, time and reason when an FMU asked to terminate), then the keys the
        summary plugin returns; non-finite floats become None. A plugin that raises is an
        :class:`~cosim.errors.OutputWarning` and its error is ``summary_error``: the run's rows still get written.
    """
    out = {
        "config": str(config.path),
        "overrides": list(config.overrides),
        "start_s": config.run.start,
        "stop_s": config.run.stop,
        "simulated_s": result.sim_s,
        "wall_s": result.wall_s,
        "wall_per_sim_s": result.wall_s / result.sim_s if result.sim_s > 0 else None,
        "interrupted": result.interrupted,
        "rows": int(len(result.data)),
        "controller_calls": dict(result.calls),
        "solver": {"method": config.solver.method, "substeps": config.solver.substeps},
        "engine": result.engine,
        "compile_s": result.compile_s,
    }
    files = {n: f.parameters_file.record() for n, f in config.fmus.items() if f.parameters_file is not None}
    if files:
        out["parameters_files"] = files
    if result.engine_note:
        out["engine_note"] = result.engine_note
    if result.events:
        out["events"] = len(result.events)
    if result.stopped is not None:
        out["stopped"] = dict(result.stopped)
    spec = config.summary
    if spec.plugin is None:
        return out
    values = result.controller_values.get(spec.controller, {})
    try:
        out.update(spec.plugin.summarize(result.data, values, dict(spec.columns)))
    except Exception as exc:  # a plugin (maybe the user's) failing on these rows: say so, keep the rows
        out["summary_error"] = f"{type(exc).__name__}: {exc}"
        warnings.warn(f"{config.name}: the {spec.kind!r} summary failed ({out['summary_error']}); summary.json has "
                      f"the run's facts only", OutputWarning, stacklevel=2)
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}
