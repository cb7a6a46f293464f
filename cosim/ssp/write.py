"""SSP out: a run config's plants, connections and parameter values written as an SSP 1.0 archive.

The archive holds ``SystemStructure.ssd``, the FMUs under ``resources/`` (an FMU two instances share is written once),
one ``resources/NAME.ssv`` of parameter and start values per FMU instance, and one ``resources/NAME.toml`` per
Python controller. A controller is a component of type ``application/x-cosim-controller`` whose source is that TOML
(its class, rate and parameters; a controller file of the config's folder is copied beside it), with one connector
per input and output: another tool runs the system once it has an implementation of that component, e.g. an FMU
with the same connectors sampled at the same rate (docs/guide/ssp.md). The communication step, the period of the
config's fastest clock, is written in the Open Simulation Platform's ``DefaultExperiment`` annotation, which libcosim
reads (SSP 1.0 has no element for it). The SSD is written with :mod:`xml.etree` and read back with FMPy's reader,
which validates it against the SSP 1.0 schema, before the archive is moved into place.
"""

import shutil
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from cosim.errors import BuildError, SspError
from cosim.ssp.read import CONTROLLER_TYPE, FMU_TYPE, OSP, SSD

__all__ = ["export_ssp", "write_ssp"]

_NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
       "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
       "osp": OSP}
_TYPES = {"Real": "Real", "Float64": "Real", "Float32": "Real", "Boolean": "Boolean",
          **{t: "Integer" for t in ("Integer", "Enumeration", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32",
                                    "Int64", "UInt64")}}  # FMI 2.0 and 3.0 types -> SSP 1.0's
_IMPLEMENTATION = {"ME": "ModelExchange", "CS": "CoSimulation"}
_BASE_UNITS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad", "factor", "offset")
for _prefix, _uri in _NS.items():
    ET.register_namespace(_prefix, _uri)


def _q(name):
    """The qualified tag of ``prefix:name``."""
    prefix, _, local = name.partition(":")
    return f"{{{_NS[prefix]}}}{local}"


def _sub(parent, tag, **attributes):
    return ET.SubElement(parent, _q(tag), {k: str(v) for k, v in attributes.items()})


def export_ssp(config_path, out, overrides=(), force=False):
    """Write the run config at ``config_path`` (with ``--set`` overrides) as the SSP archive ``out``.

    Parameters
    ----------
    config_path : path-like
        The TOML run config.
    out : path-like
        The ``.ssp`` file written.
    overrides : sequence of str
        ``key=value`` items, as ``--set``.
    force : bool, default False
        Replace an existing file at ``out``.

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    ConfigError, SspError, BuildError
        As :func:`cosim.config.load_config` and :func:`write_ssp`.
    """
    from cosim.config import load_config
    from cosim.ssp.read import unpacked_archives

    with unpacked_archives():  # a config naming an SSP ([system] ssp): its FMUs are copied from the unpacked archive
        return write_ssp(load_config(config_path, overrides), out, force=force)


def write_ssp(config, out, force=False):
    """Write a validated config as the SSP archive ``out`` (see the module docstring): staged beside ``out`` and
    moved into place once checked (:func:`cosim.outputs.output_file`), so an error leaves no file half written
    and an existing ``out`` as it was.

    Parameters
    ----------
    config : cosim.config.Config
    out : path-like
    force : bool, default False
        Replace an existing file at ``out``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    SspError
        ``out`` does not end in ``.ssp``.
    ConfigError
        ``out`` exists and ``force`` is false, is a folder, or cannot be written.
    BuildError
        The SSD written does not pass the SSP 1.0 schema (a bug of this module).
    """
    from cosim.outputs import output_file

    out = Path(out)
    if out.suffix != ".ssp":
        raise SspError(f"{out}: the archive's name must end in .ssp")
    with output_file(out, force=force) as staged, tempfile.TemporaryDirectory(prefix="cosim-ssp-") as tmp:
        folder = Path(tmp) / "ssp"
        (folder / "resources").mkdir(parents=True)
        root = _ssd(config, folder)
        ET.indent(root)
        ET.ElementTree(root).write(folder / SSD, encoding="UTF-8", xml_declaration=True)
        with zipfile.ZipFile(staged, "w", zipfile.ZIP_DEFLATED) as zf:
            for f in sorted(folder.rglob("*")):
                if f.is_file():
                    zf.write(f, f.relative_to(folder).as_posix())
        _check(staged, out)
    return out


def _check(archive, out):
    """FMPy's reader validates the SSD and the SSVs of ``archive`` (staged for ``out``) against the SSP 1.0
    schema."""
    from fmpy.ssp.ssd import read_ssd

    try:
        read_ssd(str(archive), validate=True)
    except Exception as err:  # FMPy raises a bare Exception listing the schema errors
        raise BuildError(f"the SSD written for {out.name} does not pass the SSP 1.0 schema: {err}") from err


def _ssd(config, folder):
    """The SSD's root element; the resources written into ``folder/resources``."""
    root = ET.Element(_q("ssd:SystemStructureDescription"), {"version": "1.0", "name": config.name,
                                                             "generationTool": "cosim export-ssp"})
    system = _sub(root, "ssd:System", name=config.name)
    elements = _sub(system, "ssd:Elements")
    units, sources = {}, {}
    for name, spec in config.fmus.items():
        _fmu_component(elements, name, spec, folder, units, sources)
    for name, spec in config.controllers.items():
        _controller_component(elements, name, spec, config, folder)
    if config.connections:
        connections = _sub(system, "ssd:Connections")
        for c in config.connections:
            e = _sub(connections, "ssd:Connection", startElement=c.src[0], startConnector=c.src[1],
                     endElement=c.dst[0], endConnector=c.dst[1])
            if (c.gain, c.offset) != (1.0, 0.0):
                _sub(e, "ssc:LinearTransformation", factor=repr(c.gain), offset=repr(c.offset))
    if units:
        holder = _sub(root, "ssd:Units")
        for name, base in units.items():
            unit = _sub(holder, "ssc:Unit", name=name)
            _sub(unit, "ssc:BaseUnit", **base)
    experiment = _sub(root, "ssd:DefaultExperiment", startTime=repr(config.run.start), stopTime=repr(config.run.stop))
    annotation = _sub(_sub(experiment, "ssd:Annotations"), "ssc:Annotation", type="com.opensimulationplatform")
    _sub(_sub(annotation, "osp:Algorithm"), "osp:FixedStepAlgorithm", baseStepSize=repr(_step(config)))
    return root


def _step(config):
    """The communication step: the period of the config's fastest clock (a controller's rate, the record's)."""
    return 1.0 / max([config.record.rate, *(c.rate for c in config.controllers.values())])


def _fmu_component(elements, name, spec, folder, units, sources):
    """One FMU component: its FMU under resources/ (once per file), its connectors (every input and output, each
    with its type and unit), its parameter and start values in resources/NAME.ssv."""
    from fmpy import read_model_description

    if spec.path not in sources:
        stem, k = spec.path.stem, 1
        while f"resources/{stem}.fmu" in sources.values():
            stem, k = f"{spec.path.stem}_{k}", k + 1
        sources[spec.path] = f"resources/{stem}.fmu"
        shutil.copyfile(spec.path, folder / sources[spec.path])
    e = _sub(elements, "ssd:Component", name=name, type=FMU_TYPE, source=sources[spec.path],
             implementation=_IMPLEMENTATION[spec.kind])
    described = {u.name: u.baseUnit for u in read_model_description(str(spec.path), validate=False).unitDefinitions}
    connectors = _sub(e, "ssd:Connectors")
    for var in spec.info.variables.values():
        if var.causality in ("input", "output") and var.type in _TYPES:
            c = _sub(connectors, "ssd:Connector", name=var.name, kind=var.causality)
            typed = _sub(c, f"ssc:{_TYPES[var.type]}")
            if var.unit and _TYPES[var.type] == "Real":
                typed.set("unit", var.unit)
                base = described.get(var.unit)
                units[var.unit] = {k: repr(getattr(base, k)) if k in ("factor", "offset") else str(getattr(base, k))
                                   for k in _BASE_UNITS if base is not None and getattr(base, k)}
    values = {**spec.parameters, **spec.start}
    if values:
        _sub(_sub(e, "ssd:ParameterBindings"), "ssd:ParameterBinding", source=f"resources/{name}.ssv")
        _ssv(folder / "resources" / f"{name}.ssv", name, values, spec.info)


def _ssv(path, name, values, info):
    """An SSV parameter set of ``values`` (variable name -> value), each of its variable's type."""
    root = ET.Element(_q("ssv:ParameterSet"), {"version": "1.0", "name": name})
    parameters = _sub(root, "ssv:Parameters")
    for vname, value in values.items():
        kind = _TYPES.get(info.variables[vname].type, "Real")
        text = str(value).lower() if kind == "Boolean" else str(int(value)) if kind == "Integer" else repr(float(value))
        _sub(_sub(parameters, "ssv:Parameter", name=vname), f"ssv:{kind}", value=text)
    ET.ElementTree(root).write(path, encoding="UTF-8", xml_declaration=True)


def _controller_component(elements, name, spec, config, folder):
    """One controller component: its TOML (class, rate, parameters as the config gives them) under resources/, with
    the controller's file when the config names one of its folder; one Real connector per input and output."""
    from cosim.tomldoc import toml_text

    table = dict(config.raw.get("controllers", {}).get(name, {}))
    module, _, cls = spec.class_path.partition(":")
    if module.endswith(".py"):
        source = Path(module) if Path(module).is_absolute() else config.path.parent / module
        shutil.copyfile(source, folder / "resources" / source.name)
        table["class"] = f"{source.name}:{cls}"
    (folder / "resources" / f"{name}.toml").write_text(toml_text(table, comment=(
        f"The Python controller {name!r} of the SSD (cosim export-ssp): class, rate (Hz) and parameters.")),
        encoding="utf-8")
    e = _sub(elements, "ssd:Component", name=name, type=CONTROLLER_TYPE, source=f"resources/{name}.toml")
    connectors = _sub(e, "ssd:Connectors")
    for kind, names in (("input", spec.cls.inputs), ("output", spec.cls.outputs)):
        for signal in names:
            _sub(_sub(connectors, "ssd:Connector", name=signal, kind=kind), "ssc:Real")
