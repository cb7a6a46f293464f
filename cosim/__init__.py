"""cosim: Modelica plants compiled to FMUs, co-simulated against Python controllers at their real rates.

The public API is the names of ``__all__`` (docs/reference/python.md): :func:`build`, :func:`run`, :class:`Config`,
:class:`RunResult`. They are imported on first use, so that ``import cosim`` stays instant.
"""

__version__ = "0.1.0"
__all__ = ["__version__", "build", "run", "Config", "RunResult"]

_API = ("build", "run", "Config", "RunResult")


def __getattr__(name):
    """The API's names, from :mod:`cosim.api` on first use (it imports numpy and the master)."""
    if name in _API:
        from cosim import api

        return getattr(api, name)
    raise AttributeError(f"module 'cosim' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
