"""Fixed-step integration of a Model-Exchange FMU from Python: the state derivatives at (t, x) and RK4 steps
through them, for the off-line replays (calibration through an FMU, the haptic identification experiments).
The master integrates with its own numba kernels (:mod:`cosim.master.kernels`)."""

__all__ = ["derivatives", "rk4_steps"]


def derivatives(instance, t, x):
    """State derivatives of an ME instance at time ``t`` and state ``x``, with the inputs last set.

    Parameters
    ----------
    instance : cosim.fmi.FmuInstance
        An initialised ME instance; its state buffer ``instance.x`` is overwritten with ``x``.
    t : float
        Time, s.
    x : ndarray, shape (n_states,)

    Returns
    -------
    ndarray, shape (n_states,)
        A copy of ``dx/dt``.
    """
    instance.set_time(t)
    instance.x[:] = x
    instance.push_states()
    instance.pull_derivatives()
    return instance.dx.copy()


def rk4_steps(instance, t, x, h, substeps):
    """Advance ``x`` from ``t`` by ``substeps`` classical RK4 steps of ``h``, inputs held as last set.

    Parameters
    ----------
    instance : cosim.fmi.FmuInstance
        An initialised ME instance.
    t : float
        Start time, s; step ``j`` starts at ``t + j * h`` (not a running sum).
    x : ndarray, shape (n_states,)
        State at ``t``; not modified.
    h : float
        Step, s.
    substeps : int
        Number of steps.

    Returns
    -------
    ndarray, shape (n_states,)
        The state at ``t + substeps * h``.
    """
    for j in range(substeps):
        s = t + j * h
        k1 = derivatives(instance, s, x)
        k2 = derivatives(instance, s + h / 2, x + h / 2 * k1)
        k3 = derivatives(instance, s + h / 2, x + h / 2 * k2)
        k4 = derivatives(instance, s + h, x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x
