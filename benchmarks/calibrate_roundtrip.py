"""Round trip of the static calibration: the shipped staircase co-simulated by `cosim run` at a known eta_g is
calibrated back by `cosim calibrate examples/calibrate_static.toml` (issue 43, "the calibration model agrees with
the run model"; docs/calibration.md, development history in docs/dev/calibration-roundtrip.md).

1. `cosim run examples/gripper_static.toml` (FOC at 26.6 kHz, outer loop at 100 Hz, GripperPlant FMU) with k_t and
   T_c0 of the shipped static calibration (`--set fmus.plant.parameters_file=...`; `--scale datasheet`: the FMU's
   own), `--set fmus.plant.parameters.eta_g=ETA` over them, and the calibration job's condition (its [model]
   parameters: fingers pinned to the aluminium cylinders, gap0 = 0) set on the plant;
2. the 100 Hz record written as the job reads its data (time, i_ref = the outer loop's current set-point, F_g
   plus seeded Gaussian load-cell noise, drawn once);
3. `cosim calibrate examples/calibrate_static.toml --set data.path=...`: eta_g, k_t and T_c0 free.
Printed: each free parameter recovered +- 1 s.e. against the value the run used, the fit's residual RMS against
the noise, and the wall time of each step.

Usage: python benchmarks/calibrate_roundtrip.py [--eta 0.7] [--noise 0.5] [--seed 43] [--out out/roundtrip]
           [--scale calibrated|datasheet] [--step-s 5] [--top-a 2.5] [--run-condition]
--run-condition keeps the run config's own condition (gap0 = 2 mm: the fingers close onto the cylinders and
strike them at the first step that breaks the drag free): the data then hold a first touch the job's model
(pinned fingers) cannot make. --scale datasheet puts the dead zone T_c0/k_t on a staircase level (0.20003 A), where
the fit stops at a kink of its cost.
"""

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from cosim.calibrate.job import load_job
from cosim.config import load_config

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "examples" / "gripper_static.toml"
JOB = ROOT / "examples" / "calibrate_static.toml"
PARAMETERS_FILE = "calibrated/static_paper.toml"  # relative to the config: the shipped static calibration


def run_overrides(eta, condition, scale="calibrated", step_s=None, top_a=None, plant_fmu=None):
    """The `cosim run --set` items: the plant FMU (``plant_fmu``, default the config's), the plant's scale (k_t,
    T_c0), eta_g, the job's condition on the plant, and optionally a shorter staircase (steps of ``step_s`` up to
    ``top_a``)."""
    items = [] if plant_fmu is None else [f"fmus.plant.path={Path(plant_fmu).as_posix()}"]
    if scale == "calibrated":
        items.append(f"fmus.plant.parameters_file={PARAMETERS_FILE}")
    else:  # the FMU's own values, even under a parameters file the config may read
        declared = load_config(CONFIG, items).fmus["plant"].info.variables
        items += [f"fmus.plant.parameters.{n}={float(declared[n].start)!r}" for n in ("k_t", "T_c0")]
    items.append(f"fmus.plant.parameters.eta_g={eta!r}")
    items += [f"fmus.plant.parameters.{k}={v!r}" for k, v in condition.items()]
    if step_s is not None or top_a is not None:
        spec = load_config(CONFIG, items).controllers["outer"]
        outer = {**spec.cls.parameters, **spec.parameters}
        step_s = outer["step_s"] if step_s is None else step_s
        top_a = outer["top_A"] if top_a is None else top_a
        steps = 2 * round(top_a / outer["step_A"])  # up and down; the last is the final 0 A hold
        items += [f"controllers.outer.parameters.step_s={step_s!r}", f"controllers.outer.parameters.top_A={top_a!r}",
                  f"run.stop={steps * step_s!r}"]
    return items


def truth(overrides):
    """The plant's value of each parameter the job frees, as the run used them (config, parameters file, --set)."""
    plant = load_config(CONFIG, overrides).fmus["plant"]
    free = load_job(JOB).free
    return {n: float(plant.parameters.get(n, plant.info.variables[n].start)) for n in free}


def cosim(*args):
    """Run `python -m cosim ARGS` as a user would; return its wall time in s (exit status checked)."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "cosim", *map(str, args), "--no-progress"], check=True, cwd=ROOT)
    return time.perf_counter() - start


def write_data(results, path, noise, seed):
    """The run's record in the job's data format, F_g plus N(0, noise) drawn once; returns the noise drawn."""
    rows = pd.read_parquet(results)
    drawn = noise * np.random.default_rng(seed).standard_normal(len(rows))
    pd.DataFrame({"time": rows["time"], "i_ref": rows["outer.i_q_ref"], "F_g": rows["F_g"] + drawn}).to_csv(
        path, index=False)
    return drawn


def round_trip(out, eta=0.7, noise=0.5, seed=43, scale="calibrated", step_s=None, top_a=None, job_condition=True,
               job_overrides=(), plant_fmu=None):
    """Run, write the data, calibrate; return the figures (see the module docstring). ``plant_fmu``: a
    GripperPlant FMU other than the config's fmus/GripperPlant.fmu (the tests' own build)."""
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    condition = load_job(JOB).fixed if job_condition else {}
    overrides = run_overrides(eta, condition, scale, step_s, top_a, plant_fmu)
    values = truth(overrides)
    set_items = [a for o in overrides for a in ("--set", o)]
    wall_run = cosim("run", CONFIG, "--out", out / "run", "--force", *set_items)
    summary = json.loads((out / "run" / "summary.json").read_text())
    if f"fmus.plant.parameters.eta_g={eta!r}" not in summary["overrides"] or values["eta_g"] != eta:
        raise RuntimeError(f"the run did not use eta_g = {eta}: {summary['overrides']}, {values}")
    data = out / "staircase.csv"
    drawn = write_data(out / "run" / "results.parquet", data, noise, seed)
    job_items = [a for o in [f"data.path={data}", *job_overrides] for a in ("--set", o)]
    wall_fit = cosim("calibrate", JOB, "--out", out / "calibration", "--force", *job_items)
    fit = json.loads((out / "calibration" / "calibration.json").read_text())
    signal_noise = load_job(JOB, [f"data.path={data}", *job_overrides]).signals[0][2]
    return {"truth": values, "fit": fit["parameters"], "samples": fit["samples"], "cost": fit["cost_after"],
            "residual_rms": signal_noise * math.sqrt(2 * fit["cost_after"] / fit["samples"]),
            "noise_rms": float(np.sqrt(np.mean(drawn ** 2))), "wall_run_s": wall_run, "wall_fit_s": wall_fit,
            "run_overrides": summary["overrides"], "parameters_files": summary.get("parameters_files", {})}


def report(figures, noise):
    """Print the figures of :func:`round_trip`."""
    print(f"run overrides: {' '.join(figures['run_overrides'])}")
    if figures["parameters_files"]:
        print(f"parameters files read by the run: {figures['parameters_files']}")
    print(f"{'parameter':<8}{'run':>12}{'recovered':>12}{'1 s.e.':>10}{'error/s.e.':>12}")
    for name, value in figures["truth"].items():
        p = figures["fit"][name]
        se = p["std_error"] or math.inf
        print(f"{name:<8}{value:>12.5g}{p['value']:>12.5g}{se:>10.2g}{(p['value'] - value) / se:>+12.2f}")
    print(f"residual RMS {figures['residual_rms']:.3f} N over {figures['samples']} fitted samples (cost "
          f"{figures['cost']:.1f}); noise {noise} N (drawn: RMS {figures['noise_rms']:.3f} N); ratio "
          f"{figures['residual_rms'] / noise:.2f}")
    print(f"wall time: cosim run {figures['wall_run_s']:.1f} s, cosim calibrate {figures['wall_fit_s']:.1f} s")


def main(argv):
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--eta", type=float, default=0.7, help="eta_g of the co-simulated plant")
    args.add_argument("--noise", type=float, default=0.5, help="load-cell noise, N (1 sd)")
    args.add_argument("--seed", type=int, default=43, help="seed of the noise")
    args.add_argument("--out", default=str(ROOT / "out" / "roundtrip"), help="folder for the run, data and fit")
    args.add_argument("--scale", choices=("calibrated", "datasheet"), default="calibrated",
                      help="k_t and T_c0 of the plant: the shipped static calibration's, or the FMU's own")
    args.add_argument("--step-s", type=float, help="staircase step duration, s (default: the config's)")
    args.add_argument("--top-a", type=float, help="staircase top current, A (default: the config's)")
    args.add_argument("--run-condition", action="store_true",
                      help="keep the run config's condition instead of the job's (shows the bias)")
    opts = args.parse_args(argv)
    figures = round_trip(opts.out, opts.eta, opts.noise, opts.seed, opts.scale, opts.step_s, opts.top_a,
                         job_condition=not opts.run_condition)
    report(figures, opts.noise)


if __name__ == "__main__":
    main(sys.argv[1:])
