"""Fitting one model (the baseline or a candidate variant) to the measured experiment on a chosen set of samples.

Single shooting with CVODES (:class:`cosim.calibrate.shooting.SingleShooting`, the calibration's integrator of
the lowered Modelica equations) and scipy's trust-region least squares. The Jacobian is taken by forward
differences of whole replays: on the stiff gripper the forward-sensitivity Jacobian costs more than the replays
of a difference per parameter (measured on the shipped static job, 3 parameters: one replay 7.7 s, the exact
Jacobian 80 s; docs/dev/diagnose-history.md). The difference Jacobian at a fit's optimum is kept
(``columns_``): it screens the candidates (:class:`LinearisedFit`) without a replay of its columns.
"""

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from cosim.calibrate.progress import watch_residual
from cosim.calibrate.shooting import SingleShooting
from cosim.errors import ConfigError
from cosim.experiment import Experiment
from cosim.fitting import Estimator

__all__ = ["Replay", "Trials", "Fit", "Screen", "SampleFit", "LinearisedFit", "check_parameters", "weighted"]


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
DIFF_STEP = 3e-3  # forward-difference step relative to the scaled parameter (at least 1: the fit works on value/scale)


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
    :class:`SampleFit` fits when a diagnosis covers more than one record.

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


def _forward_jacobian(residual, q0, r0, hi, columns):
    """The ``columns`` (indices) of d residual / dq at ``q0`` (where it is ``r0``) by forward differences of
    ``DIFF_STEP * max(1, |q|)`` (backwards past the upper bound ``hi``); the other columns zero, as is one whose
    replay failed (no evidence)."""
    q0 = np.asarray(q0, float)
    jacobian = np.zeros((len(r0), len(q0)))
    for k in columns:
        h = DIFF_STEP * max(1.0, abs(q0[k]))
        h = h if q0[k] + h <= hi[k] else -h
        q = q0.copy()
        q[k] += h
        r = residual(q)
        jacobian[:, k] = 0.0 if np.all(r == _FAILED_REPLAY) else (r - r0) / h
    return jacobian


def _residual_function(replay, measured, weights, mask):
    """The weighted residual on ``mask`` as a function of scaled parameters, and the outputs of its last
    evaluations by parameter bytes (the fit's optimum was evaluated: no replay again to predict there)."""
    outputs = {}

    def residual(q):
        try:
            y = replay.evaluate(q)
        except RuntimeError:  # CVODES failed at these values (e.g. a stiff impact): a step the solver must reject
            return np.full(int(mask.sum()) * measured.shape[0], _FAILED_REPLAY)
        if len(outputs) > 64:
            outputs.clear()
        outputs[np.asarray(q, float).tobytes()] = y
        return weighted(y - measured, weights)[:, mask].ravel()

    return residual, outputs


@dataclass(frozen=True)
class Fit:
    """One model fitted on a set of samples: what a worker returns and the workflow's stages read.

    Attributes
    ----------
    label : str
        ``"baseline"`` or the effect's name.
    free : dict
        name -> :class:`~cosim.fitting.FreeParameter`: the parameters the fit varied, from the start it took.
    parameters : dict
        name -> fitted value.
    outputs : ndarray, shape (n_signals, N)
        The replay at the fitted values, every sample.
    chi2 : float
        Weighted sum of squares on the fitted samples.
    success : bool
        The trust-region solver's own verdict.
    columns : dict
        name -> d(weighted residual on the fitted samples)/d(value) at the optimum, by forward differences.
    """

    label: str
    free: dict
    parameters: dict
    outputs: np.ndarray
    chi2: float
    success: bool = True
    columns: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Screen:
    """A candidate screened without a fit (:class:`LinearisedFit` from its best start).

    Attributes
    ----------
    effect : str
    start : dict
        name -> FreeParameter: the start whose step predicts the lowest chi-square (its fold fits start there).
    chi2 : float
        At the start.
    chi2_predicted : float
        After one bounded Gauss-Newton step.
    delta_bic : float
        The baseline's chi-square minus ``chi2_predicted`` minus the added parameters' BIC penalty.
    refitted : bool
        Whether its fold fits ran (the screen's order decides, :func:`~cosim.diagnose.workflow.score_candidates`).
    """

    effect: str
    start: dict
    chi2: float
    chi2_predicted: float
    delta_bic: float = 0.0
    refitted: bool = False


class SampleFit(Estimator):
    """Least-squares fit of a replay's free parameters on the samples in ``mask`` (the fitting contract of
    :mod:`cosim.fitting`).

    Parameters
    ----------
    replay : Replay, Trials or cosim.diagnose.frequency.FrequencyReplay
    weights : ndarray, shape (n_signals,) or (n_signals, N)
        1 / noise level of each signal (or of each sample).
    mask : ndarray of bool, shape (N,)
    free : dict
        name -> :class:`~cosim.fitting.FreeParameter` for each of ``replay.free``.
    max_nfev : int, default 40
        Iteration limit of the trust-region solver.
    progress : callable, optional
        Gets a line per second: the replays so far, the cost, the step, the time left
        (:func:`cosim.calibrate.progress.watch_residual`).

    Attributes
    ----------
    parameters_ : dict
        Fitted values.
    outputs_ : ndarray, shape (n_signals, N)
        The replay at ``parameters_``.
    chi2_ : float
        Weighted sum of squares on ``mask``.
    success_ : bool
    columns_ : dict
        name -> d(weighted residual on ``mask``)/d(value) at the optimum, by forward differences.
    """

    def __init__(self, replay, weights, mask, free, max_nfev=40, progress=None):
        self.replay = replay
        self.weights = weights
        self.mask = mask
        self.free = free
        self.max_nfev = max_nfev
        self.progress = progress

    def fit(self, measured):
        """Fit to ``measured`` (n_signals, N); returns ``self``."""
        replay, weights, mask = self.replay, self.weights, self.mask
        scale = replay.scale
        lo, hi = _scaled_bounds(self.free, replay)
        q0 = np.clip(_scaled_starts(self.free, replay), lo, hi)
        residual, outputs = _residual_function(replay, measured, weights, mask)
        # 2-point Jacobians: n + 1 replays an iteration
        residual = watch_residual(residual, self.progress, self.max_nfev * (len(q0) + 1))
        jacobian = np.zeros((int(mask.sum()) * measured.shape[0], 0))
        if len(q0):
            # our forward differences, not scipy's "2-point": scipy's diff_step is relative to |q|, a step of 1.5e-8
            # for a parameter at 0 (a phase), below the replay's tolerance, and the fit stalls on a noise column
            last = {}

            def fun(q):
                last["q"], last["r"] = np.array(q, float), residual(q)
                return last["r"]

            def jac(q):
                r0 = last["r"] if np.array_equal(last.get("q"), q) else residual(q)
                return _forward_jacobian(residual, q, r0, hi, range(len(q)))

            solution = least_squares(fun, q0, bounds=(lo, hi), method="trf", jac=jac, x_scale=1.0, xtol=1e-6,
                                     ftol=1e-6, max_nfev=self.max_nfev)
            q, self.success_, jacobian = solution.x, bool(solution.success), solution.jac
        else:
            q, self.success_ = q0, True
        predicted = outputs.get(np.asarray(q, float).tobytes())
        self.outputs_ = replay.evaluate(q) if predicted is None else predicted
        r = weighted(self.outputs_ - measured, weights)[:, mask]
        self.chi2_ = float(np.sum(r ** 2))
        self.columns_ = {n: jacobian[:, k] / scale[k] for k, n in enumerate(replay.free)}
        self.parameters_ = dict(zip(replay.free, (q * scale).tolist()))
        return self

    def result(self, label):
        """The fit as a :class:`Fit` labelled ``label`` (what crosses processes: no replay inside)."""
        self._check_fitted("result")
        return Fit(label=label, free=dict(self.free), parameters=self.parameters_, outputs=self.outputs_,
                   chi2=self.chi2_, success=self.success_, columns=self.columns_)


class LinearisedFit(Estimator):
    """The chi-square one bounded Gauss-Newton step from the start predicts: a candidate screened without a fit
    (the fitting contract of :mod:`cosim.fitting`).

    Parameters
    ----------
    replay, weights, mask, free
        As for :class:`SampleFit`.
    columns : dict
        name -> d(weighted residual on ``mask``)/d(value) [1/unit] known from another fit (a candidate's
        baseline parameters: the baseline's Jacobian at its optimum); the other columns by forward differences,
        one replay each.

    Attributes
    ----------
    parameters_ : dict
        The step's values (within the bounds).
    chi2_start_ : float
        At the start.
    chi2_predicted_ : float
        After the step.
    replays_ : int
        Replays the screen took.
    """

    def __init__(self, replay, weights, mask, free, columns):
        self.replay = replay
        self.weights = weights
        self.mask = mask
        self.free = free
        self.columns = columns

    def fit(self, measured):
        """Take the step against ``measured`` (n_signals, N); returns ``self``."""
        replay = self.replay
        scale = replay.scale
        lo, hi = _scaled_bounds(self.free, replay)
        q0 = np.clip(_scaled_starts(self.free, replay), lo, hi)
        residual, _ = _residual_function(replay, measured, self.weights, self.mask)
        r0 = residual(q0)
        unknown = [k for k, name in enumerate(replay.free) if name not in self.columns]
        jacobian = _forward_jacobian(residual, q0, r0, hi, unknown)
        for k, name in enumerate(replay.free):
            if name in self.columns:
                jacobian[:, k] = self.columns[name] * scale[k]
        replays = 1 + len(unknown)
        step = lsq_linear(jacobian, -r0, bounds=(lo - q0, hi - q0 + 1e-15))
        self.chi2_start_ = float(r0 @ r0)
        self.chi2_predicted_ = float(np.sum((r0 + jacobian @ step.x) ** 2))
        self.parameters_ = dict(zip(replay.free, ((q0 + step.x) * scale).tolist()))
        self.replays_ = replays
        return self


def _scaled_starts(free, replay):
    """The starts of ``free`` in the replay's order, over its scale."""
    return np.array([free[n].start for n in replay.free], float) / replay.scale


def _scaled_bounds(free, replay):
    """The bounds of ``free`` in the replay's order, over its scale."""
    return (np.array([free[n].lower for n in replay.free], float) / replay.scale,
            np.array([free[n].upper for n in replay.free], float) / replay.scale)
