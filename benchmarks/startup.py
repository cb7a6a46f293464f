"""Where the time of one ``cosim run`` goes: imports, config, kernel load, set-up, loop, writing, plotting.

Each run is a fresh process making the same calls as ``cosim run CONFIG --out DIR``, with a timer around each
phase; the whole process is timed from outside. Prints min and median over the runs, and the load average.
``--cache`` says what numba's cache (cosim.kernel_cache) holds when each run starts:

* ``warm`` (default): the kernels of this config, from one warm-up run: a user's second run;
* ``fresh``: nothing (a new empty cache folder per run): a first run that compiles everything;
* ``precompiled``: what ``cosim build`` leaves (a new cache folder per run, filled by
  ``cosim.master.compiled.precompile`` with the shipped controllers first): a new user's first run.

    python benchmarks/startup.py [--config examples/gripper_impact.toml] [--runs 3] [--cache warm] [--validation]

``--validation`` measures the three caches one after the other (precompiled, warm, fresh) and writes the table
into docs/validation.md (section ``startup``).
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

PHASES = ("imports", "config", "kernel_load", "setup", "loop", "writing", "plotting")

# The child: the calls of cosim.cli's `run` command (cosim.master.run.run_config), timed one by one.
CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import cosim.cli, cosim.master
from cosim.master import output
t1 = time.perf_counter()
from cosim.config import load_config
config = load_config(sys.argv[1], [])
t2 = time.perf_counter()
result = cosim.master.engine_for(config).run(progress=False)
t3 = time.perf_counter()
plotting = [0.0]
draw = output.plot_results
def timed(*args, **kwargs):
    start = time.perf_counter()
    try:
        return draw(*args, **kwargs)
    finally:
        plotting[0] = time.perf_counter() - start
output.plot_results = timed
output.write_results(result, config, sys.argv[2], summary=cosim.master.summarize(result, config))
t4 = time.perf_counter()
print(json.dumps({"imports": t1 - t0, "config": t2 - t1, "kernel_load": result.compile_s,
                  "setup": t3 - t2 - result.compile_s - result.wall_s, "loop": result.wall_s,
                  "writing": t4 - t3 - plotting[0], "plotting": plotting[0]}))
"""


PRECOMPILE = "from cosim.master.compiled import precompile, shipped_controllers; precompile(shipped_controllers())"


def one_run(config, out, cache=None):
    """The phases of one fresh process, and its whole wall time (s); ``cache``: the user cache folder it sees
    (None: this process's)."""
    env = dict(os.environ)
    if cache is not None:
        env.pop("NUMBA_CACHE_DIR", None)
        env["XDG_CACHE_HOME"] = cache
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", CHILD, config, out], capture_output=True, text=True, check=True,
                          env=env)
    whole = time.perf_counter() - start
    phases = json.loads(done.stdout.strip().splitlines()[-1])
    phases["whole process"] = whole
    return phases


def measure(config, runs, cache):
    """The phases of ``runs`` fresh processes of ``cosim run config``, numba's cache holding ``cache`` at each start."""
    measured = []
    with tempfile.TemporaryDirectory(prefix="cosim-startup-") as out:
        if cache == "warm":
            one_run(config, out)  # warm-up: numba's cache
        else:  # once, copied into each run's new folder
            filled = f"{out}/precompiled"
            os.makedirs(filled)
            if cache == "precompiled":
                subprocess.run([sys.executable, "-c", PRECOMPILE], check=True,
                               env={**os.environ, "XDG_CACHE_HOME": filled, "NUMBA_CACHE_DIR": ""})
        for i in range(runs):
            folder = None if cache == "warm" else shutil.copytree(filled, f"{out}/cache{i}")
            measured.append(one_run(config, out, folder))
    return measured


def report(config, cache, runs):
    """Print the phases' min and median."""
    print(f"cosim run {config}: {len(runs)} fresh processes, cache {cache}, load average {os.getloadavg()[0]:.1f}")
    print(f"{'phase':<16}{'min s':>8}{'median s':>10}")
    for phase in (*PHASES, "whole process"):
        values = [r[phase] for r in runs]
        print(f"{phase:<16}{min(values):>8.3f}{statistics.median(values):>10.3f}")
    interpreter = [r["whole process"] - sum(r[p] for p in PHASES) for r in runs]
    print(f"{'interpreter':<16}{min(interpreter):>8.3f}{statistics.median(interpreter):>10.3f}  "
          "(start-up and exit: the whole process less the phases)")


CACHES = {"precompiled": "precompiled (a first run after `cosim build`)", "warm": "warm (a second run)",
          "fresh": "fresh (a first run without `cosim build`'s cache)"}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="examples/gripper_impact.toml")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--cache", choices=tuple(CACHES), default="warm",
                        help="what numba's cache holds when a run starts (see above)")
    parser.add_argument("--validation", action="store_true",
                        help="measure every cache and write the table into docs/validation.md")
    args = parser.parse_args()
    rows = []
    for cache in CACHES if args.validation else (args.cache,):
        runs = measure(args.config, args.runs, cache)
        report(args.config, cache, runs)
        median = {phase: statistics.median(r[phase] for r in runs) for phase in (*PHASES, "whole process")}
        whole = [r["whole process"] for r in runs]
        rows.append([CACHES[cache], f"{median['kernel_load']:.2f}", f"{median['loop']:.2f}",
                     f"{median['plotting']:.2f}", f"{min(whole):.2f} / {median['whole process']:.2f}"])
    if args.validation:
        from validation import write_section

        write_section("startup", ["numba's cache at the start", "kernel load, median s", "loop, median s",
                                  "plotting, median s", "whole process, min / median s"], rows, notes=[
            f"`cosim run {args.config}`, {args.runs} fresh processes a cache, timed from outside; the phases are "
            "timed inside the process (benchmarks/startup.py)."])


if __name__ == "__main__":
    main()
