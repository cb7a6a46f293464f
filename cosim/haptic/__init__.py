"""Haptic analyses of the PHANToM phi axis held by a user: wall stability margins, identification, contacts.

The most used functions are available here (imported on first use, so that ``cosim`` commands that do not
need them start fast); the modules hold the rest: ``params`` (shipped tables), ``tf`` (the papers' transfer
functions), ``margins`` (sampled-wall stability, adaptive damping), ``ident`` / ``experiments``
(identification; the generic frequency-response tools are in `cosim.freqresp`), ``fmu`` / ``collision`` (FMU
and master runs), ``report`` (files, plots), ``cli`` (``cosim haptic ...``).
"""

import importlib

_EXPORTS = {
    "load_user_params": "params",
    "load_arm_params": "params",
    "load_uncertainty_weight": "params",
    "tf_user": "tf",
    "tf_arm": "tf",
    "wall_margins": "margins",
    "margins_table": "margins",
    "adaptive_damping": "margins",
    "DeviceUserFit": "ident",
    "ArmFit": "ident",
}

__all__ = list(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"cosim.haptic.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'cosim.haptic' has no attribute {name!r}")
