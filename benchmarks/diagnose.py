"""Confusion matrix of the discrepancy workflow over random hidden-effect cases.

Each case: a quasi-static stick/slip gripper (tests/diagnose_truth.py, written independently of the Modelica
plant and candidates) with random parameters, one hidden effect or none, load-cell noise; the workflow fits the
baseline Gripper.GripperCurrentDriven and the candidates and names one effect or "none".

Run: python benchmarks/diagnose.py [--cases N] [--seed S] [--noise SD] [--workers W] [--validation]
Prints one line per case, then the confusion matrix (rows: truth, columns: named), the false-alarm rate on "none"
cases and the gap above the noise removed by the named effect when it is right.

Run: python benchmarks/diagnose.py --job examples/diagnose_static.toml [--workers W] [--no-build]
Diagnoses a job file as ``cosim diagnose`` does (FMUs built and re-run unless --no-build) and prints the wall time of
each stage of the workflow (nested stages indented), the replays run in this process (all of them with
``--workers 0``), the CPU time of this process and the load average before and after: the machine may be shared.
"""

import argparse
import functools
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from diagnose_truth import TRUTH_EFFECTS, make_case, write_job  # noqa: E402

from cosim.diagnose import load_diagnose_job, run_diagnosis  # noqa: E402
from validation import write_confusion  # noqa: E402

CANDIDATES = ("backdrive_efficiency", "load_dependent_friction", "loadcell_filter")
# On steady holds a guide friction mu_F*F is, to O(mu_F^2), a lower gear efficiency (docs/guide/diagnose.md): the
# static staircase cannot tell it from the baseline, so its row is reported apart from the naming rate.
NOT_IDENTIFIABLE = ("load_dependent_friction",)

# The workflow's stages as run_diagnosis calls them (cosim.diagnose.workflow); those a version lacks are skipped.
STAGES = ("load_samples", "estimate_noise", "_fit", "split_segments", "score_candidates", "_screen", "_fold_fits",
          "_run_tasks", "_restart_baseline", "decide", "show", "_final_fit", "_rerun_both", "_diagnosis")


def _timed(module, calls, depth):
    """Wrap the STAGES of ``module`` so that each call appends (depth, name, seconds) to ``calls``."""
    def wrap(name, function):
        @functools.wraps(function)
        def timed(*args, **kwargs):
            index = len(calls)
            calls.append(None)
            depth[0] += 1
            t0 = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                depth[0] -= 1
                calls[index] = (depth[0], name, time.perf_counter() - t0)
        return timed

    for name in STAGES:
        if hasattr(module, name):
            setattr(module, name, wrap(name, getattr(module, name)))


def time_job(path, workers=None, build=True):
    """Diagnose the job at ``path`` and print the time of each stage."""
    from cosim.diagnose import fitting, workflow

    replays = [0]
    evaluate = fitting.Replay.evaluate

    def counted(self, q):
        replays[0] += 1
        return evaluate(self, q)

    fitting.Replay.evaluate = counted
    calls, depth = [], [0]
    _timed(workflow, calls, depth)
    job = load_diagnose_job(path, [] if workers is None else [f"parallel.workers={workers}"])
    load = os.getloadavg()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        s = workflow.run_diagnosis(job, progress=False, build=build, out=out).to_json()
    wall = time.perf_counter() - start
    cpu = resource.getrusage(resource.RUSAGE_SELF)
    print(f"{path}: {s['verdict']}")
    print(f"stages (wall s; indented: inside the stage above; {job.workers} Dask workers):")
    for level, name, seconds in calls:
        print(f"  {'  ' * level}{name:{24 - 2 * level}s} {seconds:8.1f}")
    print(f"total {wall:.1f} s wall, {cpu.ru_utime + cpu.ru_stime:.1f} s CPU in this process, {replays[0]} replays "
          f"in this process; load average (1, 5, 15 min) before {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}, after "
          f"{' '.join(f'{v:.1f}' for v in os.getloadavg())} on {os.cpu_count()} cores")
    for c in s["candidates"]:
        print(f"  candidate {c['effect']:24s} score {c['score']:.3f} delta BIC {c['delta_bic']:.1f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", type=Path, help="time the stages of this job instead of drawing cases")
    parser.add_argument("--no-build", action="store_true", help="with --job: do not build and re-run the FMUs")
    parser.add_argument("--cases", type=int, default=3, help="cases per truth effect")
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--noise", type=float, default=0.3, help="load-cell noise sd [N]")
    parser.add_argument("--workers", type=int, help="Dask workers (default: the job's; 2 for drawn cases)")
    parser.add_argument("--validation", action="store_true",
                        help="also write the confusion matrix into docs/validation.md")
    args = parser.parse_args(argv)
    if args.job:
        time_job(args.job, args.workers, not args.no_build)
        return
    workers = 2 if args.workers is None else args.workers
    labels = list(TRUTH_EFFECTS)
    named_labels = labels + [c for c in CANDIDATES if c not in labels]
    matrix = pd.DataFrame(0, index=labels, columns=named_labels)
    gaps = []
    rng = np.random.default_rng(args.seed)
    start = time.time()
    for k in range(args.cases):
        for effect in labels:
            t, i, y, truth = make_case(effect, rng, noise=args.noise)
            with tempfile.TemporaryDirectory() as folder:
                path = write_job(folder, pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), CANDIDATES, workers)
                t0 = time.time()
                s = run_diagnosis(load_diagnose_job(path), progress=False, build=False).to_json()
            matrix.loc[effect, s["effect"]] += 1
            if effect != "none" and s["effect"] == effect:
                gaps.append(s["gap_removed"])
            extra = {key: round(float(v), 4) for key, v in truth.items() if key != "effect"}
            print(f"case {k} truth {effect:24s} named {s['effect']:24s} RMSE {s['rmse_before']:.3f} -> "
                  f"{s['rmse_after']:.3f} gap removed {100 * s['gap_removed']:5.1f} %  ({time.time() - t0:.0f} s) "
                  f"{extra}", flush=True)
    print()
    print(f"confusion matrix (rows: hidden effect, columns: named), {args.cases} cases each, noise "
          f"{args.noise} N, {time.time() - start:.0f} s:")
    print(matrix.to_string())
    identifiable = [e for e in labels if e not in ("none", *NOT_IDENTIFIABLE)]
    right = sum(matrix.loc[e, e] for e in identifiable)
    print(f"named right ({', '.join(identifiable)}): {right}/{args.cases * len(identifiable)}; false alarms on "
          f"'none': {args.cases - matrix.loc['none', 'none']}/{args.cases}")
    for e in NOT_IDENTIFIABLE:
        print(f"not identifiable on a static staircase, {e}: named right {matrix.loc[e, e]}/{args.cases}")
    if gaps:
        print(f"gap above the noise removed when named right: min {100 * min(gaps):.0f} %, median "
              f"{100 * np.median(gaps):.0f} %")
    if args.validation:
        write_confusion("diagnose-staircase", matrix, gaps, [args.seed])


if __name__ == "__main__":
    main()
