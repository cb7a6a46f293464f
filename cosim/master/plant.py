"""The FMU side of a run: instances, their routed ports in the master's signal buffer, and the
integration of the Model-Exchange FMUs between sample instants.

All Model-Exchange FMUs form one ODE system: their states are slices of one vector ``X``; an
FMU-to-FMU connection between two ME FMUs is evaluated at every derivative evaluation, in the order
given by the FMUs' declared output dependencies (an output with no declared dependencies is assumed
to depend on every input). Co-Simulation FMUs advance with ``doStep`` over each interval, their
inputs held from the interval's start.
"""

import math
import warnings

import numpy as np

from cosim.errors import ConfigError
from cosim.fmi import FmuInstance
from cosim.master.kernels import rk4_begin, rk4_final, rk4_stage, route

__all__ = ["PlantSystem"]


def _ports(inst, names, layout, buf):
    """Ports over ``names`` of ``inst``, one per run of consecutive slots in the signal buffer."""
    items = sorted((layout.index[(inst.name, n)], n) for n in dict.fromkeys(names))
    ports = []
    run = []
    for idx, n in items:
        if run and idx != run[-1][0] + 1:
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


class PlantSystem:
    """Instances of every FMU of a config, wired into a signal buffer.

    Parameters
    ----------
    config : cosim.config.Config
    layout : cosim.master.layout.Layout
        Where each routed/recorded FMU variable lives in the signal buffer.
    buf : numpy.ndarray
        The master's signal buffer.

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
    """

    def __init__(self, config, layout, buf):
        self.config = config
        self.solver = config.solver
        self.instances = {}
        try:
            for name, spec in config.fmus.items():
                self.instances[name] = FmuInstance(spec.path, name=name, kind=spec.kind)
            for name, spec in config.fmus.items():
                self.instances[name].setup(config.run.start, config.run.stop, spec.parameters, spec.start)
        except Exception:
            self.close()
            raise
        self.me = [i for i in self.instances.values() if i.kind == "ME"]
        self.cs = [i for i in self.instances.values() if i.kind == "CS"]
        for inst in self.me:
            if inst.info.n_event_indicators:
                warnings.warn(
                    f"{inst.name}: the FMU has {inst.info.n_event_indicators} event indicators; state events are "
                    "not located, discontinuities are stepped over by the fixed step",
                    stacklevel=3,
                )
        self.completed = [i for i in self.me if i.info.needs_completed_step]
        self._event_warned = False
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
        if self.me and len(self.X):
            if self.solver.method == "rk4":
                self._rk4(ta, tb, h_max)
            else:
                self._implicit(ta, tb, h_max)
        for inst in self.cs:
            inst.do_step(ta, tb - ta)

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
            if self.completed:
                self._complete(t1)

    def _complete(self, t):
        self._eval(t)
        for inst in self.completed:
            if inst.completed_integrator_step() and not self._event_warned:
                self._event_warned = True
                warnings.warn(f"{inst.name}: the FMU asked for event mode at t={t}; events are not handled",
                              stacklevel=4)

    def _implicit(self, ta, tb, h_max):
        from scipy.integrate import solve_ivp

        def f(t, x):
            self.X[:] = x
            self.derivatives(t)
            return self.dX.copy()

        self._synced = None
        sol = solve_ivp(f, (ta, tb), self.X.copy(), method=self.solver.method.upper() if self.solver.method != "lsoda"
                        else "LSODA", rtol=self.solver.rtol, atol=self.solver.atol, max_step=h_max)
        if not sol.success:
            from cosim.errors import CosimError

            raise CosimError(f"solver {self.solver.method} failed between t={ta} and t={tb}: {sol.message}")
        self.X[:] = sol.y[:, -1]
        if self.completed:
            self._complete(tb)

    def close(self):
        """Free every instance."""
        for inst in self.instances.values():
            inst.close()
        self.instances = {}
