"""Calibration: fit model parameters to measured curves with CasADi/IPOPT and exact derivatives."""

from cosim.calibrate.estimator import Calibrator
from cosim.calibrate.problem import Transcription

__all__ = ["Calibrator", "Transcription"]
