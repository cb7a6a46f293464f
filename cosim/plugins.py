"""Load a user's class from ``"package.module:Class"`` or ``"path/file.py:Class"`` (controllers, summaries).

A config names the classes it runs by such a string; :func:`load_class` imports the module (a
``.py`` path relative to the config's folder is loaded once per process) and checks that the class
derives from the base class the caller expects.
"""

import hashlib
import importlib
import importlib.util
import pkgutil
import re
import sys
import traceback
from pathlib import Path

from cosim.controller import Controller
from cosim.tomldoc import did_you_mean as _close

__all__ = ["load_class", "load_controller_class"]

_CLASS = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_MODULE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


def load_class(spec, base_class, base_dir=None, kind="plugin"):
    """Import the class ``spec`` names and check that it derives from ``base_class``.

    Parameters
    ----------
    spec : str
        ``"module:Class"`` or ``"file.py:Class"``; a ``.py`` path is resolved against ``base_dir``.
    base_class : type
        The class the loaded class must derive from.
    base_dir : path-like, optional
        Directory relative file paths are resolved against (the config file's directory).
    kind : str
        What the class is, for the messages (e.g. ``"controller"``).

    Returns
    -------
    type

    Raises
    ------
    ImportError
        ``spec`` is malformed, the module cannot be found or fails while it is imported (syntax error, an
        exception: the message gives its file:line), or the class is missing or does not derive from ``base_class``.
    """
    mod_name, _, cls_name = spec.rpartition(":")
    if not (_CLASS.match(cls_name) and (mod_name.endswith(".py") or _MODULE.match(mod_name))):
        raise ImportError(f"{kind} class must be written 'package.module:Class' or 'file.py:Class'; got {spec!r}")
    if mod_name.endswith(".py"):
        module = _load_file(mod_name, base_dir, kind)
    else:
        try:
            module = importlib.import_module(mod_name)
        except ModuleNotFoundError as err:
            raise ImportError(f"{kind} module {mod_name!r} not found: {err}{_close(mod_name, _siblings(mod_name))}"
                              ) from err
        except Exception as err:  # the user's module failed while it ran: say where
            raise ImportError(_import_failure(kind, mod_name, err)) from err
    cls = getattr(module, cls_name, None)
    if cls is None:
        names = [n for n, v in vars(module).items() if isinstance(v, type) and issubclass(v, base_class)]
        raise ImportError(f"module {mod_name!r} has no class {cls_name!r}{_close(cls_name, names)}")
    if not (isinstance(cls, type) and issubclass(cls, base_class)):
        raise ImportError(f"{spec!r} is not a subclass of {base_class.__module__}.{base_class.__qualname__}")
    return cls


def _siblings(mod_name):
    """The modules of the package ``mod_name`` would be in (``controllers.foc`` for ``controllers.fco``)."""
    parent = mod_name.rpartition(".")[0]
    try:
        package = importlib.import_module(parent) if parent else None
    except Exception:  # a parent that cannot be imported has no modules to suggest
        return []
    paths = getattr(package, "__path__", None) if package else None
    return [f"{parent}.{m.name}" for m in pkgutil.iter_modules(paths)] if paths else []


def _load_file(mod_name, base_dir, kind):
    """The module of a ``.py`` file, loaded once per process under a name derived from its resolved path."""
    path = Path(mod_name)
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    if not path.is_file():
        raise ImportError(f"{kind} file {str(path)!r} does not exist")
    # a name of the path that every process computes alike (``hash`` of a str changes from one process to the next):
    # numba keys the compiled wrapper of a kernel on its module's name, so a name new at every run compiled it again
    key = f"_cosim_{kind}_{hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:16]}"
    module = sys.modules.get(key)
    if module is None:
        s = importlib.util.spec_from_file_location(key, path)
        module = importlib.util.module_from_spec(s)
        sys.modules[key] = module
        try:
            s.loader.exec_module(module)
        except Exception as err:  # the user's file failed while it ran: say where
            del sys.modules[key]
            raise ImportError(_import_failure(kind, str(path), err)) from err
    return module


def _import_failure(kind, name, err):
    """What went wrong importing the user's module ``name``, at the file:line where it went wrong."""
    if isinstance(err, SyntaxError):
        return f"{kind} module {name!r} has a syntax error at {err.filename}:{err.lineno}: {err.msg}"
    frames = traceback.extract_tb(err.__traceback__)
    where = next((f"{f.filename}:{f.lineno}" for f in reversed(frames) if "importlib" not in f.filename), name)
    return f"{kind} module {name!r} raised {type(err).__name__} while it was imported, at {where}: {err}"


def load_controller_class(spec, base_dir=None):
    """Import a :class:`cosim.controller.Controller` subclass (see :func:`load_class`).

    Parameters
    ----------
    spec : str
        ``"module:Class"`` or ``"file.py:Class"``.
    base_dir : path-like, optional
        Directory relative file paths are resolved against (the config file's directory).

    Returns
    -------
    type
    """
    return load_class(spec, Controller, base_dir, kind="controller")
