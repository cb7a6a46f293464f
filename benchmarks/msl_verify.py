"""Verify one Modelica Standard Library example against the Modelica Association's reference results: build it
with cosim (rumoca front end, cosim's lowering and export), simulate the FMU with fmpy's own CVode over the
reference's time span, and compare every comparison signal away from event instants.

Used by benchmarks/msl.py (the whole table) and tests/test_msl.py (a fast subset and the regression list).
The criterion is the one shared/msl/README.md proposes: a signal is verified when
``max |y - y_ref| / max(range(y_ref), tiny) <= 2e-3`` at the reference's instants, instants near an event of the
reference or of the simulation left out. The FMU runs under CVode at the smaller of the experiment's tolerance
and 1e-8: at 1e-6 the simulation's own error after a step (PID_Controller, 2.2e-3) exceeds the criterion, at
1e-9 it is 3e-4.
"""

import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

TOLERANCE = 2e-3
"""Largest error of a verified signal, relative to the reference's range."""
STAGES = ("rumoca", "lower", "export", "simulate", "signals", "compare", "uncompared", "ran", "verified")
"""How far a model got: rumoca (parse, flatten) failed; cosim's lowering failed; the C export failed; the FMU
failed at run time; comparison signals missing from the FMU; a signal off by more than TOLERANCE; a signal with
no instant left to compare (every one near an event); built and ran (a model without reference results);
verified."""

__all__ = ["TOLERANCE", "STAGES", "Row", "reference_dir", "read_reference", "experiment", "verify", "compare",
           "judge"]


@dataclass
class Row:
    """One model's outcome: the stage it reached, the worst signal, the cause of a failure in a sentence."""

    model: str
    stage: str = "rumoca"
    worst_signal: str = ""
    worst_error: float = float("nan")
    cause: str = ""
    seconds: float = 0.0
    missing: list = field(default_factory=list)

    def as_dict(self):
        return asdict(self)


def reference_dir(refs, model):
    """The folder of ``model``'s reference results under ``refs`` (``Modelica/Blocks/Examples/PID_Controller``)."""
    return Path(refs).joinpath(*model.split("."))


def read_reference(folder):
    """``(time, {signal: values}, names)`` of a reference folder's CSV and comparisonSignals.txt."""
    folder = Path(folder)
    names = [n.strip() for n in (folder / "comparisonSignals.txt").read_text().split() if n.strip() != "time"]
    csv = next(folder.glob("*.csv"))
    with csv.open() as lines:
        header = [h.strip().strip('"') for h in lines.readline().split(",")]
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    columns = {name: data[:, k] for k, name in enumerate(header)}
    time_column = next(name for name in header if name.lower() == "time")  # "time" or "Time"
    return columns[time_column], columns, names


def experiment(msl, model):
    """``(StartTime, StopTime, Tolerance)`` of ``model``'s experiment annotation (defaults 0, 1, 1e-6)."""
    from cosim.compile.annotation import model_experiment

    given = model_experiment(None, model, [Path(msl)])
    return given.get("StartTime", 0.0), given.get("StopTime", 1.0), given.get("Tolerance", 1e-6)


def _event_times(t):
    """Instants that appear twice in a result: events (values before and after)."""
    t = np.asarray(t)
    return np.unique(t[1:][np.diff(t) == 0])


def compare(t_ref, y_ref, t_sim, y_sim, span):
    """The largest error of ``y_sim`` against ``y_ref`` relative to the reference's range, at the reference's
    instants that are not within a thousandth of the span of an event of either result. A jump of the reference
    between two of its rows by over a tenth of its range counts as an event too (a discontinuity the tool that
    made it did not mark: ``noEvent``, a density's edge), unless the signal jumps at over 2 % of its rows.
    None when no instant is left to compare: an empty comparison verifies nothing."""
    y_ref = np.asarray(y_ref, dtype=float)
    jumps = np.flatnonzero(np.abs(np.diff(y_ref)) > 0.1 * max(float(np.ptp(y_ref)), 1e-300))
    if len(jumps) > 0.02 * len(y_ref):  # a signal that jumps at most rows (sampled noise): compared everywhere
        jumps = jumps[:0]
    events = np.concatenate([_event_times(t_ref), _event_times(t_sim), t_ref[jumps], t_ref[jumps + 1]])
    keep = np.ones(len(t_ref), dtype=bool)
    window = 1e-3 * span
    for e in events:
        keep &= np.abs(t_ref - e) > window
    # Just after an event of the simulation the interpolation must use the value after it: the last occurrence.
    order = np.arange(len(t_sim))
    last = np.r_[np.diff(t_sim) != 0, True]
    y_at = np.interp(t_ref[keep], t_sim[last], np.asarray(y_sim, dtype=float)[order[last]])
    ref = y_ref[keep]
    tiny = max(1e-10, 1e-6 * float(np.max(np.abs(y_ref)))) if len(y_ref) else 1e-10
    scale = max(float(np.ptp(y_ref)), tiny)
    return float(np.max(np.abs(y_at - ref)) / scale) if len(ref) else None


def _first_line(error, msl, model):
    """The error's first line, without the library's folder and the model's name that every row would repeat, and
    without what the front end's refusal says of the validation run (cosim.compile.refusal)."""
    text = str(error).strip().splitlines()
    line = (text[0] if text else "").replace(str(Path(msl)) + "/", "")
    line = line.replace(f"front end, refused {model}: ", "front end, refused it: ")
    for repeated in (f"Modelica/package.mo: {model}: ", f"{model} failed in ", f"{model}: "):
        line = line.replace(repeated, "")
    line = line.split("; cosim's validation run")[0]  # what an earlier run saw is no cause of this run's row
    return f"{type(error).__name__}: {line}"[:400]


def verify(model, msl, refs, fmi_type="ModelExchange", workdir=None):
    """Build, simulate and compare ``model``; a :class:`Row` that says how far it got and why it stopped. A model
    without reference results (no CSV in its folder, or no folder) is built and run to its experiment's
    StopTime: stage ``ran`` when that works."""
    import fmpy

    from cosim.compile.export import export_fmu
    from cosim.compile.frontend import load_flat_model
    from cosim.compile.lower import lower_system
    from cosim.compile.translate import translate
    from cosim.errors import BuildError

    row, start = Row(model), time.perf_counter()
    folder = reference_dir(refs, model) if refs else None
    referenced = folder is not None and any(folder.glob("*.csv"))
    t_ref, columns, names = read_reference(folder) if referenced else (None, {}, [])
    t0, t1, tolerance = experiment(msl, model)
    if referenced:
        t0, t1 = float(t_ref[0]), float(t_ref[-1])
    try:
        flat = load_flat_model(None, model, [Path(msl)])
    except Exception as error:  # noqa: BLE001 - every failure is a row of the table
        row.cause = _first_line(error, msl, model)
        return _done(row, start)
    row.stage = "lower"
    try:
        lowered = lower_system(translate(flat))
        row.stage = "export"
        with tempfile.TemporaryDirectory(dir=workdir) as out:
            fmu = export_fmu(lowered, Path(out) / f"{model.rsplit('.', 1)[-1]}.fmu")
            row.stage = "signals"
            exposed = {v.name for v in fmpy.read_model_description(str(fmu)).modelVariables}
            row.missing = [n for n in names if n not in exposed]
            row.stage = "simulate"
            result = fmpy.simulate_fmu(
                str(fmu), start_time=t0, stop_time=t1, fmi_type=fmi_type, relative_tolerance=min(tolerance, 1e-8),
                output_interval=_output_interval(t_ref, t0, t1), output=[n for n in names if n in exposed] or None)
    except Exception as error:  # noqa: BLE001
        row.cause = _first_line(error, msl, model)
        if row.stage == "export" and not isinstance(error, BuildError):
            row.stage = "lower"
        return _done(row, start)
    if not referenced:
        row.stage, row.cause = "ran", f"no reference results: built and ran to {t1:g} s"
        return _done(row, start)
    return _done(judge(row, t_ref, columns, names, result, t1 - t0), start)


def _output_interval(t_ref, t0, t1):
    """The simulation's output grid: a quarter of the reference's median step (linear interpolation between its
    points then errs by a sixteenth of the reference's own), at most a 5000th of the span."""
    if t_ref is None or len(t_ref) < 2:
        return (t1 - t0) / 5000
    steps = np.diff(t_ref)
    return min((t1 - t0) / 5000, float(np.median(steps[steps > 0])) / 4)


def judge(row, t_ref, columns, names, result, span):
    """The row's stage from the comparison of every signal of ``names`` the FMU has (``result``: fmpy's) with the
    reference: compare (a signal off, or not a number), signals (some missing), uncompared (a signal with no
    instant away from events), else verified."""
    compared = {n: compare(t_ref, columns[n], result["time"], result[n], span) for n in names if n not in row.missing}
    errors = {n: e for n, e in compared.items() if e is not None}
    uncompared = [n for n, e in compared.items() if e is None]
    if errors:
        row.worst_signal = max(errors, key=errors.get)
        row.worst_error = errors[row.worst_signal]
    missing = f"{len(row.missing)} of {len(names)} comparison signals not in the FMU: {', '.join(row.missing[:3])}"
    if errors and (row.worst_error > TOLERANCE or not np.isfinite(row.worst_error)):  # a wrong number first
        row.stage = "compare"
        row.cause = f"{row.worst_signal} off by {row.worst_error:.3g} of its range" + (
            f"; {missing}" if row.missing else "")
    elif row.missing:
        row.stage = "signals"
        row.cause = missing
    elif uncompared:
        row.stage = "uncompared"
        row.cause = (f"{len(uncompared)} of {len(names)} comparison signals not compared (every instant near an "
                     f"event): {', '.join(uncompared[:3])}")
    else:
        row.stage = "verified"
    return row


def _done(row, start):
    row.seconds = time.perf_counter() - start
    return row
