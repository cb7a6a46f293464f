"""Running a campaign: trials in batches on Dask, each finished batch written to disk as it arrives, the same
command resuming where it stopped.

The output folder holds ``campaign.json`` (the job, the SHA-256 of each coating's run config and FMU, their
hash and the command) and ``parts/`` (one Parquet file a batch, written atomically). A run skips the batches
whose part exists; a job, config or FMU that differs from the folder's is refused with the keys that changed. A batch is a run of consecutive trials of one coating:
the worker keeps that coating's :class:`~cosim.campaign.trial.TrialRunner` (engine, loaded kernels) from one
batch to the next.
"""

import hashlib
import json
import os
import shlex
import sys
import time
from pathlib import Path

import pandas as pd

from cosim.campaign.draws import trial_list
from cosim.campaign.job import job_changes
from cosim.campaign.trial import COLUMNS, TrialRunner
from cosim.errors import ConfigError
from cosim.paramfile import file_sha256

__all__ = ["batches", "run_batch", "run_trials", "read_parts", "command_line", "close_runners"]

_RUNNERS = {}  # per process: (campaign hash, coating) -> TrialRunner, kept across the batches a worker runs


def batches(job, specs):
    """The trials cut into batches: consecutive trials of one coating, at most ``job.batch`` each.

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob
    specs : list of cosim.campaign.draws.TrialSpec
        In grid order.

    Returns
    -------
    list of list of TrialSpec
    """
    out = []
    for s in specs:
        if out and out[-1][-1].coating == s.coating and len(out[-1]) < job.batch:
            out[-1].append(s)
        else:
            out.append([s])
    return out


def run_batch(job, specs, key=""):
    """Run a batch of trials in this process (a Dask task).

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob
    specs : list of cosim.campaign.draws.TrialSpec
        Trials of one coating.
    key : str
        The campaign's hash (job, configs, FMUs): batches of the same key reuse this process's runner.

    Returns
    -------
    rows : list of dict
        One row of trials.parquet a trial.
    times : dict
        Wall times (s): ``setup_s`` (making the runner: the config, the engine, its kernels, the loop kernel's
        compile or load in the first run; 0 when this process had them), ``loop_s`` (inside the engine's loop), ``trials_s`` (the trials, loop included).
    """
    t0 = time.perf_counter()
    runner = _RUNNERS.get((key, specs[0].coating))
    if runner is None:
        coating = next(c for c in job.coatings if c.name == specs[0].coating)
        runner = _RUNNERS[(key, specs[0].coating)] = TrialRunner(job, coating)
    t1 = time.perf_counter()
    loop0, kernel0 = runner.loop_s, runner.kernel_s
    rows = [runner.run(s) for s in specs]
    kernel = runner.kernel_s - kernel0  # the first run's kernel compile or load: set-up, not the trials'
    return rows, {"setup_s": t1 - t0 + kernel, "loop_s": runner.loop_s - loop0,
                  "trials_s": time.perf_counter() - t1 - kernel}


def close_runners():
    """Close this process's runners (a Dask worker's, at the end of a campaign): their FMUs unloaded, the folders
    they were unpacked into removed (a local cluster's workers' folders go with the cluster anyway)."""
    while _RUNNERS:
        _RUNNERS.popitem()[1].close()


def _inputs(job):
    """What a campaign's results depend on beside the job: each coating's run config, FMU files and the parameters
    files its config reads (SHA-256)."""
    from cosim.config import load_config

    out = {}
    for c in job.coatings:
        cfg = load_config(c.config)
        out[c.name] = {"config_sha256": file_sha256(c.config),
                       "fmus_sha256": {n: file_sha256(f.path) for n, f in sorted(cfg.fmus.items())},
                       "parameters_files_sha256": {n: f.parameters_file.sha256 for n, f in sorted(cfg.fmus.items())
                                                   if f.parameters_file is not None}}
    return out


def parameters_files(job):
    """The parameters files a campaign's trials read, each with its SHA-256 and provenance: the job's
    (``campaign``) and, per coating and FMU instance, its run config's."""
    from cosim.config import load_config

    out = {"campaign": job.parameters_file.record() if job.parameters_file is not None else None}
    for c in job.coatings:
        fmus = load_config(c.config).fmus
        out[c.name] = {n: f.parameters_file.record() for n, f in sorted(fmus.items()) if f.parameters_file is not None}
    return out


def _prepare(job, out, command):
    """Mark ``out`` as this campaign's folder, or check that it already is (same job and inputs)."""
    from cosim.outputs import mark_output

    out = Path(out)
    manifest = out / "campaign.json"
    state = {"job": job.canonical(), "inputs": _inputs(job)}
    h = hashlib.sha256(json.dumps(state, sort_keys=True).encode()).hexdigest()
    if manifest.is_file():
        old = json.loads(manifest.read_text(encoding="utf-8"))
        if old.get("job_hash") != h:
            changes = job_changes({k: old.get(k, {}) for k in state}, state)
            raise ConfigError(f"--out {out}: holds a campaign of another job or model (hash "
                              f"{old.get('job_hash', '?')[:12]}, now {h[:12]}); changed: "
                              f"{'; '.join(changes) or 'the file format'}. Resume with the same job, --set items, "
                              "configs and FMUs, or choose another --out")
        return out, h
    mark_output(out, "campaign")
    (out / "parts").mkdir(exist_ok=True)
    manifest.write_text(json.dumps({"job_hash": h, "command": command, **state}, indent=2), encoding="utf-8")
    return out, h


def _part(out, batch):
    return out / "parts" / f"part-{batch[0].index:06d}.parquet"


def _write_part(out, batch, rows):
    path = _part(out, batch)
    tmp = path.with_suffix(".tmp")
    pd.DataFrame(rows, columns=list(COLUMNS)).to_parquet(tmp, index=False)
    os.replace(tmp, path)


def read_parts(out):
    """Every finished trial of a campaign folder, in grid order.

    Parameters
    ----------
    out : path-like

    Returns
    -------
    pandas.DataFrame
        The columns of :data:`cosim.campaign.trial.COLUMNS`.
    """
    parts = sorted((Path(out) / "parts").glob("part-*.parquet"))
    if not parts:
        return pd.DataFrame(columns=list(COLUMNS))
    return pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True)


def run_trials(job, out, workers=None, scheduler="", progress=True, command=""):
    """Run the trials of ``job`` not yet in ``out`` on Dask; each batch's part is written as it arrives.

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob
    out : path-like
        The campaign folder (created, or resumed when it holds this job).
    workers : int, optional
        Workers of the local cluster (default: one a core).
    scheduler : str, default ""
        A Dask scheduler's address instead of a local cluster.
    progress : bool, default True
        A progress bar with the ETA on stderr.
    command : str
        The command line, kept in campaign.json.

    Returns
    -------
    dict
        ``trials`` (all), ``resumed`` (already done), ``ran``, ``wall_s`` (of this call), ``setup_s``,
        ``loop_s`` and ``trials_s`` (summed over the batches run, see :func:`run_batch`), ``workers`` (of the
        cluster), ``interrupted``.

    Raises
    ------
    cosim.errors.ConfigError
        ``out`` is not a cosim output, or holds another job's campaign; the scheduler does not answer.
    """
    from distributed import as_completed
    from tqdm import tqdm

    from cosim.parallel import open_client

    out, key = _prepare(job, out, command)
    todo = [b for b in batches(job, trial_list(job)) if not _part(out, b).exists()]
    n_all = job.trials * len(job.coatings) * len(job.speeds_rpm) * len(job.currents_A)
    info = {"trials": n_all, "resumed": n_all - sum(len(b) for b in todo), "ran": 0, "setup_s": 0.0, "loop_s": 0.0,
            "trials_s": 0.0, "wall_s": 0.0, "workers": 0, "interrupted": False}
    if not todo:
        return info
    t0 = time.perf_counter()
    with open_client(scheduler, max_workers=workers) as client:
        futures = {client.submit(run_batch, job, b, key, pure=False): b for b in todo}
        bar = tqdm(total=n_all, initial=info["resumed"], desc="trials", unit="trial", file=sys.stderr,
                   disable=not progress, smoothing=0.1)
        try:
            for future in as_completed(futures):
                rows, times = future.result()
                _write_part(out, futures[future], rows)
                info["ran"] += len(rows)
                for k, v in times.items():
                    info[k] += v
                bar.update(len(rows))
        except KeyboardInterrupt:
            info["interrupted"] = True
            client.cancel(list(futures))
        finally:
            bar.close()
        if not info["interrupted"]:  # (interrupted: a runner may still be in a cancelled batch's trial)
            client.run(close_runners)
        info["workers"] = len(client.scheduler_info().get("workers", {}))  # at the end: a remote one may grow
    info["wall_s"] = time.perf_counter() - t0
    return info


def command_line(job_path, overrides):
    """The ``cosim campaign`` command of a job and its ``--set`` items (for campaign.json)."""
    return "cosim campaign " + shlex.quote(str(job_path)) + "".join(f" --set {shlex.quote(s)}" for s in overrides)
