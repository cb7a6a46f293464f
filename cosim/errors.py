"""The typed errors of cosim: callers tell failures apart by type, not by message text."""

__all__ = [
    "CosimError",
    "ModelicaError",
    "UnsupportedConstructError",
    "StructureError",
    "BuildError",
    "ConfigError",
    "FmiCallError",
    "FmuFileError",
    "NotFittedError",
    "HapticDataError",
    "EngineFallbackWarning",
    "EffectSlotError",
]


class CosimError(Exception):
    """Base of every error cosim raises on purpose; the CLI turns it into exit code 2."""


class ModelicaError(CosimError, ValueError):
    """A Modelica source cannot be parsed or flattened (syntax, unknown model, missing file).

    Parameters
    ----------
    message : str
        What went wrong.
    file : str, optional
        The source file, when known.
    line : int, optional
        The 1-based line in ``file``, when known.
    """

    def __init__(self, message, file=None, line=None):
        self.file = file
        self.line = line
        where = ""
        if file is not None:
            where = f"{file}:{line}: " if line is not None else f"{file}: "
        super().__init__(f"{where}{message}")


class UnsupportedConstructError(ModelicaError):
    """The model uses a construct the compiler does not lower (``when``, ``pre``, discrete variables...)."""


class StructureError(ModelicaError):
    """The model is under- or over-determined, or its equations cannot be made explicit."""


class BuildError(CosimError, RuntimeError):
    """Exporting, compiling or packing the FMU failed."""


class ConfigError(CosimError, ValueError):
    """A run config or job file is invalid; the message names the file, line and key."""


class FmiCallError(CosimError, RuntimeError):
    """An FMI function returned a status worse than warning.

    Parameters
    ----------
    function : str
        The FMI function name, e.g. ``fmi3DoStep``.
    status : str
        The status label returned.
    """

    def __init__(self, function, status, detail=""):
        self.function = function
        self.status = status
        super().__init__(f"{function} returned {status}{': ' + detail if detail else ''}")


class FmuFileError(CosimError, FileNotFoundError):
    """An FMU file is missing, not a zip archive, or has no usable modelDescription.xml."""


class NotFittedError(CosimError, AttributeError):
    """A result was asked of an estimator (a calibrator, an identification fit) before ``fit`` ran."""


class HapticDataError(CosimError, ValueError):
    """A requested user, position, axis or structure is not in the shipped tables, or a value is missing."""


class EngineFallbackWarning(UserWarning):
    """The compiled engine was asked for but the run uses the Python engine (the message says why)."""


class EffectSlotError(ConfigError):
    """A candidate effect does not fit a model: the model has no replaceable slot (or parameter) the effect fills,
    or the effect's block does not extend the slot's constraining interface."""
