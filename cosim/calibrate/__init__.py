"""Calibration: fit model parameters to measured curves with CasADi/IPOPT and exact derivatives."""

import sys

from cosim import _callable_package
from cosim.calibrate.estimator import Calibrator
from cosim.calibrate.problem import Transcription

__all__ = ["Calibrator", "Transcription"]

_callable_package(sys.modules[__name__])  # cosim.calibrate(job, ...) is cosim.api.calibrate
