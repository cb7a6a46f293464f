"""A model's ``experiment`` annotation, read from its Modelica text (rumoca 0.10.2 gives no annotations): the
start and stop time, output interval and tolerance its author meant it to be run with, written into the FMU's
DefaultExperiment. Lexical only: the class is found by its ``model ... end Name;`` lines, comments and strings
masked, the annotation's numeric arguments read; nothing is parsed."""

import re
from pathlib import Path

from cosim.compile.source_text import masked
from cosim.modelica_text import find_class, own_text

__all__ = ["EXPERIMENT_KEYS", "class_text", "experiment_annotation", "model_experiment"]

EXPERIMENT_KEYS = ("StartTime", "StopTime", "Interval", "Tolerance")
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def class_text(name, roots):
    """The text of library class ``name`` (``Modelica.Blocks.Examples.PID_Controller``) in the folders ``roots``:
    its own file (``PID_Controller.mo``) or its span in the ``package.mo``/``Examples.mo`` that declares it;
    '' when no folder holds it."""
    parts = name.split(".")
    for root in roots:
        here = Path(root)
        for k, part in enumerate(parts):
            if (here / part).is_dir() and k < len(parts) - 1:
                here = here / part
                continue
            mo = here / f"{part}.mo" if (here / f"{part}.mo").is_file() else here / "package.mo"
            if mo.is_file():
                return _span(mo.read_text(encoding="utf-8", errors="replace"), parts[-1])
            break
    return ""


def _span(text, name):
    """The text from ``model|block|class name`` to ``end name;`` in ``text`` (comments and strings skipped)."""
    hidden = masked(text)
    start = re.search(rf"\b(?:model|block|class)\s+{re.escape(name)}\b", hidden)
    end = re.search(rf"\bend\s+{re.escape(name)}\s*;", hidden[start.end():]) if start else None
    return text[start.start():start.end() + end.end()] if end else ""


def experiment_annotation(text):
    """``{key: value}`` of the numeric arguments of the ``experiment(...)`` annotation in the class text ``text``
    (its nested classes left out), keys among :data:`EXPERIMENT_KEYS`; {} when it has none."""
    own = masked(own_text(text)) if text else ""
    found = re.search(r"\bexperiment\s*\((?P<body>[^()]*)\)", own)
    if not found:
        return {}
    values = {}
    for key in EXPERIMENT_KEYS:
        given = re.search(rf"\b{key}\s*=\s*(?P<v>{_NUMBER})\s*(?:,|$)", found.group("body"))
        if given:
            values[key] = float(given.group("v"))
    return values


def model_experiment(path, model, roots=()):
    """The experiment annotation of ``model``: from the file ``path``, or from the library folders ``roots``
    when ``path`` is None (:func:`experiment_annotation`)."""
    if path is None:
        return experiment_annotation(class_text(model, roots))
    return experiment_annotation(find_class(Path(path).read_text(encoding="utf-8"), model) or "")
