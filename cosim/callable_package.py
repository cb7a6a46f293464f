"""Subpackages that are also calls: ``cosim.calibrate(job)`` and ``cosim.calibrate.job`` side by side.

``cosim.calibrate``, ``cosim.diagnose`` and ``cosim.campaign`` are the subpackages that hold those jobs' code,
and importing a subpackage sets the attribute of its name on ``cosim``: a plain function of that name in
``cosim/__init__.py`` would be replaced by the module as soon as any of its modules is imported. So each of the
three is a module that can be called, and calling it calls its own function of the same name
(``cosim.calibrate.calibrate``), whether or not a module of it was imported first. This module imports nothing of
cosim, so the subpackages use it without an import cycle.
"""

import types

__all__ = ["CallablePackage", "make_callable"]


class CallablePackage(types.ModuleType):
    """A subpackage that, called, calls its function of its own name (``cosim.campaign(...)`` is
    ``cosim.campaign.campaign(...)``)."""

    def __call__(self, *args, **kwargs):
        return getattr(self, self.__name__.rpartition(".")[2])(*args, **kwargs)


def make_callable(module):
    """Make the subpackage ``module`` (``cosim.calibrate``, ...) a :class:`CallablePackage`; its contents stay."""
    module.__class__ = CallablePackage
