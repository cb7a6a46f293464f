"""The event rules of both loops, written once: the crossing test, the bisection that locates a crossing, the
chattering guard and where a step ends for a time event.

The Python loop (:class:`cosim.master.plant.PlantSystem`) calls these numba functions from Python; the compiled
kernel (:mod:`cosim.master.ckernel`) calls the same functions inside its loop, so the two engines locate and
count events by the same code, to the bit. The kernel gets the constants as run-time data (its ``ff`` table),
never as compile-time globals; numba's on-disk cache of the kernel keys on ckernel.py only: after editing this
file, touch ckernel.py so the kernel recompiles.
"""

import numba

__all__ = ["EVENT_TOL", "MAX_EVENTS_AT_ONE_TIME", "CHATTER_WINDOW", "crossed", "bisection_trial", "bisection_narrow",
           "chatter", "step_end", "time_event_due"]

EVENT_TOL = 1e-10  # s: width of the bracket a state event is located to
MAX_EVENTS_AT_ONE_TIME = 100  # events in a row, each within CHATTER_WINDOW of the last, before EventError
CHATTER_WINDOW = 100 * EVENT_TOL  # s: events closer than this to the previous one count as one instant


@numba.njit(cache=True, _nrt=False)
def crossed(z0, z1, a, b):
    """True when one of the event indicators ``a .. b - 1`` changed sign from ``z0`` (the last accepted point) to
    ``z1`` (just read): from > 0 to <= 0, or from < 0 to >= 0 (an indicator leaving 0 is no crossing)."""
    for i in range(a, b):
        if (z0[i] > 0 and z1[i] <= 0) or (z0[i] < 0 and z1[i] >= 0):
            return True
    return False


@numba.njit(cache=True, _nrt=False)
def bisection_trial(lo, hi, tol):
    """The step length to try next when locating a crossing between the step lengths ``lo`` (no crossing) and
    ``hi`` (crossed), or -1.0 once they are at most ``tol`` apart: the event is then at ``hi``, on the far side
    of the crossing, so the FMUs see the indicator's new sign."""
    return 0.5 * (lo + hi) if hi - lo > tol else -1.0


@numba.njit(cache=True, _nrt=False)
def bisection_narrow(lo, hi, mid, hit):
    """The bracket ``(lo, hi)`` after the trial of length ``mid``: it crossed (``hit``) or not."""
    return (lo, mid) if hit else (mid, hi)


@numba.njit(cache=True, _nrt=False)
def chatter(t, last_t, count, window, max_events):
    """The chattering guard: ``(count, chattering)`` after an event at ``t``, the previous one at ``last_t`` with
    ``count`` events in a row each within ``window`` of the one before; chattering when more than
    ``max_events`` (a Zeno accumulation, or an event iteration that keeps firing)."""
    count = count + 1 if abs(t - last_t) <= window else 1
    return count, count > max_events


@numba.njit(cache=True, _nrt=False)
def step_end(t, t_event, grid):
    """Where a step from ``t`` towards the grid point ``grid`` ends: at the next time event ``t_event`` when it
    falls strictly inside, else at the grid point."""
    return t_event if t < t_event < grid else grid


@numba.njit(cache=True, _nrt=False)
def time_event_due(t_event, t):
    """True when an FMU's next time event ``t_event`` has come at ``t``."""
    return t_event <= t
