"""``cosim campaign``: the gripper paper's experimental campaign (Table 1, Fig. 12) as a grid of co-simulated
impact trials with physical trial-to-trial variability, run in batches on Dask, resumable.

Modules: ``job`` (the TOML job), ``draws`` (trials, seeds, drawn values), ``trial`` (one trial through the
master's engine), ``execute`` (batches on Dask, parts on disk, resume), ``report`` (tables, plot, summary).
"""

from pathlib import Path

from cosim.campaign.draws import trial_list
from cosim.campaign.execute import command_line, read_parts, run_trials
from cosim.campaign.job import load_campaign
from cosim.campaign.report import table1, write_report
from cosim.campaign.trial import TrialRunner, run_command
from cosim.errors import ConfigError

__all__ = ["run_campaign", "run_one_trial", "load_campaign", "table1"]


def run_campaign(path, out=None, overrides=(), workers=None, scheduler="", progress=True):
    """Run (or resume) a campaign job and write its files.

    Parameters
    ----------
    path : path-like
        The campaign job (.toml).
    out : path-like, optional
        Output folder (default ``out/<job stem>``); a folder holding the same job is resumed.
    overrides : sequence of str
        ``key=value`` items, as ``--set`` (e.g. ``campaign.trials=5``).
    workers : int, optional
        Workers of the local Dask cluster (default: one a core).
    scheduler : str, default ""
        Address of a running Dask scheduler to use instead of a local cluster.
    progress : bool, default True
        Progress bar with ETA on stderr.

    Returns
    -------
    dict
        The summary (summary.json); ``summary["run"]["interrupted"]`` is True after Ctrl-C (the finished
        trials are kept in ``out/parts``; the same command resumes).

    Raises
    ------
    cosim.errors.ConfigError
        Invalid job; ``out`` not a cosim output or holding another job (the changed keys are named);
        the scheduler does not answer.
    """
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ConfigError(f"--workers: expected a whole number >= 1; got {workers!r}")
    job = load_campaign(path, overrides)
    out = Path(out) if out is not None else Path("out") / Path(path).stem
    info = run_trials(job, out, workers=workers, scheduler=scheduler, progress=progress,
                      command=command_line(path, overrides))
    if info["interrupted"]:
        return {"run": info}
    return write_report(read_parts(out), job, out, info)


def run_one_trial(path, index, overrides=()):
    """Run trial ``index`` (its row in trials.parquet) of a campaign alone, in this process.

    Parameters
    ----------
    path : path-like
    index : int
    overrides : sequence of str

    Returns
    -------
    row : dict
        The trial's row of trials.parquet.
    command : str
        The ``cosim run`` command that runs the same co-simulation.
    """
    job = load_campaign(path, overrides)
    specs = trial_list(job)
    if not 0 <= index < len(specs):
        raise ConfigError(f"--trial {index}: the campaign has trials 0 to {len(specs) - 1}")
    spec = specs[index]
    coating = next(c for c in job.coatings if c.name == spec.coating)
    runner = TrialRunner(job, coating)
    try:
        row = runner.run(spec)
    finally:
        runner.close()
    return row, run_command(job, spec, runner.stop_s)
