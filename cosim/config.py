"""Run configs: TOML text -> validated, frozen run spec.

:func:`load_config` parses the file once, applies ``--set key=value`` overrides, checks every key
against the schema, the FMUs' model descriptions and the controller classes, and collects *every*
problem, each with its TOML key path and ``file:line`` (found by scanning the text: tomllib gives no
line numbers for keys), before raising one :class:`cosim.errors.ConfigError`. Each section is read by
one function; a key's default is the default of its field in the section's frozen dataclass.

The schema (see docs/config.md for the full reference)::

    [run]         start, stop, seed, engine, progress
    [solver]      method (rk4|bdf|radau|lsoda), substeps, max_step, rtol, atol
    [fmus.NAME]   path, kind (ME|CS), parameters_file = "calibrated.toml", parameters = {...}, start = {...}
    [controllers.NAME]  class = "module:Class", rate, jit, parameters = {...}
    [[connections]]     from = "inst.var", to = "inst.var", gain, offset
    [record]      rate, signals = ["inst.var", ...]
    [plot]        file, panels = [["sig", ...], ...]
    [summary]     kind (none, or a summary the controller provides), controller, the summary's signals
    [system]      ssp = "system.ssp": the FMUs, connections and parameter values of an SSP (cosim.ssp.read)
"""

import copy
import math
import re
import warnings
from dataclasses import MISSING, dataclass, field, fields, is_dataclass
from pathlib import Path

from cosim.errors import ParameterError, ScaleWarning
from cosim.fmi.instance import value_dtype
from cosim.paramfile import parameters_file_key
from cosim.ssp.read import ssp_document, with_system
from cosim.tomldoc import did_you_mean as _close
from cosim.tomldoc import (Problems, apply_overrides, format_key, key_paths, parse_overrides, read_toml,
                           toml_value)

__all__ = [
    "load_config",
    "override_items",
    "config_from_data",
    "check_parameter",
    "check_start",
    "parse_overrides",
    "record_columns",
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
    """Run window and options (``[run]``).

    Attributes
    ----------
    start, stop : float
        The run window in s; ``stop`` is required.
    seed : int
        Seed of the run's random draws (noise, scatter), default 0.
    engine : {"compiled", "python"}
        The per-instant loop: "compiled" (numba; falls back to "python" where a controller needs it).
    progress : bool or "auto"
        Show a progress bar ("auto": when the run is long and the terminal is interactive).
    max_steps : float
        The most steps a run may take (controller and record instants plus integrator steps, estimated before
        the run): a bound against a rate or ``substeps`` typed a thousand times too large.
    """

    start: float = 0.0
    stop: float = None
    seed: int = 0
    engine: str = "compiled"  # "compiled" (falls back to "python" where controllers need it) or "python"
    progress: object = "auto"
    max_steps: float = 1e9


@dataclass(frozen=True)
class SolverSpec:
    """How Model-Exchange FMUs are integrated between sample instants (``[solver]``).

    Attributes
    ----------
    method : {"rk4", "bdf", "radau", "lsoda"}
        "rk4": fixed step; otherwise a variable-step implicit scipy method restarted at every instant
        (inputs are held between instants).
    substeps : int
        RK4 steps per interval of the fastest clock (when ``max_step`` is 0).
    max_step : float
        Largest RK4 step in s; 0 means "use ``substeps``".
    rtol, atol : float
        Tolerances of the scipy methods.
    """

    method: str = "rk4"
    substeps: int = 1
    max_step: float = 0.0
    rtol: float = 1e-6
    atol: float = 1e-9


@dataclass(frozen=True)
class FmuSpec:
    """One FMU instance (``[fmus.NAME]``).

    Attributes
    ----------
    name : str
        The instance name connections and recorded signals use.
    path : pathlib.Path
        The FMU file, resolved against the config's folder.
    kind : {"ME", "CS"}
        The FMI interface the master uses.
    parameters, start : dict
        Parameter values and start values by variable name (SI units).
    info : cosim.fmi.ModelInfo
        The FMU's model description, read while validating.
    parameters_file : cosim.paramfile.ParametersFile or None
        The file ``parameters_file`` named (its values are in ``parameters``, under the config's own).
    """

    name: str = None
    path: Path = None
    kind: str = None
    parameters: dict = field(default_factory=dict)
    start: dict = field(default_factory=dict)
    info: object = field(repr=False, compare=False, default=None)
    parameters_file: object = field(repr=False, compare=False, default=None)


@dataclass(frozen=True)
class ControllerSpec:
    """One controller instance (``[controllers.NAME]``).

    Attributes
    ----------
    name : str
        The instance name.
    class_path : str
        ``"module:Class"`` or ``"file.py:Class"`` as written in the config.
    rate : float
        Sample rate in Hz (required).
    parameters : dict
        Values for the class's ``parameters``.
    jit : bool
        Compile the kernel with numba.
    cls : type
        The imported :class:`cosim.controller.Controller` subclass.
    """

    name: str = None
    class_path: str = None
    rate: float = None
    parameters: dict = field(default_factory=dict)
    jit: bool = True
    cls: object = field(repr=False, compare=False, default=None)


@dataclass(frozen=True)
class Connection:
    """One connection ``dst = gain * src + offset`` (``[[connections]]``).

    Attributes
    ----------
    src, dst : tuple of str
        ``(instance, variable)`` pairs.
    gain, offset : float
        The affine map applied on the way.
    round : bool
        Allow a real to drive an Integer, enumeration or Boolean input: the value is rounded to the nearest
        integer (a Boolean is true when that is not 0). Without it such a connection is a config error.
    """

    src: tuple
    dst: tuple
    gain: float = 1.0
    offset: float = 0.0
    round: bool = False


@dataclass(frozen=True)
class RecordSpec:
    """What a run records (``[record]``).

    Attributes
    ----------
    rate : float
        Recording rate in Hz: instants ``start + k / rate`` up to ``stop``.
    signals : tuple of tuple
        ``(instance, variable)`` pairs, written as ``"inst.var"`` columns.
    """

    rate: float = 1000.0
    signals: tuple = ()


@dataclass(frozen=True)
class PlotSpec:
    """The PNG a run draws (``[plot]``).

    Attributes
    ----------
    file : str
        File name in the output folder.
    panels : tuple of tuple of str
        One tuple of recorded column names per panel.
    """

    file: str = "signals.png"
    panels: tuple = ()


@dataclass(frozen=True)
class SummarySpec:
    """The experiment keys of summary.json (``[summary]``).

    Attributes
    ----------
    kind : str
        A summary the controller's class provides (``cls.summaries``), or "none".
    controller : str
        The controller instance whose class provides the summary.
    columns : dict
        Maps each name the plugin reads (its ``signals``, the keys of ``[summary]``, and its
        ``outputs``, the controller's outputs) to the recorded column.
    plugin : type
        ``cls.summaries[kind]`` (None for "none").
    """

    kind: str = "none"
    controller: str = None
    columns: dict = field(default_factory=dict)
    plugin: object = field(repr=False, compare=False, default=None)


@dataclass(frozen=True)
class Config:
    """A validated run config (frozen), one field per TOML section.

    Made by :meth:`load` (a TOML file), :meth:`from_data` (the same tables built in code), :meth:`with_set` (a
    config with some keys changed) or the constructor (the sections as spec objects, or as their tables): each
    checks every key as ``cosim run`` does, with the loader's checks, and raises one
    :class:`~cosim.errors.ConfigError` listing every problem, each at its key instead of a ``file:line``. Built in
    code, a config is its sections as they would be written in ``path`` (which need not exist: FMU paths and
    controller files are relative to its folder), a section left out taking its default and an FMU or controller
    named by its key: ``Config("sys.toml", run=RunSpec(stop=1.0), fmus={"a": FmuSpec(path="A.fmu"), "b":
    FmuSpec(path="B.fmu")}, connections=[Connection(("a", "y"), ("b", "u"))], record=RecordSpec(signals=[("a",
    "y")]))`` (docs/guide/python.md runs one). :func:`dataclasses.replace` of a config is checked again the same way.

    Attributes
    ----------
    path : pathlib.Path
        The config file.
    run : RunSpec
    solver : SolverSpec
    fmus : dict of str to FmuSpec
    controllers : dict of str to ControllerSpec
    connections : tuple of Connection
    record : RecordSpec
    plot : PlotSpec
    summary : SummarySpec
    raw : dict
        The TOML data after overrides.
    overrides : tuple of str
        The ``--set key=value`` overrides applied.
    """

    path: Path = Path("config.toml")
    run: RunSpec = RunSpec()
    solver: SolverSpec = SolverSpec()
    fmus: dict = field(default_factory=dict)
    controllers: dict = field(default_factory=dict)
    connections: tuple = ()
    record: RecordSpec = RecordSpec()
    plot: PlotSpec = PlotSpec()
    summary: SummarySpec = SummarySpec()
    raw: dict = field(repr=False, compare=False, default_factory=dict)
    overrides: tuple = ()

    def __post_init__(self):
        """Check the config built in code with the loader's checks (:func:`config_from_data` of its tables); the
        fields become the checked ones (an FMU's model description read, a controller's class imported)."""
        checked = config_from_data(_tables(self), self.path)
        for f in fields(self):
            if f.name != "overrides":
                object.__setattr__(self, f.name, getattr(checked, f.name))

    @property
    def name(self):
        """The config file's stem (default output folder name)."""
        return self.path.stem

    @classmethod
    def load(cls, path, set=None):
        """Read and check a TOML run config: :func:`load_config`, ``set`` changing keys first.

        Parameters
        ----------
        path : path-like
            The TOML file (FMU paths and controller files relative to its folder), or an SSP archive (``.ssp``):
            unpacked into a temporary folder kept until the process exits, as the config names its files
            (:func:`cosim.run` of the archive's path unpacks it for that run only).
        set : dict or sequence of str, optional
            ``{"run.stop": 0.5}``, or ``["run.stop=0.5"]`` as ``cosim run --set`` takes them.

        Returns
        -------
        Config
            Checked: an invalid one raises a :class:`~cosim.errors.ConfigError` listing every problem at its
            ``file:line`` or ``--set`` key.
        """
        return load_config(path, override_items(set))

    @classmethod
    def from_data(cls, data, path="config.toml"):
        """Check the tables of a run config built in code: :func:`config_from_data`.

        Parameters
        ----------
        data : dict
            ``{"run": {"stop": 1.0}, "fmus": {"plant": {"path": ...}}, "controllers": {...}, "connections": [...],
            "record": {...}, ...}``, the keys of docs/config.md.
        path : path-like, default "config.toml"
            The file the config would be (it need not exist): FMU paths and controller files are relative to
            its folder.

        Returns
        -------
        Config
            Checked: invalid tables raise a :class:`~cosim.errors.ConfigError` listing every problem at its key.
        """
        return config_from_data(data, path)

    def with_set(self, set):
        """This config with some keys changed, checked again as a whole (the config itself is not changed).

        Parameters
        ----------
        set : dict or sequence of str
            ``{"fmus.plant.path": "../fmus2/GripperPlant.fmu", "run.stop": 0.5}``, or ``["run.stop=0.5"]``.

        Returns
        -------
        Config
            Its ``overrides`` are this config's followed by the new ones.

        Raises
        ------
        ConfigError
            A changed key is unknown or invalid, or makes another key invalid.
        """
        items = override_items(set)
        data = copy.deepcopy(self.raw)
        keys = {format_key(k) for k in key_paths(data)}  # the config's own keys, before the new ones
        set_keys = apply_overrides(data, items)
        return _validated(data, Problems(str(self.path), None, set_keys, keys), self.path, self.overrides + items)


def _tables(config):
    """The tables of a config built in code, as its file would hold them; each section a spec or its table. A spec
    the loader made (its FMU's ``info``, its controller's ``cls`` read) holds paths resolved against the working
    folder: they are written absolute, so that a config changed with :func:`dataclasses.replace` is the same."""
    data = {key: _spec_table(getattr(config, key)) for key in ("run", "solver", "plot")}
    data["record"] = _spec_table(config.record)
    if isinstance(config.record, RecordSpec) and config.record.signals:
        data["record"]["signals"] = [_dotted(s) for s in config.record.signals]
    data["fmus"] = {name: _fmu_table(spec) for name, spec in config.fmus.items()}
    data["controllers"] = {name: _controller_table(spec) for name, spec in config.controllers.items()}
    data["connections"] = [_connection_table(c) for c in config.connections]
    data["summary"] = _summary_table(config.summary)
    return data


def _spec_table(spec):
    """A spec's fields as a table, those at their default left out as a file leaves them out (a table, or anything
    else, is itself)."""
    if not is_dataclass(spec):
        return spec
    return {f.name: getattr(spec, f.name) for f in fields(spec) if getattr(spec, f.name) != f.default}


def _dotted(signal):
    """``("inst", "var")`` as ``"inst.var"`` (a string is itself)."""
    return ".".join(signal) if isinstance(signal, tuple) else signal


def _fmu_table(spec):
    if not isinstance(spec, FmuSpec):
        return spec
    made = spec.info is not None
    upstream = spec.parameters_file
    table = {"path": Path(spec.path).absolute() if made else spec.path, "kind": spec.kind,
             "parameters": spec.parameters, "start": spec.start,
             "parameters_file": upstream.path.absolute() if hasattr(upstream, "sha256") else upstream}
    return {key: value for key, value in table.items() if value is not None}


def _controller_table(spec):
    if not isinstance(spec, ControllerSpec):
        return spec
    paths = spec.cls.path_parameters if spec.cls is not None else ()
    parameters = {pn: str(Path(v).absolute()) if pn in paths and isinstance(v, str) and v else v
                  for pn, v in spec.parameters.items()}
    table = {"class": spec.class_path, "rate": spec.rate, "jit": spec.jit, "parameters": parameters}
    return {key: value for key, value in table.items() if value is not None}


def _connection_table(connection):
    if not isinstance(connection, Connection):
        return connection
    return {"from": _dotted(connection.src), "to": _dotted(connection.dst), "gain": connection.gain,
            "offset": connection.offset, "round": connection.round}


def _summary_table(spec):
    """The summary's table: its kind, controller and the columns of its plugin's signals (the outputs it reads
    are not keys)."""
    if not isinstance(spec, SummarySpec):
        return spec
    signals = spec.plugin.signals if spec.plugin is not None else spec.columns
    table = {"kind": spec.kind, "controller": spec.controller}
    table.update({key: column for key, column in spec.columns.items() if key in signals})
    return {key: value for key, value in table.items() if value is not None}


def override_items(set):
    """The ``set`` of a Python call (:func:`cosim.run`, :func:`cosim.calibrate`, ...) as ``--set`` items.

    Parameters
    ----------
    set : dict or str or sequence of str or None
        Keys to values (``{"run.stop": 0.5}``), or ``key=value`` items.

    Returns
    -------
    tuple of str
        ``key=value`` items, each value written as TOML.
    """
    if set is None:
        return ()
    if isinstance(set, str):
        return (set,)
    if isinstance(set, dict):
        return tuple(f"{key}={toml_value(_plain(value))}" for key, value in set.items())
    return tuple(set)


# ----------------------------------------------------------------------------------------------
# schema helpers
# ----------------------------------------------------------------------------------------------
_TOP = ("run", "solver", "fmus", "controllers", "connections", "record", "plot", "summary", "system")
_FMU = ("path", "kind", "parameters_file", "parameters", "start")
_CTRL = ("class", "rate", "jit", "parameters")
_CONN = ("from", "to", "gain", "offset", "round")
_RESERVED_COLUMNS = ("time",)
_SUMMARY = ("kind", "controller")  # and the signals of the chosen summary
_ENGINES = ("compiled", "python")
_METHODS = ("rk4", "bdf", "radau", "lsoda")


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


class _Section:
    """One table read against a spec dataclass: unknown keys are problems, a missing key takes its field's
    default (a default of None: the key is required)."""

    def __init__(self, table, path, spec, problems, allowed=None):
        self.table, self.path, self.problems = table, path, problems
        self.defaults = {f.name: f.default for f in fields(spec) if f.default is not MISSING}
        _unknown(table, allowed or tuple(self.defaults), problems, path)

    def number(self, key, positive=False, nonneg=False, integer=False):
        """``table[key]`` checked as a finite number (the default, after a problem, when it is not)."""
        default = self.defaults.get(key)
        v = self.table.get(key, default)
        where = self.path + (key,)
        if v is None:
            self.problems.add(where, "is required")
            return default
        if integer:
            if isinstance(v, bool) or not isinstance(v, int):
                self.problems.add(where, f"must be an integer; got {v!r}")
                return default
        elif not _is_num(v):
            self.problems.add(where, f"must be a finite number; got {v!r}")
            return default
        if positive and not v > 0:
            self.problems.add(where, f"must be > 0; got {v!r}")
            return default
        if nonneg and v < 0:
            self.problems.add(where, f"must be >= 0; got {v!r}")
            return default
        return v

    def choice(self, key, choices):
        """``table[key]`` checked against ``choices`` (the default, after a problem, when it is not one)."""
        v = self.table.get(key, self.defaults[key])
        if v not in choices:
            self.problems.add(self.path + (key,), f"must be one of {', '.join(repr(c) for c in choices)}; "
                                                  f"got {v!r}{_close(str(v), choices)}")
            return self.defaults[key]
        return v


def _signal(text, problems, path):
    if not isinstance(text, str) or "." not in text:
        problems.add(path, f"must be 'instance.variable'; got {text!r}")
        return None
    inst, _, var = text.partition(".")
    return inst, var


# ----------------------------------------------------------------------------------------------
# one function per section
# ----------------------------------------------------------------------------------------------
def _run(data, problems):
    s = _Section(_table(data, "run", problems, ()), ("run",), RunSpec, problems)
    start = s.number("start")
    stop = s.number("stop")
    if _is_num(start) and _is_num(stop) and stop <= start:
        problems.add(("run", "stop"), f"must be > run.start ({start}); got {stop}")
    seed = s.number("seed", integer=True, nonneg=True)
    engine = s.choice("engine", _ENGINES)
    progress = s.table.get("progress", s.defaults["progress"])
    if progress not in (True, False, "auto"):
        problems.add(("run", "progress"), f"must be true, false or \"auto\"; got {progress!r}")
        progress = s.defaults["progress"]
    max_steps = s.number("max_steps", positive=True)
    return RunSpec(float(start), None if stop is None else float(stop), int(seed), engine, progress,
                   float(max_steps))


def _solver(data, problems):
    s = _Section(_table(data, "solver", problems, ()), ("solver",), SolverSpec, problems)
    return SolverSpec(
        method=s.choice("method", _METHODS),
        substeps=s.number("substeps", positive=True, integer=True),
        max_step=float(s.number("max_step", nonneg=True)),
        rtol=float(s.number("rtol", positive=True)),
        atol=float(s.number("atol", positive=True)),
    )


def _value_type(info, var, value, problems, where):
    """A parameter or start value must fit the variable's type: a number for a real, an integer (or an integral
    float) for an Integer or enumeration, true/false for a Boolean."""
    dtype = value_dtype(info.fmi_version, var.type)
    kind = None if dtype is None else dtype.kind
    if kind == "b":
        ok = isinstance(value, bool)
    elif kind in ("i", "u"):
        ok = _is_num(value) and float(value).is_integer()
    else:
        ok = _is_num(value) and kind is not None
    if not ok:
        want = {"b": "true or false", "i": "an integer", "u": "an integer"}.get(kind, "a number")
        problems.add(where, f"{var.name!r} is {var.type}: the value must be {want}; got {value!r}"
                     if kind is not None else f"{var.name!r} is {var.type}: it cannot be set from a config")
    return ok


def _in_range(file, var, value, problems, where):
    """A parameter's value must lie in the range its FMU declares (the Modelica ``min``/``max``, inclusive)."""
    lo = -math.inf if var.min is None else var.min
    hi = math.inf if var.max is None else var.max
    if lo <= value <= hi or isinstance(value, bool):
        return
    unit = f" {var.unit}" if var.unit not in ("", "1") else " (no unit: a ratio)" if var.unit == "1" else ""
    percent = f"; a percentage? {value:g} % is {value / 100:g}" if var.unit == "1" and hi <= 1 < value <= 100 else ""
    problems.add(where, f"{value!r} is outside the range {file.name} declares for {var.name}: "
                        f"[{lo:g}, {hi:g}]{unit}{percent}")


def check_parameter(info, file, name, value, problems, where):
    """Add to ``problems`` what is wrong with setting a parameter of an FMU to a value: no such parameter (with
    "did you mean"), not settable, of the wrong type, or outside the range the FMU declares (with its unit). A run
    config's ``fmus.NAME.parameters``, a campaign coating's ``parameters`` and a campaign's parameters file are
    checked with it.

    Parameters
    ----------
    info : cosim.fmi.ModelInfo
        The FMU's model description.
    file : pathlib.Path
        The FMU (its name is in the messages).
    name : str
        The parameter.
    value : object
        The value given (a number, or a bool for a Boolean parameter).
    problems : cosim.tomldoc.Problems
        Where the problems go.
    where : tuple of str
        The key path the value was given at (its file:line or ``--set`` item in the message).
    """
    var = info.variables.get(name)
    if var is None:
        names = [v.name for v in info.variables.values() if v.causality == "parameter"]
        problems.add(where, f"{file.name} has no parameter {name!r}{_close(name, names)}")
    elif var.causality not in ("parameter",) or var.variability == "constant":
        problems.add(where, f"{name!r} is a {var.variability} {var.causality}, not a settable parameter")
    elif _value_type(info, var, value, problems, where):
        _in_range(file, var, value, problems, where)


def check_start(info, file, name, value, problems, where):
    """Add to ``problems`` what is wrong with giving a variable of an FMU a start value: no such variable (with
    "did you mean"), one the FMU calculates (an output, a calculated parameter, a local without a start value, a
    constant), or a value of the wrong type. A run config's ``fmus.NAME.start`` and ``cosim simulate --set`` are
    checked with it.

    Parameters
    ----------
    info : cosim.fmi.ModelInfo
        What the FMU declares.
    file : pathlib.Path
        The FMU file, named in the messages.
    name : str
        The variable given a start value.
    value : object
        Its start value: a number, or true/false for a Boolean.
    problems : cosim.tomldoc.Problems
        The collector the problems are added to.
    where : tuple of str
        The key path of the start value (the messages say its file:line or ``--set`` item).
    """
    var = info.variables.get(name)
    if var is None:
        problems.add(where, f"{file.name} has no variable {name!r}{_close(name, info.variables)}")
    elif var.causality in ("output", "independent", "calculatedParameter") or var.variability == "constant":
        problems.add(where, f"{name!r} is {'an' if var.causality[0] in 'aeiou' else 'a'} {var.causality} (the FMU "
                            "calculates it); its start value cannot be set")
    elif var.causality == "local" and var.start is None:
        problems.add(where, f"{name!r} is a local variable the FMU calculates (it has no start value); it cannot "
                            "be set")
    else:
        _value_type(info, var, value, problems, where)


def _fmu_values(info, file, params, starts, problems, p):
    """Check parameter and start values against the model description ``info`` of ``file``."""
    for pn, pv in params.items():
        check_parameter(info, file, pn, pv, problems, p + ("parameters", pn))
    for sn, sv in starts.items():
        check_start(info, file, sn, sv, problems, p + ("start", sn))


def _fmu(name, t, base_dir, problems):
    """One ``[fmus.NAME]`` table -> FmuSpec, or None when its FMU cannot be read."""
    from cosim.errors import FmuFileError
    from cosim.fmi import read_model_info

    p = ("fmus", name)
    if not _NAME.match(name):
        problems.add(p, f"instance name {name!r} must be an identifier (letters, digits, _)")
    if not isinstance(t, dict):
        problems.add(p, "must be a table")
        return None
    _unknown(t, _FMU, problems, p)
    fpath = t.get("path")
    if not isinstance(fpath, str):
        problems.add(p + ("path",), "is required: the .fmu file (relative to the config's folder)")
        return None
    full = Path(fpath) if Path(fpath).is_absolute() else (base_dir / fpath)
    try:
        info = read_model_info(full)
    except FmuFileError as err:
        problems.add(p + ("path",), str(err), cause=True)
        return None
    kind = t.get("kind", "ME" if "ME" in info.kinds else "CS")
    if kind not in info.kinds:
        problems.add(p + ("kind",), f"{full.name} provides {', '.join(info.kinds)}, not {kind!r}")
    upstream = parameters_file_key(t, p, base_dir, problems)
    params = {**(upstream.values if upstream else {}), **_table(t, "parameters", problems, p)}
    starts = _table(t, "start", problems, p)
    _fmu_values(info, full, params, starts, problems, p)
    return FmuSpec(name, full, kind, dict(params), dict(starts), info, upstream)


def _fmus(fmus_t, base_dir, problems):
    if not fmus_t:
        problems.add(("fmus",), "at least one FMU is required: [fmus.plant] path = \"...fmu\"")
    specs = {name: _fmu(name, t, base_dir, problems) for name, t in fmus_t.items()}
    return {name: spec for name, spec in specs.items() if spec is not None}


def _controller(name, t, fmus_t, base_dir, problems):
    """One ``[controllers.NAME]`` table -> ControllerSpec, or None when its class cannot be loaded."""
    from cosim.plugins import load_controller_class

    p = ("controllers", name)
    if not _NAME.match(name):
        problems.add(p, f"instance name {name!r} must be an identifier (letters, digits, _)")
    if name in fmus_t:
        problems.add(p, f"name {name!r} is already an FMU instance")
    if not isinstance(t, dict):
        problems.add(p, "must be a table")
        return None
    s = _Section(t, p, ControllerSpec, problems, allowed=_CTRL)
    rate = s.number("rate", positive=True)
    jit = t.get("jit", s.defaults["jit"])
    if not isinstance(jit, bool):
        problems.add(p + ("jit",), f"must be true or false; got {jit!r}")
    params = dict(_table(t, "parameters", problems, p))
    cpath = t.get("class")
    if not isinstance(cpath, str):
        problems.add(p + ("class",), "is required: \"module:Class\" or \"file.py:Class\"")
        return None
    try:
        cls = load_controller_class(cpath, base_dir)
    except ImportError as err:
        problems.add(p + ("class",), str(err), cause=True)
        return None
    for pn in cls.path_parameters:
        if isinstance(params.get(pn), str) and params[pn]:
            params[pn] = str(base_dir / params[pn])
    for pn in params:
        if pn not in cls.parameters:
            problems.add(p + ("parameters", pn), f"{cls.__name__} has no parameter {pn!r}{_close(pn, cls.parameters)}")
    if rate is not None and all(pn in cls.parameters for pn in params):
        try:
            cls(rate=rate, jit=False, **params)
        except ParameterError as err:  # the key, what it must be and what it is
            key = ("parameters", err.key) if err.key in params else ("rate",) if err.key == "rate" else ("parameters",)
            problems.add(p + key, str(err))
        except Exception as err:  # the user's constructor may raise anything: name the controller and the values
            given = ", ".join(f"{k}={v!r}" for k, v in params.items()) or "no parameters"
            problems.add(p + ("parameters",), f"{cls.__name__}(rate={rate!r}, {given}) raised "
                                              f"{type(err).__name__}: {err}")
    return ControllerSpec(name, cpath, rate, dict(params), bool(jit), cls)


def _controllers(ctrl_t, fmus_t, base_dir, problems):
    specs = {name: _controller(name, t, fmus_t, base_dir, problems) for name, t in ctrl_t.items()}
    return {name: spec for name, spec in specs.items() if spec is not None}


class _Instances:
    """The FMU and controller instances of a config, to check the signals that connections and records name.

    ``declared`` also holds the names whose table had a problem (already reported): they are not reported again.
    """

    def __init__(self, fmus, ctrls, declared):
        self.fmus, self.ctrls, self.declared = fmus, ctrls, declared
        self.known = set(fmus) | set(ctrls)
        self.failed = declared - self.known  # their problem is the cause; what names them is not checked

    def _routable(self, inst, causality):
        info = self.fmus[inst].info
        return [v.name for v in info.variables.values()
                if v.causality == causality and value_dtype(info.fmi_version, v.type) is not None]

    def outputs(self, inst):
        if inst in self.fmus:
            return self._routable(inst, "output")
        return list(self.ctrls[inst].cls.outputs)

    def inputs(self, inst):
        if inst in self.fmus:
            return self._routable(inst, "input")
        return list(self.ctrls[inst].cls.inputs)

    def kind(self, sig):
        """'f' (real), 'i' (integer or enumeration) or 'b' (Boolean): how a signal's values convert."""
        inst, var = sig
        if inst not in self.fmus:
            return "f"
        info = self.fmus[inst].info
        k = value_dtype(info.fmi_version, info.variables[var].type).kind
        return "i" if k == "u" else k

    def type_name(self, sig):
        inst, var = sig
        return self.fmus[inst].info.variables[var].type if inst in self.fmus else "Float64 (a controller signal)"

    def end(self, text, cpath, direction, problems):
        """The (instance, variable) of a connection's ``direction`` ("from"/"to") end, or None after a problem."""
        sig = _signal(text, problems, cpath)
        if sig is None:
            return None
        inst, var = sig
        if inst not in self.known:
            if inst not in self.declared:
                problems.add(cpath, f"no instance {inst!r}{_close(inst, self.known)} "
                                    f"(instances: {', '.join(sorted(self.known))})")
            return None
        good = self.outputs(inst) if direction == "from" else self.inputs(inst)
        if var in good:
            return inst, var
        want, other_kind = ("an output", "an input") if direction == "from" else ("an input", "an output")
        other = self.inputs(inst) if direction == "from" else self.outputs(inst)
        if inst in self.fmus and var in self.fmus[inst].info.variables:
            v = self.fmus[inst].info.variables[var]
            problems.add(cpath, f"{text} has causality {v.causality!r}; a connection's {direction!r} end must be "
                                f"{want}{_close(var, good)}")
        elif var in other:
            problems.add(cpath, f"{text} is {other_kind}; a connection's {direction!r} end must be {want}")
        else:
            problems.add(cpath, f"{inst} has no {'output' if direction == 'from' else 'input'} {var!r}{_close(var, good)}")
        return None

    def recorded(self, text, sp, problems):
        """The (instance, variable) of a recorded signal, or None after a problem."""
        sig = _signal(text, problems, sp)
        if sig is None:
            return None
        inst, var = sig
        if inst in self.fmus:
            info = self.fmus[inst].info
            v = info.variables.get(var)
            if v is None:
                problems.add(sp, f"{self.fmus[inst].path.name} has no variable {var!r}{_close(var, info.variables)}")
                return None
            if value_dtype(info.fmi_version, v.type) is None:
                problems.add(sp, f"{text} is a {v.type} variable; Real/Float, Integer, enumeration and Boolean "
                                 "variables can be recorded")
                return None
        elif inst in self.ctrls:
            names = list(self.ctrls[inst].cls.inputs) + list(self.ctrls[inst].cls.outputs)
            if var not in names:
                problems.add(sp, f"{inst} has no signal {var!r}{_close(var, names)}")
                return None
        else:
            if inst not in self.declared:
                problems.add(sp, f"no instance {inst!r}{_close(inst, self.known)}")
            return None
        return inst, var


def _connections(data, instances, problems):
    ctab = data.get("connections", [])
    if not isinstance(ctab, list):
        problems.add(("connections",), "must be an array of tables: [[connections]]")
        ctab = []
    conns, seen_dst = [], {}
    for i, c in enumerate(ctab):
        p = ("connections", i)
        if not isinstance(c, dict):
            problems.add(p, "must be a table with from/to")
            continue
        s = _Section(c, p, Connection, problems, allowed=_CONN)
        if "from" not in c or "to" not in c:
            problems.add(p, "needs both 'from' and 'to'")
            continue
        src = instances.end(c["from"], p + ("from",), "from", problems)
        dst = instances.end(c["to"], p + ("to",), "to", problems)
        gain = s.number("gain")
        offset = s.number("offset")
        if dst is not None:
            if dst in seen_dst:
                problems.add(p + ("to",), f"{c['to']} is already driven by connections[{seen_dst[dst]}]")
            seen_dst[dst] = i
        rounding = c.get("round", False)
        if not isinstance(rounding, bool):
            problems.add(p + ("round",), f"must be true or false; got {rounding!r}")
            rounding = False
        if src is not None and dst is not None:
            if src[0] == dst[0]:
                problems.add(p, f"connects {src[0]} to itself")
            _conversion(instances, src, dst, gain, offset, rounding, problems, p)
            conns.append(Connection(src, dst, float(gain), float(offset), rounding))
    return tuple(conns)


def _conversion(instances, src, dst, gain, offset, rounding, problems, p):
    """The type rules of a connection (docs/master.md "Variable types"): any value drives a real input
    (Boolean as 0/1); an Integer input takes Integer or Boolean values with an integer gain and offset; a
    Boolean input takes a Boolean with gain 1 and offset 0; anything else needs ``round = true``."""
    sk, dk = instances.kind(src), instances.kind(dst)
    if dk == "f" or rounding:
        return
    where = f"{'.'.join(src)} ({instances.type_name(src)}) -> {'.'.join(dst)} ({instances.type_name(dst)})"
    if dk == "i" and sk in "ib":
        if _is_num(gain) and _is_num(offset) and (gain != int(gain) or offset != int(offset)):
            problems.add(p, f"{where}: an Integer input needs an integer gain and offset; got gain={gain}, "
                            f"offset={offset} (or set round = true)")
    elif dk == "b" and sk == "b":
        if (gain, offset) != (1, 0):
            problems.add(p, f"{where}: a Boolean drives a Boolean input with gain 1 and offset 0 only; "
                            f"got gain={gain}, offset={offset}")
    else:
        problems.add(p + ("to",), f"{where}: a real value does not drive an Integer or Boolean input without "
                                  "round = true (nearest integer; a Boolean is true when it is not 0)"
                     if sk == "f" else f"{where}: an Integer does not drive a Boolean input without round = true")


def _record(data, instances, problems):
    s = _Section(_table(data, "record", problems, ()), ("record",), RecordSpec, problems)
    rate = s.number("rate", positive=True)
    sigs = s.table.get("signals", list(s.defaults["signals"]))
    if not isinstance(sigs, list):
        problems.add(("record", "signals"), "must be a list of 'instance.variable' strings")
        sigs = []
    if not sigs and "signals" in s.table:
        problems.add(("record", "signals"), "is empty: list at least one 'instance.variable' to record")
    good, pending = [], []
    for i, text in enumerate(sigs):
        if isinstance(text, str) and text.partition(".")[0] in instances.failed:
            pending.append(_signal(text, problems, ("record", "signals", i)))
            continue
        sig = instances.recorded(text, ("record", "signals", i), problems)
        if sig is not None and sig[0] in instances.fmus and sig[1] in _RESERVED_COLUMNS:
            problems.add(("record", "signals", i), f"{text}: the column {sig[1]!r} is reserved (the results' "
                                                   "time column); this variable cannot be recorded under its name")
        elif sig is not None and sig not in good:
            good.append(sig)
    return RecordSpec(float(rate), tuple(good)), tuple(pending)


def record_columns(signals, fmu_names):
    """The recorded columns' names: a variable recorded from one FMU only is named by itself (``F_g``),
    otherwise ``instance.variable``; a controller signal always ``instance.variable``.

    Parameters
    ----------
    signals : sequence of tuple
        ``(instance, variable)`` pairs, as ``RecordSpec.signals``.
    fmu_names : collection of str
        The FMU instances (the other instances are controllers).

    Returns
    -------
    dict of str to tuple
        Column name -> ``(instance, variable)``, in the order of ``signals``.
    """
    counts = {}
    for inst, var in signals:
        if inst in fmu_names:
            counts[var] = counts.get(var, 0) + 1
    return {(var if inst in fmu_names and counts[var] == 1 else f"{inst}.{var}"): (inst, var)
            for inst, var in signals}


def _plot(data, record, pending, fmu_names, problems):
    """The ``[plot]`` table -> PlotSpec; a panel may name a column of ``pending`` (a signal of an instance whose
    table had a problem, already reported) without a problem of its own."""
    s = _Section(_table(data, "plot", problems, ()), ("plot",), PlotSpec, problems)
    pfile = s.table.get("file", s.defaults["file"])
    if not isinstance(pfile, str) or not pfile.endswith(".png") or "/" in pfile:
        problems.add(("plot", "file"), f"must be a file name ending in .png; got {pfile!r}")
        pfile = s.defaults["file"]
    panels = s.table.get("panels", list(s.defaults["panels"]))
    if not isinstance(panels, list) or not all(isinstance(x, list) and all(isinstance(y, str) for y in x) for x in panels):
        problems.add(("plot", "panels"), "must be a list of lists of recorded column names")
        panels = []
    columns = record_columns(record.signals + pending, fmu_names)
    for i, panel in enumerate(panels):
        for j, name in enumerate(panel):
            if name not in columns:
                problems.add(("plot", "panels", i, j), f"{name!r} is not a recorded column{_close(name, columns)} "
                                                       f"(recorded: {', '.join(columns) or 'none'})")
    return PlotSpec(pfile, tuple(tuple(x) for x in panels))


def _summary_plugins(kind, name, instances, problems):
    """The summaries the named controller's class provides (``Class.summaries``); None when they cannot be
    told (a problem is reported when the summary needs them: ``kind`` is not "none")."""
    if name in instances.ctrls:
        return instances.ctrls[name].cls.summaries
    if kind != "none":
        if name is None:
            problems.add(("summary", "controller"), "is required: the controller whose class provides the summary")
        elif name not in instances.declared:
            problems.add(("summary", "controller"), f"no controller {name!r}{_close(name, instances.ctrls)}")
    return {} if name is None and kind == "none" else None


def _summary(data, instances, record, pending, problems):
    """The ``[summary]`` table -> SummarySpec, and the record with the controller outputs the summary reads; a
    column of ``pending`` (see :func:`_plot`) is taken as recorded."""
    t = _table(data, "summary", problems, ())
    kind = t.get("kind", SummarySpec.kind)
    name = t.get("controller", SummarySpec.controller)
    for key, value in (("kind", kind), ("controller", name)):
        if value is not None and not isinstance(value, str):
            problems.add(("summary", key), f"must be a string; got {value!r}")
            return SummarySpec(), record
    plugins = _summary_plugins(kind, name, instances, problems)
    plugin = None
    if plugins is not None and kind != "none":
        plugin = plugins.get(kind)
        if plugin is None:
            cls = instances.ctrls[name].cls.__name__
            provided = ", ".join(repr(k) for k in ("none", *plugins))
            problems.add(("summary", "kind"), f"must be one of {provided} (the summaries {cls} provides); "
                                              f"got {kind!r}{_close(str(kind), plugins)}")
            plugins = None
    if plugins is not None:
        # "none" keeps the keys of any summary of the controller, so that --set summary.kind=none turns one off
        chosen = [plugin] if plugin is not None else list(plugins.values())
        _unknown(t, _SUMMARY + tuple(dict.fromkeys(k for p in chosen for k in p.signals)), problems, ("summary",))
    if plugin is None:
        return SummarySpec(kind, name), record
    columns = {}
    for key in plugin.signals:
        column = t.get(key)
        if column is None:
            problems.add(("summary", key), f"is required: the recorded column the {kind!r} summary reads")
        elif not isinstance(column, str):
            problems.add(("summary", key), f"must be a recorded column name; got {column!r}")
        elif not any(var == column for _, var in record.signals + pending):
            problems.add(("summary", key), f"{column!r} is not among record.signals")
        columns[key] = column
    outputs = instances.ctrls[name].cls.outputs
    for out in plugin.outputs:
        columns[out] = f"{name}.{out}"
        # the summary reads the controller's output: record it even when the config does not list it
        if out in outputs and (name, out) not in record.signals:
            record = RecordSpec(record.rate, record.signals + ((name, out),))
    return SummarySpec(kind, name, columns, plugin), record


def _available_memory():
    """Bytes of memory available to a new allocation (psutil: free plus reclaimable cache)."""
    import psutil

    return psutil.virtual_memory().available


def _bounds(run, solver, fmus, ctrls, record, problems):
    """The run's size estimated before anything is allocated: the steps it takes against ``run.max_steps``, the
    memory its recording needs against the memory available. Each problem names the key to change."""
    span = run.stop - run.start
    if span * record.rate < 1:
        problems.add(("record", "rate"), f"must be >= 1 / (run.stop - run.start) = {1 / span:.6g} Hz, or only the "
                                         f"start instant is recorded; got {record.rate:g}")
    rates = {("controllers", n, "rate"): c.rate for n, c in ctrls.items()}
    rates[("record", "rate")] = record.rate
    instants = sum(span * r + 1 for r in rates.values())
    fastest = max(rates, key=rates.get)
    h = solver.max_step if solver.max_step > 0 else 1.0 / rates[fastest] / solver.substeps
    integrator = span / h if any(f.kind == "ME" for f in fmus.values()) else 0.0
    if instants + integrator > run.max_steps:
        key = fastest if instants >= integrator else ("solver", "max_step" if solver.max_step > 0 else "substeps")
        change = "raise" if key[-1] == "max_step" else "lower"
        problems.add(key, f"the run would take about {instants + integrator:.3g} steps ({instants:.3g} controller "
                          f"and record instants, {integrator:.3g} integrator steps over {span:g} s), more than "
                          f"run.max_steps = {run.max_steps:.3g}: {change} {format_key(key)}, shorten run.stop, or "
                          "raise run.max_steps")
    rows = span * record.rate + 1
    need = 3 * rows * (len(record.signals) + 1) * 8  # float64 rows, copied once to a table and once to the file
    available = _available_memory()
    if need > available:
        problems.add(("record", "rate"), f"recording {rows:.3g} rows of {len(record.signals) + 1} columns "
                                         f"({record.rate:g} Hz over {span:g} s) needs about {need / 2**30:.3g} GiB "
                                         f"at its peak; {available / 2**30:.3g} GiB of memory is available: lower "
                                         "record.rate, record fewer signals, or shorten run.stop")


def _settable_keys(fmus, ctrls):
    """The keys a config may have beyond those it has (dotted), for "did you mean" on a made-up ``--set`` key: the
    sections' keys, each FMU's parameters and each controller's."""
    keys = {f"{section}.{f.name}" for section, spec in (("run", RunSpec), ("solver", SolverSpec),
                                                          ("record", RecordSpec), ("plot", PlotSpec))
            for f in fields(spec)}
    for name, spec in fmus.items():
        keys |= {f"fmus.{name}.{k}" for k in _FMU}
        keys |= {f"fmus.{name}.parameters.{v.name}" for v in spec.info.variables.values()
                 if v.causality == "parameter" and v.variability != "constant"}
    for name, spec in ctrls.items():
        keys |= {f"controllers.{name}.{k}" for k in _CTRL}
        keys |= {f"controllers.{name}.parameters.{pn}" for pn in spec.cls.parameters}
    return keys


_FAST = 100  # a controller period this many times shorter than the plant's step: a factor 1000 typed by mistake?
# Steps of a run's fastest controller: 3 times the longest shipped run (examples/gripper_static.toml, 250 s at
# 26.6 kHz, 6.65e6 steps). A run length in milliseconds typed as seconds is 1000 times its meaning: the shipped
# impact's 1.9 s typed as 1900 is 5.05e7 steps, above; speed_pi's 0.3 s (7980 steps) typed as 300 is not.
_LONG = 2e7


def _time_scales(run, fmus, ctrls):
    """Warn (:class:`ScaleWarning`) of a rate or a run length far from the plant's time scale, the step its FMUs
    declare (``ModelInfo.step``): a controller period more than ``_FAST`` times shorter (the shipped configs run
    theirs at periods of 1/20 of it and longer), a run shorter than that step, a run of more than ``_LONG`` steps of
    its fastest controller (``(stop - start) * rate``; the longest shipped run takes a third of that), unless that
    controller's rate is warned of (the likely typo then). The run goes on: a fast controller on a slow plant, or a
    long run, can be meant."""
    span = run.stop - run.start
    steps = {name: spec.info.step for name, spec in fmus.items() if spec.info.step is not None}
    messages, fast = [], set()
    if steps:
        name = min(steps, key=steps.get)
        h, file = steps[name], fmus[name].path.name
        for cn, c in ctrls.items():
            if c.rate * h > _FAST:
                fast.add(cn)
                messages.append(f"controllers.{cn}.rate = {c.rate:g} Hz: a period of {1 / c.rate:.3g} s, "
                                f"{c.rate * h:.3g} times shorter than the step {file} declares ({h:.3g} s); the "
                                f"shipped configs run controllers at periods of 1/20 of their plant's step or longer "
                                f"(a factor 1000 typed by mistake? {c.rate / 1000:g} Hz)")
        if span < h:
            messages.append(f"run.stop - run.start = {span:g} s is shorter than the step {file} declares ({h:.3g} s)")
    fastest = max(ctrls, key=lambda cn: ctrls[cn].rate, default=None)
    if fastest is not None and fastest not in fast and span * ctrls[fastest].rate > _LONG:
        messages.append(_long_run(run, fastest, ctrls[fastest].rate))
    for message in messages:
        warnings.warn(message, ScaleWarning, stacklevel=3)


def _long_run(run, name, rate):
    """The warning of a run far longer, in steps of its fastest controller, than any shipped run: what the run
    length probably meant (milliseconds typed as seconds)."""
    span = run.stop - run.start
    return (f"run.stop = {run.stop:g} s: a run of {span:g} s is {span * rate:.3g} steps of controllers.{name} at "
            f"{rate:g} Hz, more than {_LONG:.3g} (the longest shipped run, examples/gripper_static.toml, takes "
            f"6.65e+06); milliseconds typed as seconds? run.stop = {run.start + span / 1000:g} is a run of "
            f"{span / 1000:g} s")


# ----------------------------------------------------------------------------------------------
# load
# ----------------------------------------------------------------------------------------------
def load_config(path, overrides=()):
    """Read, override and validate a run config.

    Parameters
    ----------
    path : path-like
        The TOML file (relative FMU paths and controller files are resolved against its folder), or an SSP archive
        (``.ssp``, read by :func:`cosim.ssp.read.ssp_document`).
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
    path = Path(path)
    if path.suffix == ".ssp":  # an SSP archive run as it is
        data, problems = ssp_document(path, overrides)
    else:
        data, problems = read_toml(path, overrides, what="config")
    return _validated(data, problems, path, tuple(overrides or ()))


def config_from_data(data, path):
    """A run config built in code: ``data`` holds the tables a TOML run config holds (``run``, ``fmus``,
    ``controllers``, ``connections``, ``record``, ...) and is validated as :func:`load_config` validates a file.

    Parameters
    ----------
    data : dict
        The config's tables, as :func:`tomllib.loads` would return them.
    path : path-like
        Where the config would be: relative FMU paths and controller files are resolved against its folder, and
        it names the config in messages and results (the file need not exist; :func:`cosim.tomldoc.toml_text`
        writes ``data`` there for ``cosim run`` to repeat the run).

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        Any key is unknown or invalid; the message lists every problem with its key path.
    """
    path = Path(path)
    return _validated(_plain(data), Problems(path, None, {}), path, ())


def _plain(value):
    """``value`` with numpy scalars as Python numbers and paths as strings: what a TOML file would have given."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, Path):
        return value.as_posix()
    return value.item() if hasattr(value, "item") and type(value).__module__ == "numpy" else value


def _validated(data, problems, path, overrides):
    """The Config of ``data`` (a config file's tables) or a ConfigError listing every problem."""
    base_dir = path.parent
    data = with_system(data, base_dir, problems)  # [system] ssp = "file.ssp": the SSP's tables under the config's
    _unknown(data, _TOP, problems, ())
    run = _run(data, problems)
    solver = _solver(data, problems)
    fmus_t = _table(data, "fmus", problems, ())
    fmus = _fmus(fmus_t, base_dir, problems)
    ctrl_t = _table(data, "controllers", problems, ())
    ctrls = _controllers(ctrl_t, fmus_t, base_dir, problems)
    instances = _Instances(fmus, ctrls, set(fmus_t) | set(ctrl_t))
    connections = _connections(data, instances, problems)
    record, pending = _record(data, instances, problems)
    summary, record = _summary(data, instances, record, pending, problems)
    plot = _plot(data, record, pending, set(fmus_t), problems)
    problems.keys |= _settable_keys(fmus, ctrls)
    if not problems.items:
        _bounds(run, solver, fmus, ctrls, record, problems)
    problems.raise_if_any()
    _time_scales(run, fmus, ctrls)
    return _made(dict(path=path, run=run, solver=solver, fmus=fmus, controllers=ctrls, connections=connections,
                      record=record, plot=plot, summary=summary, raw=data, overrides=overrides))


def _made(values):
    """The Config of these field values, not checked by :meth:`Config.__post_init__` (they are checked already)."""
    config = object.__new__(Config)
    for name, value in values.items():
        object.__setattr__(config, name, value)
    return config


def replace_unchecked(config, **changes):
    """``config`` with some fields changed and not checked again, where :func:`dataclasses.replace` checks it: for
    the variants of a checked config the master runs (a calibration's or a campaign's values, checked where they
    are given), where a check per run would cost more than the run and refuse the values an optimizer tries.

    Parameters
    ----------
    config : Config
        A checked config.
    **changes
        New values of its fields, by name.

    Returns
    -------
    Config
    """
    return _made({**{f.name: getattr(config, f.name) for f in fields(config)}, **changes})
