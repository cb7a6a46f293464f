"""Modelica libraries: the folders where a model's classes are looked for (``--modelica-path``, the
``MODELICAPATH`` environment variable, ``libraries`` in ``models.toml``), the file that holds a top-level class,
and one rumoca session per library path and thread, for the loads that need the whole library (a model rumoca
refuses, a class :mod:`~cosim.compile.library_subset` missed), so that several builds parse a library once."""

import hashlib
import os
import threading
from pathlib import Path

import rumoca

from cosim.errors import ModelicaError

__all__ = ["ENVIRONMENT_VARIABLE", "library_path", "find_class_file", "library_session", "library_fingerprint",
           "describe_path"]

ENVIRONMENT_VARIABLE = "MODELICAPATH"
"""Read as other Modelica tools read it: a list of folders separated by ``os.pathsep``."""

_SESSIONS = threading.local()  # rumoca sessions are bound to the thread that made them (unsendable PyO3 objects)


def library_path(dirs=(), environ=None):
    """The folders where libraries are looked for: ``dirs`` first, then those of ``MODELICAPATH``.

    Parameters
    ----------
    dirs : iterable of str or Path
        Folders given explicitly (``--modelica-path``, ``libraries`` of ``models.toml``), in order.
    environ : mapping, optional
        The environment to read ``MODELICAPATH`` from (default: ``os.environ``).

    Returns
    -------
    tuple of Path
        Resolved folders, each once, in order of precedence.

    Raises
    ------
    ModelicaError
        A folder that does not exist, naming where it was given.
    """
    environ = os.environ if environ is None else environ
    given = [(Path(d), "--modelica-path / libraries") for d in dirs]
    given += [(Path(d), ENVIRONMENT_VARIABLE) for d in environ.get(ENVIRONMENT_VARIABLE, "").split(os.pathsep) if d]
    roots = []
    for folder, origin in given:
        if not folder.is_dir():
            raise ModelicaError(f"library folder {folder} (from {origin}) does not exist or is not a folder; "
                                "expected a folder holding Modelica libraries, e.g. the one that holds Modelica/")
        folder = folder.resolve()
        if folder not in roots:
            roots.append(folder)
    return tuple(roots)


def _candidates(root, top):
    """Where a library folder may hold top-level class ``top`` (Modelica Language Specification 13.2.4)."""
    yield root / top / "package.mo"
    yield root / f"{top}.mo"
    for versioned in sorted(root.glob(f"{top} *")):  # "Modelica 4.1.0/package.mo", "Modelica 4.1.0.mo"
        yield versioned / "package.mo" if versioned.is_dir() else versioned


def find_class_file(name, roots):
    """The file that holds the top-level package of class ``name`` (``Modelica`` for ``Modelica.Blocks.X``).

    Returns
    -------
    Path or None
        None when no folder of ``roots`` holds it.
    """
    top = name.split(".", 1)[0]
    for root in roots:
        for candidate in _candidates(Path(root), top):
            if candidate.is_file():
                return candidate
    return None


def describe_path(roots):
    """The library path in words, for error messages."""
    if not roots:
        return (f"no library folders (give cosim build --modelica-path DIR, set {ENVIRONMENT_VARIABLE}, or list "
                "libraries = [...] in models.toml)")
    return "the library folders " + ", ".join(str(r) for r in roots)


def library_session(roots):
    """This thread's rumoca session for library path ``roots`` (made on first use; it parses each library once,
    on its first model, and re-reads the user's own files on every load)."""
    key = tuple(str(r) for r in roots)
    sessions = getattr(_SESSIONS, "by_roots", None)
    if sessions is None:
        sessions = _SESSIONS.by_roots = {}
    if key not in sessions:
        sessions[key] = rumoca.Session(roots=list(key))
    return sessions[key]


def library_fingerprint(roots):
    """A digest of every ``.mo`` file under ``roots`` (name, size, modification time): a build of a model that
    uses a library is redone when the library changes."""
    digest = hashlib.sha256()
    for root in roots:
        for mo in sorted(Path(root).rglob("*.mo")):
            stat = mo.stat()
            digest.update(f"{mo} {stat.st_size} {stat.st_mtime_ns}\n".encode())
    return digest.hexdigest()
