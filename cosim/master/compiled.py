"""The compiled engine: the per-instant loop as one numba kernel calling the FMUs' C entry points.

:func:`engine_for` picks the engine of a config: ``run.engine = "compiled"`` (the default) runs
:class:`CompiledEngine` when every controller's kernel compiles with numba and the solver is the
fixed-step RK4; otherwise the run falls back to the Python engine (:class:`cosim.master.engine.Engine`)
with a one-line explanation: a warning naming the construct when numba cannot compile a kernel, a
note in the result (``RunResult.engine_note``, summary.json) when the config itself asks for
Python (``jit = false``, a controller overriding ``step`` in Python, an implicit solver).

The compiled engine builds the same :class:`~cosim.master.engine.Layout` and
:class:`~cosim.master.plant.PlantSystem` as the Python engine and turns them into the integer/float
tables of :mod:`cosim.master.ckernel`, so both engines do the same operations at the same instants.
The kernel runs in chunks of instants: between chunks the progress bar moves and Ctrl-C stops the
run with what was recorded. Numba compile time (or loading from numba's on-disk cache) is reported
separately in ``RunResult.compile_s``.
"""

import time as _time
import warnings

import numpy as np

from controllers.base import Controller, compile_kernel, kernel_problem, native_kernel
from cosim.errors import EngineFallbackWarning, FmiCallError
from cosim.fmi import check
from cosim.master import ckernel
from cosim.master.engine import Engine, RunResult

__all__ = ["CompiledEngine", "engine_for", "compiled_problem"]

CHUNK = 4096  # instants per kernel call (about 1-5 ms of wall time at the FOC rate)


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


def engine_for(config):
    """The engine that runs ``config`` (compiled where possible, see the module docstring).

    Parameters
    ----------
    config : cosim.config.Config

    Returns
    -------
    CompiledEngine or cosim.master.engine.Engine
    """
    if config.run.engine == "python":
        return Engine(config)
    t0 = _time.perf_counter()
    reason, numba_failed = compiled_problem(config)  # compiles the controllers' cfuncs (or loads them)
    if reason is None:
        engine = CompiledEngine(config)
        engine._cfunc_s += _time.perf_counter() - t0
        return engine
    if numba_failed:
        warnings.warn(f"{config.name}: running the Python engine: {reason}", EngineFallbackWarning, stacklevel=2)
    with warnings.catch_warnings():  # the controllers' own "runs in plain Python" warning: said just above
        warnings.simplefilter("ignore", UserWarning)
        engine = Engine(config)
    engine.engine_note = f"Python engine: {reason}"
    return engine


class CompiledEngine(Engine):
    """Run a config with the compiled per-instant kernel (see the module docstring).

    Parameters
    ----------
    config : cosim.config.Config
        A config :func:`compiled_problem` accepts.
    """

    def __init__(self, config):
        super().__init__(config)
        t0 = _time.perf_counter()
        self._native = {name: native_kernel(type(c).kernel) for name, c in self.controllers.items()}
        self._cfunc_s = _time.perf_counter() - t0

    # -- tables ----------------------------------------------------------------------------------
    def _tables(self, plant):
        lay, buf = self.layout, self.buf
        names = list(plant.instances)
        fidx = {n: i for i, n in enumerate(names)}
        buf_addr = buf.ctypes.data
        scr = np.zeros((len(names), 16), dtype=np.uint8)
        fmu = np.zeros((len(names), len(ckernel.FMU_COLS)), dtype=np.int64)
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
            if inst in plant._completed:
                need.append("CompletedIntegratorStep")
            missing = [f for f in need if not ep[f]]
            if missing:  # a call through address 0 would crash the process: refuse here
                raise FmiCallError("load", "missing entry points", f"{n}: {', '.join(missing)} not exported")
            row = [ep["component"], ep["SetTime"], ep["SetContinuousStates"], ep["GetDerivatives"], ep["GetReal"],
                   ep["SetReal"], ep["DoStep"], ep["CompletedIntegratorStep"], inst.version, x_off.get(n, 0),
                   inst.n_states, scr[i].ctypes.data]
            fmu[i] = row
        me = np.array([fidx[i.name] for i in plant.me], dtype=np.int64)
        cmp = np.array([fidx[i.name] for i in plant._completed], dtype=np.int64)
        cs = np.array([fidx[i.name] for i in plant.cs], dtype=np.int64)

        ports, pgrp, items_ = [], [], []

        def group(items):
            a = len(ports)
            for inst, port in items:
                off = (port.values.ctypes.data - buf_addr) // 8
                ports.append((fidx[inst.name], port.vr_address, port.n, off))
                items_.append((inst, port))
            pgrp.append((a, len(ports)))
            return len(pgrp) - 1

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
        for gets, arrays, sets in plant._program:
            lvl.append((group(gets), rgroup(arrays), group(sets)))
        clocks = self.tb.clocks
        ctl = []
        for name in lay.ctrl_order:
            c = self.controllers[name]
            ctl.append((self._native[name].address, clocks[f"ctrl:{name}"].period, ctrl_route[name],
                        c.u.ctypes.data, len(c.u), c.y.ctypes.data, len(c.y), c.x.ctypes.data, len(c.x),
                        c.p.ctypes.data, len(c.p)))
        periods = sorted({c.period for c in clocks.values()})
        num, den = self.tb.base.numerator, self.tb.base.denominator
        ii = np.array([self.k_stop, clocks["record"].period, num, den, len(periods)] + periods, dtype=np.int64)
        r = np.array(routes, dtype=np.float64).reshape(-1, 4)
        return dict(
            fmu=fmu, me=me, cmp=cmp, cs=cs,
            port=np.array(ports, dtype=np.int64).reshape(-1, 4), pgrp=np.array(pgrp, dtype=np.int64).reshape(-1, 2),
            rsrc=r[:, 0].astype(np.int64), rdst=r[:, 1].astype(np.int64),
            rgain=np.ascontiguousarray(r[:, 2]), roff=np.ascontiguousarray(r[:, 3]),
            rgrp=np.array(rgrp, dtype=np.int64).reshape(-1, 2), lvl=np.array(lvl, dtype=np.int64).reshape(-1, 3),
            ctl=np.array(ctl, dtype=np.int64).reshape(-1, len(ckernel.CTL_COLS)), ii=ii,
            ff=np.array([self.tb.start, self.h_max]), scr=scr, port_items=items_, fmu_names=names,
        )

    # -- the run ---------------------------------------------------------------------------------
    def run(self, progress=None):
        """Run from start to stop; returns a :class:`RunResult` (partial if interrupted by Ctrl-C).

        Parameters
        ----------
        progress : bool or None
            Show a tqdm bar on stderr; None: when the run has more than 200,000 instants.
        """
        cfg = self.config
        tb = self.tb
        _, rec, times, plant, progress = self._start_run(progress)
        order = list(self.layout.ctrl_order)
        calls = np.zeros(len(order), dtype=np.int64)
        st = np.zeros(len(ckernel.ST), dtype=np.int64)
        st[2] = -1  # synced tick
        st[3] = 1  # first chunk: send the initial FMU inputs
        rec_idx = np.ascontiguousarray(self.rec_idx)
        bar = None
        interrupted = False
        wall = 0.0
        try:
            tab = self._tables(plant)
            args = (tab["fmu"], tab["me"], tab["cmp"], tab["cs"], tab["port"], tab["pgrp"], tab["rsrc"], tab["rdst"],
                    tab["rgain"], tab["roff"], tab["rgrp"], tab["lvl"], tab["ctl"], tab["ii"], tab["ff"], self.buf,
                    plant.W, rec, times, rec_idx, calls, tab["scr"], st)
            c0 = _time.perf_counter()
            ckernel.run_chunk(*args, 0)  # compile, or load from numba's cache
            self.compile_s = self._cfunc_s + _time.perf_counter() - c0
            if progress:
                bar = self._progress_bar()
            wall0 = _time.perf_counter()
            try:
                while True:
                    code = ckernel.run_chunk(*args, CHUNK)
                    if code == ckernel.ERROR:
                        self._raise(plant, st)
                    if st[7]:
                        self._warn_event(plant, st)
                    if bar is not None:
                        bar.update(tb.time(int(st[0])) - cfg.run.start - bar.n)
                    if code == ckernel.DONE:
                        break
            except KeyboardInterrupt:
                interrupted = True
            finally:
                wall = _time.perf_counter() - wall0
        finally:
            if bar is not None:
                bar.close()
            plant.close()
            self.plant = None
        row = int(st[1])
        dtype = [("time", "f8")] + [(name, "f8") for name in self.signals]
        data = np.zeros(row, dtype=dtype)
        data["time"] = times[:row]
        for j, name in enumerate(self.signals):
            data[name] = rec[:row, j]
        return RunResult(
            data=data,
            units=dict(self.units),
            calls={name: int(calls[i]) for i, name in enumerate(order)},
            interrupted=interrupted,
            wall_s=wall,
            sim_s=float(times[row - 1] - cfg.run.start) if row else 0.0,
            signals=dict(self.signals),
            controller_values={n: dict(c.values) for n, c in self.controllers.items()},
            engine="compiled",
            compile_s=self.compile_s,
        )

    def _raise(self, plant, st):
        inst = list(plant.instances.values())[int(st[4])]
        fn = ckernel.FUNCTIONS[int(st[5])]
        t = self.tb.time(int(st[0]))
        if fn == "DoStep:terminate":
            raise FmiCallError("DoStep", "terminateSimulation", f"{inst.name} asked to stop after t={t}")
        check(fn, int(st[6]), f"{inst._last_message()} (in the instant after t={t})")
        raise FmiCallError(fn, f"status {int(st[6])}", inst.name)  # pragma: no cover - check raised

    def _warn_event(self, plant, st):
        if getattr(self, "_event_warned", False):
            return
        self._event_warned = True
        inst = list(plant.instances.values())[int(st[7]) - 1]
        warnings.warn(f"{inst.name}: the FMU asked for event mode after t={self.tb.time(int(st[8]))}; events are "
                      "not handled", stacklevel=3)
