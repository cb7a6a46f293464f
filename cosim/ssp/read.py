"""SSP in: an SSP archive (SSP 1.0 or 2.0) read into the tables of a run config, which the master runs unchanged.

The SSD is read with FMPy's SSP reader (:func:`fmpy.ssp.ssd.read_ssd`): the components, their connectors' names and
kinds, the connections, the parameter bindings (inline, or ``.ssv`` files in the archive) and the units; an SSP 1.x
archive is validated against the SSP 1.0 schema FMPy ships. What that reader leaves out is read here from the same
SSD, and only that:

* ``DefaultExperiment`` (``startTime``, ``stopTime``): not read; nor the communication step, which SSP 1.0 has no
  element for: it is read from the Open Simulation Platform's annotation (``osp:FixedStepAlgorithm baseStepSize``),
  the one libcosim reads and :mod:`cosim.ssp.write` writes;
* a connector's unit (``<ssc:Real unit="m"/>``): only its name and kind are read;
* a connection's ``ssc:LinearTransformation``: FMPy looks for it in the ``ssd`` namespace, so it never finds it in a
  file the schema accepts; nor does it read ``suppressUnitConversion``;
* a component's ``implementation`` (ModelExchange or CoSimulation);
* SSP 2.0: the schema FMPy ships accepts version 1.x only, and FMPy validates every referenced ``.ssv`` with it; a
  2.x archive is read unvalidated (its SSVs too).

Units are not converted: a connection between connectors of different units, or a parameter value given in another
unit than its variable's, is an error (give the factor with a ``LinearTransformation`` and
``suppressUnitConversion="true"``).
"""

import contextlib
import contextvars
import functools
import math
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from cosim.errors import FmuFileError, SspError

__all__ = ["SSD", "FMU_TYPE", "CONTROLLER_TYPE", "OSP", "SspSystem", "read_ssp", "ssp_document", "with_system",
           "unpacked_archives"]

SSD = "SystemStructure.ssd"
FMU_TYPE = "application/x-fmu-sharedlibrary"
CONTROLLER_TYPE = "application/x-cosim-controller"  # a Python controller, described by a TOML resource
OSP = "http://opensimulationplatform.com/SSP/OSPAnnotations"
_IMPLEMENTATION = {"ModelExchange": "ME", "CoSimulation": "CS"}
_KEEP = []  # the folders of archives unpacked outside unpacked_archives(), removed when the process exits
_SCOPE = contextvars.ContextVar("cosim_ssp_unpacked", default=None)  # the open unpacked_archives() block's list


@dataclass
class SspSystem:
    """An SSP archive as the tables of a run config.

    Attributes
    ----------
    path : pathlib.Path
        The archive.
    start, stop, step : float or None
        The default experiment's start and stop time and the communication step (s), when the SSD gives them.
    fmus : dict
        Component name -> its ``[fmus.NAME]`` table (``path``, ``kind``, ``parameters``, ``start``).
    controllers : dict
        Component name -> its ``[controllers.NAME]`` table (from the component's TOML resource; empty when it has
        none: the run config must declare it).
    connections : list of dict
        ``[[connections]]`` tables.
    outputs : list of str
        ``"component.connector"`` of the components' output connectors (what ``cosim run system.ssp`` records).
    """

    path: Path
    start: float = None
    stop: float = None
    step: float = None
    fmus: dict = field(default_factory=dict)
    controllers: dict = field(default_factory=dict)
    connections: list = field(default_factory=list)
    outputs: list = field(default_factory=list)


class _Report:
    """The problems of one archive, each at ``archive:SystemStructure.ssd:line``, raised together."""

    def __init__(self, path):
        self.path, self.items = path, []

    def add(self, element, message):
        line = getattr(element, "sourceline", None)
        self.items.append(f"{self.path}:{SSD}{f':{line}' if line else ''}: {message}")

    def raise_if_any(self):
        if self.items:
            n = len(self.items)
            raise SspError(f"{n} problem{'s' if n > 1 else ''} in {self.path}:\n  - " + "\n  - ".join(self.items))


@contextlib.contextmanager
def unpacked_archives():
    """Within the block, the folders SSP archives are unpacked into (by :func:`read_ssp`) are the block's: removed
    when it ends, error or not. A run's load and run go in one block (:func:`cosim.run`, ``cosim run``): its FMUs
    are loaded from there (each FMU instance unpacks its own copy, removed when the run closes it) and its
    controllers imported. An archive read outside such a block stays unpacked until the process exits: the config
    read from it names files there, and may be run any time later."""
    folders = []
    token = _SCOPE.set(folders)
    try:
        yield
    finally:
        _SCOPE.reset(token)
        for folder in folders:
            folder.cleanup()


def _unpacked(path):
    """The archive unpacked into a new folder: (its :class:`tempfile.TemporaryDirectory`, the folder); the folder
    is removed at once when the archive cannot be unpacked."""
    from cosim.fmi import safe_extract

    if not path.is_file():
        raise SspError(f"{path}: SSP file does not exist")
    if not zipfile.is_zipfile(path):
        raise SspError(f"{path}: not an SSP archive (a zip file holding {SSD})")
    folder = tempfile.TemporaryDirectory(prefix="cosim-ssp-")
    try:
        target = safe_extract(path, folder.name)
    except FmuFileError as err:
        folder.cleanup()
        raise SspError(f"{path}: {err}") from err
    except BaseException:
        folder.cleanup()
        raise
    if not (target / SSD).is_file():
        folder.cleanup()
        raise SspError(f"{path}: the archive has no {SSD} at its root")
    return folder, target


def _keep(folder):
    """Keep an unpacked archive's folder as long as the open :func:`unpacked_archives` block, else the process."""
    scope = _SCOPE.get()
    (_KEEP if scope is None else scope).append(folder)


def _fmpy_ssd(path, version):
    """FMPy's reading of the SSD; a 2.x archive unvalidated (FMPy's schema is SSP 1.0's; see the module docstring)."""
    import fmpy.ssp.ssd as fmpy_ssd

    validate = version.startswith("1.")
    read_ssv = fmpy_ssd.read_ssv
    if not validate:  # read_ssd reads each referenced .ssv with read_ssv(validate=True), no argument to turn it off:
        # for the time of the call the module's read_ssv does not validate (not thread-safe; runs read no SSP at once)
        fmpy_ssd.read_ssv = functools.partial(read_ssv, validate=False)
    try:
        return fmpy_ssd.read_ssd(str(path), validate=validate)
    except Exception as err:  # FMPy raises a bare Exception listing the schema errors, or lxml's
        raise SspError(f"{path}: {SSD} is not a valid SSP {version} system structure: {err}") from err
    finally:
        fmpy_ssd.read_ssv = read_ssv


class _Tree:
    """The SSD's elements FMPy does not read (see the module docstring), with their lines for the messages."""

    def __init__(self, folder, path):
        from lxml import etree
        from fmpy.ssp.ssd import ns

        self.ns = ns
        try:
            self.root = etree.parse(str(folder / SSD)).getroot()
        except etree.XMLSyntaxError as err:
            raise SspError(f"{path}:{SSD}:{err.lineno}: malformed XML: {err.msg}") from err
        system = self.root.find("ssd:System", ns)
        if system is None:
            raise SspError(f"{path}:{SSD}: no ssd:System element in the SSP 1.0 namespace ({ns['ssd']})")
        self.system = system
        self.components = {c.get("name"): c for c in system.findall("ssd:Elements/ssd:Component", ns)}
        self.connections = system.findall("ssd:Connections/ssd:Connection", ns)

    def experiment(self):
        """(start, stop, step) of ``DefaultExperiment``, each None when not given."""
        e = self.root.find("ssd:DefaultExperiment", self.ns)
        if e is None:
            return None, None, None
        algorithm = e.find(f"ssd:Annotations/ssc:Annotation/{{{OSP}}}Algorithm/{{{OSP}}}FixedStepAlgorithm", self.ns)
        step = None if algorithm is None else algorithm.get("baseStepSize")
        return (*(None if e.get(k) is None else float(e.get(k)) for k in ("startTime", "stopTime")),
                None if step is None else float(step))

    def connector_units(self, name):
        """Connector name -> (its declared unit or None, its element) of the component ``name``."""
        units = {}
        for c in self.components[name].findall("ssd:Connectors/ssd:Connector", self.ns):
            typed = [t for t in c if t.tag.startswith(f"{{{self.ns['ssc']}}}")]
            units[c.get("name")] = (typed[0].get("unit") if typed else None, c)
        return units

    def transformation(self, k):
        """(factor, offset, suppressUnitConversion) of the k-th connection."""
        c = self.connections[k]
        t = c.find("ssc:LinearTransformation", self.ns)
        factor, offset = (1.0, 0.0) if t is None else (float(t.get("factor", 1)), float(t.get("offset", 0)))
        return factor, offset, c.get("suppressUnitConversion", "false") in ("true", "1")


def read_ssp(path):
    """Read an SSP archive into the tables of a run config.

    Parameters
    ----------
    path : path-like
        The ``.ssp`` file. A component's ``source`` is looked for in the archive, then beside it.

    Returns
    -------
    SspSystem
        Its tables name files of the unpacked archive (FMUs, controller files): a temporary folder kept as long as
        the open :func:`unpacked_archives` block, else until the process exits.

    Raises
    ------
    SspError
        The archive or its SSD cannot be read, or an element is wrong (a missing FMU, a connection to an unknown
        connector, a unit mismatch...): every problem, each with its SSD line and element.
    """
    path = Path(path)
    handle, folder = _unpacked(path)
    try:
        system = _read(path, folder)
    except BaseException:  # nothing of the archive is used: its folder goes now
        handle.cleanup()
        raise
    _keep(handle)
    return system


def _read(path, folder):
    """The :class:`SspSystem` of the archive ``path`` unpacked in ``folder`` (see :func:`read_ssp`)."""
    tree = _Tree(folder, path)
    ssd = _fmpy_ssd(path, tree.root.get("version", ""))
    report = _Report(path)
    system = SspSystem(path, *tree.experiment())
    infos = {}
    for element in ssd.system.elements:
        where = tree.components.get(element.name, tree.system)
        if type(element).__name__ != "Component":
            report.add(where, f"{type(element).__name__} {element.name!r}: only components of FMUs or controllers "
                              "directly in the system are supported (no nested systems)")
        elif (element.type or FMU_TYPE) == FMU_TYPE:
            infos[element.name] = _fmu_component(element, tree, folder, path.parent, system, report)
        elif element.type == CONTROLLER_TYPE:
            system.controllers[element.name] = _controller_component(element, folder, report, where)
            system.outputs += [f"{element.name}.{c.name}" for c in element.connectors if c.kind == "output"]
        else:
            report.add(where, f"component {element.name!r} is of type {element.type!r}; cosim runs FMUs "
                              f"({FMU_TYPE}) and its controllers ({CONTROLLER_TYPE})")
    _system_bindings(ssd.system, tree, infos, system, report)
    _connections(ssd.system, tree, infos, system, report)
    report.raise_if_any()
    return system


def _fmu_component(element, tree, folder, beside, system, report):
    """The ``[fmus.NAME]`` table of an FMU component, its connectors checked against the FMU; its ModelInfo."""
    from cosim.fmi import read_model_info

    where = tree.components[element.name]
    name = element.name
    if not element.source:
        report.add(where, f"component {name!r} has no source (the FMU)")
        return None
    fmu = next((p for p in (folder / element.source, beside / element.source) if p.is_file()), None)
    if fmu is None:
        report.add(where, f"component {name!r}: FMU {element.source!r} is neither in the archive nor beside it "
                          f"({beside / element.source})")
        return None
    try:
        info = read_model_info(fmu)
    except FmuFileError as err:
        report.add(where, f"component {name!r}: {err}")
        return None
    table = {"path": str(fmu), "parameters": {}, "start": {}}
    kind = _IMPLEMENTATION.get(where.get("implementation"))
    if kind is not None:
        table["kind"] = kind
    for cname, (unit, celement) in tree.connector_units(name).items():
        var = info.variables.get(cname)
        if var is None:
            report.add(celement, f"connector {name}.{cname}: {fmu.name} has no variable {cname!r}")
        elif unit and var.unit and unit != var.unit:
            report.add(celement, f"connector {name}.{cname}: unit {unit!r}, but {fmu.name} declares {cname} in "
                                 f"{var.unit!r} (cosim does not convert units)")
        elif var.causality == "output":
            system.outputs.append(f"{name}.{cname}")
    for binding in element.parameterBindings:
        _bind(binding, "", name, info, table, report, where)
    system.fmus[name] = table
    return info


def _controller_component(element, folder, report, where):
    """The ``[controllers.NAME]`` table of a controller component (its TOML resource), or {} when it has none."""
    import tomllib

    if not element.source:
        return {}
    resource = folder / element.source
    try:
        table = tomllib.loads(resource.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as err:
        report.add(where, f"component {element.name!r}: cannot read its controller {element.source!r}: {err}")
        return {}
    cpath, _, cls = str(table.get("class", "")).partition(":")
    if cpath.endswith(".py"):  # a controller file shipped in the archive, beside its TOML
        source = resource.parent / cpath
        table["class"] = f"{_kept_controller_file(source) if source.is_file() else source}:{cls}"
    return table


def _kept_controller_file(source):
    """A copy of an archive's controller file at a path of its content in the user's cache folder.

    numba keys its cache of a compiled kernel on the source file's path and time stamp: loaded from the archive's
    temporary folder, new at every run, the controller's kernels would be compiled again each time (seconds). The
    copy is made once, and later runs of the same file find it and its compiled kernels."""
    import hashlib
    import os

    from cosim.kernel_cache import user_cache_root

    text = source.read_bytes()
    kept = user_cache_root() / "cosim" / "ssp-controllers" / hashlib.sha256(text).hexdigest()[:16] / source.name
    if not kept.is_file():
        kept.parent.mkdir(parents=True, exist_ok=True)
        staged = kept.with_name(f".{source.name}.{os.getpid()}")
        staged.write_bytes(text)
        os.replace(staged, kept)  # atomic: a run beside this one reads the whole file or none
    return kept


def _system_bindings(ssd_system, tree, infos, system, report):
    """Parameter bindings of the system itself: names ``component.variable``."""
    for binding in ssd_system.parameterBindings:
        for name, info in infos.items():
            if info is not None:
                _bind(binding, f"{name}.", name, info, system.fmus[name], report, tree.system)


def _bind(binding, prefix, name, info, table, report, where):
    """Put the values of a parameter binding into ``table``: parameters under ``parameters``, the start values of
    other variables (inputs, states) under ``start``."""
    if binding.type not in (None, "application/x-ssp-parameter-set"):
        report.add(where, f"component {name!r}: parameter binding of type {binding.type!r}; cosim reads "
                          "application/x-ssp-parameter-set")
        return
    if any(m.mappingEntries or m.source for m in binding.parameterMapping):
        report.add(where, f"component {name!r}: parameter mappings (SSM) are not supported; give the values under "
                          "the variables' names")
    prefix += binding.prefix or ""
    for pset in binding.parameterValues:
        for p in pset.parameters:
            if not p.name.startswith(prefix):
                continue
            vname = p.name[len(prefix):]
            where_p = f"component {name!r}: parameter set {pset.name!r}: {p.name}"
            var = info.variables.get(vname)
            if var is None:
                report.add(where, f"{where_p}: {info.path.name} has no variable {vname!r}")
                continue
            if p.unit and var.unit and p.unit != var.unit:
                report.add(where, f"{where_p}: unit {p.unit!r}, but {info.path.name} declares {vname} in "
                                  f"{var.unit!r} (cosim does not convert units)")
                continue
            value = _value(p)
            if value is None:
                report.add(where, f"{where_p}: a {p.type or 'value of a type FMPy does not read'} parameter; cosim "
                                  "sets Real, Integer and Boolean values")
                continue
            table["parameters" if var.causality == "parameter" else "start"][vname] = value


def _value(p):
    """The Python value of an SSV parameter (None for a type cosim does not set)."""
    if p.type == "Real":
        return float(p.value)
    if p.type == "Integer":
        return int(p.value)
    if p.type == "Boolean":
        return p.value in ("true", "1")
    return None


def _connections(ssd_system, tree, infos, system, report):
    """The ``[[connections]]`` of the SSD: both ends must be declared connectors of known components, of the
    same unit (unless the connection suppresses unit conversion)."""
    known = {e.name: {c.name: c.kind for c in e.connectors} for e in ssd_system.elements}
    for k, c in enumerate(ssd_system.connections):
        element = tree.connections[k]
        text = f"connection {c.startElement}.{c.startConnector} -> {c.endElement}.{c.endConnector}"
        ends = [(c.startElement, c.startConnector), (c.endElement, c.endConnector)]
        bad = [f"{e}.{n}" if e in known else e for e, n in ends if e not in known or n not in known[e]]
        if None in (c.startElement, c.endElement):
            report.add(element, f"{text}: connections to the system's own connectors are not supported")
            continue
        if bad:
            report.add(element, f"{text}: no {'connector' if '.' in bad[0] else 'component'} {bad[0]!r} "
                                f"(components: {', '.join(sorted(known))})")
            continue
        factor, offset, suppress = tree.transformation(k)
        units = [_unit(tree, infos, e, n) for e, n in ends]
        if not suppress and None not in units and units[0] != units[1]:
            report.add(element, f"{text}: unit mismatch: {c.startConnector} is in {units[0]!r}, {c.endConnector} in "
                                f"{units[1]!r} (cosim does not convert units; give the factor with a "
                                "LinearTransformation and suppressUnitConversion=\"true\")")
            continue
        table = {"from": f"{c.startElement}.{c.startConnector}", "to": f"{c.endElement}.{c.endConnector}"}
        if (factor, offset) != (1.0, 0.0):
            table.update(gain=factor, offset=offset)
        system.connections.append(table)


def _unit(tree, infos, name, connector):
    """The unit of a connector: declared in the SSD, else its FMU variable's; None when neither gives one."""
    declared = tree.connector_units(name).get(connector, (None,))[0] if name in tree.components else None
    info = infos.get(name)
    var = info.variables.get(connector) if info is not None else None
    return declared or (var.unit if var is not None and var.unit else None)


def ssp_document(path, overrides=()):
    """The run config of ``cosim run system.ssp``: the SSP's components, connections and parameter values, its
    default experiment, every FMU output recorded at the communication step, with ``--set`` overrides applied.

    Parameters
    ----------
    path : path-like
        The ``.ssp`` file.
    overrides : sequence of str
        ``"key.path=value"`` items, as for a TOML config.

    Returns
    -------
    data : dict
        The config's tables.
    problems : cosim.tomldoc.Problems
        The collector the config's validation adds its problems to.
    """
    from cosim.tomldoc import Problems, apply_overrides, format_key, key_paths

    path = Path(path)
    system = read_ssp(path)
    if not all(system.controllers.values()):
        missing = [n for n, t in system.controllers.items() if not t]
        raise SspError(f"{path}: component {missing[0]!r} is a controller without its resource: run it from a run "
                       f"config that names this SSP ([system] ssp = \"{path.name}\") and declares "
                       f"[controllers.{missing[0]}]")
    run = {k: v for k, v in (("start", system.start), ("stop", system.stop)) if v is not None}
    data = {"run": run, "fmus": system.fmus, "controllers": system.controllers, "connections": system.connections,
            "record": {"rate": 1.0 / _step(system), "signals": system.outputs}}
    if not system.outputs:
        del data["record"]["signals"]
    keys = {format_key(k) for k in key_paths(data)}
    set_keys = apply_overrides(data, overrides)
    return data, Problems(str(path), None, set_keys, keys)


def _step(system):
    """The communication step: the SSD's, else the smallest step the FMUs declare, else a 500th of the run."""
    from cosim.fmi import read_model_info

    if system.step:
        return system.step
    steps = [read_model_info(t["path"]).step for t in system.fmus.values()]
    steps = [s for s in steps if s]
    if steps:
        return min(steps)
    span = (system.stop or 1.0) - (system.start or 0.0)
    return span / 500 if span > 0 and math.isfinite(span) else 1e-3


def with_system(data, base_dir, problems):
    """``data`` (a run config's tables) with those of the SSP its ``[system] ssp = "file.ssp"`` names merged
    under its own: the SSP's FMUs, controllers (a config's table of the same name over the SSP's, key by key,
    parameter by parameter), connections (the SSP's first) and default experiment (``[run]`` start and stop when
    the config gives none). ``data`` itself when it has no ``[system]``."""
    t = data.get("system")
    if t is None:
        return data
    if not isinstance(t, dict) or set(t) != {"ssp"} or not isinstance(t["ssp"], str):
        problems.add(("system",), "must be a table with one key, ssp = \"file.ssp\" (relative to the config)")
        return data
    ssp = Path(t["ssp"]) if Path(t["ssp"]).is_absolute() else base_dir / t["ssp"]
    try:
        system = read_ssp(ssp)
    except SspError as err:
        raise SspError(f"{problems.where(('system', 'ssp'))}: system.ssp: {err}") from err
    merged = dict(data)
    merged["run"] = {**{k: v for k, v in (("start", system.start), ("stop", system.stop)) if v is not None},
                     **data.get("run", {})}
    for section, tables in (("fmus", system.fmus), ("controllers", system.controllers)):
        own = data.get(section, {})
        merged[section] = {**{n: _merged(tables[n], own.get(n, {})) for n in tables}, **{n: v for n, v in
                                                                                        own.items() if n not in tables}}
    for name, table in merged["controllers"].items():
        if not table:
            problems.add(("system", "ssp"), f"{ssp.name}: component {name!r} is a controller without its resource: "
                                            f"declare [controllers.{name}]")
    merged["connections"] = system.connections + list(data.get("connections", []))
    return merged


def _merged(ssp_table, own):
    """A component's table: the config's keys over the SSP's, its parameters and start values one by one."""
    out = {**ssp_table, **own}
    for key in ("parameters", "start"):
        if isinstance(own.get(key, {}), dict) and key in ssp_table:
            out[key] = {**ssp_table[key], **own.get(key, {})}
    return out
