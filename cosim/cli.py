"""The ``cosim`` command line: a thin layer that parses arguments and calls one library function per command."""

import argparse
import signal
import subprocess
import sys
import warnings
from pathlib import Path

from cosim.errors import CosimError, EngineFallbackWarning, LibraryTransformWarning, ScaleWarning

__all__ = ["main"]


_PRECOMPILE = "from cosim.master.compiled import precompile, shipped_controllers; precompile(shipped_controllers())"


def _cmd_build(args):
    from cosim.api import build

    if args.file is not None and args.model is None:
        raise CosimError(f"{args.file}: name the model to build with --model Pkg.Model")
    if args.model is not None:
        build(args.file, args.model, out=args.out, modelica_path=args.modelica_path, fmi_version=args.fmi_version,
              c_sources=args.source or None, report=print)
        return 0
    # the engine's kernels compile into numba's cache meanwhile, so that the first `cosim run` loads them
    ahead = subprocess.Popen([sys.executable, "-c", _PRECOMPILE], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
    try:
        build(args.models, out=args.out, modelica_path=args.modelica_path, fmi_version=args.fmi_version,
              force=args.force, c_sources=args.source or None, report=print)
    except BaseException:
        ahead.kill()
        ahead.wait()
        raise
    _, err = ahead.communicate()
    if ahead.returncode:
        print(f"cosim build: note: compiling the engine's kernels ahead failed (the first run compiles them): "
              f"{(err.strip().splitlines() or ['?'])[-1]}", file=sys.stderr)
    return 0


def _add_build(sub):
    p = sub.add_parser(
        "build",
        help="compile Modelica models to FMUs (FMI 3.0 or 2.0)",
        description=(
            "Compile Modelica to FMUs with Model Exchange and Co-Simulation (FMI 3.0 by default, FMI 2.0 with "
            "--fmi-version 2). With FILE and --model, build that model to OUT/<Model>.fmu; with --model alone, "
            "a model of a library on the library path (cosim build --model "
            "Modelica.Mechanics.Rotational.Examples.First --modelica-path DIR). With neither, build every model "
            "listed in modelica/models.toml, skipping those whose sources, libraries and compiler version are "
            "unchanged. Libraries (the Modelica Standard Library, your own) are looked for in the --modelica-path "
            "folders, then those of models.toml's libraries = [...], then those of the MODELICAPATH environment "
            "variable (separated by ':' on Linux and macOS, ';' on Windows)."
        ),
    )
    p.add_argument("file", nargs="?", help="Modelica source file (.mo)")
    p.add_argument("--model", help="full name of the model to build, e.g. Gripper.GripperPlant")
    p.add_argument("--modelica-path", action="append", default=[], metavar="DIR",
                   help="a folder holding Modelica libraries, e.g. the one that holds Modelica/ (repeatable)")
    p.add_argument("--out", help="output directory (default: fmus/, or the one models.toml names); new, or one "
                                 "holding only FMUs and cosim's build files; only the FMUs built are replaced")
    p.add_argument("--models", default="modelica/models.toml", help="model list used when no FILE is given")
    p.add_argument("--force", action="store_true", help="rebuild even when up to date")
    p.add_argument("--fmi-version", type=int, choices=(2, 3),
                   help="FMI version of the FMUs (default: 3, or each models.toml entry's fmi_version)")
    p.add_argument("--source", action="store_true",
                   help="also ship the C sources in the FMUs (sources/), for importers on other platforms")
    p.set_defaults(func=_cmd_build)


def _add_haptic(sub):
    from cosim.haptic.cli import add_haptic_parser

    add_haptic_parser(sub)


def _signal_exit(result):
    """The exit status of a run a signal interrupted, as a shell gives it: 128 + the signal's number (Ctrl-C 130)."""
    return 128 + signal.Signals[result.stopped["cause"]].value


def _cmd_run(args):
    from cosim.api import run
    from cosim.errors import RunStopped

    out = args.out or Path("out") / Path(args.config).stem
    try:
        result = run(args.config, set=args.set, out=out, csv=args.csv, force=args.force,
                     progress=False if args.no_progress else None)
    except RunStopped as stop:
        for f in stop.files:
            print(f"wrote {f}")
        print(f"cosim run: {stop}; kept what was recorded before (summary.json \"stopped\")", file=sys.stderr)
        return 3
    for f in result.files:
        print(f"wrote {f}")
    compiled = f"; kernels compiled or loaded in {result.compile_s:.2g} s" if result.engine == "compiled" else ""
    note = f"; {result.engine_note}" if result.engine_note else ""
    print(f"simulated {result.sim_s:.6g} s in {result.wall_s:.3g} s wall ({result.engine} engine{compiled}{note})")
    s = result.stopped
    if result.interrupted:
        print(f"cosim run: {s['reason']}; kept what was recorded", file=sys.stderr)
        return _signal_exit(result)
    if s is not None:
        print(f"cosim run: stopped at t={s['time']:.9g} s: {s['by']} asked to terminate"
              f"{': ' + s['reason'] if s['reason'] else ''}; kept what was recorded")
    return 0


def _add_run(sub):
    p = sub.add_parser(
        "run",
        help="co-simulate the FMUs and controllers of a TOML config",
        description=("Run a co-simulation config; writes OUT/results.parquet, OUT/summary.json and a PNG plot. "
                     "CONFIG may be an SSP archive (.ssp): its FMUs, connections, parameter values and default "
                     "experiment are run, every output connector recorded at its step (docs/guide/ssp.md)."),
    )
    p.add_argument("config", help="run config (.toml) or SSP archive (.ssp)")
    p.add_argument("--out", help="output folder (default out/<config stem>)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any config key, e.g. --set fmus.plant.parameters.eta_g=0.7 (repeatable)")
    p.add_argument("--csv", action="store_true", help="also write OUT/results.csv")
    p.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_run)


def _cmd_calibrate(args):
    from cosim.calibrate import calibrate
    from cosim.calibrate.report import standard_error

    out = args.out or f"out/{Path(args.job).stem}"
    result = calibrate(args.job, set=args.set, out=out, progress=not args.no_progress, force=args.force)
    for name, p in result.parameters.items():
        print(f"{name} = {p.value:.6g} {standard_error(p.std_error)}, start {p.start:.6g}")
    print(f"cost {result.cost_before:.6g} -> {result.cost_after:.6g} in {result.iterations} "
          f"iterations ({result.return_status}); wrote {out}/calibration.json, parameters.toml, fit.png")
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
    p.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    p.set_defaults(func=_cmd_calibrate)


def _cmd_diagnose(args):
    from cosim.diagnose import diagnose

    out = args.out or f"out/{Path(args.job).stem}"
    result = diagnose(args.job, set=args.set, out=out, build=not args.no_build, force=args.force,
                      progress=not args.no_progress)
    print(result.verdict)
    for label, text in (("evidence", result.evidence), ("next step", result.next_step)):
        if text:
            print(f"{label}: {text}")
    unit = f" {result.units[0]}" if result.units[0] else ""
    print(f"{result.signals[0]}, measured vs replayed model: RMSE {result.rmse_before:.4g} -> "
          f"{result.rmse_after:.4g}{unit}, max error {result.max_error_before:.4g} -> "
          f"{result.max_error_after:.4g}{unit}; wrote {out}/diagnosis.json, report.md")
    return 0


def _add_diagnose(sub):
    p = sub.add_parser(
        "diagnose",
        help="find where simulation and measurement disagree, name the missing effect, add it",
        description=("Calibrate the baseline model on the measured data (one record; repeated trials diagnosed "
                     "together: data.records; or records of several experiments of one plant: [[experiments]], "
                     "the answer saying which record showed each finding), locate significant residuals by "
                     "segment, fit each candidate effect or form of a law (Modelica variants) in parallel, name "
                     "the winner or 'none', write the variant into the Modelica source, rebuild and re-run "
                     "through the master; while a gap is "
                     "left after the winner, look again with it added (decision.rounds, default 3). Writes "
                     "OUT/diagnosis.json, OUT/report.md and PNGs."),
    )
    p.add_argument("job", help="diagnosis job (.toml)")
    p.add_argument("--out", help="output folder (default out/<job stem>)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any job key, e.g. --set data.path=measured.csv (repeatable)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-build", action="store_true", help="do not build the FMUs nor re-run them through the master")
    p.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    p.set_defaults(func=_cmd_diagnose)


def _cmd_campaign(args):
    from cosim.campaign import campaign, run_one_trial

    if args.trial is not None:
        row, command = run_one_trial(args.job, args.trial, overrides=args.set)
        for k, v in row.items():
            print(f"{k} = {v}")
        print(f"the same co-simulation alone (without the load cell's noise):\n{command}")
        return 0
    out = args.out or f"out/{Path(args.job).stem}"
    result = campaign(args.job, set=args.set, out=out, workers=args.workers, scheduler=args.scheduler,
                      progress=not args.no_progress)
    run = result.run
    if result.interrupted:
        print(f"cosim campaign: interrupted; {run['resumed'] + run['ran']} of {run['trials']} trials kept in "
              f"{out}/parts; the same command resumes", file=sys.stderr)
        return 130
    print(f"{result.trials} trials ({run['resumed']} resumed, {run['ran']} run in {run['wall_s']:.1f} s on "
          f"{run['workers']} worker{'s' if run['workers'] != 1 else ''}); {result.p3_iqr_below_bare}")
    print(f"wrote {out}/trials.parquet, table1.csv, table1.md, boxplots.png, summary.json")
    return 0


def _add_dask_options(p):
    """--workers N | --scheduler ADDRESS: where a command's Dask tasks run."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N", help="workers of the local Dask cluster (default: one a core)")
    where.add_argument("--scheduler", default="", metavar="ADDRESS",
                       help="address of a running Dask scheduler, e.g. tcp://127.0.0.1:8786")


def _add_campaign(sub):
    p = sub.add_parser(
        "campaign",
        help="a grid of co-simulated gripper impacts with physical variability (the paper's Table 1), on Dask",
        description=("Run every trial of a campaign job (coatings x impact speeds x tightening currents x trials), "
                     "each a full impact co-simulation, in batches on a Dask cluster; finished batches are kept in "
                     "OUT/parts and the same command resumes. Writes OUT/trials.parquet, OUT/table1.csv, "
                     "OUT/table1.md, OUT/boxplots.png and OUT/summary.json."),
    )
    p.add_argument("job", help="campaign job (.toml)")
    p.add_argument("--out", help="output folder (default out/<job stem>); a folder of the same job is resumed")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any job key, e.g. --set campaign.trials=10 (repeatable)")
    _add_dask_options(p)
    p.add_argument("--trial", type=int, metavar="K",
                   help="run trial K (row K of trials.parquet) alone in this process; print it and its cosim run command")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_campaign)


def _cmd_sensitivity(args):
    from cosim.campaign.sensitivity import run_sensitivity

    out = args.out or f"out/{Path(args.job).stem}"
    summary = run_sensitivity(args.job, out=out, overrides=args.set, workers=args.workers, scheduler=args.scheduler,
                              progress=not args.no_progress, force=args.force)
    print(f"{summary['points']} parameter points x {summary['trials'] // summary['points']} trials = "
          f"{summary['trials']} trials in {summary['run']['wall_s']:.1f} s wall")
    for output, top in summary["largest_total_index"].items():
        print(f"  {output}: largest total index {top['factor']} ST = {top['ST']:.2f} +- {top['ST_conf']:.2f}")
    print(f"wrote {out}/points.parquet, indices.csv, indices.png, summary.json")
    return 0


def _add_sensitivity(sub):
    p = sub.add_parser(
        "sensitivity",
        help="Sobol sensitivity of a campaign's steady-force median and IQR to estimated constants, on Dask",
        description=("Run the trials of a reduced campaign grid at every parameter point of a Saltelli sample of "
                     "the job's factors, on a Dask cluster, and write the first-order and total Sobol indices of "
                     "each cell's steady-force median and IQR with their confidence intervals: OUT/indices.csv, "
                     "OUT/indices.png, OUT/points.parquet, OUT/summary.json."),
    )
    p.add_argument("job", help="sensitivity job (.toml)")
    p.add_argument("--out", help="output folder (default out/<job stem>)")
    p.add_argument("--force", action="store_true", help="replace a previous cosim output at --out")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any job key, e.g. --set sensitivity.samples=8 (repeatable)")
    _add_dask_options(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_sensitivity)


def _cmd_export_ssp(args):
    from cosim.ssp.write import export_ssp

    print(f"wrote {export_ssp(args.config, args.out, overrides=args.set, force=args.force)}")
    return 0


def _add_export_ssp(sub):
    p = sub.add_parser(
        "export-ssp",
        help="write a run config's FMUs, connections and parameter values as an SSP archive",
        description=("Write the FMUs of a run config, their connections and parameter values as an SSP 1.0 "
                     "archive (SystemStructure.ssd, the FMUs and one .ssv per FMU) that other tools open. The "
                     "Python controllers are components of type application/x-cosim-controller, described by a "
                     "TOML resource: another tool needs an implementation of them (docs/guide/ssp.md)."),
    )
    p.add_argument("config", help="run config (.toml)")
    p.add_argument("--out", required=True, help="the SSP archive written (.ssp); a new file unless --force")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override any config key before writing, e.g. --set run.stop=1 (repeatable)")
    p.add_argument("--force", action="store_true", help="replace the file at --out when it exists")
    p.set_defaults(func=_cmd_export_ssp)


def _cmd_info(args):
    from cosim.single_fmu import describe_fmu

    print(describe_fmu(args.fmu))
    return 0


def _add_info(sub):
    p = sub.add_parser(
        "info",
        help="what an FMU declares: interfaces, default experiment, variables",
        description="Print what an FMU (FMI 2.0 or 3.0, cosim's or another tool's) declares: FMI version, model, "
                    "the tool that generated it, its interfaces (Model Exchange, Co-Simulation), default experiment, "
                    "and a table of its variables (name, causality, variability, type, start, unit, description).",
    )
    p.add_argument("fmu", help="the FMU (.fmu)")
    p.set_defaults(func=_cmd_info)


def _cmd_simulate(args):
    from cosim.single_fmu import report_lines, simulate_fmu

    result, out, kind = simulate_fmu(args.fmu, out=args.out, start=args.start_time, stop=args.stop_time,
                                     step=args.step, sets=args.set, kind=args.kind, force=args.force)
    print("\n".join(report_lines(result, out, kind)))
    return _signal_exit(result) if result.interrupted else 0


def _add_simulate(sub):
    p = sub.add_parser(
        "simulate",
        help="simulate one FMU from its default experiment and write a CSV, with no config",
        description="Simulate one FMU (FMI 2.0 or 3.0, cosim's or another tool's) with no run config: from its "
                    "default experiment (else from 0 to 1 s), by Co-Simulation when it has it (else Model Exchange, "
                    "integrated by cosim's variable-step BDF at the experiment's tolerance, 1e-6 when it gives "
                    "none), recording its outputs (its local variables when it has none) at every output step. "
                    "The CSV has a header line of 'name [unit]' columns (the bare name when the variable declares "
                    "no unit), time first in s, then one row an output step; Booleans are written 0/1.",
    )
    p.add_argument("fmu", help="the FMU (.fmu)")
    p.add_argument("--start-time", type=float, metavar="T", help="start time in s (default: the default experiment's, "
                                                                  "else 0)")
    p.add_argument("--stop-time", type=float, metavar="T", help="stop time in s (default: the default experiment's, "
                                                                 "else start + 1)")
    p.add_argument("--step", type=float, metavar="H",
                   help="output step in s, also the Co-Simulation communication step (default: the default "
                        "experiment's stepSize, else 10^(round(log10(stop - start)) - 3), as FMPy)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a parameter's value, or the start value of an input (held for the whole run) or of a state, "
                        "set before initialisation, e.g. --set e=0.8 or --set load.J=0.3; the name as the FMU spells "
                        "it (cosim info lists them), the value a number or true/false (repeatable)")
    p.add_argument("--kind", choices=("CS", "ME"), help="the interface (default: CS when the FMU has it)")
    p.add_argument("--out", help="the CSV file (default out/<FMU stem>.csv)")
    p.add_argument("--force", action="store_true", help="replace the file at --out when it exists")
    p.set_defaults(func=_cmd_simulate)


# Each command adds its parser here; keep one function per command.
_COMMANDS = [_add_build, _add_haptic, _add_info, _add_simulate, _add_run, _add_export_ssp, _add_calibrate,
             _add_diagnose, _add_campaign, _add_sensitivity]


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


def _warning_line(command):
    """How a warning reads on the terminal: ``cosim COMMAND: warning: message`` (cosim's own warnings say where
    and what; the Python source line that raised them says nothing to a user)."""
    def line(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, (ScaleWarning, EngineFallbackWarning, LibraryTransformWarning)):
            return f"cosim {command}: warning: {message}\n"
        return default(message, category, filename, lineno, line)

    default = warnings.formatwarning
    return line


def main(argv=None):
    """Run the CLI; returns the exit status: 0 success, 2 bad input or a failed step, 3 a run stopped by a fault
    (what it recorded is written), 128 + the signal number when interrupted (130 Ctrl-C, 143 SIGTERM).

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
    warnings.formatwarning = _warning_line(args.command)
    try:
        return args.func(args)
    except CosimError as err:
        if args.debug:
            raise
        print(f"cosim {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as interrupt:
        # Ctrl-C, or SIGTERM/SIGHUP turned into an interrupt: the shell's 128 + signal number
        signum = getattr(interrupt, "signum", signal.SIGINT)
        print(f"cosim {args.command}: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum
