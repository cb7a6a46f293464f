"""Counts of the discrepancy workflow on drawn cases of independent truths of each experiment, or a job's stage times.

Run: python benchmarks/diagnose.py [--experiments E ...] [--cases N] [--seed S] [--truths 1 2 ...] [--effects ...]
                                   [--forms] [--rows FILE [--resume]] [--workers W] [--validation]
Each case hides one effect, or none, in a truth written independently of the Modelica plant and its candidates,
and is diagnosed by the experiment's baseline model with the whole effect library that applies to it offered.
Per experiment (``--experiments``, default all), truth 1 is the one the workflow was developed against; truths 2
and 3 were written from other textbook formulations and never used to tune anything (truth 3 was written after
truth 2's results had been seen, to judge the changes made in response to them):

* ``staircase`` (the static current staircase, force at 100 Hz): ``tests/diagnose_truth.py`` (quasi-static
  Karnopp stick/slip, rigid drivetrain) and ``tests/diagnose_truth2.py`` (Dahl motor friction, torque-proportional
  gear loss, a compliant mesh with backlash, LuGre guides, a second-order load cell); truth 4
  (``tests/diagnose_truth4_staircase.py``, the fourth impact truth's plant on the staircase) as below;
* ``impact``, ``slide``, ``speed`` (the current-step impact; stops and restarts against the jaw guides; a slow
  speed run under a PI loop): ``tests/diagnose_truth_impact.py``, ``tests/diagnose_truth2_impact.py`` and
  ``tests/diagnose_truth3_impact.py``; truth 4 (``tests/diagnose_truth4_impact.py``, laws of forms outside the
  candidate library) is reserved for the evaluation of issue 42 and is drawn only when ``--truths`` names it;
* ``impact+slide`` (issue 42, item 3): one gripper of each of those truths measured by an impact and a slide,
  both records in one job (``[[experiments]]``); its rows also say which records showed the first finding;
* ``haptic`` (the PHANToM's frequency response with a user): ``tests/diagnose_truth_haptic.py`` and
  ``tests/diagnose_truth2_haptic.py`` (built without the project's transfer-function code; truth set ``2w``: the
  same records estimated by Welch H1 instead of at the multisine's lines).

A truth an experiment lacks is skipped. ``--forms`` offers the forms of laws (``candidates.forms``) too; a case is
then diagnosed in rounds as ``cosim diagnose`` does, and counted named right when the hidden effect is among its
findings. The effects drawn are "none" and those the experiment shows
(docs/guide/diagnose.md, "Which experiment shows which effect"), unless ``--effects`` names others. The run's seed
is drawn from the operating system unless ``--seed`` is given (to re-run a printed draw); every case's seed derives
from it and is printed with its row; ``--rows`` appends every row to a JSON-lines file, and ``--resume`` with the
same ``--seed`` takes the cases already there instead of diagnosing them again (a run of many hours done in parts;
every row of the file must come from the checkout's commit). Counts: named right per
effect with Wilson 95 % intervals, false alarms on "none", named right on the effects the experiment shows and the
gap above the noise removed when named (the targets of issue 32: >= 85 %, <= 5 %, >= 80 %). After each case's
row, the wall time of each stage of its diagnosis (as ``--job`` names them; ``--rows`` keeps them), the CPU time of
this process and the load average. ``--validation``
writes each experiment's counts into its section of docs/validation.md, stamped with the commit and the seed.

Run: python benchmarks/diagnose.py --tables ROWS [--validation]
Diagnoses nothing: counts a rows file written by earlier runs (every row of one commit) and prints each
experiment's table as above, plus the counts over the experiments of each truth (with ``--forms`` rows: issue 51's
targets, >= 70 % named right and <= 10 % false alarms; a form named on a "none" case counted apart; the answers
that leave a gap above the noise unexplained). ``--validation`` writes them into their sections (``-forms`` for
rows made with ``--forms``), noting the rows' commit.

Run: python benchmarks/diagnose.py --job examples/diagnose_static.toml [--workers W] [--no-build]
Diagnoses a job file as ``cosim diagnose`` does (FMUs built and re-run unless --no-build) and prints the wall time of
each stage of the workflow (nested stages indented), the replays run in this process (all of them with
``--workers 0``), the CPU time of this process and of the processes it started (the Dask workers, the compilers of
the FMU builds) and the load average before and after: the machine may be shared.
"""

import argparse
import functools
import importlib
import json
import os
import resource
import secrets
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from diagnose_truth import make_case  # noqa: E402
import diagnose_truth2  # noqa: E402
from diagnose_truth2 import (SHOWN_ON_STAIRCASE, count_rows, diagnose_case2, diagnose_frame, library,  # noqa: E402
                             wilson)
from diagnose_truth2_haptic import SHOWN as SHOWN_ON_HAPTIC  # noqa: E402
from diagnose_truth2_haptic import diagnose_case_haptic1, diagnose_case_haptic2  # noqa: E402
from diagnose_truth2_impact import (SHOWN_BY, diagnose_case_impact1, diagnose_case_impact2,  # noqa: E402
                                   diagnose_experiments_case)

from cosim.diagnose import load_diagnose_job  # noqa: E402
from validation import DOC, write_section, write_sections  # noqa: E402

# Noise sd [N] of the first staircase truth's load cell (the second draws its own).
STAIRCASE_NOISE = 0.3

# The workflow's stages as run_round calls them (cosim.diagnose.workflow); those a version lacks are skipped.
STAGES = ("load_samples", "estimate_noise", "fit_free", "split_segments", "score_candidates", "_screen", "_fold_fits",
          "run_tasks", "_restart_baseline", "decide", "show", "_final_fit", "_rerun_both", "advise", "_diagnosis")
# (depth, stage, wall s) of every stage call of the drawn cases since the last case began
STAGE_CALLS = []


def _timed(module, calls, depth):
    """Wrap the STAGES of ``module`` so that each call appends (depth, name, seconds) to ``calls``; a stage already
    wrapped is left as it is (its calls go to the list of the first wrapping)."""
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
        timed.stage_timed = True
        return timed

    for name in STAGES:
        if hasattr(module, name) and not getattr(getattr(module, name), "stage_timed", False):
            setattr(module, name, wrap(name, getattr(module, name)))


def stage_times(calls):
    """{stage: wall s} of the outer stages in ``calls`` (from :func:`_timed`: depth 0, and the fitting stages one
    level inside ``score_candidates`` and ``show``), each summed over its calls."""
    times = {}
    for level, name, seconds in calls:
        if level == 0 or level == 1 and name != "run_tasks":
            times[name] = times.get(name, 0.0) + seconds
    return {name: round(seconds, 2) for name, seconds in times.items()}


def time_job(path, workers=None, build=True):
    """Diagnose the job at ``path`` and print the time of each stage."""
    import cosim.diagnose.show as show_stage
    from cosim.diagnose import fitting, run_diagnosis, workflow

    replays = [0]
    evaluate = fitting.Replay.evaluate

    def counted(self, q):
        replays[0] += 1
        return evaluate(self, q)

    fitting.Replay.evaluate = counted
    calls, depth = [], [0]
    _timed(workflow, calls, depth)
    _timed(show_stage, calls, depth)  # stage 5's own steps (the winner's final fit, the re-run)
    job = load_diagnose_job(path, [] if workers is None else [f"parallel.workers={workers}"])
    load = os.getloadavg()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        s = run_diagnosis(job, progress=False, build=build, out=out).to_json()
    wall = time.perf_counter() - start
    cpu = resource.getrusage(resource.RUSAGE_SELF)
    workers_cpu = resource.getrusage(resource.RUSAGE_CHILDREN)  # the Dask cluster's processes, ended by now
    print(f"{path}: {s['verdict']}")
    print(f"stages (wall s; indented: inside the stage above; {job.workers} Dask workers):")
    for level, name, seconds in calls:
        print(f"  {'  ' * level}{name:{24 - 2 * level}s} {seconds:8.1f}")
    print(f"total {wall:.1f} s wall, {cpu.ru_utime + cpu.ru_stime:.1f} s CPU in this process and "
          f"{workers_cpu.ru_utime + workers_cpu.ru_stime:.1f} s in the processes it started, {replays[0]} replays "
          f"in this process; load average (1, 5, 15 min) before {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}, after "
          f"{' '.join(f'{v:.1f}' for v in os.getloadavg())} on {os.cpu_count()} cores")
    for c in s["candidates"]:
        print(f"  candidate {c['effect']:24s} score {c['score']:.3f} delta BIC {c['delta_bic']:.1f}")


def diagnose_staircase1(effect, seed, folder, workers):
    """Diagnose the first staircase truth's case (``effect``, ``seed``, load-cell noise ``STAIRCASE_NOISE``) with the
    whole library offered; one row as :func:`diagnose_truth2.diagnose_frame` gives."""
    t, i, y, truth = make_case(effect, np.random.default_rng(seed), noise=STAIRCASE_NOISE)
    return diagnose_frame(pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), {**truth, "noise": STAIRCASE_NOISE},
                          seed, folder, library(), workers)


def diagnose_staircase2(effect, seed, folder, workers):
    """Diagnose the second staircase truth's case with the whole library offered; one row."""
    return diagnose_case2(effect, seed, folder, library(), workers)


def _gripper(experiment, function):
    return lambda effect, seed, folder, workers: function(effect, seed, folder, experiment, workers)


def _truth3(effect, seed, folder, experiment, workers):
    from diagnose_truth3_impact import diagnose_case_impact3

    return diagnose_case_impact3(effect, seed, folder, experiment, workers)


def _truth4(effect, seed, folder, experiment, workers):
    from diagnose_truth4_impact import diagnose_case_impact4

    return diagnose_case_impact4(effect, seed, folder, experiment, workers)


def _staircase4(effect, seed, folder, workers):
    from diagnose_truth4_staircase import diagnose_case4

    return diagnose_case4(effect, seed, folder, None, workers)


def _both(truth):
    """The ``impact+slide`` case function of gripper truth ``truth`` (its module imported when a case is drawn:
    truth 4 stays unread until named)."""
    def case(effect, seed, folder, workers):
        module = importlib.import_module("diagnose_truth_impact" if truth == "1" else f"diagnose_truth{truth}_impact")
        simulate = module.record_of if truth == "1" else module.simulate  # truth 1's simulate takes parameters
        return diagnose_experiments_case(module.draw_truth, simulate, int(truth))(effect, seed, folder, workers)
    return case


def _welch(effect, seed, folder, workers):
    return diagnose_case_haptic2(effect, seed, folder, workers, estimator="welch")


# experiment -> (the effects it shows, {truth: case function (effect, seed, folder, workers) -> row},
# default Dask workers: the haptic fits are fast enough in process)
EXPERIMENTS = {
    "staircase": (SHOWN_ON_STAIRCASE, {"1": diagnose_staircase1, "2": diagnose_staircase2, "4": _staircase4}, 2),
    **{name: (SHOWN_BY[name], {"1": _gripper(name, diagnose_case_impact1), "2": _gripper(name, diagnose_case_impact2),
                               "3": _gripper(name, _truth3), "4": _gripper(name, _truth4)}, 2)
       for name in ("impact", "slide", "speed")},
    "haptic": (SHOWN_ON_HAPTIC, {"1": diagnose_case_haptic1, "2": diagnose_case_haptic2, "2w": _welch}, 0),
    # last: the seed streams of the experiments above keep their index
    "impact+slide": (tuple(dict.fromkeys(SHOWN_BY["impact"] + SHOWN_BY["slide"])),
                     {truth: _both(truth) for truth in ("1", "2", "3", "4")}, 2),
}
TRUTHS = ("1", "2", "2w", "3", "4")


@functools.cache
def commit_of_checkout():
    """The commit this benchmark's checkout is at, with ``+changes`` when its tracked files other than
    docs/validation.md (which ``--validation`` writes) differ from it."""
    def git(*args):
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True).stdout.strip()
    changed = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)docs/validation.md")
    return git("rev-parse", "--short", "HEAD") + ("+changes" if changed else "")


def rows_done(rows_file, commit):
    """The rows of ``rows_file`` diagnosed at ``commit``, by (experiment, truth set, run seed, case, effect, case
    seed, forms offered): what ``--resume`` takes instead of diagnosing again. A row of another commit is an error (the counts
    of one table come from one commit)."""
    done = {}
    if rows_file is None or not rows_file.exists():
        return done
    for number, line in enumerate(rows_file.read_text(encoding="utf-8").splitlines(), 1):
        row = json.loads(line)
        if row.get("commit") != commit:
            sys.exit(f"{rows_file}:{number}: a row of commit {row.get('commit')}, this checkout is at {commit}: "
                     "--resume takes rows of one commit only")
        done[_row_key(row["experiment"], row["truth_set"], row["run_seed"], row.get("case"), row["truth"],
                      row["seed"], row.get("forms", False))] = row
    return done


def _row_key(*fields):
    return tuple(str(f) for f in fields)


def draw_rows(experiment, truths, effects, cases, seed, workers, rows_file=None, done=None):
    """Diagnose ``cases`` drawn cases of each effect of each truth of ``experiment`` (those it lacks skipped);
    returns {truth: [row, ...]}, each row also appended to ``rows_file`` (JSON lines) when given. The truths share
    each case's seed: a paired comparison (the gripper truths draw the same baseline from it). Each row carries
    the wall time of each stage of its diagnosis (``stages``), the CPU time of this process (``cpu_seconds``: the
    fits on Dask workers are not in it), the load average when it ended (``load``) and the checkout's commit. A
    case in ``done`` (:func:`rows_done`) is taken from there, not diagnosed again."""
    import cosim.diagnose.show as show_stage
    from cosim.diagnose import workflow

    calls, depth = STAGE_CALLS, [0]
    _timed(workflow, calls, depth)
    _timed(show_stage, calls, depth)
    _, functions, default_workers = EXPERIMENTS[experiment]
    workers = default_workers if workers is None else workers
    stream = np.random.default_rng([seed, list(EXPERIMENTS).index(experiment)])  # one stream an experiment
    seeds = stream.integers(0, 2 ** 31, size=(cases, len(effects)))
    rows = {t: [] for t in truths if t in functions}
    for k in range(cases):
        for truth in rows:
            for b, effect in enumerate(effects):
                case_seed = int(seeds[k, b])
                key = _row_key(experiment, truth, seed, k, effect, case_seed, diagnose_truth2.OFFER_FORMS)
                if key in (done or {}):
                    rows[truth].append(done[key])
                    continue
                calls.clear()
                cpu = time.process_time()
                with tempfile.TemporaryDirectory() as folder:
                    row = functions[truth](effect, case_seed, folder, workers)
                row = {**row, "experiment": experiment, "truth_set": truth, "run_seed": seed, "case": k,
                       "forms": diagnose_truth2.OFFER_FORMS,
                       "commit": commit_of_checkout(),
                       "stages": stage_times(calls), "cpu_seconds": round(time.process_time() - cpu, 1),
                       "load": os.getloadavg()[0]}
                rows[truth].append(row)
                if rows_file:
                    with open(rows_file, "a", encoding="utf-8") as out:
                        out.write(json.dumps(row) + "\n")
                print(f"{experiment} truth {truth} case {k} {effect:24s} seed {case_seed:10d} named {row['named']:24s} "
                      f"RMSE {row['rmse_before']:.4g} -> {row['rmse_after']:.4g} (truth's noise {row['noise']:.3g}), gap "
                      f"removed {100 * row['gap_removed']:5.1f} %, {row['seconds']:.0f} s", flush=True)
                print("    stages (wall s): " + ", ".join(f"{n} {v:.1f}" for n, v in row["stages"].items())
                      + f"; {row['cpu_seconds']:.0f} s CPU in this process; load average {row['load']:.1f}",
                      flush=True)
    return rows


def _interval(pair):
    """A Wilson interval in % (its bounds clipped to 0-100: rounding leaves -0 at a count of 0; "-" of no case)."""
    if np.isnan(pair[0]):
        return "-"
    return f"{max(0.0, 100 * pair[0]):.0f}-{min(100.0, 100 * pair[1]):.0f} %"


# Column titles of a validation table (count_table's rows).
TABLE_HEADER = ["truth", "hidden effect", "cases", "named right", "95 % interval", "named",
                "gap removed >= 80 % when named", "a form named", "gap left unexplained"]
# Targets (named right on the effects shown, false alarms on "none"), in %: issue 32's for the one-effect tables,
# issue 51's for the tables with forms offered (judged on truth 4).
TARGETS = {False: (85, 5), True: (70, 10)}


def count_table(rows, shown, targets=TARGETS[False]):
    """The validation table's header and rows and the summary lines, from {truth: [row, ...]}; ``shown``: the
    effects the experiment shows; ``targets``: (named right, false alarms) in %. Rows that say which records showed
    their first finding (``impact+slide``) add that column."""
    table, notes = [], []
    by_record = any("shown_by" in r for mine in rows.values() for r in mine)
    header = TABLE_HEADER + (["first finding shown by"] if by_record else [])
    for truth, mine in rows.items():
        counts = count_rows(mine, shown)
        for effect, entry in counts.items():
            if effect == "summary":
                continue
            gap = "-" if effect == "none" else f"{entry['gap_removed_80']}/{entry['named_right']}"
            table.append([truth, f"`{effect}`", entry["cases"], f"{entry['named_right']}/{entry['cases']}",
                          _interval(entry["interval"]),
                          ", ".join(f"{name} {n}" for name, n in Counter(entry["named"]).items()), gap,
                          entry["forms_named"], entry["gap_left"]]
                         + ([_shown_by(r for r in mine if r["truth"] == effect)] if by_record else []))
        su = counts["summary"]
        notes.append(f"Truth {truth}: named right on the effects the experiment shows {su['named_right_shown']}/"
                     f"{su['shown_cases']} ({_interval(su['named_right_interval'])}, target >= {targets[0]} %); false "
                     f"alarms {su['false_alarms']}/{su['none_cases']} ({_interval(su['false_alarm_interval'])}, target "
                     f"<= {targets[1]} %), a form named on {su['forms_on_none']} of those; a gap left unexplained in "
                     f"{su['gap_left']}/{su['cases']}; median time a case "
                     f"{np.median([r['seconds'] for r in mine]):.0f} s.")
    return header, table, notes


def _shown_by(rows):
    """Which records showed each row's first finding, counted ("impact 2, impact+slide 1"; "-" when none named)."""
    counts = Counter("+".join(r["shown_by"]) for r in rows if r.get("shown_by"))
    return ", ".join(f"{records} {n}" for records, n in counts.items()) or "-"


def section_name(experiment, forms):
    """The experiment's section of docs/validation.md: the one-effect tables, or those with forms offered."""
    return f"diagnose-{experiment}" + ("-forms" if forms else "")


def run_experiment(experiment, args, seed):
    """Draw, diagnose and count one experiment's cases; print them and, with ``--validation``, write its section."""
    shown = EXPERIMENTS[experiment][0]
    effects = args.effects or ["none", *shown]
    start = time.time()
    done = rows_done(args.rows, commit_of_checkout()) if args.resume else None
    rows = draw_rows(experiment, args.truths, effects, args.cases, seed, args.workers, args.rows, done)
    print(f"\n{experiment}: {time.time() - start:.0f} s")
    section = _show_table(experiment, rows, args.forms, [seed])
    if args.validation:
        write_section(*section)


def _show_table(experiment, rows, forms, seeds, notes=()):
    """Print an experiment's counts ({truth: [row, ...]}); returns its section of docs/validation.md as
    :func:`write_section` takes it (name, header, table, seeds, notes)."""
    header, table, summary = count_table(rows, EXPERIMENTS[experiment][0], TARGETS[forms])
    _print_table(header, table)
    print("\n".join(summary), flush=True)
    return section_name(experiment, forms), header, table, seeds, [*summary, *notes]


def tables_from_rows(rows_file, doc=None):
    """Count the rows of an evaluation (``--rows`` of earlier runs, every row of one commit) and print each
    experiment's table, then the counts over the experiments of each truth; given a ``doc`` (docs/validation.md),
    write them there, every section or none. No case is diagnosed: a run of many hours, done in parts, is counted
    once all its rows are in."""
    rows = [json.loads(line) for line in rows_file.read_text(encoding="utf-8").splitlines() if line.strip()]
    commits = sorted({r["commit"] for r in rows})
    if len(commits) != 1:
        sys.exit(f"{rows_file}: rows of {len(commits)} commits ({', '.join(commits) or 'none'}); the counts of one "
                 "table come from one commit")
    source = (f"Counted from {rows_file.name} by `--tables`: {len(rows)} rows, every one diagnosed at commit "
              f"{commits[0]}.")
    seeds = sorted({r["run_seed"] for r in rows})
    groups = {}
    for r in rows:
        groups.setdefault((r["experiment"], r.get("forms", False)), {}).setdefault(r["truth_set"], []).append(r)
    sections = []
    for (experiment, forms), by_truth in groups.items():
        print(f"\n{experiment}{' (forms offered)' if forms else ''}: {sum(map(len, by_truth.values()))} rows")
        sections.append(_show_table(experiment, dict(sorted(by_truth.items())), forms, seeds, [source]))
    for forms in sorted({forms for _, forms in groups}):
        table = _overall_table({e: t for (e, f), t in groups.items() if f == forms})
        print(f"\nover the experiments{' (forms offered)' if forms else ''}:")
        _print_table(OVERALL_HEADER, table)
        sections.append((section_name("summary", forms), OVERALL_HEADER, table, seeds, [source]))
    if doc:
        write_sections(sections, doc)


def _print_table(header, table):
    """A table's header and rows, one line each, cells two spaces apart."""
    print("  ".join(header))
    for row in table:
        print("  ".join(map(str, row)))


OVERALL_HEADER = ["truth", "experiments", "named right (effects shown)", "95 % interval", "false alarms",
                  "95 % interval", "a form named on none", "gap left unexplained", "median time a case"]


def _overall_table(groups):
    """One row a truth: the counts of :func:`count_rows` summed over the experiments ({experiment: {truth: rows}}),
    the median time a case per experiment."""
    table = []
    for truth in sorted({t for by_truth in groups.values() for t in by_truth}):
        mine = {e: by_truth[truth] for e, by_truth in groups.items() if truth in by_truth}
        sums = Counter()
        for experiment, rows in mine.items():
            su = count_rows(rows, EXPERIMENTS[experiment][0])["summary"]
            sums.update({k: su[k] for k in ("named_right_shown", "shown_cases", "false_alarms", "none_cases",
                                            "forms_on_none", "gap_left", "cases")})
        times = ", ".join(f"{e} {np.median([r['seconds'] for r in rows]):.0f} s" for e, rows in mine.items())
        table.append([truth, ", ".join(mine), f"{sums['named_right_shown']}/{sums['shown_cases']}",
                      _interval(wilson(sums["named_right_shown"], sums["shown_cases"])),
                      f"{sums['false_alarms']}/{sums['none_cases']}",
                      _interval(wilson(sums["false_alarms"], sums["none_cases"])), sums["forms_on_none"],
                      f"{sums['gap_left']}/{sums['cases']}", times])
    return table


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", type=Path, help="time the stages of this job instead of drawing cases")
    parser.add_argument("--no-build", action="store_true", help="with --job: do not build and re-run the FMUs")
    parser.add_argument("--experiments", nargs="+", choices=tuple(EXPERIMENTS), default=list(EXPERIMENTS),
                        help="experiments to draw cases of (default: all)")
    parser.add_argument("--cases", type=int, default=3, help="cases per experiment, truth and effect")
    parser.add_argument("--seed", type=int, help="the run's seed (default: drawn from the operating system)")
    parser.add_argument("--truths", nargs="+", choices=TRUTHS, default=["1", "2", "3"],
                        help="truths to draw cases of (default 1 2 3; 2w: the haptic second truth by Welch H1; 4: "
                             "reserved for the evaluation of issue 42)")
    parser.add_argument("--rows", type=Path, help="append every row to this JSON-lines file")
    parser.add_argument("--forms", action="store_true",
                        help="offer the forms of laws (candidates.forms) beside the effects to the gripper truths' "
                             "cases (issue 42's evaluation)")
    parser.add_argument("--resume", action="store_true",
                        help="with --rows and --seed: take the cases already in the rows file (of this commit) "
                             "instead of diagnosing them again")
    parser.add_argument("--effects", nargs="+", help="hidden effects (default: none and those the experiment shows)")
    parser.add_argument("--workers", type=int,
                        help="Dask workers (default: the job's; for drawn cases 2, the haptic ones 0)")
    parser.add_argument("--validation", action="store_true", help="also write the counts into docs/validation.md")
    parser.add_argument("--tables", type=Path, metavar="ROWS",
                        help="diagnose nothing: count the rows file of earlier runs (every row of one commit) and "
                             "print each experiment's table (with --validation, write it)")
    args = parser.parse_args(argv)
    if args.tables:
        tables_from_rows(args.tables, DOC if args.validation else None)
        return
    if args.job:
        time_job(args.job, args.workers, not args.no_build)
        return
    if args.resume and (args.rows is None or args.seed is None):
        parser.error("--resume needs --rows (the file to take cases from) and --seed (the run's seed)")
    seed = secrets.randbelow(2 ** 31) if args.seed is None else args.seed
    diagnose_truth2.OFFER_FORMS = args.forms
    print(f"seed {seed}; experiments {args.experiments}; truths {args.truths}; {args.cases} cases each; the whole "
          f"library of each experiment's model offered{', forms too' if args.forms else ''}", flush=True)
    for experiment in args.experiments:
        run_experiment(experiment, args, seed)


if __name__ == "__main__":
    main()
