"""The controller interface the co-simulation master drives.

A controller is a plain Python class with

* ``parameters``: a dict of parameter names to default values (float, int, bool, a tuple of
  allowed strings whose first entry is the default, or a string such as a file name, which ``pack``
  reads and turns into numbers); a user overrides them by keyword; ``path_parameters`` names the
  string parameters that are file paths (a run config resolves them against its own folder);
* ``inputs`` / ``outputs``: tuples of signal names (what the config's ``[[connections]]`` wire);
* ``units``: an optional dict of signal or parameter name to unit string (recorded with results);
* numeric state in numpy arrays: ``self.u`` (inputs, float64), ``self.y`` (outputs, float64),
  ``self.x`` (state, float64) and ``self.p`` (packed numeric parameters, float64);
* ``step(t)``: read ``self.u``, update ``self.x``, write ``self.y``.

``step`` calls the class's ``kernel(t, u, y, x, p)``, a *module-level function* written in the subset
of Python numba compiles (floats, numpy arrays, ``math``; no Python objects). The master calls
the numba-compiled kernel when numba can compile it (``jit=True``, the default) and the plain
function otherwise; the compiled engine of the master (issue 8) calls the same kernel from its
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
import importlib
import importlib.util
import linecache
import re
import sys
import warnings
from pathlib import Path

import numpy as np

__all__ = ["Controller", "load_controller_class", "compile_kernel", "kernel_problem", "native_kernel",
           "numba_problem"]


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

    def __init__(self, rate, jit=True, **params):
        if not rate > 0:
            raise ValueError(f"{type(self).__name__}: rate must be > 0 Hz; got {rate!r}")
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
            default = self.parameters[name]
            if isinstance(default, tuple):
                if v not in default:
                    raise ValueError(
                        f"{type(self).__name__}: parameter {name!r} must be one of {default}; got {v!r}"
                    )
            elif isinstance(default, str):
                if not isinstance(v, str):
                    raise TypeError(f"{type(self).__name__}: parameter {name!r} must be a string; got {v!r}")
            elif isinstance(default, bool):
                if not isinstance(v, (bool, int)):
                    raise TypeError(f"{type(self).__name__}: parameter {name!r} must be a bool; got {v!r}")
            elif isinstance(v, bool) or not isinstance(v, (int, float)):
                raise TypeError(f"{type(self).__name__}: parameter {name!r} must be a number; got {v!r}")
            values[name] = v
        return values


_COMPILED = {}
_WARNED = set()  # kernels whose fallback was already warned about
_PROBLEMS = {}  # kernel -> one-line reason numba could not compile it
_NATIVE = {}  # kernel -> numba cfunc wrapper (for the compiled engine)
_ANSI = re.compile(r"\x1b\[[0-9;]*m")


def numba_problem(err):
    """One line naming the construct numba rejected, from a numba compilation error.

    Parameters
    ----------
    err : Exception
        What numba raised.

    Returns
    -------
    str
        E.g. ``Unknown attribute 'append' of type list (ctl.py:12: `l.append(u)`)``.
    """
    text = _ANSI.sub("", str(err))
    lines = [ln.strip() for ln in text.splitlines()]
    head = next((ln for ln in lines if ln and not ln.startswith("Failed in ")), type(err).__name__)
    head = head.rstrip(":")
    where = None
    m = re.search(r'File "([^"]+)", line (\d+)', text) or re.search(r"Raised from (\S+) \((\d+)\)", text)
    if m:
        path, line = m.group(1), int(m.group(2))
        src = linecache.getline(path, line).strip()
        if not src:  # numba prints the path relative to the cwd sometimes: take the source line it printed
            after = text.split(m.group(0), 1)[1].splitlines()
            src = next((ln.strip() for ln in after[1:] if ln.strip() and not ln.strip().startswith("def ")), "")
        where = f"{Path(path).name}:{line}" + (f": `{src}`" if src else "")
    return f"{head} ({where})" if where else head


def kernel_problem(fn):
    """The reason numba could not compile kernel ``fn`` (None when it compiled or was not tried)."""
    return _PROBLEMS.get(fn)


def native_kernel(fn):
    """The kernel ``fn`` compiled as a numba ``cfunc`` the compiled engine calls by address.

    The C signature is ``void(double t, double* u, int64 nu, double* y, int64 ny, double* x, int64 nx,
    double* p, int64 np)`` (:data:`cosim.fmi.native.KERNEL_SIGNATURE`). Cached per kernel in the
    process and on disk.

    Raises
    ------
    numba.core.errors.NumbaError (or another exception numba raises)
        numba cannot compile the kernel; :func:`numba_problem` turns it into one line.
    """
    if fn in _NATIVE:
        return _NATIVE[fn]
    import numba

    from cosim.fmi.native import KERNEL_SIGNATURE

    kernel = compile_kernel(fn, warn=False)
    if kernel is fn:
        raise TypeError(kernel_problem(fn) or "numba cannot compile the kernel")
    cf = _cfunc_wrapper(kernel, numba, KERNEL_SIGNATURE)
    _NATIVE[fn] = cf
    return cf


def _cfunc_wrapper(kernel, numba, sig):
    carray = numba.carray

    def wrapper(t, u, nu, y, ny, x, nx, p, np_):
        kernel(t, carray(u, (nu,)), carray(y, (ny,)), carray(x, (nx,)), carray(p, (np_,)))

    try:  # the on-disk cache keys closures on their captured values (the kernel), so wrappers do not collide
        return numba.cfunc(sig, cache=True)(wrapper)
    except Exception:  # e.g. a kernel from a file numba cannot cache: compile uncached
        return numba.cfunc(sig)(wrapper)


def compile_kernel(fn, label="controller", warn=True):
    """Return ``numba.njit(fn)`` (cached per function), or ``fn`` with a warning if numba fails.

    Parameters
    ----------
    fn : callable
        A kernel ``fn(t, u, y, x, p)``.
    label : str
        Name used in the fallback warning.
    warn : bool
        Warn when numba cannot compile the kernel (the reason is kept for :func:`kernel_problem`).
    """
    if fn in _COMPILED:
        jitted = _COMPILED[fn]
        if jitted is fn and warn and fn in _PROBLEMS and fn not in _WARNED:
            _WARNED.add(fn)
            warnings.warn(f"{label}: kernel runs in plain Python, numba cannot compile it: {_PROBLEMS[fn]}",
                          stacklevel=3)
        return jitted
    try:
        import numba

        sig = "(float64, float64[::1], float64[::1], float64[::1], float64[::1])"
        try:
            # compile for the one signature the master uses, so a failure shows here and not mid-run
            jitted = numba.njit(cache=True)(fn)
            jitted.compile(sig)
        except Exception:  # e.g. no on-disk cache for a kernel loaded from a file: compile uncached
            jitted = numba.njit(fn)
            jitted.compile(sig)
    except Exception as err:  # numba raises many types; any of them means "run it in Python"
        _PROBLEMS[fn] = numba_problem(err)
        if warn:
            _WARNED.add(fn)
            warnings.warn(f"{label}: kernel runs in plain Python, numba cannot compile it: {_PROBLEMS[fn]}",
                          stacklevel=3)
        jitted = fn
    _COMPILED[fn] = jitted
    return jitted


def load_controller_class(spec, base_dir=None):
    """Import a controller class from ``"package.module:Class"`` or ``"path/file.py:Class"``.

    Parameters
    ----------
    spec : str
        Where the class lives; a ``.py`` path is resolved against ``base_dir``.
    base_dir : path-like, optional
        Directory relative file paths are resolved against (the config file's directory).

    Raises
    ------
    ImportError
        The module or class cannot be found, or the class is not a ``Controller``.
    """
    if ":" not in spec:
        raise ImportError(f"controller class {spec!r} must be written 'module:Class' or 'file.py:Class'")
    mod_name, _, cls_name = spec.rpartition(":")
    if mod_name.endswith(".py"):
        path = Path(mod_name)
        if not path.is_absolute() and base_dir is not None:
            path = Path(base_dir) / path
        if not path.is_file():
            raise ImportError(f"controller file {str(path)!r} does not exist")
        key = f"_cosim_controller_{abs(hash(str(path.resolve())))}"
        module = sys.modules.get(key)
        if module is None:
            s = importlib.util.spec_from_file_location(key, path)
            module = importlib.util.module_from_spec(s)
            sys.modules[key] = module
            s.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(mod_name)
        except ModuleNotFoundError as err:
            raise ImportError(f"controller module {mod_name!r} not found: {err}") from err
    cls = getattr(module, cls_name, None)
    if cls is None:
        names = [n for n, v in vars(module).items() if isinstance(v, type) and issubclass(v, Controller)]
        close = difflib.get_close_matches(cls_name, names, n=3)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        raise ImportError(f"module {mod_name!r} has no class {cls_name!r}{hint}")
    if not (isinstance(cls, type) and issubclass(cls, Controller)):
        raise ImportError(f"{spec!r} is not a subclass of controllers.base.Controller")
    return cls
