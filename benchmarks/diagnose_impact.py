"""Confusion matrix of the discrepancy workflow over random hidden-effect impact cases.

Each case: a current step closing P2-coated fingers onto the ABS cylinders, from the reduced gripper of
tests/diagnose_truth_impact.py (written from the paper's equations independently of the Modelica plant and of the
candidates) with random parameters and one hidden effect or none; load cell at 100 Hz with 0.5 N noise, 2048 cpt
encoder. The workflow fits the baseline Gripper.GripperCurrentDriven (eta_g, T_c0 free; on the impact also the
presliding angle phi_b) and the candidates on F_g and theta_m and names one effect or "none".

With ``--trials N`` each case is N repeated impacts (the paper's protocol repeats each condition), the object
placed anew within 0.1 mm each time (its position given per record, as the encoder angle at first contact would
give it), diagnosed together: the rotor comes to rest at another angle in each.

With ``--experiment slide`` the current is not a step but the slide of tests/diagnose_truth_impact.py (two stops
and restarts against the jaw guides, then the object 15 mm away), diagnosed as a staircase: it shows the guides'
stiction, which the impact cannot. With ``--experiment speed`` the jaws run free under a PI speed loop at four
slow speeds, the current (10 mA noise) and the encoder at 1 kHz compared (model Gripper.GripperSpeedControlled):
the classic cogging measurement, where a detent shows as a ripple of the current.

Run: python benchmarks/diagnose_impact.py [--cases N] [--seed S] [--workers W] [--effects a,b] [--trials N]
                                          [--experiment impact|slide|speed] [--only a] [--from-case K] [--save DIR]
                                          [--validation]
``--only`` and ``--from-case`` re-run a subset of a run's cases on the same draws (e.g. after a change to one
candidate, or to finish a run that was stopped).
Prints one line per case, with how much the hidden effect alone changes the noise-free truth's records (a miss
of an effect smaller than the 0.5 N load-cell noise and one encoder count is the experiment's limit, not the
workflow's) and the three best candidates' held-out scores and delta BIC (a miss's or false alarm's margin), then
the confusion matrix (rows: truth, columns: named), the share named right, the false-alarm rate on "none" cases
and the gap above the noise removed by the named effect when it is right: in the mean square of both compared
signals in noise units (diagnosis.json's ``gap_removed``), and in the first (force, or the speed run's current)
alone.
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from diagnose_truth_impact import (COUNTS, EXPERIMENTS, TRUTH_EFFECTS, effect_signal, make_case,  # noqa: E402
                                   write_job)

from cosim.diagnose import load_diagnose_job, run_diagnosis  # noqa: E402
from cosim.diagnose.report import write_diagnosis  # noqa: E402
from validation import write_confusion  # noqa: E402

CANDIDATES = ("gear_play", "contact_damping", "coating_relaxation", "stiction", "loadcell_filter", "cogging",
              "load_dependent_friction")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=2, help="cases per truth effect")
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--workers", type=int, default=0, help="Dask worker processes (0: in this process)")
    parser.add_argument("--effects", default=",".join(TRUTH_EFFECTS), help="truth effects to draw, comma-separated")
    parser.add_argument("--trials", type=int, default=1,
                        help="repeated impacts per case, the object placed anew within 0.1 mm: one record each, "
                             "diagnosed together")
    parser.add_argument("--experiment", choices=EXPERIMENTS, default="impact",
                        help="the current step onto the object, the slide (two restarts, then the object), or the "
                             "speed run (jaws free, four slow speeds under a PI speed loop)")
    parser.add_argument("--only", help="diagnose only the cases of these truth effects (comma-separated); the "
                                       "others are drawn and skipped, so the draws are those of a run of all")
    parser.add_argument("--from-case", type=int, default=0, metavar="K",
                        help="diagnose cases K and later only; the earlier are drawn and skipped, as with --only")
    parser.add_argument("--save", type=Path, metavar="DIR",
                        help="write each case's diagnosis (diagnosis.json, report.md, plots) to DIR/case<K>_<effect>")
    parser.add_argument("--validation", action="store_true",
                        help="also write the confusion matrix into docs/validation.md")
    args = parser.parse_args(argv)
    if not 0 <= args.from_case < args.cases:
        parser.error(f"--from-case must be in 0..{args.cases - 1}")
    labels = args.effects.split(",")
    unknown = sorted(set(labels) - set(TRUTH_EFFECTS))
    if unknown:
        parser.error(f"--effects: no truth for {', '.join(unknown)}; known: {', '.join(TRUTH_EFFECTS)}")
    only = args.only.split(",") if args.only else labels
    if set(only) - set(labels):
        parser.error(f"--only: {', '.join(sorted(set(only) - set(labels)))} not among --effects")
    named_labels = labels + [c for c in ("none", *CANDIDATES) if c not in labels]
    matrix = pd.DataFrame(0, index=labels, columns=named_labels)
    gaps = []
    rng = np.random.default_rng(args.seed)
    source = ROOT / "modelica" / "Gripper" / "package.mo"
    start = time.time()
    for k in range(args.cases):
        for effect in labels:
            case = make_case(effect, rng, trials=args.trials, experiment=args.experiment)
            if effect not in only or k < args.from_case:
                continue
            with tempfile.TemporaryDirectory() as folder:
                t0 = time.time()
                job = load_diagnose_job(write_job(Path(folder), source, case, CANDIDATES, workers=args.workers,
                                                  experiment=args.experiment))
                diagnosis = run_diagnosis(job, progress=False, build=False)
            if args.save:
                write_diagnosis(diagnosis, args.save / f"case{k}_{effect}", source)
            s = diagnosis.to_json()
            matrix.loc[effect, s["effect"]] += 1
            channel, unit, noise = s["signals"][0], s["units"][0], s["noise"]["used"][0]
            channel_gap = (1 - (s["rmse_after"] ** 2 - noise ** 2) / (s["rmse_before"] ** 2 - noise ** 2)
                         if s["rmse_before"] > noise else 0.0)
            if effect != "none" and s["effect"] == effect:
                gaps.append((s["gap_removed"], channel_gap))
            truth = {key: round(float(v), 5) for key, v in case[1].items() if key != "effect"}
            fitted = {key: round(float(v), 5) for key, v in (s["after"] or {}).get("parameters", {}).items()}
            count = 2 * np.pi / COUNTS
            alone = effect_signal(case, args.experiment)
            print(f"case {k} truth {effect:18s} named {s['effect']:18s} {channel} RMSE {s['rmse_before']:.3f} -> "
                  f"{s['rmse_after']:.3f} {unit} (noise {noise:.3f} {unit}), theta_m RMSE "
                  f"{s['rmse_before_per_signal'][1] / count:.1f} -> {s['rmse_after_per_signal'][1] / count:.1f} "
                  f"counts, gap removed {100 * s['gap_removed']:5.1f} % ({channel} alone {100 * channel_gap:5.1f} %) "
                  f"({time.time() - t0:.0f} s); the effect alone (truth, "
                  f"noise-free): {channel} {alone[0]:.3f} {unit}, theta_m {alone[1] / count:.1f} counts; "
                  f"truth {truth}; fitted {fitted}; baseline mean square {s['baseline_mean_square']:.2f} "
                  f"(gap found: {s['gap_found']}), held-out scores (need {s['decision']['min_gap_removed']:g}, "
                  f"delta BIC {s['decision']['min_delta_bic']:g}): "
                  + ", ".join(f"{c['effect']} {c['score']:.2f} ({c['delta_bic']:.0f})" for c in s["candidates"][:3]),
                  flush=True)
    print()
    diagnosed = args.cases - args.from_case
    print(f"confusion matrix (rows: hidden effect, columns: named), {diagnosed} cases each"
          + (f" (cases {args.from_case}-{args.cases - 1})" if args.from_case else "") + f", seed {args.seed}, "
          f"{args.trials} {args.experiment}(s) a case, "
          f"{time.time() - start:.0f} s:")
    print(matrix.loc[only, (matrix != 0).any() | matrix.columns.isin(only)].to_string())
    effects = [e for e in only if e != "none"]
    right = sum(matrix.loc[e, e] for e in effects)
    print(f"named right: {right}/{diagnosed * len(effects)}"
          + (f"; false alarms on 'none': {diagnosed - matrix.loc['none', 'none']}/{diagnosed}"
             if "none" in only else ""))
    if gaps:
        both, channel_only = np.array(gaps).T
        print(f"gap above the noise removed when named right (mean square of {channel} and theta_m in noise units, as "
              f"diagnosis.json's gap_removed): min {100 * both.min():.0f} %, median {100 * np.median(both):.0f} %; "
              f"{channel} alone: min {100 * channel_only.min():.0f} %, median {100 * np.median(channel_only):.0f} %")
    if args.validation:
        write_confusion(f"diagnose-{args.experiment}" + ("-trials" if args.trials > 1 else ""), matrix.loc[only],
                        gaps, [args.seed])


if __name__ == "__main__":
    main()
