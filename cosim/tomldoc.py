"""TOML documents for run configs and jobs: parse once, apply ``--set key=value`` overrides, and collect every
problem with its ``file:line`` (or ``--set key``) and key path before raising one :class:`ConfigError`.

tomllib gives no line numbers for keys: :class:`Locator` finds them by scanning the text (best effort)."""

import datetime
import difflib
import json
import math
import numbers
import re
import tomllib
from pathlib import Path

from cosim.errors import ConfigError
from cosim.fitting import FreeParameter

__all__ = ["read_text", "read_toml", "sections", "bounded_parameters", "number", "string", "values", "signal_tables",
           "Problems", "Locator", "override_value", "parse_overrides", "apply_override", "apply_overrides", "format_key",
           "toml_text", "toml_value", "toml_key", "key_paths", "did_you_mean"]


# ----------------------------------------------------------------------------------------------
# locating keys in the text
# ----------------------------------------------------------------------------------------------
_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEYLINE = re.compile(r"""^\s*((?:[A-Za-z0-9_\-]+|"[^"]*"|'[^']*')(?:\s*\.\s*(?:[A-Za-z0-9_\-]+|"[^"]*"|'[^']*'))*)\s*=""")


_DOTTED = re.compile(r"""^(?:[A-Za-z0-9_\-]+|"[^"]*"|'[^']*')(?:\s*\.\s*(?:[A-Za-z0-9_\-]+|"[^"]*"|'[^']*'))*$""")


def _split_dotted(s):
    parts = re.findall(r"""[A-Za-z0-9_\-]+|"[^"]*"|'[^']*'""", s)
    return [p[1:-1] if p[:1] in "\"'" else p for p in parts]


class Locator:
    """Best-effort map from key paths to 1-based line numbers of the TOML text."""

    def __init__(self, text):
        self.entries = []  # (path tuple, line)
        header = ()
        counts = {}
        for i, line in enumerate(text.splitlines(), start=1):
            m = _HEADER.match(line)
            if m and "=" not in line.split("]")[0]:
                parts = tuple(_split_dotted(m.group(2)))
                if m.group(1) == "[[":
                    n = counts.get(parts, -1) + 1
                    counts[parts] = n
                    header = parts + (n,)
                else:
                    # a sub-table of an array-of-tables element refers to its last element
                    fixed = []
                    for j in range(len(parts)):
                        fixed.append(parts[j])
                        if tuple(parts[: j + 1]) in counts and j < len(parts) - 1:
                            fixed.append(counts[tuple(parts[: j + 1])])
                    header = tuple(fixed)
                self.entries.append((header, i))
                continue
            m = _KEYLINE.match(line)
            if m:
                self.entries.append((header + tuple(_split_dotted(m.group(1))), i))

    def line(self, path):
        """Line of ``path`` (tuple of str/int), or of its closest located ancestor (the line of a key whose value, an
        inline table or a list, holds the rest of the path); None if unknown."""
        path = tuple(path)
        for n in range(len(path), 0, -1):
            for p, i in self.entries:
                if p == path[:n]:
                    return i
        return None


def key_paths(node, prefix=()):
    """Every key path of a parsed document, lists' elements by index (``("record", "signals", 0)``)."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield prefix + (k,)
        yield from key_paths(v, prefix + (k,))


def did_you_mean(name, names, n=3, cutoff=0.5):
    """"; did you mean 'X' or 'Y'?" for the ``names`` closest to ``name`` (difflib's ratio, case aside), or "".

    Dotted names are told apart below the parents they share (``controllers.outer`` for ``controllers.outr``,
    not ``controllers.foc``) and also by their last names (``Gripper.GripperPlant`` for ``GripperPlnt``)."""
    def ratio(a, b):
        return difflib.SequenceMatcher(None, a, b).ratio()

    def score(candidate):
        a, b = str(name).lower().split("."), str(candidate).lower().split(".")
        while len(a) > 1 and len(b) > 1 and a[0] == b[0]:
            a, b = a[1:], b[1:]
        return max(ratio(".".join(a), ".".join(b)), ratio(a[-1], b[-1]))

    scored = sorted(((score(c), str(c)) for c in set(names)), key=lambda sc: (-sc[0], sc[1]))
    found = [c for s, c in scored if s >= cutoff][:n]
    return f"; did you mean {' or '.join(repr(c) for c in found)}?" if found else ""


def format_key(path):
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (("." if out else "") + str(p))
    return out


class Problems:
    """Every problem of one document, each located at ``file:line`` or at the ``--set`` item that made it.

    A problem added with ``cause=True`` (an FMU or a controller class that cannot be loaded) is listed first: the
    problems that follow from it are not reported by the loaders, and what is left reads cause first."""

    def __init__(self, file, locator, set_keys, keys=(), origins=None):
        self.file = file
        self.locator = locator
        self.set_keys = set_keys
        self.keys = set(keys)  # the document's own key paths, dotted: what --set is told it may have meant
        self.origins = origins or {}  # override key -> where its value came from, when not from the command line
        self.items = []

    def _set_item(self, path):
        """The ``--set`` key that wrote ``path`` (or a table above it, or a key below it it created), or None."""
        for n in range(len(path), 0, -1):
            if format_key(path[:n]) in self.set_keys:
                return self.set_keys[format_key(path[:n])]
        key = format_key(path)
        for written, item in self.set_keys.items():
            if key and written.startswith((key + ".", key + "[")):
                return item
        return None

    def where(self, path):
        """Where the value at the key path ``path`` was given: ``file:line``, ``--set KEY``, or the origin the
        loader was told of for an override it was passed (another document's key)."""
        item = self._set_item(tuple(path))
        if item is not None:
            return self.origins.get(item, f"--set {item}")
        line = self.locator.line(tuple(path)) if self.locator else None
        return f"{self.file}:{line}" if line else f"{self.file}"

    def add(self, path, message, cause=False):
        path = tuple(path)
        key = format_key(path)
        item = self._set_item(path)
        where = self.where(path)
        # a --set key made up above its last name (plant.eta_g: "plant" is no section): the problem is the key, told
        # against every key the document has or may have, once they are all known
        made_up = (item is not None and message.startswith("unknown") and item not in self.keys
                   and self.set_keys.get(key) != item)
        self.items.append((where, key, message, cause, item if made_up else None))

    def did_you_mean(self, item):
        """"; did you mean --set K=...?" for the keys closest to the ``--set`` key ``item``: those that hold its
        names in order, each as the start of one of theirs (fmus.plant.parameters.eta_g for plant.eta_g,
        controllers.foc.parameters.bandwidth_hz for foc.bandwidth), the same last name first; then those spelt
        alike (run.stop for run.stpo) when none does."""
        names = item.split(".")
        keys = sorted(self.keys)

        def holds(key):
            rest = iter(key.split("."))
            return all(any(part.startswith(n) for part in rest) for n in names)

        def rank(key):
            return (key.rsplit(".", 1)[-1] != names[-1], -difflib.SequenceMatcher(None, item, key).ratio())

        close = sorted(filter(holds, keys), key=rank) or difflib.get_close_matches(item, keys, n=3, cutoff=0.6)
        return f"; did you mean {' or '.join(f'--set {k}=...' for k in close[:3])}?" if close else ""

    def raise_if_any(self):
        if self.items:
            def order(item):
                m = re.search(r":(\d+)$", item[0])
                return (not item[3], item[0].startswith("--set"), int(m.group(1)) if m else 0)

            lines = []
            for where, key, message, _, made_up in sorted(self.items, key=order):
                if made_up is not None:
                    key, message = made_up, f"unknown key in {self.file}{self.did_you_mean(made_up)}"
                line = f"{where}: {key}: {message}" if key else f"{where}: {message}"
                if line not in lines:  # one made-up key is reported once, however many tables it reached
                    lines.append(line)
            err = ConfigError(
                f"{len(lines)} problem{'s' if len(lines) > 1 else ''} in {self.file}:\n  - " + "\n  - ".join(lines)
            )
            err.problems = lines
            raise err


# ----------------------------------------------------------------------------------------------
# overrides
# ----------------------------------------------------------------------------------------------
def override_value(text):
    """The value of a ``--set`` item: ``text`` read as a TOML value, else the plain string (bare words)."""
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def parse_overrides(items):
    """Turn ``["a.b=1", ...]`` into a list of (path tuple, value); values are TOML, else plain strings.

    Parameters
    ----------
    items : iterable of str
        ``--set`` arguments, ``"dotted.key=value"``.

    Returns
    -------
    list of tuple
        ``(key path tuple, value)`` pairs in the order given.

    Raises
    ------
    ConfigError
        An item has no ``=`` or an empty key.
    """
    out = []
    for item in items or ():
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not _DOTTED.match(key):
            raise ConfigError(f"--set {item!r}: expected key=value with a dotted key such as run.stop, e.g. "
                              f"--set run.stop=2.0; got the key {key!r}")
        v = override_value(value)
        parts = []
        for p in _split_dotted(key):
            parts.append(int(p) if p.isdigit() else p)
        out.append((tuple(parts), v))
    return out


def apply_override(data, path, value):
    """Set ``path`` (a tuple of str and list indices) of the document ``data`` to ``value``, creating tables.

    Raises
    ------
    ConfigError
        The path goes through a value (a string, a number) or past the end of a list.
    """
    node = data
    for i, p in enumerate(path):
        last = i == len(path) - 1
        here = format_key(path[:i])
        if isinstance(node, list):
            if not isinstance(p, int) or p >= len(node):
                expected = f"an index 0 to {len(node) - 1}" if node else "no index (it is empty)"
                raise ConfigError(f"--set {format_key(path)}: {here} is a list of {len(node)} elements; expected "
                                  f"{expected}, got {p!r}")
        elif isinstance(node, dict):
            p = str(p)
            if not last and node.get(p) is None:
                node[p] = {}
        else:
            raise ConfigError(f"--set {format_key(path)}: {here} is a value ({node!r}), not a table or a list")
        if last:
            node[p] = value
        else:
            node = node[p]


def read_text(path, what="file", error=ConfigError):
    """The text of ``path`` decoded as UTF-8 (TOML and Modelica are UTF-8 by their specifications).

    Parameters
    ----------
    path : path-like
    what : str
        What the file is, for the messages.
    error : type
        The CosimError subclass raised (ConfigError for configs and jobs, ModelicaError for sources).

    Returns
    -------
    str

    Raises
    ------
    ConfigError
        (or ``error``) The file cannot be read, or is not UTF-8 (the message gives the line and column of the
        first bad byte).
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise error(f"{path}: cannot read the {what}: {err.strerror or err}") from err
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as err:
        line = raw.count(b"\n", 0, err.start) + 1
        column = err.start - (raw.rfind(b"\n", 0, err.start) + 1) + 1
        raise error(f"{path}:{line}:{column}: the {what} must be UTF-8 text; got byte "
                          f"0x{raw[err.start]:02x}, which is not valid UTF-8 there (save the file as UTF-8)") from err


def read_toml(path, overrides=(), what="config", origins=None):
    """Read a TOML file, apply ``--set`` overrides, and return ``(data, problems)``.

    Parameters
    ----------
    path : Path
    overrides : sequence of str
        ``"key.path=value"`` items.
    what : str
        What the file is, for the "does not exist" message.
    origins : dict, optional
        Override key (``"campaign.hold_s"``) -> where a problem of its value is said to be, instead of ``--set
        KEY``: for overrides a loader makes from another document (a sensitivity job's reduced grid, given to
        its campaign job), the place in that document.

    Returns
    -------
    data : dict
        The parsed document with the overrides applied.
    problems : Problems
        An empty collector that locates each problem by ``file:line`` (or ``--set key``).

    Raises
    ------
    ConfigError
        The file is missing, the TOML is malformed (with line and column), an override is malformed, or a string
        holds a NUL byte (with the line and key of each).
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: {what} file does not exist")
    text = read_text(path, what)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(err))
        where = f"{path}:{m.group(1)}:{m.group(2)}" if m else str(path)
        msg = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(err))
        raise ConfigError(f"{where}: malformed TOML: {msg}") from err
    keys = {format_key(k) for k in key_paths(data)}  # the file's own keys, before the overrides add theirs
    problems = Problems(str(path), Locator(text), apply_overrides(data, overrides), keys, origins)
    _refuse_nul(data, problems)
    return data, problems


def apply_overrides(data, overrides):
    """Apply ``--set`` items (``"key.path=value"``) to the document ``data``; returns the keys they set (dotted)
    -> the key as given, what :class:`Problems` locates their problems with."""
    set_keys = {}
    for (p, v), item in zip(parse_overrides(overrides), overrides or ()):
        apply_override(data, p, v)
        set_keys[format_key(p)] = item.partition("=")[0].strip()
    return set_keys


def _refuse_nul(data, problems):
    """Raise the problems of every string of ``data`` holding a NUL byte: no file name (nor model, signal or
    column name) can hold one, and the operating system refuses such a path with a ValueError of its own."""
    for path in key_paths(data):
        node = data
        for p in path:
            node = node[p]
        if isinstance(node, str) and "\0" in node:
            problems.add(path, f"holds a NUL byte (\\u0000): {node!r}; no file, model or signal name can hold one")
    problems.raise_if_any()


def number(problems, table, key, where, default=None, positive=False, integer=False):
    """``table[key]`` as a finite number (``default`` when absent; required when the default is None); a
    problem is recorded at ``where + (key,)`` when it is missing, not a number, not whole or not positive."""
    value = table.get(key, default)
    if value is None:
        problems.add(where + (key,), "is required")
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        problems.add(where + (key,), f"must be a number; got {value!r}")
        return None
    if integer and int(value) != value:
        problems.add(where + (key,), f"must be a whole number; got {value!r}")
    if positive and value <= 0:
        problems.add(where + (key,), f"must be > 0; got {value!r}")
    return int(value) if integer else float(value)


def string(problems, table, key, where, default=None):
    """``table[key]`` as a non-empty string (``default`` when absent; required when the default is None); a
    problem is recorded at ``where + (key,)`` when it is missing or not a string, and ``default`` returned."""
    value = table.get(key, default)
    if value is None:
        problems.add(where + (key,), "is required (a string)")
    elif not isinstance(value, str) or (not value and default is None):
        problems.add(where + (key,), f"must be a {'non-empty ' if default is None else ''}string; got {value!r}")
        return default
    return value


def values(problems, table, key, where):
    """``table[key]``, a table of ``name = number`` (fixed parameter values), as a dict of floats (empty when
    absent); a problem is recorded for the table or for each value that is not a finite number."""
    given = table.get(key, {})
    if not isinstance(given, dict):
        problems.add(where + (key,), f"must be a table of name = number, e.g. {{eta_g = 0.7}}; got {given!r}")
        return {}
    out = {}
    for name, value in given.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            problems.add(where + (key, name), f"must be a finite number; got {value!r}")
        else:
            out[name] = float(value)
    return out


def signal_tables(problems, table, key, where, default_noise):
    """``table[key]``, a list of ``{output, column, noise}`` tables (measured signals), as a list of
    ``(output, column, noise)``; a problem is recorded for each malformed entry, and when the list is empty."""
    given = table.get(key, [])
    if not isinstance(given, list):
        problems.add(where + (key,), f"must be a list of tables [{{output = \"F_g\", noise = 0.5}}]; got {given!r}")
        return []
    signals = []
    for k, s in enumerate(given):
        here = where + (key, k)
        if not isinstance(s, dict) or not isinstance(s.get("output"), str):
            problems.add(here, f"must be a table {{output = \"F_g\", column = \"F_g\", noise = 0.5}}; got {s!r}")
            continue
        for extra in sorted(set(s) - {"output", "column", "noise"}):
            problems.add(here + (extra,), "unknown key; allowed: output, column, noise")
        column = string(problems, s, "column", here, default=s["output"])
        noise = number(problems, s, "noise", here, default=default_noise, positive=True)
        signals.append((s["output"], column, noise))
    if not given:
        problems.add(where + (key,), "name at least one measured output: [{output = \"F_g\", noise = 0.5}]")
    return signals


def sections(data, problems, schema, free_form=("parameters",)):
    """The tables of a job document by section name; unknown sections and keys are problems.

    Parameters
    ----------
    data : dict
        The parsed document.
    problems : Problems
    schema : dict
        section -> tuple of allowed keys.
    free_form : tuple of str
        Sections whose keys are the user's names (e.g. ``[parameters.eta_g]``), not checked here.
    """
    for key in sorted(set(data) - set(schema) - set(free_form)):
        problems.add((key,), f"unknown section; expected {', '.join([*schema, *free_form])}")
    tables = {}
    for section, allowed in schema.items():
        table = data.get(section, {})
        if not isinstance(table, dict):
            problems.add((section,), "must be a table")
            table = {}
        for key in sorted(set(table) - set(allowed)):
            problems.add((section, key), f"unknown key; allowed: {', '.join(allowed)}")
        tables[section] = table
    return tables


def bounded_parameters(data, problems, required=True):
    """``[parameters.NAME] start, min, max`` tables as ``{name: FreeParameter}``, checked (start in bounds)."""

    tables = data.get("parameters", {})
    if not isinstance(tables, dict):
        problems.add(("parameters",), f"must be tables [parameters.NAME] with start, min, max; got {tables!r}")
        return {}
    if required and not tables:
        problems.add(("parameters",), "name at least one parameter to fit: [parameters.eta_g] start, min, max")
    free = {}
    for name, p in tables.items():
        where = ("parameters", name)
        if not isinstance(p, dict):
            problems.add(where, "must be a table with start, min, max")
            continue
        for key in sorted(set(p) - {"start", "min", "max"}):
            problems.add(where + (key,), "unknown key; allowed: start, min, max")
        s, lo, hi = (number(problems, p, key, where) for key in ("start", "min", "max"))
        if None not in (s, lo, hi):
            if not lo <= s <= hi:
                problems.add(where + ("start",), f"{s:g} is outside the bounds [{lo:g}, {hi:g}]")
            free[name] = FreeParameter(s, lo, hi)
    return free


# ----------------------------------------------------------------------------------------------
# writing
# ----------------------------------------------------------------------------------------------
_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_text(data, comment=""):
    """The TOML text of ``data``: what :func:`tomllib.loads` reads back as ``data``.

    Parameters
    ----------
    data : dict
        Tables (dicts) of numbers, booleans, strings, lists and tables; a list of tables is written as an array
        of tables (``[[connections]]``).
    comment : str, optional
        Lines written first, each as a ``#`` comment.

    Returns
    -------
    str
    """
    lines = [f"# {line}" for line in comment.splitlines()]
    _write_table(data, (), lines)
    return "\n".join(lines).lstrip("\n") + "\n"


def _write_table(table, prefix, lines):
    """The body of ``table`` (its values, then its sub-tables and arrays of tables) appended to ``lines``."""
    nested = {k: v for k, v in table.items() if isinstance(v, dict) or _table_array(v)}
    lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items() if k not in nested]
    for key, value in nested.items():
        path = ".".join(toml_key(k) for k in (*prefix, key))
        for item in ([value] if isinstance(value, dict) else value):
            if not isinstance(value, dict):
                lines += ["", f"[[{path}]]"]
            elif not value or not all(isinstance(v, dict) or _table_array(v) for v in value.values()):
                lines += ["", f"[{path}]"]  # a table holding only tables needs no header of its own
            _write_table(item, (*prefix, key), lines)


def _table_array(value):
    return isinstance(value, (list, tuple)) and bool(value) and all(isinstance(v, dict) for v in value)


def toml_key(key):
    """``key`` as a TOML key: bare when it can be, else quoted (``"load.J"``, ``"x[1]"``), so that it reads back as
    one key, not a dotted path to a nested table or a syntax error."""
    return key if _BARE_KEY.match(key) else _toml_string(key)


def _toml_string(text):
    """A TOML basic string: JSON's escapes are TOML's (DEL too must be escaped in TOML)."""
    return json.dumps(str(text), ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_value(value):
    """``value`` (what :mod:`tomllib` reads, numpy numbers, paths) as a TOML literal: ``--set`` items made from
    a document's values, lines of :func:`toml_text`."""
    if isinstance(value, (datetime.date, datetime.time)):  # a datetime is a date
        return value.isoformat()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        v = float(value)
        return ("nan" if math.isnan(v) else "inf" if v > 0 else "-inf") if not math.isfinite(v) else repr(v)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, Path):
        return _toml_string(value.as_posix())
    raise TypeError(f"toml_text: no TOML form for {type(value).__name__} {value!r}")
