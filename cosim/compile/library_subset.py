"""The part of the libraries a model uses, copied to a scratch folder for rumoca: its session reads and resolves
every class of every library under its roots (the whole Modelica Standard Library, about 2,500 files, 20 s and
1.4 GB for one small example), so handing it only the packages the model names makes a build of one library
model some ten times cheaper. The packages are found from the sources' text: every dotted name that starts with
a library's top-level name (``Modelica.Mechanics.Rotational.Components.Inertia``) brings in that name's package
two levels below the top (``Modelica/Mechanics/Rotational/``, or the file ``Modelica/Blocks/Sources.mo``) and the
``package.mo`` files above it, then the names those files use, until no new package comes in."""

import re
import shutil
from pathlib import Path

__all__ = ["library_subset"]

# String literals (documentation, modelica:// links) and comments name classes that are not used.
_NOISE = re.compile(r'"(?:[^"\\]|\\.)*"|//[^\n]*|/\*.*?\*/', re.S)
_DOTTED = re.compile(r"\b[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*")


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


def _files(parts, folder):
    """The files that hold dotted name ``parts`` looked up in library folder ``folder``: the ``package.mo`` of
    each package folder on the way and the file of the first class stored as a file; none when ``parts[0]`` is
    not in ``folder``."""
    files = []
    for part in parts:
        if (folder / f"{part}.mo").is_file():
            return files + [folder / f"{part}.mo"]
        if not (folder / part / "package.mo").is_file():
            return files  # a class of the package.mo above
        folder = folder / part
        files.append(folder / "package.mo")
    return files


def _used(mo, tops):
    """The files holding the classes that file ``mo`` names, by full name or relative to its enclosing packages."""
    names = {tuple(n.split(".")) for n in _DOTTED.findall(_NOISE.sub(" ", mo.read_text(encoding="utf-8",
                                                                                     errors="replace")))}
    top = next(t for t in tops.values() if mo == t or mo.is_relative_to(t))
    enclosing = [top] if top.is_file() else [f for f in [mo.parent, *mo.parent.parents] if f.is_relative_to(top)]
    for parts in names:
        if parts[0] in tops:
            found = tops[parts[0]]
            yield from [found] if found.is_file() else [found / "package.mo"] + _files(parts[1:], found)
        for folder in enclosing if not top.is_file() else []:
            yield from _files(parts, folder)


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
    tops = _tops(roots)
    queue = [t if t.is_file() else t / "package.mo" for t in tops.values()
             if t.stem.split(" ", 1)[0] == model.split(".", 1)[0]]
    queue += _files(model.split(".")[1:], queue[0].parent) if queue and queue[0].name == "package.mo" else []
    for text in texts:
        for name in _DOTTED.findall(_NOISE.sub(" ", text)):
            parts = name.split(".")
            if parts[0] in tops:
                top = tops[parts[0]]
                queue += [top] if top.is_file() else [top / "package.mo"] + _files(parts[1:], top)
    seen = set()
    while queue:
        mo = queue.pop()
        if mo not in seen:
            seen.add(mo)
            queue += [f for f in _used(mo, tops) if f not in seen]
    copies = {}
    for mo in seen:
        top = next(t for t in tops.values() if mo == t or mo.is_relative_to(t))
        copy = scratch / top.name / mo.relative_to(top) if mo != top else scratch / top.name
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(mo, copy)
        copies[str(copy)] = str(mo)
    return copies
