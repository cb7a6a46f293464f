"""The per-instant loop in Python: the part of a run :class:`cosim.master.engine.Engine` swaps.

The work of one sample instant ``k`` is:

1. bring the plant to ``t_k`` and read the sampled FMU variables into the signal buffer;
2. route FMU-to-FMU connections that act at instants (to/from Co-Simulation FMUs);
3. for each controller due at ``k`` (in dependency order): route its inputs, ``step(t_k)``;
4. route controller outputs to FMU inputs and send them (zero-order hold until the next instant);
   stop with a NonFiniteError when a value or state is NaN or infinite (:mod:`cosim.master.finite`);
5. record a row if the recorder is due;
6. advance the plant to the next instant (ME: RK4 substeps or an implicit solver; CS: doStep).

Controllers are called at every instant ``t0 + j / rate`` with ``t < stop``; the recorder at every
``t0 + j / rate <= stop``. :class:`cosim.master.compiled.CompiledLoop` does the same in one numba
kernel. A loop has ``name``, ``start(plant)`` (returns the seconds spent compiling or loading
kernels), ``run(n)`` (at most ``n`` instants; True when the last one is done), ``tick`` (the next
instant) and ``call_counts()``.
"""

from cosim.master.finite import all_finite, nonfinite_error
from cosim.master.kernels import route

__all__ = ["PythonLoop"]


class PythonLoop:
    """The per-instant loop in Python (see the module docstring).

    Parameters
    ----------
    engine : cosim.master.engine.Engine
        The set-up the loop runs: its layout, buffer, time base, controllers, step bound and recorder.
    """

    name = "python"

    def __init__(self, engine):
        self.engine = engine
        clocks = engine.tb.clocks
        lay = engine.layout
        self.ctrl = [(engine.controllers[name], clocks[f"ctrl:{name}"].period, lay.route_ctrl_in[name])
                     for name in lay.ctrl_order]
        self.periods = sorted({c.period for c in clocks.values()})
        self.tick = 0
        self.calls = [0] * len(self.ctrl)
        self.plant = None

    def start(self, plant):
        """Start at the first instant with ``plant``; sends the initial FMU inputs (outputs not yet computed: 0)."""
        self.plant = plant
        self.tick = 0
        self.calls = [0] * len(self.ctrl)
        plant.push_instant_inputs()
        return 0.0

    def call_counts(self):
        """Number of ``step`` calls per controller so far."""
        return {name: n for name, n in zip(self.engine.layout.ctrl_order, self.calls)}

    def run(self, n):
        """Run at most ``n`` instants; True when the stop instant is done."""
        eng, plant, calls = self.engine, self.plant, self.calls
        tb, k_stop, h_max, buf, recorder = eng.tb, eng.k_stop, eng.h_max, eng.buf, eng.recorder
        rec_p = tb.clocks["record"].period
        c2f = eng.layout.route_ctrl_to_fmu
        has_c2f = len(c2f[0]) > 0
        k = self.tick
        t = tb.time(k)
        for _ in range(n):
            plant.sample(t)
            plant.route_instant()
            if k < k_stop:
                for i, (c, p, (src, dst, gain, off)) in enumerate(self.ctrl):
                    if k % p == 0:
                        route(buf, src, dst, gain, off)
                        c.step(t)
                        calls[i] += 1
                if has_c2f:
                    route(buf, *c2f)
                plant.push_instant_inputs()
            if not all_finite(buf, plant.W):
                self._nonfinite(t)
            if k % rec_p == 0:
                recorder.record(t)
            if k >= k_stop:
                return True
            k_next = k_stop
            for p in self.periods:
                kn = (k // p + 1) * p
                if kn < k_next:
                    k_next = kn
            t_next = tb.time(k_next)
            plant.advance(t, t_next, h_max)
            k, t = k_next, t_next
            self.tick = k
        return False

    def _nonfinite(self, t):
        """Raise the NonFiniteError naming the first non-finite value at instant ``t``."""
        err = nonfinite_error(self.engine.layout, self.engine.buf, self.plant, t)
        if err is not None:
            raise err
