"""Calibration: fit model parameters to measured curves with CasADi/IPOPT and exact derivatives."""

from cosim.calibrate.data import check_measurements, load_measurements
from cosim.calibrate.estimator import Calibrator, NotFittedError
from cosim.calibrate.problem import Experiment, Transcription

__all__ = ["Calibrator", "NotFittedError", "Experiment", "Transcription", "load_measurements",
           "check_measurements"]
