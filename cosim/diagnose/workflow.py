"""The discrepancy workflow: replay and compare, locate, name, add and show.

1. *Replay and compare*: the baseline's free parameters are calibrated on the cost samples (the settled end of
   each hold of a staircase; every sample of an impact; every frequency of a frequency response, compared as
   magnitude [dB] and phase [deg]); the noise level of each channel is estimated from the data themselves
   (differences inside the steady windows, inside the approach and steady hold of an impact, or of neighbouring
   frequencies), floored by the job's stated noise.
2. *Locate*: the experiment is cut into its natural segments (holds, impact phases, frequency bands); each
   segment's residual is compared with the noise and given a shape; whiteness and cross-correlation with the
   input are reported.
3. *Name*: every candidate effect is written as a Modelica variant of the baseline and screened from the
   baseline's fit on every cost sample: the chi-square one bounded Gauss-Newton step predicts, the baseline's
   Jacobian columns from its fit and the effect's by forward differences (a score test of the nested effect, no
   fit). The ``REFIT_BEST`` with the best predicted BIC are calibrated on the even segments (with the baseline's
   parameters free as well), and scored on the odd segments they were not fitted on; while the baseline shows a
   gap that none of those fitted explains, the next ``REFIT_BEST`` in the screen's order are fitted too, up to
   the whole library (a linearised screen can rank a strongly nonlinear effect low, and "no effect in the
   library explains it" must mean that each was fitted):
   ``score`` = fraction of the baseline's held-out excess gap (mean square residual above the noise) that the
   candidate removes; BIC and a likelihood-ratio test on the fitted segments give the evidence against noise.
   Candidates run in parallel (Dask). The winner is the best-scoring candidate that removes at least
   ``min_gap_removed`` of the held-out gap and improves BIC by ``min_delta_bic``; "none" when no candidate
   qualifies, or when the baseline shows no gap: no segment of its residual is significant, or its whole residual
   is within chance of the noise (mean square in noise units below 1 + ``gap_sigmas``*sqrt(2/n)).
4. *Add and show*: the winner's variant is refitted on every cost sample, written into the Modelica source (a
   copy of the package under ``OUT/modelica`` with a diff), built into an FMU and, with the baseline's FMU, re-run
   through the master with the measured inputs; gaps before and after per segment and overall.
5. *Answer*: the verdict (an effect named; a gap of N noise levels no candidate explains, with where it is; or a
   baseline within the noise), its evidence and the next step, with the effects plausible but not identifiable on
   these data and the experiment that would show each (:mod:`cosim.diagnose.advice`).

Repeated trials (``data.records``: several records, each with its own fixed values, e.g. the object's position)
are diagnosed as one experiment: every fit shares its parameters over the records, their samples are end to end
(noise, cost, folds, scores), each record is cut into its own segments. One impact sees a position-dependent
torque such as cogging at one rest angle; impacts with the object placed anew each time see it at several.

In code, each step is a stage, a function returning a frozen dataclass that the next stages read: the samples
(:class:`Samples`), the noise (:class:`Noise`), the segments and folds (:class:`Split`), the candidates' scores
(:class:`Scores`), the decision (:class:`Decision`) and the show (:class:`Show`); :func:`run_diagnosis` chains
them into a :class:`Diagnosis`, whose :meth:`Diagnosis.to_json` is the content of ``diagnosis.json``.
"""

import difflib
import shutil
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import stats

from cosim.diagnose.advice import MAX_ADVISED, change_here, change_on, gap_locations, plausible
from cosim.diagnose.analysis import (band_shape, branch_shapes, cross_correlation, cut_segments, frequency_bands,
                                     in_segment, noise_level, quiet_phases, segment_table, whiteness)
from cosim.experiment import Experiment, steady_mask
from cosim.parallel import map_on_dask
from cosim.diagnose.effects import EFFECTS, Effect, write_variant
from cosim.diagnose.fitting import Replay, Trials, fit_samples, linearised_fit, weighted
from cosim.diagnose.frequency import DEG_PER_DB, FrequencyReplay, frequency_noise
from cosim.diagnose.result import Candidate, Diagnosis, Noise, RecordSummary, Rerun, SegmentRow, Traces

__all__ = ["Samples", "Split", "Scores", "Decision", "Show", "load_samples", "estimate_noise", "split_segments",
           "score_candidates", "rivals_of", "decide", "show", "run_diagnosis", "advise", "answer"]

MIN_QUIET_SAMPLES = 20  # fewer samples in an impact's approach and steady holds: its noise from every sample
RERUN_HOW = "the built FMUs run by the master (BDF) with the measured inputs played at the data rate"
# Candidates refitted on the folds after the screen (:func:`_screen`): the best and one rival. Fixed
# before any benchmark ran with the screen; not tuned to a case.
REFIT_BEST = 2


# -- the effect library (cosim.diagnose.effects): every use of it is here -----------------------------------------

def _effect(name):
    """The candidate ``name``, or for ``"baseline"`` an effect that adds nothing."""
    return Effect("baseline", "", ()) if name == "baseline" else EFFECTS[name]


def _write_variant(job, name, folder):
    """The job's baseline with the effect ``name`` written into a copy of its package in ``folder``; returns the
    copy's path and the variant's model name."""
    return write_variant(job.source, job.model, EFFECTS[name], folder)


def _added_parameters(name):
    """The parameters the effect ``name`` declares, then the baseline's parameters it frees."""
    effect = EFFECTS[name]
    return [p.name for p in effect.parameters] + [n for n, _, _ in effect.frees]


def _title(name):
    """One line: what physics the effect ``name`` adds."""
    return EFFECTS[name].title


def _effect_units(names):
    """Name -> unit of the parameters the effects ``names`` declare."""
    return {p.name: p.unit for n in names for p in EFFECTS[n].parameters}


# -- the stages' results ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Samples:
    """The measured records end to end, as every stage reads them.

    Attributes
    ----------
    model : cosim.compile.LoweredModel
        The baseline, lowered.
    records : list of (Experiment, dict)
        Each record and its trial's fixed values (:func:`~cosim.diagnose.job.load_records`).
    experiment : Experiment
        The records end to end (:func:`_end_to_end`).
    shifts : list of float
        Time shift of each record in ``experiment`` [s].
    sampled : list of ndarray of bool
        Per record, the instants where every compared channel has a sample.
    present, mask : ndarray of bool, shape (N,)
        The instants every channel has; the cost samples among them.
    channels, units : list of str
        Names and units of the compared channels.
    floor : ndarray, shape (n_signals,)
        The job's noise floor of each channel.
    """

    model: object
    records: list
    experiment: Experiment
    shifts: list
    sampled: list
    present: np.ndarray
    mask: np.ndarray
    channels: list
    units: list
    floor: np.ndarray

    @property
    def time(self):
        """Time [s] (frequency [Hz] for a frequency response), shape (N,)."""
        return self.experiment.time

    @property
    def measured(self):
        """The compared channels, shape (n_signals, N)."""
        return self.experiment.measured.T

    @property
    def n_fit(self):
        """The number of weighted residuals in the cost."""
        return int(self.mask.sum()) * self.measured.shape[0]


@dataclass(frozen=True)
class Split:
    """The segments (holds, impact phases, frequency bands; labelled by record for repeated trials), the segment
    ``shape`` classifier (None: the time-domain default) and the two folds, each (train, test) masks."""

    segments: list
    shape: object
    folds: list


@dataclass(frozen=True)
class Scores:
    """The baseline's fit on every cost sample (``base``, refitted when a candidate showed it a better start), the
    fits per fold (``fits``: "baseline" and each refitted effect -> [fold 0, fold 1]), the refitted ``candidates``
    in the job's order and the ``screen`` of every candidate (effect -> ``chi2`` at its start, ``predicted``
    chi-square after one Gauss-Newton step, ``delta_bic`` predicted, ``refitted``; :func:`_screen`)."""

    base: dict
    fits: dict
    candidates: tuple
    screen: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Decision:
    """The baseline's residual per segment (``rows``, :func:`~cosim.diagnose.analysis.segment_table`), its
    shapes, whiteness and cross-correlation with the input; whether it shows a gap (``mean_square`` in noise
    levels squared against ``chance``), the ``winner`` (None: "none") and its ``rivals``; the ``outcome``
    ("named", "unexplained gap" or "within noise"), the gap's size (``gap_levels``: RMS residual in noise levels)
    and ``where`` it is (:func:`~cosim.diagnose.advice.gap_locations`), the candidates ``plausible`` but not
    identifiable here (:func:`~cosim.diagnose.advice.plausible`)."""

    rows: list
    shapes: list
    whiteness: dict
    cross_correlation: object
    mean_square: float
    chance: float
    gap_found: bool
    winner: object
    rivals: list
    outcome: str = "within noise"
    gap_levels: float = 0.0
    where: list = ()
    plausible: list = ()

    @property
    def effect(self):
        """The winner's name, or ``"none"``."""
        return "none" if self.winner is None else self.winner.effect


@dataclass(frozen=True)
class Show:
    """The winner added: its fit on every cost sample (``final``, None for "none"), its replay ``after`` (the
    baseline's for "none"), its built ``fmu``, the package with its variant and the diff, the ``rerun``."""

    final: object
    after: np.ndarray
    fmu: object = None
    variant_source: str = ""
    variant_diff: str = ""
    rerun: object = None


# -- fits -----------------------------------------------------------------------------------------------------------

def _scales(values):
    return np.array([abs(v) if v != 0 else 1.0 for v in values], float)


def _candidate(task):
    """A candidate's (or for ``effect = "baseline"`` the baseline's) lowered model, records and free parameters
    (name -> (start, lo, hi)) for each of its starts: the baseline's values at its fit on every sample, the
    effect's start values, then each of the effect's other starts."""
    from cosim.compile import lower
    from cosim.diagnose.job import load_records

    job = task["job"]
    effect = _effect(task["effect"])
    model = lower(task["variant_path"], task["variant_model"])
    records = load_records(job, model)
    defaults = dict(zip([p.name for p in model.parameters], model.parameter_values))
    free = dict(task["baseline"])
    for p in effect.parameters:
        start = p.start if isinstance(p.start, (int, float)) else \
            free[p.start][0] if p.start in free else job.fixed.get(p.start, defaults[p.start])
        free[p.name] = (float(np.clip(start, p.lower, p.upper)), p.lower, p.upper)
    for name, lo, hi in effect.frees:
        free[name] = (float(np.clip(job.fixed.get(name, defaults[name]), lo, hi)), lo, hi)
    trials = [free] + [{**free, p.name: (float(np.clip(v, p.lower, p.upper)), p.lower, p.upper)}
                       for p in effect.parameters for v in p.starts]
    return model, records, trials


def _fit_candidate(task):
    """One fit in a worker (a candidate's variant, or the baseline itself for ``effect = "baseline"``) on one
    fold's training segments, from the task's ``start`` (the screen's best start) or else the best of every
    start; replays every sample."""
    model, records, trials = _candidate(task)
    trials = [task["start"]] if task.get("start") else trials
    fits = [_fit(model, records, task["job"], trial, task["weights"], task["mask"], task["effect"])
            for trial in trials]
    return min(fits, key=lambda fit: fit["chi2"])


def _screen_candidate(task):
    """One candidate screened in a worker: the linearised fit (:func:`~cosim.diagnose.fitting.linearised_fit`)
    from each of its starts on every cost sample, the baseline's columns from its fit; the best start's."""
    model, records, trials = _candidate(task)
    screens = []
    for trial in trials:
        replay, measured = _replay(model, records, task["job"], trial)
        screen = linearised_fit(replay, measured, task["weights"], task["mask"], [v[0] for v in trial.values()],
                                ([v[1] for v in trial.values()], [v[2] for v in trial.values()]), task["columns"])
        screens.append({**screen, "start": trial})
    return min(screens, key=lambda screen: screen["predicted"])


def _replay(model, records, job, free):
    """The replay of every record varying the ``free`` parameters (name -> (start, lo, hi)), each record with its
    trial's fixed values, and the measured channels end to end."""
    starts = [v[0] for v in free.values()]
    kind = FrequencyReplay if job.kind == "frequency" else Replay
    replay = Trials([kind(model, e, [o for o, _, _ in job.signals], list(free), _scales(starts),
                          fixed={**job.fixed, **trial}, rtol=job.rtol) for e, trial in records])
    return replay, np.hstack([e.measured.T for e, _ in records])


def _fit(model, records, job, free, weights, mask, label):
    """Fit the ``free`` parameters (name -> (start, lo, hi)) on ``mask`` over every record (from
    :func:`~cosim.diagnose.job.load_records`), each replayed with its trial's fixed values."""
    replay, measured = _replay(model, records, job, free)
    result = fit_samples(replay, measured, weights, mask, [v[0] for v in free.values()],
                         ([v[1] for v in free.values()], [v[2] for v in free.values()]), max_nfev=job.max_nfev)
    result["label"] = label
    result["free"] = {n: list(v) for n, v in free.items()}
    return result


def _run_tasks(job, tasks, progress, function=_fit_candidate, desc="candidate effects"):
    if job.workers <= 0 or len(tasks) <= 1 and not job.scheduler:
        return [function(t) for t in tasks]
    return map_on_dask(function, tasks, job.scheduler, max_workers=job.workers, desc=desc, progress=progress)


def _free_at(job, fit):
    """The job's free baseline parameters (name -> (start, lo, hi)) starting at their values in ``fit``."""
    return {n: (fit["parameters"][n], lo, hi) for n, (_, lo, hi) in job.free.items()}


def _restart_baseline(job, groups, weights, progress):
    """For each (fit, mask, starts) of ``groups`` (a baseline fit on ``mask`` and fits whose values of the
    baseline's free parameters start refits of it), the best of the fit and its refits; the refits of every group
    run in parallel."""
    tasks = [{"job": job, "effect": "baseline", "variant_path": str(job.source), "variant_model": job.model,
              "baseline": {}, "weights": weights, "mask": mask, "start": _free_at(job, other), "group": g}
             for g, (_, mask, starts) in enumerate(groups) for other in starts]
    best = [fit for fit, _, _ in groups]
    for task, refit in zip(tasks, _run_tasks(job, tasks, progress, desc="baseline restarts")):
        if refit["chi2"] < best[task["group"]]["chi2"]:
            best[task["group"]] = refit
    return best


def _ms(pred, measured, weights, mask):
    """Mean square of the weighted residual on ``mask`` (1 = at the noise level)."""
    r = weighted(pred - measured, weights)
    return float(np.mean(r[:, mask] ** 2)) if mask.any() else float("nan")


def _rmse(pred, measured, mask):
    r = (pred - measured)[:, mask]
    return [float(np.sqrt(np.mean(x ** 2))) for x in r], [float(np.max(np.abs(x))) for x in r]


# -- stage 0: the samples -------------------------------------------------------------------------------------------

def _spread(where, values):
    """A boolean array over all instants: ``values`` at those ``where`` selects (a record's sampled instants),
    False elsewhere."""
    out = np.zeros(len(where), bool)
    out[where] = values
    return out


def _end_to_end(records):
    """The records (from :func:`~cosim.diagnose.job.load_records`) as one Experiment, each record's time shifted to
    start ten samples after the previous one ends (the gap keeps noise differences and segments inside a record);
    returns it and the shift of each record [s]. One record is returned as it is."""
    if len(records) == 1:
        return records[0][0], [0.0]
    shifts, end = [], 0.0
    for r, _ in records:
        shifts.append(end - r.time[0] if shifts else 0.0)
        end = shifts[-1] + r.time[-1] + 10 * float(np.median(np.diff(r.time)))
    parts = [r for r, _ in records]
    return Experiment(time=np.concatenate([r.time + shift for r, shift in zip(parts, shifts)]),
                      inputs=np.vstack([r.inputs for r in parts]), measured=np.vstack([r.measured for r in parts]),
                      weights=parts[0].weights, mask=np.concatenate([r.mask for r in parts])), shifts


def _per_record(records, f):
    """``f`` of each record's Experiment, end to end."""
    return np.concatenate([f(r) for r, _ in records])


def _channels(job, model):
    """Names, units and noise floors of the compared channels: the job's signals, or for a frequency response
    the magnitude [dB] and phase [deg] of its one output (the phase floor: the same complex-log error)."""
    if job.kind == "frequency":
        output, _, floor = job.signals[0]
        ratio = f"{output}/{job.input}"
        return [f"magnitude {ratio}", f"phase {ratio}"], ["dB", "deg"], [floor, floor * DEG_PER_DB]
    units = [model.outputs[model.index("outputs", o)].unit for o, _, _ in job.signals]
    return [o for o, _, _ in job.signals], units, [n for _, _, n in job.signals]


def load_samples(job):
    """The job's baseline lowered and its records end to end, with the cost samples: a staircase's settled end of
    each hold (``steady_s`` > 0), else every instant where each compared channel has a sample.

    Raises
    ------
    cosim.errors.ConfigError
        When no hold lasts ``experiment.steady_s``.
    """
    from cosim.compile import lower
    from cosim.diagnose.job import load_records

    model = lower(job.source, job.model)
    records = load_records(job, model)
    e, shifts = _end_to_end(records)
    # per record, the instants where every compared channel has a sample (multi-rate data are compared there; the
    # inputs are played at every instant)
    sampled = [np.all(np.isfinite(r.measured), axis=1) for r, _ in records]
    channels, units, floor = _channels(job, model)
    present = np.concatenate(sampled)
    if job.kind == "staircase" and job.steady_s > 0:
        mask = present & _per_record(records, lambda r: steady_mask(r.time, r.inputs, job.steady_s, job.min_hold_s))
    else:
        mask = present
    if not mask.any():
        from cosim.errors import ConfigError
        raise ConfigError(f"{job.path}: no hold of the input lasts experiment.steady_s = {job.steady_s:g} s")
    return Samples(model=model, records=records, experiment=e, shifts=shifts, sampled=sampled, present=present,
                   mask=mask, channels=channels, units=units, floor=np.array(floor))


# -- stage 1: the noise ---------------------------------------------------------------------------------------------

def estimate_noise(job, samples):
    """The noise level of each channel: from differences inside the steady windows of a staircase, inside the
    approach and steady hold of each impact, or of neighbouring frequencies (shaped by the coherence), floored by
    the job's stated noise."""
    s, floor = samples, samples.floor
    if job.kind == "frequency":  # per frequency, shaped by the coherence
        sigma, estimated = frequency_noise(s.experiment, floor)
        return Noise(estimated=estimated, floor=floor, sigma=sigma)
    t, y = s.time, s.measured
    estimated = noise_level(t, y, s.present & _per_record(s.records, lambda r: steady_mask(
        r.time, r.inputs, job.steady_s or 0.2, job.min_hold_s)) if job.kind == "staircase" else s.mask)
    if job.kind == "impact":  # from every sample first, then from the approach and steady hold of each record
        rough = max(estimated[0], floor[0])
        quiet = np.concatenate([_spread(p, quiet_phases(r.time[p], r.measured[p, 0], rough))
                                for (r, _), p in zip(s.records, s.sampled)])
        if (s.mask & quiet).sum() >= MIN_QUIET_SAMPLES:
            estimated = noise_level(t, y, s.mask & quiet)
    return Noise(estimated=estimated, floor=floor, sigma=np.maximum(estimated, floor))


# -- stage 2: segments and folds ------------------------------------------------------------------------------------

def split_segments(job, samples, noise):
    """The segments (each record cut into its own, labelled by record for repeated trials) and the two folds: fit
    on the even segments and score on the odd ones, and back (alternate samples when a fold would be empty)."""
    s = samples
    t, mask = s.time, s.mask
    if job.kind == "frequency":
        segments, shape = frequency_bands(t, s.measured[0], job.bands_per_decade), band_shape
    else:
        segments, shape = [], None
        for k, ((r, _), shift, p) in enumerate(zip(s.records, s.shifts, s.sampled)):
            for piece in cut_segments(r.time[p], r.inputs[p], job.kind, r.measured[p, 0], noise.sigma[0],
                                      job.min_hold_s):
                segments.append(replace(piece, index=len(segments), t0=piece.t0 + shift, t1=piece.t1 + shift,
                                        label=piece.label if len(s.records) == 1 else
                                        f"record {k} ({job.records[k][0].name}): {piece.label}"))
    seg_index = np.full(len(t), -1)
    for seg in segments:
        seg_index[in_segment(t, seg)] = seg.index
    folds = [(mask & (seg_index % 2 == 0), mask & (seg_index % 2 == 1)),
             (mask & (seg_index % 2 == 1), mask & (seg_index % 2 == 0))]
    if not all(train.any() and test.any() for train, test in folds):
        even = np.arange(len(t)) % 2 == 0
        folds = [(mask & even, mask & ~even), (mask & ~even, mask & even)]
    return Split(segments=segments, shape=shape, folds=folds)


# -- stage 3: the candidates' scores ------------------------------------------------------------------------------

def _screen(job, samples, weights, base, folder, progress):
    """Every candidate screened from the baseline's fit on every cost sample (variants written into ``folder``):
    the chi-square one bounded Gauss-Newton step predicts from each of its starts, the baseline's Jacobian
    columns taken from its fit and the effect's by forward differences (a score test of the nested effect: a
    replay per start and per effect parameter, no fit); returns effect -> screen (:class:`Scores`) and the fold
    tasks of every candidate from its best start, best predicted BIC first."""
    base_free = _free_at(job, base)
    tasks = []
    for name in job.effects:
        path, variant = _write_variant(job, name, folder / name)
        tasks.append({"job": job, "effect": name, "variant_path": str(path), "variant_model": variant,
                      "baseline": base_free, "weights": weights, "mask": samples.mask,
                      "columns": {n: base["columns"][n] for n in job.free}})
    results = _run_tasks(job, tasks, progress, _screen_candidate, "screening candidates")
    screen = {task["effect"]: {"chi2": r["chi2"], "predicted": r["predicted"],
                               "delta_bic": base["chi2"] - r["predicted"]
                               - len(_added_parameters(task["effect"])) * np.log(samples.n_fit)}
              for task, r in zip(tasks, results)}
    for entry in screen.values():
        entry["refitted"] = False
    ranked = sorted(zip(tasks, results), key=lambda pair: -screen[pair[0]["effect"]]["delta_bic"])
    return screen, [{**task, "start": r["start"]} for task, r in ranked]


def _fold_fits(job, samples, weights, folds, base, candidates, progress, fits=None):
    """The baseline and the ``candidates`` (fold tasks from :func:`_screen`) fitted on each fold's training
    samples, the baseline restarted from candidates that beat it and stalled candidates from the baseline;
    returns the fits ("baseline" and each candidate -> [fold 0, fold 1]) and ``base``, refitted when a restart
    moved a fold's baseline. The ``fits`` of an earlier call are kept, and its baseline's fold fits reused."""
    results = {name: list(pair) for name, pair in (fits or {}).items()}
    tasks = [] if "baseline" in results else [
        {"job": job, "effect": "baseline", "variant_path": str(job.source), "variant_model": job.model,
         "baseline": _free_at(job, base), "weights": weights, "mask": train, "fold": f}
        for f, (train, _) in enumerate(folds)]
    tasks += [{**task, "mask": train, "fold": f} for task in candidates for f, (train, _) in enumerate(folds)]
    names = [task["effect"] for task in candidates]
    for task, res in zip(tasks, _run_tasks(job, tasks, progress)):
        results.setdefault(task["effect"], [None, None])[task["fold"]] = res
    # A candidate contains the baseline, so its fit may find values of the baseline's parameters that the
    # baseline's own fit missed (an impact's cost is rough: the held force jumps with where the motor sticks).
    # The baseline is refitted from the values of every candidate that beats it by more than min_delta_bic on
    # the same samples, so that no candidate wins by a better start.
    restarted = _restart_baseline(job, [(fit, train, [results[n][f] for n in names if results[n][f]["chi2"] <
                                                     fit["chi2"] - job.min_delta_bic])
                                        for f, (fit, (train, _)) in enumerate(zip(results["baseline"], folds))],
                                  weights, progress)
    moved = [new for new, old in zip(restarted, results["baseline"]) if new is not old]
    results["baseline"] = restarted
    # The other way round: a candidate fitting a fold worse than the (restarted) baseline stalled (a
    # step in the effect's parameter can stall the trust region while the baseline's parameters still had
    # far to go). It is refitted from the baseline's values on that fold.
    stalled = [{**task, "start": {**task["start"], **_free_at(job, results["baseline"][task["fold"]])}}
               for task in tasks if task["effect"] != "baseline"
               and results[task["effect"]][task["fold"]]["chi2"] > results["baseline"][task["fold"]]["chi2"]]
    for task, retry in zip(stalled, _run_tasks(job, stalled, progress)):
        if retry["chi2"] < results[task["effect"]][task["fold"]]["chi2"]:
            results[task["effect"]][task["fold"]] = retry
    if moved:
        base = _restart_baseline(job, [(base, samples.mask, moved)], weights, progress)[0]
    return results, base


def _score(job, samples, weights, folds, fits):
    """Each candidate against the baseline: the fraction of the baseline's held-out gap above the noise it removes
    (each cost sample predicted by the fold's fit that did not see it), information criteria and a
    likelihood-ratio test on the summed training chi-square."""
    y, n_fit = samples.measured, samples.n_fit

    def pooled(pair):
        r = np.concatenate([weighted(fit["predicted"] - y, weights)[:, test].ravel()
                            for fit, (_, test) in zip(pair, folds)])
        return r, sum(fit["chi2"] for fit in pair)

    k_base = len(job.free)
    r_b, chi2_b = pooled(fits["baseline"])
    ms_b_test = float(np.mean(r_b ** 2))
    candidates = []
    for name in [n for n in job.effects if n in fits]:
        pair = fits[name]
        k = len(pair[0]["free"])
        r_c, chi2_c = pooled(pair)
        ms_c = float(np.mean(r_c ** 2))
        removed = (ms_b_test - ms_c) / max(ms_b_test - 1.0, 1e-12) if ms_b_test > 1.0 else 0.0
        delta = chi2_b - chi2_c
        heldout = np.concatenate([(fit["predicted"] - y)[0, test] for fit, (_, test) in zip(pair, folds)])
        candidates.append(Candidate(
            effect=name, score=float(removed),
            rmse_after=float(np.sqrt(np.mean(heldout ** 2))), max_error_after=float(np.max(np.abs(heldout))),
            parameters=dict(pair[0]["parameters"]), parameters_other_fold=dict(pair[1]["parameters"]),
            added_parameters=_added_parameters(name),
            heldout_ms_sigma2=ms_c, aic=chi2_c + 2 * k, bic=chi2_c + k * np.log(n_fit),
            delta_aic=float(delta - 2 * (k - k_base)), delta_bic=float(delta - (k - k_base) * np.log(n_fit)),
            p_value=float(stats.chi2.sf(max(delta, 0.0), max(k - k_base, 1))), free=pair[0]["free"]))
    return tuple(candidates)


def score_candidates(job, samples, noise, split, base, folder, progress=True):
    """Screen every candidate from the baseline's fit, fit the baseline and the best few on each fold and score
    them on the held-out folds (variants written into ``folder``), the next few in the screen's order while the
    baseline's gap stays unexplained; no candidates: no fits."""
    if not job.effects:
        return Scores(base=base, fits={}, candidates=())
    screen, ranked = _screen(job, samples, noise.weights, base, folder, progress)
    fits = None
    while ranked:
        batch, ranked = ranked[:REFIT_BEST], ranked[REFIT_BEST:]
        fits, base = _fold_fits(job, samples, noise.weights, split.folds, base, batch, progress, fits)
        for task in batch:
            screen[task["effect"]]["refitted"] = True
        scores = Scores(base=base, fits=fits, candidates=_score(job, samples, noise.weights, split.folds, fits),
                        screen=screen)
        decision = decide(job, samples, noise, split, scores)
        if not decision.gap_found or decision.winner is not None:
            break
    return scores


# -- stage 4: the decision ----------------------------------------------------------------------------------------

def rivals_of(winner, qualified):
    """The qualified candidates the held-out data cannot tell from the winner: a score within 0.1 of its score
    *and* a held-out mean square (noise units) within 1.5 times its own. The score alone says too little when
    the baseline's gap is large: 0.1 of a gap of 180 noise levels squared is a candidate leaving 7 times the
    winner's residual (a jaw friction mimicking a larger gear play on an impact: RMSE 1.23 N against 0.46 N)."""
    if winner is None:
        return []
    return [c.effect for c in qualified if c is not winner and c.score >= winner.score - 0.1
            and c.heldout_ms_sigma2 <= 1.5 * winner.heldout_ms_sigma2]


def decide(job, samples, noise, split, scores):
    """Locate the baseline's gap (segment table, shapes, whiteness, cross-correlation with the input) and name the
    winner: the best-scoring candidate that removes ``min_gap_removed`` of the held-out gap and improves BIC by
    ``min_delta_bic``, when the baseline shows a gap (a significant segment *and* a whole residual beyond chance);
    else none."""
    s = samples
    t, y, mask, sigma = s.time, s.measured, s.mask, noise.sigma
    before = scores.base["predicted"]
    residual = before - y
    rows = segment_table(t, residual, before, y, mask, split.segments, sigma, job.gap_sigmas, split.shape)
    cross = None if job.kind == "frequency" else cross_correlation(residual[0, mask], s.experiment.inputs[mask, 0])
    # a gap is a segment above gap_sigmas noise levels *and* a baseline whose whole residual is more than noise:
    # its mean square (in noise units) must exceed 1 by more than gap_sigmas times the sqrt(2/n) a mean of n
    # squared unit noises scatters by (a lone segment at 3 sigma is also what noise gives over many segments)
    ms_baseline, chance = _ms(before, y, noise.weights, mask), 1.0 + job.gap_sigmas * np.sqrt(2.0 / s.n_fit)
    gap_found = any(r["significant"] for r in rows) and bool(ms_baseline > chance)
    qualified = [c for c in scores.candidates if gap_found and c.score >= job.min_gap_removed
                 and c.delta_bic >= job.min_delta_bic]
    winner = max(qualified, key=lambda c: (c.score, c.delta_bic)) if qualified else None
    rivals = rivals_of(winner, qualified)
    return Decision(rows=rows, shapes=branch_shapes(split.segments, rows, sigma),
                    whiteness=whiteness(residual[0, mask]), cross_correlation=cross, mean_square=ms_baseline,
                    chance=chance, gap_found=gap_found, winner=winner, rivals=rivals,
                    outcome=_outcome(gap_found, winner, ms_baseline > chance), gap_levels=float(np.sqrt(max(ms_baseline, 0.0))),
                    where=gap_locations(rows),
                    plausible=plausible(scores.candidates, winner, rivals, gap_found, job.min_gap_removed))


def _outcome(gap_found, winner, above_chance):
    """What the decision says: an effect named, a gap no candidate explains, a residual above chance with no
    segment significant (a diffuse gap: nothing to locate), or a baseline within the noise."""
    if winner is not None:
        return "named"
    return "unexplained gap" if gap_found else "diffuse gap" if above_chance else "within noise"


# -- stage 5: the show ----------------------------------------------------------------------------------------------

@contextmanager
def _build_folder(out):
    """Where the FMUs and the re-run configs go: ``out``, or without it a new folder the result points to (removed
    when the build fails)."""
    if out is not None:
        yield Path(out)
        return
    folder = Path(tempfile.mkdtemp(prefix="cosim-diagnose-"))
    try:
        yield folder
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise


def _final_fit(job, samples, noise, winner, path, variant):
    """The winner's variant refitted on every cost sample, from the mean of its two folds' values (and from each
    fold's when they found different minima, in parallel); the best fit."""
    folds_fit = (winner.parameters, winner.parameters_other_fold)
    starts = [{n: 0.5 * (folds_fit[0][n] + folds_fit[1][n]) for n in folds_fit[0]}]
    if any(abs(folds_fit[0][n] - folds_fit[1][n]) > 0.1 * abs(starts[0][n]) for n in folds_fit[0]):
        starts += folds_fit  # the folds found different minima: their mean may lie in neither basin
    tasks = [{"job": job, "effect": winner.effect, "variant_path": str(path), "variant_model": variant,
              "baseline": {}, "weights": noise.weights, "mask": samples.mask,
              "start": {n: (v, *winner.free[n][1:]) for n, v in start.items()}} for start in starts]
    return min(_run_tasks(job, tasks, False, desc="final fit"), key=lambda fit: fit["chi2"])


def _rerun_both(job, samples, base, final, variant_path, variant, folder):
    """Build the baseline's and the winner's FMUs into ``folder/fmu`` and re-run both through the master with the
    measured inputs of every record (:mod:`cosim.diagnose.rerun`, configs in ``folder/rerun``, in
    ``folder/rerun/record<k>`` for repeated trials); returns the :class:`Rerun` and the winner's FMU."""
    from cosim.compile import build_fmu
    from cosim.diagnose.rerun import rerun

    s = samples
    outputs = [o for o, _, _ in job.signals]
    inputs = [u.name for u in s.model.inputs]
    fmus = {"baseline": build_fmu(job.source, job.model, out_dir=folder / "fmu"),
            final["label"]: build_fmu(variant_path, variant, out_dir=folder / "fmu")}
    fits = {"baseline": base, final["label"]: final}
    folders = [folder / "rerun"] if len(s.records) == 1 else \
        [folder / "rerun" / f"record{k}" for k in range(len(s.records))]
    replayed = [rerun({label: (fmus[label], {**job.fixed, **trial, **fit["parameters"]})
                       for label, fit in fits.items()}, e, inputs, outputs, where, job.rtol)
                for (e, trial), where in zip(s.records, folders)]
    entry = {"configs": {}}
    for label, fit in fits.items():
        predicted = np.hstack([r[label] for r in replayed])
        rmse, max_error = _rmse(predicted, s.measured, s.mask)
        key = "before" if label == "baseline" else "after"
        entry[f"rmse_{key}"], entry[f"max_error_{key}"] = rmse[0], max_error[0]
        entry[f"max_difference_to_replay_{key}"] = float(np.max(np.abs(predicted - fit["predicted"])[0, s.mask]))
        entry["configs"][label] = str((folders[0] if len(folders) == 1 else folder / "rerun" / "record*")
                                      / f"{label}.toml")
    return Rerun(how=RERUN_HOW, signal=outputs[0], **entry), str(fmus[final["label"]])


def show(job, samples, noise, scores, decision, folder, build=True, out=None):
    """Add the winner: write its variant (into ``folder``), refit it on every cost sample, diff it against the
    baseline's source and, with ``build``, build its FMU (and for a time series the baseline's) and re-run both
    through the master, into ``out`` (without it, a new folder the result points to)."""
    winner = decision.winner
    if winner is None:
        return Show(final=None, after=scores.base["predicted"])
    path, variant = _write_variant(job, winner.effect, folder / "winner")
    final = _final_fit(job, samples, noise, winner, path, variant)
    variant_source = path.read_text(encoding="utf-8")
    variant_diff = "".join(difflib.unified_diff(
        Path(job.source).read_text(encoding="utf-8").splitlines(keepends=True),
        variant_source.splitlines(keepends=True), fromfile=str(job.source), tofile=f"{job.source} ({winner.effect})"))
    fmu, rerun = None, None
    if build:
        with _build_folder(out) as target:
            if job.kind == "frequency":  # a frequency response is not a time series the master could replay
                from cosim.compile import build_fmu

                fmu = str(build_fmu(path, variant, out_dir=target / "fmu"))
            else:
                rerun, fmu = _rerun_both(job, samples, scores.base, final, path, variant, target)
    return Show(final=final, after=final["predicted"], fmu=fmu, variant_source=variant_source,
                variant_diff=variant_diff, rerun=rerun)


# -- the result -----------------------------------------------------------------------------------------------------

def _verdict(job, decision, segments=(), ms_after=0.0):
    """The first line of the answer: the effect named (and, when a gap remains after it by the rule that finds
    the baseline's, that gap), the gap no candidate explains (its size and where it is largest), or a baseline
    within the noise; ``segments``: the :class:`SegmentRow` table before and after the winner, ``ms_after``: the
    winner's mean square in noise levels squared."""
    if decision.winner is not None:
        named = f"missing effect: {decision.effect} ({_title(decision.effect)})"
        left = _left_after(segments)
        if not left or ms_after <= decision.chance:
            return named
        top = left[0]
        return (f"{named}; after it, a gap of {np.sqrt(ms_after):.1f} noise levels remains that no effect in the "
                f"library explains (largest in {top.segment}, {_span(job, top.t0, top.t1)}: "
                f"{_levels_after(top):.1f} noise levels): it explains part of the gap, the rest needs another effect "
                "or a model of another form")
    if decision.gap_found:
        top = decision.where[0]
        return (f"a gap of {decision.gap_levels:.1f} noise levels remains that no effect in the library explains "
                f"(largest in {top['segment']}, {_span(job, top['t0'], top['t1'])}: {top['sigmas']:.1f} noise levels)")
    if decision.outcome == "diffuse gap":
        return (f"no effect named: a diffuse gap of {decision.gap_levels:.1f} noise levels RMS remains (mean square "
                f"{decision.mean_square:.3g} noise levels squared, chance up to {decision.chance:.3g}), with no "
                f"segment above {job.gap_sigmas:g} noise levels")
    return (f"no missing effect found: the baseline fits within the noise (mean square {decision.mean_square:.3g} "
            f"noise levels squared, chance up to {decision.chance:.3g}; segments above {job.gap_sigmas:g} noise "
            f"levels: {sum(r['significant'] for r in decision.rows)})")


def _segment_rows(samples, noise, split, job, rows, after):
    """The baseline's segment table beside the winner's (``after``: its replay)."""
    s = samples
    rows_after = segment_table(s.time, after - s.measured, after, s.measured, s.mask, split.segments, noise.sigma,
                               job.gap_sigmas, split.shape)
    return tuple(SegmentRow(**{k: rb[k] for k in ("segment", "kind", "t0", "t1", "level", "samples", "significant",
                                                  "shape", "sigmas")},
                            signal=s.channels[rb["signal"]], bias_before=rb["bias"], rmse_before=rb["rmse"],
                            max_error_before=rb["max_error"], bias_after=ra["bias"], rmse_after=ra["rmse"],
                            max_error_after=ra["max_error"], significant_after=ra["significant"])
                 for rb, ra in zip(rows, rows_after))


def _diagnosis(job, samples, noise, split, scores, decision, shown, advice=()):
    """The stages' results as a :class:`Diagnosis`, with the answer a user acts on (:func:`answer`)."""
    s, base, final = samples, scores.base, shown.final
    y, mask, model, frequency = s.measured, s.mask, s.model, job.kind == "frequency"
    rmse_before, max_before = _rmse(base["predicted"], y, mask)
    rmse_after, max_after = _rmse(shown.after, y, mask)
    ms_after, ms_baseline = _ms(shown.after, y, noise.weights, mask), decision.mean_square
    segments = _segment_rows(s, noise, split, job, decision.rows, shown.after)
    gap_removed = float(1 - (ms_after - 1) / (ms_baseline - 1)) if ms_baseline > 1 else 0.0
    evidence, next_step = answer(job, s, decision, advice, segments, ms_after, gap_removed, scores.candidates)
    return Diagnosis(
        job=str(job.path), model=job.model, data=str(job.data_path),
        records=tuple(RecordSummary(path=str(path), parameters=trial, samples=len(r.time), compared=int(p.sum()),
                                    time_shift=shift)
                      for (path, trial), (r, _), shift, p in zip(job.records, s.records, s.shifts, s.sampled)),
        effect=decision.effect, verdict=_verdict(job, decision, segments, ms_after),
        also_explained_by=decision.rivals,
        kind=job.kind, signals=s.channels, units=s.units,
        inputs=[] if frequency else [u.name for u in model.inputs],
        input_units=[] if frequency else [u.unit for u in model.inputs],
        parameter_units={**{p.name: p.unit for p in model.parameters}, **_effect_units(job.effects)},
        noise=noise, rmse_before_per_signal=rmse_before, rmse_after_per_signal=rmse_after,
        max_error_before=max_before[0], max_error_after=max_after[0],
        gap_removed=gap_removed,
        baseline_parameters=base["parameters"], baseline_free={n: list(v) for n, v in job.free.items()},
        after_parameters=final["parameters"] if final else None, fmu=shown.fmu, rerun=shown.rerun,
        segments=segments,
        gap_found=decision.gap_found, baseline_mean_square=ms_baseline, shapes=decision.shapes,
        whiteness=decision.whiteness, input_cross_correlation=decision.cross_correlation,
        fold_samples=[int(train.sum()) for train, _ in split.folds],
        decision={"min_gap_removed": job.min_gap_removed, "min_delta_bic": job.min_delta_bic,
                  "gap_sigmas": job.gap_sigmas, "mean_square_chance": decision.chance},
        candidates=tuple(sorted(scores.candidates, key=lambda c: -c.score)),
        traces=Traces(time=s.time, inputs=np.zeros((len(s.time), 0)) if frequency else s.experiment.inputs,
                      measured=y, before=base["predicted"], after=shown.after, mask=mask,
                      candidate_predictions={name: pair[0]["predicted"] for name, pair in scores.fits.items()}),
        variant_source=shown.variant_source, variant_diff=shown.variant_diff,
        outcome=decision.outcome, gap={"noise_levels": decision.gap_levels, "where": list(decision.where),
                                       "remaining_noise_levels": float(np.sqrt(max(ms_after, 0.0)))},
        not_identifiable=list(advice), evidence=evidence, next_step=next_step)


def run_diagnosis(job, progress=True, build=True, out=None):
    """Run the workflow on a loaded job.

    Parameters
    ----------
    job : cosim.diagnose.job.DiagnoseJob
    progress : bool, default True
        Progress bar over the candidate fits.
    build : bool, default True
        Build the winner's FMU (for a time series also the baseline's) and re-run both through the master.
    out : str or Path, optional
        Where the built FMUs (``out/fmu``) and the re-run configs (``out/rerun``) go; without it, a new folder
        the result's ``fmu`` and ``rerun.configs`` name.

    Returns
    -------
    Diagnosis

    Raises
    ------
    cosim.errors.ConfigError
        When no hold of a staircase lasts ``experiment.steady_s``.
    """
    samples = load_samples(job)
    noise = estimate_noise(job, samples)
    base = _fit(samples.model, samples.records, job, dict(job.free), noise.weights, samples.mask, "baseline")
    split = split_segments(job, samples, noise)
    with tempfile.TemporaryDirectory(prefix="cosim-diagnose-") as scratch:  # the variants' Modelica packages
        scores = score_candidates(job, samples, noise, split, base, Path(scratch), progress)
        decision = decide(job, samples, noise, split, scores)
        shown = show(job, samples, noise, scores, decision, Path(scratch), build, out)
        advice = advise(job, samples, noise, split, scores, decision, Path(scratch))
    return _diagnosis(job, samples, noise, split, scores, decision, shown, advice)


# -- the answer a user acts on -------------------------------------------------------------------------------------

def advise(job, samples, noise, split, scores, decision, folder):
    """The plausible effects the data cannot identify (:func:`~cosim.diagnose.advice.plausible`, at most
    ``MAX_ADVISED``), each with why, its change on the data given and on the experiment that shows it
    (:func:`~cosim.diagnose.advice.change_on`, variants written into ``folder``); a list of dicts."""
    segments = [in_segment(samples.time, seg) for seg in split.segments]
    base = scores.fits["baseline"][0]["predicted"] if scores.fits else scores.base["predicted"]
    out = []
    for c in decision.plausible[:MAX_ADVISED]:
        why = (f"the held-out segments do not tell it from {decision.effect}" if decision.winner is not None else
               f"it removes {100 * c.score:.0f} % of the held-out gap (naming needs {100 * job.min_gap_removed:.0f} "
               f"%) with ΔBIC {c.delta_bic:.1f} (needs {job.min_delta_bic:g})")
        here = change_here(scores.fits[c.effect][0]["predicted"], base, noise.weights, samples.mask, segments)
        values = {n: c.parameters[n] for n in c.added_parameters if n in c.parameters}
        shown = change_on(c.effect, values, scores.base["parameters"], folder / f"advice_{c.effect}",
                          this=(job.kind, job.model))
        out.append({"effect": c.effect, "title": _title(c.effect), "why": why, "score": c.score,
                    "delta_bic": c.delta_bic, "parameters": values, "change_here": here, "shown_by": shown})
    return out


def _span(job, t0, t1):
    """A segment's extent (from ``t0`` to ``t1``) as words: time for a time series, frequency for a frequency
    response."""
    if job.kind == "frequency":
        return f"{t0:.3g}-{t1:.3g} Hz"
    return f"t = {t0:.4g}-{t1:.4g} s"


def _shows(entry):
    """The experiment that would show an advised effect and its computed change there, as words."""
    shown = entry["shown_by"]
    text = f"{entry['effect']}: {shown['experiment']}"
    if shown["job"]:
        text += f" (`{Path(shown['job']).name}`)"
    if shown["computed"]:
        return (text + f", where at the size fitted here it changes {shown['signal']} by {shown['rms']:.3g} RMS, "
                f"{shown['max']:.3g} at most ({shown['rms_noise_levels']:.1f} and {shown['max_noise_levels']:.1f} "
                f"noise levels of that job)")
    return text + f" (change not computed: {shown['why']})"


def _left_after(segments):
    """The segments (:class:`SegmentRow`) still above the noise after the winner, largest residual first."""
    return sorted((r for r in segments if r.significant_after), key=_levels_after, reverse=True)


def _levels_after(row):
    """A segment's residual after the winner in noise levels (its noise level is rmse_before / sigmas; a segment
    the baseline fitted exactly, sigmas 0, gives no noise level and counts as 0)."""
    return row.rmse_after * row.sigmas / row.rmse_before if row.rmse_before > 0 else 0.0


def answer(job, samples, decision, advice, segments, ms_after, gap_removed, candidates=()):
    """The evidence behind the verdict and the next step, one paragraph each (the report's first lines);
    ``segments``: the :class:`SegmentRow` table before and after the winner, ``candidates``: the scored ones."""
    d, unit = decision, f" {samples.units[0]}" if samples.units and samples.units[0] else ""
    significant = sum(r["significant"] for r in d.rows)
    if d.winner is not None:
        w = d.winner
        left = _left_after(segments)
        evidence = (f"{w.effect} removes {100 * w.score:.0f} % of the baseline's gap on held-out segments "
                    f"(ΔBIC {w.delta_bic:.1f}); refitted on every segment it removes {100 * gap_removed:.0f} % of "
                    f"the gap above the noise ({d.gap_levels:.1f} -> {np.sqrt(max(ms_after, 0.0)):.1f} noise levels)")
        if left:
            evidence += (f"; {len(left)} segment(s) stay above {job.gap_sigmas:g} noise levels, largest "
                         f"{left[0].segment}")
        step = (f"add {w.effect} to the model: the variant is in OUT/modelica and OUT/variant.diff; calibrate it "
                f"with its parameters free")
        if advice:
            step += ". To tell it from " + "; ".join(_shows(a) for a in advice)
        return evidence, step
    if d.gap_found:
        best = max(candidates, key=lambda c: c.score, default=None)
        where = "; ".join(f"{w['segment']} ({_span(job, w['t0'], w['t1'])}): {w['sigmas']:.1f} noise levels, "
                          f"shape {w['shape']}, mean residual {w['bias']:+.3g}{unit}" for w in d.where[:3])
        evidence = (f"the baseline's residual is {d.gap_levels:.1f} noise levels RMS (mean square {d.mean_square:.3g}"
                    f", chance up to {d.chance:.3g}); {significant} of {len(d.rows)} segments above "
                    f"{job.gap_sigmas:g} noise levels: {where}")
        evidence += "" if best is None else (
            f"; the best candidate, {best.effect}, removes {100 * best.score:.0f} % of the held-out gap (naming "
            f"needs {100 * job.min_gap_removed:.0f} %) with ΔBIC {best.delta_bic:.1f} (needs {job.min_delta_bic:g})")
        if advice:
            step = ("plausible but not identifiable on these data: "
                    + "; ".join(f"{a['effect']} ({a['why']})" for a in advice)
                    + ". The experiment that would show it: " + "; ".join(_shows(a) for a in advice))
        else:
            step = ("the library lacks the physics of this gap: check the fixed parameters and the data where the "
                    "gap is largest, then write the effect as a candidate (docs/guide/diagnose.md, the effect "
                    "library) and run the diagnosis again")
        return evidence, step
    evidence = (f"mean square {d.mean_square:.3g} noise levels squared (chance up to {d.chance:.3g}); "
                f"{significant} of {len(d.rows)} segments above {job.gap_sigmas:g} noise levels")
    if d.outcome == "diffuse gap":
        return evidence, ("no segment stands out, so no effect can be located: the baseline's error is spread over "
                          "the record (a gain or a shape its free parameters miss); check the calibration, or "
                          "measure longer or with less noise until a segment exceeds the noise")
    return evidence, "nothing to add on these data: the baseline explains them to within the noise"
