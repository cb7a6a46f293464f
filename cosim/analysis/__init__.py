"""Analyses of models and runs: haptic wall stability margins, frequency-response identification, contacts.

The most used functions are available here (imported on first use, so that ``cosim`` commands that do not
need them start fast); the modules hold the rest: ``haptic_params`` (shipped tables), ``haptic_tf`` (the
papers' transfer functions), ``haptic_margins`` (sampled-wall stability, adaptive damping), ``freqresp`` /
``haptic_ident`` / ``haptic_experiments`` (identification), ``haptic_fmu`` / ``haptic_collision`` (FMU and
master runs), ``haptic_report`` (files, plots), ``haptic_cli`` (``cosim haptic ...``).
"""

import importlib

_EXPORTS = {
    "load_user_params": "haptic_params",
    "load_arm_params": "haptic_params",
    "load_uncertainty_weight": "haptic_params",
    "tf_user": "haptic_tf",
    "tf_arm": "haptic_tf",
    "wall_margins": "haptic_margins",
    "margins_table": "haptic_margins",
    "adaptive_damping": "haptic_margins",
    "DeviceUserFit": "haptic_ident",
    "ArmFit": "haptic_ident",
}

__all__ = list(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"cosim.analysis.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'cosim.analysis' has no attribute {name!r}")
