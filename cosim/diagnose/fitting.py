"""Fitting one model (the baseline or a candidate variant) to the measured experiment on a chosen set of samples.

Single shooting with CVODES (:class:`cosim.calibrate.shooting.SingleShooting`, the calibration's integrator of
the lowered Modelica equations) and scipy's trust-region least squares. The Jacobian is taken by forward
differences of whole replays: with the 3-5 parameters of a diagnosis this is several times cheaper than the
forward-sensitivity Jacobian on the stiff gripper (measured: 1 s against 4 s on a 8 s staircase).
"""

import numpy as np
from scipy.optimize import least_squares

from cosim.calibrate.shooting import SingleShooting
from cosim.errors import ConfigError
from cosim.experiment import Experiment

__all__ = ["Replay", "Trials", "fit_samples", "check_parameters", "weighted"]


def check_parameters(model, names):
    """A ConfigError when ``model`` has no tunable parameter of one of ``names``."""
    known = [p.name for p in model.parameters]
    for name in names:
        if name not in known:
            raise ConfigError(f"{model.name} has no tunable parameter {name!r}")


def weighted(residual, weights):
    """``residual`` (n_signals, N) times the weights: one per signal, shape (n_signals,), or one per sample,
    shape (n_signals, N)."""
    weights = np.asarray(weights, float)
    return residual * (weights[:, None] if weights.ndim == 1 else weights)


_FAILED_REPLAY = 1e3  # weighted residual (noise levels) of every sample when a trial replay fails


class Replay:
    """Outputs of ``model`` along ``experiment`` for values of the ``free`` parameters.

    Parameters
    ----------
    model : cosim.compile.LoweredModel
    experiment : Experiment
    outputs : list of str
        Outputs compared with the measured columns, in order.
    free : list of str
        Parameters the replay varies.
    scale : ndarray, shape (len(free),)
        Typical magnitudes (the fit works on value/scale).
    fixed : dict
        name -> value held at other than the model default.
    rtol : float
        CVODES relative tolerance.
    """

    def __init__(self, model, experiment, outputs, free, scale, fixed=None, rtol=1e-6):
        check_parameters(model, [*free, *(fixed or {})])
        full = Experiment(time=experiment.time, inputs=experiment.inputs, measured=experiment.measured,
                          weights=experiment.weights, mask=np.ones(len(experiment.time), bool))
        self.free = list(free)
        self.scale = np.asarray(scale, float)
        self.shooting = SingleShooting(model, full, outputs, self.free, fixed=fixed, scale=self.scale,
                                       rtol=rtol, atol=rtol * 1e-3)
        self.evaluations = 0

    def evaluate(self, q):
        """Outputs, shape (n_signals, N), for scaled parameters ``q`` (value / scale)."""
        self.evaluations += 1
        return self.shooting.evaluate(q)[3]

    def outputs(self, values):
        """Outputs, shape (n_signals, N), for parameter ``values`` (dict or array in ``free`` order)."""
        if isinstance(values, dict):
            values = [values[n] for n in self.free]
        return self.evaluate(np.asarray(values, float) / self.scale)


class Trials:
    """Replays of several records (repeated trials) with shared free parameters, their outputs end to end: what
    :func:`fit_samples` fits when a diagnosis covers more than one record.

    Parameters
    ----------
    replays : list of Replay
        One per record, each with its own experiment and fixed values, the same ``free`` and ``scale``.
    """

    def __init__(self, replays):
        self.replays = list(replays)
        self.free, self.scale = self.replays[0].free, self.replays[0].scale

    def evaluate(self, q):
        """Outputs of every record end to end, shape (n_signals, sum of the records' N)."""
        return np.hstack([r.evaluate(q) for r in self.replays])


def fit_samples(replay, measured, weights, mask, start, bounds, max_nfev=40):
    """Least-squares fit of the replay's free parameters on the samples in ``mask``.

    Parameters
    ----------
    replay : Replay, Trials or cosim.diagnose.frequency.FrequencyReplay
    measured : ndarray, shape (n_signals, N)
    weights : ndarray, shape (n_signals,) or (n_signals, N)
        1 / noise level of each signal (or of each sample).
    mask : ndarray of bool, shape (N,)
    start : ndarray
        Starting values (physical units).
    bounds : (ndarray, ndarray)
        Lower and upper bounds.
    max_nfev : int
        Iteration limit of the trust-region solver.

    Returns
    -------
    dict
        ``parameters`` (dict), ``predicted`` (n_signals, N), ``chi2`` (weighted sum of squares on ``mask``),
        ``evaluations``, ``success``.
    """
    scale = replay.scale
    lo, hi = np.asarray(bounds[0], float) / scale, np.asarray(bounds[1], float) / scale
    q0 = np.clip(np.asarray(start, float) / scale, lo, hi)

    def residual(q):
        try:
            y = replay.evaluate(q)
        except RuntimeError:  # CVODES failed at these values (e.g. a stiff impact): a step the solver must reject
            return np.full(int(mask.sum()) * measured.shape[0], _FAILED_REPLAY)
        return weighted(y - measured, weights)[:, mask].ravel()

    if len(q0):
        solution = least_squares(residual, q0, bounds=(lo, hi), method="trf", jac="2-point", diff_step=3e-3,
                                 x_scale=1.0, xtol=1e-6, ftol=1e-6, max_nfev=max_nfev)
        q, success = solution.x, bool(solution.success)
    else:
        q, success = q0, True
    predicted = replay.evaluate(q)
    r = weighted(predicted - measured, weights)[:, mask]
    return {"parameters": dict(zip(replay.free, (q * scale).tolist())), "predicted": predicted,
            "chi2": float(np.sum(r ** 2)), "success": success}
