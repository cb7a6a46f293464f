"""The run driver: set up a config's instances, run them with a per-instant loop, assemble the result.

:class:`Engine` does what every run does whatever loop runs the instants: the signal buffer and its
:class:`~cosim.master.layout.Layout`, the time base, the controllers (their ``u``/``y`` arrays are
views of the buffer), the :class:`~cosim.master.recorder.Recorder`, then per run a fresh
:class:`~cosim.master.plant.PlantSystem`, the progress bar, Ctrl-C (the run stops with what was
recorded) and freeing the FMUs on any exit. The per-instant loop is the only swappable part:
:class:`~cosim.master.loop.PythonLoop` or the numba kernel :class:`~cosim.master.compiled.CompiledLoop`.

:func:`engine_for` picks the loop of a config: ``run.engine = "compiled"`` (the default) runs the
compiled loop when :func:`~cosim.master.compiled.compiled_problem` finds nothing against it (FMU
variables of every routable type are carried); otherwise the run falls back to the Python loop with a
one-line explanation saying what it costs (:data:`PYTHON_COST`) and why: a warning naming the construct when
numba cannot compile a kernel, a note in the result (``RunResult.engine_note``, summary.json, the line
``cosim run`` prints) when the config itself asks for Python (``jit = false``, a controller overriding
``step`` in Python, an implicit solver).
"""

import signal
import time as _time
import traceback
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from cosim.config import replace_unchecked
from cosim.errors import ConfigError, EngineFallbackWarning, NonFiniteError, SimulationTerminated
from cosim.fmi import FmuInstance
from cosim.jit import signals_deferred
from cosim.master.compiled import CompiledLoop, compiled_problem
from cosim.master.layout import Layout
from cosim.master.loop import PythonLoop
from cosim.master.plant import PlantSystem
from cosim.master.recorder import Recorder
from cosim.master.schedule import TimeBase

__all__ = ["RunResult", "Engine", "Interrupt", "engine_for"]

CHUNK = 4096  # instants per loop call: between calls the progress bar moves (about 1-5 ms of the compiled loop)


@dataclass
class RunResult:
    """What a run produced.

    Attributes
    ----------
    data : numpy.ndarray
        Structured array, field ``time`` (s) first, then one float64 field per recorded column.
    units : dict of str to str
        Unit of each column.
    calls : dict of str to int
        Number of ``step`` calls per controller.
    interrupted : bool
        True when the run was stopped by Ctrl-C or SIGTERM (``data`` holds what was recorded until then).
    wall_s : float
        Wall time of the loop (s), without loading.
    sim_s : float
        Simulated time covered (s).
    signals : dict of str to tuple
        Column name -> (instance, variable).
    controller_values : dict of str to dict
        Each controller's full parameter dict (defaults and overrides), for summaries.
    engine : str
        The engine that ran: "compiled" or "python".
    engine_note : str
        Why the Python engine ran when the config did not ask for it ('' otherwise).
    compile_s : float
        Compiled loop: time to compile the kernels or load them from numba's cache (s), not in ``wall_s``.
    events : list of tuple
        ``(time, instance, kind)`` of every FMU event the Python engine handled (see
        :class:`~cosim.master.plant.PlantSystem` ``event_log``).
    stopped : dict or None
        Why the run ended before its stop time: ``{"by": who, "time": t, "reason": message, "cause": cause}``
        with cause "terminate" (an FMU asked to; ``by`` the instance), "error" (an exception in the loop, kept
        with ``Engine.run(faults="keep")``; ``by`` the controller or FMU that raised it, else "master"),
        "non-finite" (a NaN or infinite value; ``by`` the instance), "SIGINT" (Ctrl-C) or "SIGTERM"/"SIGHUP"
        (``by`` "user", ``time`` the last row's). ``data`` holds what was recorded until then. None otherwise.
    fault : Exception or None
        The exception that stopped the run (cause "error" or "non-finite").
    config : cosim.config.Config or None
        The config that ran (set by :func:`cosim.run`).
    summary : dict or None
        What summary.json holds (set by :func:`cosim.run`).
    out : pathlib.Path or None
        The folder the results were written to; None when nothing was written.
    files : list of pathlib.Path
        The files written.
    """

    data: np.ndarray
    units: dict
    calls: dict
    interrupted: bool = False
    wall_s: float = 0.0
    sim_s: float = 0.0
    signals: dict = field(default_factory=dict)
    controller_values: dict = field(default_factory=dict)
    engine: str = "python"
    engine_note: str = ""
    compile_s: float = 0.0
    events: list = field(default_factory=list)
    stopped: dict = None
    fault: Exception = None
    config: object = field(default=None, repr=False, compare=False)
    summary: dict = field(default=None, repr=False, compare=False)
    out: object = None
    files: list = field(default_factory=list)

    def column(self, name):
        """The recorded column ``name`` as a float array."""
        return self.data[name]

    def frame(self, instance=None):
        """The recorded columns as a pandas DataFrame indexed by time (s), with their units.

        Parameters
        ----------
        instance : str, optional
            An FMU or controller instance of the config (``"plant"``, ``"foc"``): its columns only, named by
            their variable (``F_g``, ``v_q``). Default: every column, named as in results.parquet.

        Returns
        -------
        pandas.DataFrame
            ``frame.attrs["units"]``: column name -> unit ("" for none).

        Raises
        ------
        KeyError
            No recorded column belongs to ``instance``.
        """
        import pandas as pd

        columns = {name: name for name in self.signals}
        if instance is not None:
            columns = {name: var for name, (inst, var) in self.signals.items() if inst == instance}
            if not columns:
                owners = ", ".join(dict.fromkeys(inst for inst, _ in self.signals.values()))
                raise KeyError(f"no recorded column of instance {instance!r}; the recorded instances: {owners}")
        frame = pd.DataFrame({label: self.data[name] for name, label in columns.items()},
                             index=pd.Index(self.data["time"], name="time"))
        frame.attrs["units"] = {label: self.units.get(name, "") for name, label in columns.items()}
        return frame

    def plot(self, panels=None):
        """The run's figure, as ``cosim run`` draws its PNG (:func:`~cosim.master.plot.run_figure`).

        Parameters
        ----------
        panels : sequence of sequence of str, optional
            Column names per panel (default: the config's ``[plot] panels``, else one panel per column).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from cosim.master.plot import run_figure

        if panels is None:
            panels = self.config.plot.panels if self.config is not None else ()
        return run_figure(self, panels=panels, config=self.config, summary=self.summary)


class Engine:
    """Set up the instances of a config and run them with a per-instant loop (see the module docstring).

    Parameters
    ----------
    config : cosim.config.Config
    loop : type
        :class:`~cosim.master.loop.PythonLoop` (default) or :class:`~cosim.master.compiled.CompiledLoop`.
    note : str
        Why the Python loop runs when the config did not ask for it (``RunResult.engine_note``).
    compile_s : float
        Seconds already spent compiling the loop's kernels (:func:`engine_for`'s check), added to
        ``RunResult.compile_s``.

    Attributes
    ----------
    layout : cosim.master.layout.Layout
    buf : numpy.ndarray
        The signal buffer.
    tb : cosim.master.schedule.TimeBase
    k_stop : int
        The stop instant (ticks).
    controllers : dict
        Instance name -> controller, in dependency order.
    h_max : float
        ME step bound (s): the fastest clock's period / substeps, or ``solver.max_step``.
    recorder : cosim.master.recorder.Recorder
    loop : PythonLoop or CompiledLoop
    fmu_pool : cosim.master.plant.FmuPool or None
        Keeps the FMUs loaded between runs when set (many short runs of one engine); None: each run loads them.
    base_config : cosim.config.Config
        The config the engine was built with; ``config`` is the one the last run used (:meth:`run_variant`).
    """

    def __init__(self, config, loop=PythonLoop, note="", compile_s=0.0):
        self.config = config
        self.layout = Layout(config)
        self.buf = np.zeros(self.layout.size)
        rates = {f"ctrl:{n}": s.rate for n, s in config.controllers.items()}
        rates["record"] = config.record.rate
        self.tb = TimeBase(rates, start=config.run.start)
        self.k_stop = self.tb.ticks(config.run.stop - config.run.start)
        if self.k_stop < 1:
            raise ConfigError(f"{config.path}: run.stop - run.start is shorter than one tick of the time base")
        self.controllers = {}
        for name in self.layout.ctrl_order:
            spec = config.controllers[name]
            ctrl = spec.cls(rate=spec.rate, jit=spec.jit, **spec.parameters)
            a, b, c = self.layout.ctrl_slices[name]
            ctrl.u = self.buf[a:b]
            ctrl.y = self.buf[b:c]
            ctrl._y0 = np.zeros(c - b)
            self.controllers[name] = ctrl
        fastest = min(c.period for c in self.tb.clocks.values())
        h = float(fastest * self.tb.base.denominator) / self.tb.base.numerator / config.solver.substeps
        self.h_max = config.solver.max_step if config.solver.max_step > 0 else h
        self.recorder = Recorder(config, self.layout, self.buf)
        self.note = note
        self.compile_s = compile_s
        self.loop = loop(self)
        self.fmu_pool = None
        self.base_config = config  # what run_variant's changes apply to
        self._values = {name: dict(c.values) for name, c in self.controllers.items()}

    def _progress_bar(self):
        """A tqdm bar on stderr counting simulated seconds."""
        from tqdm import tqdm

        cfg = self.config
        return tqdm(total=round(cfg.run.stop - cfg.run.start, 6), unit="sim s", desc=cfg.name, leave=False,
                    bar_format="{l_bar}{bar}| {n:.3f}/{total:.3f} sim s [{elapsed}<{remaining}]")

    def _start(self, progress):
        """Controllers reset, signal buffer zeroed, empty recording rows; whether to show progress."""
        periods = {c.period for c in self.tb.clocks.values()}
        for c in self.controllers.values():
            c.reset()
        self.buf[:] = 0.0
        self.recorder.start(self.k_stop // self.tb.clocks["record"].period + 1)
        if progress is None:
            run = self.config.run
            progress = run.progress if run.progress != "auto" else sum(self.k_stop // p + 1 for p in periods) > 200_000
        return progress

    def run(self, progress=None, faults="raise", loop_end=None):
        """Run from start to stop; a partial result if interrupted by Ctrl-C (or SIGTERM, see :class:`Interrupt`).

        Parameters
        ----------
        progress : bool or None
            Show a tqdm bar on stderr; None: when the run has more than 200,000 instants.
        faults : {"raise", "keep"}
            On an exception in the loop (a controller raising, an FMU error, a non-finite value): "raise" it, or
            "keep" what was recorded: the result's ``stopped`` says why (cause "error" or "non-finite") and
            ``fault`` holds the exception.
        loop_end : callable, optional
            Called as soon as the loop has ended, before the FMUs are closed: from then on the recorded rows are
            final (``cosim run`` holds Ctrl-C from there until they are written:
            :class:`~cosim.master.run.SignalsHeld`).

        Returns
        -------
        RunResult
        """
        cfg, loop = self.config, self.loop
        progress = self._start(progress)
        try:
            plant = PlantSystem(cfg, self.layout, self.buf, pool=self.fmu_pool)
        except SimulationTerminated as stop:  # an FMU asked to stop during its initialisation: nothing recorded
            return self._result(_stopped(stop, cfg.run.start))
        bar = None
        stopped = fault = None
        wall = 0.0
        compile_s = self.compile_s
        try:
            compile_s += loop.start(plant)
            bar = self._progress_bar() if progress else None
            wall0 = _time.perf_counter()
            try:
                while not loop.run(CHUNK):
                    if bar is not None:
                        bar.update(self.tb.time(loop.tick) - cfg.run.start - bar.n)
            except KeyboardInterrupt as exc:
                stopped = _interrupted(exc, self._last_row_time())
            except SimulationTerminated as stop:
                stopped = _stopped(stop, self.tb.time(loop.tick))
            except Exception as exc:
                if faults != "keep":
                    raise
                fault = exc
                stopped = self._fault(exc, self.tb.time(loop.tick))
            finally:
                wall = _time.perf_counter() - wall0
                if loop_end is not None:
                    loop_end()
        finally:
            if bar is not None:
                bar.close()
            plant.close()
        result = self._result(stopped, stopped is not None and stopped["cause"] in _SIGNALS, wall, compile_s,
                              plant.event_log)
        result.fault = fault
        return result

    def run_variant(self, stop=None, parameters=None, start=None, controllers=None, progress=False,
                    faults="raise"):
        """Run the config the engine was built with, some of its values changed: a variant run (a campaign's
        trial, a study's case). The engine's controllers (their compiled kernels) and, with ``fmu_pool``, its
        FMUs are kept; every call starts from ``base_config``, so no change carries over to the next call.

        Parameters
        ----------
        stop : float, optional
            The run's stop time [s] (default: the config's).
        parameters, start : dict, optional
            FMU instance -> {name: value}: parameter and start values over the config's.
        controllers : dict, optional
            Controller instance -> {parameter: value} over the config's (numeric parameters: the kernel reads
            them packed).
        progress, faults
            As for :meth:`run`.

        Returns
        -------
        RunResult

        Raises
        ------
        cosim.errors.ConfigError
            An instance the config does not have, or a stop not after the start.
        """
        base = self.base_config
        parameters, start, controllers = parameters or {}, start or {}, controllers or {}
        _known(base, "FMU", [*parameters, *start], base.fmus)
        _known(base, "controller", controllers, self.controllers)
        stop = base.run.stop if stop is None else float(stop)
        k_stop = self.tb.ticks(stop - base.run.start)
        if k_stop < 1:
            raise ConfigError(f"{base.path}: run_variant: stop = {stop!r} s is not after run.start = "
                              f"{base.run.start!r} s by one tick of the time base")
        fmus = {n: replace(s, parameters={**s.parameters, **parameters.get(n, {})},
                           start={**s.start, **start.get(n, {})}) for n, s in base.fmus.items()}
        self.config, self.k_stop = replace_unchecked(base, run=replace(base.run, stop=stop), fmus=fmus), k_stop
        for name, ctrl in self.controllers.items():
            ctrl.values = {**self._values[name], **controllers.get(name, {})}
            ctrl.p[:] = ctrl.pack()
        return self.run(progress=progress, faults=faults)

    def _last_row_time(self):
        rows = int(self.recorder.rows[0])
        return float(self.recorder.times[rows - 1]) if rows else self.config.run.start

    def _fault(self, exc, t):
        """``RunResult.stopped`` of an exception from the loop: who raised it (a controller or an FMU found in
        the traceback), when, and the message with the file:line where it was raised."""
        if isinstance(exc, NonFiniteError):
            return {"by": exc.instance, "time": float(exc.time), "reason": str(exc), "cause": "non-finite"}
        by = "master"
        names = {id(c): n for n, c in self.controllers.items()}
        tb = exc.__traceback__
        while tb is not None:
            local = tb.tb_frame.f_locals
            owner = local.get("self")
            if id(owner) in names:
                by = names[id(owner)]
            elif by == "master":  # an FMU's method, or the compiled loop naming the FMU whose call failed
                inst = owner if isinstance(owner, FmuInstance) else local.get("inst")
                by = inst.name if isinstance(inst, FmuInstance) else by
            tb = tb.tb_next
        where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ is not None else None
        at = f" ({where.filename}:{where.lineno})" if where is not None and by in names.values() else ""
        return {"by": by, "time": float(t), "reason": f"{by} raised {type(exc).__name__}: {exc}{at} at t={t:.9g} s",
                "cause": "error"}

    def _result(self, stopped, interrupted=False, wall=0.0, compile_s=None, events=()):
        """The RunResult of what the recorder holds."""
        data = self.recorder.data()
        return RunResult(
            data=data,
            units=dict(self.recorder.units),
            calls=self.loop.call_counts(),
            interrupted=interrupted,
            wall_s=wall,
            sim_s=float(data["time"][-1] - self.config.run.start) if len(data) else 0.0,
            signals=dict(self.recorder.signals),
            controller_values={n: dict(c.values) for n, c in self.controllers.items()},
            engine=self.loop.name,
            engine_note=self.note,
            compile_s=self.compile_s if compile_s is None else compile_s,
            events=list(events),
            stopped=stopped,
        )


def _known(config, kind, names, instances):
    """A ConfigError when one of ``names`` is not one of the config's ``instances`` of ``kind``."""
    for name in names:
        if name not in instances:
            raise ConfigError(f"{config.path}: run_variant: no {kind} instance {name!r}; the config has "
                              f"{', '.join(instances) or 'none'}")


def _stopped(stop, t_default):
    """``RunResult.stopped`` of a SimulationTerminated (its time NaN: ``t_default``, the loop's instant)."""
    t = stop.time if stop.time == stop.time else t_default
    return {"by": stop.instance, "time": float(t), "reason": stop.reason, "cause": "terminate"}


class Interrupt(KeyboardInterrupt):
    """A signal other than SIGINT turned into an interrupt (``cosim run`` does so for SIGTERM): the run stops
    as on Ctrl-C, keeping what was recorded.

    Parameters
    ----------
    signum : int
        The signal.
    """

    def __init__(self, signum):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


def _interrupted(exc, t_last):
    """``RunResult.stopped`` of an interrupt: by a signal, at the last recorded row's time."""
    name = signal.Signals(exc.signum).name if isinstance(exc, Interrupt) else "SIGINT"
    reason = "interrupted (Ctrl-C)" if name == "SIGINT" else f"terminated by {name}"
    return {"by": "user", "time": t_last, "reason": reason, "cause": name}


def engine_for(config):
    """The engine that runs ``config``: the compiled loop where possible (see the module docstring).

    Parameters
    ----------
    config : cosim.config.Config

    Returns
    -------
    Engine
        Its ``loop`` is a :class:`~cosim.master.compiled.CompiledLoop` or a :class:`~cosim.master.loop.PythonLoop`.
    """
    if config.run.engine == "python":
        return Engine(config)
    t0 = _time.perf_counter()
    with signals_deferred():  # a Ctrl-C inside numba's compilation would be lost
        reason, numba_failed = compiled_problem(config)  # compiles the controllers' cfuncs (or loads them)
    if reason is None:
        return Engine(config, CompiledLoop, compile_s=_time.perf_counter() - t0)
    note = f"running the Python engine ({PYTHON_COST}) because {reason}"
    if numba_failed:
        warnings.warn(f"{config.name}: {note}", EngineFallbackWarning, stacklevel=2)
    with warnings.catch_warnings():  # the controllers' own "runs in plain Python" warning: said just above
        warnings.simplefilter("ignore", UserWarning)
        return Engine(config, note=note)


PYTHON_COST = "30-75 times slower than the compiled one on the gripper's impact, docs/validation.md"
"""What running the Python engine costs, said with every fallback (benchmarks/engine.py measures it)."""
