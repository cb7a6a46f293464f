"""Non-finite values: the per-instant check both loops run, and the message naming the first bad value.

Each instant, after the controllers stepped, both loops check the signal buffer (FMU outputs read at the instant,
controller inputs and outputs) and the ME FMUs' states (the compiled kernel with one comparison per value,
or-ed); only when it fails does :func:`nonfinite_error` look for the value to name: a
state, its derivative, an output.
"""

import numpy as np

from cosim.errors import NonFiniteError

__all__ = ["all_finite", "nonfinite_error"]


def all_finite(buf, W):
    """True when the signal buffer and the states (row 0 of the RK4 work array) are finite. A bad derivative makes
    the state bad within the step (RK4 and the implicit solvers use every derivative they compute), so it is
    found there, and named by :func:`nonfinite_error`.

    Parameters
    ----------
    buf, W : numpy.ndarray
    """
    return bool(np.isfinite(buf).all() and np.isfinite(W[0]).all())


def _state_names(info):
    """The state variables of an FMU in state-vector order (the model description's derivatives)."""
    import fmpy

    md = fmpy.read_model_description(str(info.path), validate=False)
    names = []
    for unknown in md.derivatives:
        state = getattr(unknown.variable, "derivative", None)
        names.append(state.name if state is not None else unknown.variable.name)
    return names


def nonfinite_error(layout, buf, plant, t):
    """The :class:`~cosim.errors.NonFiniteError` naming the first non-finite value at instant ``t``, None if none.

    States come first, then derivatives, then the values in the signal buffer by instance (FMUs, then controllers):
    a state gone bad makes the outputs computed from it bad too.

    Parameters
    ----------
    layout : cosim.master.layout.Layout
    buf : numpy.ndarray
        The signal buffer.
    plant : cosim.master.plant.PlantSystem
    t : float
        The instant (s).

    Returns
    -------
    NonFiniteError or None
    """
    for inst in plant.me:
        for values, form in ((inst.x, "{}"), (inst.dx, "der({})")):
            bad = np.flatnonzero(~np.isfinite(values))
            if len(bad):
                names = _state_names(inst.info)
                name = names[bad[0]] if bad[0] < len(names) else f"state {bad[0]}"
                return NonFiniteError(inst.name, form.format(name), t, float(values[bad[0]]))
    bad = np.flatnonzero(~np.isfinite(buf))
    if not len(bad):
        return None
    by_slot = {slot: key for key, slot in layout.index.items()}
    outputs = {(name, v) for name, names in layout.fmu_sampled.items() for v in names}
    outputs |= {by_slot[j] for a, b, c in layout.ctrl_slices.values() for j in range(b, c)}
    keys = [by_slot[int(b)] for b in bad]
    inst, var = ([k for k in keys if k in outputs] or keys)[0]  # an input is bad because an output is
    return NonFiniteError(inst, var, t, float(buf[layout.index[(inst, var)]]))
