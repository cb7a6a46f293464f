"""Confusion matrix of the discrepancy workflow on frequency responses of the haptic device + user.

Each case: a simulated identification experiment (tests/diagnose_truth_haptic.py: white-noise torque, encoder
quantisation, Welch estimate) on a random true plant written independently of the Modelica device and of the
candidates: a 7-parameter device + user (none), an 11-parameter one (hand_mass, seed 000 eq. 2), the 7-parameter
one with a second mode from a hand-written state space (vibration_mode), or with an exact torque delay
(loop_delay). The workflow fits the baseline Haptic.Device7 and the three candidates and names one or "none".

Run: python benchmarks/diagnose_haptic.py [--cases N] [--seed S] [--effects a,b] [--validation]
Prints one line per case, then the confusion matrix (rows: truth, columns: named), the false-alarm rate on "none"
cases and the gap above the noise removed by the named effect when it is right.
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from diagnose_truth_haptic import TRUTH_EFFECTS, make_case  # noqa: E402
from test_diagnose_haptic import HAPTIC, _write_job  # noqa: E402

from cosim.diagnose import load_diagnose_job, run_diagnosis  # noqa: E402
from validation import write_confusion  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=3, help="cases per truth effect")
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--effects", default=",".join(TRUTH_EFFECTS), help="truth effects to draw, comma-separated")
    parser.add_argument("--validation", action="store_true",
                        help="also write the confusion matrix into docs/validation.md")
    args = parser.parse_args(argv)
    labels = args.effects.split(",")
    unknown = sorted(set(labels) - set(TRUTH_EFFECTS))
    if unknown:
        parser.error(f"--effects: no truth for {', '.join(unknown)}; known: {', '.join(TRUTH_EFFECTS)}")
    matrix = pd.DataFrame(0, index=labels, columns=list(TRUTH_EFFECTS))
    gaps, times = [], []
    rng = np.random.default_rng(args.seed)
    start = time.time()
    for k in range(args.cases):
        for effect in labels:
            frame, truth = make_case(effect, rng)
            with tempfile.TemporaryDirectory() as folder:
                t0 = time.time()
                job = load_diagnose_job(_write_job(Path(folder), frame, effects=HAPTIC))
                s = run_diagnosis(job, progress=False, build=False).to_json()
                times.append(time.time() - t0)
            matrix.loc[effect, s["effect"]] += 1
            if effect != "none" and s["effect"] == effect:
                gaps.append(s["gap_removed"])
            fitted = s["after"]["parameters"] if s["after"] else {}
            added = {c["effect"]: c["added_parameters"] for c in s["candidates"]}.get(s["effect"], [])
            shown = {key: float(f"{v:.4g}") for key, v in truth.items() if key not in ("effect",)}
            print(f"case {k} truth {effect:15s} named {s['effect']:15s} gap removed {100 * s['gap_removed']:6.1f} % "
                  f"({times[-1]:.0f} s) fitted {({n: float(f'{fitted[n]:.4g}') for n in added})} truth {shown}",
                  flush=True)
    print()
    print(f"confusion matrix (rows: hidden effect, columns: named), {args.cases} cases each, seed {args.seed}, "
          f"{time.time() - start:.0f} s ({np.median(times):.0f} s median per case):")
    print(matrix.to_string())
    effects = [e for e in labels if e != "none"]
    right = sum(matrix.loc[e, e] for e in effects)
    print((f"named right: {right}/{args.cases * len(effects)}; " if effects else "")
          + (f"false alarms on 'none': {args.cases - matrix.loc['none', 'none']}/{args.cases}"
             if "none" in labels else ""))
    if gaps:
        print(f"gap above the noise removed when named right: min {100 * min(gaps):.0f} %, median "
              f"{100 * np.median(gaps):.0f} %")
    if args.validation:
        write_confusion("diagnose-haptic", matrix, gaps, [args.seed])


if __name__ == "__main__":
    main()
