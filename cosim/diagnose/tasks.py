"""The fits a diagnosis runs in its workers: a :class:`FitTask` names one model (the baseline or a candidate's
variant), the samples it is fitted on and where it starts; :func:`fit_task` fits it (a
:class:`~cosim.diagnose.fitting.Fit`), :func:`screen_task` screens it (a :class:`~cosim.diagnose.fitting.Screen`),
:func:`run_tasks` maps either over the job's Dask workers. Every use of the effect library by the fits is here.
"""

from dataclasses import dataclass, field

import numpy as np

from cosim.diagnose.effects import EFFECTS, Effect, write_variant
from cosim.diagnose.fitting import LinearisedFit, SampleFit, Screen, Trials
from cosim.fitting import FreeParameter
from cosim.parallel import map_here, map_on_dask

__all__ = ["FitTask", "task_of", "variant_of", "fit_task", "screen_task", "run_tasks", "fit_free", "free_at",
           "added_parameters", "bic_penalty", "effect_free"]


@dataclass(frozen=True)
class FitTask:
    """One fit (or screen) for a worker: a plain record, so it crosses processes (the model is lowered there).

    Attributes
    ----------
    job : cosim.diagnose.job.DiagnoseJob
    effect : str
        The candidate, or ``"baseline"`` for the baseline itself.
    variant_path, variant_model : str
        The Modelica file and full name of the model fitted (the baseline's own for ``"baseline"``).
    baseline : dict
        name -> FreeParameter: the baseline's free parameters and where they start (its fit's values).
    weights : ndarray, shape (n_signals,) or (n_signals, N)
        1 / noise level.
    mask : ndarray of bool, shape (N,)
        The samples fitted on.
    start : dict, optional
        name -> FreeParameter: the one start to fit from (the screen's best); without it, every start of the
        effect in turn, the best fit kept.
    columns : dict
        The screen's known Jacobian columns (the baseline's at its fit).
    fold, group : int
        Which fold, which group of baseline restarts the fit belongs to (bookkeeping of the caller).
    """

    job: object
    effect: str
    variant_path: str
    variant_model: str
    baseline: dict
    weights: np.ndarray
    mask: np.ndarray
    start: dict = None
    columns: dict = field(default_factory=dict)
    fold: int = 0
    group: int = 0


def task_of(job, effect, weights, mask, path=None, variant=None, **fields):
    """A :class:`FitTask` of ``effect`` on ``mask`` (the baseline's own model when no variant ``path`` and
    ``variant`` name are given); ``fields``: the task's other attributes."""
    return FitTask(job=job, effect=effect, variant_path=str(path or job.source), variant_model=variant or job.model,
                   baseline=fields.pop("baseline", {}), weights=weights, mask=mask, **fields)


def variant_of(job, name, folder):
    """The job's baseline with the candidate ``name`` written into a copy of its package in ``folder`` (in a later
    round: the user's baseline with the candidates of earlier rounds and ``name``); returns the copy's path and the
    variant's model name."""
    source, model = job.user_model
    return write_variant(source, model, [EFFECTS[n] for n in (*job.adopted, name)], folder)


def _effect(name):
    """The candidate ``name``, or for ``"baseline"`` an effect that adds nothing."""
    return Effect("baseline", "", ()) if name == "baseline" else EFFECTS[name]


def _bounds(effect):
    """(name, lower, upper) of each parameter ``effect`` adds: those it declares, then the baseline's it frees."""
    return [(p.name, p.lower, p.upper) for p in effect.parameters] + list(effect.frees)


def added_parameters(name):
    """The parameters the effect ``name`` declares, then the baseline's parameters it frees."""
    return [n for n, _, _ in _bounds(EFFECTS[name])]


def bic_penalty(name, n_fit):
    """The BIC's price of the candidate ``name`` on ``n_fit`` fitted values: ln(n_fit) per parameter it adds. A job
    never frees a parameter an offered effect frees (:func:`~cosim.diagnose.job.load_diagnose_job` refuses it, a
    later round does not offer it), so each one adds a parameter to the fit."""
    return len(added_parameters(name)) * np.log(n_fit)


def effect_free(effect, values):
    """The parameters ``effect`` adds (name -> FreeParameter) within the effect's bounds, each starting at its value
    in ``values`` clipped into them: a candidate's start, or in a later round a finding's fitted value."""
    return {n: FreeParameter(lower, lower, upper).clipped(values[n]) for n, lower, upper in _bounds(effect)}


def free_at(job, fit):
    """The job's free baseline parameters (name -> FreeParameter) starting at their values in ``fit``."""
    return {n: p.at(fit.parameters[n]) for n, p in job.free.items()}


def _candidate(task):
    """A task's lowered model, records and free parameters (name -> FreeParameter) for each of its starts: the
    baseline's values at its fit on every sample, the effect's start values, then each of the effect's other
    starts."""
    from cosim.compile import lower
    from cosim.diagnose.job import load_records

    job = task.job
    effect = _effect(task.effect)
    model = lower(task.variant_path, task.variant_model)
    records = load_records(job, model)
    defaults = dict(zip([p.name for p in model.parameters], model.parameter_values))
    free = dict(task.baseline)
    starts = {p.name: p.start if isinstance(p.start, (int, float)) else
              free[p.start].start if p.start in free else job.fixed.get(p.start, defaults[p.start])
              for p in effect.parameters}
    starts.update({name: job.fixed.get(name, defaults[name]) for name, _, _ in effect.frees})
    free.update(effect_free(effect, starts))
    trials = [free] + [{**free, p.name: free[p.name].clipped(v)} for p in effect.parameters for v in p.starts]
    return model, records, trials


def _replay(model, records, job, free):
    """The replay of every record varying the ``free`` parameters (name -> FreeParameter), each record with its
    trial's fixed values, and the measured channels end to end."""
    scale = np.array([abs(p.start) if p.start != 0 else 1.0 for p in free.values()], float)
    replay = Trials([job.kind.replay(model, e, [o for o, _, _ in job.signals], list(free), scale,
                                     fixed={**job.fixed, **trial}, rtol=job.rtol) for e, trial in records])
    return replay, np.hstack([e.measured.T for e, _ in records])


def fit_free(model, records, job, free, weights, mask, label, report=None):
    """Fit the ``free`` parameters (name -> FreeParameter) on ``mask`` over every record (from
    :func:`~cosim.diagnose.job.load_records`), each replayed with its trial's fixed values; a Fit labelled
    ``label``. ``report`` gets the fit's progress lines."""
    replay, measured = _replay(model, records, job, free)
    return SampleFit(replay, weights, mask, free, max_nfev=job.max_nfev, progress=report).fit(measured).result(label)


def fit_task(task, report=None):
    """One fit in a worker (a candidate's variant, or the baseline itself) on the task's samples, from its
    ``start`` or else the best of every start; replays every sample. ``report`` gets the fits' progress lines."""
    model, records, trials = _candidate(task)
    trials = [task.start] if task.start else trials
    fits = [fit_free(model, records, task.job, trial, task.weights, task.mask, task.effect,
                     report and (lambda line, k=k: report(f"{task.effect} start {k + 1}/{len(trials)}: {line}")))
            for k, trial in enumerate(trials)]
    return min(fits, key=lambda fit: fit.chi2)


def screen_task(task):
    """One candidate screened in a worker: the linearised fit (:class:`~cosim.diagnose.fitting.LinearisedFit`)
    from each of its starts on the task's samples, the baseline's columns from its fit; the best start's."""
    model, records, trials = _candidate(task)
    screens = []
    for trial in trials:
        replay, measured = _replay(model, records, task.job, trial)
        step = LinearisedFit(replay, task.weights, task.mask, trial, task.columns).fit(measured)
        screens.append(Screen(effect=task.effect, start=trial, chi2=step.chi2_start_,
                              chi2_predicted=step.chi2_predicted_))
    return min(screens, key=lambda screen: screen.chi2_predicted)


def run_tasks(job, tasks, progress, function=fit_task, desc="candidate effects"):
    """``function`` of every task: in this process (``parallel.workers = 0``, or one task and no scheduler), else
    on the job's Dask workers; a fit's progress lines (iteration, cost, time left) beside the bar."""
    if not tasks:  # nothing to run: no empty progress bar
        return []
    report = function is fit_task
    if job.workers <= 0 or len(tasks) <= 1 and not job.scheduler:
        return map_here(function, tasks, desc=desc, progress=progress, report=report)
    return map_on_dask(function, tasks, job.scheduler, max_workers=job.workers, desc=desc, progress=progress,
                       report=report)
