"""The calibration estimator: fit tunable parameters of a lowered model to measured outputs with IPOPT and exact
derivatives, and report standard errors and correlations from the Jacobian at the optimum."""

import casadi as ca
import numpy as np

from cosim.calibrate.problem import Transcription
from cosim.errors import ConfigError, CosimError

__all__ = ["Calibrator", "NotFittedError"]


class NotFittedError(CosimError, AttributeError):
    """A result was asked of a Calibrator before ``fit`` ran."""


class Calibrator:
    """Least-squares calibration of model parameters (fit/predict contract: ``__init__`` only stores settings).

    Parameters
    ----------
    model : cosim.compile.LoweredModel
    outputs : list of str
        Model outputs compared with the experiment's measured columns, in order.
    free : dict
        name -> (start, lower, upper) for each parameter to fit.
    fixed : dict, optional
        name -> value: parameters held at values other than the model defaults.
    substeps : int, default 1
        Integration steps per sample interval.
    method : {"rk4", "implicit_euler"}, default "rk4"
    max_iter : int, default 200
        IPOPT iteration limit.

    Attributes (after ``fit``)
    --------------------------
    parameters_ : dict
        Fitted values.
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

    def __init__(self, model, outputs, free, fixed=None, substeps=1, method="rk4", max_iter=200):
        self.model = model
        self.outputs = outputs
        self.free = free
        self.fixed = fixed
        self.substeps = substeps
        self.method = method
        self.max_iter = max_iter

    def transcription(self, experiment):
        """The NLP for ``experiment`` (built from the settings; also used for derivative checks)."""
        starts = np.array([v[0] for v in self.free.values()], dtype=float)
        scale = np.where(starts != 0, np.abs(starts), 1.0)
        return Transcription(self.model, experiment, self.outputs, list(self.free), fixed=self.fixed,
                             scale=scale, substeps=self.substeps, method=self.method)

    def fit(self, experiment, start=None):
        """Fit the free parameters to ``experiment``; ``start`` overrides the starting values (multi-start)."""
        for name, (s, lo, hi) in self.free.items():
            if not lo <= s <= hi:
                raise ConfigError(f"parameter {name}: start {s:g} is outside its bounds [{lo:g}, {hi:g}]")
        tr = self.transcription(experiment)
        starts = np.array([v[0] for v in self.free.values()] if start is None else start, dtype=float)
        q0 = starts / tr.scale
        cost_before, _, X0, _ = tr.evaluate(q0)
        lower = np.array([v[1] for v in self.free.values()]) / tr.scale
        upper = np.array([v[2] for v in self.free.values()]) / tr.scale
        n_states = X0.size
        solver = ca.nlpsol("calibration", "ipopt", tr.nlp, {
            "ipopt": {"print_level": 0, "max_iter": self.max_iter, "tol": 1e-10, "sb": "yes"},
            "print_time": False,
        })
        solution = solver(x0=np.concatenate([X0, q0]),
                          lbx=np.concatenate([np.full(n_states, -np.inf), lower]),
                          ubx=np.concatenate([np.full(n_states, np.inf), upper]), lbg=0, ubg=0)
        stats = solver.stats()
        q = np.array(solution["x"], dtype=float).ravel()[n_states:]
        cost_after, residual, X, Y = tr.evaluate(q)
        jac = tr.reduced_jacobian(X, q) * 1.0
        dof = max(residual.size - q.size, 1)
        s2 = 2.0 * cost_after / dof
        cov_q = s2 * np.linalg.pinv(jac.T @ jac)
        cov = cov_q * np.outer(tr.scale, tr.scale)
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
        names = list(self.free)
        self.parameters_ = dict(zip(names, (q * tr.scale).tolist()))
        self.std_errors_ = dict(zip(names, std.tolist()))
        self.correlation_ = cov / np.outer(std, std) if np.all(std > 0) else np.full_like(cov, np.nan)
        self.cost_before_, self.cost_after_ = cost_before, cost_after
        self.iterations_ = int(stats.get("iter_count", 0))
        self.success_ = bool(stats.get("success", False))
        self.return_status_ = str(stats.get("return_status", ""))
        self.predicted_ = Y
        self.start_ = dict(zip(names, starts.tolist()))
        return self

    def predict(self, experiment, parameters=None):
        """Model outputs at the samples of ``experiment`` for ``parameters`` (default: the fitted ones)."""
        if parameters is None:
            if not hasattr(self, "parameters_"):
                raise NotFittedError("Calibrator.predict needs fit() first, or explicit parameters")
            parameters = self.parameters_
        tr = self.transcription(experiment)
        q = np.array([parameters[n] for n in self.free]) / tr.scale
        return tr.evaluate(q)[3]
