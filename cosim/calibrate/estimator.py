"""The calibration estimator: fit tunable parameters of a lowered model to measured outputs with IPOPT and exact
derivatives, and report standard errors and correlations from the Jacobian at the optimum."""

import casadi as ca
import numpy as np

from cosim.calibrate.problem import Transcription
from cosim.calibrate.progress import IpoptProgress, watch_residual
from cosim.calibrate.shooting import SingleShooting
from cosim.fitting import Estimator, bounds, free_parameters, starts

__all__ = ["Calibrator", "gauss_newton_uncertainty"]


def gauss_newton_uncertainty(jac, cost, fitted, scale=1.0):
    """Standard errors and correlation matrix from the Jacobian of the weighted residuals at the optimum.

    The covariance is s^2 (J^T J)^-1 with s^2 = 2 cost / (fitted residuals - parameters), on the directions J
    determines. A parameter with a component along a direction J does not determine (a singular value below
    max(J.shape) * eps * the largest: the parameter has no effect on the fitted samples, alone or with others)
    is not identifiable: its standard error is inf and its correlations NaN. A pseudo-inverse would give it a
    standard error of exactly 0 instead, i.e. claim it is known perfectly.

    Parameters
    ----------
    jac : ndarray, shape (m, n)
        Jacobian of the weighted residuals with respect to the (scaled) parameters.
    cost : float
        0.5 * sum of squared weighted residuals at the optimum.
    fitted : int
        Number of fitted residuals.
    scale : float or ndarray of shape (n,)
        Converts the optimiser's scaled parameters back to physical ones.

    Returns
    -------
    std : ndarray, shape (n,)
        Standard errors (inf: not identifiable).
    correlation : ndarray, shape (n, n)
    """
    n = jac.shape[1]
    s2 = 2.0 * cost / max(fitted - n, 1)
    scale = np.broadcast_to(np.asarray(scale, dtype=float), (n,))
    _, sv, vt = np.linalg.svd(jac, full_matrices=True)
    singular = np.zeros(n)
    singular[:sv.size] = sv
    determined = singular > (singular.max() * max(jac.shape) * np.finfo(float).eps)
    identifiable = ~np.any(np.abs(vt[~determined]) > 1e-9, axis=0)
    basis = vt[determined]
    cov = s2 * (basis.T / singular[determined] ** 2) @ basis * np.outer(scale, scale)
    std = np.where(identifiable, np.sqrt(np.clip(np.diag(cov), 0, None)), np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = np.where(np.outer(identifiable, identifiable), cov / np.outer(std, std), np.nan)
    return std, correlation


class Calibrator(Estimator):
    """Least-squares calibration of model parameters (fit/predict contract: ``__init__`` only stores settings).

    Parameters
    ----------
    model : cosim.compile.LoweredModel
    outputs : list of str
        Model outputs compared with the experiment's measured columns, in order.
    free : dict
        name -> :class:`~cosim.fitting.FreeParameter` (or ``(start, lower, upper)``) for each parameter to fit.
    fixed : dict, optional
        name -> value: parameters held at values other than the model defaults.
    substeps : int, default 1
        Integration steps per sample interval.
    method : {"rk4", "implicit_euler", "single_shooting"}, default "rk4"
        The first two transcribe the experiment for IPOPT (a state node at every grid point); the third
        integrates with CVODES and fits by Gauss-Newton (scipy ``least_squares``, trust region) on the exact
        Jacobian from forward sensitivities: for stiff plants over long experiments.
    max_iter : int, default 200
        IPOPT iteration limit.
    progress : callable, optional
        Called with a line of text (iteration, cost, step, time left: :mod:`cosim.calibrate.progress`) at most once a
        second while the fit runs.

    Attributes
    ----------
    parameters_ : dict
        Fitted values (this and the attributes below are set by ``fit``).
    std_errors_ : dict
        Standard errors from the Gauss-Newton covariance s^2 (J^T J)^-1, J = d(residual)/d(parameters) along the
        trajectory, s^2 = residual sum of squares / (samples - parameters).
    correlation_ : ndarray, shape (n, n)
    cost_before_, cost_after_ : float
        0.5 * sum of squared weighted residuals at the start values and at the optimum.
    iterations_ : int
    predicted_ : ndarray, shape (n_signals, N)
        Fitted outputs at the samples.
    """

    def __init__(self, model, outputs, free, fixed=None, substeps=1, method="rk4", max_iter=200, progress=None):
        self.model = model
        self.outputs = outputs
        self.free = free
        self.fixed = fixed
        self.substeps = substeps
        self.method = method
        self.max_iter = max_iter
        self.progress = progress

    def transcription(self, experiment):
        """The problem for ``experiment``: a :class:`Transcription` (NLP) or, for single shooting, a
        :class:`SingleShooting` (also used for derivative checks)."""
        start = starts(free_parameters(self.free))
        scale = np.where(start != 0, np.abs(start), 1.0)
        if self.method == "single_shooting":
            return SingleShooting(self.model, experiment, self.outputs, list(self.free), fixed=self.fixed,
                                  scale=scale)
        return Transcription(self.model, experiment, self.outputs, list(self.free), fixed=self.fixed,
                             scale=scale, substeps=self.substeps, method=self.method)

    def fit(self, experiment, start=None):
        """Fit the free parameters to ``experiment``; ``start`` overrides the starting values (multi-start)."""
        free = free_parameters(self.free)
        tr = self.transcription(experiment)
        initial = starts(free) if start is None else np.asarray(start, dtype=float)
        q0 = initial / tr.scale
        cost_before, _, X0, _ = tr.evaluate(q0)
        lower, upper = (b / tr.scale for b in bounds(free))
        if self.method == "single_shooting":
            q, iterations, success, status = self._gauss_newton(tr, q0, lower, upper)
            return self._finish(tr, q, initial, cost_before, iterations, success, status, tr.jacobian(q))
        n_states = X0.size
        options = {"ipopt": {"print_level": 0, "max_iter": self.max_iter, "tol": 1e-10, "sb": "yes"},
                   "print_time": False}
        if self.progress is not None:
            options["iteration_callback"] = watch = IpoptProgress(n_states + q0.size, tr.nlp["g"].numel(), q0.size,
                                                                  self.progress, self.max_iter)
        solver = ca.nlpsol("calibration", "ipopt", tr.nlp, options)
        solution = solver(x0=np.concatenate([X0, q0]),
                          lbx=np.concatenate([np.full(n_states, -np.inf), lower]),
                          ubx=np.concatenate([np.full(n_states, np.inf), upper]), lbg=0, ubg=0)
        stats = solver.stats()
        if self.progress is not None:
            watch.meter.done()
        q = np.array(solution["x"], dtype=float).ravel()[n_states:]
        X = tr.evaluate(q)[2]
        return self._finish(tr, q, initial, cost_before, int(stats.get("iter_count", 0)),
                            bool(stats.get("success", False)), str(stats.get("return_status", "")),
                            tr.reduced_jacobian(X, q))

    def _gauss_newton(self, tr, q0, lower, upper):
        from scipy.optimize import least_squares

        residual = watch_residual(lambda q: tr.evaluate(q)[1], self.progress, self.max_iter)
        solution = least_squares(residual, q0, jac=tr.jacobian, bounds=(lower, upper),
                                 method="trf", x_scale="jac", xtol=1e-8, ftol=1e-10, max_nfev=self.max_iter)
        if self.progress is not None:
            residual.meter.done()
        status = f"least_squares (trust region, exact Jacobian): {solution.message}"
        return solution.x, int(solution.njev or solution.nfev), bool(solution.success), status

    def _finish(self, tr, q, initial, cost_before, iterations, success, status, jac):
        """Store the fit and its uncertainty: covariance s^2 (J^T J)^-1 at the optimum."""
        cost_after, residual, _, Y = tr.evaluate(q)
        std, self.correlation_ = gauss_newton_uncertainty(jac, cost_after, tr.experiment.fitted_entries(), tr.scale)
        names = list(self.free)
        self.parameters_ = dict(zip(names, (q * tr.scale).tolist()))
        self.std_errors_ = dict(zip(names, std.tolist()))
        self.cost_before_, self.cost_after_ = cost_before, cost_after
        self.iterations_, self.success_, self.return_status_ = iterations, success, status
        self.predicted_ = Y
        self.start_ = dict(zip(names, initial.tolist()))
        return self

    def predict(self, experiment, parameters=None):
        """Model outputs at the samples of ``experiment`` for ``parameters`` (default: the fitted ones)."""
        if parameters is None:
            self._check_fitted("predict (without explicit parameters)")
            parameters = self.parameters_
        tr = self.transcription(experiment)
        q = np.array([parameters[n] for n in self.free]) / tr.scale
        return tr.evaluate(q)[3]
