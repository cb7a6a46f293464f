"""Several discrepancies in turn: a real plant differs from its model in more than one way, and an engineer fixes
the largest gap first, then looks again.

:func:`~cosim.diagnose.workflow.run_diagnosis` runs rounds: each is the whole workflow on a baseline, and when it
names a candidate (an effect or a form) and a gap is left after it (:func:`gap_left`: the rule by which the
verdict says "a gap remains"), the next round's baseline is the user's model with every candidate named so far,
their parameters and the baseline's free from their fitted values (:func:`next_round`), up to the job's
``decision.rounds``. A candidate whose slot an earlier finding fills, or whose parameter it frees, is not offered
again. :func:`combine` makes one :class:`~cosim.diagnose.result.Diagnosis` of the rounds.
"""

from dataclasses import replace

from cosim.diagnose.answer import finding_words
from cosim.diagnose.effects import EFFECTS, write_variant
from cosim.diagnose.result import Round
from cosim.fitting import FreeParameter

__all__ = ["gap_left", "next_round", "round_of", "combine"]


def gap_left(diagnosis):
    """Whether a round named a candidate and a gap is left after it: a segment still above the noise *and* a
    whole residual beyond chance (the baseline's gap rule, applied to the candidate's fit)."""
    d = diagnosis
    remaining = d.gap["remaining_noise_levels"] ** 2
    return (d.outcome == "named" and remaining > d.decision["mean_square_chance"]
            and any(r.significant_after for r in d.segments))


def next_round(job, diagnosis, folder):
    """The job of the round after ``diagnosis``: its baseline the user's model with the candidates named so far
    (written into ``folder``), the free parameters from their fitted values, the candidates that still fit."""
    adopted = (*job.adopted, diagnosis.effect)
    source, model = job.user_model
    path, name = write_variant(source, model, [EFFECTS[n] for n in adopted], folder)
    values = diagnosis.after_parameters
    free = {n: p.at(values[n]) for n, p in job.free.items()}
    named = EFFECTS[diagnosis.effect]
    for p in named.parameters:
        free[p.name] = FreeParameter(p.lower, p.lower, p.upper).clipped(values[p.name])
    for n, lower, upper in named.frees:
        free[n] = FreeParameter(lower, lower, upper).clipped(values[n])
    filled = {EFFECTS[n].slot for n in adopted} - {""}
    offered = tuple(n for n in job.effects if n not in adopted and EFFECTS[n].slot not in filled
                    and not any(f in free for f, _, _ in EFFECTS[n].frees))
    return replace(job, source=path, model=name, origin=(source, model), adopted=adopted, free=free,
                   effects=offered)


def round_of(number, diagnosis):
    """A one-round diagnosis as a :class:`~cosim.diagnose.result.Round`."""
    d = diagnosis
    named = d.effect != "none"
    added = ([p.name for p in EFFECTS[d.effect].parameters] + [n for n, _, _ in EFFECTS[d.effect].frees]
             if named else [])
    return Round(number=number, effect=d.effect, form=named and EFFECTS[d.effect].is_form,
                 parameters={n: d.after_parameters[n] for n in added}, gap_before=d.gap["noise_levels"],
                 gap_after=d.gap["remaining_noise_levels"], outcome=d.outcome, verdict=d.verdict)


def combine(diagnoses):
    """One Diagnosis of the rounds' (a single round's as it is, with its round): the last named round's, with the
    first finding as ``effect``, the user's baseline's gap before, the gap removed from it to the last finding, and
    the verdict, evidence and next step of every round in order (each finding's parameters at the last fit)."""
    rounds = tuple(round_of(k, d) for k, d in enumerate(diagnoses, 1))
    if len(diagnoses) == 1:
        return replace(diagnoses[0], rounds=rounds)
    first, last = diagnoses[0], diagnoses[-1]
    final = [d for d in diagnoses if d.outcome == "named"][-1]
    rounds = tuple(replace(r, parameters={n: final.after_parameters[n] for n in r.parameters}) for r in rounds)
    ms_before, ms_after = first.baseline_mean_square, final.gap["remaining_noise_levels"] ** 2
    return replace(
        final, effect=first.effect, model=first.model, verdict=_verdict(rounds, last), rounds=rounds,
        baseline_mean_square=ms_before, rmse_before_per_signal=first.rmse_before_per_signal,
        max_error_before=first.max_error_before, baseline_parameters=first.baseline_parameters,
        baseline_free=first.baseline_free,
        gap_removed=float(1 - (ms_after - 1) / (ms_before - 1)) if ms_before > 1 else 0.0,
        gap={**final.gap, "noise_levels": first.gap["noise_levels"], "where": first.gap["where"]},
        traces=replace(final.traces, before=first.traces.before),
        evidence="; ".join(f"round {k}: {d.evidence}" for k, d in enumerate(diagnoses, 1) if d.evidence),
        next_step=_next_step(rounds, last), not_identifiable=last.not_identifiable)


def _verdict(rounds, last):
    """Every finding in order, then what is left after the last one."""
    found = [finding_words(r.effect, r.parameters) for r in rounds if r.effect != "none"]
    left = rounds[-1].gap_after
    if last.outcome == "named" and gap_left(last):
        tail = f"a gap of {left:.1f} noise levels remains after {len(rounds)} rounds (the job's decision.rounds)"
    elif last.outcome in ("named", "within noise"):
        tail = f"what remains is within the noise ({left:.1f} noise levels RMS)"
    else:
        where = last.gap["where"][0] if last.gap["where"] else None
        tail = f"a gap of {left:.1f} noise levels remains that no candidate explains" + (
            f" (largest in {where['segment']}: {where['sigmas']:.1f} noise levels)" if where else "")
    return f"found in {len(found)} rounds: " + "; then ".join(found) + f"; {tail}"


def _next_step(rounds, last):
    """What to change in the model (every finding, a form said as such), then the last round's advice when it
    named nothing."""
    found = [r for r in rounds if r.effect != "none"]
    forms = [r.effect for r in found if r.form]
    step = (f"change the model as found, in this order: {', '.join(r.effect for r in found)}; the variant with "
            "all of them is in OUT/modelica and OUT/variant.diff; calibrate it with their parameters free")
    if forms:
        step += (f". {', '.join(forms)} replace{'s' if len(forms) == 1 else ''} a law the model has by a law of "
                 "another form: the model's law has the wrong shape, so the parameters of the old law fitted "
                 "before are not to be trusted")
    return step if last.outcome == "named" else f"{step}. Then: {last.next_step}"
