"""The ``cosim`` command line: a thin layer that parses arguments and calls one library function per command."""

import argparse
import sys
from pathlib import Path

from cosim.errors import CosimError

__all__ = ["main"]


def _cmd_build(args):
    from cosim.compile import build_all, build_fmu

    if args.file is None:
        if args.model is not None:
            raise CosimError("--model needs a FILE: cosim build FILE.mo --model Pkg.Model")
        for line in build_all(models_toml=args.models, out_dir=args.out, force=args.force):
            print(line)
        return 0
    if args.model is None:
        raise CosimError(f"{args.file}: name the model to build with --model Pkg.Model")
    path = build_fmu(args.file, args.model, out_dir=args.out or "fmus")
    print(f"built {path}")
    return 0


def _add_build(sub):
    p = sub.add_parser(
        "build",
        help="compile Modelica models to FMI 3.0 Model-Exchange FMUs",
        description=(
            "Compile Modelica to FMI 3.0 Model-Exchange FMUs. With FILE and --model, build that model to "
            "OUT/<Model>.fmu. With no FILE, build every model listed in modelica/models.toml, skipping those "
            "whose sources and compiler version are unchanged."
        ),
    )
    p.add_argument("file", nargs="?", help="Modelica source file (.mo)")
    p.add_argument("--model", help="full name of the model to build, e.g. Gripper.GripperPlant")
    p.add_argument("--out", help="output directory (default: fmus/, or the one models.toml names)")
    p.add_argument("--models", default="modelica/models.toml", help="model list used when no FILE is given")
    p.add_argument("--force", action="store_true", help="rebuild even when up to date")
    p.set_defaults(func=_cmd_build)


def _add_haptic(sub):
    from cosim.haptic.cli import add_haptic_parser

    add_haptic_parser(sub)


def _cmd_run(args):
    from cosim.master import run_config

    result, summary, files = run_config(args.config, out=args.out, overrides=args.set, csv=args.csv,
                                        progress=False if args.no_progress else None)
    for f in files:
        print(f"wrote {f}")
    compiled = f"; kernels compiled or loaded in {result.compile_s:.2g} s" if result.engine == "compiled" else ""
    note = f"; {result.engine_note}" if result.engine_note else ""
    print(f"simulated {result.sim_s:.6g} s in {result.wall_s:.3g} s wall ({result.engine} engine{compiled}{note})")
    if result.interrupted:
        print("cosim run: interrupted; kept what was recorded", file=sys.stderr)
        return 130
    if result.stopped is not None:
        s = result.stopped
        print(f"cosim run: stopped at t={s['time']:.9g} s: {s['by']} asked to terminate"
              f"{': ' + s['reason'] if s['reason'] else ''}; kept what was recorded")
    return 0


def _add_run(sub):
    p = sub.add_parser(
        "run",
        help="co-simulate the FMUs and controllers of a TOML config",
        description="Run a co-simulation config; writes OUT/results.parquet, OUT/summary.json and a PNG plot.",
    )
    p.add_argument("config", help="run config (.toml)")
    p.add_argument("--out", help="output folder (default out/<config stem>)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any config key, e.g. --set fmus.plant.parameters.eta_g=0.7 (repeatable)")
    p.add_argument("--csv", action="store_true", help="also write OUT/results.csv")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_run)


def _cmd_calibrate(args):
    from cosim.calibrate.job import run_job

    out = args.out or f"out/{Path(args.job).stem}"
    summary = run_job(args.job, out=out, overrides=args.set, progress=not args.no_progress)
    from cosim.calibrate.report import standard_error

    for name, p in summary["parameters"].items():
        print(f"{name} = {p['value']:.6g} {standard_error(p['std_error'])}, start {p['start']:.6g}")
    print(f"cost {summary['cost_before']:.6g} -> {summary['cost_after']:.6g} in {summary['iterations']} "
          f"iterations ({summary['return_status']}); wrote {out}/calibration.json, parameters.toml, fit.png")
    return 0


def _add_calibrate(sub):
    p = sub.add_parser(
        "calibrate",
        help="fit model parameters to measured data (CasADi/IPOPT, exact derivatives, multi-start)",
        description=("Fit the free parameters of a Modelica model to measured signals. Writes "
                     "OUT/calibration.json (values, standard errors, correlations, costs), OUT/parameters.toml "
                     "and OUT/fit.png."),
    )
    p.add_argument("job", help="calibration job (.toml)")
    p.add_argument("--out", help="output folder (default out/<job stem>)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any job key, e.g. --set data.path=measured.csv (repeatable)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_calibrate)


def _cmd_diagnose(args):
    from cosim.diagnose import diagnose

    out = args.out or f"out/{Path(args.job).stem}"
    result = diagnose(args.job, out=out, overrides=args.set, progress=not args.no_progress,
                      build=not args.no_build)
    print(result.verdict)
    unit = f" {result.units[0]}" if result.units[0] else ""
    print(f"{result.signals[0]}, measured vs replayed model: RMSE {result.rmse_before:.4g} -> "
          f"{result.rmse_after:.4g}{unit}, max error {result.max_error_before:.4g} -> "
          f"{result.max_error_after:.4g}{unit}; wrote {out}/diagnosis.json, report.md")
    return 0


def _add_diagnose(sub):
    p = sub.add_parser(
        "diagnose",
        help="find where simulation and measurement disagree, name the missing effect, add it",
        description=("Calibrate the baseline model on the measured data (one record, or repeated trials diagnosed "
                     "together: data.records), locate significant residuals by segment, fit each candidate "
                     "effect (Modelica variants) in parallel, name the winner or 'none', write the variant into "
                     "the Modelica source, rebuild and re-run through the master. Writes OUT/diagnosis.json, "
                     "OUT/report.md and PNGs."),
    )
    p.add_argument("job", help="diagnosis job (.toml)")
    p.add_argument("--out", help="output folder (default out/<job stem>)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any job key, e.g. --set data.path=measured.csv (repeatable)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-build", action="store_true", help="do not build the FMUs nor re-run them through the master")
    p.set_defaults(func=_cmd_diagnose)


# Each command adds its parser here; keep one function per command.
_COMMANDS = [_add_build, _add_haptic, _add_run, _add_calibrate, _add_diagnose]


def make_parser():
    """Build the argument parser with every subcommand."""
    parser = argparse.ArgumentParser(
        prog="cosim",
        description="Modelica plants compiled to FMUs, co-simulated against Python controllers at their real rates.")
    from cosim import __version__

    parser.add_argument("--version", action="version", version=f"cosim {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="on an error, show the Python traceback too (for a bug report)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in _COMMANDS:
        add(sub)
    return parser


def main(argv=None):
    """Run the CLI; returns the exit status (0 success, 2 bad input or a failed step, 130 interrupted).

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: the process's). ``--debug`` before the command shows the traceback of an error.

    Returns
    -------
    int
    """
    parser = make_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return args.func(args)
    except CosimError as err:
        if args.debug:
            raise
        print(f"cosim {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"cosim {args.command}: interrupted", file=sys.stderr)
        return 130
