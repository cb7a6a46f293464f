"""Several discrepancies in turn: a real plant differs from its model in more than one way, and an engineer fixes
the largest gap first, then looks again.

:func:`run_diagnosis` runs rounds of the workflow (:func:`~cosim.diagnose.workflow.run_round`). When a round names
a candidate (an effect or a form) and a gap is left after it (:func:`gap_left`: the rule by which the verdict says
"a gap remains"), the next round's baseline is the user's model with every candidate named so far, their
parameters and the baseline's free from their fitted values (:func:`job_with`), up to the job's
``decision.rounds``. A candidate whose slot a finding fills, or whose parameter it frees, is not offered again.

A candidate named early may only have stood in for one named later (a coating that stiffens as a power of its
compression looks, at first touch, like more gear play). So after two or more findings each is checked against
the others (:func:`least_needed`, backward elimination as in stepwise regression): the model with every finding
is refitted without each in turn, and when the least needed one no longer improves the BIC by
``min_delta_bic``, it is dropped and the last finding's round is run again on a baseline without it (a
confirmation round). :func:`combine` makes one :class:`~cosim.diagnose.result.Diagnosis` of the rounds.
"""

import tempfile
from dataclasses import replace
from pathlib import Path

from cosim.diagnose.analysis import gap_shown
from cosim.diagnose.answer import finding_words, shown_words
from cosim.diagnose.effects import EFFECTS, write_variant
from cosim.diagnose.result import Round
from cosim.diagnose.tasks import added_parameters, bic_penalty, effect_free, run_tasks, task_of
from cosim.diagnose.workflow import run_round
from cosim.parallel import keep_local_cluster

__all__ = ["run_diagnosis", "gap_left", "fitted_values", "job_with", "least_needed", "round_of", "combine"]


def run_diagnosis(job, progress=True, build=True, out=None):
    """Run the workflow on a loaded job, round after round, and check each finding against the others.

    Parameters
    ----------
    job : cosim.diagnose.job.DiagnoseJob
    progress : bool, default True
        Progress bar over the candidate fits.
    build : bool, default True
        Build the winner's FMU (for a time series also the baseline's) and re-run both through the master.
    out : str or Path, optional
        Where the built FMUs (``out/fmu``) and the re-run configs (``out/rerun``) go, a later round's under
        ``out/round<k>``; without it, a new folder the result's ``fmu`` and ``rerun.configs`` name.

    Returns
    -------
    Diagnosis
        With one :class:`~cosim.diagnose.result.Round` per round run (:func:`combine`).

    Raises
    ------
    cosim.errors.ConfigError
        When no hold of a staircase lasts ``experiment.steady_s``.
    """
    with tempfile.TemporaryDirectory(prefix="cosim-diagnose-") as scratch, \
            keep_local_cluster(job.workers):  # the variants' Modelica packages; one Dask cluster for every round
        scratch = Path(scratch)
        done = [(job, run_round(job, progress, build, out, scratch / "round1"))]  # (round's job, its diagnosis)

        def another(round_job):
            k = len(done) + 1
            done.append((round_job, run_round(round_job, progress, build, out and Path(out) / f"round{k}",
                                              scratch / f"round{k}")))

        exhausted = False  # a gap was left and no candidate was left to offer
        while len(done) < job.rounds and gap_left(done[-1][1]):
            last_job, last = done[-1]
            following = job_with(job, (*last_job.adopted, last.effect), fitted_values(last),
                                 scratch / f"round{len(done) + 1}" / "baseline")
            exhausted = not following.effects
            if exhausted:
                break
            another(following)
        findings = _findings(*done[-1])
        dropped = least_needed(job, findings, done[-1][1], scratch / "check", progress) if len(findings) > 1 else None
        if dropped is not None:  # the last finding's round again, on a baseline without the one not needed
            kept = [f for f in findings if f != dropped]
            confirming = job_with(job, tuple(kept[:-1]), fitted_values(done[-1][1]),
                                  scratch / f"round{len(done) + 1}" / "baseline", leave_out=(dropped,))
            another(confirming)
            if done[-1][1].effect != kept[-1]:  # not confirmed: the findings stand as the rounds named them
                done.pop()
        return combine([d for _, d in done], _findings(*done[-1]), exhausted)


def gap_left(diagnosis):
    """Whether a round named a candidate and a gap is left after it: a segment still above the noise *and* a
    whole residual beyond chance (:func:`~cosim.diagnose.analysis.gap_shown`, the baseline's gap rule, applied to
    the candidate's fit)."""
    d = diagnosis
    return d.outcome == "named" and gap_shown([r.significant_after for r in d.segments],
                                              d.gap["remaining_noise_levels"] ** 2, d.decision["mean_square_chance"])


def fitted_values(diagnosis):
    """The fitted values of the model a round ends with: its winner's refit on every cost sample, or, when it
    names nothing, its baseline's fit (a later round's baseline holds the earlier findings, their parameters
    free, so this is the last fit of them)."""
    d = diagnosis
    return d.after_parameters if d.outcome == "named" else d.baseline_parameters


def _findings(round_job, diagnosis):
    """The candidates in a round's model after it: its baseline's and its winner."""
    return [*round_job.adopted] + ([diagnosis.effect] if diagnosis.outcome == "named" else [])


def job_with(job, findings, values, folder, leave_out=()):
    """``job`` (the user's) with ``findings`` added to its baseline (written into ``folder``): their parameters and
    the baseline's free from ``values`` (their fit), offering the candidates that still fit, less ``leave_out``."""
    findings = tuple(findings)
    path, name = write_variant(job.source, job.model, [EFFECTS[n] for n in findings], folder)
    free = {n: p.at(values[n]) for n, p in job.free.items()}
    for named in findings:
        free.update(effect_free(EFFECTS[named], values))
    filled = {EFFECTS[n].slot for n in findings} - {""}
    offered = tuple(n for n in job.effects if n not in findings and n not in leave_out
                    and EFFECTS[n].slot not in filled and not any(f in free for f, _, _ in EFFECTS[n].frees))
    return replace(job, source=path, model=name, origin=(job.source, job.model), adopted=findings, free=free,
                   effects=offered)


def least_needed(job, findings, final, folder, progress):
    """The finding the others do not need, or None: the model with every finding and the model without each are
    fitted on every cost sample (from the values ``final``, the last round, ends with: :func:`fitted_values`, in
    parallel); the finding whose removal costs the least BIC is returned when that is below ``job.min_delta_bic``."""
    weights = final.noise.weights
    mask = final.traces.mask
    values = fitted_values(final)
    jobs = [job_with(job, [f for f in findings if f != left], values, folder / (left or "all"))
            for left in (None, *findings)]
    tasks = [task_of(j, "baseline", weights, mask, baseline=j.free) for j in jobs]
    fits = run_tasks(job, tasks, progress, desc="checking each finding against the others")
    n_fit = int(mask.sum()) * len(final.signals)
    cost = {left: fit.chi2 - fits[0].chi2 - bic_penalty(left, n_fit)
            for left, fit in zip(findings, fits[1:])}
    weakest = min(cost, key=cost.get)
    return weakest if cost[weakest] < job.min_delta_bic else None


def round_of(number, diagnosis):
    """A one-round diagnosis as a :class:`~cosim.diagnose.result.Round`."""
    d = diagnosis
    named = d.effect != "none"
    added = added_parameters(d.effect) if named else []
    return Round(number=number, effect=d.effect, form=named and EFFECTS[d.effect].is_form,
                 parameters={n: d.after_parameters[n] for n in added}, gap_before=d.gap["noise_levels"],
                 gap_after=d.gap["remaining_noise_levels"], outcome=d.outcome, verdict=d.verdict,
                 shown_by=d.shown_by)


def combine(diagnoses, findings, exhausted=False):
    """One Diagnosis of the rounds' (a single round's as it is, with its round): the last named round's, with the
    first of the ``findings`` (the candidates in the final model, in order) as ``effect``, the user's baseline's
    gap before, the gap removed from it, and the verdict, evidence and next step of the rounds; a round whose
    candidate the final model does not hold is marked dropped. ``exhausted``: the rounds stopped with a gap left
    because no candidate was left to offer (else a gap left means ``decision.rounds`` were run)."""
    rounds = tuple(round_of(k, d) for k, d in enumerate(diagnoses, 1))
    if len(diagnoses) == 1:
        return replace(diagnoses[0], rounds=rounds)
    first, last = diagnoses[0], diagnoses[-1]
    final = [d for d in diagnoses if d.outcome == "named"][-1]
    rounds = tuple(replace(r, parameters={n: final.after_parameters.get(n, v) for n, v in r.parameters.items()},
                           dropped=r.effect != "none" and r.effect not in findings) for r in rounds)
    ms_before, ms_after = first.baseline_mean_square, final.gap["remaining_noise_levels"] ** 2
    return replace(
        final, effect=findings[0] if findings else "none", model=first.model,
        verdict=_verdict(rounds, findings, last, exhausted), rounds=rounds, baseline_mean_square=ms_before,
        rmse_before_per_signal=first.rmse_before_per_signal, max_error_before=first.max_error_before,
        baseline_parameters=first.baseline_parameters, baseline_free=first.baseline_free,
        gap_removed=float(1 - (ms_after - 1) / (ms_before - 1)) if ms_before > 1 else 0.0,
        gap={**final.gap, "noise_levels": first.gap["noise_levels"], "where": first.gap["where"]},
        traces=replace(final.traces, before=first.traces.before),
        evidence="; ".join(f"round {k}: {d.evidence}" for k, d in enumerate(diagnoses, 1) if d.evidence),
        next_step=_next_step(rounds, findings, last), not_identifiable=last.not_identifiable,
        experiments=_experiments(first, final), shown_by=_shown(rounds)[findings[0]] if findings else ())


def _experiments(first, final):
    """Each experiment's gap from the user's baseline (the first round's) to the final model, and the chi-square
    all the findings together remove from it."""
    channels = len(final.signals)
    return tuple(replace(e, gap_before=b.gap_before,
                         chi2_removed=(b.gap_before ** 2 - e.gap_after ** 2) * e.samples * channels)
                 for b, e in zip(first.experiments, final.experiments))


def _shown(rounds):
    """Candidate -> the experiments that showed it (a finding confirmed again: its last round's)."""
    return {r.effect: r.shown_by for r in rounds}


def _verdict(rounds, findings, last, exhausted):
    """Every finding in order, the ones dropped, then what is left after the last one (and, a gap left after it,
    why no round followed: ``exhausted``, no candidate left to offer, else the job's rounds all run)."""
    values = {n: v for r in rounds for n, v in r.parameters.items()}
    shown = _shown(rounds)
    found = [finding_words(f, {n: values[n] for n in added_parameters(f) if n in values}) + shown_words(shown[f])
             for f in findings]
    left = rounds[-1].gap_after
    if last.outcome == "named" and gap_left(last):
        tail = f"a gap of {left:.1f} noise levels remains after {len(rounds)} rounds " + (
            "and no candidate is left to offer (each fills a slot, or frees a parameter, a finding has)" if exhausted
            else "(the job's decision.rounds)")
    elif last.outcome in ("named", "within noise"):
        tail = f"what remains is within the noise ({left:.1f} noise levels RMS)"
    else:
        where = last.gap["where"][0] if last.gap["where"] else None
        tail = f"a gap of {left:.1f} noise levels remains that no candidate explains" + (
            f" (largest in {where['segment']}: {where['sigmas']:.1f} noise levels)" if where else "")
    dropped = sorted({r.effect for r in rounds if r.dropped})
    also = (f"; {', '.join(dropped)} (named in an earlier round) dropped: the later findings explain what it did"
            if dropped else "")
    return f"found in {len(rounds)} rounds: " + "; then ".join(found) + also + f"; {tail}"


def _next_step(rounds, findings, last):
    """What to change in the model (every finding, a form said as such), then the last round's advice when it
    named nothing."""
    forms = [f for f in findings if EFFECTS[f].is_form]
    step = (f"change the model as found, in this order: {', '.join(findings)}; the variant with all of them is in "
            "OUT/modelica and OUT/variant.diff; calibrate it with their parameters free")
    if forms:
        step += (f". {', '.join(forms)} replace{'s' if len(forms) == 1 else ''} a law the model has by a law of "
                 "another form: the model's law has the wrong shape, so the parameters of the old law fitted "
                 "before are not to be trusted")
    return step if last.outcome == "named" else f"{step}. Then: {last.next_step}"
