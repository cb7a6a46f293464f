"""Stage 5 of the discrepancy workflow, *add and show*: the winner's variant refitted on every cost sample, written
into the Modelica source with a diff, built into an FMU and, with the baseline's FMU, re-run through the master with
the measured inputs (:mod:`cosim.diagnose.rerun`)."""

import difflib
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from cosim.diagnose.analysis import rmse_per_signal
from cosim.diagnose.result import Rerun
from cosim.diagnose.stages import Show
from cosim.diagnose.tasks import run_tasks, task_of, variant_of

__all__ = ["show"]

RERUN_HOW = "the built FMUs run by the master (BDF) with the measured inputs played at the data rate"


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
    tasks = [task_of(job, winner.effect, noise.weights, samples.mask, path, variant,
                   start={n: winner.free[n].at(v) for n, v in start.items()}) for start in starts]
    return min(run_tasks(job, tasks, False, desc="final fit"), key=lambda fit: fit.chi2)


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
            final.label: build_fmu(variant_path, variant, out_dir=folder / "fmu")}
    fits = {"baseline": base, final.label: final}
    folders = [folder / "rerun"] if len(s.records) == 1 else \
        [folder / "rerun" / f"record{k}" for k in range(len(s.records))]
    replayed = [rerun({label: (fmus[label], {**job.fixed, **trial, **fit.parameters})
                       for label, fit in fits.items()}, e, inputs, outputs, where, job.rtol)
                for (e, trial), where in zip(s.records, folders)]
    entry = {"configs": {}}
    for label, fit in fits.items():
        predicted = np.hstack([r[label] for r in replayed])
        rmse, max_error = rmse_per_signal(predicted, s.measured, s.mask)
        key = "before" if label == "baseline" else "after"
        entry[f"rmse_{key}"], entry[f"max_error_{key}"] = rmse[0], max_error[0]
        entry[f"max_difference_to_replay_{key}"] = float(np.max(np.abs(predicted - fit.outputs)[0, s.mask]))
        entry["configs"][label] = str((folders[0] if len(folders) == 1 else folder / "rerun" / "record*")
                                      / f"{label}.toml")
    return Rerun(how=RERUN_HOW, signal=outputs[0], **entry), str(fmus[final.label])


def show(job, samples, noise, scores, decision, folder, build=True, out=None):
    """Add the winner: write its variant (into ``folder``), refit it on every cost sample, diff it against the
    baseline's source and, with ``build``, build its FMU (and for a time series the baseline's) and re-run both
    through the master, into ``out`` (without it, a new folder the result points to)."""
    winner = decision.winner
    if winner is None:
        return Show(final=None, after=scores.base.outputs)
    path, variant = variant_of(job, winner.effect, folder / "winner")
    final = _final_fit(job, samples, noise, winner, path, variant)
    variant_source = path.read_text(encoding="utf-8")
    source = job.user_model[0]  # the user's file: the diff shows every finding so far
    variant_diff = "".join(difflib.unified_diff(
        Path(source).read_text(encoding="utf-8").splitlines(keepends=True),
        variant_source.splitlines(keepends=True), fromfile=str(source),
        tofile=f"{source} ({', '.join((*job.adopted, winner.effect))})"))
    fmu, rerun = None, None
    if build:
        with _build_folder(out) as target:
            if job.kind.time_series:
                rerun, fmu = _rerun_both(job, samples, scores.base, final, path, variant, target)
            else:  # a frequency response is not a time series the master could replay
                from cosim.compile import build_fmu

                fmu = str(build_fmu(path, variant, out_dir=target / "fmu"))
    return Show(final=final, after=final.outputs, fmu=fmu, variant_source=variant_source,
                variant_diff=variant_diff, rerun=rerun)
