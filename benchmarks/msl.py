"""Build every Modelica Standard Library example that has reference results, simulate it with fmpy and compare
it with the Modelica Association's reference (benchmarks/msl_verify.py says how); print one row per model and
the counts per package and per stage reached.

Usage:
    python benchmarks/msl.py --msl DIR --refs DIR [--only TEXT ...] [--jobs 2] [--timeout 600] [--rows FILE]
                             [--validation]

--msl: the folder holding Modelica/ (MSL 4.1.0); --refs: the folder holding Modelica/<package>/Examples/<Model>/
with <Model>.csv and comparisonSignals.txt. --only: models whose name contains one of the texts. --jobs: worker
processes (each parses the library once). --rows: also write every row as JSON lines. --validation: write the
table into docs/validation.md (section msl) and every model's stage into cosim/data/msl_validation.csv (what
``cosim build`` says of an MSL example the front end refuses).
"""

import argparse
import collections
import csv
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from msl_verify import STAGES, TOLERANCE, Row, verify  # noqa: E402

PACKAGES = ("Modelica.Mechanics.Rotational", "Modelica.Mechanics.Translational", "Modelica.Mechanics.MultiBody",
            "Modelica.Electrical.Analog", "Modelica.Electrical.Machines", "Modelica.Thermal.HeatTransfer",
            "Modelica.Thermal.FluidHeatFlow", "Modelica.Blocks")


def reference_models(refs):
    """Every model that has reference results (a CSV) under ``refs``, by full name, sorted."""
    refs = Path(refs)
    return sorted(".".join(p.parent.relative_to(refs).parts) for p in refs.rglob("comparisonSignals.txt")
                  if any(p.parent.glob("*.csv")))


def _models_in(block, prefix):
    """The models of a ``package Examples ... end Examples;`` block by full name, those of its nested packages
    too (by their indentation), but a package of utilities, base classes or components."""
    found, packages = [], []
    for indent, kind, name in re.findall(r"^( *)(package|model) (\w+)", block, re.M)[1:]:
        packages = [(i, n) for i, n in packages if i < len(indent)]
        if kind == "package":
            packages.append((len(indent), name))
        elif not any(n.endswith("Utilities") or n in ("BaseClasses", "Components") for _, n in packages):
            found.append(".".join([prefix, *(n for _, n in packages), name]))
    return found


def example_models(msl, package):
    """The example models of ``package`` (``Modelica.Thermal.HeatTransfer``) in the library at ``msl``: one per
    file of its Examples folders, or per top-level model of an Examples.mo or of a ``package Examples`` written
    inside a package's file (``Modelica.Blocks``); partial models and the Utilities and BaseClasses folders left
    out."""
    root = Path(msl).joinpath(*package.split("."))
    found = []
    for mo in sorted(root.rglob("*.mo")):
        parts = mo.relative_to(Path(msl)).with_suffix("").parts
        if {"Utilities", "BaseClasses", "Components"} & set(parts):
            continue
        text = mo.read_text(encoding="utf-8", errors="replace")
        prefix = ".".join(parts[:-1] if mo.name == "package.mo" else parts)
        if "Examples" not in parts:
            for inner in re.finditer(r"^( *)package Examples\b.*?^\1end Examples;", text, re.M | re.S):
                found += _models_in(inner.group(0), f"{prefix}.Examples")
            continue
        if mo.name == "package.mo" or mo.stem == "Examples":
            found += [f"{prefix}.{name}" for name in re.findall(r"^  model (\w+)", text, re.M)]
        elif re.search(rf"^(?:encapsulated )?model {re.escape(mo.stem)}\b", text, re.M):
            found.append(".".join(parts))
    return found


def _worker(models, msl, refs, rows_file, timeout):
    """Verify ``models`` one after another in this process; each row is appended to ``rows_file`` as it ends,
    after a line naming the model begun, so that the parent can tell which model a crash took down."""
    def give_up(signum, frame):
        raise TimeoutError(f"took over {timeout} s")

    signal.signal(signal.SIGALRM, give_up)
    with open(rows_file, "a", encoding="utf-8") as out:
        for model in models:
            out.write(json.dumps({"started": model}) + "\n")
            out.flush()
            signal.alarm(timeout)
            try:
                row = verify(model, msl, refs)
            except TimeoutError as error:
                row = Row(model, stage="simulate", cause=f"TimeoutError: {error}", seconds=float(timeout))
            finally:
                signal.alarm(0)
            out.write(json.dumps(row.as_dict()) + "\n")
            out.flush()


def _read_rows(rows_file):
    """(finished rows by model, the model begun and not finished or None)."""
    rows, begun = {}, None
    if not Path(rows_file).is_file():
        return rows, begun
    for line in Path(rows_file).read_text(encoding="utf-8").splitlines():
        entry = json.loads(line)
        if "started" in entry:
            begun = entry["started"]
        else:
            rows[entry["model"]] = Row(**entry)
            begun = None
    return rows, begun


def run_all(models, args):
    """Verify ``models`` in ``args.jobs`` worker processes, printing each row as it ends; a worker that dies is
    replaced, its model recorded as a crash."""
    rows = {}
    with tempfile.TemporaryDirectory(prefix="cosim-msl-") as scratch:
        queues = [models[k::args.jobs] for k in range(args.jobs)]
        files = [Path(scratch) / f"rows{k}.jsonl" for k in range(args.jobs)]
        running = {k: _spawn(queue, args, files[k]) for k, queue in enumerate(queues) if queue}
        while running:
            time.sleep(0.5)
            for k, process in list(running.items()):
                finished = process.poll() is not None
                done, begun = _read_rows(files[k])
                for model in set(done) - set(rows):
                    rows[model] = done[model]
                    _print(done[model])
                if not finished:
                    continue
                del running[k]
                if begun is not None:
                    rows[begun] = Row(begun, stage="simulate", cause=f"the process died (exit {process.returncode}):"
                                      " a crash inside the FMU, gcc or rumoca")
                    _print(rows[begun])
                    files[k].write_text("", encoding="utf-8")
                left = [m for m in queues[k] if m not in rows]
                if left:
                    running[k] = _spawn(left, args, files[k])
    return [rows[m] for m in models]


def _spawn(models, args, rows_file):
    command = [sys.executable, __file__, "--msl", args.msl, "--refs", args.refs, "--timeout", str(args.timeout),
               "--worker", rows_file.as_posix(), *models]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=dict(os.environ, OMP_NUM_THREADS="1"))


def _print(row):
    error = "" if row.worst_error != row.worst_error else f"{row.worst_error:.2e}"
    print(f"{row.model:<66} {row.stage:<9} {row.worst_signal[:28]:<28} {error:>9} {row.seconds:>6.1f}  {row.cause[:150]}",
          flush=True)


def package_of(model):
    return next((p for p in PACKAGES if model.startswith(p + ".")), model.rsplit(".", 2)[0])


def counts(rows):
    """Per package: verified / all, and how many stopped at each stage."""
    table = []
    by_package = collections.defaultdict(list)
    for row in rows:
        by_package[package_of(row.model)].append(row)
    for package, group in sorted(by_package.items()) + [("all", rows)]:
        stages = collections.Counter(r.stage for r in group)
        table.append([package, f"{stages['verified']} / {len(group)}", *(stages[s] for s in STAGES[:-1])])
    return table


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--msl", required=True, help="the folder holding Modelica/")
    parser.add_argument("--refs", required=True, help="the folder holding Modelica/<package>/Examples/<Model>/")
    parser.add_argument("--only", nargs="*", default=[], help="models whose name contains one of these texts")
    parser.add_argument("--examples", nargs="*", default=[], metavar="PACKAGE",
                        help="also the example models of these packages that have no reference results (built "
                             "and run to their StopTime), e.g. Modelica.Thermal.HeatTransfer")
    parser.add_argument("--examples-only", action="store_true",
                        help="only the --examples models, not those with reference results")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--timeout", type=int, default=600, help="s a model may take (default 600)")
    parser.add_argument("--rows", help="also write every row to this file (JSON lines)")
    parser.add_argument("--validation", action="store_true",
                        help="write the table into docs/validation.md and cosim/data/msl_validation.csv")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("models", nargs="*", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        return _worker(args.models, args.msl, args.refs, args.worker, args.timeout)
    referenced = reference_models(args.refs)
    others = [m for package in args.examples for m in example_models(args.msl, package) if m not in referenced]
    models = [m for m in ([] if args.examples_only else referenced) + others
              if not args.only or any(o in m for o in args.only)]
    print(f"{len(models)} models, {args.jobs} workers; verified when every comparison signal is within "
          f"{TOLERANCE:g} of its range", flush=True)
    start = time.perf_counter()
    rows = run_all(models, args)
    print(f"\n{'package':<34}{'verified':>10}" + "".join(f"{s:>9}" for s in STAGES[:-1]))
    table = counts(rows)
    for line in table:
        print(f"{line[0]:<34}{line[1]:>10}" + "".join(f"{c:>9}" for c in line[2:]))
    print(f"wall time {time.perf_counter() - start:.0f} s")
    if args.rows:
        Path(args.rows).write_text("".join(json.dumps(r.as_dict()) + "\n" for r in rows), encoding="utf-8")
    if args.validation:
        _write_validation(rows, set(referenced))


def _write_validation(rows, referenced):
    """The dev set's rows (the models with reference results) into sections msl and msl-models, the others
    (``--examples``) into msl-examples and msl-examples-models, each pair only when the run has such rows; every
    row into the shipped status file (write_status)."""
    from validation import write_section

    header = ["package", "verified", *(f"stopped: {s}" for s in STAGES[:-1])]
    stages_note = (f"Verified: every comparison signal within {TOLERANCE:g} of its range, away from events "
                   "(benchmarks/msl_verify.py). Stages: rumoca = the front end rejected it; lower = cosim's lowering; "
                   "export = C code; simulate = the FMU failed under fmpy's CVode; signals = comparison signals not "
                   "in the FMU; compare = a signal off the reference; uncompared = a signal with every instant near "
                   "an event (nothing to compare); ran = built and ran to its StopTime (no reference results).")
    dev = [r for r in rows if r.model in referenced]
    others = [r for r in rows if r.model not in referenced]
    if dev:
        write_section("msl", header, counts(dev), notes=[stages_note])
        write_section("msl-models", MODEL_HEADER, _model_rows(dev))
    if others:
        write_section("msl-examples", header, counts(others), notes=[stages_note])
        write_section("msl-examples-models", MODEL_HEADER, _model_rows(others))
    write_status(rows)


MODEL_HEADER = ["model", "stage", "worst signal", "error", "time [s]", "cause"]


def _model_rows(rows):
    return [[r.model.removeprefix("Modelica."), r.stage, r.worst_signal,
             "" if r.worst_error != r.worst_error else f"{r.worst_error:.1e}", f"{r.seconds:.0f}",
             r.cause.replace("|", "/")[:200]] for r in rows]


STATUS_FILE = HERE.parent / "cosim" / "data" / "msl_validation.csv"


def write_status(rows, path=STATUS_FILE):
    """Every model's stage and cause as the package ships them (cosim.compile.refusal reads them): a user whose
    MSL example the front end refuses is told whether this run saw it refused too. The run's models replace their
    rows; the others' (a run of the dev set alone, then one of --examples) stay."""
    kept = {}
    if Path(path).is_file():
        with open(path, encoding="utf-8", newline="") as given:
            kept = {line["model"]: [line["model"], line["stage"], line["cause"]] for line in csv.DictReader(given)}
    kept.update({r.model: [r.model, r.stage, r.cause[:200]] for r in rows})
    with open(path, "w", encoding="utf-8", newline="") as out:
        table = csv.writer(out, lineterminator="\n")
        table.writerow(["model", "stage", "cause"])
        table.writerows(kept[model] for model in sorted(kept))


if __name__ == "__main__":
    main()
