"""Transcription of a calibration problem into a CasADi NLP on the lowered model's exact equations.

The experiment's time grid (the data samples, refined by ``substeps``) carries one state vector per grid point
as a decision variable (multiple shooting with a node at every grid point): consecutive nodes are tied by one
integration step, explicit RK4 (``method = "rk4"``) or backward Euler (``method = "implicit_euler"``). For long,
stiff experiments use ``method = "single_shooting"`` (:mod:`cosim.calibrate.shooting`, CVODES). Inputs are held between samples (zero-order hold, as the master does). The cost is the weighted sum of
squared output errors at the measured samples inside the chosen segments.
"""

import casadi as ca
import numpy as np

from cosim.errors import ConfigError

__all__ = ["Transcription", "METHODS"]

METHODS = ("rk4", "implicit_euler", "single_shooting")


class Transcription:
    """The NLP of one calibration problem; builds once, solves from any starting point.

    Parameters
    ----------
    model : cosim.compile.LoweredModel
    experiment : cosim.experiment.Experiment
    outputs : list of str
        Model outputs compared with ``experiment.measured`` columns, in order.
    free : list of str
        Parameters to fit.
    fixed : dict
        Parameter values that replace the model defaults (name -> value).
    scale : ndarray
        Typical magnitude of each free parameter; the optimiser works on parameter/scale.
    substeps : int
        Integration steps per sample interval.
    method : {"rk4", "implicit_euler"}
    """

    def __init__(self, model, experiment, outputs, free, fixed=None, scale=None, substeps=1, method="rk4"):
        if method not in METHODS[:2]:
            raise ConfigError(f"fit.method: {method!r} is not one of {', '.join(METHODS)}")
        self.model, self.experiment = model, experiment
        self.free = list(free)
        names = [p.name for p in model.parameters]
        for name in [*self.free, *(fixed or {})]:
            if name not in names:
                raise ConfigError(f"{model.name} has no tunable parameter {name!r}; it has {', '.join(names)}")
        self.out_index = [model.index("outputs", name) for name in outputs]
        self.scale = np.ones(len(self.free)) if scale is None else np.asarray(scale, dtype=float)
        self.substeps, self.method = int(substeps), method
        defaults = model.parameter_values
        for name, value in (fixed or {}).items():
            defaults[names.index(name)] = value
        self.defaults = defaults
        self.free_index = [names.index(n) for n in self.free]
        self._build()

    # -- building ---------------------------------------------------------------
    def parameter_vector(self, q):
        """Full parameter vector (symbolic or numeric) from scaled free parameters ``q``."""
        p = ca.MX(ca.DM(self.defaults)) if isinstance(q, ca.MX) else ca.DM(self.defaults)
        for k, i in enumerate(self.free_index):
            p[i] = q[k] * self.scale[k]
        return p

    def _grid(self):
        e, m = self.experiment, self.substeps
        t = e.time
        fine = (t[:-1, None] + np.diff(t)[:, None] * np.arange(m)[None, :] / m).ravel()
        fine = np.append(fine, t[-1])
        u = np.repeat(e.inputs[:-1], m, axis=0)
        u = np.vstack([u, e.inputs[-1:]]) if u.size else np.zeros((len(fine), 0))
        return fine, u

    def _build(self):
        model = self.model
        nx, nu, nq = len(model.states), len(model.inputs), len(self.free)
        x, u, p, t, h = ca.MX.sym("x", nx), ca.MX.sym("u", nu), ca.MX.sym("p", len(self.defaults)), \
            ca.MX.sym("t"), ca.MX.sym("h")
        f = model.ode
        if self.method == "rk4":
            k1 = f(x, u, p, t)
            k2 = f(x + h / 2 * k1, u, p, t + h / 2)
            k3 = f(x + h / 2 * k2, u, p, t + h / 2)
            k4 = f(x + h * k3, u, p, t + h)
            step = ca.Function("rk4_step", [x, u, p, t, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
            xn = ca.MX.sym("xn", nx)
            defect = ca.Function("defect", [x, xn, u, p, t, h], [xn - step(x, u, p, t, h)])
        else:
            xn = ca.MX.sym("xn", nx)
            defect = ca.Function("defect", [x, xn, u, p, t, h], [xn - x - h * f(xn, u, p, t + h)])
            step = None
        self.fine_time, self.fine_inputs = self._grid()
        n = len(self.fine_time)
        X = ca.MX.sym("X", nx, n)
        q = ca.MX.sym("q", nq)
        P = self.parameter_vector(q)
        T, H = self.fine_time[:-1], np.diff(self.fine_time)
        U = self.fine_inputs.T
        defects = defect.map(n - 1)(X[:, :-1], X[:, 1:], ca.DM(U[:, :-1]), ca.repmat(P, 1, n - 1),
                                    ca.DM(T).T, ca.DM(H).T)
        g = ca.vertcat(X[:, 0] - model.x0(P), ca.vec(defects))
        sample = np.arange(0, n, self.substeps)
        e = self.experiment
        Xs = X[:, sample]
        Y = model.out.map(len(sample))(Xs, ca.DM(e.inputs.T), ca.repmat(P, 1, len(sample)), ca.DM(e.time).T)
        Y = Y[self.out_index, :]
        weighted = (Y - ca.DM(e.measured_or_zero())) * ca.DM(e.residual_weights())
        residual = ca.vec(weighted[:, np.flatnonzero(e.mask).tolist()])
        self.z = ca.vertcat(ca.vec(X), q)
        self.nx, self.n, self.nq = nx, n, nq
        self.residual_fn = ca.Function("residual", [ca.vec(X), q], [residual])
        self.constraint_fn = ca.Function("constraints", [ca.vec(X), q], [g])
        self.output_fn = ca.Function("outputs", [ca.vec(X), q], [Y])
        self.nlp = {"x": self.z, "f": 0.5 * ca.sumsqr(residual), "g": g}
        self.step = step
        self.defect = defect

    # -- numeric helpers ------------------------------------------------------------
    def simulate(self, q):
        """States on the fine grid for scaled parameters ``q``, by stepping the same scheme forward."""
        p = np.array(self.parameter_vector(ca.DM(q)), dtype=float).ravel()
        x = np.array(self.model.x0(p), dtype=float).ravel()
        states = np.empty((self.nx, self.n))
        states[:, 0] = x
        if self.method == "rk4":
            run = self.step.mapaccum(self.n - 1)
            U = self.fine_inputs.T
            out = run(x, U[:, :-1], ca.repmat(ca.DM(p), 1, self.n - 1), self.fine_time[:-1][None, :],
                      np.diff(self.fine_time)[None, :])
            states[:, 1:] = np.array(out, dtype=float)
            return states
        xn = ca.MX.sym("xn", self.nx)
        for k in range(self.n - 1):
            residual = self.defect(x, xn, self.fine_inputs[k], p, self.fine_time[k], self.fine_time[k + 1] -
                                   self.fine_time[k])
            solver = ca.rootfinder("be", "newton", ca.Function("r", [xn], [residual]))
            x = np.array(solver(x), dtype=float).ravel()
            states[:, k + 1] = x
        return states

    def evaluate(self, q):
        """(cost, residual vector, states, outputs at the samples) for scaled parameters ``q``."""
        X = self.simulate(q).ravel(order="F")
        r = np.array(self.residual_fn(X, q), dtype=float).ravel()
        Y = np.array(self.output_fn(X, q), dtype=float)
        return 0.5 * float(r @ r), r, X, Y

    def reduced_jacobian(self, X, q):
        """d(residual)/d(q) along the trajectory (constraints eliminated): dr/dq - dr/dX (dg/dX)^-1 dg/dq."""
        from scipy.sparse import csc_matrix
        from scipy.sparse.linalg import spsolve

        Xs, qs = ca.MX.sym("X", X.size), ca.MX.sym("q", self.nq)
        r, g = self.residual_fn(Xs, qs), self.constraint_fn(Xs, qs)
        jac = ca.Function("jacobians", [Xs, qs],
                          [ca.jacobian(r, Xs), ca.jacobian(r, qs), ca.jacobian(g, Xs), ca.jacobian(g, qs)])
        rX, rq, gX, gq = (_sparse(m) for m in jac(X, q))
        dX_dq = -spsolve(csc_matrix(gX), gq.toarray())
        dX_dq = dX_dq.reshape(X.size, self.nq)
        return rq.toarray() + rX @ dX_dq


def _sparse(dm):
    from scipy.sparse import csc_matrix

    sp = dm.sparsity()
    return csc_matrix((np.array(dm.nonzeros()), sp.row(), sp.colind()), shape=dm.shape)
