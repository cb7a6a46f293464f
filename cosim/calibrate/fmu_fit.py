"""Calibration through an FMU binary, for models with no CasADi form (an FMU from another tool): the experiment
is replayed by fixed-step RK4 through the FMU's C functions and the fit uses scipy's least_squares with
finite-difference derivatives. Slower and less accurate than the exact-derivative fit; used only when needed."""

import numpy as np
from scipy.optimize import least_squares

from cosim.calibrate.estimator import gauss_newton_uncertainty
from cosim.fitting import Estimator, bounds, free_parameters, starts
from cosim.fmi import FmuInstance, rk4_steps

__all__ = ["simulate_fmu_experiment", "FmuCalibrator"]


def simulate_fmu_experiment(fmu, experiment, inputs, outputs, parameters, substeps=1):
    """Outputs of ``fmu`` at the experiment's samples, inputs held between samples, RK4 with ``substeps``.

    Parameters
    ----------
    fmu : path-like
    experiment : Experiment
    inputs, outputs : list of str
        FMU variable names, in the order of ``experiment.inputs`` columns and of the returned rows.
    parameters : dict
        name -> value, set before initialisation.

    Returns
    -------
    ndarray, shape (len(outputs), N)
    """
    with FmuInstance(fmu, name="calibration", kind="ME") as inst:
        inst.setup(start_time=float(experiment.time[0]), parameters=parameters)
        u_port, y_port = inst.port(inputs), inst.port(outputs)
        result = np.empty((len(outputs), len(experiment.time)))
        x = inst.x.copy()
        for k, t in enumerate(experiment.time):
            u_port.values[:] = experiment.inputs[k]
            inst.set(u_port)
            inst.set_time(t)
            inst.x[:] = x
            inst.push_states()
            inst.get(y_port)
            result[:, k] = y_port.values
            if k + 1 == len(experiment.time):
                break
            x = rk4_steps(inst, t, x, (experiment.time[k + 1] - t) / substeps, substeps)
    return result


class FmuCalibrator(Estimator):
    """Least squares through an FMU with finite-difference derivatives (scipy ``least_squares``, 'trf').

    Parameters
    ----------
    fmu : path-like
    inputs, outputs : list of str
    free : dict
        name -> :class:`~cosim.fitting.FreeParameter` (or ``(start, lower, upper)``).
    fixed : dict, optional
    substeps : int, default 1
    """

    def __init__(self, fmu, inputs, outputs, free, fixed=None, substeps=1):
        self.fmu = fmu
        self.inputs = inputs
        self.outputs = outputs
        self.free = free
        self.fixed = fixed
        self.substeps = substeps

    def _residual(self, values, experiment):
        parameters = {**(self.fixed or {}), **dict(zip(self.free, values))}
        predicted = simulate_fmu_experiment(self.fmu, experiment, self.inputs, self.outputs, parameters,
                                            self.substeps)
        weighted = (predicted - experiment.measured_or_zero()) * experiment.residual_weights()
        return weighted[:, experiment.mask].ravel()

    def fit(self, experiment):
        """Fit; sets ``parameters_``, ``std_errors_``, ``cost_before_``, ``cost_after_``, ``evaluations_``."""
        free = free_parameters(self.free)
        start = starts(free)
        r0 = self._residual(start, experiment)
        solution = least_squares(self._residual, start, bounds=bounds(free), args=(experiment,), x_scale=np.abs(start),
                                 xtol=1e-10, ftol=1e-10)
        std, self.correlation_ = gauss_newton_uncertainty(solution.jac, solution.cost, experiment.fitted_entries())
        self.start_ = dict(zip(self.free, start.tolist()))
        self.parameters_ = dict(zip(self.free, solution.x.tolist()))
        self.std_errors_ = dict(zip(self.free, std.tolist()))
        self.cost_before_, self.cost_after_ = 0.5 * float(r0 @ r0), float(solution.cost)
        self.evaluations_ = int(solution.nfev)
        self.success_ = bool(solution.success)
        return self
