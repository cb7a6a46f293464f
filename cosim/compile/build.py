"""Build FMUs: one model on request, or every model of ``modelica/models.toml``, skipping those whose sources
and compiler are unchanged."""

import dataclasses
import hashlib
import json
import tomllib
from pathlib import Path

from cosim import __version__
from cosim.compile.annotation import model_experiment
from cosim.compile.balance import unbalanced_error
from cosim.compile.divisions import check_divisions
from cosim.compile.export import DEFAULT_CS_STEP, METHODS, export_fmu
from cosim.compile.frontend import load_flat_model
from cosim.compile.library import library_fingerprint, library_path
from cosim.compile.lower import lower_system
from cosim.compile.translate import translate
from cosim.errors import BuildError, ConfigError, StructureError

__all__ = ["lower", "build_fmu", "build_all", "build_listed", "mark_fmu_folder", "read_model_list"]

_STATE_FILE = ".build-state.json"
_ENTRY_KEYS = {"name", "model", "source", "description", "fmi_version", "c_sources", "cs_step", "cs_method"}
_FMI_VERSIONS = (2, 3)


# Lowered models by source: a diagnosis lowers the same baseline and variants in every stage and every task
# (0.5 s each, a quarter of an impact case's CPU time); the last few are kept, keyed on what rumoca reads.
_LOWERED = {}
_LOWERED_KEPT = 16


def _source_key(path, model, modelica_path):
    """What a lowering of ``model`` depends on: the file, the contents of every ``.mo`` file of its directory
    (rumoca reads them all) and the libraries' fingerprint."""
    digest = hashlib.sha256()
    if path is not None:
        path = Path(path).resolve()
        for mo in sorted(path.parent.glob("*.mo")):
            digest.update(f"{mo.name}\n".encode() + mo.read_bytes())
    roots = tuple(str(r) for r in modelica_path)
    return str(path), model, roots, digest.hexdigest(), library_fingerprint(roots) if roots else ""


def lower(path, model, modelica_path=()):
    """Parse, flatten and lower Modelica model ``model`` from file ``path`` to a :class:`LoweredModel`.

    This is the public, explicit form of the model (CasADi functions ``ode`` and ``out`` of x, u, p, t) that the
    FMU contains, for calibration and diagnosis with exact derivatives. A model lowered before from the same
    sources is returned again (a frozen record), not lowered anew.

    Parameters
    ----------
    path : str or Path or None
        The ``.mo`` file holding the model (rumoca also reads the other ``.mo`` files of its directory); None for
        a model of a library on ``modelica_path``.
    model : str
        Full model name, e.g. ``Gripper.GripperPlant``.
    modelica_path : sequence of Path, default ()
        Folders holding the Modelica libraries the model uses (:func:`cosim.compile.library.library_path`).

    Returns
    -------
    LoweredModel
    """
    if path is not None and not Path(path).is_file():
        return _lower_once(path, model, modelica_path)  # the loader's error
    key = _source_key(path, model, modelica_path)
    if key not in _LOWERED:
        lowered = _lower_once(path, model, modelica_path)
        if len(_LOWERED) >= _LOWERED_KEPT:
            del _LOWERED[next(iter(_LOWERED))]
        _LOWERED[key] = lowered
    return _LOWERED[key]


def _lower_once(path, model, modelica_path):
    """Load, translate and lower ``model``; an unbalanced one names what it has in excess (cosim.compile.balance).
    The lowered model carries the model's experiment annotation (the FMU's DefaultExperiment)."""
    try:
        flat = load_flat_model(path, model, modelica_path)
    except StructureError as err:
        if getattr(err, "padded", None) is None:
            raise
        raise unbalanced_error(err, translate(err.padded)) from None
    return dataclasses.replace(lower_system(translate(flat)),
                               experiment=model_experiment(path, model, modelica_path))


def build_fmu(path, model, out_dir="fmus", name=None, description="", fmi_version=3, source=False,
              cs_step=DEFAULT_CS_STEP, cs_method="rk4", modelica_path=()):
    """Build Modelica model ``model`` of file ``path`` to ``out_dir/<name>.fmu``.

    Parameters
    ----------
    path : str or Path or None
        The ``.mo`` file holding the model (rumoca also reads the other ``.mo`` files of its directory); None for
        a model of a library on ``modelica_path``.
    model : str
        Full model name, e.g. ``Gripper.GripperPlant``.
    out_dir : str or Path, default "fmus"
    name : str, optional
        FMU file stem; default: the model's last name component.
    description : str, optional
        The FMU's ``description`` attribute.
    fmi_version : {3, 2}, default 3
        FMI 3.0, or FMI 2.0 (Model Exchange and Co-Simulation in one FMU).
    source : bool, default False
        Also ship the C sources in the FMU (``sources/``), for importers on other platforms.
    cs_step : float, default 1e-3
        Co-Simulation: the embedded solver's internal step (s), the start value of parameter ``_cs_step``.
    cs_method : {"rk4", "implicit_euler"}
        Co-Simulation: the embedded solver, the start value of parameter ``_cs_method``.
    modelica_path : sequence of Path, default ()
        Folders holding the Modelica libraries the model uses (:func:`cosim.compile.library.library_path`).

    Returns
    -------
    Path
        The written FMU. Nothing is written when any step fails.

    Raises
    ------
    ModelicaError
        The source cannot be compiled, or divides by zero at its parameter values (:func:`check_divisions`).
    BuildError
        ``out_dir`` is an existing file, or the FMU cannot be compiled or packed.
    """
    if Path(out_dir).exists() and not Path(out_dir).is_dir():
        raise BuildError(f"{out_dir}: the output folder is an existing file; give --out a folder")
    lowered = lower(path, model, modelica_path)
    check_divisions(lowered, path)
    name = name or model.rsplit(".", 1)[-1]
    return export_fmu(lowered, Path(out_dir) / f"{name}.fmu", description=description, cs_step=cs_step,
                      cs_method=cs_method, fmi_version=fmi_version, source=source)


def _compiler_fingerprint():
    digest = hashlib.sha256(__version__.encode())
    here = Path(__file__).parent
    sources = sorted(here.glob("*.py")) + sorted((here / "fmu_c").glob("*.[ch]"))  # the FMU's C wrapper too
    for source in sources + [here.parent / "modelica_text.py"]:  # the front end's redeclare check
        digest.update(source.read_bytes())
    return digest.hexdigest()


def _source_hash(source, model, options="", library=""):
    """The build's key: model, options, compiler, the source folder's files and ``library``, the fingerprint of the
    libraries it uses (:func:`~cosim.compile.library.library_fingerprint`, '' for none)."""
    digest = hashlib.sha256(f"{model} {options}".encode())
    digest.update(_compiler_fingerprint().encode())
    for mo in sorted(source.parent.glob("*.mo")) if source is not None else ():
        digest.update(mo.name.encode())
        digest.update(mo.read_bytes())
    digest.update(library.encode())
    return digest.hexdigest()


def _line_of(text, needle):
    for number, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return number
    return None


def read_model_list(models_toml):
    """Read ``models.toml``: a list of ``[[model]]`` tables with ``name``, ``model``, ``source`` (none for a
    library's model) and optional ``description``, ``fmi_version`` (2 or 3), ``c_sources`` (bool), ``cs_step``
    (s), ``cs_method``; and an optional top-level ``libraries``, folders holding Modelica libraries.

    Parameters
    ----------
    models_toml : str or Path
        The model list; every problem in it is reported at once, with its line.

    Returns
    -------
    list of dict
        Entries with ``source`` resolved against the file's directory (None when absent) and ``libraries``,
        the list's library folders resolved likewise.
    """
    models_toml = Path(models_toml)
    if not models_toml.is_file():
        raise ConfigError(f"no model list at {models_toml}")
    text = models_toml.read_text()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{models_toml}: {err}") from err
    problems = []
    extra = set(data) - {"model", "libraries"}
    for key in sorted(extra):
        problems.append(f"{models_toml}:{_line_of(text, key)}: unknown key {key!r} (expected [[model]] tables "
                        "and libraries = [...])")
    libraries = data.get("libraries", [])
    if not isinstance(libraries, list) or not all(isinstance(d, str) for d in libraries):
        problems.append(f"{models_toml}:{_line_of(text, 'libraries')}: libraries must be a list of folders "
                        f"(strings), not {libraries!r}")
        libraries = []
    entries = []
    for k, entry in enumerate(data.get("model", [])):
        where = f"{models_toml}:{_line_of(text, entry.get('name', '@@')) or '?'}"
        for key in sorted(set(entry) - _ENTRY_KEYS):
            problems.append(f"{where}: model[{k}] has unknown key {key!r}; allowed: {', '.join(sorted(_ENTRY_KEYS))}")
        for key in ("name", "model"):
            if key not in entry:
                problems.append(f"{where}: model[{k}] misses {key!r}")
        if entry.get("fmi_version", 3) not in _FMI_VERSIONS:
            problems.append(f"{where}: model[{k}] fmi_version must be 2 or 3, not {entry['fmi_version']!r}")
        if not isinstance(entry.get("c_sources", False), bool):
            problems.append(f"{where}: model[{k}] c_sources must be true or false, not {entry['c_sources']!r}")
        step = entry.get("cs_step", DEFAULT_CS_STEP)
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not 0 < step < float("inf"):
            problems.append(f"{where}: model[{k}] cs_step must be a positive step in s, not {step!r}")
        if entry.get("cs_method", "rk4") not in METHODS:
            problems.append(f"{where}: model[{k}] cs_method must be one of {', '.join(METHODS)}, "
                            f"not {entry['cs_method']!r}")
        if not problems:
            source = models_toml.parent / entry["source"] if "source" in entry else None
            entries.append(dict(entry, source=source,
                                libraries=[models_toml.parent / folder for folder in libraries]))
    if problems:
        raise ConfigError("\n".join(problems))
    return entries


FMU_FOLDER_FILES = ("*.fmu", ".*.fmu.partial", _STATE_FILE, ".cosim-output", ".gitkeep")
"""What a folder of FMUs from before output folders were marked holds (:func:`cosim.outputs.check_output`)."""


def mark_fmu_folder(out_dir, check_only=False):
    """Check (``check_only``: before a build) or mark (after it) the folder ``cosim build`` writes FMUs into: new,
    empty, a previous cosim output, or a folder holding only FMUs, the build stamp and a ``.gitkeep``. Only the
    FMUs a build writes are replaced, each atomically.

    Parameters
    ----------
    out_dir : str or Path
    check_only : bool, default False
        Only refuse a folder that is not an FMU folder; create and mark nothing (a failed build leaves no folder).

    Returns
    -------
    Path
    """
    from cosim.outputs import check_output, mark_output

    if check_only:
        return check_output(out_dir, FMU_FOLDER_FILES)
    return mark_output(out_dir, "build", FMU_FOLDER_FILES)


def build_all(models_toml="modelica/models.toml", out_dir=None, force=False, fmi_version=None, source=None,
              modelica_path=()):
    """Build every model listed in ``models_toml``; yields one line of report per model.

    Parameters
    ----------
    models_toml : str or Path
    out_dir : str or Path, optional
        Default: ``fmus/`` beside the directory holding ``models_toml``.
    force : bool
        Rebuild even when sources and compiler are unchanged.
    fmi_version : {None, 2, 3}
        FMI version of every FMU; None: each entry's ``fmi_version`` (default 3).
    source : {None, True, False}
        Ship the C sources in every FMU; None: each entry's ``c_sources`` (default false).
    modelica_path : sequence of Path, default ()
        Library folders looked in before the list's ``libraries`` and ``MODELICAPATH``.
    """
    for _, line in build_listed(models_toml, out_dir, force, fmi_version, source, modelica_path):
        yield line


def build_listed(models_toml="modelica/models.toml", out_dir=None, force=False, fmi_version=None, source=None,
                 modelica_path=()):
    """:func:`build_all`, yielding each model's FMU with its line of report.

    Parameters
    ----------
    models_toml, out_dir, force, fmi_version, source, modelica_path
        As :func:`build_all`'s.

    Yields
    ------
    (pathlib.Path, str)
        The FMU (built, or up to date) and the line ``cosim build`` prints for it.
    """
    models_toml = Path(models_toml)
    out_dir = mark_fmu_folder(out_dir if out_dir else models_toml.resolve().parent.parent / "fmus", check_only=True)
    state_path = out_dir / _STATE_FILE
    state = json.loads(state_path.read_text()) if state_path.is_file() else {}
    fingerprints = {(): ""}  # library path -> its files' fingerprint, read once per build
    for entry in read_model_list(models_toml):
        roots = library_path(list(modelica_path) + entry["libraries"])
        if roots not in fingerprints:
            fingerprints[roots] = library_fingerprint(roots)
        fmu = out_dir / f"{entry['name']}.fmu"
        version = fmi_version or entry.get("fmi_version", 3)
        with_source = entry.get("c_sources", False) if source is None else source
        solver = {"cs_step": entry.get("cs_step", DEFAULT_CS_STEP), "cs_method": entry.get("cs_method", "rk4")}
        digest = _source_hash(entry["source"], entry["model"], f"fmi{version} sources={with_source} {solver}",
                              fingerprints[roots])
        if not force and fmu.is_file() and state.get(entry["name"]) == digest:
            yield fmu, f"{entry['name']}: up to date ({fmu})"
            continue
        build_fmu(entry["source"], entry["model"], out_dir=out_dir, name=entry["name"],
                  description=entry.get("description", ""), fmi_version=version, source=with_source,
                  modelica_path=roots, **solver)
        state[entry["name"]] = digest
        mark_fmu_folder(out_dir)
        state_path.write_text(json.dumps(state, indent=1, sort_keys=True))
        yield fmu, f"{entry['name']}: built {fmu}"
