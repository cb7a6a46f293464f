"""Single shooting with CVODES (BDF, forward sensitivities): for stiff, non-smooth plants over long experiments
(a gripper's current staircase: contacts of 1e6 N/m and friction bristles against 5 s steps), where a
fixed-step transcription would need millions of steps. The experiment is cut into runs of constant input;
each run is one integrator call with the run's samples as its output grid. Derivatives with respect to the
parameters are exact (CasADi's sensitivity equations of the same lowered Modelica model)."""

import casadi as ca
import numpy as np

__all__ = ["SingleShooting"]


class SingleShooting:
    """Residuals and their exact Jacobian for scaled free parameters ``q`` (see :class:`Transcription` for the
    meaning of the arguments)."""

    def __init__(self, model, experiment, outputs, free, fixed=None, scale=None, rtol=1e-7, atol=1e-9):
        names = [p.name for p in model.parameters]
        self.model, self.experiment = model, experiment
        self.free = list(free)
        self.scale = np.ones(len(self.free)) if scale is None else np.asarray(scale, dtype=float)
        self.defaults = model.parameter_values
        for name, value in (fixed or {}).items():
            self.defaults[names.index(name)] = value
        self.free_index = [names.index(n) for n in self.free]
        self.out_index = [model.index("outputs", n) for n in outputs]
        self.rtol, self.atol = rtol, atol
        self._integrators = {}
        self._build()

    def _integrator(self, grid):
        key = tuple(np.round(grid, 12))
        if key not in self._integrators:
            m = self.model
            x = ca.MX.sym("x", len(m.states))
            u = ca.MX.sym("u", len(m.inputs))
            q = ca.MX.sym("q", len(self.free))
            t, t0 = ca.MX.sym("t"), ca.MX.sym("t0")
            # Only the free parameters enter as integrator parameters: CasADi computes forward sensitivities
            # with respect to every integrator parameter.
            dae = {"x": x, "p": ca.vertcat(u, q, t0), "t": t, "ode": m.ode(x, u, self._parameters(q), t + t0)}
            self._integrators[key] = ca.integrator(
                f"run{len(self._integrators)}", "cvodes", dae, 0.0, list(key),
                {"abstol": self.atol, "reltol": self.rtol, "max_num_steps": 1_000_000, "expand": True,
                 "fsens_err_con": True})
        return self._integrators[key]

    def _parameters(self, q):
        p = ca.MX(ca.DM(self.defaults))
        for k, i in enumerate(self.free_index):
            p[i] = q[k] * self.scale[k]
        return p

    def _build(self):
        e, m = self.experiment, self.model
        q = ca.MX.sym("q", len(self.free))
        p = self._parameters(q)
        changes = np.flatnonzero(np.any(np.diff(e.inputs, axis=0) != 0, axis=1)) + 1
        starts = np.concatenate([[0], changes])
        ends = np.concatenate([changes, [len(e.time)]])
        x = m.x0(p)
        states = []
        for a, b in zip(starts, ends):
            states.append(x)
            stop = b if b < len(e.time) else b - 1  # integrate up to the next run's first sample
            if stop == a:
                continue
            grid = e.time[a + 1:stop + 1] - e.time[a]
            run = self._integrator(grid)(x0=x, p=ca.vertcat(ca.DM(e.inputs[a]), q, e.time[a]))["xf"]
            inside = b - a - 1
            states += [run[:, j] for j in range(inside)]
            x = run[:, -1]
        X = ca.horzcat(*states[:len(e.time)])
        Y = m.out.map(len(e.time))(X, ca.DM(e.inputs.T), ca.repmat(p, 1, len(e.time)), ca.DM(e.time).T)
        Y = Y[self.out_index, :]
        weighted = (Y - ca.DM(e.measured_or_zero())) * ca.DM(e.residual_weights())
        r = ca.vec(weighted[:, np.flatnonzero(e.mask).tolist()])
        # residuals and outputs from one integration (two Functions would integrate the experiment twice)
        self._evaluate = ca.Function("evaluate", [q], [r, Y])
        self._q, self._r = q, r
        self._jacobian = None  # built on first use: a diagnosis's replays never ask for it (0.08 s a replay built)

    def evaluate(self, q):
        """(cost, weighted residuals, None, outputs at the samples) for scaled parameters ``q``."""
        r, Y = self._evaluate(q)
        r = np.array(r, dtype=float).ravel()
        return 0.5 * float(r @ r), r, None, np.array(Y, dtype=float)

    def jacobian(self, q):
        """Exact d(residual)/dq from the integrator's forward sensitivities."""
        if self._jacobian is None:
            self._jacobian = ca.Function("jacobian", [self._q], [ca.jacobian(self._r, self._q)])
        return np.array(self._jacobian(q), dtype=float)
