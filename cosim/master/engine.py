"""The Python engine: the multi-rate loop over integer ticks.

Every routed or recorded value lives in one float64 signal buffer ``buf``: each controller's
``u``/``y`` arrays and each FMU port are views of slices of it, and a connection is a triple of
indices/coefficients ``buf[dst] = gain * buf[src] + offset``. The work of one sample instant ``k``
(the per-tick kernel a compiled engine replaces, issue 8) is:

1. bring the plant to ``t_k`` and read the sampled FMU variables into ``buf``;
2. route FMU-to-FMU connections that act at instants (to/from Co-Simulation FMUs);
3. for each controller due at ``k`` (in dependency order): route its inputs, ``step(t_k)``;
4. route controller outputs to FMU inputs and send them (zero-order hold until the next instant);
5. record a row if the recorder is due;
6. advance the plant to the next instant (ME: RK4 substeps or an implicit solver; CS: doStep).

Controllers are called at every instant ``t0 + j / rate`` with ``t < stop``; the recorder at every
``t0 + j / rate <= stop``.
"""

import time as _time
from dataclasses import dataclass, field

import numpy as np

from cosim.errors import ConfigError
from cosim.master import kernels
from cosim.master.plant import PlantSystem
from cosim.master.schedule import TimeBase

__all__ = ["Layout", "RunResult", "Engine"]


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
        True when the run was stopped by Ctrl-C (``data`` holds what was recorded until then).
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
        Compiled engine: time to compile the kernels or load them from numba's cache (s), not in ``wall_s``.
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

    def column(self, name):
        """The recorded column ``name`` as a float array."""
        return self.data[name]


class Layout:
    """Slots of the signal buffer and the routing index arrays of a config."""

    def __init__(self, config):
        self.index = {}
        n = 0

        def slot(key):
            nonlocal n
            if key not in self.index:
                self.index[key] = n
                n += 1
            return self.index[key]

        fmus = config.fmus
        kind = {name: spec.kind for name, spec in fmus.items()}
        self.fmu_sampled = {name: [] for name in fmus}
        self.fmu_instant_inputs = {name: [] for name in fmus}
        me_to_me = []
        instant = []
        for c in config.connections:
            (si, sv), (di, dv) = c.src, c.dst
            if si in fmus and di in fmus:
                if kind[si] == "ME" and kind[di] == "ME":
                    me_to_me.append((si, sv, di, dv, c.gain, c.offset))
                else:
                    instant.append(c)
                    self.fmu_sampled[si].append(sv)
                    self.fmu_instant_inputs[di].append(dv)
            elif si in fmus:
                self.fmu_sampled[si].append(sv)
            elif di in fmus:
                self.fmu_instant_inputs[di].append(dv)
        for inst, var in config.record.signals:
            if inst in fmus:
                self.fmu_sampled[inst].append(var)
        # contiguous slots per FMU: sampled variables, then instant inputs, then stage ports
        for name in fmus:
            self.fmu_sampled[name] = list(dict.fromkeys(self.fmu_sampled[name]))
            self.fmu_instant_inputs[name] = list(dict.fromkeys(self.fmu_instant_inputs[name]))
            for v in self.fmu_sampled[name]:
                slot((name, v))
            for v in self.fmu_instant_inputs[name]:
                slot((name, v))
        for si, sv, di, dv, _, _ in sorted(me_to_me):
            slot((si, sv))
        for si, sv, di, dv, _, _ in sorted(me_to_me, key=lambda c: (c[2], c[3])):
            slot((di, dv))
        self.me_to_me = me_to_me
        # controllers: u then y, contiguous
        self.ctrl_slices = {}
        for name, spec in config.controllers.items():
            a = n
            for v in spec.cls.inputs:
                slot((name, v))
            b = n
            for v in spec.cls.outputs:
                slot((name, v))
            self.ctrl_slices[name] = (a, b, n)
        self.size = n

        def arrays(cs):
            src = np.array([self.index[c.src] for c in cs], dtype=np.int64)
            dst = np.array([self.index[c.dst] for c in cs], dtype=np.int64)
            return (src, dst, np.array([c.gain for c in cs], dtype=np.float64),
                    np.array([c.offset for c in cs], dtype=np.float64))

        self.route_fmu_instant = arrays(instant)
        self.route_ctrl_in = {
            name: arrays([c for c in config.connections if c.dst[0] == name]) for name in config.controllers
        }
        self.route_ctrl_to_fmu = arrays([c for c in config.connections if c.src[0] in config.controllers
                                         and c.dst[0] in fmus])
        # controller order: a controller feeding another runs first at a shared instant
        self.ctrl_order = _topo_order(config)


def _topo_order(config):
    names = list(config.controllers)
    deps = {n: set() for n in names}
    for c in config.connections:
        if c.src[0] in deps and c.dst[0] in deps:
            deps[c.dst[0]].add(c.src[0])
    order, state = [], {}

    def visit(n, stack):
        if state.get(n) == 2:
            return
        if state.get(n) == 1:
            raise ConfigError(f"{config.path}: controllers form a loop: {' -> '.join(stack + [n])}; "
                              "break it (e.g. feed one of them from a plant output)")
        state[n] = 1
        for d in sorted(deps[n], key=names.index):
            visit(d, stack + [n])
        state[n] = 2
        order.append(n)

    for n in names:
        visit(n, [])
    return order


class Engine:
    """Build the instances of a config and run the multi-rate loop (the Python engine).

    :class:`cosim.master.compiled.CompiledEngine` runs the same loop compiled;
    :func:`cosim.master.compiled.engine_for` picks one.

    Parameters
    ----------
    config : cosim.config.Config
    """

    def __init__(self, config):
        self.config = config
        self.layout = Layout(config)
        self.buf = np.zeros(self.layout.size)
        rates = {f"ctrl:{n}": s.rate for n, s in config.controllers.items()}
        rates["record"] = config.record.rate
        self.tb = TimeBase(rates, start=config.run.start)
        self.k_stop = self.tb.ticks(config.run.stop - config.run.start)
        if self.k_stop < 1:
            raise ConfigError(f"{config.path}: run.stop - run.start is shorter than one tick of the time base")
        # controllers with their arrays as views of the signal buffer
        self.controllers = {}
        for name in self.layout.ctrl_order:
            spec = config.controllers[name]
            ctrl = spec.cls(rate=spec.rate, jit=spec.jit, **spec.parameters)
            a, b, c = self.layout.ctrl_slices[name]
            ctrl.u = self.buf[a:b]
            ctrl.y = self.buf[b:c]
            ctrl._y0 = np.zeros(c - b)
            self.controllers[name] = ctrl
        # ME step bound: the fastest clock's period / substeps, or solver.max_step
        fastest = min(c.period for c in self.tb.clocks.values())
        h = float(fastest * self.tb.base.denominator) / self.tb.base.numerator / config.solver.substeps
        if config.solver.max_step > 0:
            h = config.solver.max_step
        self.h_max = h
        self._columns()
        self.plant = None

    def _columns(self):
        cfg = self.config
        counts = {}
        for inst, var in cfg.record.signals:
            if inst in cfg.fmus:
                counts[var] = counts.get(var, 0) + 1
        self.signals = {}
        self.units = {"time": "s"}
        for inst, var in cfg.record.signals:
            if inst in cfg.fmus:
                name = var if counts[var] == 1 else f"{inst}.{var}"
                unit = cfg.fmus[inst].info.variables[var].unit
            else:
                name = f"{inst}.{var}"
                unit = cfg.controllers[inst].cls.units.get(var, "")
            self.signals[name] = (inst, var)
            self.units[name] = unit
        self.rec_idx = np.array([self.layout.index[s] for s in self.signals.values()], dtype=np.int64)

    def _start_run(self, progress):
        """What both engines do before the loop: controllers reset, a fresh plant, empty recording arrays, and
        whether to show progress (None: when the run has more than 200,000 instants).

        Returns (sorted clock periods, rec, times, plant, progress)."""
        cfg = self.config
        periods = sorted({c.period for c in self.tb.clocks.values()})
        n_rows = self.k_stop // self.tb.clocks["record"].period + 1
        rec = np.full((n_rows, len(self.rec_idx)), np.nan)
        times = np.zeros(n_rows)
        for c in self.controllers.values():
            c.reset()
        self.buf[:] = 0.0
        self.plant = PlantSystem(cfg, self.layout, self.buf)
        n_inst = sum(self.k_stop // p + 1 for p in periods)
        if progress is None:
            progress = cfg.run.progress if cfg.run.progress != "auto" else n_inst > 200_000
        return periods, rec, times, self.plant, progress

    def _progress_bar(self):
        """A tqdm bar on stderr counting simulated seconds."""
        from tqdm import tqdm

        cfg = self.config
        return tqdm(total=round(cfg.run.stop - cfg.run.start, 6), unit="sim s", desc=cfg.name, leave=False,
                    bar_format="{l_bar}{bar}| {n:.3f}/{total:.3f} sim s [{elapsed}<{remaining}]")

    def run(self, progress=None):
        """Run from start to stop; returns a :class:`RunResult` (partial if interrupted by Ctrl-C).

        Parameters
        ----------
        progress : bool or None
            Show a tqdm bar on stderr; None: when the run has more than 200,000 instants.
        """
        cfg = self.config
        tb = self.tb
        k_stop = self.k_stop
        clocks = tb.clocks
        rec_p = clocks["record"].period
        ctrl = [(name, self.controllers[name], clocks[f"ctrl:{name}"].period, self.layout.route_ctrl_in[name])
                for name in self.layout.ctrl_order]
        periods, rec, times, plant, progress = self._start_run(progress)
        calls = {name: 0 for name in self.controllers}
        c2f = self.layout.route_ctrl_to_fmu
        has_c2f = len(c2f[0]) > 0
        rec_idx = self.rec_idx
        buf = self.buf
        h_max = self.h_max
        route = kernels.route
        bar = self._progress_bar() if progress else None
        interrupted = False
        row = 0
        k = 0
        t = tb.time(0)
        shown = 0.0
        wall0 = _time.perf_counter()
        try:
            plant.push_instant_inputs()  # FMU inputs from unconnected controller outputs start at 0
            while True:
                # -- the per-instant kernel --
                plant.sample(t)
                plant.route_instant()
                if k < k_stop:
                    for name, c, p, (src, dst, gain, off) in ctrl:
                        if k % p == 0:
                            route(buf, src, dst, gain, off)
                            c.step(t)
                            calls[name] += 1
                    if has_c2f:
                        route(buf, *c2f)
                    plant.push_instant_inputs()
                if k % rec_p == 0:
                    times[row] = t
                    rec[row] = buf[rec_idx]
                    row += 1
                if k >= k_stop:
                    break
                k_next = k_stop
                for p in periods:
                    kn = (k // p + 1) * p
                    if kn < k_next:
                        k_next = kn
                t_next = tb.time(k_next)
                plant.advance(t, t_next, h_max)
                k, t = k_next, t_next
                if bar is not None and t - shown > 0.002 * bar.total:
                    bar.update(t - cfg.run.start - bar.n)
                    shown = t
        except KeyboardInterrupt:
            interrupted = True
        finally:
            wall = _time.perf_counter() - wall0
            if bar is not None:
                bar.close()
            plant.close()
            self.plant = None
        dtype = [("time", "f8")] + [(name, "f8") for name in self.signals]
        data = np.zeros(row, dtype=dtype)
        data["time"] = times[:row]
        for j, name in enumerate(self.signals):
            data[name] = rec[:row, j]
        return RunResult(
            data=data,
            units=dict(self.units),
            calls=calls,
            interrupted=interrupted,
            wall_s=wall,
            sim_s=float(times[row - 1] - cfg.run.start) if row else 0.0,
            signals=dict(self.signals),
            controller_values={n: dict(c.values) for n, c in self.controllers.items()},
            engine="python",
            engine_note=getattr(self, "engine_note", ""),
        )
