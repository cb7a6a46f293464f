"""Diagnosis outputs: ``diagnosis.json``, ``report.md``, the PNG figures, the winner's Modelica variant and diff."""

import json
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from cosim.diagnose.kinds import KINDS  # noqa: E402

__all__ = ["write_diagnosis", "plot_diagnosis"]


def plot_diagnosis(diagnosis, folder):
    """Write ``fit.png`` (measured vs before vs after, residuals) and, for a staircase, ``curve.png`` (output
    against input at the cost samples), or for a frequency response ``bode.png`` and ``bands.png``; returns the
    file names."""
    d, tr = diagnosis, diagnosis.traces
    folder = Path(folder)
    kind = KINDS.get(d.kind)  # records of several experiments ("several") are time series without held levels
    if kind is not None and not kind.time_series:
        return _plot_frequency(diagnosis, folder)
    names = []
    n = tr.measured.shape[0]
    after = " and ".join(d.findings or [d.effect])  # the final model holds every finding of the rounds
    fig, axes = plt.subplots(2 * n, 1, figsize=(10, 3.2 * 2 * n), sharex=True)
    for j in range(n):
        ax, ar = axes[2 * j], axes[2 * j + 1]
        ax.plot(tr.time, tr.measured[j], ".", ms=2, color="0.5", label="measured")
        ax.plot(*_apart(tr.time, tr.before[j]), color="C0", lw=1.2,
                label=f"baseline (RMSE {d.rmse_before_per_signal[j]:.3g})")
        if d.effect != "none":
            ax.plot(*_apart(tr.time, tr.after[j]), color="C3", lw=1.2,
                    label=f"with {after} (RMSE {d.rmse_after_per_signal[j]:.3g})")
        label = f"{d.signals[j]} [{d.units[j]}]"
        ax.set_ylabel(label)
        ax.legend(loc="best", fontsize=8)
        ax.grid(alpha=0.3)
        sigma = d.noise.sigma[j] if d.noise.sigma.ndim == 2 else d.noise.used[j]
        ar.plot(tr.time[tr.mask], (tr.before[j] - tr.measured[j])[tr.mask], ".", ms=2, color="C0", label="baseline")
        if d.effect != "none":
            ar.plot(tr.time[tr.mask], (tr.after[j] - tr.measured[j])[tr.mask], ".", ms=2, color="C3",
                    label=after)
        ar.fill_between(tr.time, -3 * sigma, 3 * sigma, color="0.85", label="±3 noise")
        ar.set_ylabel(f"residual {label}")
        ar.legend(loc="best", fontsize=8)
        ar.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]" + (f" ({len(d.records)} records end to end)" if len(d.records) > 1 else ""))
    fig.suptitle(d.verdict, fontsize=10)
    fig.tight_layout()
    fig.savefig(folder / "fit.png", dpi=110)
    plt.close(fig)
    names.append("fit.png")
    ramps = any(seg.kind in ("up", "down") for seg in d.segments)
    if kind is not None and kind.held_levels and tr.inputs.shape[1] >= 1 and ramps:
        fig, ax = plt.subplots(figsize=(7, 5))
        m = tr.mask
        ax.plot(tr.inputs[m, 0], tr.measured[0, m], ".", ms=3, color="0.5", label="measured")
        ax.plot(tr.inputs[m, 0], tr.before[0, m], ".", ms=3, color="C0", label="baseline")
        if d.effect != "none":
            ax.plot(tr.inputs[m, 0], tr.after[0, m], ".", ms=3, color="C3", label=f"with {after}")
        ax.set_xlabel(f"{d.inputs[0]} (held level) [{d.input_units[0]}]")
        ax.set_ylabel(f"{d.signals[0]} [{d.units[0]}]")
        ax.grid(alpha=0.3)
        ax.legend()
        ax.set_title("steady values: rising and falling branches")
        fig.tight_layout()
        fig.savefig(folder / "curve.png", dpi=110)
        plt.close(fig)
        names.append("curve.png")
    return names


def _plot_frequency(diagnosis, folder):
    """``bode.png``: magnitude and phase, measured vs before vs after, and the residuals with the +-3 sigma band
    over frequency (band edges dotted); ``bands.png``: RMS residual per band before and after, in noise levels."""
    d, tr = diagnosis, diagnosis.traces
    f = tr.time
    fig, axes = plt.subplots(4, 1, figsize=(9, 11), sharex=True)
    for j in range(2):
        ax, ar = axes[j], axes[2 + j]
        label = f"{d.signals[j]} [{d.units[j]}]"
        ax.semilogx(f, tr.measured[j], ".", ms=3, color="0.5", label="measured")
        ax.semilogx(f, tr.before[j], color="C0", lw=1.2, label="baseline")
        ar.semilogx(f, tr.before[j] - tr.measured[j], ".", ms=3, color="C0", label="baseline")
        if d.effect != "none":
            ax.semilogx(f, tr.after[j], color="C3", lw=1.2, label=f"with {d.effect}")
            ar.semilogx(f, tr.after[j] - tr.measured[j], ".", ms=3, color="C3", label=d.effect)
        ar.fill_between(f, -3 * d.noise.sigma[j], 3 * d.noise.sigma[j], color="0.85", label="±3 noise")
        ax.set_ylabel(label)
        ar.set_ylabel(f"residual {d.signals[j]} [{d.units[j]}]")
        for a in (ax, ar):
            for seg in d.segments[::2]:
                a.axvline(seg.t0, color="0.7", lw=0.6, ls=":")
            a.grid(alpha=0.3, which="both")
            a.legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("frequency [Hz]")
    fig.suptitle(d.verdict, fontsize=10)
    fig.tight_layout()
    fig.savefig(folder / "bode.png", dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for j, ax in enumerate(axes):
        rows = [r for r in d.segments if r.signal == d.signals[j]]
        x = np.arange(len(rows))
        level = [r.rmse_before / r.sigmas if r.sigmas else np.nan for r in rows]
        ax.bar(x - 0.2, [r.sigmas for r in rows], 0.4, color="C0", label="baseline")
        ax.bar(x + 0.2, [r.rmse_after / n for r, n in zip(rows, level)], 0.4, color="C3",
               label=d.effect if d.effect != "none" else "after (= baseline)")
        ax.axhline(d.decision["gap_sigmas"], color="k", lw=0.8, ls="--", label="significance")
        ax.set_ylabel("RMS residual [noise levels]")
        ax.set_title(f"{d.signals[j]} [{d.units[j]}] per band", fontsize=9)
        ax.set_xticks(x, [f"{r.t0:.3g}-{r.t1:.3g}" for r in rows], rotation=30, fontsize=8)
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("frequency band [Hz]")
    fig.tight_layout()
    fig.savefig(folder / "bands.png", dpi=110)
    plt.close(fig)
    return ["bode.png", "bands.png"]


def _apart(time, values):
    """``time`` and ``values`` with a NaN at each gap between records (a step over 1.5 sample intervals), so a
    line does not join the end of one record to the start of the next."""
    cut = np.flatnonzero(np.diff(time) > 1.5 * np.median(np.diff(time))) + 1
    return np.insert(time, cut, np.nan), np.insert(values, cut, np.nan)


def _experiments(d):
    """The table of a job of several experiments: each one's noise and gap before and after, and what the
    finding removed from it (where it shows)."""
    if not d.experiments:
        return []
    lines = ["## Experiments", "", "Each record's own noise (1 sd, per channel) weighs its residuals; the gap is "
             "its RMS residual in noise levels on its cost samples. A finding shows where it removes chi-square.",
             "", "| experiment | kind | cost samples | noise | gap before | gap after | chi-square removed |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {e.name} | {e.kind} | {e.samples} | {', '.join(f'{v:.3g}' for v in e.noise)} | "
              f"{e.gap_before:.1f} | {e.gap_after:.1f} | {e.chi2_removed:.4g} |" for e in d.experiments]
    return lines + [""]


def _report(diagnosis, figures):
    d = diagnosis
    unit = f" {d.units[0]}" if d.units and d.units[0] else ""
    pu = d.parameter_units

    def values(params, names=None):
        return ", ".join(f"{k} = {v:.5g}" + (f" {pu[k]}" if pu.get(k, "1") != "1" else "")
                         for k, v in params.items() if names is None or k in names)

    lines = [f"# Diagnosis: {d.model}", "", f"**{d.verdict}**", ""]
    if d.evidence:
        lines += [f"- **evidence**: {d.evidence}", f"- **next step**: {d.next_step}", ""]
    if len(d.rounds) > 1:
        lines += ["## Rounds", "", "Each round adds what the one before found and looks again at the gap left (RMS "
                  "residual in noise levels). A finding the later ones explain is dropped, and the last round is "
                  "run again without it.", "", "| round | found | kind | fitted parameters | gap before | gap "
                  "after |", "|---|---|---|---|---|---|"]
        lines += [f"| {r.number} | {r.effect}{' (dropped)' if r.dropped else ''} | "
                  f"{'form' if r.form else 'effect' if r.effect != 'none' else '-'} | "
                  f"{values(r.parameters) or '-'} | {r.gap_before:.1f} | {r.gap_after:.1f} |" for r in d.rounds]
        lines += [""]
    lines += _experiments(d)
    if d.also_explained_by:
        lines += [f"Nearly as good on the held-out segments: {', '.join(d.also_explained_by)} (the data do not "
                  f"tell these apart).", ""]
    records = d.records
    together = "experiments" if d.experiments else "repeated trials"
    data = f"`{d.data}`" if len(records) == 1 else f"{len(records)} records ({together}, one fit): " + \
        ", ".join(f"`{r.path}`" + (f" ({values(r.parameters)})" if r.parameters else "") for r in records)
    lines += [f"- data: {data}; signals: {', '.join(d.signals)}",
              f"- noise (1 sd) estimated from the data: {', '.join(f'{v:.3g}' for v in d.noise.estimated)}; "
              f"used (floored by the job): {', '.join(f'{v:.3g}' for v in d.noise.used)} "
              f"({', '.join(f'{n} [{u}]' for n, u in zip(d.signals, d.units))})",
              f"- {d.signals[0]} on the cost samples, model replayed by CVODES on the lowered equations: RMSE "
              f"before {d.rmse_before:.4g}{unit}, after {d.rmse_after:.4g}{unit}; max error before "
              f"{d.max_error_before:.4g}{unit}, after {d.max_error_after:.4g}{unit}; gap above the noise "
              f"removed (all channels): {100 * d.gap_removed:.0f} %",
              "- baseline parameters: " + values(d.baseline_parameters), ""]
    if d.after_parameters is not None:
        lines += ["- after: " + values(d.after_parameters), ""]
    if d.rerun is not None:
        r = d.rerun
        lines += [f"- re-run of the built FMUs through the master ({', '.join(f'`{c}`' for c in r.configs.values())}"
                  f"; BDF, measured inputs played), {r.signal}: RMSE before {r.rmse_before:.4g}{unit}, after "
                  f"{r.rmse_after:.4g}{unit}; max error before {r.max_error_before:.4g}{unit}, after "
                  f"{r.max_error_after:.4g}{unit}; largest difference to the CVODES replay "
                  f"{max(r.max_difference_to_replay_before, r.max_difference_to_replay_after):.3g}{unit}", ""]
    lines += _not_identifiable(d)
    of_round = f" (round {len(d.rounds)}: its baseline has the earlier findings)" if len(d.rounds) > 1 else ""
    lines += [f"## Candidates{of_round}", "",
              "Fitted on the even segments, scored on the odd ones (score: fraction of the baseline's held-out gap "
              "above the noise that the candidate removes).", "",
              f"| effect | score | ΔBIC | ΔAIC | p (LR) | RMSE after [{unit.strip()}] | fitted parameters |",
              "|---|---|---|---|---|---|---|"]
    for c in d.candidates:
        params = values(c.parameters, c.added_parameters)
        lines.append(f"| {c.effect} | {c.score:.3f} | {c.delta_bic:.1f} | {c.delta_aic:.1f} | "
                     f"{c.p_value:.2g} | {c.rmse_after:.4g} | {params} |")
    lines += ["", f"## Where the gap is{of_round}", "",
              "| segment | signal | samples | bias before | RMSE before | × noise | "
              "shape | RMSE after |", "|---|---|---|---|---|---|---|---|"]
    for r in d.segments:
        lines.append(f"| {r.segment} | {r.signal} | {r.samples} | {r.bias_before:+.3g} | "
                     f"{r.rmse_before:.3g} | {r.sigmas:.1f}{' **!**' if r.significant else ''} | "
                     f"{r.shape} | {r.rmse_after:.3g} |")
    for f in d.shapes:
        lines += ["", f"- {f['shape']}: {f['detail']}"]
    w, c = d.whiteness, d.input_cross_correlation
    lines += ["", "## Residual analysis (baseline)", "",
              f"- whiteness: {w['outside']} of {len(w['acf'])} autocorrelations outside ±{w['band']:.3g}; Ljung-Box "
              f"Q = {w['q']:.4g}, p = {w['p_value']:.2g} ({'white' if w['white'] else 'not white: structure left'})"]
    if c is not None:  # a frequency response has no input time series
        verdict = "independent" if c["independent"] else "the residual still depends on the input"
        lines += [f"- cross-correlation with the input: {c['outside']} of {len(c['ccf'])} lags outside "
                  f"±{c['band']:.3g} ({verdict})"]
    lines += [""]
    lines += ["## Figures", ""] + [f"![{f}]({f})" for f in figures]
    if diagnosis.variant_diff:
        lines += ["", "## The change to the Modelica source", "",
                  "`modelica/` holds the package with the variant; `variant.diff` is the change:", "", "```diff",
                  diagnosis.variant_diff.rstrip(), "```"]
    return "\n".join(lines) + "\n"


def _not_identifiable(d):
    """The section on effects plausible but not identifiable on these data (none: no lines)."""
    if not d.not_identifiable:
        return []
    lines = ["## Plausible but not identifiable on these data", "",
             "| effect | why | change here [noise levels: RMS, max; segments moved] | experiment that shows it | "
             "expected change there |", "|---|---|---|---|---|"]
    for a in d.not_identifiable:
        h, s = a["change_here"], a["shown_by"]
        there = (f"{s['rms']:.3g} RMS, {s['max']:.3g} max on {s['signal']} ({s['rms_noise_levels']:.1f}, "
                 f"{s['max_noise_levels']:.1f} noise levels)" if s["computed"] else f"not computed: {s['why']}")
        job = f" (`{s['job']}`)" if s["job"] else ""
        lines.append(f"| {a['effect']} | {a['why']} | {h['rms_noise_levels']:.2g}, {h['max_noise_levels']:.2g}; "
                     f"{h['segments_moved']} of {h['segments']} | {s['experiment']}{job} | {there} |")
    return lines + [""]


def write_diagnosis(diagnosis, out, source=None):
    """Write ``diagnosis.json``, ``report.md``, PNGs and (when an effect is named) ``modelica/<Pkg>/<file>`` and
    ``variant.diff`` into ``out`` (created if missing; :func:`cosim.diagnose.diagnose` gives a staging folder it
    moves into place, so that no file of the user's is replaced)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figures = plot_diagnosis(diagnosis, out)
    (out / "diagnosis.json").write_text(json.dumps(diagnosis.to_json(), indent=2) + "\n", encoding="utf-8")
    (out / "report.md").write_text(_report(diagnosis, figures), encoding="utf-8")
    if diagnosis.variant_source and source is not None:
        target = out / "modelica" / Path(source).parent.name / Path(source).name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(diagnosis.variant_source, encoding="utf-8")
        (out / "variant.diff").write_text(diagnosis.variant_diff, encoding="utf-8")
    return out
