"""The controller interface the co-simulation master drives.

A controller is a plain Python class with

* ``parameters``: a dict of parameter names to default values (float, int, bool, a tuple of
  allowed strings whose first entry is the default, or a string such as a file name, which ``pack``
  reads and turns into numbers); a user overrides them by keyword; ``path_parameters`` names the
  string parameters that are file paths (a run config resolves them against its own folder);
* ``inputs`` / ``outputs``: tuples of signal names (what the config's ``[[connections]]`` wire);
* ``units``: an optional dict of signal or parameter name to unit string (recorded with results);
* ``limits``: the values each numeric parameter may take, as an interval (``"(0, inf)"``, ``"[0, 1]"``,
  ``"[0, inf]"`` when infinity means "never", ``"integer [1, 6]"``); checked when the controller is built, so
  a value it cannot run with is a :class:`cosim.errors.ParameterError` naming the key before any run (NaN is
  outside every interval; a parameter without an entry is not checked: any number);
* numeric state in numpy arrays: ``self.u`` (inputs, float64), ``self.y`` (outputs, float64),
  ``self.x`` (state, float64) and ``self.p`` (packed numeric parameters, float64);
* ``step(t)``: read ``self.u``, update ``self.x``, write ``self.y``.

``step`` calls the class's ``kernel(t, u, y, x, p)``, a *module-level function* written in the subset
of Python numba compiles (floats, numpy arrays, ``math``; no Python objects). ``step`` calls
the numba-compiled kernel (:mod:`cosim.jit`) when numba can compile it (``jit=True``, the default)
and the plain function otherwise; the compiled engine of the master (issue 8) calls the same kernel from its
compiled loop. A subclass therefore writes four things: the class attributes above, ``pack`` (turns
the parameter dict into the float array ``p`` the kernel reads, deriving gains etc. if needed),
``initial_state`` (the float array ``x`` at the start) and the kernel.

Example
-------
>>> import numpy as np
>>> def _gain_kernel(t, u, y, x, p):
...     y[0] = p[0] * u[0]
>>> class Gain(Controller):
...     parameters = {"k": 1.0}
...     inputs = ("u",)
...     outputs = ("y",)
...     kernel = staticmethod(_gain_kernel)
>>> g = Gain(rate=100.0, k=2.0)
>>> g.u[0] = 3.0
>>> g.step(0.0)
>>> float(g.y[0])
6.0
"""

import difflib
import math
import re

import numpy as np

from cosim.errors import ParameterError
from cosim.jit import compile_kernel

__all__ = ["Controller"]


class Controller:
    """Base class of every controller the master runs.

    Parameters
    ----------
    rate : float
        Sample rate in Hz (the master calls ``step`` at ``t0 + k / rate``); ``self.dt = 1 / rate``.
    jit : bool, optional
        Compile ``kernel`` with numba (default True); falls back to the plain function with a
        warning naming the reason when numba cannot compile it.
    **params
        Values for the names in ``parameters``; an unknown name raises ``TypeError`` listing the
        close names.

    Attributes
    ----------
    u, y, x, p : numpy.ndarray of float64
        Inputs, outputs, state and packed parameters; shapes ``(len(inputs),)``,
        ``(len(outputs),)``, ``(n_state,)`` and ``(n_p,)``.
    values : dict
        The full parameter dict (defaults overridden by ``params``).
    """

    parameters: dict = {}
    path_parameters: tuple = ()
    inputs: tuple = ()
    outputs: tuple = ()
    units: dict = {}
    limits: dict = {}
    # The run summaries this controller's experiments define, chosen by a config's ``[summary] kind``:
    # kind -> a class with ``signals``, ``outputs`` and ``summarize`` (docs/config.md, "[summary]").
    summaries: dict = {}
    # Names of the values of an output, for plots: output -> {value: name} (e.g. {"mode": {0: "velocity"}}).
    labels: dict = {}

    def __init__(self, rate, jit=True, **params):
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate < math.inf:
            raise ParameterError(type(self).__name__, "rate", "a number in (0, inf) Hz", rate)
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        self.values = self._merge(params)
        self.u = np.zeros(len(self.inputs))
        self.y = np.zeros(len(self.outputs))
        self.p = np.ascontiguousarray(self.pack(), dtype=np.float64)
        self.x = np.ascontiguousarray(self.initial_state(), dtype=np.float64)
        self._x0 = self.x.copy()
        self._y0 = self.y.copy()
        self._kernel = compile_kernel(type(self).kernel, type(self).__name__) if jit else type(self).kernel

    # -- what subclasses provide -------------------------------------------------------------
    @staticmethod
    def kernel(t, u, y, x, p):  # pragma: no cover - abstract
        """Advance one sample: read ``u``, update ``x`` in place, write ``y`` in place."""
        raise NotImplementedError("a Controller subclass must set kernel = staticmethod(fn)")

    def pack(self):
        """Return the float64 parameter array the kernel reads (default: values in declaration order).

        Choice parameters (tuples of strings) are packed as the index of the chosen string; string
        parameters are not packed (a class that has them overrides ``pack``).
        """
        out = []
        for name, default in self.parameters.items():
            v = self.values[name]
            if not isinstance(default, str):
                out.append(float(default.index(v)) if isinstance(default, tuple) else float(v))
        return np.array(out, dtype=np.float64)

    def initial_state(self):
        """Return the float64 state array at the start (default: empty)."""
        return np.zeros(0)

    @classmethod
    def scenario(cls, values):
        """What a run with these parameter ``values`` does, in a few words for a plot's title ('' says nothing)."""
        return ""

    # -- what the master calls ---------------------------------------------------------------
    def step(self, t):
        """Advance one sample at time ``t`` (s): reads ``self.u``, writes ``self.y``."""
        self._kernel(t, self.u, self.y, self.x, self.p)

    def reset(self):
        """Restore the initial state and zero outputs (a run starts from here)."""
        self.x[:] = self._x0
        self.y[:] = self._y0
        self.u[:] = 0.0

    @property
    def compiled(self):
        """True when ``step`` runs the numba-compiled kernel."""
        return self._kernel is not type(self).kernel

    def unit(self, name):
        """Unit string of a signal or parameter ('' when not declared)."""
        return self.units.get(name, "")

    # -- helpers ----------------------------------------------------------------------------
    def _merge(self, params):
        values = {k: (v[0] if isinstance(v, tuple) else v) for k, v in self.parameters.items()}
        for name, v in params.items():
            if name not in self.parameters:
                close = difflib.get_close_matches(name, list(self.parameters), n=3)
                hint = f"; did you mean {', '.join(close)}?" if close else ""
                raise TypeError(
                    f"{type(self).__name__}: unknown parameter {name!r}{hint} "
                    f"(known: {', '.join(self.parameters) or 'none'})"
                )
            self._check_type(name, v)
            values[name] = v
        for name, spec in self.limits.items():
            if name in values:  # (a subclass may drop a parameter of the class whose limits it extends)
                self._check_limit(name, spec, values[name])
        return values

    def _check_type(self, name, v):
        default = self.parameters[name]
        if isinstance(default, tuple):
            if v not in default:
                self.refuse(name, f"one of {', '.join(map(repr, default))}", v)
        elif isinstance(default, str):
            if not isinstance(v, str):
                self.refuse(name, "a string", v)
        elif isinstance(default, bool):
            if not isinstance(v, (bool, int)):
                self.refuse(name, "true or false", v)
        elif isinstance(v, bool) or not isinstance(v, (int, float)):
            self.refuse(name, "a number", v)

    def _check_limit(self, name, spec, v):
        """Refuse a value outside the parameter's ``limits`` interval ``spec``."""
        m = _INTERVAL.fullmatch(spec)
        if m is None:
            raise ValueError(f"{type(self).__name__}.limits[{name!r}] = {spec!r}: expected an interval such as "
                             f"'(0, inf)' or 'integer [1, 6]'")
        whole, lo_closed, lo, hi, hi_closed = m[1], m[2] == "[", float(m[3]), float(m[4]), m[5] == "]"
        inside = (lo < v or lo_closed and v == lo) and (v < hi or hi_closed and v == hi)
        if not inside or whole and math.isfinite(v) and v != math.floor(v):
            unit = self.units.get(name, "")
            self.refuse(name, f"{'a whole number' if whole else 'a number'} in {spec[len(whole or ''):]}"
                              f"{' ' + unit if unit and unit != '1' else ''}", v)

    def refuse(self, name, expected, received):
        """Raise the :class:`cosim.errors.ParameterError` of parameter ``name`` (for checks between parameters
        that ``limits`` cannot state, in a subclass's ``pack``)."""
        raise ParameterError(type(self).__name__, name, expected, received)


_INTERVAL = re.compile(r"(integer )?([\[(])\s*([-+\w.]+)\s*,\s*([-+\w.]+)\s*([\])])")
