"""``run``: config -> results in memory; ``run_config``: the whole ``cosim run`` job (load, run, write)."""

from pathlib import Path

from cosim.master.engine import engine_for
from cosim.master.output import write_results
from cosim.master.summary import summarize

__all__ = ["run", "run_config"]


def run(config, progress=None):
    """Run a validated config with the engine it asks for (``run.engine``; see :func:`engine_for`).

    Parameters
    ----------
    config : cosim.config.Config
    progress : bool or None
        tqdm bar on stderr (None: for long runs, as ``run.progress`` says).

    Returns
    -------
    cosim.master.engine.RunResult
    """
    return engine_for(config).run(progress=progress)


def run_config(path, out=None, overrides=(), csv=False, progress=None):
    """Load ``path`` with ``overrides``, run it and write results, summary and plot to ``out``.

    Nothing is written when the config is invalid or the FMUs cannot be loaded (the exception
    propagates); when the run is interrupted by Ctrl-C, what was recorded is written.

    Parameters
    ----------
    path : path-like
        The TOML config.
    out : path-like, optional
        Output folder (default ``out/<config stem>``).
    overrides : sequence of str
        ``key=value`` items, as ``--set``.
    csv : bool
        Also write ``results.csv``.
    progress : bool or None

    Returns
    -------
    (RunResult, dict, list of pathlib.Path)
        The result, the summary and the files written.
    """
    from cosim.config import load_config

    config = load_config(path, overrides)
    result = engine_for(config).run(progress=progress)
    summary = summarize(result, config)
    out = Path(out) if out is not None else Path("out") / config.name
    files = write_results(result, config, out, csv=csv, summary=summary)
    return result, summary, files
