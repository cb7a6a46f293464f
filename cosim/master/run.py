"""``run``: config -> results in memory; ``run_config``: the whole ``cosim run`` job (load, run, write);
``write_run``: run and write a config already loaded."""

import contextlib
import signal
import sys
from pathlib import Path

from cosim.errors import RunStopped
from cosim.master.engine import Interrupt, engine_for
from cosim.master.output import write_results
from cosim.master.summary import summarize
from cosim.outputs import output_folder
from cosim.signals import handlers

__all__ = ["run", "run_config", "write_run", "interrupt_on_signals", "SignalsHeld"]


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
    """Load ``path`` with ``overrides``, run it and write results, summary and plot to ``out``: the whole
    ``cosim run`` job (:func:`write_run` after :func:`cosim.config.load_config`).

    Parameters
    ----------
    path : path-like
        The TOML config.
    out : path-like, optional
        Output folder (default ``out/<config stem>``).
    overrides : sequence of str
        ``key=value`` items, as ``--set``.
    csv, progress, force
        As :func:`write_run`'s.

    Returns
    -------
    (RunResult, dict, list of pathlib.Path)
        As :func:`write_run`, which raises what it raises.
    """
    from cosim.config import load_config
    from cosim.ssp.read import unpacked_archives

    with unpacked_archives():  # an SSP read here is unpacked for this run only
        config = load_config(path, overrides)
        return write_run(config, out if out is not None else Path("out") / config.name, csv=csv, progress=progress,
                         force=force)


def write_run(config, out, csv=False, progress=None, force=False):
    """Run a validated config and write results, summary and plot to ``out``.

    Nothing is written when ``out`` cannot be used (see :func:`cosim.outputs.output_folder`) or the FMUs cannot
    be loaded (the exception propagates, before the run).
    When the run stops early (Ctrl-C, SIGTERM, an exception in the loop, a NaN), what was recorded is written and
    ``summary.json`` says why (``stopped``). Results go to a folder beside ``out``, moved into place at the end;
    a Ctrl-C (or SIGTERM) while they are written waits for the files and the move (:class:`SignalsHeld`), and a
    plot that cannot be drawn is a warning.

    Parameters
    ----------
    config : cosim.config.Config
    out : path-like
        Output folder: new, empty, or a previous cosim output (with ``force``).
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
        The run stopped on a fault; what was recorded was written first.
    cosim.master.engine.Interrupt
        A signal came while the results were written: they were written in full first.
    """
    out = Path(out)
    held = SignalsHeld(out)
    with interrupt_on_signals(), held, output_folder(out, "run", force=force) as staging:
        result = engine_for(config).run(progress=progress, faults="keep", loop_end=held.start)
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
    def interrupt(signum, frame):
        raise Interrupt(signum)

    with handlers((signal.SIGTERM, signal.SIGHUP), interrupt):
        yield


class SignalsHeld:
    """Ctrl-C, SIGTERM and SIGHUP held from :meth:`start` to the end of the block, then raised as an
    :class:`~cosim.master.engine.Interrupt`: the files being written and their move into place are finished
    first (cut short, the staging folder would be removed, and the run's rows with it).

    Parameters
    ----------
    out : path-like
        Where the results go (named in the messages).
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

    def __init__(self, out):
        self.out = out
        self.signum = None
        self._held = contextlib.ExitStack()

    def __enter__(self):
        return self

    def start(self):
        """Hold the signals from now on (only in the main thread, where handlers can be set)."""
        self._held.enter_context(handlers(self.SIGNALS, self._note))

    def _note(self, signum, frame):
        if self.signum is None:
            self.signum = signum
            print(f"cosim: {signal.Signals(signum).name}: finishing writing the results into {self.out} first",
                  file=sys.stderr)

    def __exit__(self, exc_type, exc, tb):
        self._held.close()
        if self.signum is not None and exc_type is None:
            print(f"cosim: the results are written in {self.out}", file=sys.stderr)
            raise Interrupt(self.signum)
        return False
