"""The fitting contract that calibration, identification and diagnosis share.

Every fitting front end (:class:`~cosim.calibrate.Calibrator`, :class:`~cosim.calibrate.fmu_fit.FmuCalibrator`,
the haptic frequency fits, the diagnosis's :class:`~cosim.diagnose.fitting.SampleFit` and
:class:`~cosim.diagnose.fitting.LinearisedFit`) is an :class:`Estimator`, after scikit-learn's estimator API and
pysindy's ``BaseOptimizer``: ``__init__`` only stores settings, ``fit`` validates its inputs, fits and returns the
estimator itself, what it learned is in attributes ending in ``_`` (``parameters_`` always: name -> fitted value),
and a method that needs a fit raises :class:`~cosim.errors.NotFittedError` before one. The parameters a fit varies
are :class:`FreeParameter` records, never ``(start, lower, upper)`` tuples read by position.
"""

from dataclasses import dataclass

import numpy as np

from cosim.errors import ConfigError, NotFittedError

__all__ = ["FreeParameter", "free_parameters", "starts", "bounds", "Estimator"]


@dataclass(frozen=True)
class FreeParameter:
    """A parameter a fit varies: where it starts and the bounds it stays in (physical units)."""

    start: float
    lower: float
    upper: float

    def at(self, value):
        """The same bounds, starting at ``value``."""
        return FreeParameter(float(value), self.lower, self.upper)

    def clipped(self, value):
        """The same bounds, starting at ``value`` clipped into them."""
        return self.at(np.clip(value, self.lower, self.upper))

    def to_list(self):
        """``[start, lower, upper]``: its form in JSON results."""
        return [self.start, self.lower, self.upper]


def free_parameters(free):
    """``free`` (name -> :class:`FreeParameter` or a ``(start, lower, upper)`` sequence, as a user may write it)
    as name -> FreeParameter, each start checked against its bounds.

    Raises
    ------
    cosim.errors.ConfigError
        A start outside its bounds, or an entry that is neither form.
    """
    out = {}
    for name, value in free.items():
        if not isinstance(value, FreeParameter):
            try:
                start, lower, upper = (float(v) for v in value)
            except (TypeError, ValueError) as err:
                raise ConfigError(f"parameter {name}: expected a FreeParameter or (start, lower, upper); "
                                  f"got {value!r}") from err
            value = FreeParameter(start, lower, upper)
        if not value.lower <= value.start <= value.upper:
            raise ConfigError(f"parameter {name}: start {value.start:g} is outside its bounds "
                              f"[{value.lower:g}, {value.upper:g}]")
        out[name] = value
    return out


def starts(free):
    """The start values of ``free`` (name -> FreeParameter), in its order, shape (n,)."""
    return np.array([p.start for p in free.values()], float)


def bounds(free):
    """The lower and upper bounds of ``free`` (name -> FreeParameter), in its order: two arrays of shape (n,)."""
    return (np.array([p.lower for p in free.values()], float), np.array([p.upper for p in free.values()], float))


class Estimator:
    """Base of every fitting front end (module docstring): ``fit`` returns ``self`` and sets ``parameters_``."""

    def fit(self, *args, **kwargs):
        """Fit to the data given; returns ``self``."""
        raise NotImplementedError(f"{type(self).__name__} must implement fit")

    @property
    def fitted(self):
        """Whether ``fit`` has run."""
        return hasattr(self, "parameters_")

    def _check_fitted(self, method):
        """A NotFittedError naming ``method`` when ``fit`` has not run."""
        if not self.fitted:
            raise NotFittedError(f"{type(self).__name__}.{method} needs fit() first")
