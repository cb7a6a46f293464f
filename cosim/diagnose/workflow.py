"""The discrepancy workflow: replay and compare, locate, name, add and show.

1. *Replay and compare*: the baseline's free parameters are calibrated on the cost samples (the settled end of
   each hold of a staircase; every sample of an impact; every frequency of a frequency response, compared as
   magnitude [dB] and phase [deg]); the noise level of each channel is estimated from the data themselves
   (differences inside the steady windows, inside the approach and steady hold of an impact, or of neighbouring
   frequencies), floored by the job's stated noise.
2. *Locate*: the experiment is cut into its natural segments (holds, impact phases, frequency bands); each
   segment's residual is compared with the noise and given a shape; whiteness and cross-correlation with the
   input are reported.
3. *Name*: every candidate effect is written as a Modelica variant of the baseline, calibrated on the even
   segments (with the baseline's parameters free as well), and scored on the odd segments it was not fitted on:
   ``score`` = fraction of the baseline's held-out excess gap (mean square residual above the noise) that the
   candidate removes; BIC and a likelihood-ratio test on the fitted segments give the evidence against noise.
   Candidates run in parallel (Dask). The winner is the best-scoring candidate that removes at least
   ``min_gap_removed`` of the held-out gap and improves BIC by ``min_delta_bic``; "none" when no candidate
   qualifies, or when the baseline shows no gap: no segment of its residual is significant, or its whole residual
   is within chance of the noise (mean square in noise units below 1 + ``gap_sigmas``*sqrt(2/n)).
4. *Add and show*: the winner's variant is refitted on every cost sample, written into the Modelica source (a
   copy of the package under ``OUT/modelica`` with a diff), built into an FMU and, with the baseline's FMU, re-run
   through the master with the measured inputs; gaps before and after per segment and overall.

Repeated trials (``data.records``: several records, each with its own fixed values, e.g. the object's position)
are diagnosed as one experiment: every fit shares its parameters over the records, their samples are end to end
(noise, cost, folds, scores), each record is cut into its own segments. One impact sees a position-dependent
torque such as cogging at one rest angle; impacts with the object placed anew each time see it at several.
"""

import shutil
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import stats

from cosim.diagnose.analysis import (band_shape, branch_shapes, cross_correlation, cut_segments, frequency_bands,
                                     in_segment, noise_level, quiet_phases, segment_table, whiteness)
from cosim.experiment import Experiment, steady_mask
from cosim.parallel import map_on_dask
from cosim.diagnose.effects import EFFECTS, write_variant
from cosim.diagnose.fitting import Replay, Trials, fit_samples, weighted
from cosim.diagnose.frequency import DEG_PER_DB, FrequencyReplay, frequency_noise

__all__ = ["Diagnosis", "run_diagnosis"]

MIN_QUIET_SAMPLES = 20  # fewer samples in an impact's approach and steady holds: its noise from every sample


@dataclass(frozen=True)
class Diagnosis:
    """The result of a diagnosis: ``summary`` is the content of ``diagnosis.json``; the arrays feed the plots.

    Attributes
    ----------
    effect : str
        The named effect, or ``"none"``.
    summary : dict
    time : ndarray, shape (N,)
        Time [s], or frequency [Hz] for a frequency response.
    inputs : ndarray, shape (N, n_inputs)
        (N, 0) for a frequency response.
    measured, before, after : ndarray, shape (n_signals, N)
        For a frequency response the two channels magnitude [dB] and phase [deg].
        Measured outputs and the baseline's and the winner's replays (``after`` is ``before`` for "none").
    mask : ndarray of bool, shape (N,)
        Cost samples.
    noise : ndarray, shape (n_signals,) or (n_signals, N)
        The noise level (1 sd) each residual was weighed with.
    variant_source : str
        Modelica text of the package with the winner's variant ("" for none).
    variant_diff : str
    """

    effect: str
    summary: dict
    time: np.ndarray
    inputs: np.ndarray
    measured: np.ndarray
    before: np.ndarray
    after: np.ndarray
    mask: np.ndarray
    variant_source: str = ""
    variant_diff: str = ""
    candidate_predictions: dict = field(default_factory=dict)
    noise: np.ndarray = None  # noise level used: (n_signals,), or (n_signals, N) per frequency


def _scales(values):
    return np.array([abs(v) if v != 0 else 1.0 for v in values], float)


def _fit_candidate(task):
    """One fit in a worker (a candidate's variant, or the baseline itself for ``effect = "baseline"``) on one
    fold's training segments; replays every sample."""
    from cosim.compile import lower
    from cosim.diagnose.effects import Effect
    from cosim.diagnose.job import load_records

    job = task["job"]
    effect = Effect("baseline", "", ()) if task["effect"] == "baseline" else EFFECTS[task["effect"]]
    model = lower(task["variant_path"], task["variant_model"])
    records = load_records(job, model)
    defaults = dict(zip([p.name for p in model.parameters], model.parameter_values))
    free = dict(task["baseline"])  # name -> (start, lo, hi), starts at the baseline's fit on every sample
    for p in effect.parameters:
        start = p.start if isinstance(p.start, (int, float)) else \
            free[p.start][0] if p.start in free else job.fixed.get(p.start, defaults[p.start])
        free[p.name] = (float(np.clip(start, p.lower, p.upper)), p.lower, p.upper)
    for name, lo, hi in effect.frees:
        free[name] = (float(np.clip(job.fixed.get(name, defaults[name]), lo, hi)), lo, hi)
    trials = [free] + [{**free, p.name: (float(np.clip(v, p.lower, p.upper)), p.lower, p.upper)}
                       for p in effect.parameters for v in p.starts]
    fits = [_fit(model, records, job, trial, task["weights"], task["mask"], task["effect"]) for trial in trials]
    return min(fits, key=lambda fit: fit["chi2"])


def _fit(model, records, job, free, weights, mask, label):
    """Fit the ``free`` parameters (name -> (start, lo, hi)) on ``mask`` over every record (from
    :func:`~cosim.diagnose.job.load_records`), each replayed with its trial's fixed values."""
    starts = [v[0] for v in free.values()]
    kind = FrequencyReplay if job.kind == "frequency" else Replay
    replay = Trials([kind(model, e, [o for o, _, _ in job.signals], list(free), _scales(starts),
                          fixed={**job.fixed, **trial}, rtol=job.rtol) for e, trial in records])
    measured = np.hstack([e.measured.T for e, _ in records])
    result = fit_samples(replay, measured, weights, mask, starts,
                         ([v[1] for v in free.values()], [v[2] for v in free.values()]), max_nfev=job.max_nfev)
    result["label"] = label
    result["free"] = {n: list(v) for n, v in free.items()}
    return result


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


def _run_tasks(job, tasks, progress):
    if job.workers <= 0 or len(tasks) <= 1 and not job.scheduler:
        return [_fit_candidate(t) for t in tasks]
    return map_on_dask(_fit_candidate, tasks, job.scheduler, max_workers=job.workers, desc="candidate effects",
                       progress=progress)


def _restart_baseline(job, model, records, fit, starts, weights, mask):
    """The best of ``fit`` (a baseline fit on ``mask``) and refits of the baseline from each of ``starts`` (fits
    whose values of the baseline's free parameters start the refit)."""
    best = fit
    for other in starts:
        start = {n: (other["parameters"][n], lo, hi) for n, (_, lo, hi) in job.free.items()}
        refit = _fit(model, records, job, start, weights, mask, "baseline")
        best = refit if refit["chi2"] < best["chi2"] else best
    return best


def _ms(pred, measured, weights, mask):
    """Mean square of the weighted residual on ``mask`` (1 = at the noise level)."""
    r = weighted(pred - measured, weights)
    return float(np.mean(r[:, mask] ** 2)) if mask.any() else float("nan")


def _channels(job, model):
    """Names, units and noise floors of the compared channels: the job's signals, or for a frequency response
    the magnitude [dB] and phase [deg] of its one output (the phase floor: the same complex-log error)."""
    if job.kind == "frequency":
        output, _, floor = job.signals[0]
        ratio = f"{output}/{job.input}"
        return [f"magnitude {ratio}", f"phase {ratio}"], ["dB", "deg"], [floor, floor * DEG_PER_DB]
    units = [model.outputs[model.index("outputs", o)].unit for o, _, _ in job.signals]
    return [o for o, _, _ in job.signals], units, [n for _, _, n in job.signals]


def _rmse(pred, measured, mask):
    r = (pred - measured)[:, mask]
    return [float(np.sqrt(np.mean(x ** 2))) for x in r], [float(np.max(np.abs(x))) for x in r]


def _rerun_both(job, records, model, base, variant_path, variant, final, folder, y, mask):
    """Build the baseline's and the winner's FMUs into ``folder/fmu`` and re-run both through the master with the
    measured inputs of every record (:mod:`cosim.diagnose.rerun`, configs in ``folder/rerun``, in
    ``folder/rerun/record<k>`` for repeated trials); returns the summary's ``rerun`` entry."""
    from cosim.compile import build_fmu
    from cosim.diagnose.rerun import rerun

    outputs = [o for o, _, _ in job.signals]
    inputs = [u.name for u in model.inputs]
    fmus = {"baseline": build_fmu(job.source, job.model, out_dir=folder / "fmu"),
            final["label"]: build_fmu(variant_path, variant, out_dir=folder / "fmu")}
    final["fmu"] = str(fmus[final["label"]])
    entry = {"how": "the built FMUs run by the master (BDF) with the measured inputs played at the data rate",
             "signal": outputs[0], "configs": {}}
    fits = {"baseline": base, final["label"]: final}
    folders = [folder / "rerun"] if len(records) == 1 else \
        [folder / "rerun" / f"record{k}" for k in range(len(records))]
    replayed = [rerun({label: (fmus[label], {**job.fixed, **trial, **fit["parameters"]})
                       for label, fit in fits.items()}, e, inputs, outputs, where, job.rtol)
                for (e, trial), where in zip(records, folders)]
    for label, fit in fits.items():
        predicted = np.hstack([r[label] for r in replayed])
        rmse, max_error = _rmse(predicted, y, mask)
        key = "before" if label == "baseline" else "after"
        entry[f"rmse_{key}"], entry[f"max_error_{key}"] = rmse[0], max_error[0]
        entry[f"max_difference_to_replay_{key}"] = float(np.max(np.abs(predicted - fit["predicted"])[0, mask]))
        entry["configs"][label] = str((folders[0] if len(folders) == 1 else folder / "rerun" / "record*")
                                      / f"{label}.toml")
    return entry


def rivals_of(winner, qualified):
    """The qualified candidates the held-out data cannot tell from the winner: a score within 0.1 of its score
    *and* a held-out mean square (noise units) within 1.5 times its own. The score alone says too little when
    the baseline's gap is large: 0.1 of a gap of 180 noise levels squared is a candidate leaving 7 times the
    winner's residual (a jaw friction mimicking a larger gear play on an impact: RMSE 1.23 N against 0.46 N)."""
    if winner is None:
        return []
    return [c["effect"] for c in qualified if c is not winner and c["score"] >= winner["score"] - 0.1
            and c["heldout_ms_sigma2"] <= 1.5 * winner["heldout_ms_sigma2"]]


def run_diagnosis(job, progress=True, build=True, out=None):
    """Run the workflow on a loaded :class:`~cosim.diagnose.job.DiagnoseJob`; returns a :class:`Diagnosis`.

    ``build`` builds the baseline's and the winner's FMUs and re-runs them through the master (into ``out/fmu`` and
    ``out/rerun`` when ``out`` is given, else a temporary folder)."""
    from cosim.compile import lower
    from cosim.diagnose.job import load_records

    model = lower(job.source, job.model)
    records = load_records(job, model)
    e, shifts = _end_to_end(records)
    t, y = e.time, e.measured.T
    inputs = np.zeros((len(t), 0)) if job.kind == "frequency" else e.inputs

    def per_record(f):
        return np.concatenate([f(r) for r, _ in records])

    # per record, the instants where every compared channel has a sample (multi-rate data are compared there; the
    # inputs are played at every instant)
    sampled = [np.all(np.isfinite(r.measured), axis=1) for r, _ in records]
    channels, units, floor = _channels(job, model)
    present = np.concatenate(sampled)
    if job.kind == "staircase" and job.steady_s > 0:
        mask = present & per_record(lambda r: steady_mask(r.time, r.inputs, job.steady_s, job.min_hold_s))
    else:
        mask = present
    if not mask.any():
        from cosim.errors import ConfigError
        raise ConfigError(f"{job.path}: no hold of the input lasts experiment.steady_s = {job.steady_s:g} s")
    floor = np.array(floor)
    if job.kind == "frequency":  # per frequency, shaped by the coherence
        sigma, estimated = frequency_noise(e, floor)
    else:
        estimated = noise_level(t, y, present & per_record(lambda r: steady_mask(r.time, r.inputs,
                                                                                  job.steady_s or 0.2, job.min_hold_s))
                                if job.kind == "staircase" else mask)
        if job.kind == "impact":  # from every sample first, then from the approach and steady hold of each record
            rough = max(estimated[0], floor[0])
            quiet = np.concatenate([_spread(p, quiet_phases(r.time[p], r.measured[p, 0], rough))
                                    for (r, _), p in zip(records, sampled)])
            if (mask & quiet).sum() >= MIN_QUIET_SAMPLES:
                estimated = noise_level(t, y, mask & quiet)
        sigma = np.maximum(estimated, floor)
    weights = 1.0 / sigma

    # 1. replay and compare
    base = _fit(model, records, job, dict(job.free), weights, mask, "baseline")
    before = base["predicted"]
    residual = before - y
    rmse_before, max_before = _rmse(before, y, mask)

    # 2. locate (the segments; their table once the baseline is final, after the restarts below)
    if job.kind == "frequency":
        segments, shape = frequency_bands(t, y[0], job.bands_per_decade), band_shape
    else:
        segments, shape = [], None
        for k, ((r, _), shift, p) in enumerate(zip(records, shifts, sampled)):
            for piece in cut_segments(r.time[p], r.inputs[p], job.kind, r.measured[p, 0], sigma[0], job.min_hold_s):
                segments.append(replace(piece, index=len(segments), t0=piece.t0 + shift, t1=piece.t1 + shift,
                                        label=piece.label if len(records) == 1 else
                                        f"record {k} ({job.records[k][0].name}): {piece.label}"))

    # 3. name: two-fold cross-validation over segments (fit on the even ones, score on the odd ones, and back)
    seg_index = np.full(len(t), -1)
    for s in segments:
        seg_index[in_segment(t, s)] = s.index
    folds = [(mask & (seg_index % 2 == 0), mask & (seg_index % 2 == 1)),
             (mask & (seg_index % 2 == 1), mask & (seg_index % 2 == 0))]
    if not all(train.any() and test.any() for train, test in folds):
        even = np.arange(len(t)) % 2 == 0
        folds = [(mask & even, mask & ~even), (mask & ~even, mask & even)]
    candidates = []
    folder = Path(tempfile.mkdtemp(prefix="cosim-diagnose-"))
    results = {}
    if job.effects:
        base_free = {n: (base["parameters"][n], lo, hi) for n, (_, lo, hi) in job.free.items()}
        tasks = [{"job": job, "effect": "baseline", "variant_path": str(job.source), "variant_model": job.model,
                  "baseline": base_free, "weights": weights, "mask": train, "fold": f}
                 for f, (train, _) in enumerate(folds)]
        for name in job.effects:
            path, variant = write_variant(job.source, job.model, EFFECTS[name], folder / name)
            tasks += [{"job": job, "effect": name, "variant_path": str(path), "variant_model": variant,
                       "baseline": base_free, "weights": weights, "mask": train, "fold": f}
                      for f, (train, _) in enumerate(folds)]
        for task, res in zip(tasks, _run_tasks(job, tasks, progress)):
            results.setdefault(task["effect"], [None, None])[task["fold"]] = res
        # A candidate contains the baseline, so its fit may find values of the baseline's parameters that the
        # baseline's own fit missed (an impact's cost is rough: the held force jumps with where the motor sticks).
        # The baseline is refitted from the values of every candidate that beats it by more than min_delta_bic on
        # the same samples, so that no candidate wins by a better start.
        restarted = []
        for f, (fit, (train, _)) in enumerate(zip(results["baseline"], folds)):
            better = [results[n][f] for n in job.effects if results[n][f]["chi2"] < fit["chi2"] - job.min_delta_bic]
            restarted.append(_restart_baseline(job, model, records, fit, better, weights, train))
        moved = [new for new, old in zip(restarted, results["baseline"]) if new is not old]
        results["baseline"] = restarted
        # The other way round: a candidate fitting a fold worse than the (restarted) baseline stalled (a
        # step in the effect's parameter can stall the trust region while the baseline's parameters still had
        # far to go). It is refitted from the baseline's values on that fold.
        stalled = [{**task, "baseline": {n: (results["baseline"][task["fold"]]["parameters"][n], lo, hi)
                                         for n, (_, lo, hi) in job.free.items()}}
                   for task in tasks if task["effect"] != "baseline"
                   and results[task["effect"]][task["fold"]]["chi2"] > results["baseline"][task["fold"]]["chi2"]]
        for task, retry in zip(stalled, _run_tasks(job, stalled, progress)):
            if retry["chi2"] < results[task["effect"]][task["fold"]]["chi2"]:
                results[task["effect"]][task["fold"]] = retry
        if moved:
            base = _restart_baseline(job, model, records, base, moved, weights, mask)
            before = base["predicted"]
            residual = before - y
            rmse_before, max_before = _rmse(before, y, mask)
    rows = segment_table(t, residual, before, y, mask, segments, sigma, job.gap_sigmas, shape)
    findings = branch_shapes(segments, rows, sigma)
    white = whiteness(residual[0, mask])
    cross = None if job.kind == "frequency" else cross_correlation(residual[0, mask], e.inputs[mask, 0])
    n_fit = int(mask.sum()) * y.shape[0]
    # a gap is a segment above gap_sigmas noise levels *and* a baseline whose whole residual is more than noise:
    # its mean square (in noise units) must exceed 1 by more than gap_sigmas times the sqrt(2/n) a mean of n
    # squared unit noises scatters by (a lone segment at 3 sigma is also what noise gives over many segments)
    ms_baseline, chance = _ms(before, y, weights, mask), 1.0 + job.gap_sigmas * np.sqrt(2.0 / n_fit)
    gap_found = any(r["significant"] for r in rows) and bool(ms_baseline > chance)

    def pooled(fits):
        """Held-out weighted residuals of both folds (each cost sample predicted by the fit that did not see it),
        and the summed training chi-square."""
        r = np.concatenate([weighted(fit["predicted"] - y, weights)[:, test].ravel()
                            for fit, (_, test) in zip(fits, folds)])
        return r, sum(fit["chi2"] for fit in fits)

    k_base = len(job.free)
    if results:
        r_b, chi2_b = pooled(results["baseline"])
        ms_b_test = float(np.mean(r_b ** 2))
    for name in job.effects:
        fits = results[name]
        k = len(fits[0]["free"])
        r_c, chi2_c = pooled(fits)
        ms_c = float(np.mean(r_c ** 2))
        removed = (ms_b_test - ms_c) / max(ms_b_test - 1.0, 1e-12) if ms_b_test > 1.0 else 0.0
        delta = chi2_b - chi2_c
        heldout = np.concatenate([(fit["predicted"] - y)[0, test] for fit, (_, test) in zip(fits, folds)])
        candidates.append({
            "effect": name, "score": float(removed),
            "rmse_after": float(np.sqrt(np.mean(heldout ** 2))), "max_error_after": float(np.max(np.abs(heldout))),
            "parameters": dict(fits[0]["parameters"]),
            "parameters_other_fold": dict(fits[1]["parameters"]),
            "added_parameters": [p.name for p in EFFECTS[name].parameters] + [n for n, _, _ in EFFECTS[name].frees],
            "heldout_ms_sigma2": ms_c, "aic": chi2_c + 2 * k, "bic": chi2_c + k * np.log(n_fit),
            "delta_aic": float(delta - 2 * (k - k_base)), "delta_bic": float(delta - (k - k_base) * np.log(n_fit)),
            "p_value": float(stats.chi2.sf(max(delta, 0.0), max(k - k_base, 1))),
            "free": fits[0]["free"],
        })
    qualified = [c for c in candidates if gap_found and c["score"] >= job.min_gap_removed
                 and c["delta_bic"] >= job.min_delta_bic]
    winner = max(qualified, key=lambda c: (c["score"], c["delta_bic"])) if qualified else None
    effect = winner["effect"] if winner else "none"
    rivals = rivals_of(winner, qualified)

    # 4. add and show
    after, variant_source, variant_diff, final, rerun_out = before, "", "", None, None
    if winner:
        from cosim.compile import lower as lower_variant

        path, variant = write_variant(job.source, job.model, EFFECTS[effect], folder / "winner")
        vmodel = lower_variant(path, variant)
        folds_fit = (winner["parameters"], winner["parameters_other_fold"])
        starts = [{n: 0.5 * (folds_fit[0][n] + folds_fit[1][n]) for n in folds_fit[0]}]
        if any(abs(folds_fit[0][n] - folds_fit[1][n]) > 0.1 * abs(starts[0][n]) for n in folds_fit[0]):
            starts += folds_fit  # the folds found different minima: their mean may lie in neither basin
        variant_records = load_records(job, vmodel)
        final = min((_fit(vmodel, variant_records, job, {n: (v, *winner["free"][n][1:]) for n, v in start.items()},
                          weights, mask, effect) for start in starts), key=lambda fit: fit["chi2"])
        after = final["predicted"]
        variant_source = path.read_text(encoding="utf-8")
        import difflib

        variant_diff = "".join(difflib.unified_diff(
            Path(job.source).read_text(encoding="utf-8").splitlines(keepends=True),
            variant_source.splitlines(keepends=True), fromfile=str(job.source), tofile=f"{job.source} ({effect})"))
        if build:
            target = Path(out) if out is not None else folder
            if job.kind == "frequency":  # a frequency response is not a time series the master could replay
                from cosim.compile import build_fmu

                final["fmu"] = str(build_fmu(path, variant, out_dir=target / "fmu"))
            else:
                rerun_out = _rerun_both(job, records, model, base, path, variant, final, target, y, mask)
    rmse_after, max_after = _rmse(after, y, mask)
    ms_after = _ms(after, y, weights, mask)
    rows_after = segment_table(t, after - y, after, y, mask, segments, sigma, job.gap_sigmas, shape)
    seg_out = []
    for rb, ra in zip(rows, rows_after):
        seg_out.append({**{k: rb[k] for k in ("segment", "kind", "t0", "t1", "level", "samples", "significant",
                                              "shape", "sigmas")},
                        "signal": channels[rb["signal"]], "bias_before": rb["bias"], "rmse_before": rb["rmse"],
                        "max_error_before": rb["max_error"], "bias_after": ra["bias"], "rmse_after": ra["rmse"],
                        "max_error_after": ra["max_error"], "significant_after": ra["significant"]})
    summary = {
        "job": str(job.path), "model": job.model, "data": str(job.data_path),
        "records": [{"path": str(path), "parameters": trial, "samples": len(r.time), "compared": int(p.sum()),
                     "time_shift": shift}
                    for (path, trial), (r, _), shift, p in zip(job.records, records, shifts, sampled)],
        "effect": effect,
        "verdict": (f"missing effect: {effect} ({EFFECTS[effect].title})" if winner else
                    "no missing effect found" + ("" if gap_found else
                                                 f": the baseline fits within the noise (mean square "
                                                 f"{ms_baseline:.3g} noise levels squared, chance up to "
                                                 f"{chance:.3g}; segments above {job.gap_sigmas:g} noise "
                                                 f"levels: {sum(r['significant'] for r in rows)})")),
        "also_explained_by": rivals,
        "kind": job.kind,
        "signals": channels,
        "units": units,
        "inputs": [u.name for u in model.inputs] if job.kind != "frequency" else [],
        "input_units": [u.unit for u in model.inputs] if job.kind != "frequency" else [],
        "parameter_units": {**{p.name: p.unit for p in model.parameters},
                            **{p.name: p.unit for n in job.effects for p in EFFECTS[n].parameters}},
        "noise": {"estimated": estimated.tolist(), "floor": floor.tolist(),
                  "used": (sigma if sigma.ndim == 1 else np.median(sigma, axis=1)).tolist()},
        "rmse_before": rmse_before[0], "rmse_after": rmse_after[0],
        "max_error_before": max_before[0], "max_error_after": max_after[0],
        "rmse_before_per_signal": rmse_before, "rmse_after_per_signal": rmse_after,
        "gap_removed": float(1 - (ms_after - 1) / (ms_baseline - 1)) if ms_baseline > 1 else 0.0,
        "baseline": {"parameters": base["parameters"], "free": {n: list(v) for n, v in job.free.items()}},
        "after": ({"parameters": final["parameters"], "fmu": final.get("fmu")} if final else None),
        "rerun": rerun_out,
        "segments": seg_out,
        "gap_found": gap_found,
        "baseline_mean_square": ms_baseline,  # weighted residual on the cost samples, in noise levels squared
        "shapes": findings,
        "whiteness": white,
        "input_cross_correlation": cross,
        "folds": {"scheme": "two-fold over segments: fit on the even ones, score on the odd ones, and back",
                  "samples": [int(train.sum()) for train, _ in folds]},
        "decision": {"min_gap_removed": job.min_gap_removed, "min_delta_bic": job.min_delta_bic,
                     "gap_sigmas": job.gap_sigmas, "mean_square_chance": chance},
        "candidates": sorted(candidates, key=lambda c: -c["score"]),
    }
    preds = {name: fits[0]["predicted"] for name, fits in results.items()}
    for c in candidates:
        del c["free"]
    if not (build and winner and out is None):  # keep the folder only when it holds the built FMU
        shutil.rmtree(folder, ignore_errors=True)
    return Diagnosis(effect=effect, summary=summary, time=t, inputs=inputs, measured=y, before=before,
                     after=after, mask=mask, noise=sigma, variant_source=variant_source, variant_diff=variant_diff,
                     candidate_predictions=preds)
