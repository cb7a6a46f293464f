"""Modelica front end: rumoca parses and flattens a model into its DAE IR; this module maps its failures to
cosim errors with file and line, and gives source locations for IR spans."""

import re
from dataclasses import dataclass
from pathlib import Path

import rumoca

from cosim.errors import ModelicaError, StructureError
from cosim.modelica_text import check_redeclares

__all__ = ["FlatModel", "load_flat_model"]

# A rumoca diagnostic locates itself as "╭─[file:line:col]" and states the problem after "×".
_LOCATION = re.compile(r"╭─\[(?P<file>[^\]]+?):(?P<line>\d+):(?P<col>\d+)\]")
_PROBLEM = re.compile(r"×\s*(?P<msg>.+?)(?:\n\s*│\s*(?P<more>.+?))?\n")


@dataclass(frozen=True)
class FlatModel:
    """A flattened model: rumoca's DAE IR plus the source texts its spans point into.

    Attributes
    ----------
    name : str
        Full Modelica name, e.g. ``Gripper.GripperPlant``.
    path : Path
        The file the model was loaded from.
    ir : dict
        ``Model.to_dict('dae')`` as rumoca returns it.
    """

    name: str
    path: Path
    ir: dict

    def locate(self, span):
        """Return ``"file:line"`` for a rumoca span dict (``{"source", "start", "end"}``), or the file alone."""
        if not span:
            return str(self.path)
        for file_id, file_name, text in self.ir.get("source_map", {}).get("files", []):
            if file_id == span.get("source"):
                line = text.count("\n", 0, span.get("start", 0)) + 1
                return f"{file_name}:{line}"
        return str(self.path)


def _first_diagnostic(diagnostics, default_file):
    """Turn rumoca's first error diagnostic into (message, file, line)."""
    for diag in diagnostics:
        if getattr(diag, "level", "error") != "error":
            continue
        text = str(getattr(diag, "message", diag))
        loc = _LOCATION.search(text)
        prob = _PROBLEM.search(text + "\n")
        message = prob.group("msg").strip() if prob else text.strip().splitlines()[0]
        if prob and prob.group("more"):
            message = f"{message} {prob.group('more').strip()}"
        if loc:
            return message, loc.group("file"), int(loc.group("line"))
        return message, getattr(diag, "file", default_file), getattr(diag, "line", None)
    return None


def load_flat_model(path, model):
    """Parse and flatten ``model`` from the Modelica file ``path`` with rumoca.

    Parameters
    ----------
    path : str or Path
        A ``.mo`` file. rumoca also reads every other ``.mo`` file in its directory.
    model : str
        Full name of the model, e.g. ``Pkg.Model``.

    Returns
    -------
    FlatModel

    Raises
    ------
    ModelicaError
        Missing file, syntax error (with file:line), unknown model name.
    StructureError
        rumoca found the model unbalanced (more or fewer equations than unknowns).
    UnsupportedConstructError
        A ``redeclare`` form that rumoca would ignore without a word (:func:`~cosim.modelica_text.check_redeclares`).
    """
    path = Path(path)
    if not path.is_file():
        raise ModelicaError(f"no such Modelica file: {path}")
    for mo in sorted(path.parent.glob("*.mo")):
        found = _first_diagnostic(rumoca.validate(str(mo)), str(mo))
        if found:
            message, file, line = found
            raise ModelicaError(message, file=file, line=line)
    check_redeclares(path.read_text(encoding="utf-8"), str(path))
    try:
        # No local names rumoca's Session or Model: they are unsendable PyO3 objects, and a frame a Dask worker's
        # profiler still holds when this returns would drop them on the profiler's thread (a RuntimeError printed
        # by tornado, the objects leaked).
        ir = rumoca.Session().load(str(path), model=model).to_dict("dae")
    except rumoca.RumocaError as err:
        text = str(err)
        if "resolve/parse failed" in text or "not found" in text.lower():
            raise ModelicaError(f"no model named {model!r} in {path.parent}", file=str(path)) from err
        if "unbalanced" in text:
            detail = text.split("unbalanced model:")[-1].strip()
            raise StructureError(
                f"model {model} is unbalanced: {detail}", file=str(path)
            ) from err
        raise ModelicaError(f"{model}: {text.splitlines()[0]}", file=str(path)) from err
    return FlatModel(name=model, path=path, ir=ir)
