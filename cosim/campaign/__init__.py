"""``cosim campaign``: the gripper paper's experimental campaign (Table 1, Fig. 12) as a grid of co-simulated
impact trials with physical trial-to-trial variability, run in batches on Dask, resumable.

Modules: ``job`` (the TOML job), ``draws`` (trials, seeds, drawn values), ``trial`` (one trial through the
master's engine), ``execute`` (batches on Dask, parts on disk, resume), ``report`` (tables, plot, summary).
"""

import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from cosim import _callable_package
from cosim.campaign.draws import trial_list
from cosim.campaign.execute import command_line, read_parts, run_trials
from cosim.campaign.job import load_campaign
from cosim.campaign.report import campaign_result, table1, write_report
from cosim.campaign.trial import TrialRunner, run_command
from cosim.errors import ConfigError

__all__ = ["run_campaign", "run_one_trial", "load_campaign", "table1"]

_callable_package(sys.modules[__name__])  # cosim.campaign(job, ...) is cosim.api.campaign


def run_campaign(path, out=None, overrides=(), workers=None, scheduler="", progress=True):
    """Run (or resume) a campaign job: :func:`cosim.api.campaign` (the parameters are described there); without
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
