"""Build FMUs: one model on request, or every model of ``modelica/models.toml``, skipping those whose sources
and compiler are unchanged."""

import hashlib
import json
import tomllib
from pathlib import Path

from cosim import __version__
from cosim.compile.export import export_fmu
from cosim.compile.frontend import load_flat_model
from cosim.compile.lower import lower_system
from cosim.compile.translate import translate
from cosim.errors import ConfigError

__all__ = ["lower", "build_fmu", "build_all", "mark_fmu_folder", "read_model_list"]

_STATE_FILE = ".build-state.json"
_ENTRY_KEYS = {"name", "model", "source", "description"}


def lower(path, model):
    """Parse, flatten and lower Modelica model ``model`` from file ``path`` to a :class:`LoweredModel`.

    This is the public, explicit form of the model (CasADi functions ``ode`` and ``out`` of x, u, p, t) that the
    FMU contains, for calibration and diagnosis with exact derivatives.

    Parameters
    ----------
    path : str or Path
        The ``.mo`` file holding the model (rumoca also reads the other ``.mo`` files of its directory).
    model : str
        Full model name, e.g. ``Gripper.GripperPlant``.

    Returns
    -------
    LoweredModel
    """
    return lower_system(translate(load_flat_model(path, model)))


def build_fmu(path, model, out_dir="fmus", name=None, description=""):
    """Build Modelica model ``model`` of file ``path`` to ``out_dir/<name>.fmu`` (FMI 3.0 Model Exchange).

    Parameters
    ----------
    path : str or Path
        The ``.mo`` file holding the model (rumoca also reads the other ``.mo`` files of its directory).
    model : str
        Full model name, e.g. ``Gripper.GripperPlant``.
    out_dir : str or Path, default "fmus"
    name : str, optional
        FMU file stem; default: the model's last name component.
    description : str, optional
        The FMU's ``description`` attribute.

    Returns
    -------
    Path
        The written FMU. Nothing is written when any step fails.
    """
    lowered = lower(path, model)
    name = name or model.rsplit(".", 1)[-1]
    return export_fmu(lowered, Path(out_dir) / f"{name}.fmu", description=description)


def _compiler_fingerprint():
    digest = hashlib.sha256(__version__.encode())
    here = Path(__file__).parent
    sources = sorted(here.glob("*.py")) + sorted((here / "fmu_c").glob("*.[ch]"))  # the FMU's C wrapper too
    for source in sources + [here.parent / "modelica_text.py"]:  # the front end's redeclare check
        digest.update(source.read_bytes())
    return digest.hexdigest()


def _source_hash(source, model):
    digest = hashlib.sha256(model.encode())
    digest.update(_compiler_fingerprint().encode())
    for mo in sorted(source.parent.glob("*.mo")):
        digest.update(mo.name.encode())
        digest.update(mo.read_bytes())
    return digest.hexdigest()


def _line_of(text, needle):
    for number, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return number
    return None


def read_model_list(models_toml):
    """Read ``models.toml``: a list of ``[[model]]`` tables with ``name``, ``model``, ``source``.

    Parameters
    ----------
    models_toml : str or Path
        The model list; every problem in it is reported at once, with its line.

    Returns
    -------
    list of dict
        Entries with ``source`` resolved against the file's directory.
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
    extra = set(data) - {"model"}
    for key in sorted(extra):
        problems.append(f"{models_toml}:{_line_of(text, key)}: unknown key {key!r} (expected [[model]] tables)")
    entries = []
    for k, entry in enumerate(data.get("model", [])):
        where = f"{models_toml}:{_line_of(text, entry.get('name', '@@')) or '?'}"
        for key in sorted(set(entry) - _ENTRY_KEYS):
            problems.append(f"{where}: model[{k}] has unknown key {key!r}; allowed: {', '.join(sorted(_ENTRY_KEYS))}")
        for key in ("name", "model", "source"):
            if key not in entry:
                problems.append(f"{where}: model[{k}] misses {key!r}")
        if not problems:
            entries.append(dict(entry, source=models_toml.parent / entry["source"]))
    if problems:
        raise ConfigError("\n".join(problems))
    return entries


def mark_fmu_folder(out_dir):
    """Check and mark the folder ``cosim build`` writes FMUs into: new, empty, a previous cosim output, or a folder
    holding only FMUs and the build stamp (built before output folders were marked); see
    :func:`cosim.outputs.mark_output`. Only the FMUs a build writes are replaced, each atomically.

    Parameters
    ----------
    out_dir : str or Path

    Returns
    -------
    Path
    """
    from cosim.outputs import MARKER, mark_output

    return mark_output(out_dir, "build", adopt=("*.fmu", ".*.fmu.partial", _STATE_FILE, MARKER))


def build_all(models_toml="modelica/models.toml", out_dir=None, force=False):
    """Build every model listed in ``models_toml``; yields one line of report per model.

    Parameters
    ----------
    models_toml : str or Path
    out_dir : str or Path, optional
        Default: ``fmus/`` beside the directory holding ``models_toml``.
    force : bool
        Rebuild even when sources and compiler are unchanged.
    """
    models_toml = Path(models_toml)
    out_dir = mark_fmu_folder(out_dir if out_dir else models_toml.resolve().parent.parent / "fmus")
    state_path = out_dir / _STATE_FILE
    state = json.loads(state_path.read_text()) if state_path.is_file() else {}
    for entry in read_model_list(models_toml):
        fmu = out_dir / f"{entry['name']}.fmu"
        digest = _source_hash(entry["source"], entry["model"])
        if not force and fmu.is_file() and state.get(entry["name"]) == digest:
            yield f"{entry['name']}: up to date ({fmu})"
            continue
        build_fmu(entry["source"], entry["model"], out_dir=out_dir, name=entry["name"],
                  description=entry.get("description", ""))
        state[entry["name"]] = digest
        out_dir.mkdir(parents=True, exist_ok=True)
        state_path.write_text(json.dumps(state, indent=1, sort_keys=True))
        yield f"{entry['name']}: built {fmu}"
