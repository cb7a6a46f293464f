"""``cosim campaign``: the gripper paper's experimental campaign (Table 1, Fig. 12) as a grid of co-simulated
impact trials with physical trial-to-trial variability, run in batches on Dask, resumable.

Modules: ``job`` (the TOML job), ``draws`` (trials, seeds, drawn values), ``trial`` (one trial through the
master's engine), ``execute`` (batches on Dask, parts on disk, resume), ``report`` (tables, plot, summary).
"""

import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from cosim.callable_package import make_callable
from cosim.campaign.draws import trial_list
from cosim.campaign.execute import command_line, read_parts, run_trials
from cosim.campaign.job import load_campaign
from cosim.campaign.report import campaign_result, table1, write_report
from cosim.campaign.trial import TrialRunner, run_command
from cosim.config import override_items
from cosim.errors import ConfigError

__all__ = ["campaign", "run_campaign", "run_one_trial", "load_campaign", "table1"]

make_callable(sys.modules[__name__])  # cosim.campaign(job, ...) is campaign below


def campaign(job, *, set=None, out=None, workers=None, scheduler="", progress=False):
    """Run every trial of a campaign job on Dask, as ``cosim campaign`` does; nothing is written unless ``out``
    is given (the trials' parts then go to a temporary folder, removed at the end).

    Parameters
    ----------
    job : path-like
        The campaign job (.toml, docs/guide/campaign.md).
    set : dict or sequence of str, optional
        Job keys changed first, as ``cosim campaign --set``: ``{"campaign.trials": 2}``.
    out : path-like, optional
        The campaign folder: the finished trials' parts as they arrive, then trials.parquet, table1.csv,
        table1.md, boxplots.png and summary.json. A folder holding the same job is resumed.
    workers : int, optional
        Workers of the local Dask cluster (default: one a core).
    scheduler : str, default ""
        Address of a running Dask scheduler to use instead of a local cluster.
    progress : bool, default False
        A progress bar with the ETA on stderr.

    Returns
    -------
    CampaignResult
        summary.json's figures, the trials and the table of each cell's statistics; after Ctrl-C
        (``interrupted``), those of the trials finished (kept in ``out/parts``: the same call resumes).

    Raises
    ------
    ConfigError
        The job is invalid; ``out`` is not a cosim output or holds another job (the changed keys are named); the
        scheduler does not answer.
    """
    return run_campaign(job, out=out, overrides=override_items(set), workers=workers, scheduler=scheduler,
                        progress=progress)


def run_campaign(path, out=None, overrides=(), workers=None, scheduler="", progress=True):
    """Run (or resume) a campaign job: :func:`campaign` (the parameters are described there); without
    ``out`` the trials' parts go to a temporary folder, removed at the end."""
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ConfigError(f"--workers: expected a whole number >= 1; got {workers!r}")
    job = load_campaign(path, overrides)
    if out is None:
        with tempfile.TemporaryDirectory(prefix="cosim-campaign-") as folder:
            result = _run(job, Path(folder), workers, scheduler, progress, command_line(path, overrides))
        return result
    result = _run(job, Path(out), workers, scheduler, progress, command_line(path, overrides))
    if not result.interrupted:
        write_report(result, job, Path(out))
    return replace(result, out=Path(out))


def _run(job, folder, workers, scheduler, progress, command):
    """The campaign's trials run in ``folder`` (those it holds resumed), as a result."""
    info = run_trials(job, folder, workers=workers, scheduler=scheduler, progress=progress, command=command)
    return campaign_result(read_parts(folder), job, info)


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
