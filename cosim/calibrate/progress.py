"""Progress of a fit while it runs: iteration, cost, step and the time left, for calibrations and diagnoses.

A fit takes a ``progress`` callable (None: silent) and calls it with one line of text at most once a second. Both
of the project's optimisers report through here: :func:`watch_residual` wraps the residual function that scipy's
``least_squares`` evaluates (single-shooting calibration, the diagnosis's fits), :class:`IpoptProgress` is the
iteration callback of an IPOPT solve (the transcribed calibration). :func:`cosim.parallel.map_on_dask` carries
the lines from its workers to its progress bar.
"""

import time

import casadi as ca
import numpy as np

__all__ = ["FitProgress", "watch_residual", "IpoptProgress"]


class FitProgress:
    """Turns a fit's iterations into lines ``it 12/200  cost 1.95e+03  step 3.1e-04  2.1 s/it  ETA <= 6 min``.

    The ETA is the time the iteration limit would take at the mean time per iteration so far: an upper bound,
    since a fit usually converges before its limit.

    Parameters
    ----------
    progress : callable
        Called with each line.
    limit : int
        The fit's iteration (or evaluation) limit.
    unit : str, default "it"
        What one step of the count is ("it": an iteration, "eval": an evaluation of the residual).
    every_s : float, default 1.0
        Least time between two lines (the last one is always sent by :meth:`done`).
    """

    def __init__(self, progress, limit, unit="it", every_s=1.0):
        self.progress = progress
        self.limit = limit
        self.unit = unit
        self.every_s = every_s
        self.first = None  # (time, count) of the first update: the set-up before it is not an iteration's time
        self.last = -np.inf
        self.line = ""

    def update(self, count, cost, step):
        """Record step ``count`` (1-based) at ``cost`` after a step of norm ``step``; send a line if one is due."""
        now = time.perf_counter()
        self.first = self.first or (now, count)
        per = (now - self.first[0]) / (count - self.first[1]) if count > self.first[1] else 0.0
        left = max(self.limit - count, 0) * per
        self.line = (f"{self.unit} {count}/{self.limit}  cost {cost:.4g}  step {step:.2g}  {per:.3g} s/{self.unit}  "
                     f"ETA <= {_duration(left)}")
        if now - self.last >= self.every_s:
            self.last = now
            self.progress(self.line)

    def done(self):
        """Send the last line."""
        if self.line:
            self.progress(self.line)


def _duration(seconds):
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min" if seconds < 7200 else \
        f"{seconds / 3600:.1f} h"


def watch_residual(residual, progress, limit):
    """``residual`` for scipy's ``least_squares``, reporting each evaluation to ``progress``.

    Parameters
    ----------
    residual : callable
        ``q -> r`` (an array).
    progress : callable or None
        Gets the lines of :class:`FitProgress` (None: ``residual`` is returned unchanged).
    limit : int
        The most evaluations the fit may make (its ``max_nfev`` times the evaluations per Jacobian).

    Returns
    -------
    callable
        The same residual; each evaluation counts, the cost shown is the lowest ``0.5 * |r|^2`` so far (a trial
        step the solver rejects does not raise it), the step the distance of ``q`` from the previous evaluation's.
    """
    if progress is None:
        return residual
    meter = FitProgress(progress, limit, unit="eval")
    state = {"count": 0, "q": None, "cost": np.inf}

    def watched(q):
        r = residual(q)
        q = np.asarray(q, dtype=float)
        step = 0.0 if state["q"] is None else float(np.linalg.norm(q - state["q"]))
        state["count"] += 1
        state["q"] = q.copy()
        state["cost"] = min(state["cost"], 0.5 * float(np.dot(r, r)))
        meter.update(state["count"], state["cost"], step)
        return r

    watched.meter = meter
    return watched


class IpoptProgress(ca.Callback):
    """The ``iteration_callback`` of an IPOPT ``nlpsol``: reports the iteration, the objective and the step of the
    parameters (the last ``n_parameters`` decision variables).

    Parameters
    ----------
    n_x, n_g : int
        Decision variables and constraints of the NLP.
    n_parameters : int
        The trailing decision variables that are the fitted parameters.
    progress : callable
        Gets the lines of :class:`FitProgress`.
    limit : int
        IPOPT's ``max_iter``.
    """

    def __init__(self, n_x, n_g, n_parameters, progress, limit):
        ca.Callback.__init__(self)
        self.n_x, self.n_g, self.n_p = n_x, n_g, n_parameters
        self.meter = FitProgress(progress, limit)
        self.count = 0
        self.q = None
        self.construct("fit_progress", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        size = {"f": 1, "x": self.n_x, "lam_x": self.n_x, "g": self.n_g, "lam_g": self.n_g}.get(name, 0)
        return ca.Sparsity.dense(size, 1) if size else ca.Sparsity(0, 0)

    def eval(self, args):
        q = np.array(args[0], dtype=float).ravel()[self.n_x - self.n_p:]
        step = 0.0 if self.q is None else float(np.linalg.norm(q - self.q))
        self.count += 1
        self.q = q
        self.meter.update(self.count, float(args[1]), step)
        return [0]
