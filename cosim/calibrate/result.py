"""The typed result of a calibration (:func:`cosim.calibrate.calibrate`): what ``calibration.json`` holds is
:meth:`CalibrationResult.to_json`."""

import math
from dataclasses import asdict, dataclass
from pathlib import Path

__all__ = ["FittedParameter", "CalibrationResult", "calibration_result"]

COST_DEFINITION = "0.5 * sum over fitted samples of ((simulated - measured) / noise)^2"


@dataclass(frozen=True)
class FittedParameter:
    """A free parameter after the fit (an entry of ``parameters`` in calibration.json).

    Attributes
    ----------
    value : float
    std_error : float or None
        One standard error; None when the fitted samples do not determine the parameter.
    identifiable : bool
    start : float
        The best start's value.
    """

    value: float
    std_error: float | None
    identifiable: bool
    start: float


@dataclass(frozen=True)
class CalibrationResult:
    """The result of a calibration job: each attribute is the key of that name in ``calibration.json``
    (:meth:`to_json`), but ``out``; ``values`` is name -> calibrated value, as parameters.toml holds them.

    Attributes
    ----------
    job, model, data : str
        The job file, the model's name, the data file.
    method : str
        The transcription, e.g. ``"single_shooting"``.
    substeps : int
    derivatives : str
        Exact (CasADi) or finite differences through the FMU.
    parameters : dict of str to FittedParameter
        The free parameters, in the job's order, each with its ``value``, ``std_error`` (one standard error,
        None when the fitted samples do not determine it), ``identifiable`` and ``start``.
    correlation : dict
        ``names`` (the free parameters) and ``matrix`` (their correlations, None where not identifiable).
    cost_before, cost_after : float
        The best start's cost at its start and at its end (``cost_definition``).
    cost_definition : str
    iterations : int
    success : bool
    return_status : str
        The optimiser's last word.
    samples : int
        The fitted samples.
    multistart : tuple of dict
        Every start's start values, cost and iterations.
    provenance : dict
        The job and data files with their SHA-256, the commit, the date, the parameters files the job read.
    out : pathlib.Path or None
        The folder written (None when nothing was).
    """

    job: str
    model: str
    data: str
    method: str
    substeps: int
    derivatives: str
    parameters: dict
    correlation: dict
    cost_before: float
    cost_after: float
    cost_definition: str
    iterations: int
    success: bool
    return_status: str
    samples: int
    multistart: tuple
    provenance: dict
    out: Path | None = None

    @property
    def values(self):
        """The calibrated values, name -> value (what parameters.toml holds)."""
        return {name: p.value for name, p in self.parameters.items()}

    def to_json(self):
        """The content of calibration.json."""
        entry = asdict(self)
        del entry["out"]
        return entry


def _finite(x):
    """``x``, or None (JSON null) when it is inf or NaN (a parameter the data do not determine)."""
    return x if math.isfinite(x) else None


def calibration_result(job, fit, runs):
    """The :class:`CalibrationResult` of a fit of ``job``: ``fit`` the best start's
    :class:`~cosim.calibrate.multistart.StartFit`, ``runs`` every start's."""
    from cosim.paramfile import provenance

    names = list(job.free)
    return CalibrationResult(
        job=str(job.path), model=job.model, data=str(job.data_path), method=job.method, substeps=job.substeps,
        derivatives=("finite differences through the FMU (the model has no CasADi form)" if job.fmu else
                     "exact (CasADi automatic differentiation of the lowered Modelica equations)"),
        parameters={n: FittedParameter(value=fit.parameters[n], std_error=_finite(fit.std_errors[n]),
                                       identifiable=math.isfinite(fit.std_errors[n]), start=fit.start[n])
                    for n in names},
        correlation={"names": names, "matrix": [[_finite(c) for c in row] for row in fit.correlation]},
        cost_before=fit.cost_before, cost_after=fit.cost_after, cost_definition=COST_DEFINITION,
        iterations=fit.iterations, success=fit.success, return_status=fit.return_status,
        samples=int(fit.mask.sum()), multistart=tuple(r.summary() for r in runs),
        provenance=provenance(job.path, [job.data_path], job.upstream))
