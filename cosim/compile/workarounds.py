"""Source transforms for front-end bugs of one rumoca version, applied to a private copy of a library.

rumoca 0.10.2 gives a scalar parameter bound to a call with an array argument the shape of that argument (a table
object counts as its table), so each equation that uses the parameter is counted once per element and the model is
refused as unbalanced (docs/dev/rumoca-upstream.md, "Parameter bound to a call with an array argument"). The MSL
4.1.0 binds such parameters to its table lookups (``mu0`` of ``Clutch``, ``Brake``, ``OneWayClutch``,
``eta_mf1_0``... of ``LossyGear``). The transform ``table-lookup-binding`` writes the binding ``= e`` as
``= 1.0*(e)``, the same value for every floating-point ``e``, which rumoca 0.10.2 counts right. It is applied to a
cached copy of the library (``<user cache>/cosim/library-transforms/rumoca-<version>/``: its ``.mo`` files, a
link to the user's for every other file), never to the user's files, and only under the rumoca version it
works around: with another version the library is handed to rumoca as it is."""

import hashlib
import re
import shutil
import tempfile
import warnings
from pathlib import Path

from cosim.errors import LibraryTransformWarning
from cosim.kernel_cache import user_cache_root

__all__ = ["RUMOCA_VERSION", "TRANSFORM", "transform_table_bindings", "transformed_roots"]

RUMOCA_VERSION = "0.10.2"
TRANSFORM = "table-lookup-binding"
_WHY = (f"rumoca {RUMOCA_VERSION} counts an equation that uses a parameter bound to a table lookup once per element "
        "of the table (docs/dev/rumoca-upstream.md); its binding = e is read as = 1.0*(e), the same value")
# A scalar parameter declaration whose binding calls a 1-D table lookup: its binding (up to the description string
# or the ';') is wrapped. The MSL's lookups take the table object, which rumoca sizes as its table.
_BINDING = re.compile(r"(?P<head>\bparameter\s+[\w.]+\s+\w+\s*(?:\([^;]*?\))?\s*=[ \t]*)"
                      r"(?P<expr>[^;\"]*?\bgetTable1DValue(?:NoDer2?)?\s*\([^;\"]*?)"
                      r"(?P<tail>\s*(?:\"[^\"]*\"\s*)?(?:annotation\b[^;]*)?;)")


def transform_table_bindings(text):
    """``text`` with each parameter binding that calls a table lookup written ``1.0*(...)``; the lines are kept
    (the expression keeps its line breaks). Returns the text and the number of bindings rewritten."""
    return _BINDING.subn(lambda m: f"{m['head'].rstrip()} 1.0*({m['expr']}){m['tail']}", text)


def transformed_roots(roots, version, fingerprint):
    """The library folders to hand rumoca ``version``: each of ``roots`` whose files hold the construct replaced by
    its transformed copy (made once per library state ``fingerprint``), with a :class:`LibraryTransformWarning`.

    Returns
    -------
    tuple of Path
    """
    if version != RUMOCA_VERSION:
        return tuple(roots)
    out = []
    for root in roots:
        key = hashlib.sha256(f"{root}\n{fingerprint}".encode()).hexdigest()[:16]
        folder = user_cache_root() / "cosim" / "library-transforms" / f"rumoca-{version}" / key
        if not (folder / "count").is_file():
            _write_copy(root, folder)
        count = int((folder / "count").read_text())
        out.append(folder / root.name if count else root)
        if count:
            warnings.warn(LibraryTransformWarning(f"{TRANSFORM}: {count} parameter bindings of {root} read from a "
                                                  f"transformed private copy ({folder / root.name}): {_WHY}"),
                          stacklevel=2)
    return tuple(out)


def _write_copy(root, folder):
    """Write ``folder``: ``count`` (the bindings rewritten) and, when there are any, ``<root's name>/`` with the
    ``.mo`` files of ``root`` transformed and a link for every other file. Built aside and renamed into place, so
    that builds running at once never read a half-written copy."""
    texts = {mo: transform_table_bindings(mo.read_text(encoding="utf-8")) for mo in sorted(root.rglob("*.mo"))}
    count = sum(n for _, n in texts.values())
    folder.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f"{folder.name}-", dir=folder.parent))
    for source in (sorted(p for p in root.rglob("*") if p.is_file()) if count else ()):
        target = scratch / root.name / source.relative_to(root)
        target.parent.mkdir(parents=True, exist_ok=True)
        if source in texts:
            target.write_text(texts[source][0], encoding="utf-8")  # a link would lead rumoca to the original's folder
        else:
            target.symlink_to(source)
    (scratch / "count").write_text(str(count))
    if (folder / "count").is_file():  # another build put it there first
        shutil.rmtree(scratch)
        return
    if folder.is_dir() and not (folder / "count").is_file():  # left without its count by an older cosim
        shutil.rmtree(folder)
    scratch.rename(folder)
