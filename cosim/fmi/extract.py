"""Unpack an FMU archive without letting its member names escape the target directory, and without letting a
small archive fill the disk (a "zip bomb"): total size, entry count and compression ratio are bounded, checked
against the archive's directory before anything is written and again while the bytes are inflated."""

import os
import stat
import zipfile
import zlib
from pathlib import Path

from cosim.errors import FmuFileError
from cosim.fmi.model import REBUILD_HINT

__all__ = ["safe_extract", "MAX_TOTAL_BYTES", "MAX_ENTRIES", "MAX_RATIO"]

MAX_TOTAL_BYTES = 2 * 2**30  # an FMU with binaries for every platform is tens of MB; 2 GiB is far beyond
MAX_ENTRIES = 10_000
MAX_RATIO = 200  # deflate packs source text ~10:1; a member packed more than 200:1 (past 1 MiB) is a bomb
_RATIO_FROM = 2**20
_CHUNK = 2**20


def _check_member(path, info, target):
    """Refuse a member whose name or mode would escape ``target``, or whose compression ratio is a bomb's."""
    name = info.filename
    if stat.S_ISLNK(info.external_attr >> 16):
        raise FmuFileError(f"{path}: member {name!r} is a symbolic link; refused")
    parts = Path(name.replace("\\", "/")).parts
    if name.startswith(("/", "\\")) or ".." in parts or (parts and ":" in parts[0]):
        raise FmuFileError(f"{path}: member {name!r} would be written outside the unpack folder")
    dest = (target / name).resolve()
    if dest != target and target not in dest.parents:
        raise FmuFileError(f"{path}: member {name!r} would be written outside the unpack folder")
    if info.file_size > _RATIO_FROM and info.file_size > MAX_RATIO * max(info.compress_size, 1):
        raise FmuFileError(f"{path}: member {name!r} inflates {info.compress_size} bytes to {info.file_size} "
                           f"(more than {MAX_RATIO}:1); refused as a zip bomb")
    return dest


def _copy(zf, info, dest, path, budget):
    """Inflate ``info`` into ``dest``, never past its declared size nor the archive's remaining ``budget``."""
    written = 0
    with zf.open(info) as src, open(dest, "wb") as out:
        while chunk := src.read(_CHUNK):
            written += len(chunk)
            if written > info.file_size or written > budget:
                raise FmuFileError(f"{path}: member {info.filename!r} inflates past its declared size "
                                   f"({info.file_size} bytes); refused")
            out.write(chunk)
    return written


def safe_extract(path, target):
    """Extract the zip archive ``path`` into the directory ``target``.

    Members with absolute names, ``..`` components, drive letters or symlink modes are refused, and so are
    archives of more than ``MAX_ENTRIES`` members or ``MAX_TOTAL_BYTES`` unpacked, or with a member packed more
    than ``MAX_RATIO``:1.

    Parameters
    ----------
    path : path-like
    target : path-like
        Existing directory.

    Returns
    -------
    pathlib.Path
        ``target``, resolved.

    Raises
    ------
    FmuFileError
        A member would land outside ``target``, a bound is passed, or the archive is unreadable or corrupt.
    """
    target = Path(target).resolve()
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            total = sum(i.file_size for i in infos)
            if len(infos) > MAX_ENTRIES or total > MAX_TOTAL_BYTES:
                raise FmuFileError(f"{path}: {len(infos)} members, {total / 2**20:.1f} MiB unpacked; an FMU is "
                                   f"refused past {MAX_ENTRIES} members or {MAX_TOTAL_BYTES / 2**30:g} GiB")
            dests = [_check_member(path, info, target) for info in infos]
            budget = MAX_TOTAL_BYTES
            for info, dest in zip(infos, dests):
                if info.is_dir():
                    dest.mkdir(parents=True, exist_ok=True)
                    continue
                dest.parent.mkdir(parents=True, exist_ok=True)
                budget -= _copy(zf, info, dest, path, budget)
    except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError) as err:
        raise FmuFileError(f"{path}: not a valid zip archive (corrupt or unsupported member): {err}; "
                           f"{REBUILD_HINT}") from err
    for root, _, files in os.walk(target):
        for f in files:
            p = os.path.join(root, f)
            if p.endswith((".so", ".dylib", ".dll")):
                os.chmod(p, 0o755)
    return target
