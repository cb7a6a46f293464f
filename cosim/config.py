"""Run configs: TOML text -> validated, frozen run spec.

:func:`load_config` parses the file once, applies ``--set key=value`` overrides, checks every key
against the schema, the FMUs' model descriptions and the controller classes, and collects *every*
problem, each with its TOML key path and ``file:line`` (found by scanning the text: tomllib gives no
line numbers for keys), before raising one :class:`cosim.errors.ConfigError`.

The schema (see docs/config.md for the full reference)::

    [run]         start, stop, seed, engine, progress
    [solver]      method (rk4|bdf|radau|lsoda), substeps, max_step, rtol, atol
    [fmus.NAME]   path, kind (ME|CS), parameters_file = "calibrated.toml", parameters = {...}, start = {...}
    [controllers.NAME]  class = "module:Class", rate, jit, parameters = {...}
    [[connections]]     from = "inst.var", to = "inst.var", gain, offset
    [record]      rate, signals = ["inst.var", ...]
    [plot]        file, panels = [["sig", ...], ...]
    [summary]     kind (none|static|impact), force, controller
"""

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from cosim.tomldoc import Problems, parse_overrides, read_toml

__all__ = [
    "load_config",
    "parse_overrides",
    "Config",
    "RunSpec",
    "SolverSpec",
    "FmuSpec",
    "ControllerSpec",
    "Connection",
    "RecordSpec",
    "PlotSpec",
    "SummarySpec",
]

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


# ----------------------------------------------------------------------------------------------
# the spec
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunSpec:
    """Run window and options. ``start``/``stop`` in s; ``progress`` is True, False or "auto"."""

    start: float = 0.0
    stop: float = 1.0
    seed: int = 0
    engine: str = "compiled"  # "compiled" (falls back to "python" where controllers need it) or "python"
    progress: object = "auto"


@dataclass(frozen=True)
class SolverSpec:
    """How Model-Exchange FMUs are integrated between sample instants.

    ``method``: "rk4" (fixed step, ``substeps`` per interval of the fastest clock, or steps of at
    most ``max_step`` s when given) or a variable-step implicit scipy method ("bdf", "radau",
    "lsoda") with ``rtol``/``atol``, restarted at every instant (inputs are held between instants).
    """

    method: str = "rk4"
    substeps: int = 1
    max_step: float = 0.0
    rtol: float = 1e-6
    atol: float = 1e-9


@dataclass(frozen=True)
class FmuSpec:
    """One FMU instance: ``path`` resolved against the config's folder; ``info`` its model description."""

    name: str
    path: Path
    kind: str
    parameters: dict
    start: dict
    info: object = field(repr=False, compare=False, default=None)


@dataclass(frozen=True)
class ControllerSpec:
    """One controller instance: ``cls`` the imported class, ``rate`` in Hz (as written)."""

    name: str
    class_path: str
    rate: float
    parameters: dict
    jit: bool = True
    cls: object = field(repr=False, compare=False, default=None)


@dataclass(frozen=True)
class Connection:
    """``dst = gain * src + offset``; ``src``/``dst`` are (instance, variable) pairs."""

    src: tuple
    dst: tuple
    gain: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class RecordSpec:
    """Signals ("inst.var") recorded at ``rate`` Hz (instants ``start + k / rate`` up to ``stop``)."""

    rate: float
    signals: tuple


@dataclass(frozen=True)
class PlotSpec:
    """PNG plot ``file`` in the output folder; each panel lists recorded column names."""

    file: str = "signals.png"
    panels: tuple = ()


@dataclass(frozen=True)
class SummarySpec:
    """Experiment summary written to summary.json: "static", "impact" or "none"."""

    kind: str = "none"
    force: str = "F_g"
    controller: str = "outer"


@dataclass(frozen=True)
class Config:
    """A validated run config (frozen); ``raw`` is the TOML data after overrides."""

    path: Path
    run: RunSpec
    solver: SolverSpec
    fmus: dict
    controllers: dict
    connections: tuple
    record: RecordSpec
    plot: PlotSpec
    summary: SummarySpec
    raw: dict = field(repr=False, compare=False, default_factory=dict)
    overrides: tuple = ()

    @property
    def name(self):
        """The config file's stem (default output folder name)."""
        return self.path.stem


# ----------------------------------------------------------------------------------------------
# suggestions
# ----------------------------------------------------------------------------------------------
def _close(name, names):
    close = difflib.get_close_matches(name, list(names), n=4, cutoff=0.5)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""


# ----------------------------------------------------------------------------------------------
# schema helpers
# ----------------------------------------------------------------------------------------------
_TOP = ("run", "solver", "fmus", "controllers", "connections", "record", "plot", "summary")
_RUN = {"start": 0.0, "stop": None, "seed": 0, "engine": "compiled", "progress": "auto"}
_SOLVER = {"method": "rk4", "substeps": 1, "max_step": 0.0, "rtol": 1e-6, "atol": 1e-9}
_FMU = ("path", "kind", "parameters_file", "parameters", "start")
_CTRL = ("class", "rate", "jit", "parameters")
_CONN = ("from", "to", "gain", "offset")
_RECORD = ("rate", "signals")
_PLOT = ("file", "panels")
_SUMMARY = ("kind", "force", "controller")
_METHODS = ("rk4", "bdf", "radau", "lsoda")


def _parameters_file(table, base_dir, problems, path):
    """The ``[parameters]`` table of a TOML file (as ``cosim calibrate`` writes it); ``parameters`` override it."""
    name = table.get("parameters_file")
    if name is None:
        return {}
    file = base_dir / str(name)
    try:
        values = tomllib.loads(file.read_text(encoding="utf-8")).get("parameters", {})
    except (OSError, tomllib.TOMLDecodeError) as err:
        problems.add(path + ("parameters_file",), f"cannot read a [parameters] table from {file}: {err}")
        return {}
    if not isinstance(values, dict):
        problems.add(path + ("parameters_file",), f"{file}: [parameters] must be a table of name = value")
        return {}
    return values


def _is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _table(data, key, problems, path):
    v = data.get(key, {})
    if not isinstance(v, dict):
        problems.add(path + (key,), f"must be a table; got {type(v).__name__}")
        return {}
    return v


def _unknown(table, allowed, problems, path):
    for k in table:
        if k not in allowed:
            problems.add(path + (k,), f"unknown key{_close(k, allowed)} (allowed: {', '.join(allowed)})")


def _number(table, key, default, problems, path, positive=False, nonneg=False, integer=False):
    v = table.get(key, default)
    if v is None:
        problems.add(path + (key,), "is required")
        return default
    if integer:
        if isinstance(v, bool) or not isinstance(v, int):
            problems.add(path + (key,), f"must be an integer; got {v!r}")
            return default
    elif not _is_num(v):
        problems.add(path + (key,), f"must be a finite number; got {v!r}")
        return default
    if positive and not v > 0:
        problems.add(path + (key,), f"must be > 0; got {v!r}")
        return default
    if nonneg and v < 0:
        problems.add(path + (key,), f"must be >= 0; got {v!r}")
        return default
    return v


def _choice(table, key, default, choices, problems, path):
    v = table.get(key, default)
    if v not in choices:
        problems.add(path + (key,), f"must be one of {', '.join(repr(c) for c in choices)}; got {v!r}{_close(str(v), choices)}")
        return default
    return v


def _signal(text, problems, path):
    if not isinstance(text, str) or "." not in text:
        problems.add(path, f"must be 'instance.variable'; got {text!r}")
        return None
    inst, _, var = text.partition(".")
    return inst, var


# ----------------------------------------------------------------------------------------------
# load
# ----------------------------------------------------------------------------------------------
def load_config(path, overrides=()):
    """Read, override and validate a run config.

    Parameters
    ----------
    path : path-like
        The TOML file; relative FMU paths and controller files are resolved against its folder.
    overrides : sequence of str, optional
        ``"key.path=value"`` items (values in TOML syntax; bare words are strings).

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        The file is missing or malformed, or any key is unknown or invalid; the message lists every
        problem with ``file:line`` (or ``--set key``) and the key path.
    """
    from cosim.errors import FmuFileError
    from cosim.fmi import read_model_info
    from cosim.plugins import load_controller_class

    path = Path(path)
    data, problems = read_toml(path, overrides, what="config")
    base_dir = path.parent

    _unknown(data, _TOP, problems, ())

    # [run]
    run_t = _table(data, "run", problems, ())
    _unknown(run_t, tuple(_RUN), problems, ("run",))
    start = _number(run_t, "start", 0.0, problems, ("run",))
    stop = _number(run_t, "stop", None, problems, ("run",))
    if _is_num(start) and _is_num(stop) and stop <= start:
        problems.add(("run", "stop"), f"must be > run.start ({start}); got {stop}")
    seed = _number(run_t, "seed", 0, problems, ("run",), integer=True, nonneg=True)
    engine = _choice(run_t, "engine", "compiled", ("compiled", "python"), problems, ("run",))
    progress = run_t.get("progress", "auto")
    if progress not in (True, False, "auto"):
        problems.add(("run", "progress"), f"must be true, false or \"auto\"; got {progress!r}")
        progress = "auto"
    run = RunSpec(float(start), float(stop or 1.0), int(seed), engine, progress)

    # [solver]
    sol_t = _table(data, "solver", problems, ())
    _unknown(sol_t, tuple(_SOLVER), problems, ("solver",))
    solver = SolverSpec(
        method=_choice(sol_t, "method", "rk4", _METHODS, problems, ("solver",)),
        substeps=_number(sol_t, "substeps", 1, problems, ("solver",), positive=True, integer=True),
        max_step=float(_number(sol_t, "max_step", 0.0, problems, ("solver",), nonneg=True)),
        rtol=float(_number(sol_t, "rtol", 1e-6, problems, ("solver",), positive=True)),
        atol=float(_number(sol_t, "atol", 1e-9, problems, ("solver",), positive=True)),
    )

    # [fmus.*]
    fmus = {}
    fmus_t = _table(data, "fmus", problems, ())
    if not fmus_t:
        problems.add(("fmus",), "at least one FMU is required: [fmus.plant] path = \"...fmu\"")
    for name, t in fmus_t.items():
        p = ("fmus", name)
        if not _NAME.match(name):
            problems.add(p, f"instance name {name!r} must be an identifier (letters, digits, _)")
        if not isinstance(t, dict):
            problems.add(p, "must be a table")
            continue
        _unknown(t, _FMU, problems, p)
        fpath = t.get("path")
        if not isinstance(fpath, str):
            problems.add(p + ("path",), "is required: the .fmu file (relative to the config's folder)")
            continue
        full = Path(fpath) if Path(fpath).is_absolute() else (base_dir / fpath)
        try:
            info = read_model_info(full)
        except FmuFileError as err:
            problems.add(p + ("path",), str(err))
            continue
        kind = t.get("kind", "ME" if "ME" in info.kinds else "CS")
        if kind not in info.kinds:
            problems.add(p + ("kind",), f"{full.name} provides {', '.join(info.kinds)}, not {kind!r}")
        params = {**_parameters_file(t, base_dir, problems, p), **_table(t, "parameters", problems, p)}
        for pn, pv in params.items():
            var = info.variables.get(pn)
            if var is None:
                names = [v.name for v in info.variables.values() if v.causality == "parameter"]
                problems.add(p + ("parameters", pn), f"{full.name} has no parameter {pn!r}{_close(pn, names)}")
            elif var.causality not in ("parameter",) or var.variability == "constant":
                problems.add(p + ("parameters", pn), f"{pn!r} is a {var.variability} {var.causality}, not a settable parameter")
            elif not (_is_num(pv) or isinstance(pv, bool)):
                problems.add(p + ("parameters", pn), f"must be a number or boolean; got {pv!r}")
        starts = _table(t, "start", problems, p)
        for sn, sv in starts.items():
            var = info.variables.get(sn)
            if var is None:
                problems.add(p + ("start", sn), f"{full.name} has no variable {sn!r}{_close(sn, info.variables)}")
            elif var.causality in ("output", "independent", "calculatedParameter") or var.variability == "constant":
                problems.add(p + ("start", sn), f"{sn!r} is a {var.causality}; its start value cannot be set")
            elif not _is_num(sv):
                problems.add(p + ("start", sn), f"must be a number; got {sv!r}")
        fmus[name] = FmuSpec(name, full, kind, dict(params), dict(starts), info)

    # [controllers.*]
    ctrls = {}
    for name, t in _table(data, "controllers", problems, ()).items():
        p = ("controllers", name)
        if not _NAME.match(name):
            problems.add(p, f"instance name {name!r} must be an identifier (letters, digits, _)")
        if name in fmus_t:
            problems.add(p, f"name {name!r} is already an FMU instance")
        if not isinstance(t, dict):
            problems.add(p, "must be a table")
            continue
        _unknown(t, _CTRL, problems, p)
        rate = _number(t, "rate", None, problems, p, positive=True)
        jit = t.get("jit", True)
        if not isinstance(jit, bool):
            problems.add(p + ("jit",), f"must be true or false; got {jit!r}")
        params = dict(_table(t, "parameters", problems, p))
        cpath = t.get("class")
        if not isinstance(cpath, str):
            problems.add(p + ("class",), "is required: \"module:Class\" or \"file.py:Class\"")
            continue
        try:
            cls = load_controller_class(cpath, base_dir)
        except ImportError as err:
            problems.add(p + ("class",), str(err))
            continue
        for pn in cls.path_parameters:
            if isinstance(params.get(pn), str) and params[pn]:
                params[pn] = str(base_dir / params[pn])
        for pn in params:
            if pn not in cls.parameters:
                problems.add(p + ("parameters", pn), f"{cls.__name__} has no parameter {pn!r}{_close(pn, cls.parameters)}")
        if rate is not None and all(pn in cls.parameters for pn in params):
            try:
                cls(rate=rate, jit=False, **params)
            except (TypeError, ValueError) as err:
                problems.add(p + ("parameters",), str(err))
        ctrls[name] = ControllerSpec(name, cpath, rate or 1.0, dict(params), bool(jit), cls)

    def outputs_of(inst):
        if inst in fmus:
            return [v.name for v in fmus[inst].info.variables.values() if v.causality == "output" and v.is_real]
        return list(ctrls[inst].cls.outputs)

    def inputs_of(inst):
        if inst in fmus:
            return [v.name for v in fmus[inst].info.variables.values() if v.causality == "input" and v.is_real]
        return list(ctrls[inst].cls.inputs)

    known = set(fmus) | set(ctrls)
    declared = set(fmus_t) | set(_table(data, "controllers", Problems("", None, {}), ()))

    def check_end(text, cpath, direction):
        sig = _signal(text, problems, cpath)
        if sig is None:
            return None
        inst, var = sig
        if inst not in known:
            if inst not in declared:
                problems.add(cpath, f"no instance {inst!r}{_close(inst, known)} (instances: {', '.join(sorted(known))})")
            return None
        good = outputs_of(inst) if direction == "from" else inputs_of(inst)
        if var not in good:
            other = inputs_of(inst) if direction == "from" else outputs_of(inst)
            if inst in fmus and var in fmus[inst].info.variables:
                v = fmus[inst].info.variables[var]
                problems.add(cpath, f"{text} has causality {v.causality!r}; a connection's {direction!r} end must be "
                                    f"{'an output' if direction == 'from' else 'an input'}{_close(var, good)}")
            elif var in other:
                problems.add(cpath, f"{text} is {'an input' if direction == 'from' else 'an output'}; a connection's "
                                    f"{direction!r} end must be {'an output' if direction == 'from' else 'an input'}")
            else:
                problems.add(cpath, f"{inst} has no {'output' if direction == 'from' else 'input'} {var!r}"
                                    f"{_close(var, good)}")
            return None
        return inst, var

    # [[connections]]
    conns = []
    ctab = data.get("connections", [])
    if not isinstance(ctab, list):
        problems.add(("connections",), "must be an array of tables: [[connections]]")
        ctab = []
    seen_dst = {}
    for i, c in enumerate(ctab):
        p = ("connections", i)
        if not isinstance(c, dict):
            problems.add(p, "must be a table with from/to")
            continue
        _unknown(c, _CONN, problems, p)
        if "from" not in c or "to" not in c:
            problems.add(p, "needs both 'from' and 'to'")
            continue
        src = check_end(c["from"], p + ("from",), "from")
        dst = check_end(c["to"], p + ("to",), "to")
        gain = _number(c, "gain", 1.0, problems, p)
        offset = _number(c, "offset", 0.0, problems, p)
        if dst is not None:
            if dst in seen_dst:
                problems.add(p + ("to",), f"{c['to']} is already driven by connections[{seen_dst[dst]}]")
            seen_dst[dst] = i
        if src is not None and dst is not None:
            if src[0] == dst[0]:
                problems.add(p, f"connects {src[0]} to itself")
            conns.append(Connection(src, dst, float(gain), float(offset)))

    # [record]
    rec_t = _table(data, "record", problems, ())
    _unknown(rec_t, _RECORD, problems, ("record",))
    rrate = _number(rec_t, "rate", 1000.0, problems, ("record",), positive=True)
    sigs = rec_t.get("signals", [])
    if not isinstance(sigs, list):
        problems.add(("record", "signals"), "must be a list of 'instance.variable' strings")
        sigs = []
    good_sigs = []
    for i, s in enumerate(sigs):
        sp = ("record", "signals", i)
        sig = _signal(s, problems, sp)
        if sig is None:
            continue
        inst, var = sig
        if inst in fmus:
            v = fmus[inst].info.variables.get(var)
            if v is None or not v.is_real:
                problems.add(sp, f"{fmus[inst].path.name} has no real variable {var!r}{_close(var, fmus[inst].info.variables)}")
                continue
        elif inst in ctrls:
            names = list(ctrls[inst].cls.inputs) + list(ctrls[inst].cls.outputs)
            if var not in names:
                problems.add(sp, f"{inst} has no signal {var!r}{_close(var, names)}")
                continue
        else:
            if inst not in declared:
                problems.add(sp, f"no instance {inst!r}{_close(inst, known)}")
            continue
        if (inst, var) not in good_sigs:
            good_sigs.append((inst, var))
    record = RecordSpec(float(rrate), tuple(good_sigs))

    # [plot]
    plot_t = _table(data, "plot", problems, ())
    _unknown(plot_t, _PLOT, problems, ("plot",))
    pfile = plot_t.get("file", "signals.png")
    if not isinstance(pfile, str) or not pfile.endswith(".png") or "/" in pfile:
        problems.add(("plot", "file"), f"must be a file name ending in .png; got {pfile!r}")
        pfile = "signals.png"
    panels = plot_t.get("panels", [])
    if not isinstance(panels, list) or not all(isinstance(x, list) and all(isinstance(s, str) for s in x) for x in panels):
        problems.add(("plot", "panels"), "must be a list of lists of recorded column names")
        panels = []
    plot = PlotSpec(pfile, tuple(tuple(x) for x in panels))

    # [summary]
    sum_t = _table(data, "summary", problems, ())
    _unknown(sum_t, _SUMMARY, problems, ("summary",))
    summary = SummarySpec(
        kind=_choice(sum_t, "kind", "none", ("none", "static", "impact"), problems, ("summary",)),
        force=sum_t.get("force", "F_g"),
        controller=sum_t.get("controller", "outer"),
    )
    if summary.kind != "none":
        if summary.controller not in ctrls and summary.controller not in declared:
            problems.add(("summary", "controller"), f"no controller {summary.controller!r}{_close(summary.controller, ctrls)}")
        if not any(var == summary.force for _, var in good_sigs):
            problems.add(("summary", "force"), f"{summary.force!r} is not among record.signals")

    if summary.kind == "impact" and summary.controller in ctrls:
        # the impact summary needs the switch time: record it even when the config does not list it
        if "t_switch" in ctrls[summary.controller].cls.outputs and (summary.controller, "t_switch") not in good_sigs:
            record = RecordSpec(record.rate, record.signals + ((summary.controller, "t_switch"),))

    problems.raise_if_any()
    return Config(
        path=path,
        run=run,
        solver=solver,
        fmus=fmus,
        controllers=ctrls,
        connections=tuple(conns),
        record=record,
        plot=plot,
        summary=summary,
        raw=data,
        overrides=tuple(overrides or ()),
    )
