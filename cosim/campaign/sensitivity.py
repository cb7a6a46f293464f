"""``cosim sensitivity``: global (Sobol) sensitivity of a campaign's steady-force statistics to constants that were
estimated, not measured, on the campaign's own machinery (:class:`~cosim.campaign.trial.TrialRunner` on Dask).

The job names a campaign job and a reduced grid of it (coatings, speeds, currents, trials a cell, tightening
time), and the factors: each a range, a scale, the plant parameters or outer-loop values it sets (per coating
where they differ) and the reason for its range. Every parameter point of Saltelli's sample runs the same trials
of each cell (the campaign's trial seeds: common random numbers, so a point's statistics differ from another's by
the factors alone); the outputs are each cell's median and IQR of the steady force over its trials.

Job schema (paths relative to the job)::

    [sensitivity]  campaign = "campaign_table1.toml", samples = 16, seed = 1, bootstrap = 500, confidence = 0.95,
                   trials = 10, coatings = ["bare", "P3"], speeds_rpm = [1000], currents_A = [1.0, 2.0],
                   hold_s = 1.5, steady_s = 0.5, batch = 4
    [factors.NAME] low, high, scale = "linear"|"log", reason,
                   set = ["plant.C_h", "outer.Kp"]  or  set = {bare = ["plant.C_p", "plant.C_h"], P3 = [...]}
"""

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from cosim.campaign.draws import trial_list
from cosim.campaign.job import COATINGS, load_campaign
from cosim.campaign.sobol import Factor, index_table, plot_indices, sample_points
from cosim.tomldoc import number, read_toml, sections, string, toml_value

__all__ = ["SensitivityJob", "load_sensitivity", "run_sensitivity"]

_GRID = ("trials", "coatings", "speeds_rpm", "currents_A", "hold_s", "steady_s")
_SCHEMA = {"sensitivity": ("campaign", "samples", "seed", "bootstrap", "confidence", "batch", *_GRID)}
_TARGETS = ("plant", "outer")  # a factor sets parameters of the plant FMU instance or values of the outer loop


@dataclass(frozen=True)
class SensitivityJob:
    """A validated sensitivity job (see the module docstring).

    Attributes
    ----------
    path : pathlib.Path
    campaign : cosim.campaign.job.CampaignJob
        The campaign job with the reduced grid applied.
    factors : tuple of cosim.campaign.sobol.Factor
    targets : dict
        factor name -> coating -> tuple of ``("plant"|"outer", name)`` it sets (empty: no effect on the coating).
    reasons : dict
        factor name -> why its range is what it is.
    samples, seed, bootstrap, batch : int
    confidence : float
    """

    path: Path
    campaign: object
    factors: tuple
    targets: dict
    reasons: dict
    samples: int
    seed: int
    bootstrap: int
    confidence: float
    batch: int
    overrides: tuple = field(default=(), compare=False)


def _targets(spec, where, problems):
    """``set``: coating -> tuple of (target, name)."""
    given = spec.get("set")
    per = given if isinstance(given, dict) else {c: given for c in COATINGS}
    out = {}
    for coating, items in per.items():
        if coating not in COATINGS:
            problems.add(where + ("set", coating), f"unknown coating; the paper's are {', '.join(COATINGS)}")
            continue
        if not isinstance(items, list) or not all(isinstance(i, str) and i.partition(".")[0] in _TARGETS
                                                   and i.partition(".")[2] for i in items):
            problems.add(where + ("set",), "must list \"plant.NAME\" (a plant FMU parameter) or \"outer.NAME\" (an "
                                           f"outer-loop value), or give such a list per coating; got {given!r}")
            return {}
        out[coating] = tuple(tuple(i.split(".", 1)) for i in items)
    return out


def _factor(name, spec, problems):
    """One ``[factors.NAME]`` table -> (Factor, targets, reason), or None."""
    where = ("factors", name)
    if not isinstance(spec, dict):
        problems.add(where, "must be a table: low, high, scale, set, reason")
        return None
    for key in sorted(set(spec) - {"low", "high", "scale", "set", "reason"}):
        problems.add(where + (key,), "unknown key; allowed: low, high, scale, set, reason")
    low, high = number(problems, spec, "low", where), number(problems, spec, "high", where)
    scale = spec.get("scale", "linear")
    if scale not in ("linear", "log"):
        problems.add(where + ("scale",), f"must be \"linear\" or \"log\"; got {scale!r}")
    reason = string(problems, spec, "reason", where)
    targets = _targets(spec, where, problems)
    if None in (low, high) or scale not in ("linear", "log"):
        return None
    if not low < high:
        problems.add(where, f"low {low:g} must be below high {high:g}")
    elif scale == "log" and low <= 0:
        problems.add(where + ("low",), f"must be > 0 on a log scale; got {low:g}")
    return Factor(name, low, high, scale), targets, reason


def _grid_sets(table, problems):
    """The reduced grid as ``--set`` items of the campaign job, and where each was given (``--set sensitivity.K``
    or the sensitivity job's file:line and key), for the campaign job's messages about them."""
    keys = [k for k in _GRID if k in table]
    where = {k: problems.where(("sensitivity", k)) for k in keys}
    return ([f"campaign.{k}={toml_value(table[k])}" for k in keys],
            {f"campaign.{k}": w if w.startswith("--set") else f"{w} (sensitivity.{k})" for k, w in where.items()})


def load_sensitivity(path, overrides=()):
    """Read and check a sensitivity job and the campaign job it names (with its reduced grid).

    Parameters
    ----------
    path : path-like
    overrides : sequence of str
        ``--set key=value`` items of the sensitivity job.

    Returns
    -------
    SensitivityJob

    Raises
    ------
    cosim.errors.ConfigError
        Every problem of the job with its file:line and key; the campaign job's own problems.
    """
    path = Path(path)
    data, problems = read_toml(path, overrides, what="sensitivity job")
    tables = sections(data, problems, _SCHEMA, free_form=("factors",))
    s, w = tables["sensitivity"], ("sensitivity",)
    campaign = string(problems, s, "campaign", w)
    if campaign is not None and not (path.parent / campaign).is_file():
        problems.add(w + ("campaign",), f"no such campaign job: {path.parent / campaign}")
    job = dict(samples=number(problems, s, "samples", w, positive=True, integer=True),
               seed=number(problems, s, "seed", w, default=0, integer=True),
               bootstrap=number(problems, s, "bootstrap", w, default=500, positive=True, integer=True),
               confidence=number(problems, s, "confidence", w, default=0.95, positive=True),
               batch=number(problems, s, "batch", w, default=4, positive=True, integer=True))
    if job["confidence"] is not None and not job["confidence"] < 1:
        problems.add(w + ("confidence",), f"must be between 0 and 1; got {job['confidence']!r}")
    given = data.get("factors", {})
    if not isinstance(given, dict):
        problems.add(("factors",), "must be a table of [factors.NAME] tables")
        given = {}
    factors = [f for f in (_factor(n, t, problems) for n, t in given.items()) if f is not None]
    if not given:
        problems.add(("factors",), "name at least one factor: [factors.NAME] low, high, set, reason")
    problems.raise_if_any()
    camp = load_campaign(path.parent / campaign, *_grid_sets(s, problems))
    return SensitivityJob(path=path, campaign=camp, factors=tuple(f for f, _, _ in factors),
                          targets={f.name: t for f, t, _ in factors}, reasons={f.name: r for f, _, r in factors},
                          overrides=tuple(overrides), **job)


def _settings(job, coating, point):
    """(plant parameters, outer-loop values) of one coating at one parameter point."""
    plant, outer = {}, {}
    for name, value in point.items():
        for target, key in job.targets[name].get(coating, ()):
            (plant if target == "plant" else outer)[key] = value
    return plant, outer


_RUNNERS = {}  # per process: (job path, coating) -> TrialRunner, kept across the tasks a worker runs


def evaluate(task):
    """Run one task (a Dask task): the trials of every cell of one coating at a few parameter points.

    Parameters
    ----------
    task : tuple
        ``(job, coating name, [(point index, point), ...])``.

    Returns
    -------
    list of (int, dict)
        Per point, its index and ``(speed_rpm, current_A)`` -> the steady forces of the cell's trials (N).
    """
    from cosim.campaign.trial import TrialRunner

    job, coating, points = task
    camp = job.campaign
    runner = _RUNNERS.get((str(job.path), coating))
    if runner is None:
        spec = next(c for c in camp.coatings if c.name == coating)
        runner = _RUNNERS[(str(job.path), coating)] = TrialRunner(camp, spec)
    specs = [s for s in trial_list(camp) if s.coating == coating]
    out = []
    for index, point in points:
        plant, outer = _settings(job, coating, point)
        forces = {}
        for s in specs:
            row = runner.run(s, plant=plant, outer=outer)
            forces.setdefault((s.speed_rpm, s.current_A), []).append(row["steady_force_N"])
        out.append((index, forces))
    return out


def _statistics(forces):
    """Median and IQR (N) of a cell's steady forces (trials without a switch left out)."""
    f = np.asarray(forces, dtype=float)
    f = f[np.isfinite(f)]
    if not len(f):
        return math.nan, math.nan
    q1, med, q3 = np.percentile(f, [25, 50, 75])
    return float(med), float(q3 - q1)


def run_sensitivity(path, out=None, overrides=(), workers=None, scheduler="", progress=True, force=False):
    """Run a sensitivity job and write ``points.parquet``, ``indices.csv``, ``indices.png`` and ``summary.json``.

    Parameters
    ----------
    path : path-like
        The sensitivity job (.toml).
    out : path-like, optional
        Output folder (default ``out/<job stem>``); must be new, empty or a previous cosim output (``force``).
    overrides : sequence of str
        ``--set`` items of the sensitivity job.
    workers : int, optional
        Workers of the local Dask cluster (default: one a core).
    scheduler : str, default ""
        A running Dask scheduler's address instead of a local cluster.
    progress : bool, default True
    force : bool, default False
        Replace a previous cosim output at ``out``.

    Returns
    -------
    dict
        The summary (summary.json).

    Raises
    ------
    cosim.errors.ConfigError
        An invalid job; ``out`` not usable; the scheduler does not answer.
    """
    from cosim.outputs import output_folder
    from cosim.parallel import map_on_dask

    job = load_sensitivity(path, overrides)
    out = Path(out) if out is not None else Path("out") / Path(path).stem
    points = sample_points(job.factors, job.samples, job.seed)
    tasks = [(job, c.name, [(k, points[k]) for k in range(a, min(a + job.batch, len(points)))])
             for c in job.campaign.coatings for a in range(0, len(points), job.batch)]
    with output_folder(out, "sensitivity", force=force) as staging:
        t0 = time.perf_counter()
        done = map_on_dask(evaluate, tasks, scheduler=scheduler, max_workers=workers,
                           desc=f"batches of {job.batch} points", progress=progress)
        wall = time.perf_counter() - t0
        frame = _points_frame(job, points, tasks, done)
        frame.to_parquet(staging / "points.parquet", index=False)
        outputs = {key: frame[_column(*key)].to_numpy() for key in _outputs(job)}
        table = index_table(job.factors, outputs, job.bootstrap, job.confidence, job.seed)
        table.to_csv(staging / "indices.csv", index=False)
        plot_indices(table, staging / "indices.png")
        summary = _summary(job, points, wall, workers, table)
        (staging / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary


def _outputs(job):
    camp = job.campaign
    return [(c.name, v, i, stat) for c in camp.coatings for v in camp.speeds_rpm for i in camp.currents_A
            for stat in ("median", "iqr")]


def _column(coating, rpm, amp, stat):
    return f"{coating}_{rpm:g}rpm_{amp:g}A_{stat}_N"


def _points_frame(job, points, tasks, done):
    """One row a parameter point: the factors' values and every output (points.parquet)."""
    rows = [dict(p) for p in points]
    for (_, coating, _), results in zip(tasks, done):
        for index, forces in results:
            for (rpm, amp), f in forces.items():
                med, iqr = _statistics(f)
                rows[index][_column(coating, rpm, amp, "median")] = med
                rows[index][_column(coating, rpm, amp, "iqr")] = iqr
    return pd.DataFrame(rows)


def _summary(job, points, wall, workers, table):
    from cosim.campaign.execute import parameters_files

    camp = job.campaign
    top = (table.sort_values("ST", ascending=False).groupby(["coating", "speed_rpm", "current_A", "statistic"],
                                                              sort=False).head(1))
    return {"job": str(job.path), "overrides": list(job.overrides), "campaign": str(camp.path),
            "samples": job.samples, "points": len(points),
            "trials": len(points) * len(camp.coatings) * len(camp.speeds_rpm) * len(camp.currents_A) * camp.trials,
            "factors": {f.name: {"low": f.low, "high": f.high, "scale": f.scale, "reason": job.reasons[f.name]}
                        for f in job.factors},
            "largest_total_index": {_column(r.coating, r.speed_rpm, r.current_A, r.statistic): {
                "factor": r.factor, "ST": r.ST, "ST_conf": r.ST_conf} for r in top.itertuples()},
            "parameters_files": parameters_files(camp),
            "run": {"wall_s": wall, "workers": workers, "load_average_1min": float(os.getloadavg()[0])}}
