"""The words of a diagnosis's answer: the verdict (an effect named; a gap of N noise levels no candidate explains,
with where it is; or a baseline within the noise), the evidence behind it and the next step (for a gap no
candidate explains, also the forms of the model's laws the job did not offer), and why an advised effect is
plausible but not identifiable. The numbers come from the workflow's decision
(:class:`~cosim.diagnose.workflow.Decision`); this module only says them (``report.md`` opens with them,
:mod:`cosim.diagnose.report` writes it).
"""

from pathlib import Path

import numpy as np

from cosim.diagnose.analysis import gap_shown
from cosim.diagnose.effects import EFFECTS

__all__ = ["verdict", "answer", "why_plausible", "finding_words", "shown_words"]


def verdict(job, decision, segments=(), ms_after=0.0, shown_by=()):
    """The first line of the answer: the effect named (and, when a gap remains after it by the rule that finds
    the baseline's, that gap), the gap no candidate explains (its size and where it is largest), or a baseline
    within the noise.

    Parameters
    ----------
    job : cosim.diagnose.job.DiagnoseJob
    decision : cosim.diagnose.workflow.Decision
    segments : sequence of cosim.diagnose.result.SegmentRow, optional
        The segment table before and after the winner.
    ms_after : float, default 0.0
        The winner's mean square in noise levels squared.
    shown_by : sequence of str, optional
        Records of several experiments: the ones that showed the winner (:func:`~cosim.diagnose.workflow.shown_by`).
    """
    d = decision
    if d.winner is not None:
        named = _finding(d.winner) + shown_words(shown_by)
        if not gap_shown([r.significant_after for r in segments], ms_after, d.chance):
            return named
        top = _left_after(segments)[0]
        return (f"{named}; after it, a gap of {np.sqrt(ms_after):.1f} noise levels remains that no effect in the "
                f"library explains (largest in {top.segment}, {job.kind.span(top.t0, top.t1)}: "
                f"{_levels_after(top):.1f} noise levels): it explains part of the gap, the rest needs another effect "
                "or a model of another form")
    if d.gap_found:
        top = d.where[0]
        return (f"a gap of {d.gap_levels:.1f} noise levels remains that no effect in the library explains "
                f"(largest in {top['segment']}, {job.kind.span(top['t0'], top['t1'])}: {top['sigmas']:.1f} noise "
                "levels)")
    if d.outcome == "diffuse gap":
        return (f"no effect named: a diffuse gap of {d.gap_levels:.1f} noise levels RMS remains (mean square "
                f"{d.mean_square:.3g} noise levels squared, chance up to {d.chance:.3g}), with no "
                f"segment above {job.gap_sigmas:g} noise levels")
    return (f"no missing effect found: the baseline fits within the noise (mean square {d.mean_square:.3g} "
            f"noise levels squared, chance up to {d.chance:.3g}; segments above {job.gap_sigmas:g} noise "
            f"levels: {sum(r['significant'] for r in d.rows)})")


def shown_words(experiments):
    """Which experiments showed a finding, as words ("" when the job has one experiment)."""
    if not experiments:
        return ""
    return f", shown by the {' and the '.join(experiments)} record{'s' if len(experiments) > 1 else ''}"


def finding_words(name, parameters, with_title=False):
    """A named candidate in words: a missing effect, or a law of another form, with its fitted ``parameters``
    (name -> value) and, ``with_title``, what it is."""
    effect = EFFECTS[name]
    values = ", ".join(f"{n} = {v:.3g}" for n, v in parameters.items())
    if not effect.is_form:
        return f"missing effect: {name} ({effect.title if with_title else values})"
    return f"{effect.law} is of another form: {name} ({f'{effect.title}; ' if with_title else ''}{values})"


def _finding(winner):
    """The winner of a round in words, with what it is (a form also with its fitted parameters)."""
    added = {n: winner.parameters[n] for n in winner.added_parameters if n in winner.parameters}
    return finding_words(winner.effect, added if EFFECTS[winner.effect].is_form else {}, with_title=True)


def why_plausible(job, decision, candidate):
    """Why an advised ``candidate`` is plausible but not identifiable: the held-out data do not tell it from the
    winner, or, without a winner, how far it falls short of the decision's thresholds.

    Parameters
    ----------
    job : cosim.diagnose.job.DiagnoseJob
    decision : cosim.diagnose.workflow.Decision
    candidate : cosim.diagnose.result.Candidate
    """
    if decision.winner is not None:
        return f"the held-out segments do not tell it from {decision.effect}"
    return (f"it removes {100 * candidate.score:.0f} % of the held-out gap (naming needs "
            f"{100 * job.min_gap_removed:.0f} %) with ΔBIC {candidate.delta_bic:.1f} (needs {job.min_delta_bic:g})")


def answer(job, samples, decision, advice, segments, ms_after, gap_removed, candidates=(), forms_left=None):
    """The evidence behind the verdict and the next step, one paragraph each (the report's first lines).

    Parameters
    ----------
    job : cosim.diagnose.job.DiagnoseJob
    samples : cosim.diagnose.workflow.Samples
    decision : cosim.diagnose.workflow.Decision
    advice : list of dict
        The plausible effects (:func:`~cosim.diagnose.workflow.advise`).
    segments : sequence of cosim.diagnose.result.SegmentRow
        The segment table before and after the winner.
    ms_after : float
        The winner's mean square in noise levels squared.
    gap_removed : float
        The fraction of the gap above the noise the winner, refitted on every segment, removes.
    candidates : sequence of cosim.diagnose.result.Candidate, optional
        The scored ones.
    forms_left : dict, optional
        The library's forms for the model's slots that the job did not offer, by the law they replace
        (:func:`~cosim.diagnose.effects.forms_not_offered`): a gap no candidate explains names them.

    Returns
    -------
    (str, str)
        Evidence and next step.
    """
    d = decision
    if d.winner is not None:
        return _named(job, d, advice, segments, ms_after, gap_removed)
    if d.gap_found:
        return _unexplained(job, samples, d, advice, candidates, forms_left or {})
    significant = sum(r["significant"] for r in d.rows)
    evidence = (f"mean square {d.mean_square:.3g} noise levels squared (chance up to {d.chance:.3g}); "
                f"{significant} of {len(d.rows)} segments above {job.gap_sigmas:g} noise levels")
    if d.outcome == "diffuse gap":
        return evidence, ("no segment stands out, so no effect can be located: the baseline's error is spread over "
                          "the record (a gain or a shape its free parameters miss); check the calibration, or "
                          "measure longer or with less noise until a segment exceeds the noise")
    return evidence, "nothing to add on these data: the baseline explains them to within the noise"


def _named(job, d, advice, segments, ms_after, gap_removed):
    """Evidence and next step when an effect is named."""
    w, left = d.winner, _left_after(segments)
    evidence = (f"{w.effect} removes {100 * w.score:.0f} % of the baseline's gap on held-out segments "
                f"(ΔBIC {w.delta_bic:.1f}); refitted on every segment it removes {100 * gap_removed:.0f} % of "
                f"the gap above the noise ({d.gap_levels:.1f} -> {np.sqrt(max(ms_after, 0.0)):.1f} noise levels)")
    if left:
        evidence += f"; {len(left)} segment(s) stay above {job.gap_sigmas:g} noise levels, largest {left[0].segment}"
    if EFFECTS[w.effect].is_form:
        step = (f"replace {EFFECTS[w.effect].law} of the model by the form {w.effect} ({EFFECTS[w.effect].replacement}"
                f" in slot {EFFECTS[w.effect].slot}): the model misses no physics, its law has the wrong shape, so "
                "the parameters of the old law fitted before are not to be trusted; the variant is in OUT/modelica "
                "and OUT/variant.diff; calibrate it with its parameters free")
    else:
        step = (f"add {w.effect} to the model: the variant is in OUT/modelica and OUT/variant.diff; calibrate it "
                f"with its parameters free")
    if advice:
        step += ". To tell it from " + "; ".join(_shows(a) for a in advice)
    return evidence, step


def _unexplained(job, samples, d, advice, candidates, forms_left):
    """Evidence and next step when the baseline shows a gap no candidate explains (and the forms not offered)."""
    unit = f" {samples.units[0]}" if samples.units and samples.units[0] else ""
    significant = sum(r["significant"] for r in d.rows)
    best = max(candidates, key=lambda c: c.score, default=None)
    where = "; ".join(f"{w['segment']} ({job.kind.span(w['t0'], w['t1'])}): {w['sigmas']:.1f} noise levels, "
                      f"shape {w['shape']}, mean residual {w['bias']:+.3g}{unit}" for w in d.where[:3])
    evidence = (f"the baseline's residual is {d.gap_levels:.1f} noise levels RMS (mean square {d.mean_square:.3g}"
                f", chance up to {d.chance:.3g}); {significant} of {len(d.rows)} segments above "
                f"{job.gap_sigmas:g} noise levels: {where}")
    evidence += "" if best is None else (
        f"; the best candidate, {best.effect}, removes {100 * best.score:.0f} % of the held-out gap (naming "
        f"needs {100 * job.min_gap_removed:.0f} %) with ΔBIC {best.delta_bic:.1f} (needs {job.min_delta_bic:g})")
    left = "; ".join(f"{law}: {', '.join(names)}" for law, names in forms_left.items())
    if advice:
        step = ("plausible but not identifiable on these data: "
                + "; ".join(f"{a['effect']} ({a['why']})" for a in advice)
                + ". The experiment that would show it: " + "; ".join(_shows(a) for a in advice))
        if left:
            step += (f". The library also holds forms of the model's laws that the job did not offer ({left}): "
                     "list them under candidates.forms to try them")
    elif left:
        step = ("no candidate offered explains this gap, and a law the model has may be of another form: the "
                f"library holds forms of the model's laws that the job did not offer ({left}); list them under "
                "candidates.forms and run the diagnosis again")
    else:
        step = ("the library lacks the physics of this gap: check the fixed parameters and the data where the "
                "gap is largest, then write the effect as a candidate (docs/guide/diagnose.md, the effect "
                "library) and run the diagnosis again")
    return evidence, step



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
    """The segments (:class:`~cosim.diagnose.result.SegmentRow`) still above the noise after the winner, largest
    residual first."""
    return sorted((r for r in segments if r.significant_after), key=_levels_after, reverse=True)


def _levels_after(row):
    """A segment's residual after the winner in noise levels (its noise level is rmse_before / sigmas; a segment
    the baseline fitted exactly, sigmas 0, gives no noise level and counts as 0)."""
    return row.rmse_after * row.sigmas / row.rmse_before if row.rmse_before > 0 else 0.0
