"""Calibration: fit model parameters to measured curves with CasADi/IPOPT and exact derivatives."""

from cosim.calibrate.data import check_measurements, load_measurements
from cosim.calibrate.estimator import Calibrator
from cosim.calibrate.problem import Experiment, Transcription

__all__ = ["Calibrator", "Experiment", "Transcription", "load_measurements",
           "check_measurements"]
