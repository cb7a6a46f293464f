"""The part of the libraries a model uses, copied to a scratch folder for rumoca: its session reads and parses
every file of every library under its roots (the whole Modelica Standard Library, about 2,500 files, 20 s and
1.4 GB for one small example), so handing it only the files the model's classes come from makes a build of one
library model several times cheaper. The files are found from the sources' text: each dotted name, taken as a
full name (``Modelica.Mechanics.Rotational.Components.Inertia``) and relative to each package enclosing the file
that uses it (``Interfaces.Flange_a`` in ``Rotational/Components/``), brings in the file that stores its class
and the ``package.mo`` files above it, then the names that file uses, until no new file comes in. A scan that
misses a class makes rumoca's load of the copy fail, and the caller loads from the whole library path instead."""

import re
import shutil
from pathlib import Path

__all__ = ["library_subset"]

# String literals (documentation, modelica:// links) and comments name classes that are not used.
_NOISE = re.compile(r'"(?:[^"\\]|\\.)*"|//[^\n]*|/\*.*?\*/', re.S)
_DOTTED = re.compile(r"\b[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*")


def _names(text):
    """The dotted names of Modelica code ``text``, outside its strings and comments."""
    return _DOTTED.findall(_NOISE.sub(" ", text))


def _top_of(mo, tops):
    """The library folder (or single file) that holds file ``mo``."""
    return next(t for t in tops.values() if mo == t or mo.is_relative_to(t))


def _tops(roots):
    """Top-level library name -> its folder or file, the first root holding it winning (as in the library path)."""
    tops = {}
    for root in roots:
        for entry in sorted(Path(root).iterdir()):
            if entry.is_dir() and (entry / "package.mo").is_file():
                tops.setdefault(entry.name.split(" ", 1)[0], entry)
            elif entry.suffix == ".mo":
                tops.setdefault(entry.stem.split(" ", 1)[0], entry)
    return tops


def _listing(folder, listings):
    """The class names a library folder stores as files (``X.mo``) and as package folders (``X/package.mo``),
    read once per folder into ``listings``."""
    if folder not in listings:
        entries = list(folder.iterdir()) if folder.is_dir() else []
        listings[folder] = ({e.stem for e in entries if e.suffix == ".mo" and e.name != "package.mo"},
                            {e.name for e in entries if (e / "package.mo").is_file()})
    return listings[folder]


def _files(parts, folder, listings):
    """The files that hold dotted name ``parts`` looked up in library folder ``folder``: the ``package.mo`` of
    each package folder on the way and the file of the first class stored as a file; none when ``parts[0]`` is
    not in ``folder``."""
    files = []
    for part in parts:
        stored_files, packages = _listing(folder, listings)
        if part in stored_files:
            return files + [folder / f"{part}.mo"]
        if part not in packages:
            return files  # a class of the package.mo above
        folder = folder / part
        files.append(folder / "package.mo")
    return files


def _absolute(parts, tops, listings):
    """The files that hold full name ``parts`` (``Modelica``, ``Mechanics``, ...), none if no library is named so."""
    top = tops.get(parts[0])
    if top is None:
        return []
    return [top] if top.is_file() else [top / "package.mo"] + _files(parts[1:], top, listings)


def _used(mo, tops, listings):
    """The files holding the classes that file ``mo`` names, by full name or relative to its enclosing packages."""
    names = {tuple(n.split(".")) for n in _names(mo.read_text(encoding="utf-8", errors="replace"))}
    top = _top_of(mo, tops)
    enclosing = [top] if top.is_file() else [f for f in [mo.parent, *mo.parent.parents] if f.is_relative_to(top)]
    for parts in names:
        yield from _absolute(parts, tops, listings)
        for folder in enclosing if not top.is_file() else []:
            yield from _files(parts, folder, listings)


def library_subset(model, texts, roots, scratch):
    """Copy to ``scratch`` the packages of the libraries on ``roots`` that ``model`` and ``texts`` use.

    Parameters
    ----------
    model : str
        Full name of the model (its own package is always copied when it is a library's).
    texts : iterable of str
        The user's own Modelica sources, scanned for the library classes they use.
    roots : sequence of Path
        The library path.
    scratch : Path
        An empty folder: the new root to hand rumoca instead of ``roots``.

    Returns
    -------
    dict of str to str
        Each copied file's path -> the original's (to name the originals in rumoca's source map).
    """
    tops, listings = _tops(roots), {}
    names = {model, *(n for text in texts for n in _names(text))}
    queue = [mo for name in names for mo in _absolute(name.split("."), tops, listings)]
    seen = set()
    while queue:
        mo = queue.pop()
        if mo not in seen:
            seen.add(mo)
            queue += [f for f in _used(mo, tops, listings) if f not in seen]
    copies = {}
    for mo in seen:
        top = _top_of(mo, tops)
        copy = scratch / top.name / mo.relative_to(top) if mo != top else scratch / top.name
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(mo, copy)
        copies[str(copy)] = str(mo)
    return copies
