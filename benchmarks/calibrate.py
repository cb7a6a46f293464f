"""Static-curve fit of the gripper (eta_g, T_c0) with exact derivatives (CasADi: CVODES forward sensitivities
of the lowered Modelica model, trust-region Gauss-Newton) next to the same fit with finite differences through
the FMU (RK4 replay through the FMU's C functions, scipy least_squares), on the same synthetic data, in one run.

Usage: python benchmarks/calibrate.py [--top 1.0] [--step 0.5] [--validation]
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from cosim.calibrate import Calibrator
from cosim.calibrate.fmu_fit import FmuCalibrator
from cosim.calibrate.problem import Transcription
from cosim.compile import build_fmu, lower
from cosim.experiment import Experiment, steady_mask
from validation import write_section

ROOT = Path(__file__).resolve().parent.parent
SOURCE = ROOT / "modelica" / "Gripper" / "package.mo"
TRUTH = {"eta_g": 0.62, "T_c0": 0.011}
FIXED = {"gap0": 0.0, "k_obj": 1.234e9}
FREE = {"eta_g": (0.75, 0.3, 1.0), "T_c0": (0.0098, 1e-4, 0.05)}
NOISE = 0.3


def main(argv):
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--top", type=float, default=1.0, help="top of the staircase [A]")
    args.add_argument("--step", type=float, default=0.5, help="step duration [s]")
    args.add_argument("--validation", action="store_true", help="also write the table into docs/validation.md")
    opts = args.parse_args(argv)
    model = lower(SOURCE, "Gripper.GripperCurrentDriven")
    levels = np.round(np.concatenate([np.arange(0, opts.top + 1e-9, 0.1), np.arange(opts.top - 0.1, -1e-9, -0.1)]), 3)
    t = np.round(np.arange(0, len(levels) * opts.step, 0.01), 6)
    current = levels[np.minimum((t // opts.step).astype(int), len(levels) - 1)][:, None]
    shape = Experiment(t, current, np.zeros((len(t), 1)), np.ones(1), np.ones(len(t), bool))
    force = Transcription(model, shape, ["F_g"], list(TRUTH), fixed=FIXED, substeps=200).evaluate(
        np.array(list(TRUTH.values())))[3][0]
    measured = force + NOISE * np.random.default_rng(4).standard_normal(len(t))
    data = Experiment(t, current, measured[:, None], np.array([1 / NOISE]), steady_mask(t, current, 0.2, min_hold_s=0.0))
    print(f"synthetic static staircase: {len(levels)} steps of {opts.step} s up to {opts.top} A, "
          f"{len(t)} samples at 100 Hz, noise {NOISE} N; truth {TRUTH}")
    print(f"{'method':<58}{'wall [s]':>9}{'iter':>6}{'eta_g':>9}{'T_c0 [N.m]':>12}{'cost':>10}")
    rows = []
    start = time.perf_counter()
    exact = Calibrator(model, ["F_g"], FREE, fixed=FIXED, method="single_shooting").fit(data)
    rows.append(report("exact derivatives (CVODES sensitivities, Gauss-Newton)", time.perf_counter() - start,
                       exact.iterations_, exact.parameters_, exact.cost_after_))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fmu = build_fmu(SOURCE, "Gripper.GripperCurrentDriven", out_dir=ROOT / "fmus")
    start = time.perf_counter()
    fd = FmuCalibrator(fmu, ["i_ref"], ["F_g"], FREE, fixed=FIXED, substeps=200).fit(data)
    rows.append(report("finite differences through the FMU (RK4 50 us, least_squares)", time.perf_counter() - start,
                       fd.evaluations_, fd.parameters_, fd.cost_after_))
    print("source: wall-clock time on this machine (time.perf_counter), one run each; 'iter' counts Jacobian "
          "evaluations (exact) or function evaluations (finite differences, each FD Jacobian adds 2)")
    if opts.validation:
        write_section("calibrate", ["method", "wall [s]", "iterations", "eta_g", "T_c0 [N.m]", "cost"], rows,
                      seeds=[4], notes=[f"Synthetic static staircase: {len(levels)} steps of {opts.step} s up to "
                                        f"{opts.top} A, {len(t)} samples at 100 Hz, noise {NOISE} N, truth {TRUTH}. "
                                        "Iterations: Jacobian evaluations (exact) or function evaluations (finite "
                                        "differences)."])


def report(name, wall, iterations, parameters, cost):
    """Print one method's line; return it as a table row."""
    print(f"{name:<58}{wall:>9.1f}{iterations:>6}{parameters['eta_g']:>9.4f}{parameters['T_c0']:>12.5f}"
          f"{cost:>10.1f}")
    return [name, f"{wall:.1f}", iterations, f"{parameters['eta_g']:.4f}", f"{parameters['T_c0']:.5f}", f"{cost:.1f}"]


if __name__ == "__main__":
    main(sys.argv[1:])
