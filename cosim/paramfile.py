"""Parameters files: the calibrated values ``cosim calibrate`` writes (``parameters.toml``) with where they came
from, read back by run configs, campaign jobs and other calibration jobs (``parameters_file = "..."``).

A file holds a ``[parameters]`` table (name = number) and a ``[provenance]`` table: the job that wrote it and its
SHA-256, the data files and theirs, the git commit of the code, the date, and the parameters files the job itself
read (``upstream``, each with its hash and provenance). Whoever reads a file records :meth:`ParametersFile.record`
(its path, SHA-256 and provenance) in its own outputs, so a changed upstream calibration shows downstream.
"""

import hashlib
import math
import subprocess
import tomllib
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from cosim.errors import ConfigError
from cosim.tomldoc import read_text, toml_key, toml_value

__all__ = ["ParametersFile", "read_parameters_file", "parameters_file_key", "write_parameters_file", "provenance",
           "file_sha256"]


def file_sha256(path):
    """The SHA-256 of a file's bytes, as hex.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    str
    """
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@dataclass(frozen=True)
class ParametersFile:
    """A parameters file as read.

    Attributes
    ----------
    path : pathlib.Path
    values : dict
        ``[parameters]``: name -> float.
    sha256 : str
        Of the file's bytes.
    provenance : dict
        ``[provenance]`` (empty for a file written by hand).
    """

    path: Path
    values: dict
    sha256: str
    provenance: dict = field(default_factory=dict)

    def record(self):
        """What a downstream output records about this file: path, SHA-256 and provenance (a plain dict)."""
        return {"file": str(self.path), "sha256": self.sha256, "provenance": dict(self.provenance)}


def read_parameters_file(path, key=None):
    """Read and check a parameters file.

    Parameters
    ----------
    path : path-like
        The file (TOML).
    key : str, optional
        The key that named it (``campaign.parameters_file``...), said first in the messages; None where the
        caller's problem list names the key.

    Returns
    -------
    ParametersFile

    Raises
    ------
    ConfigError
        The file is missing, not UTF-8 or not TOML, has no ``[parameters]`` table, or a value is not a finite
        number; the message names ``key`` and the file (with the line of a TOML error).
    """
    path = Path(path)

    def error(message):
        return ConfigError(f"{key}: {message}" if key else message)

    try:
        text = read_text(path, "parameters file")
    except ConfigError as err:
        raise error(str(err)) from err
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise error(f"{path}: not a TOML parameters file: {err}") from err
    values = doc.get("parameters")
    if not isinstance(values, dict):
        raise error(f"{path}: needs a [parameters] table of name = value (as cosim calibrate writes)")
    pairs = _flat(values)
    values = dict(pairs)
    twice = sorted({n for n, _ in pairs if sum(m == n for m, _ in pairs) > 1})
    if twice:
        raise error(f"{path}: [parameters] names {', '.join(map(repr, twice))} twice (quoted and as a dotted key)")
    bad = [f"{n} = {v!r}" for n, v in values.items()
           if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)]
    if bad:
        raise error(f"{path}: [parameters] values must be finite numbers; got {', '.join(bad)}")
    prov = doc.get("provenance", {})
    return ParametersFile(path, {n: float(v) for n, v in values.items()}, file_sha256(path),
                          prov if isinstance(prov, dict) else {})


def _flat(table, prefix=""):
    """``[parameters]`` as (name, value) pairs, its nested tables as dotted names: ``load.J = 2.0`` written bare
    (by hand, or by cosim calibrate before it quoted keys) is TOML for ``{load = {J = 2.0}}`` and means the
    parameter ``load.J``."""
    out = []
    for name, value in table.items():
        out += _flat(value, f"{prefix}{name}.") if isinstance(value, dict) else [(prefix + name, value)]
    return out


def parameters_file_key(table, where, base, problems):
    """The parameters file a config's or job's ``parameters_file`` key names, or None (no key, or a problem
    added to ``problems`` under ``where + ("parameters_file",)``).

    Parameters
    ----------
    table : dict
        The TOML table holding the key.
    where : tuple of str
        The table's key path (``("fmus", "plant")``).
    base : pathlib.Path
        The folder the file name is relative to (the config's or job's).
    problems : cosim.tomldoc.Problems

    Returns
    -------
    ParametersFile or None
    """
    name = table.get("parameters_file")
    if name is None:
        return None
    if not isinstance(name, str):
        problems.add(where + ("parameters_file",), f"must be a file name (a string); got {name!r}")
        return None
    try:
        return read_parameters_file(Path(base) / name)
    except ConfigError as err:
        problems.add(where + ("parameters_file",), str(err))
        return None


def _commit():
    """The git commit of the code that runs (``+dirty`` when its files differ from it), or "unknown"."""
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10)
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    if head.returncode != 0:
        return "unknown"
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def _shown(path):
    """A path as recorded: relative to the working folder when inside it (portable), else absolute."""
    path = Path(path).resolve()
    try:
        return str(path.relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def provenance(job, data, upstream=()):
    """The provenance of a calibration's parameters file.

    Parameters
    ----------
    job : path-like
        The job file.
    data : sequence of path-like
        The data files it fitted.
    upstream : sequence of ParametersFile
        The parameters files the job read.

    Returns
    -------
    dict
    """
    return {"job": _shown(job), "job_sha256": file_sha256(job),
            "data": [{"file": _shown(d), "sha256": file_sha256(d)} for d in data],
            "commit": _commit(), "date": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "upstream": [u.record() for u in upstream]}


def write_parameters_file(path, values, notes, prov, header=()):
    """Write a parameters file.

    Parameters
    ----------
    path : path-like
    values : dict
        name -> float.
    notes : dict
        name -> a comment written beside the value (its standard error).
    prov : dict
        The ``[provenance]`` table (:func:`provenance`).
    header : sequence of str
        Comment lines at the top.
    """
    lines = [f"# {h}" for h in header] + ["[parameters]"]
    lines += [f"{toml_key(n)} = {float(v)!r}" + (f"  # {notes[n]}" if n in notes else "") for n, v in values.items()]
    lines += ["", "[provenance]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in prov.items() if k != "upstream"]
    lines += [f"upstream = {toml_value(list(prov.get('upstream', ())))}"]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
