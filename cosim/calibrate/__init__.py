"""Calibration: fit model parameters to measured curves with CasADi/IPOPT and exact derivatives."""

import sys

from cosim.callable_package import make_callable
from cosim.calibrate.estimator import Calibrator
from cosim.calibrate.problem import Transcription

__all__ = ["Calibrator", "Transcription", "calibrate"]

make_callable(sys.modules[__name__])  # cosim.calibrate(job, ...) is calibrate below


def calibrate(job, *, set=None, out=None, force=False, progress=False):
    """Fit the free parameters of a calibration job's model to its measured data, as ``cosim calibrate`` does;
    nothing is written unless ``out`` is given.

    Parameters
    ----------
    job : path-like
        The calibration job (.toml, docs/guide/calibrate.md).
    set : dict or sequence of str, optional
        Job keys changed first, as ``cosim calibrate --set``: ``{"multistart.count": 1}`` or
        ``["multistart.count=1"]``.
    out : path-like, optional
        Write calibration.json, parameters.toml (the calibrated set, for a run config) and fit.png there: new,
        empty, or a previous cosim output with ``force``.
    force : bool, default False
        With ``out``: replace a previous cosim output there.
    progress : bool, default False
        A progress bar over the starts' fits on stderr.

    Returns
    -------
    CalibrationResult
        What calibration.json holds: the values with their standard errors, correlations, costs, every start's
        fit, the provenance.

    Raises
    ------
    ConfigError
        The job is invalid (every problem, with its key), or ``out`` cannot be used.
    """
    from cosim.calibrate.job import run_job
    from cosim.config import override_items

    return run_job(job, out=out, overrides=override_items(set), progress=progress, force=force)
