"""Speed of ``cosim campaign``: the wall time of a trial and what is spent outside the engine's loop, and the
speed-up from 1 to 2 workers, measured on a small grid of full trials (5 s of tightening), then extrapolated
to the shipped 6,000-trial campaign.

    PYTHONPATH=. python benchmarks/campaign.py [--trials 5] [--out DIR]

Needs fmus/GripperPlant.fmu (``cosim build``). Grid: bare and P3 x 1000 rpm x 1.0 and 2.5 A x ``--trials``.

* in process: one :class:`~cosim.campaign.trial.TrialRunner` per coating, trials one after the other: the set-up
  (config, engine, kernels), the wall time of a trial, the part of it inside the engine's loop, simulated
  seconds per wall second.
* on Dask: ``run_campaign`` on a local cluster of 1 worker, then of 2 workers, one after the other in this run
  (each from a new output folder: cluster start-up and set-up included).
The load average of the machine is printed with each figure: other jobs share the cores.
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
    print(f"in process, {n} trials ({_load()}):")
    print(f"  set-up per coating (config, engine, kernels, first trial): {setup / len(job.coatings):.2f} s")
    print(f"  wall per trial {wall / n:.3f} s, of which in the engine's loop {loop / n:.3f} s; outside it "
          f"{100 * (1 - loop / wall):.1f} %")
    print(f"  simulated {sim / n:.2f} s per trial: loop {loop / sim:.4f} wall s per simulated s "
          f"({sim / loop:.1f} simulated s per wall s per core)")
    return wall / n


def on_dask(trials, out):
    """The same grid on a local cluster of 1 then 2 workers; returns {workers: wall_s}."""
    from cosim.campaign import run_campaign

    walls = {}
    for workers in (1, 2):
        folder = out / f"w{workers}"
        shutil.rmtree(folder, ignore_errors=True)
        t0 = time.perf_counter()
        s = run_campaign(JOB, out=folder, overrides=_grid(trials), workers=workers, progress=False)
        walls[workers] = time.perf_counter() - t0
        r = s["run"]
        print(f"dask, {workers} worker(s), {r['ran']} trials ({_load()}): command {walls[workers]:.1f} s, "
              f"trials phase {r['wall_s']:.1f} s; per trial on its worker {r['trial_s']:.3f} s, outside the loop "
              f"{100 * r['overhead_share']:.1f} %, set-up summed over workers {r['setup_s']:.1f} s")
    print(f"1 -> 2 workers: {walls[1] / walls[2]:.2f}x (whole command, cluster start-up included)")
    return walls


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=5, help="trials per cell (4 cells)")
    ap.add_argument("--out", help="output folder of the Dask runs (default: a temporary one)")
    args = ap.parse_args()
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, {_load()}")
    per_trial = in_process(args.trials)
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="cosim-campaign-bench-"))
    on_dask(args.trials, out)
    print(f"extrapolated: {FULL} trials x {per_trial:.3f} s = {FULL * per_trial / 60:.1f} core-minutes; on 2 "
          f"cores at the measured per-trial time {FULL * per_trial / 2 / 60:.1f} minutes (+ set-up)")
    if not args.out:
        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
