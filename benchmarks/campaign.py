"""Speed of ``cosim campaign``: the wall time of a trial and what is spent outside the engine's loop, and the
speed-up from 1 to 2 workers, measured on a small grid of full trials (5 s of tightening), then extrapolated
to the shipped 6,000-trial campaign.

    PYTHONPATH=. python benchmarks/campaign.py [--trials 5] [--out DIR] [--full DIR [--only-full]] [--validation]

Needs fmus/GripperPlant.fmu (``cosim build``). Grid: bare and P3 x 1000 rpm x 1.0 and 2.5 A x ``--trials``.

* in process: one :class:`~cosim.campaign.trial.TrialRunner` per coating, trials one after the other: the set-up
  (config, engine, kernels), the wall time of a trial, the part of it inside the engine's loop, simulated
  seconds per wall second.
* on Dask: ``run_campaign`` on a local cluster of 1 worker, then of 2 workers, one after the other in this run
  (each from a new output folder: cluster start-up and set-up included).
* the C limit: the FMU calls of the engine's loop alone, from C (``benchmarks/engine.py``), on the same impact.
* ``--full DIR``: the shipped campaign whole (6,000 trials, 2 workers) into the new folder DIR, its wall time
  and its statistics beside the paper's Table 1 and the 1000 rpm / 1 A figures (Secs. 4.3-4.4).

``--validation`` writes the speed table (section ``campaign-speed``) and, with ``--full``, the Table 1 table
(section ``campaign-table1``) into docs/validation.md. The load average of the machine is printed with each
figure: other jobs share the cores.
"""

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
JOB = ROOT / "examples" / "campaign_table1.toml"
FULL = 6000


def _grid(trials):
    return [f"campaign.trials={trials}", 'campaign.coatings=["bare","P3"]', "campaign.speeds_rpm=[1000]",
            "campaign.currents_A=[1.0,2.5]", f"campaign.batch={trials}"]


def _load():
    return "load average {:.1f} / {:.1f} / {:.1f}".format(*os.getloadavg())


def in_process(trials):
    """Trials one after the other in this process: set-up, wall per trial, loop share, sim s per wall s."""
    from cosim.campaign.draws import trial_list
    from cosim.campaign.job import load_campaign
    from cosim.campaign.trial import TrialRunner

    job = load_campaign(JOB, _grid(trials))
    specs = trial_list(job)
    setup = wall = loop = sim = 0.0
    for coating in job.coatings:
        t0 = time.perf_counter()
        runner = TrialRunner(job, coating)
        runner.run(specs[0])  # the first run loads what the set-up left to the first run
        setup += time.perf_counter() - t0
        mine = [s for s in specs if s.coating == coating.name]
        loop0 = runner.loop_s
        t0 = time.perf_counter()
        for s in mine:
            runner.run(s)
            sim += runner.engine.config.run.stop - runner.engine.config.run.start
        wall += time.perf_counter() - t0
        loop += runner.loop_s - loop0
    n = len(specs)
    figures = {"trials": n, "setup_s": setup / len(job.coatings), "trial_s": wall / n, "outside": 1 - loop / wall,
               "sim_s": sim / n, "loop_ratio": loop / sim}
    print(f"in process, {n} trials ({_load()}):")
    print(f"  set-up per coating (config, engine, kernels, first trial): {figures['setup_s']:.2f} s")
    print(f"  wall per trial {wall / n:.3f} s, of which in the engine's loop {loop / n:.3f} s; outside it "
          f"{100 * figures['outside']:.1f} %")
    print(f"  simulated {sim / n:.2f} s per trial: loop {loop / sim:.4f} wall s per simulated s "
          f"({sim / loop:.1f} simulated s per wall s per core)")
    return figures


def c_limit():
    """The FMU calls of the engine's loop alone, from C (benchmarks/engine.py): wall s per simulated s."""
    from engine import _configs, c_limit as engine_c_limit

    cfg = _configs(ROOT / "fmus", 1.0)["GripperPlant"]()
    with tempfile.TemporaryDirectory(prefix="cosim-campaign-c-") as work:
        ratio, _ = engine_c_limit(cfg, Path(work))
    print(f"C limit (FMU calls alone, bare impact, 1 s simulated; {_load()}): {ratio:.4f} wall s per simulated s "
          f"({1 / ratio:.1f} simulated s per wall s per core)")
    return ratio


def on_dask(trials, out):
    """The same grid on a local cluster of 1 then 2 workers; returns {workers: (command wall s, summary run)}."""
    from cosim.campaign import run_campaign

    runs = {}
    for workers in (1, 2):
        folder = out / f"w{workers}"
        shutil.rmtree(folder, ignore_errors=True)
        t0 = time.perf_counter()
        s = run_campaign(JOB, out=folder, overrides=_grid(trials), workers=workers, progress=False)
        runs[workers] = (time.perf_counter() - t0, s.run)
        r = s.run
        print(f"dask, {workers} worker(s), {r['ran']} trials ({_load()}): command {runs[workers][0]:.1f} s, "
              f"trials phase {r['wall_s']:.1f} s; per trial on its worker {r['trial_s']:.3f} s, outside the loop "
              f"{100 * r['overhead_share']:.1f} %, set-up summed over workers {r['setup_s']:.1f} s")
    print(f"1 -> 2 workers: {runs[1][0] / runs[2][0]:.2f}x (whole command, cluster start-up included)")
    return runs


def full_campaign(out):
    """The shipped job whole on 2 workers into the new folder ``out``; returns (command wall s, summary)."""
    from cosim.campaign import run_campaign

    if out.exists():
        raise SystemExit(f"--full {out}: expected a new folder (the run is timed whole); it exists")
    t0 = time.perf_counter()
    summary = run_campaign(JOB, out=out, workers=2, progress=True)
    wall = time.perf_counter() - t0
    print(f"full campaign, {summary.run['ran']} trials on 2 workers ({_load()}): {wall / 60:.1f} min; "
          f"{summary.p3_iqr_below_bare}")
    return wall, summary


def write_speed_section(local, c_ratio, runs):
    """Section campaign-speed of docs/validation.md."""
    from validation import write_section

    one, two = runs[1][1], runs[2][1]
    rows = [
        ["in process: wall per trial (s)", f"{local['trial_s']:.3f}"],
        ["in process: outside the engine's loop (target ≤ 5 %)", f"{100 * local['outside']:.1f} %"],
        ["in process: simulated s per wall s per core (loop)", f"{1 / local['loop_ratio']:.1f}"],
        ["C limit, FMU calls alone: simulated s per wall s per core", f"{1 / c_ratio:.1f}"],
        ["engine loop / C limit", f"{local['loop_ratio'] / c_ratio:.2f}"],
        ["Dask, 1 worker: command (s); per trial on its worker (s); outside the loop",
         f"{runs[1][0]:.1f}; {one['trial_s']:.3f}; {100 * one['overhead_share']:.1f} %"],
        ["Dask, 2 workers: command (s); per trial on its worker (s); outside the loop",
         f"{runs[2][0]:.1f}; {two['trial_s']:.3f}; {100 * two['overhead_share']:.1f} %"],
        ["1 → 2 workers, whole command (target ≥ 1.8x)", f"{runs[1][0] / runs[2][0]:.2f}x"],
        ["1 → 2 workers, trials phase", f"{one['wall_s'] / two['wall_s']:.2f}x"],
    ]
    notes = [f"Grid: bare and P3 x 1000 rpm x 1.0 and 2.5 A x {local['trials'] // 4} trials "
             f"({local['sim_s']:.2f} s simulated a trial); each Dask run from a new output folder, cluster start-up "
             "included in the command's time."]
    write_section("campaign-speed", ["figure", "measured"], rows, notes=notes)


def write_table1_section(wall, summary, out):
    """Section campaign-table1 of docs/validation.md: the full campaign beside Table 1 and Secs. 4.3-4.4."""
    import pandas as pd

    from cosim.campaign import load_campaign, table1
    from cosim.campaign.report import paper_iqrs
    from validation import write_section

    trials = pd.read_parquet(out / "trials.parquet")
    stats = table1(trials).set_index(["coating", "speed_rpm", "current_A"])
    paper = paper_iqrs()
    rows = []
    for (c, v, i) in stats.index:
        if c != "P3" or ("bare", v, i) not in stats.index:
            continue
        bare, p3 = stats.loc[("bare", v, i)], stats.loc[(c, v, i)]
        rows.append([f"{v:g}", f"{i:g}", f"{bare['median_N']:.1f}", f"{bare['iqr_N']:.1f}",
                     f"{paper[('bare', v, i)]:.2f}", f"{p3['median_N']:.1f}", f"{p3['iqr_N']:.1f}",
                     f"{paper[('P3', v, i)]:.2f}", "yes" if p3["iqr_N"] < bare["iqr_N"] else "no",
                     "yes" if paper[("P3", v, i)] < paper[("bare", v, i)] else "no"])
    cell = trials[(trials.speed_rpm == 1000) & (trials.current_A == 1.0)]
    med = cell.groupby("coating")[["peak_force_N", "steady_force_N"]].median()
    bounce = cell.groupby("coating")["bounced"].mean()
    run = summary.run
    notes = [f"{summary.p3_iqr_below_bare} (Target: at least 13 of 15.)",
             f"1000 rpm / 1 A, {len(cell[cell.coating == 'bare'])} trials a coating (medians; paper Secs. 4.3-4.4): "
             f"bare peak {med.loc['bare', 'peak_force_N']:.0f} N (220 N ± 20 %), steady "
             f"{med.loc['bare', 'steady_force_N']:.1f} N (62 N ± 15 %), bounced in "
             f"{100 * bounce['bare']:.0f} % of the trials (at least 10 %); P3 peak {med.loc['P3', 'peak_force_N']:.0f} N "
             f"(160 N ± 20 %), steady {med.loc['P3', 'steady_force_N']:.1f} N (40 N ± 15 %), bounced in "
             f"{100 * bounce['P3']:.0f} % (none).",
             f"The whole campaign ({run['ran']} trials, {summary.cells} cells with P1 and P2, 2 workers): "
             f"{wall / 60:.1f} min wall (target ≤ 5 min), {run['trial_s']:.3f} s a trial on its worker, "
             f"{100 * run['overhead_share']:.1f} % outside the engine's loop; {summary.no_steady_force} trials "
             "without a steady force."]
    write_section("campaign-table1", ["speed (rpm)", "current (A)", "bare median (N)", "bare IQR (N)",
                                      "paper bare IQR (N)", "P3 median (N)", "P3 IQR (N)", "paper P3 IQR (N)",
                                      "P3 below bare", "in the paper"], rows, seeds=[load_campaign(JOB).seed],
                  notes=notes)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=5, help="trials per cell (4 cells)")
    ap.add_argument("--out", help="output folder of the Dask runs (default: a temporary one)")
    ap.add_argument("--full", metavar="DIR", help="also run the shipped 6,000-trial campaign into the new folder DIR")
    ap.add_argument("--validation", action="store_true", help="also write the tables into docs/validation.md")
    ap.add_argument("--only-full", action="store_true",
                    help="with --full: run only the shipped campaign (the speed grid and its section are left)")
    args = ap.parse_args()
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, {_load()}")
    if args.only_full and not args.full:
        ap.error("--only-full needs --full DIR")
    if not args.only_full:
        speed(args)
    if args.full:
        wall, summary = full_campaign(Path(args.full))
        if args.validation:
            write_table1_section(wall, summary, Path(args.full))


def speed(args):
    """The speed grid in process, at its C limit and on Dask; its section with --validation."""
    local = in_process(args.trials)
    c_ratio = c_limit()
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="cosim-campaign-bench-"))
    runs = on_dask(args.trials, out)
    print(f"extrapolated: {FULL} trials x {local['trial_s']:.3f} s = {FULL * local['trial_s'] / 60:.1f} core-minutes; "
          f"on 2 cores at the measured per-trial time {FULL * local['trial_s'] / 2 / 60:.1f} minutes (+ set-up)")
    if not args.out:
        shutil.rmtree(out, ignore_errors=True)
    if args.validation:
        write_speed_section(local, c_ratio, runs)


if __name__ == "__main__":
    main()
