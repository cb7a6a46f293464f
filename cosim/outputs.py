"""Output folders that never cost a user a file.

A command's results go into a staging folder beside ``--out`` and are moved into place only when the work
succeeded. A folder cosim wrote holds the marker file ``.cosim-output``; an existing ``--out`` without it holding
anything is the user's and is refused, a previous output is replaced only on request (``--force``). A lock file
beside ``--out`` keeps two commands from writing the same folder at once.
"""

import contextlib
import fcntl
import os
import secrets
import shutil
import tempfile
import warnings
from pathlib import Path

from cosim.errors import ConfigError, OutputWarning

__all__ = ["MARKER", "output_folder", "output_file", "check_output", "mark_output", "is_output", "optional_file"]

MARKER = ".cosim-output"


def is_output(folder):
    """True when ``folder`` is a folder cosim wrote (it holds the marker file).

    Parameters
    ----------
    folder : str or Path

    Returns
    -------
    bool
    """
    return (Path(folder) / MARKER).is_file()


def _check_target(out, force, option="--force"):
    """Refuse an ``out`` whose replacement could lose a user's file; True when it holds a previous output."""
    if not out.exists() and not out.is_symlink():
        return False
    if out.is_symlink() or not out.is_dir():
        raise ConfigError(f"--out {out}: exists and is not a folder; expected a new folder or a previous cosim "
                          f"output; choose another --out")
    if is_output(out):
        if not force:
            raise ConfigError(f"--out {out}: holds a previous cosim output; pass {option} to replace it, or choose "
                              f"another --out")
        return True
    if any(out.iterdir()):
        raise ConfigError(f"--out {out}: an existing folder that is not a cosim output (no {MARKER} file in it); "
                          f"cosim does not write into it, to keep your files; choose a new or empty folder (an "
                          f"output of a cosim from before {MARKER} existed: delete or move it yourself)")
    return False


def _write_marker(folder, command):
    (Path(folder) / MARKER).write_text(f"written by: cosim {command}\n", encoding="utf-8")


@contextlib.contextmanager
def _lock(out):
    """Hold an exclusive lock on ``.<name>.cosim-lock`` beside ``out``; the kernel frees it if the process dies."""
    path = out.parent / f".{out.name}.cosim-lock"
    for _ in range(3):
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise ConfigError(f"--out {out}: another cosim command is writing into it now (lock {path}); wait for "
                              f"it to end or choose another --out") from None
        try:
            if os.path.exists(path) and os.stat(path).st_ino == os.fstat(fd).st_ino:
                break  # else the holder unlinked it between our open and lock: take the new file
        except OSError:
            pass
        os.close(fd)
    else:
        raise ConfigError(f"--out {out}: could not lock {path}; try again")
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)


def _make_parent(out):
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--out {out}: cannot create its parent folder {out.parent} ({exc.strerror}); "
                          f"expected a writable location") from None


def _writable(folder, out):
    """Write and remove a probe file: the permission bits do not tell (root, read-only mounts, full disks)."""
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".cosim-probe-"):
            pass
    except OSError as exc:
        raise ConfigError(f"--out {out}: {folder} is not writable ({exc.strerror}); expected a folder cosim can "
                          f"write into; choose another --out") from None


def _sibling(out, kind):
    """A new hidden folder beside ``out``, made with the user's umask (unlike mkdtemp's 0700)."""
    for _ in range(100):
        path = out.parent / f".{out.name}.{secrets.token_hex(4)}.{kind}"
        try:
            path.mkdir()
            return path
        except FileExistsError:
            continue
    raise ConfigError(f"--out {out}: cannot make a staging folder beside it")


@contextlib.contextmanager
def output_folder(out, command, force=False):
    """A staging folder for a command's results, moved into place at ``out`` when the block succeeds.

    Parameters
    ----------
    out : str or Path
        The output folder the user asked for.
    command : str
        The command writing it (``run``, ``calibrate``...): written into the marker file.
    force : bool, default False
        Replace a previous cosim output at ``out``.

    Yields
    ------
    Path
        An empty staging folder beside ``out`` (same parent) holding the marker; write everything there.

    Raises
    ------
    ConfigError
        ``out`` exists and is not a previous cosim output (nor an empty folder), or is one and ``force`` is
        false; its location is not writable; another cosim command is writing it. All before the block runs.
    """
    out = Path(os.path.abspath(out))  # "." or "x/..": the parent is where the staging folder goes
    _make_parent(out)
    _writable(out.parent, out)
    with _lock(out):
        replace = _check_target(out, force)
        if out.exists():
            _writable(out, out)  # an immutable or read-only folder cannot be replaced either
        staging = _sibling(out, "partial")
        try:
            _write_marker(staging, command)
            yield staging
            _commit(staging, out, replace)
        finally:
            shutil.rmtree(staging, ignore_errors=True)


@contextlib.contextmanager
def output_file(out, force=False):
    """A staging file for a command's one result file, moved into place at ``out`` when the block succeeds: a
    file has no marker to tell it is a cosim output, so an existing one is replaced only on request.

    Parameters
    ----------
    out : str or Path
        The file the user asked for.
    force : bool, default False
        Replace an existing file at ``out``.

    Yields
    ------
    Path
        A new hidden file name beside ``out`` (same folder); write the result there.

    Raises
    ------
    ConfigError
        ``out`` is a folder, or exists and ``force`` is false; its folder is not writable; another cosim command
        is writing it. All before the block runs.
    """
    out = Path(os.path.abspath(out))
    _make_parent(out)
    _writable(out.parent, out)
    with _lock(out):
        if out.is_dir():
            raise ConfigError(f"--out {out}: is a folder; expected a file name, e.g. {out / 'results.csv'}")
        if (out.exists() or out.is_symlink()) and not force:
            raise ConfigError(f"--out {out}: the file exists; pass --force to replace it, or choose another --out")
        staging = out.parent / f".{out.name}.{secrets.token_hex(4)}.partial"
        try:
            yield staging
            os.replace(staging, out)  # atomic on one file system: the old file or the new one, never half
        finally:
            staging.unlink(missing_ok=True)


def _commit(staging, out, replace):
    """Move ``staging`` to ``out``; a previous output is moved aside first and removed only after."""
    old = None
    if replace and out.exists():
        old = _sibling(out, "old")
        os.rename(out, old / "out")
    elif out.exists() and any(out.iterdir()):  # appeared while the command ran: keep both, say where
        kept = staging.with_suffix(".done")
        os.rename(staging, kept)
        raise ConfigError(f"--out {out}: something was written there while the command ran; cosim did not touch "
                          f"it; the results are in {kept}")
    try:
        os.replace(staging, out)  # onto an empty folder or nothing: atomic on one file system
    except OSError as exc:
        if old is not None:
            os.rename(old / "out", out)
        raise ConfigError(f"--out {out}: could not move the results into place ({exc.strerror})") from None
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def optional_file(path, make, *args, **kwargs):
    """Write ``path`` with ``make(path, *args, **kwargs)``: a file the results do not depend on (a plot), written
    after them, whose failure is an :class:`~cosim.errors.OutputWarning` instead of the command's failure.

    Parameters
    ----------
    path : Path
        The file; removed when ``make`` fails half way.
    make : callable
        Writes it; may raise anything (matplotlib's failures on values it cannot scale, a figure too large).

    Returns
    -------
    Path or None
        ``path``, or None when it could not be made.
    """
    try:
        make(path, *args, **kwargs)
    except Exception as exc:  # the results it illustrates are written already: keep them, say what is missing
        Path(path).unlink(missing_ok=True)
        warnings.warn(f"{Path(path).name} was not made ({type(exc).__name__}: {exc}); the results are written",
                      OutputWarning, stacklevel=2)
        return None
    return Path(path)


def check_output(folder, adopt=()):
    """Refuse a ``folder`` a command writing in place could spoil; creates nothing.

    Parameters
    ----------
    folder : str or Path
        Must be missing, empty, a cosim output, or hold only files matching ``adopt``; writable (or, when
        missing, its nearest existing parent).
    adopt : sequence of str, optional
        Glob patterns of the files a folder written before markers existed holds (``cosim build``: ``*.fmu`` and
        its build stamp): such a folder is taken as a cosim output.

    Returns
    -------
    Path
        ``folder``, absolute.

    Raises
    ------
    ConfigError
        ``folder`` exists and holds something else, is a file, or cannot be written.
    """
    folder = Path(os.path.abspath(folder))
    adopted = folder.is_dir() and all(any(p.match(pattern) for pattern in adopt) for p in folder.iterdir())
    if not is_output(folder) and not adopted:
        _check_target(folder, force=False)
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    _writable(existing, folder)
    return folder


def mark_output(folder, command, adopt=()):
    """Make ``folder`` a cosim output written in place (an FMU folder, a resumable campaign).

    Parameters
    ----------
    folder : str or Path
        Created when missing. An existing folder must be a cosim output, empty, or hold only files matching
        ``adopt`` (see :func:`check_output`).
    command : str
        The command writing it, written into the marker when the folder has none.
    adopt : sequence of str, optional
        As for :func:`check_output`; such a folder is marked.

    Returns
    -------
    Path
        ``folder``, absolute.

    Raises
    ------
    ConfigError
        ``folder`` exists, is not a cosim output and is not empty, or it is not writable.
    """
    folder = check_output(folder, adopt)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--out {folder}: cannot create it ({exc.strerror})") from None
    if not is_output(folder):
        _write_marker(folder, command)
    return folder
