"""cosim: Modelica plants compiled to FMUs, co-simulated against Python controllers at their real rates.

The public API is the names of ``__all__`` (docs/reference/python.md): :func:`build`, :func:`run`,
:func:`calibrate`, :func:`diagnose`, :func:`campaign`, their results, :class:`Config` and the specs of its sections,
:class:`Controller` (the interface a user's controller implements) and :class:`CosimError` (what every error cosim
raises derives from). Everything else, the modules of the package included, is private: it may change without
notice. The names are imported on first use, so that ``import cosim`` stays instant.

``cosim.calibrate``, ``cosim.diagnose`` and ``cosim.campaign`` are also the subpackages that hold those jobs'
code: each is a module that can be called (:mod:`cosim.callable_package` says why), so ``cosim.calibrate(job,
...)`` is ``cosim.calibrate.calibrate(job, ...)`` and ``cosim.calibrate.job`` stays where it is.
"""

from cosim.kernel_cache import use_cache_dir

__version__ = "0.1.0"
__all__ = ["__version__", "build", "run", "calibrate", "diagnose", "campaign", "Config", "RunResult",
           "CalibrationResult", "Diagnosis", "CampaignResult", "RunSpec", "SolverSpec", "FmuSpec", "ControllerSpec",
           "Connection", "RecordSpec", "PlotSpec", "SummarySpec", "Controller", "CosimError"]

use_cache_dir()  # before any kernel is decorated: numba's cache in the user's cache directory (cosim.kernel_cache)

_API = {"build": "cosim.api", "run": "cosim.api", "Config": "cosim.api", "RunResult": "cosim.api",
        "CalibrationResult": "cosim.calibrate.result", "Diagnosis": "cosim.diagnose.result",
        "CampaignResult": "cosim.campaign.result", "Controller": "cosim.controller", "CosimError": "cosim.errors",
        **{spec: "cosim.config" for spec in ("RunSpec", "SolverSpec", "FmuSpec", "ControllerSpec", "Connection",
                                             "RecordSpec", "PlotSpec", "SummarySpec")}}
_CALLABLE = ("calibrate", "diagnose", "campaign")


def __getattr__(name):
    """The API's names, from their modules on first use (they import numpy and more)."""
    import importlib

    if name in _CALLABLE:  # the subpackage, which calls its function of its name
        return importlib.import_module(f"cosim.{name}")
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'cosim' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API) | set(_CALLABLE))
