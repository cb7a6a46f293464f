"""numba compilation of controller kernels: ``njit`` for ``Controller.step``, a ``cfunc`` for the compiled engine.

Both the controller interface (:class:`cosim.controller.Controller`, whose ``step`` calls the
compiled kernel) and the master's compiled loop (:mod:`cosim.master.compiled`, which calls the
``cfunc`` by address) use it, so it lives below both. Each kernel is compiled once per process and
cached on disk; when numba cannot compile it, the reason is kept as one line naming the construct.
"""

import contextlib
import hashlib
import linecache
import os
import re
import signal
import types
import warnings
from pathlib import Path

import numba

from cosim.fmi.native import KERNEL_SIGNATURE
from cosim.signals import handlers

__all__ = ["compile_kernel", "kernel_problem", "native_kernel", "numba_problem", "signals_deferred"]

_COMPILED = {}
_WARNED = set()  # kernels whose fallback was already warned about
_PROBLEMS = {}  # kernel -> one-line reason numba could not compile it
_NATIVE = {}  # kernel -> numba cfunc wrapper (for the compiled engine)
_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_SIGNATURE = "(float64, float64[::1], float64[::1], float64[::1], float64[::1])"


_DEFERRED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def signals_deferred():
    """Within the block, Ctrl-C, SIGTERM and SIGHUP are noted and handled as they would have been once it ends.

    numba compiles (and loads from its cache) through llvmlite, which calls back into Python by ctypes: a
    KeyboardInterrupt raised in such a callback is printed as "Exception ignored" and lost, so a Ctrl-C during a
    kernel's compilation would leave a long run going. Only in the main thread (where handlers can be set)."""
    noted = []
    try:
        with handlers(_DEFERRED, lambda signum, frame: noted.append(signum)) as previous:
            yield
    finally:
        if noted:
            handler = previous[noted[0]]
            if callable(handler):
                handler(noted[0], None)  # the handler's own answer (default_int_handler: KeyboardInterrupt)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), noted[0])


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
    """The reason numba could not compile kernel ``fn`` (None when it compiled or was not tried).

    Parameters
    ----------
    fn : callable
        A kernel ``fn(t, u, y, x, p)``.

    Returns
    -------
    str or None
    """
    return _PROBLEMS.get(fn)


def native_kernel(fn):
    """The kernel ``fn`` compiled as a numba ``cfunc`` the compiled engine calls by address.

    The C signature is ``void(double t, double* u, int64 nu, double* y, int64 ny, double* x, int64 nx,
    double* p, int64 np)`` (:data:`cosim.fmi.native.KERNEL_SIGNATURE`). Cached per kernel in the
    process and on disk.

    Parameters
    ----------
    fn : callable
        A kernel ``fn(t, u, y, x, p)``.

    Returns
    -------
    numba cfunc
        Its ``address`` is what the compiled loop calls.

    Raises
    ------
    numba.core.errors.NumbaError (or another exception numba raises)
        numba cannot compile the kernel; :func:`numba_problem` turns it into one line.
    """
    if fn in _NATIVE:
        return _NATIVE[fn]
    kernel = compile_kernel(fn, warn=False)
    if kernel is fn:
        raise TypeError(kernel_problem(fn) or "numba cannot compile the kernel")
    cf = _cfunc_wrapper(kernel)
    _NATIVE[fn] = cf
    return cf


def _call_kernel(t, u, nu, y, ny, x, nx, p, np_):
    """The C-callable body of every kernel's cfunc; ``kernel`` and ``carray`` are globals of each copy
    (:func:`_cfunc_wrapper`)."""
    kernel(t, carray(u, (nu,)), carray(y, (ny,)), carray(x, (nx,)), carray(p, (np_,)))  # noqa: F821


def _cfunc_wrapper(kernel):
    """A copy of :func:`_call_kernel` calling ``kernel``, compiled as a cfunc and cached on disk under a name of the
    kernel and of its source file's content.

    numba keys a cached closure on its captured values pickled, and a dispatcher pickles with a random id: a
    closure over the kernel missed the cache in every new process (compiled again, a new file in the cache each
    run). A copy named after the kernel (module, name, and a hash of its file, so an edit of the file compiles it
    anew: the wrapper holds the kernel's code) has an index of its own that every process finds."""
    fn = kernel.py_func
    try:
        source = Path(fn.__code__.co_filename).read_bytes()
    except OSError:  # no file to key on (e.g. a kernel typed in a notebook): compile uncached
        source = None
    digest = hashlib.sha256(f"{fn.__module__}.{fn.__qualname__}".encode() + (source or b"")).hexdigest()[:16]
    name = f"_call_kernel_{digest}"
    code = _call_kernel.__code__.replace(co_name=name, co_qualname=name)
    wrapper = types.FunctionType(code, {"kernel": kernel, "carray": numba.carray, "__name__": __name__}, name)
    if source is not None:
        try:
            return numba.cfunc(KERNEL_SIGNATURE, cache=True)(wrapper)
        except Exception:  # e.g. a kernel from a file numba cannot cache: compile uncached
            pass
    return numba.cfunc(KERNEL_SIGNATURE)(wrapper)


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

    Returns
    -------
    callable
        The compiled kernel, or ``fn`` itself when numba cannot compile it.
    """
    if fn in _COMPILED:
        jitted = _COMPILED[fn]
        if jitted is fn and warn and fn in _PROBLEMS and fn not in _WARNED:
            _WARNED.add(fn)
            warnings.warn(f"{label}: kernel runs in plain Python, numba cannot compile it: {_PROBLEMS[fn]}",
                          stacklevel=3)
        return jitted
    try:
        try:
            # compile for the one signature the master uses, so a failure shows here and not mid-run
            jitted = numba.njit(cache=True)(fn)
            jitted.compile(_SIGNATURE)
        except Exception:  # e.g. no on-disk cache for a kernel loaded from a file: compile uncached
            jitted = numba.njit(fn)
            jitted.compile(_SIGNATURE)
    except Exception as err:  # numba raises many types; any of them means "run it in Python"
        _PROBLEMS[fn] = numba_problem(err)
        if warn:
            _WARNED.add(fn)
            warnings.warn(f"{label}: kernel runs in plain Python, numba cannot compile it: {_PROBLEMS[fn]}",
                          stacklevel=3)
        jitted = fn
    _COMPILED[fn] = jitted
    return jitted
