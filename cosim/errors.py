"""The typed errors of cosim: callers tell failures apart by type, not by message text."""

__all__ = [
    "CosimError",
    "ModelicaError",
    "UnsupportedConstructError",
    "StructureError",
    "BuildError",
    "ConfigError",
    "SspError",
    "ParameterError",
    "FmiCallError",
    "FmuFileError",
    "NotFittedError",
    "HapticDataError",
    "EngineFallbackWarning",
    "ScaleWarning",
    "LoopWarning",
    "OutputWarning",
    "LibraryTransformWarning",
    "EffectSlotError",
    "EventError",
    "SimulationTerminated",
    "NonFiniteError",
    "RunStopped",
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


class SspError(ConfigError):
    """An SSP archive cannot be run or written: a missing FMU, a connection to an unknown connector, a unit
    mismatch, an element cosim does not support. The message names the archive, the SSD line and the element."""


class ParameterError(CosimError, ValueError):
    """A controller parameter (or its rate) has a value the controller cannot run with; raised when the
    controller is built, before a run starts.

    Parameters
    ----------
    controller : str
        The controller class.
    key : str
        The parameter (``rate`` for the sample rate).
    expected : str
        What the value must be, e.g. ``"a number in (0, inf) s"``.
    received : object
        The value given.
    """

    def __init__(self, controller, key, expected, received):
        self.controller = controller
        self.key = key
        self.expected = expected
        self.received = received
        super().__init__(f"{controller}: parameter {key!r}: expected {expected}; received {received!r}")


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


class ScaleWarning(UserWarning):
    """A config's rate or run length is far from the plant's time scale (a typo of a factor 1000 is likely); the
    run goes on, the message names the key, its value and the scale it was told against."""


class LoopWarning(UserWarning):
    """A nonlinear algebraic loop of a model has no solution the build finds at the model's start point; the FMU
    is built, and reports an error wherever the loop's Newton iterations do not converge (the message names the
    loop's unknowns and equations)."""


class OutputWarning(UserWarning):
    """A part of a command's output that the results do not depend on (a plot, a summary plugin's keys) could
    not be made; the results themselves were written (the message says what is missing and why)."""


class LibraryTransformWarning(UserWarning):
    """A library was handed to the Modelica front end as a transformed private copy, to work around a bug of that
    front end's version; the user's files are unchanged (the message names the transform, the files and why)."""


class EffectSlotError(ConfigError):
    """A candidate effect does not fit a model: the model has no replaceable slot (or parameter) the effect fills,
    or the effect's block does not extend the slot's constraining interface."""


class EventError(CosimError, RuntimeError):
    """Event handling failed: events chatter at one instant (the event iteration does not settle), or an event
    cannot be located. The message names the FMU and the time."""


class SimulationTerminated(CosimError):
    """An FMU asked to stop (``terminateSimulation``, a Modelica ``terminate()``). Not a failure: the master
    stops the run, keeps what was recorded and states the reason in the summary.

    Parameters
    ----------
    instance : str
        The FMU instance that asked.
    time : float
        When it asked (s).
    reason : str
        The FMU's message, when it gave one.
    """

    def __init__(self, instance, time, reason=""):
        self.instance = instance
        self.time = time
        self.reason = reason
        super().__init__(f"{instance} asked to terminate at t={time:.9g} s{': ' + reason if reason else ''}")


class NonFiniteError(CosimError, FloatingPointError):
    """A state, derivative or output became NaN or infinite: the run stops at the first instant it is seen.

    Parameters
    ----------
    instance : str
        The FMU or controller instance whose value is not finite.
    variable : str
        The variable (``der(x)`` for a derivative).
    time : float
        The instant (s).
    value : float
        The value (nan, inf or -inf).
    """

    def __init__(self, instance, variable, time, value):
        self.instance = instance
        self.variable = variable
        self.time = time
        self.value = value
        super().__init__(f"{instance}.{variable} = {value} at t={time:.9g} s (the first instant a state, "
                         f"derivative or output is not finite)")


class RunStopped(CosimError):
    """A run stopped early on a fault (an exception, a non-finite value); what was recorded was written.

    Parameters
    ----------
    stopped : dict
        ``RunResult.stopped``: ``by``, ``time``, ``reason``, ``cause``.
    files : list of pathlib.Path
        The files written.
    """

    def __init__(self, stopped, files):
        self.stopped = stopped
        self.files = files
        super().__init__(f"the run stopped early: {stopped['reason']}")
