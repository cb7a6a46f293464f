"""``run``: config -> results in memory; ``run_config``: the whole ``cosim run`` job (load, run, write)."""

import contextlib
import signal
import threading
from pathlib import Path

from cosim.errors import RunStopped
from cosim.master.engine import Interrupt, engine_for
from cosim.master.output import write_results
from cosim.master.summary import summarize
from cosim.outputs import output_folder

__all__ = ["run", "run_config", "interrupt_on_signals"]


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


def run_config(path, out=None, overrides=(), csv=False, progress=None, force=False):
    """Load ``path`` with ``overrides``, run it and write results, summary and plot to ``out``.

    Nothing is written when the config is invalid, ``out`` cannot be used (see
    :func:`cosim.outputs.output_folder`) or the FMUs cannot be loaded (the exception propagates, before the run).
    When the run stops early (Ctrl-C, SIGTERM, an exception in the loop, a NaN), what was recorded is written and
    ``summary.json`` says why (``stopped``). Results go to a folder beside ``out``, moved into place at the end.

    Parameters
    ----------
    path : path-like
        The TOML config.
    out : path-like, optional
        Output folder (default ``out/<config stem>``): new, empty, or a previous cosim output (with ``force``).
    overrides : sequence of str
        ``key=value`` items, as ``--set``.
    csv : bool
        Also write ``results.csv``.
    progress : bool or None
    force : bool, default False
        Replace a previous cosim output at ``out``.

    Returns
    -------
    (RunResult, dict, list of pathlib.Path)
        The result, the summary and the files written.

    Raises
    ------
    cosim.errors.RunStopped
        The run stopped on a fault (an exception, a non-finite value); what was recorded was written first.
    """
    from cosim.config import load_config

    config = load_config(path, overrides)
    out = Path(out) if out is not None else Path("out") / config.name
    with output_folder(out, "run", force=force) as staging, interrupt_on_signals():
        result = engine_for(config).run(progress=progress, faults="keep")
        summary = summarize(result, config)
        files = [out / f.relative_to(staging) for f in write_results(result, config, staging, csv=csv,
                                                                       summary=summary)]
    if result.fault is not None:
        raise RunStopped(result.stopped, files) from result.fault
    return result, summary, files


@contextlib.contextmanager
def interrupt_on_signals():
    """Within the block, SIGTERM and SIGHUP raise :class:`~cosim.master.engine.Interrupt` (a KeyboardInterrupt)
    instead of killing the process: a run stops as on Ctrl-C and keeps what was recorded, and every command's
    ``finally`` clauses run (staging and unpacked FMU folders removed). Only in the main thread (signal handlers
    cannot be set elsewhere); elsewhere the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise Interrupt(signum)

    previous = {s: signal.signal(s, interrupt) for s in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
