"""Long run of the loader fuzz (tests/test_fuzz.py runs a few hundred cases a loader): mutated shipped examples
(tests/fuzz_cases.py) through the run-config, calibration-job, diagnosis-job, campaign-job and sensitivity-job
loaders and ``--set``, and the haptic command's table loaders and arguments, counted by
outcome ("ok" or the class of the project's error raised). Any other exception is a bug: it is counted under its
own class name with the case that raised it printed, and the exit status is 1.

Run: PYTHONPATH=. python benchmarks/fuzz.py [--cases N] (default 10,000 in all: run 25 %, calibrate 35 %,
diagnose 15 %, campaign 10 %, sensitivity 5 %, haptic 10 %). Needs the FMUs of `cosim build`.
"""

import argparse
import collections
import contextlib
import io
import sys
import tempfile
import time
import traceback
from pathlib import Path

from hypothesis import HealthCheck, given, settings

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from fuzz_cases import cases, check, check_haptic, haptic_cases, workspace  # noqa: E402

SHARES = {"run": 0.25, "calibrate": 0.35, "diagnose": 0.15, "campaign": 0.1, "sensitivity": 0.05, "haptic": 0.1}


def fuzz(loader, n, folder, seed):
    """Counts of outcomes over ``n`` cases of ``loader``; unexpected exceptions are counted and printed."""
    counts = collections.Counter()

    @settings(max_examples=n, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(case=haptic_cases() if loader == "haptic" else cases(loader))
    def one(case):
        try:
            with contextlib.redirect_stderr(io.StringIO()):  # argparse's usage line on each refused argument
                counts[check_haptic(case) if loader == "haptic" else check(loader, folder, case)] += 1
        except Exception as err:  # the fuzz's finding: not a CosimError
            counts[f"UNEXPECTED {type(err).__name__}"] += 1
            print(f"{loader}: {type(err).__name__}: {err}\n  case: {case!r}\n{traceback.format_exc(limit=3)}")

    from hypothesis import seed as hseed

    hseed(seed)(one)()
    return counts


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    folder = workspace(tempfile.mkdtemp(prefix="cosim-fuzz-"), ROOT / "fmus")
    total = collections.Counter()
    bad = 0
    for loader, share in SHARES.items():
        n = round(args.cases * share)
        t0 = time.perf_counter()
        counts = fuzz(loader, n, folder, args.seed)
        wall = time.perf_counter() - t0
        bad += sum(v for k, v in counts.items() if k.startswith("UNEXPECTED"))
        print(f"{loader}: {sum(counts.values())} cases in {wall:.0f} s: "
              + ", ".join(f"{k} {v}" for k, v in counts.most_common()), flush=True)
        total.update(counts)
    print(f"all loaders: {sum(total.values())} cases: " + ", ".join(f"{k} {v}" for k, v in total.most_common()))
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
