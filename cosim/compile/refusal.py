"""What a user reads when the front end refuses a model: that rumoca (with its version) refused it, the class
its message names and that class's file and line (not the library's ``package.mo``), whether cosim's own
validation run on the Modelica Standard Library examples saw the same model refused (``data/msl_validation.csv``,
written by ``benchmarks/msl.py --validation``), and what to try."""

import csv
import functools
from importlib import resources

import rumoca

from cosim.compile.source_text import class_source

__all__ = ["validation_status", "refusal"]

VALIDATED_MSL = "4.1.0"  # the MSL version of cosim's validation run (data/msl_validation.csv)


@functools.cache
def _validation_rows():
    with resources.files("cosim").joinpath("data", "msl_validation.csv").open("r", encoding="utf-8") as fh:
        return {row["model"]: (row["stage"], row["cause"]) for row in csv.DictReader(fh)}


def validation_status(model):
    """``(stage, cause)`` of ``model`` in cosim's validation run on the MSL examples (stage ``rumoca``: the front
    end refused it, ``verified``: it matched the reference results; docs/validation.md), or None when the run did
    not try it."""
    return _validation_rows().get(model)


def _known(model):
    """What cosim's validation run says of ``model``, and what to try, as two sentences."""
    status = validation_status(model)
    other_tool = ("build its FMU with another Modelica tool (OpenModelica, Dymola) and co-simulate that FMU with "
                  "cosim run")
    if status is not None and status[0] == "rumoca":
        return (f"cosim's validation run on the MSL {VALIDATED_MSL} examples (docs/validation.md) saw rumoca refuse "
                f"this model too: a limit of the front end, not a fault of the library or of your setup",
                f"try an example cosim verifies (docs/validation.md), or {other_tool}")
    if status is not None:
        return (f"cosim's validation run on the MSL {VALIDATED_MSL} examples got this model further (stage "
                f"{status[0]})", f"check that the library on --modelica-path is the MSL {VALIDATED_MSL}")
    if model.startswith("Modelica."):
        return (f"cosim's validation run on the MSL {VALIDATED_MSL} examples did not try this model",
                f"if another Modelica tool accepts it, the limit is the front end's: {other_tool}")
    return ("", "if another Modelica tool (OpenModelica, Dymola) accepts the model, the limit is the front end's: "
                "write the part it refuses differently, or build the FMU with that tool and co-simulate it with "
                "cosim run; otherwise correct the model")


def refusal(model, said, path, roots=()):
    """``(message, file, line)`` of the front end's refusal of ``model``.

    Parameters
    ----------
    model : str
        The full model name.
    said : str
        What rumoca said (``unbalanced model: 115 equations, 112 unknowns ...``).
    path : Path
        The file the model was loaded from (a library's ``package.mo`` for a library model).
    roots : sequence of Path
        The library folders.
    """
    in_library = any(path.resolve().is_relative_to(root.resolve()) for root in roots)
    file, line, _ = class_source(None if in_library else path, model, roots)
    known, attempt = _known(model)
    message = f"rumoca {rumoca.version()}, the Modelica front end, refused {model}: {said}"
    return f"{message}; {known + '; ' if known else ''}{attempt}", file or str(path), line
