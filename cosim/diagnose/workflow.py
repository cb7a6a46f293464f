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

In code, each step is a stage, a function returning a frozen dataclass (:mod:`cosim.diagnose.stages`) that the
next stages read: the samples (:class:`Samples`), the noise (:class:`Noise`), the segments and folds
(:class:`Split`), the candidates' scores (:class:`Scores`), the decision (:class:`Decision`) and the show
(:class:`Show`, :mod:`cosim.diagnose.show`); :func:`run_round` chains them into a :class:`Diagnosis`, whose
:meth:`Diagnosis.to_json` is the content of ``diagnosis.json``. What differs between experiment kinds (cost
samples, noise, segments, replay) is asked of the job's kind (:mod:`cosim.diagnose.kinds`); the fits run as
:class:`~cosim.diagnose.tasks.FitTask` records in the workers; the answer's words are in
:mod:`cosim.diagnose.answer`.
"""

from dataclasses import replace

import numpy as np
from scipy import stats

from cosim.diagnose.advice import MAX_ADVISED, change_here, change_on, gap_locations, plausible
from cosim.diagnose.analysis import branch_shapes, gap_shown, in_segment, rmse_per_signal, segment_table, whiteness
from cosim.diagnose.answer import answer, verdict, why_plausible
from cosim.diagnose.effects import EFFECTS, forms_not_offered
from cosim.diagnose.fitting import weighted
from cosim.diagnose.kinds import record_slices
from cosim.diagnose.result import Candidate, Diagnosis, ExperimentGap, RecordSummary, SegmentRow, Traces
from cosim.diagnose.show import show
from cosim.diagnose.stages import Decision, Samples, Scores, Split
from cosim.diagnose.tasks import (added_parameters, bic_penalty, fit_free, free_at, run_tasks, screen_task, task_of,
                                  variant_of)
from cosim.experiment import Experiment
from cosim.parallel import map_here
from cosim.tomldoc import read_text

__all__ = ["load_samples", "estimate_noise", "split_segments",
           "score_candidates", "rivals_of", "decide", "show", "run_round", "advise", "experiment_gaps", "shown_by"]

# Candidates refitted on the folds after the screen (:func:`_screen`): the best and one rival. Fixed
# before any benchmark ran with the screen; not tuned to a case.
REFIT_BEST = 2


# -- fits ---------------------------------------------------------------------------------------------------------

def _restart_baseline(job, groups, weights, progress):
    """For each (fit, mask, starts) of ``groups`` (a baseline fit on ``mask`` and fits whose values of the
    baseline's free parameters start refits of it), the best of the fit and its refits; the refits of every group
    run in parallel."""
    tasks = [task_of(job, "baseline", weights, mask, start=free_at(job, other), group=g)
             for g, (_, mask, starts) in enumerate(groups) for other in starts]
    best = [fit for fit, _, _ in groups]
    for task, refit in zip(tasks, run_tasks(job, tasks, progress, desc="baseline restarts")):
        if refit.chi2 < best[task.group].chi2:
            best[task.group] = refit
    return best


def _ms(pred, measured, weights, mask):
    """Mean square of the weighted residual on ``mask`` (1 = at the noise level)."""
    r = weighted(pred - measured, weights)
    return float(np.mean(r[:, mask] ** 2)) if mask.any() else float("nan")


# -- stage 0: the samples -------------------------------------------------------------------------------------------

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


def load_samples(job):
    """The job's baseline lowered and its records end to end, with the cost samples the job's kind takes
    (:meth:`~cosim.diagnose.kinds.ExperimentKind.cost_mask`: a staircase's settled end of each hold, else every
    instant where each compared channel has a sample).

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
    channels, units, floor = job.kind.channels(job, model)
    present = np.concatenate(sampled)
    mask = job.kind.cost_mask(job, records, present)
    if not mask.any():
        from cosim.errors import ConfigError
        raise ConfigError(f"{job.path}: no hold of the input lasts experiment.steady_s = {job.steady_s:g} s")
    return Samples(model=model, records=records, experiment=e, shifts=shifts, sampled=sampled, present=present,
                   mask=mask, channels=channels, units=units, floor=np.array(floor))


# -- stage 1: the noise ---------------------------------------------------------------------------------------------

def estimate_noise(job, samples):
    """The noise level of each channel as the job's kind estimates it (from differences inside the steady windows
    of a staircase, inside the approach and steady hold of each impact, or of neighbouring frequencies), floored
    by the job's stated noise."""
    return job.kind.noise(job, samples)


# -- stage 2: segments and folds ------------------------------------------------------------------------------------

def split_segments(job, samples, noise):
    """The segments (the job's kind cuts them: holds, impact phases, frequency bands; each record into its own)
    and the two folds: fit on the even segments and score on the odd ones, and back (alternate samples when a
    fold would be empty)."""
    t, mask = samples.time, samples.mask
    segments, shape = job.kind.segments(job, samples, noise)
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
    replay per start and per effect parameter, no fit); returns effect -> :class:`~cosim.diagnose.fitting.Screen`
    and the fold tasks of every candidate from its best start, best predicted BIC first."""
    tasks = [task_of(job, name, weights, samples.mask, *variant_of(job, name, folder / name),
                   baseline=free_at(job, base), columns={n: base.columns[n] for n in job.free})
             for name in job.effects]
    screen = {r.effect: replace(r, delta_bic=base.chi2 - r.chi2_predicted - bic_penalty(r.effect, samples.n_fit))
              for r in run_tasks(job, tasks, progress, screen_task, "screening candidates")}
    ranked = sorted(tasks, key=lambda task: -screen[task.effect].delta_bic)
    return screen, [replace(task, start=screen[task.effect].start) for task in ranked]


def _fold_fits(job, samples, weights, folds, base, candidates, progress, fits=None):
    """The baseline and the ``candidates`` (fold tasks from :func:`_screen`) fitted on each fold's training
    samples, the baseline restarted from candidates that beat it and stalled candidates from the baseline;
    returns the fits ("baseline" and each candidate -> [fold 0, fold 1]) and ``base``, refitted when a restart
    moved a fold's baseline. The ``fits`` of an earlier call are kept, and its baseline's fold fits reused."""
    results = {name: list(pair) for name, pair in (fits or {}).items()}
    tasks = [] if "baseline" in results else [
        task_of(job, "baseline", weights, train, baseline=free_at(job, base), fold=f)
        for f, (train, _) in enumerate(folds)]
    tasks += [replace(task, mask=train, fold=f) for task in candidates for f, (train, _) in enumerate(folds)]
    names = [task.effect for task in candidates]
    for task, res in zip(tasks, run_tasks(job, tasks, progress)):
        results.setdefault(task.effect, [None, None])[task.fold] = res
    # A candidate contains the baseline, so its fit may find values of the baseline's parameters that the
    # baseline's own fit missed (an impact's cost is rough: the held force jumps with where the motor sticks).
    # The baseline is refitted from the values of every candidate that beats it by more than min_delta_bic on
    # the same samples, so that no candidate wins by a better start.
    restarted = _restart_baseline(job, [(fit, train, [results[n][f] for n in names if results[n][f].chi2 <
                                                     fit.chi2 - job.min_delta_bic])
                                        for f, (fit, (train, _)) in enumerate(zip(results["baseline"], folds))],
                                  weights, progress)
    moved = [new for new, old in zip(restarted, results["baseline"]) if new is not old]
    results["baseline"] = restarted
    # The other way round: a candidate fitting a fold worse than the (restarted) baseline stalled (a
    # step in the effect's parameter can stall the trust region while the baseline's parameters still had
    # far to go). It is refitted from the baseline's values on that fold.
    stalled = [replace(task, start={**task.start, **free_at(job, results["baseline"][task.fold])})
               for task in tasks if task.effect != "baseline"
               and results[task.effect][task.fold].chi2 > results["baseline"][task.fold].chi2]
    for task, retry in zip(stalled, run_tasks(job, stalled, progress)):
        if retry.chi2 < results[task.effect][task.fold].chi2:
            results[task.effect][task.fold] = retry
    if moved:
        base = _restart_baseline(job, [(base, samples.mask, moved)], weights, progress)[0]
    return results, base


def _score(job, samples, weights, folds, fits):
    """Each candidate against the baseline: the fraction of the baseline's held-out gap above the noise it removes
    (each cost sample predicted by the fold's fit that did not see it), information criteria and a
    likelihood-ratio test on the summed training chi-square."""
    y, n_fit = samples.measured, samples.n_fit

    def pooled(pair):
        r = np.concatenate([weighted(fit.outputs - y, weights)[:, test].ravel()
                            for fit, (_, test) in zip(pair, folds)])
        return r, sum(fit.chi2 for fit in pair)

    r_b, chi2_b = pooled(fits["baseline"])
    ms_b_test = float(np.mean(r_b ** 2))
    candidates = []
    for name in [n for n in job.effects if n in fits]:
        pair = fits[name]
        added = added_parameters(name)
        k = len(job.free) + len(added)
        r_c, chi2_c = pooled(pair)
        ms_c = float(np.mean(r_c ** 2))
        removed = (ms_b_test - ms_c) / max(ms_b_test - 1.0, 1e-12) if ms_b_test > 1.0 else 0.0
        delta = chi2_b - chi2_c
        heldout = np.concatenate([(fit.outputs - y)[0, test] for fit, (_, test) in zip(pair, folds)])
        candidates.append(Candidate(
            effect=name, score=float(removed),
            rmse_after=float(np.sqrt(np.mean(heldout ** 2))), max_error_after=float(np.max(np.abs(heldout))),
            parameters=dict(pair[0].parameters), parameters_other_fold=dict(pair[1].parameters),
            added_parameters=added, heldout_ms_sigma2=ms_c, aic=chi2_c + 2 * k, bic=chi2_c + k * np.log(n_fit),
            delta_aic=float(delta - 2 * len(added)), delta_bic=float(delta - bic_penalty(name, n_fit)),
            p_value=float(stats.chi2.sf(max(delta, 0.0), max(len(added), 1))), free=pair[0].free))
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
        screen.update({task.effect: replace(screen[task.effect], refitted=True) for task in batch})
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
    before = scores.base.outputs
    residual = before - y
    rows = segment_table(t, residual, before, y, mask, split.segments, sigma, job.gap_sigmas, split.shape)
    cross = job.kind.cross_correlation(residual[0, mask], s.experiment, mask)
    # chance: the mean square (noise units) must exceed 1 by more than gap_sigmas times the sqrt(2/n) a mean of n
    # squared unit noises scatters by (gap_shown: the rule, also for the gap a finding leaves)
    ms_baseline, chance = _ms(before, y, noise.weights, mask), 1.0 + job.gap_sigmas * np.sqrt(2.0 / s.n_fit)
    gap_found = gap_shown([r["significant"] for r in rows], ms_baseline, chance)
    qualified = [c for c in scores.candidates if gap_found and c.score >= job.min_gap_removed
                 and c.delta_bic >= job.min_delta_bic]
    winner = max(qualified, key=lambda c: (c.score, c.delta_bic)) if qualified else None
    rivals = rivals_of(winner, qualified)
    return Decision(rows=rows, shapes=branch_shapes(split.segments, rows),
                    whiteness=whiteness(residual[0, mask]), cross_correlation=cross, mean_square=ms_baseline,
                    chance=chance, gap_found=gap_found, winner=winner, rivals=rivals,
                    outcome=_outcome(gap_found, winner, ms_baseline > chance),
                    gap_levels=float(np.sqrt(max(ms_baseline, 0.0))),
                    where=gap_locations(rows),
                    plausible=plausible(scores.candidates, winner, rivals, gap_found, job.min_gap_removed))


def _outcome(gap_found, winner, above_chance):
    """What the decision says: an effect named, a gap no candidate explains, a residual above chance with no
    segment significant (a diffuse gap: nothing to locate), or a baseline within the noise."""
    if winner is not None:
        return "named"
    return "unexplained gap" if gap_found else "diffuse gap" if above_chance else "within noise"


# -- the result -----------------------------------------------------------------------------------------------------

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


def experiment_gaps(job, samples, noise, before, after):
    """For records of several experiments (``job.kind.parts``), each one's gap before and after (RMS weighted
    residual on its cost samples) and the chi-square ``after`` removes from it; empty for one experiment."""
    gaps = []
    for k, (part, cut) in enumerate(zip(job.kind.parts, record_slices(samples.records))):
        mask, weights, measured = samples.mask[cut], noise.weights[:, cut], samples.measured[:, cut]
        r_before, r_after = (weighted(y[:, cut] - measured, weights)[:, mask] for y in (before, after))
        gaps.append(ExperimentGap(name=part.name, kind=part.kind.name, samples=int(mask.sum()),
                                  noise=noise.parts[k].used, gap_before=float(np.sqrt(np.mean(r_before ** 2))),
                                  gap_after=float(np.sqrt(np.mean(r_after ** 2))),
                                  chi2_removed=float(np.sum(r_before ** 2) - np.sum(r_after ** 2))))
    return tuple(gaps)


def shown_by(gaps, min_delta_bic):
    """The experiments (:func:`experiment_gaps`) where a finding removes at least ``min_delta_bic`` of
    chi-square, the most first; the one it removes most from when none does."""
    ranked = sorted(gaps, key=lambda g: -g.chi2_removed)
    return tuple(g.name for g in ranked if g.chi2_removed >= min_delta_bic) or tuple(g.name for g in ranked[:1])


def _diagnosis(job, samples, noise, split, scores, decision, shown, advice=()):
    """The stages' results as a :class:`Diagnosis`, with the answer a user acts on (:func:`answer`)."""
    s, base, final = samples, scores.base, shown.final
    y, mask, model, time_series = s.measured, s.mask, s.model, job.kind.time_series
    rmse_before, max_before = rmse_per_signal(base.outputs, y, mask)
    rmse_after, max_after = rmse_per_signal(shown.after, y, mask)
    ms_after, ms_baseline = _ms(shown.after, y, noise.weights, mask), decision.mean_square
    segments = _segment_rows(s, noise, split, job, decision.rows, shown.after)
    gap_removed = float(1 - (ms_after - 1) / (ms_baseline - 1)) if ms_baseline > 1 else 0.0
    gaps = experiment_gaps(job, s, noise, base.outputs, shown.after)
    where = shown_by(gaps, job.min_delta_bic) if gaps and decision.winner is not None else ()
    source, user_model = job.user_model
    left = forms_not_offered(read_text(source, "Modelica source"), user_model, job.effects, job.adopted) \
        if decision.gap_found else {}
    evidence, next_step = answer(job, s, decision, advice, segments, ms_after, gap_removed, scores.candidates, left)
    return Diagnosis(
        job=str(job.path), model=job.model, data=str(job.data_path),
        records=tuple(RecordSummary(path=str(path), parameters=trial, samples=len(r.time), compared=int(p.sum()),
                                    time_shift=shift)
                      for (path, trial), (r, _), shift, p in zip(job.records, s.records, s.shifts, s.sampled)),
        effect=decision.effect, verdict=verdict(job, decision, segments, ms_after, where),
        also_explained_by=decision.rivals,
        kind=job.kind.name, signals=s.channels, units=s.units,
        inputs=[u.name for u in model.inputs] if time_series else [],
        input_units=[u.unit for u in model.inputs] if time_series else [],
        parameter_units={**{p.name: p.unit for p in model.parameters},
                         **{p.name: p.unit for n in job.effects for p in EFFECTS[n].parameters}},
        noise=noise, rmse_before_per_signal=rmse_before, rmse_after_per_signal=rmse_after,
        max_error_before=max_before[0], max_error_after=max_after[0],
        gap_removed=gap_removed,
        baseline_parameters=base.parameters, baseline_free={n: p.to_list() for n, p in job.free.items()},
        after_parameters=final.parameters if final else None, fmu=shown.fmu, rerun=shown.rerun,
        segments=segments,
        gap_found=decision.gap_found, baseline_mean_square=ms_baseline, shapes=decision.shapes,
        whiteness=decision.whiteness, input_cross_correlation=decision.cross_correlation,
        fold_samples=[int(train.sum()) for train, _ in split.folds],
        decision={"min_gap_removed": job.min_gap_removed, "min_delta_bic": job.min_delta_bic,
                  "gap_sigmas": job.gap_sigmas, "mean_square_chance": decision.chance},
        candidates=tuple(sorted(scores.candidates, key=lambda c: -c.score)),
        traces=Traces(time=s.time, inputs=s.experiment.inputs if time_series else np.zeros((len(s.time), 0)),
                      measured=y, before=base.outputs, after=shown.after, mask=mask,
                      candidate_predictions={name: pair[0].outputs for name, pair in scores.fits.items()}),
        variant_source=shown.variant_source, variant_diff=shown.variant_diff,
        outcome=decision.outcome, gap={"noise_levels": decision.gap_levels, "where": list(decision.where),
                                       "remaining_noise_levels": float(np.sqrt(max(ms_after, 0.0)))},
        not_identifiable=list(advice), evidence=evidence, next_step=next_step, experiments=gaps, shown_by=where)


def run_round(job, progress, build, out, scratch):
    """One round of the workflow (stages 1-5 and the answer) on ``job``'s baseline, variants written into
    ``scratch``; :func:`cosim.diagnose.rounds.run_diagnosis` runs the rounds.

    Raises
    ------
    cosim.errors.ConfigError
        When no hold of a staircase lasts ``experiment.steady_s``.
    """
    samples = load_samples(job)
    noise = estimate_noise(job, samples)
    base = map_here(lambda _, report: fit_free(samples.model, samples.records, job, dict(job.free), noise.weights,
                                               samples.mask, "baseline", report),
                    [None], desc="baseline fit", progress=progress, report=True)[0]
    split = split_segments(job, samples, noise)
    scores = score_candidates(job, samples, noise, split, base, scratch, progress)
    decision = decide(job, samples, noise, split, scores)
    shown = show(job, samples, noise, scores, decision, scratch, build, out)
    advice = advise(job, samples, noise, split, scores, decision, scratch)
    return _diagnosis(job, samples, noise, split, scores, decision, shown, advice)


# -- the answer a user acts on -------------------------------------------------------------------------------------

def advise(job, samples, noise, split, scores, decision, folder):
    """The plausible effects the data cannot identify (:func:`~cosim.diagnose.advice.plausible`, at most
    ``MAX_ADVISED``), each with why, its change on the data given and on the experiment that shows it
    (:func:`~cosim.diagnose.advice.change_on`, variants written into ``folder``); a list of dicts."""
    segments = [in_segment(samples.time, seg) for seg in split.segments]
    base = scores.fits["baseline"][0].outputs if scores.fits else scores.base.outputs
    out = []
    for c in decision.plausible[:MAX_ADVISED]:
        here = change_here(scores.fits[c.effect][0].outputs, base, noise.weights, samples.mask, segments)
        values = {n: c.parameters[n] for n in c.added_parameters if n in c.parameters}
        shown = change_on(c.effect, values, scores.base.parameters, folder / f"advice_{c.effect}",
                          this=(job.kind.name, job.user_model[1]))
        out.append({"effect": c.effect, "title": EFFECTS[c.effect].title, "why": why_plausible(job, decision, c),
                    "score": c.score,
                    "delta_bic": c.delta_bic, "parameters": values, "change_here": here, "shown_by": shown})
    return out
