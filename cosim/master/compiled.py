"""The compiled per-instant loop: one numba kernel calling the FMUs' C entry points, and when a config can use it.

:class:`CompiledLoop` is the loop :class:`cosim.master.engine.Engine` swaps in for the Python one
(:class:`cosim.master.loop.PythonLoop`) when :func:`compiled_problem` finds nothing against it
(every controller's kernel compiles with numba, the solver is the fixed-step RK4, FMI 2.0 or 3.0). Events of
Model Exchange FMUs (state, time and step events, terminateSimulation) are handled inside the kernel with the
Python engine's rules; a config whose FMUs cannot have events gets the kernel's version without event code.
It turns the engine's :class:`~cosim.master.layout.Layout` and the run's
:class:`~cosim.master.plant.PlantSystem` into the integer/float tables of :mod:`cosim.master.ckernel`,
so both loops do the same operations at the same instants, and runs the kernel in chunks of
instants. Numba compile time (or loading from numba's on-disk cache) is what :meth:`CompiledLoop.start`
returns.
"""

import importlib
import pkgutil
import time as _time
import warnings

import numpy as np

from cosim.controller import Controller
from cosim.errors import EventError, FmiCallError, SimulationTerminated
from cosim.fmi import FmuInstance, check
from cosim.jit import compile_kernel, kernel_problem, native_kernel, signals_deferred
from cosim.master.ckernel import (CTL_COLS, DONE, ERROR, FF, FMU_COLS, FUNCTIONS, KINDS, PORT_COLS, RAW_TYPES, ST,
                                  run_chunk)
from cosim.master.finite import nonfinite_error
from cosim.master.events import CHATTER_WINDOW, EVENT_TOL, MAX_EVENTS_AT_ONE_TIME

__all__ = ["CompiledLoop", "compiled_problem", "precompile", "shipped_controllers"]

_K, _EF, _EFN, _ES, _NLOG, _EP = (ST.index(n) for n in ("k", "err_fmu", "err_fn", "err_status", "n_log", "err_port"))
_LOG_ROWS = 1 << 14  # events the kernel logs before Python reads them (a chunk stops when half are used)
_EVENT_FUNCTIONS = ("GetEventIndicators", "EnterEventMode", "UpdateDiscreteStates", "EnterContinuousTimeMode",
                    "GetContinuousStates")


def compiled_problem(config):
    """Why ``config`` cannot run compiled: ``(reason, is_numba_failure)``, or ``(None, False)``.

    Parameters
    ----------
    config : cosim.config.Config
    """
    if config.solver.method != "rk4":
        return f"solver.method = {config.solver.method!r} runs in Python (scipy); the compiled engine is RK4", False
    for name, spec in config.controllers.items():
        cls = spec.cls
        where = f"controller {name!r} ({cls.__name__})"
        if not spec.jit:
            return f"{where} has jit = false", False
        if cls.step is not Controller.step:
            return f"{where} overrides step() in Python", False
        kernel = cls.kernel
        if compile_kernel(kernel, cls.__name__, warn=False) is kernel:
            return f"{where}: numba cannot compile its kernel: {kernel_problem(kernel)}", True
        try:
            native_kernel(kernel)
        except Exception as err:  # numba raises many types; any means "not compiled"
            return f"{where}: numba cannot compile its kernel as a cfunc: {str(err).splitlines()[0]}", True
    for name, spec in config.fmus.items():
        if spec.info.fmi_version not in (2, 3):
            return f"FMU {name!r} is FMI {spec.info.fmi_version}; the compiled engine calls FMI 2.0 and 3.0", False
    return None, False


def precompile(controller_classes=()):
    """Compile the loop and the kernels of ``controller_classes`` into numba's on-disk cache ahead of a run.

    The loop in its four versions (with or without event code, with or without typed ports), called on empty
    tables of the types :meth:`CompiledLoop.start` passes with no instant to run: a later run in any process
    sharing the cache (:mod:`cosim.kernel_cache`) loads them instead of compiling. ``cosim build`` does this.

    Parameters
    ----------
    controller_classes : iterable of type
        :class:`~cosim.controller.Controller` subclasses whose kernels to compile.
    """
    for cls in controller_classes:
        native_kernel(cls.kernel)
    i64, f64 = np.int64, np.float64
    scr = np.zeros((0, 32), dtype=np.uint8)
    ff = np.zeros(len(FF))
    evt = (np.zeros((0, 3), i64), np.zeros((2, 0)), np.zeros((2, 0)), np.zeros(0, i64), np.zeros(0), scr,
           scr.view(f64), ff, np.zeros((_LOG_ROWS, 3)))
    for typed in (None, np.zeros((0, len(PORT_COLS)), i64)):
        for events in (None, evt):
            run_chunk(np.zeros((0, len(FMU_COLS)), i64), *(np.zeros(0, i64),) * 3, np.zeros((0, 4), i64), typed,
                      np.zeros((2, 4), i64), np.zeros(0, i64), np.zeros(0, i64), np.zeros(0), np.zeros(0),
                      np.zeros((0, 2), i64), np.zeros((0, 3), i64), np.zeros((0, len(CTL_COLS)), i64),
                      np.zeros(5, i64), ff, np.zeros(1), np.zeros((7, 0)), np.zeros((1, 0)), np.zeros(1),
                      np.zeros(1, i64), np.zeros(0, i64), np.zeros(0, i64), scr, np.zeros(len(ST), i64), events, 0)


def shipped_controllers():
    """The controller classes of the shipped ``cosim_controllers`` package that the compiled engine runs (those
    of the examples), for :func:`precompile`."""
    import cosim_controllers

    found = []
    for info in pkgutil.iter_modules(cosim_controllers.__path__):
        module = importlib.import_module(f"cosim_controllers.{info.name}")
        found.extend(c for c in vars(module).values() if isinstance(c, type) and issubclass(c, Controller)
                     and c.__module__ == module.__name__ and c.kernel is not Controller.kernel
                     and c.step is Controller.step)
    return found


class CompiledLoop:
    """The per-instant loop as one numba kernel (see the module docstring; same interface as
    :class:`cosim.master.loop.PythonLoop`).

    Parameters
    ----------
    engine : cosim.master.engine.Engine
        The set-up the loop runs; a config :func:`compiled_problem` accepts.
    """

    name = "compiled"

    def __init__(self, engine):
        self.engine = engine
        self._native = {name: native_kernel(type(c).kernel) for name, c in engine.controllers.items()}
        self.calls = np.zeros(len(engine.layout.ctrl_order), dtype=np.int64)
        self.st = np.zeros(len(ST), dtype=np.int64)
        self.plant = None
        self._args = None
        self._ff = None

    @property
    def tick(self):
        """The next instant (ticks of the time base)."""
        return int(self.st[_K])

    def start(self, plant):
        """Build the kernel's tables for ``plant`` and compile the kernel (or load it from numba's cache).

        Returns
        -------
        float
            Seconds spent compiling or loading the kernel.
        """
        eng = self.engine
        self.plant = plant
        self.calls[:] = 0
        self.st[:] = 0
        self.st[ST.index("synced")] = -1
        self.st[ST.index("first")] = 1  # first chunk: send the initial FMU inputs
        rec = eng.recorder
        tab = self._tables(plant)
        self._ff = tab["ff"]
        self._log = tab["evt"][8] if tab["evt"] is not None else None
        self._raw = tab["raw"]  # the typed ports' C values, addressed by the kernel
        self._port_items = {"Real": tab["port_items"], "Typed": tab["typed_items"]}  # (instance, Port) a table row
        self._args = (tab["fmu"], tab["me"], tab["cmp"], tab["cs"], tab["port"], tab["typed"], tab["pgrp"],
                      tab["rsrc"], tab["rdst"], tab["rgain"], tab["roff"], tab["rgrp"], tab["lvl"], tab["ctl"], tab["ii"],
                      tab["ff"], eng.buf, plant.W, rec.values, rec.times, rec.rows, rec.index, self.calls, tab["scr"], self.st,
                      tab["evt"])
        t0 = _time.perf_counter()
        with signals_deferred():  # a Ctrl-C inside numba's compilation would be lost
            run_chunk(*self._args, 0)  # compile, or load from numba's cache
        return _time.perf_counter() - t0

    def call_counts(self):
        """Number of ``step`` calls per controller so far."""
        return {name: int(self.calls[i]) for i, name in enumerate(self.engine.layout.ctrl_order)}

    def run(self, n):
        """Run at most ``n`` instants; True when the stop instant is done.

        Raises
        ------
        cosim.errors.FmiCallError
            An FMI call returned an error.
        cosim.errors.SimulationTerminated
            An FMU asked to terminate.
        cosim.errors.EventError
            An FMU's event iteration did not settle, or events chatter at one instant.
        cosim.errors.NonFiniteError
            A value, state or derivative is NaN or infinite at an instant.
        """
        code = run_chunk(*self._args, n)
        self._read_log()
        if code == ERROR:
            self._raise()
        return code == DONE

    def _read_log(self):
        """Move the events the kernel logged into the plant's ``event_log``, as the Python engine keeps it."""
        n = int(self.st[_NLOG])
        if not n:
            return
        names = list(self.plant.instances)
        for t, f, kind in self._log[:min(n, len(self._log))]:
            self.plant.event_log.append((float(t), names[int(f)], KINDS[int(kind)]))
        if n > len(self._log):
            warnings.warn(f"{n - len(self._log)} events in one interval between instants were handled but not "
                          f"logged (the compiled engine logs {len(self._log)} per interval)", stacklevel=3)
        self.st[_NLOG] = 0

    def _tables(self, plant):
        eng = self.engine
        lay, buf = eng.layout, eng.buf
        names = list(plant.instances)
        fidx = {n: i for i, n in enumerate(names)}
        scr = np.zeros((len(names), 32), dtype=np.uint8)
        fmu = np.zeros((len(names), len(FMU_COLS)), dtype=np.int64)
        x_off = {}
        off = 0
        for inst in plant.me:
            x_off[inst.name] = off
            off += inst.n_states
        for i, n in enumerate(names):
            inst = plant.instances[n]
            ep = inst.entry_points()
            need = ["GetReal", "SetReal"] + (["SetTime", "SetContinuousStates", "GetDerivatives"] if inst.kind == "ME"
                                             else ["DoStep"])
            if inst in plant.completed:
                need.append("CompletedIntegratorStep")
            if inst.kind == "ME" and (inst.n_indicators or inst in plant.completed or inst.next_event_time < np.inf):
                need.extend(_EVENT_FUNCTIONS if inst.n_states else _EVENT_FUNCTIONS[:-1])
            missing = [f for f in need if not ep[f]]
            if missing:  # a call through address 0 would crash the process: refuse here
                raise FmiCallError("load", "missing entry points", f"{n}: {', '.join(missing)} not exported")
            row = [ep["component"], ep["SetTime"], ep["SetContinuousStates"], ep["GetDerivatives"], ep["GetReal"],
                   ep["SetReal"], ep["DoStep"], ep["CompletedIntegratorStep"], inst.version, x_off.get(n, 0),
                   inst.n_states, scr[i].ctypes.data] + [ep[f] for f in _EVENT_FUNCTIONS]
            fmu[i] = row
        me = np.array([fidx[i.name] for i in plant.me], dtype=np.int64)
        ev, nz = [], 0
        for inst in plant.evented:
            ev.append((fidx[inst.name], nz, inst.n_indicators))
            nz += inst.n_indicators
        tev = np.array([i.next_event_time if i.kind == "ME" else np.inf for i in plant.instances.values()])
        ff = np.array([eng.tb.start, eng.h_max, np.nan, min(tev, default=np.inf), EVENT_TOL, CHATTER_WINDOW,
                       MAX_EVENTS_AT_ONE_TIME, FmuInstance.MAX_EVENT_PASSES])  # in the order of FF
        evt = None  # no FMU can have events: the kernel's version without event code runs
        if ev or plant.completed or np.isfinite(tev).any():
            evt = (np.array(ev, dtype=np.int64).reshape(-1, 3), np.zeros((2, nz)), np.zeros((2, plant.W.shape[1])),
                   np.zeros(len(names), dtype=np.int64), tev, scr, scr.view(np.float64), ff, np.zeros((_LOG_ROWS, 3)))
        cmp = np.array([fidx[i.name] for i in plant.completed], dtype=np.int64)
        cs = np.array([fidx[i.name] for i in plant.cs], dtype=np.int64)

        groups = []  # the port groups of the kernel's pgrp, each a list of (instance, Port)

        def group(items):
            groups.append(list(items))
            return len(groups) - 1

        group(plant.sample_ports)
        group([ip for items in plant.instant_in_ports.values() for ip in items])
        routes, rgrp = [], []

        def rgroup(arrays):
            src, dst, gain, offset = arrays
            a = len(routes)
            routes.extend(zip(src.tolist(), dst.tolist(), gain.tolist(), offset.tolist()))
            rgrp.append((a, len(routes)))
            return len(rgrp) - 1

        rgroup(lay.route_fmu_instant)
        rgroup(lay.route_ctrl_to_fmu)
        ctrl_route = {name: rgroup(lay.route_ctrl_in[name]) for name in lay.ctrl_order}
        lvl = []
        for gets, arrays, sets in plant.program:
            lvl.append((group(gets), rgroup(arrays), group(sets)))
        port, typed, pgrp, raw = _port_tables(groups, fidx, buf)
        clocks = eng.tb.clocks
        ctl = []
        for name in lay.ctrl_order:
            c = eng.controllers[name]
            ctl.append((self._native[name].address, clocks[f"ctrl:{name}"].period, ctrl_route[name],
                        c.u.ctypes.data, len(c.u), c.y.ctypes.data, len(c.y), c.x.ctypes.data, len(c.x),
                        c.p.ctypes.data, len(c.p)))
        periods = sorted({c.period for c in clocks.values()})
        num, den = eng.tb.base.numerator, eng.tb.base.denominator
        ii = np.array([eng.k_stop, clocks["record"].period, num, den, len(periods)] + periods, dtype=np.int64)
        r = np.array(routes, dtype=np.float64).reshape(-1, 4)
        return dict(
            fmu=fmu, me=me, cmp=cmp, cs=cs,
            port=port, typed=typed, raw=raw, pgrp=np.array(pgrp, dtype=np.int64).reshape(-1, 4),
            rsrc=r[:, 0].astype(np.int64), rdst=r[:, 1].astype(np.int64),
            rgain=np.ascontiguousarray(r[:, 2]), roff=np.ascontiguousarray(r[:, 3]),
            rgrp=np.array(rgrp, dtype=np.int64).reshape(-1, 2), lvl=np.array(lvl, dtype=np.int64).reshape(-1, 3),
            ctl=np.array(ctl, dtype=np.int64).reshape(-1, len(CTL_COLS)), ii=ii,
            ff=ff, scr=scr, port_items=[(i, p) for g in groups for i, p in g if p.raw is None],
            typed_items=[(i, p) for g in groups for i, p in g if p.raw is not None], fmu_names=names, evt=evt,
        )

    def _raise(self):
        st = self.st
        if FUNCTIONS[int(st[_EFN])] == "nonfinite":
            t = self.engine.tb.time(int(st[_K]))
            raise nonfinite_error(self.engine.layout, self.engine.buf, self.plant, t)
        inst = list(self.plant.instances.values())[int(st[_EF])]
        fn = FUNCTIONS[int(st[_EFN])]
        status = int(st[_ES])
        t_event = float(self._ff[FF.index("event_t")])
        reason = inst.messages[-1] if inst.messages else ""
        if fn in ("terminate", "DoStep:terminate") or (fn == "DoStep" and status == 2 and inst.version == 2
                                                      and inst._fmi2_terminated()):
            raise SimulationTerminated(inst.name, t_event, reason)
        if fn == "unsettled":
            raise EventError(f"{inst.name}: the event iteration at t={t_event:.12g} s did not settle in "
                             f"{FmuInstance.MAX_EVENT_PASSES} passes (discrete states keep changing)")
        if fn == "chatter":
            raise EventError(f"{inst.name}: more than {MAX_EVENTS_AT_ONE_TIME} events in a row less than "
                             f"{CHATTER_WINDOW:g} s apart, at t={t_event:.12g} s (chattering or an accumulation of "
                             "events)")
        if fn in ("GetReal", "SetReal", "GetTyped", "SetTyped"):  # the call made: fmi3GetInt32, fmi2SetBoolean, ...
            fn = inst.call_name(fn[:3], self._port_items[fn[3:]][int(st[_EP])][1])
        t = self.engine.tb.time(int(st[_K]))
        check(fn, status, f"{inst._last_message()} (in the instant after t={t})")
        raise FmiCallError(fn, f"status {status}", inst.name)  # pragma: no cover - check raised


def _port_tables(groups, fidx, buf):
    """The kernel's ``port`` and ``typed`` tables and the group ranges ``pgrp`` (see :mod:`cosim.master.ckernel`)
    of the groups of ``(instance, Port)`` pairs, and the array whose 8-byte aligned slots hold the typed ports'
    C values (it must live as long as the tables). ``typed`` is None when no port is typed."""
    raw = np.zeros(1 + sum(p.raw.nbytes // 8 + 1 for g in groups for _, p in g if p.raw is not None), dtype=np.int64)
    plain, typed, pgrp, at = [], [], [], 0
    for group in groups:
        a, c = len(plain), len(typed)
        for inst, port in group:
            row = (fidx[inst.name], port.vr_address, port.n, (port.values.ctypes.data - buf.ctypes.data) // 8)
            if port.raw is None:
                plain.append(row)
                continue
            code = RAW_TYPES.index(np.dtype(port.raw.dtype).name)
            get, set_ = inst.port_entry_points(port)
            if not (get and set_):  # a call through address 0 would crash the process: refuse here
                raise FmiCallError("load", "missing entry points", f"{inst.name}: the Get/Set functions of "
                                   f"{port.names[0]}'s type are not exported")
            typed.append(row + (code, get, set_, raw.ctypes.data + 8 * at))
            at += port.raw.nbytes // 8 + 1
        pgrp.append((a, len(plain), c, len(typed)))
    typed = np.array(typed, dtype=np.int64).reshape(-1, len(PORT_COLS)) if typed else None
    return np.array(plain, dtype=np.int64).reshape(-1, 4), typed, pgrp, raw
