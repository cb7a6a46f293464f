"""Read what an FMU declares (variables, causality, units, kinds, output dependencies) into frozen records.

Only the XML is read here (through fmpy's parser); nothing is loaded or executed.
"""

import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from cosim.errors import FmuFileError

__all__ = ["Variable", "ModelInfo", "read_model_info", "BUILD_HINT", "REBUILD_HINT"]

# how to make a missing FMU, and how to replace a damaged one: the end of every message about an FMU file
BUILD_HINT = ("the project's FMUs are made by `cosim build` (modelica/models.toml -> fmus/), a model of yours by "
              "`cosim build FILE.mo --model Pkg.Model --out DIR`")
REBUILD_HINT = "if it is one cosim built, build it again: `cosim build --force`"


@dataclass(frozen=True)
class Variable:
    """One model variable.

    Attributes
    ----------
    name : str
    vr : int
        Value reference.
    type : str
        'Real' (FMI 2) or 'Float64' etc. (FMI 3).
    causality : str
        'input', 'output', 'parameter', 'local', 'independent', 'calculatedParameter', ...
    variability : str
        'constant', 'fixed', 'tunable', 'discrete' or 'continuous'.
    unit : str
        Unit string ('' when undeclared).
    start : str or None
        Start value as written in the XML.
    description : str
    min, max : float or None
        The declared range (the variable's or its type's ``min``/``max``; None: unbounded on that side).
    """

    name: str
    vr: int
    type: str
    causality: str
    variability: str
    unit: str = ""
    start: str | None = None
    description: str = ""
    min: float | None = None
    max: float | None = None


@dataclass(frozen=True)
class ModelInfo:
    """What an FMU declares.

    Attributes
    ----------
    path : pathlib.Path
    fmi_version : int
        2 or 3.
    model_name : str
    kinds : tuple of str
        Subset of ('ME', 'CS') the FMU provides.
    variables : dict of str to Variable
    n_states : int
    n_event_indicators : int
    output_deps : dict of str to tuple of str or None
        For each output, the names of the inputs it depends on directly (``None``: unknown, assume all).
    needs_completed_step : bool
        ME: whether ``CompletedIntegratorStep`` must be called.
    step : float or None
        The step the FMU declares for itself in s (the default of a cosim FMU's ``_cs_step``, set per model in
        modelica/models.toml, else the DefaultExperiment's ``stepSize``): the time scale its rates are told against.
    version_text : str
        ``fmiVersion`` as written ("3.0", "2.0").
    generation_tool, description : str
        What the model description says of the tool that wrote the FMU and of the model ('' when it does not).
    default_experiment : dict
        The DefaultExperiment: ``start``, ``stop``, ``step``, ``tolerance`` (s, s, s, relative), each a float or
        None when not given.
    """

    path: Path
    fmi_version: int
    model_name: str
    kinds: tuple
    variables: dict = field(repr=False)
    n_states: int = 0
    n_event_indicators: int = 0
    output_deps: dict = field(default_factory=dict, repr=False)
    needs_completed_step: bool = True
    step: float = None
    version_text: str = ""
    generation_tool: str = ""
    description: str = ""
    default_experiment: dict = field(default_factory=dict)

    def names(self, causality):
        """Names of the variables with the given causality, in declaration order."""
        return [v.name for v in self.variables.values() if v.causality == causality]


def _attribute(variable, name):
    """A numeric attribute (``min``, ``max``) of a variable, else of its declared type, as a float; None when
    neither declares one that reads as a number."""
    for holder in (variable, variable.declaredType):
        text = getattr(holder, name, None) if holder is not None else None
        if text not in (None, ""):
            try:
                return float(text)
            except (TypeError, ValueError):
                return None
    return None


def read_model_info(path):
    """Read an FMU's modelDescription.xml.

    Parameters
    ----------
    path : path-like
        The ``.fmu`` file.

    Returns
    -------
    ModelInfo

    Raises
    ------
    FmuFileError
        The file does not exist, is not a zip, or its description cannot be parsed.
    """
    import fmpy

    path = Path(path)
    if not path.is_file():
        raise FmuFileError(f"FMU file {str(path)!r} does not exist; {BUILD_HINT}")
    if not zipfile.is_zipfile(path):
        raise FmuFileError(f"{str(path)!r} is not an FMU (not a zip archive); {REBUILD_HINT}")
    try:
        md = fmpy.read_model_description(str(path), validate=False)
    except Exception as err:  # fmpy raises plain Exception for every parse problem
        raise FmuFileError(f"{str(path)!r}: cannot read modelDescription.xml: {err}") from err
    version = int(md.fmiVersion.split(".")[0])
    if version not in (2, 3):
        raise FmuFileError(f"{str(path)!r}: FMI {md.fmiVersion} is not supported (2.0 and 3.0 are)")
    variables = {}
    for v in md.modelVariables:
        unit = v.unit or (v.declaredType.unit if v.declaredType is not None and v.declaredType.unit else "") or ""
        variables[v.name] = Variable(
            name=v.name,
            vr=int(v.valueReference),
            type=v.type,
            causality=v.causality or "local",
            variability=v.variability or "continuous",
            unit=unit,
            start=None if v.start is None else str(v.start),
            description=v.description or "",
            min=_attribute(v, "min"),
            max=_attribute(v, "max"),
        )
    inputs = {v.name for v in variables.values() if v.causality == "input"}
    deps = {}
    for o in md.outputs:
        if o.dependencies is None:
            deps[o.variable.name] = None
        else:
            deps[o.variable.name] = tuple(d.name for d in o.dependencies if d.name in inputs)
    for name in (v.name for v in variables.values() if v.causality == "output"):
        deps.setdefault(name, None)
    kinds = tuple(k for k, present in (("ME", md.modelExchange), ("CS", md.coSimulation)) if present)
    needs = True
    if md.modelExchange is not None:
        needs = bool(getattr(md.modelExchange, "needsCompletedIntegratorStep", True))
    return ModelInfo(
        path=path,
        fmi_version=version,
        model_name=md.modelName,
        kinds=kinds,
        variables=variables,
        n_states=int(md.numberOfContinuousStates or len(md.derivatives)),
        n_event_indicators=int(md.numberOfEventIndicators or 0),
        output_deps=deps,
        needs_completed_step=needs,
        step=_declared_step(md, variables),
        version_text=md.fmiVersion,
        generation_tool=md.generationTool or "",
        description=md.description or "",
        default_experiment=_default_experiment(md.defaultExperiment),
    )


def _default_experiment(experiment):
    """The DefaultExperiment's attributes as floats (None when absent or not a finite number)."""
    out = {}
    for key, attribute in (("start", "startTime"), ("stop", "stopTime"), ("step", "stepSize"),
                           ("tolerance", "tolerance")):
        try:
            value = float(getattr(experiment, attribute, None))
        except (TypeError, ValueError):
            value = None
        out[key] = value if value is not None and math.isfinite(value) else None
    return out


def _declared_step(md, variables):
    """The FMU's own step (``_cs_step``'s default, else DefaultExperiment stepSize) in s, or None."""
    cs = variables.get("_cs_step")
    text = cs.start if cs is not None else getattr(md.defaultExperiment, "stepSize", None)
    try:
        step = float(text)
    except (TypeError, ValueError):
        return None
    return step if math.isfinite(step) and step > 0 else None
