"""Diagnosis jobs: ``cosim diagnose job.toml`` reads a TOML job (model, measured data, experiment, free baseline
parameters, candidate effects), validated up front with every problem reported at once.

Job schema (paths relative to the job file)::

    [model]       source = "x.mo", name = "Pkg.Model", parameters = {name = value}   # fixed values
    [data]        path = "x.csv|x.parquet", inputs = {model_input = "column"}, start, stop, decimate
                  or, for repeated trials diagnosed together (time domain only), instead of path:
                  records = [{path = "trial1.csv", parameters = {name = value}}, ...]   # per-trial fixed values
    [experiment]  kind = "staircase"|"impact"|"frequency", duration (s: the data must cover it),
                  steady_s (the last steady_s of each hold enter the cost; staircase), min_hold_s
                  frequency: input (the model input excited), sample_rate (Hz; 0: continuous), bands_per_decade
    or, for records of different experiments of one plant diagnosed together (time series), instead of
    [data] and [experiment], one table per record:
    [[experiments]]  name, kind = "staircase"|"impact", path, inputs, parameters = {name = value},
                     duration, steady_s, min_hold_s                        # as in [data] and [experiment]
    [compare]     signals = [{output = "F_g", column = "F_g", noise = 0.5}]   # noise: floor under the estimate
                  rtol (CVODES), max_nfev (least-squares evaluations per fit)
    [parameters.NAME]  start, min, max                                       # the baseline's free parameters
    [candidates]  effects = ["backdrive_efficiency", ...]                    # default: all that apply
                  forms = ["power_law_coating", ...]    # laws of another form (default: none)
    [decision]    min_gap_removed = 0.5, min_delta_bic = 10, gap_sigmas = 3, rounds = 3
    [parallel]    workers (0: in this process), scheduler (a Dask address)
"""

import math
from dataclasses import dataclass
from pathlib import Path

from cosim.diagnose.effects import EFFECTS, applicable, variant_text
from cosim.errors import ConfigError
from cosim.diagnose.kinds import KINDS, Part, Several, kind_of
from cosim.tomldoc import bounded_parameters, number, read_text, read_toml, sections, signal_tables, string, values

__all__ = ["DiagnoseJob", "load_diagnose_job", "load_experiment", "load_records"]

_SCHEMA = {
    "model": ("source", "name", "parameters"),
    "data": ("path", "records", "inputs", "start", "stop", "decimate"),
    "experiment": ("kind", "duration", "steady_s", "min_hold_s", "input", "sample_rate", "bands_per_decade"),
    "compare": ("signals", "rtol", "max_nfev"),
    "candidates": ("effects", "forms"),
    "decision": ("min_gap_removed", "min_delta_bic", "gap_sigmas", "rounds"),
    "parallel": ("workers", "scheduler"),
}


@dataclass(frozen=True)
class DiagnoseJob:
    """A validated diagnosis job (the module docstring gives its TOML form; docs/reference/jobs.md every key).

    Attributes
    ----------
    path : Path
        The job file.
    source : Path
        The Modelica file of the baseline.
    model : str
        The baseline's full name, ``Pkg.Model``.
    fixed : dict
        Parameter values held for every record (``[model] parameters``).
    records : tuple
        ``(data file, {parameter: value})`` per measured record; the values are fixed for that record only.
    inputs : dict
        Model input -> data column.
    window : tuple of float
        ``(start, stop)`` of the data used, s.
    decimate : int
        Keep every n-th sample.
    kind : cosim.diagnose.kinds.ExperimentKind
        The experiment's kind (``experiment.kind``; a staircase without ``steady_s`` is a speed run); for
        ``[[experiments]]`` a :class:`~cosim.diagnose.kinds.Several` holding each record's experiment.
    duration, steady_s, min_hold_s : float
        Length the data must cover, the steady tail of each hold that enters the cost, the shortest hold, s.
    signals : tuple
        ``(output, column, noise floor)`` per compared signal.
    rtol : float
        CVODES relative tolerance.
    max_nfev : int
        Least-squares evaluations per fit.
    free : dict
        Baseline parameter -> :class:`~cosim.fitting.FreeParameter`.
    effects : tuple of str
        The candidates: the effects, then the forms (:attr:`~cosim.diagnose.effects.Effect.is_form`).
    min_gap_removed, min_delta_bic, gap_sigmas : float
        The decision's thresholds.
    workers : int
        Dask workers (0: in this process).
    scheduler : str
        A Dask scheduler address ("" for a local cluster).
    input : str
        Frequency kind: the excited model input.
    sample_rate : float
        Frequency kind: Hz of the zero-order hold the model is compared through (0: continuous).
    bands_per_decade : float
        Frequency kind: width of the frequency bands (the segments).
    rounds : int
        At most this many rounds: each adds the candidate it names and looks again at the gap left
        (:mod:`cosim.diagnose.rounds`).
    origin, adopted : tuple
        In a later round's job (:func:`~cosim.diagnose.rounds.job_with`): the user's (source, model), whose
        variant with the ``adopted`` candidates is this job's baseline.
    """

    path: Path
    source: Path
    model: str
    fixed: dict
    records: tuple  # of (data file, {parameter: value} fixed for that trial only); one record for data.path
    inputs: dict
    window: tuple
    decimate: int
    kind: object  # an ExperimentKind
    duration: float
    steady_s: float
    min_hold_s: float
    signals: tuple  # of (output, column, noise floor)
    rtol: float
    max_nfev: int
    free: dict  # name -> FreeParameter
    effects: tuple
    min_gap_removed: float
    min_delta_bic: float
    gap_sigmas: float
    workers: int
    scheduler: str
    input: str = ""  # frequency kind: the excited model input
    sample_rate: float = 0.0  # frequency kind: Hz of the ZOH the model is compared through (0: continuous)
    bands_per_decade: float = 6.0  # frequency kind: width of the frequency bands (segments)
    rounds: int = 3
    origin: tuple = ()  # a later round's job: (source, model) of the user's baseline
    adopted: tuple = ()  # a later round's job: the candidates earlier rounds added, in order

    @property
    def user_model(self):
        """(source, model) of the baseline the user gave (a later round's job diagnoses it with earlier
        findings added)."""
        return self.origin or (self.source, self.model)

    @property
    def data_path(self):
        """The first (for data.path: the only) record's data file."""
        return self.records[0][0]


def load_diagnose_job(path, overrides=()):
    """Read and validate a diagnosis job; every problem is reported at once with file:line and key.

    Parameters
    ----------
    path : str or Path
        The TOML job.
    overrides : sequence of str, optional
        ``--set key=value`` overrides, applied before validation.

    Returns
    -------
    DiagnoseJob

    Raises
    ------
    ConfigError
        Every problem of the job, each with file:line and key.
    """
    path = Path(path)
    data, problems = read_toml(path, overrides, what="job")
    several = "experiments" in data
    t = sections(data, problems, _SCHEMA, free_form=("parameters", "experiments"))
    base = path.parent
    source = base / (string(problems, t["model"], "source", ("model",)) or "")
    model = string(problems, t["model"], "name", ("model",)) or ""
    source_text = ""
    if source != base:
        if not source.is_file():
            problems.add(("model", "source"), f"no such Modelica file: {source}")
        else:
            try:
                source_text = read_text(source, "Modelica source")
            except ConfigError as err:
                problems.add(("model", "source"), str(err))
    free = bounded_parameters(data, problems, required=False)
    if several:
        for section in sorted({"data", "experiment"} & set(data)):
            problems.add((section,), "give either [data] and [experiment] (one experiment) or [[experiments]] "
                                     "(several), not both")
        records, parts = _experiments(data["experiments"], base, free, problems)
    else:
        records, parts = _records(t["data"], base, free, problems), ()
    e = t["experiment"]
    kind = string(problems, e, "kind", ("experiment",), default="staircase")
    inputs = t["data"].get("inputs", {})
    signals = signal_tables(problems, t["compare"], "signals", ("compare",), default_noise=1e-9)
    if kind in KINDS and not KINDS[kind].time_series:  # one measured response, not records of inputs
        if "inputs" in t["data"]:
            problems.add(("data", "inputs"), "a frequency response has no input time series; name the excited "
                                             "model input in experiment.input")
        if not isinstance(e.get("input"), str):
            problems.add(("experiment", "input"), "is required for a frequency response: the excited model input, "
                                                  "e.g. \"tau\"")
        if len(signals) > 1:
            problems.add(("compare", "signals"), "a frequency response compares one output (its magnitude and "
                                                 "phase)")
        if len(records) > 1:
            problems.add(("data", "records"), "a frequency response is one measured FRF: give data.path")
    elif not several and not _inputs_ok(inputs):
        problems.add(("data", "inputs"), "must map model inputs to data columns, e.g. {i_ref = \"i_ref\"}")
        inputs = {}
    d = t["data"]
    start = number(problems, d, "start", ("data",)) if "start" in d else -math.inf
    stop = number(problems, d, "stop", ("data",)) if "stop" in d else math.inf
    decimate = number(problems, d, "decimate", ("data",), default=1, positive=True, integer=True)
    if kind not in KINDS:
        problems.add(("experiment", "kind"), f"must be 'staircase', 'impact' or 'frequency'; got {kind!r}")
    sample_rate = number(problems, e, "sample_rate", ("experiment",), default=0.0)
    if sample_rate is not None and sample_rate < 0:
        problems.add(("experiment", "sample_rate"), f"must be >= 0 Hz (0: continuous); got {sample_rate!r}")
    per_decade = number(problems, e, "bands_per_decade", ("experiment",), default=6.0, positive=True)
    duration = number(problems, e, "duration", ("experiment",), positive=True) if "duration" in e else None
    steady_s = number(problems, e, "steady_s", ("experiment",), default=0.0) if "steady_s" in e else 0.0
    min_hold_s = number(problems, e, "min_hold_s", ("experiment",), positive=True) \
        if "min_hold_s" in e else max(steady_s or 0.0, 0.05)
    rtol = number(problems, t["compare"], "rtol", ("compare",), default=1e-6, positive=True)
    max_nfev = number(problems, t["compare"], "max_nfev", ("compare",), default=40, positive=True, integer=True)
    effects = _candidates(t["candidates"], "effects", source_text, model, problems, free)
    effects += _candidates(t["candidates"], "forms", source_text, model, problems, free)
    dec = t["decision"]
    min_gap = number(problems, dec, "min_gap_removed", ("decision",), default=0.5, positive=True)
    min_bic = number(problems, dec, "min_delta_bic", ("decision",), default=10.0, positive=True)
    gap_sigmas = number(problems, dec, "gap_sigmas", ("decision",), default=3.0, positive=True)
    rounds = number(problems, dec, "rounds", ("decision",), default=3, positive=True, integer=True)
    workers = number(problems, t["parallel"], "workers", ("parallel",), default=2, integer=True)
    if workers is not None and workers < 0:
        problems.add(("parallel", "workers"), f"must be >= 0 (0: in this process); got {workers}")
    scheduler = string(problems, t["parallel"], "scheduler", ("parallel",), default="")
    experiment_input = string(problems, e, "input", ("experiment",), default="")
    fixed = values(problems, t["model"], "parameters", ("model",))
    problems.raise_if_any()
    return DiagnoseJob(
        path=path, source=source, model=model, fixed=fixed,
        records=tuple(records), inputs=dict(inputs), window=(start, stop), decimate=decimate,
        kind=Several(parts=tuple(parts)) if several else kind_of(kind, steady_s),
        duration=duration, steady_s=steady_s, min_hold_s=min_hold_s, signals=tuple(signals), rtol=rtol,
        max_nfev=max_nfev, free=free, effects=tuple(effects), min_gap_removed=min_gap, min_delta_bic=min_bic,
        gap_sigmas=gap_sigmas, workers=workers, scheduler=scheduler,
        input=experiment_input, sample_rate=sample_rate, bands_per_decade=per_decade, rounds=rounds)


def _candidates(table, key, source_text, model, problems, free):
    """The candidates of ``candidates.effects`` (default: every effect that applies and frees no parameter the job
    frees) or ``candidates.forms`` (default: none), each checked to be of that sort, to fit the model and not to
    free a parameter of ``free`` (the job's) a second time."""
    forms = key == "forms"
    names = table.get(key)
    if names is None:
        if forms:
            return []
        try:
            found = applicable(source_text, model) if source_text else []
        except ConfigError as err:  # no such model, or a slot that does not take its effect's block
            problems.add(("candidates", key), str(err))
            return []
        return [n for n in found if not _freed_twice(n, free)]
    if not isinstance(names, list) or not all(isinstance(x, str) for x in names):
        problems.add(("candidates", key), f"must be a list of {'form' if forms else 'effect'} identifiers")
        return []
    for n in names:
        if n not in EFFECTS:
            known = ", ".join(name for name, e in EFFECTS.items() if e.is_form == forms)
            problems.add(("candidates", key), f"unknown {'form' if forms else 'effect'} {n!r}; implemented: {known}")
        elif EFFECTS[n].is_form != forms:
            problems.add(("candidates", key), f"{n!r} is {'an effect' if forms else 'a form'}: list it under "
                                              f"candidates.{'effects' if forms else 'forms'}")
        elif twice := _freed_twice(n, free):
            problems.add(("candidates", key), f"{n!r} frees {', '.join(twice)}, which the job frees already "
                                              f"({', '.join(f'[parameters.{p}]' for p in twice)}): a parameter is "
                                              f"freed once; drop {n} or the [parameters] table")
        elif source_text and model:
            try:
                variant_text(source_text, model, EFFECTS[n])
            except ConfigError as err:
                problems.add(("candidates", key), str(err))
    return list(names)


def _freed_twice(name, free):
    """The baseline parameters the effect ``name`` frees that the job frees already (``free``), sorted: freed by
    both, its fit would take the effect's bounds and the BIC would count a parameter the fit does not add."""
    return sorted({n for n, _, _ in EFFECTS[name].frees} & set(free))


def _refuse_free(problems, where, fixed, free, what):
    """A record's own parameter values may fix parameters, never set one the diagnosis frees."""
    for name in sorted(set(fixed) & set(free)):
        problems.add(where + ("parameters", name), f"is a free parameter ([parameters]); {what} can only fix a "
                                                   "parameter")


def _inputs_ok(inputs):
    """Whether ``inputs`` maps model inputs to data columns."""
    return isinstance(inputs, dict) and bool(inputs) and all(isinstance(v, str) for v in inputs.values())


_EXPERIMENT_KEYS = ("name", "kind", "path", "inputs", "parameters", "duration", "steady_s", "min_hold_s")


def _experiments(tables, base, free, problems):
    """The records of ``[[experiments]]`` (data file, fixed values) and each one's experiment
    (:class:`~cosim.diagnose.kinds.Part`), checked: time-series kinds only, names and files each once."""
    if not isinstance(tables, list) or not tables or not all(isinstance(x, dict) for x in tables):
        problems.add(("experiments",), "must be an array of tables [[experiments]], each with kind, path and inputs")
        return [], []
    records, parts = [], []
    for k, e in enumerate(tables):
        where = ("experiments", k)
        for key in sorted(set(e) - set(_EXPERIMENT_KEYS)):
            problems.add(where + (key,), f"unknown key; allowed: {', '.join(_EXPERIMENT_KEYS)}")
        kind = string(problems, e, "kind", where) or ""
        if kind == "frequency":
            problems.add(where + ("kind",), "a frequency response is not a time series: diagnose it in a job of its "
                                            "own")
        elif kind and kind not in KINDS:
            problems.add(where + ("kind",), f"must be 'staircase' or 'impact'; got {kind!r}")
        data_file = string(problems, e, "path", where) or ""
        if not _inputs_ok(e.get("inputs")):
            problems.add(where + ("inputs",), "must map model inputs to data columns, e.g. {i_ref = \"i_ref\"}")
        fixed = values(problems, e, "parameters", where)
        _refuse_free(problems, where, fixed, free, "an experiment")
        steady_s = number(problems, e, "steady_s", where, default=0.0)
        parts.append(Part(
            name=string(problems, e, "name", where, default=f"{kind} {k + 1}"),
            kind=kind_of(kind, steady_s) if kind in KINDS else None,
            inputs=dict(e["inputs"]) if _inputs_ok(e.get("inputs")) else {},
            duration=number(problems, e, "duration", where, positive=True) if "duration" in e else None,
            steady_s=steady_s, min_hold_s=number(problems, e, "min_hold_s", where, positive=True)
            if "min_hold_s" in e else max(steady_s or 0.0, 0.05)))
        records.append((base / data_file, fixed))
    for what, items in (("name", [p.name for p in parts]), ("path", [r for r, _ in records])):
        for item in sorted({str(x) for x in items if items.count(x) > 1}):
            problems.add(("experiments",), f"{what} {item!r} is given to more than one experiment")
    return records, parts


def _records(d, base, free, problems):
    """The data files with their per-trial fixed parameters: data.path alone, or the tables of data.records (a
    trial may fix a parameter, not one of the ``free`` ones)."""
    if ("path" in d) == ("records" in d):
        problems.add(("data",), "give exactly one of data.path (one record: a CSV or Parquet file with `time` and "
                                "the measured channels) and data.records (repeated trials)")
        return []
    if "path" in d:
        if not isinstance(d["path"], str):
            problems.add(("data", "path"), "must be a string: a CSV or Parquet file")
            return []
        return [(base / d["path"], {})]
    if not isinstance(d["records"], list) or not d["records"]:
        problems.add(("data", "records"), "must be a list of tables {path = \"trial1.csv\", parameters = {...}}")
        return []
    records = []
    for k, r in enumerate(d["records"]):
        where = ("data", "records", k)
        if not isinstance(r, dict) or not isinstance(r.get("path"), str):
            problems.add(where, "must be a table with a path: {path = \"trial1.csv\", parameters = {gap0 = 0.0075}}")
            continue
        for key in sorted(set(r) - {"path", "parameters"}):
            problems.add(where + (key,), "unknown key; allowed: path, parameters")
        trial = r.get("parameters", {})
        if not isinstance(trial, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                  for v in trial.values()):
            problems.add(where + ("parameters",), "must map parameter names to numbers")
            trial = {}
        _refuse_free(problems, where, trial, free, "a trial")
        records.append((base / r["path"], {n: float(v) for n, v in trial.items()}))
    return records


def load_records(job, model):
    """Every record of the job aligned with ``model``: a list of (Experiment, the trial's fixed parameters)."""
    return [(load_experiment(job, model, path), trial) for path, trial in job.records]


def load_experiment(job, model, path=None):
    """The data of ``path`` (default: the job's first record) aligned with ``model`` (a LoweredModel), as the
    job's kind reads it (:meth:`~cosim.diagnose.kinds.ExperimentKind.load`)."""
    return job.kind.load(job, model, path)
