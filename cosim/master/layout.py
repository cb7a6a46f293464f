"""Where every routed or recorded value lives in the master's signal buffer, and the routing tables.

Every value the master moves is one float64 slot of a buffer ``buf``: each controller's ``u``/``y``
arrays and each FMU port are views of slices of it, and a connection is a triple of
indices/coefficients ``buf[dst] = gain * buf[src] + offset``. Controllers are ordered so that one
feeding another runs first at a shared instant.
"""

import numpy as np

from cosim.errors import ConfigError

__all__ = ["Layout"]


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
