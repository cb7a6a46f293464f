"""Where numba keeps the compiled kernels of cosim on disk: a folder of the user's cache directory.

numba's default puts its cache beside each source file (``__pycache__``): in the checkout, in site-packages, or
in the user's own folder for a controller written there. cosim points numba at
``<user cache>/cosim/numba-<tag>`` instead (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux, ``~/Library/Caches``
on macOS, ``%LOCALAPPDATA%`` on Windows), through ``NUMBA_CACHE_DIR``, so that every process of the user shares
it: the next ``cosim run``, the workers of a local Dask cluster (they inherit the environment), ``cosim build``
compiling the kernels ahead (:func:`cosim.master.compiled.precompile`). ``<tag>`` hashes the sources the
compiled loop is built from: numba keys a cached function on its own file only, so an edit of
:mod:`cosim.fmi.native` or :mod:`cosim.master.events` (whose functions the loop inlines) would otherwise
reuse a stale loop. The FMUs' layout is run-time data of the loop (tables of addresses and offsets), never
compiled in, so one cached loop serves every FMU. A ``NUMBA_CACHE_DIR`` set by the user is kept as it is.
"""

import hashlib
import os
import sys
from pathlib import Path

__all__ = ["cache_dir", "use_cache_dir", "user_cache_root"]

_ROOT = Path(__file__).resolve().parent
_LOOP_SOURCES = ("master/ckernel.py", "master/events.py", "fmi/native.py")


def user_cache_root():
    """The platform's folder for a user's caches."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def cache_dir():
    """The folder numba caches cosim's kernels in (``NUMBA_CACHE_DIR`` when the user set it).

    Returns
    -------
    pathlib.Path
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    digest = hashlib.sha256()
    for name in _LOOP_SOURCES:
        digest.update((_ROOT / name).read_bytes())
    return user_cache_root() / "cosim" / f"numba-{digest.hexdigest()[:16]}"


def use_cache_dir():
    """Point numba's on-disk cache at :func:`cache_dir` for this process and the processes it starts."""
    path = str(cache_dir())
    os.environ["NUMBA_CACHE_DIR"] = path
    if "numba" in sys.modules:  # numba read the environment when it was imported
        sys.modules["numba"].config.CACHE_DIR = path
