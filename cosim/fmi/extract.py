"""Unpack an FMU archive without letting its member names escape the target directory."""

import os
import stat
import zipfile
from pathlib import Path

from cosim.errors import FmuFileError

__all__ = ["safe_extract"]


def safe_extract(path, target):
    """Extract the zip archive ``path`` into the directory ``target``.

    Members with absolute names, ``..`` components, drive letters or symlink modes are refused.

    Parameters
    ----------
    path : path-like
    target : path-like
        Existing directory.

    Raises
    ------
    FmuFileError
        A member would land outside ``target``, or the archive is unreadable.
    """
    target = Path(target).resolve()
    try:
        with zipfile.ZipFile(path) as zf:
            for info in zf.infolist():
                name = info.filename
                mode = info.external_attr >> 16
                if stat.S_ISLNK(mode):
                    raise FmuFileError(f"{path}: member {name!r} is a symbolic link; refused")
                parts = Path(name.replace("\\", "/")).parts
                if name.startswith(("/", "\\")) or ".." in parts or (parts and ":" in parts[0]):
                    raise FmuFileError(f"{path}: member {name!r} would be written outside the unpack folder")
                dest = (target / name).resolve()
                if dest != target and target not in dest.parents:
                    raise FmuFileError(f"{path}: member {name!r} would be written outside the unpack folder")
            zf.extractall(target)
    except zipfile.BadZipFile as err:
        raise FmuFileError(f"{path}: not a valid zip archive: {err}") from err
    for root, _, files in os.walk(target):
        for f in files:
            p = os.path.join(root, f)
            if p.endswith((".so", ".dylib", ".dll")):
                os.chmod(p, 0o755)
    return target
