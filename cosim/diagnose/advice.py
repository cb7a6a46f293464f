"""The answer a user can act on: where a gap the library leaves is, which effects are plausible but not
identifiable on the data given, the experiment that would show each (with the effect's change on that experiment,
computed by replaying it) and the next step.

An effect is *plausible but not identifiable* here when the held-out data cannot tell it from the winner (a rival,
:func:`~cosim.diagnose.workflow.rivals_of`), or, when no effect is named, when it removes at least half of
``min_gap_removed`` of the held-out gap and improves the fitted segments more than its parameters cost
(ΔBIC > 0). Its expected signature is computed twice: on the data given (its fit's replay against the baseline's)
and on the experiment that shows it (the effect's ``shown_by`` and ``shown_in``,
:class:`~cosim.diagnose.effects.Effect`): the shipped job of that experiment replayed with the baseline as
calibrated here, once without and once with the effect at the size fitted here. The words of the answer are in
:mod:`cosim.diagnose.answer`.
"""

import sysconfig
from pathlib import Path

import numpy as np

__all__ = ["shipped_examples", "MAX_ADVISED", "gap_locations", "plausible", "change_here", "change_on"]

MAX_ADVISED = 3  # plausible effects whose signature on another experiment is computed (a replay of each)


def shipped_examples():
    """The folder of the shipped example jobs the advice replays: ``examples/`` of a checkout (beside the
    package), or where an install put them (``<data>/share/cosim/examples``: pyproject.toml's data-files, with the
    Modelica packages they use in ``share/cosim/modelica``)."""
    checkout = Path(__file__).resolve().parents[2] / "examples"
    installed = [Path(sysconfig.get_path("data", scheme)) / "share" / "cosim" / "examples"
                 for scheme in (sysconfig.get_default_scheme(), sysconfig.get_preferred_scheme("user"))]
    return next((folder for folder in (checkout, *installed) if folder.is_dir()), checkout)


def gap_locations(rows, limit=5):
    """The significant segments of a segment table (:func:`~cosim.diagnose.analysis.segment_table`), largest gap
    first: a list of dicts (segment, t0, t1 [s or Hz], signal index, gap in noise levels, bias, shape), at most
    ``limit``."""
    significant = sorted((r for r in rows if r["significant"]), key=lambda r: -r["sigmas"])
    return [{"segment": r["segment"], "t0": r["t0"], "t1": r["t1"], "signal": r["signal"], "sigmas": r["sigmas"],
             "bias": r["bias"], "shape": r["shape"]} for r in significant[:limit]]


def plausible(candidates, winner, rivals, gap_found, min_gap_removed):
    """The candidates that are plausible but not identifiable on the data given (module docstring), best score
    first: the winner's rivals, or without a winner those with a score of at least ``min_gap_removed``/2 and
    ΔBIC > 0 (only when the baseline shows a gap)."""
    if winner is not None:
        return [c for c in candidates if c.effect in rivals]
    if not gap_found:
        return []
    return sorted((c for c in candidates if c.score >= 0.5 * min_gap_removed and c.delta_bic > 0),
                  key=lambda c: -c.score)


def change_here(predicted, baseline, weights, mask, segments_hit):
    """How far an effect's fit moves the replay on the data given: RMS and largest change on the cost samples in
    noise levels, and the number of segments it moves by more than one noise level (``segments_hit``: a list of
    boolean masks, one per segment)."""
    from cosim.diagnose.fitting import weighted

    change = weighted(predicted - baseline, weights)[:, mask]
    full = weighted(predicted - baseline, weights)
    moved = sum(bool(np.sqrt(np.mean(full[:, seg & mask] ** 2)) > 1.0) for seg in segments_hit
                if (seg & mask).any())
    return {"rms_noise_levels": float(np.sqrt(np.mean(change ** 2))),
            "max_noise_levels": float(np.max(np.abs(change))), "segments_moved": moved,
            "segments": len(segments_hit)}


def change_on(effect, parameters, baseline_parameters, folder, this=None):
    """The change the effect ``effect`` makes on the experiment that shows it: that experiment's shipped job
    replayed (its first record's measured inputs) with the baseline as calibrated here (the values of its free
    parameters that ``baseline_parameters`` holds, the job's starts for the others), without and with the effect
    at ``parameters`` (its values fitted here); the variant is written into ``folder``. ``this``: the (kind,
    model) of the data given; when the shipped job is that same experiment nothing is replayed.

    Returns
    -------
    dict
        ``experiment`` and ``job``; ``computed`` (False with ``why`` when no job of that experiment ships, or when
        it does not take the effect); else ``rms``, ``max`` (of the first compared channel, in its ``unit``),
        ``noise`` (that job's floor) and ``rms_noise_levels``, ``max_noise_levels``.
    """
    from cosim.compile import lower
    from cosim.diagnose.effects import EFFECTS, write_variant
    from cosim.diagnose.job import load_diagnose_job
    from cosim.errors import ConfigError

    shown = EFFECTS[effect]
    name = shown.shown_in
    entry = {"experiment": shown.shown_by, "job": name, "computed": False}
    shipped = shipped_examples() / name
    if not name or not shipped.is_file():
        entry["why"] = "no job of that experiment ships with cosim" if not name else f"{shipped} not found"
        return entry
    entry["job"] = str(shipped)
    try:
        job = load_diagnose_job(shipped)
        path, variant = write_variant(job.source, job.model, EFFECTS[effect], folder)
    except ConfigError as err:  # the shipped job's model does not take the effect: said in the answer
        entry["why"] = str(err)
        return entry
    if (job.kind.name, job.model) == this:
        entry["why"] = "the data given are that experiment: more records or a lower noise would show it"
        return entry
    base = {n: baseline_parameters.get(n, p.start) for n, p in job.free.items()}
    added = {n: v for n, v in parameters.items() if n not in job.free}
    before = _replay(job, lower(job.source, job.model), base)
    after = _replay(job, lower(path, variant), {**base, **added})
    change = (after - before)[0]
    noise = float(job.signals[0][2])
    entry.update(computed=True, rms=float(np.sqrt(np.mean(change ** 2))), max=float(np.max(np.abs(change))),
                 noise=noise, signal=job.signals[0][0], parameters=added)
    entry.update(rms_noise_levels=entry["rms"] / noise, max_noise_levels=entry["max"] / noise)
    return entry


def _replay(job, model, values):
    """The job's first record replayed by ``model`` at the parameter ``values``: its outputs, (n_signals, N)."""
    from cosim.diagnose.job import load_records

    experiment, trial = load_records(job, model)[0]
    names = list(values)
    scale = np.array([abs(values[n]) or 1.0 for n in names])
    fixed = {n: v for n, v in {**job.fixed, **trial}.items() if n not in values}
    replay = job.kind.replay(model, experiment, [o for o, _, _ in job.signals], names, scale, fixed=fixed,
                             rtol=job.rtol)
    return replay.outputs(values)
