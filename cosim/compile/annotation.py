"""A model's ``experiment`` annotation, read from its Modelica text (rumoca 0.10.2 gives no annotations): the
start and stop time, output interval and tolerance its author meant it to be run with, written into the FMU's
DefaultExperiment. Lexical only: the class is found by its ``model ... end Name;`` lines, comments and strings
masked, the annotation's numeric arguments read; nothing is parsed."""

import re

from cosim.compile.source_text import class_source, masked
from cosim.modelica_text import own_text

__all__ = ["EXPERIMENT_KEYS", "experiment_annotation", "model_experiment"]

EXPERIMENT_KEYS = ("StartTime", "StopTime", "Interval", "Tolerance")
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


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
    return experiment_annotation(class_source(path, model, roots)[2])
