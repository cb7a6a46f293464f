"""Multi-start calibration: the same fit from several starting points, in parallel on a Dask cluster (a local
one by default, an existing scheduler when the job names its address), with a progress bar."""

import functools
from dataclasses import dataclass

import numpy as np

from cosim.calibrate.estimator import Calibrator
from cosim.experiment import align_experiment
from cosim.fitting import starts
from cosim.parallel import map_here, map_on_dask

__all__ = ["fit_multistart", "start_points", "StartFit"]


@dataclass(frozen=True)
class StartFit:
    """One start's fit, as the report needs it (built in a worker: plain values and arrays, no CasADi objects).

    ``parameters``, ``std_errors`` and ``start`` map the free parameters' names to values; ``predicted`` and
    ``predicted_before`` are the fitted outputs (one row a signal) at the fitted and the start values, on ``time``
    beside ``measured``; ``mask`` marks the samples in the cost; ``units`` maps each output to its unit."""

    start: dict
    parameters: dict
    std_errors: dict
    correlation: list
    cost_before: float
    cost_after: float
    iterations: int
    success: bool
    return_status: str
    predicted: np.ndarray
    predicted_before: np.ndarray
    time: np.ndarray
    measured: np.ndarray
    mask: np.ndarray
    units: dict

    def summary(self):
        """What calibration.json lists of each start."""
        return {"start": self.start, "parameters": self.parameters, "cost_after": self.cost_after,
                "iterations": self.iterations, "success": self.success}


def start_points(free, count, seed):
    """The job's start values first, then ``count - 1`` points drawn in the bounds (log-uniform where the
    bounds are positive and span more than two decades), reproducible from ``seed``."""
    rng = np.random.default_rng(seed)
    points = [starts(free)]
    for _ in range(count - 1):
        point = []
        for p in free.values():
            lo, hi = p.lower, p.upper
            if lo > 0 and hi / lo > 100:
                point.append(float(np.exp(rng.uniform(np.log(lo), np.log(hi)))))
            else:
                point.append(float(rng.uniform(lo, hi)))
        points.append(np.array(point))
    return points


def _experiment(job, inputs, outputs):
    """The job's data aligned with the model's ``inputs`` and ``outputs``: the cost takes the samples in
    ``fit.segments`` and, with ``fit.steady_s``, only the steady end of each run of constant inputs."""
    return align_experiment(job, inputs, outputs, segments=job.segments, steady_s=job.steady_s)


def _fit_one(job, start, report=None):
    """One fit in a worker: rebuilds the model from its source (CasADi objects do not cross processes); ``report``
    gets its progress lines."""
    if job.fmu is not None:
        return _fit_one_fmu(job, start)
    from cosim.compile import lower

    model = lower(job.source, job.model)
    experiment = _experiment(job, [u.name for u in model.inputs], [o.name for o in model.outputs])
    outputs = [o for o, _, _ in job.signals]
    fit = Calibrator(model, outputs, job.free, fixed=job.fixed, substeps=job.substeps, method=job.method,
                     max_iter=job.max_iter, progress=report).fit(experiment, start=start)
    return _start_fit(job, start, fit, experiment, iterations=fit.iterations_, return_status=fit.return_status_,
                      predicted=fit.predicted_, predicted_before=fit.predict(experiment, dict(zip(job.free, start))),
                      units={o.name: o.unit for o in model.outputs})


def _fit_one_fmu(job, start):
    """The finite-difference fallback for a model known only as an FMU (no CasADi form)."""
    from cosim.calibrate.fmu_fit import FmuCalibrator, simulate_fmu_experiment
    from cosim.fmi import read_model_info

    info = read_model_info(job.fmu)
    inputs, outputs = info.names("input"), info.names("output")
    experiment = _experiment(job, inputs, outputs)
    fitted = [o for o, _, _ in job.signals]
    free = {n: p.at(s) for (n, p), s in zip(job.free.items(), start)}
    fit = FmuCalibrator(job.fmu, inputs, fitted, free, fixed=job.fixed, substeps=job.substeps).fit(experiment)
    return _start_fit(
        job, start, fit, experiment, iterations=fit.evaluations_,
        return_status="finite differences through the FMU (no CasADi form of the model)",
        predicted=simulate_fmu_experiment(job.fmu, experiment, inputs, fitted, {**job.fixed, **fit.parameters_},
                                          job.substeps),
        predicted_before=simulate_fmu_experiment(job.fmu, experiment, inputs, fitted, {**job.fixed, **fit.start_},
                                                 job.substeps),
        units={o: info.variables[o].unit for o in outputs})


def _start_fit(job, start, fit, experiment, **path_specific):
    """A :class:`StartFit` from a fitted estimator (``fit``, attributes ending in ``_``) and its experiment;
    ``path_specific``: iterations, return_status, predicted, predicted_before and units, which the CasADi and the
    FMU paths get differently."""
    return StartFit(start=dict(zip(job.free, map(float, start))), parameters=fit.parameters_,
                    std_errors=fit.std_errors_, correlation=fit.correlation_.tolist(), cost_before=fit.cost_before_,
                    cost_after=fit.cost_after_, success=fit.success_, time=experiment.time,
                    measured=experiment.measured.T, mask=experiment.mask, **path_specific)


def fit_multistart(job, progress=True):
    """Fit ``job`` from ``job.starts`` starting points; returns the best :class:`StartFit` (a successful one
    first, then the lowest cost) and every start's, in the order of :func:`start_points`."""
    points = start_points(job.free, job.starts, job.seed)
    if len(points) == 1 and not job.scheduler:
        runs = map_here(functools.partial(_fit_one, job), points, desc="fit", progress=progress, report=True)
    else:
        runs = map_on_dask(functools.partial(_fit_one, job), points, job.scheduler, desc="multi-start fits",
                           progress=progress, report=True)
    return min(runs, key=lambda r: (not r.success, r.cost_after)), list(runs)
