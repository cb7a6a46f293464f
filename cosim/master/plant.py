"""The FMU side of a run: instances, their routed ports in the master's signal buffer, and the
integration of the Model-Exchange FMUs between sample instants.

All Model-Exchange FMUs form one ODE system: their states are slices of one vector ``X``; an
FMU-to-FMU connection between two ME FMUs is evaluated at every derivative evaluation, in the order
given by the FMUs' declared output dependencies (an output with no declared dependencies is assumed
to depend on every input). Co-Simulation FMUs advance with ``doStep`` over each interval, their
inputs held from the interval's start.

Events of Model-Exchange FMUs (FMI 2.0 and 3.0) are handled at their own time, with the inputs held:

* state events: after each step the event indicators of the FMUs that declare some are read; a sign
  change (from > 0 to <= 0 or from < 0 to >= 0) is located by bisection on the step length, each trial
  re-integrating one RK4 step from the step's start (``EVENT_TOL`` = 1e-10 s); the implicit solvers
  locate it with ``solve_ivp(events=...)``. The step ends at the located time (on the far side of the
  crossing), the FMUs whose indicators changed sign run their event iteration, and the step goes on;
* time events: steps end at the earliest ``nextEventTime`` an FMU announced;
* step events: ``CompletedIntegratorStep`` asking for event mode.

An FMU without event indicators and without a next event time costs nothing extra: the plain RK4 loop
runs. More than ``MAX_EVENTS_AT_ONE_TIME`` events in a row, each within ``CHATTER_WINDOW`` (1e-8 s) of the
previous one, raise EventError (chattering, or a Zeno accumulation such as a ball that never comes to rest).
These rules are the functions of :mod:`cosim.master.events`, which the compiled kernel calls too.
"""

import math

import numpy as np

from cosim.errors import ConfigError, CosimError, EventError
from cosim.fmi import FmuInstance
from cosim.master.events import (CHATTER_WINDOW, EVENT_TOL, MAX_EVENTS_AT_ONE_TIME, bisection_narrow, bisection_trial,
                                 chatter, crossed, step_end, time_event_due)
from cosim.master.kernels import rk4_begin, rk4_final, rk4_stage, route

__all__ = ["PlantSystem", "FmuPool", "EVENT_TOL", "MAX_EVENTS_AT_ONE_TIME", "CHATTER_WINDOW"]



def _ports(inst, names, layout, buf):
    """Ports over ``names`` of ``inst``, one per run of consecutive slots of one FMI type in the signal buffer."""
    items = sorted((layout.index[(inst.name, n)], n) for n in dict.fromkeys(names))
    vtype = {n: inst.info.variables[n].type for _, n in items}
    ports = []
    run = []
    for idx, n in items:
        if run and (idx != run[-1][0] + 1 or vtype[n] != vtype[run[-1][1]]):
            ports.append(run)
            run = []
        run.append((idx, n))
    if run:
        ports.append(run)
    out = []
    for r in ports:
        port = inst.port([n for _, n in r])
        port.bind(buf[r[0][0]: r[0][0] + len(r)])
        out.append(port)
    return out


class FmuPool:
    """FMUs kept loaded from one run to the next (an engine running many short runs: a campaign's trials).

    Loading an FMU (unpacking, reading its description, loading its library) costs tens of ms, a tenth of a
    short run; a :class:`PlantSystem` given a pool takes its FMUs from it and gives them back freed
    (:meth:`cosim.fmi.FmuInstance.free_instance`) instead of unloading them.
    """

    def __init__(self):
        self._free = {}

    def take(self, spec):
        """A loaded FMU for ``spec`` (a :class:`cosim.config.FmuSpec`), without an instance."""
        inst = self._free.pop((spec.name, str(spec.path), spec.kind), None)
        return inst if inst is not None else FmuInstance(spec.path, name=spec.name, kind=spec.kind)

    def give(self, inst, spec):
        """Free ``inst``'s instance and keep the FMU loaded for the next :meth:`take` of ``spec``."""
        inst.free_instance()
        self._free[(spec.name, str(spec.path), spec.kind)] = inst

    def close(self):
        """Unload every FMU kept."""
        for inst in self._free.values():
            inst.close()
        self._free = {}


class PlantSystem:
    """Instances of every FMU of a config, wired into a signal buffer.

    Parameters
    ----------
    config : cosim.config.Config
    layout : cosim.master.layout.Layout
        Where each routed/recorded FMU variable lives in the signal buffer.
    buf : numpy.ndarray
        The master's signal buffer.
    pool : FmuPool, optional
        Take the FMUs from it and give them back on :meth:`close` (default: load them, unload on close).

    Attributes
    ----------
    me, cs : list of cosim.fmi.FmuInstance
        The Model-Exchange FMUs (their states form ``X``, in this order) and the Co-Simulation FMUs.
    completed : list of cosim.fmi.FmuInstance
        The ME FMUs that need ``CompletedIntegratorStep`` after each step.
    program : list of tuple
        ME-to-ME evaluation by dependency level: (get ports, route arrays, set ports) per level.
    W : numpy.ndarray
        The RK4 work array: rows X, X0, dX, K1..K4.
    event_log : list of tuple
        ``(time, instance, kind)`` of each event handled; kind is "state" (located indicator crossing),
        "time" (nextEventTime), "step" (CompletedIntegratorStep) or "input" (an indicator changed sign when
        the inputs changed at an instant).
    """

    def __init__(self, config, layout, buf, pool=None):
        self.config = config
        self.solver = config.solver
        self.instances = {}
        self._pool = pool
        try:
            for name, spec in config.fmus.items():
                self.instances[name] = pool.take(spec) if pool is not None else FmuInstance(spec.path, name=name,
                                                                                             kind=spec.kind)
            for name, spec in config.fmus.items():
                self.instances[name].setup(config.run.start, config.run.stop, spec.parameters, spec.start)
        except Exception:
            self.close()
            raise
        self.me = [i for i in self.instances.values() if i.kind == "ME"]
        self.cs = [i for i in self.instances.values() if i.kind == "CS"]
        self.completed = [i for i in self.me if i.info.needs_completed_step]
        self.evented = [i for i in self.me if i.n_indicators]  # FMUs whose indicators are read after each step
        self._z0 = [i.z.copy() for i in self.evented]  # their indicators at the last accepted point
        self._last_event = (math.nan, 0)  # (time, count) of the latest events, for the chattering guard
        self.event_log = []  # (time, instance, kind) of every event handled: kind "state", "time", "step", "input"
        self._t_next = math.inf  # the earliest next event time of the ME FMUs (kept by _next_time_event)
        self._plain = not self.evented and self.solver.method == "rk4"  # the plain RK4 loop while no time event
        self._next_time_event()
        # combined state vector
        n = sum(i.n_states for i in self.me)
        # RK4 work array: rows X, X0, dX, K1..K4 (one argument for the numba kernels)
        self.W = np.zeros((7, n))
        self.X, self.X0, self.dX, self.K = self.W[0], self.W[1], self.W[2], self.W[3:7]
        self._synced = None  # time at which the ME FMUs already hold (t, X) from sample()
        off = 0
        for inst in self.me:
            inst.bind_state_buffers(self.X[off:off + inst.n_states], self.dX[off:off + inst.n_states])
            off += inst.n_states
        # ports over the signal buffer
        self.sample_ports = []  # (inst, port): read at every instant
        self.instant_in_ports = {}  # name -> (inst, port): inputs set at instants
        for name, inst in self.instances.items():
            for port in _ports(inst, layout.fmu_sampled.get(name, []), layout, buf):
                self.sample_ports.append((inst, port))
            for port in _ports(inst, layout.fmu_instant_inputs.get(name, []), layout, buf):
                self.instant_in_ports.setdefault(name, []).append((inst, port))
        self.buf = buf
        self.program = self._stage_program(layout, buf)
        self._route_instant = layout.route_fmu_instant  # (src, dst, gain, offset) arrays

    # -- ME-to-ME evaluation order --------------------------------------------------------------
    def _stage_program(self, layout, buf):
        """Build the per-stage list of (get port, route arrays, set ports) steps, by dependency level."""
        conns = layout.me_to_me  # list of (src inst, src var, dst inst, dst var, gain, offset)
        if not conns:
            return []
        drivers = {(c[2], c[3]): (c[0], c[1]) for c in conns}
        level = {}

        def lev(out, stack=()):
            if out in level:
                return level[out]
            if out in stack:
                chain = " -> ".join(f"{a}.{b}" for a, b in stack + (out,))
                raise ConfigError(f"algebraic loop between Model-Exchange FMUs: {chain}")
            inst, var = out
            deps = self.instances[inst].info.output_deps.get(var)
            if deps is None:
                deps = self.instances[inst].info.names("input")
            lv = 0
            for d in deps:
                src = drivers.get((inst, d))
                if src is not None:
                    lv = max(lv, lev(src, stack + (out,)) + 1)
            level[out] = lv
            return lv

        outs = sorted({(c[0], c[1]) for c in conns})
        for o in outs:
            lev(o)
        program = []
        for lv in range(max(level.values()) + 1):
            step_outs = [o for o in outs if level[o] == lv]
            gets = []
            for inst_name in sorted({o[0] for o in step_outs}):
                names = [o[1] for o in step_outs if o[0] == inst_name]
                inst = self.instances[inst_name]
                gets.extend((inst, port) for port in _ports(inst, names, layout, buf))
            cs = [c for c in conns if (c[0], c[1]) in step_outs]
            src = np.array([layout.index[(c[0], c[1])] for c in cs], dtype=np.int64)
            dst = np.array([layout.index[(c[2], c[3])] for c in cs], dtype=np.int64)
            gain = np.array([c[4] for c in cs])
            off = np.array([c[5] for c in cs])
            sets = []
            for inst_name in sorted({c[2] for c in cs}):
                names = [c[3] for c in cs if c[2] == inst_name]
                inst = self.instances[inst_name]
                sets.extend((inst, port) for port in _ports(inst, names, layout, buf))
            program.append((gets, (src, dst, gain, off), sets))
        return program

    # -- evaluation ------------------------------------------------------------------------------
    def _eval(self, t, push=True):
        """Set time and states of every ME FMU, route ME-to-ME connections (X must hold the states)."""
        if push:
            for inst in self.me:
                inst.set_time(t)
                inst.push_states()
        for gets, (src, dst, gain, off), sets in self.program:
            for inst, port in gets:
                inst.get(port)
            route(self.buf, src, dst, gain, off)
            for inst, port in sets:
                inst.set(port)

    def derivatives(self, t, push=True):
        """Evaluate dX at time t for the states in X (``push=False``: the FMUs already hold t and X)."""
        self._eval(t, push)
        for inst in self.me:
            inst.pull_derivatives()

    def sample(self, t):
        """Bring every FMU to the instant t and read the sampled ports into the signal buffer."""
        if self.me:
            self._eval(t)
            self._synced = t
        for inst, port in self.sample_ports:
            inst.get(port)

    def route_instant(self):
        """Route FMU-to-FMU connections that act at instants (to or from a CS FMU) and set the inputs."""
        src, dst, gain, off = self._route_instant
        if len(src):
            route(self.buf, src, dst, gain, off)

    def push_instant_inputs(self):
        """Send the inputs held over the next interval (from controllers and CS FMUs) to the FMUs."""
        for ports in self.instant_in_ports.values():
            for inst, port in ports:
                inst.set(port)

    # -- integration -----------------------------------------------------------------------------
    def advance(self, ta, tb, h_max):
        """Advance every FMU from ta to tb (s); ME by the configured solver with steps of at most h_max."""
        if self.me:
            if self._plain and self._t_next > tb:
                if len(self.X):
                    self._rk4(ta, tb, h_max)  # no event possible: the plain loop
            else:
                self._advance_events(ta, tb, h_max)
        for inst in self.cs:
            inst.do_step(ta, tb - ta)

    def _advance_events(self, ta, tb, h_max):
        if self.evented:
            self._input_events(ta)
        if self.solver.method != "rk4" and len(self.X):
            self._implicit(ta, tb, h_max)
        else:
            self._rk4_events(ta, tb, max(1, math.ceil((tb - ta) / h_max - 1e-9)) if len(self.X) else 1)

    def _rk4(self, ta, tb, h_max):
        L = tb - ta
        n = max(1, math.ceil(L / h_max - 1e-9))
        W = self.W
        stage, final = rk4_stage, rk4_final
        deriv = self.derivatives
        # the first stage at ta can reuse (ta, X) set by sample(ta): only the inputs changed since
        synced = self._synced == ta
        self._synced = None
        rk4_begin(W)
        for j in range(n):
            t = ta + L * j / n
            t1 = ta + L * (j + 1) / n
            h = t1 - t
            th = t + 0.5 * h
            deriv(t, not (synced and j == 0))
            stage(W, 0, 0.5 * h)
            deriv(th)
            stage(W, 1, 0.5 * h)
            deriv(th)
            stage(W, 2, h)
            deriv(t1)
            final(W, h)
            if self.completed and self._complete(t1):
                rk4_begin(W)  # the event may have changed the states: the next step starts from them

    def _complete(self, t):
        """CompletedIntegratorStep at ``t`` for the FMUs that need it; step events for those that ask (then True)."""
        self._eval(t)
        asked = None
        for inst in self.completed:
            if inst.completed_integrator_step(t):
                asked = (asked or []) + [inst]
        if asked:
            self._handle_events(t, asked, "step")
        return asked is not None

    # -- events ------------------------------------------------------------------------------------
    def _next_time_event(self):
        self._t_next = min((inst.next_event_time for inst in self.me), default=math.inf)
        return self._t_next

    def _crossed(self):
        """The evented FMUs whose indicators (just read into ``inst.z``) changed sign since ``_z0``."""
        return [inst for inst, z0 in zip(self.evented, self._z0) if crossed(z0, inst.z, 0, len(z0))]

    def _read_indicators(self):
        for inst in self.evented:
            inst.pull_indicators()

    def _accept_indicators(self):
        for inst, z0 in zip(self.evented, self._z0):
            z0[:] = inst.z

    def _input_events(self, t):
        """At an instant, after the new inputs are set: an indicator that changed sign is an event at ``t``."""
        if self._synced != t:
            self._eval(t)
        self._read_indicators()
        crossed = self._crossed()
        if crossed:
            self._handle_events(t, crossed, "input")
        else:
            self._accept_indicators()

    def _handle_events(self, t, insts, kind):
        """Event iteration of ``insts`` at ``t`` (the FMUs hold t and X); indicators re-read; chattering guard."""
        count, chattering = chatter(t, *self._last_event, CHATTER_WINDOW, MAX_EVENTS_AT_ONE_TIME)
        self._last_event = (t, count)
        if chattering:
            raise EventError(f"{insts[0].name}: more than {MAX_EVENTS_AT_ONE_TIME} events in a row less than "
                             f"{CHATTER_WINDOW:g} s apart, at t={t:.12g} s (chattering or an accumulation of events)")
        for inst in insts:
            inst.handle_event(t)
            self.event_log.append((t, inst.name, kind))
        self._next_time_event()
        self._synced = None
        if self.evented:
            self._eval(t)
            self._read_indicators()
            self._accept_indicators()

    def _time_events(self, t, synced=False):
        """Event iteration at ``t`` of the FMUs whose next event time has come (``synced``: they hold t, X)."""
        due = [inst for inst in self.me if time_event_due(inst.next_event_time, t)]
        if due:
            if not synced:
                self._eval(t)
            self._handle_events(t, due, "time")

    def _rk4_step(self, t, h, x0, k1):
        """One RK4 step of length h from (t, x0) whose first-stage derivative is k1; X holds the result."""
        W = self.W
        W[0] = x0
        W[1] = x0
        W[2] = k1
        th = t + 0.5 * h
        rk4_stage(W, 0, 0.5 * h)
        self.derivatives(th)
        rk4_stage(W, 1, 0.5 * h)
        self.derivatives(th)
        rk4_stage(W, 2, h)
        self.derivatives(t + h)
        rk4_final(W, h)

    def _trial(self, t, h, x0, k1):
        """Integrate to t + h and return the FMUs whose indicators changed sign (the FMUs hold t + h, X)."""
        self._rk4_step(t, h, x0, k1)
        self._eval(t + h)
        self._read_indicators()
        return self._crossed()

    def _locate(self, t, h, x0, k1):
        """Bisection on the step length: the shortest step (to EVENT_TOL) whose end is past a crossing.

        Returns the event time and the FMUs that cross there; X and the FMUs hold the state at that time.
        """
        lo, hi = 0.0, h
        mid = bisection_trial(lo, hi, EVENT_TOL)
        while mid >= 0:
            lo, hi = bisection_narrow(lo, hi, mid, bool(self._trial(t, mid, x0, k1)))
            mid = bisection_trial(lo, hi, EVENT_TOL)
        return t + hi, self._trial(t, hi, x0, k1)

    def _rk4_events(self, ta, tb, n):
        """RK4 from ta to tb on n equal steps, each cut at time events and located state events."""
        L = tb - ta
        self._synced = None
        j, t = 1, ta
        while t < tb:
            grid = tb if j == n else ta + L * j / n
            self._time_events(t)
            t1 = step_end(t, self._next_time_event(), grid)
            x0 = self.X.copy()
            self.derivatives(t)
            k1 = self.dX.copy()
            crossed = self._trial(t, t1 - t, x0, k1) if self.evented else None
            if crossed:
                t1, crossed = self._locate(t, t1 - t, x0, k1)
                self._handle_events(t1, crossed, "state")
            else:
                if not self.evented:
                    self._rk4_step(t, t1 - t, x0, k1)
                    self._eval(t1)
                self._accept_indicators()
                if self.completed:
                    for_step = [inst for inst in self.completed if inst.completed_integrator_step(t1)]
                    if for_step:
                        self._handle_events(t1, for_step, "step")
                self._time_events(t1, synced=True)
            if t1 >= grid:
                j += 1
            t = t1

    def _implicit(self, ta, tb, h_max):
        """scipy's solve_ivp from ta to tb, restarted at time events and at state events (located by its
        ``events=``, then moved past the crossing by at most a few EVENT_TOL on its dense output)."""
        from scipy.integrate import solve_ivp

        def f(t, x):
            self.X[:] = x
            self.derivatives(t)
            return self.dX.copy()

        method = {"bdf": "BDF", "radau": "Radau", "lsoda": "LSODA"}[self.solver.method]
        self._synced = None
        t = ta
        while t < tb:
            self._time_events(t)
            t1 = step_end(t, self._next_time_event(), tb)
            sol = solve_ivp(f, (t, t1), self.X.copy(), method=method, rtol=self.solver.rtol, atol=self.solver.atol,
                            max_step=h_max, events=self._ivp_events(), dense_output=bool(self.evented))
            if not sol.success:
                raise CosimError(f"solver {self.solver.method} failed between t={t} and t={t1}: {sol.message}")
            if sol.status == 1:
                t1 = self._past_crossing(sol.t[-1], sol.sol)
            else:
                self.X[:] = sol.y[:, -1]
                self._eval(t1)
                self._read_indicators()
            crossed = self._crossed()
            if crossed:
                self._handle_events(t1, crossed, "state")
            else:
                self._accept_indicators()
                self._time_events(t1, synced=True)
            t = t1
        if self.completed:
            self._complete(tb)

    def _ivp_events(self):
        """One terminal event function per event indicator, for solve_ivp."""
        funcs = []
        for inst in self.evented:
            for i in range(inst.n_indicators):
                def g(t, x, inst=inst, i=i):
                    self.X[:] = x
                    self._eval(t)
                    inst.pull_indicators()
                    return inst.z[i]

                g.terminal = True
                funcs.append(g)
        return funcs or None

    def _past_crossing(self, te, dense):
        """The first of te, te + EVENT_TOL, te + 2 EVENT_TOL, ... (dense output) where an indicator has crossed;
        X and the FMUs hold that state."""
        for k in range(64):
            t = te + EVENT_TOL * k
            self.X[:] = dense(t)
            self._eval(t)
            self._read_indicators()
            if self._crossed():
                return t
        raise EventError(f"{self.evented[0].name}: a state event near t={te:.12g} s: no indicator changed sign "
                         f"within {64 * EVENT_TOL:g} s of the solver's root")

    def close(self):
        """Free every instance (back to the pool, when given one), also when freeing one fails (each removes its
        unpacked files whatever happens); the first failure is raised after."""
        failed = None
        for name, inst in self.instances.items():
            try:
                if self._pool is not None:
                    self._pool.give(inst, self.config.fmus[name])
                else:
                    inst.close()
            except Exception as exc:  # a failed instance may fail again when freed: free the others first
                failed = failed or exc
        self.instances = {}
        if failed is not None:
            raise failed
