"""Export a lowered model as an FMI 3.0 Model-Exchange FMU through CasADi's DaeBuilder (C code, compiled with
gcc, linked against libm), with unit definitions added to the modelDescription."""

import os
import shutil
import tempfile
import threading
import xml.etree.ElementTree as ET
from pathlib import Path

import casadi as ca
import fmpy

from cosim.compile.units import base_unit
from cosim.errors import BuildError

__all__ = ["export_fmu"]

# DaeBuilder writes its files into the working directory: one export at a time per process.
_CWD_LOCK = threading.Lock()


def _builder(model, fmu_name):
    d = ca.DaeBuilder(fmu_name)
    t = d.add("time", "independent", "continuous")
    P = [d.add(p.name, "parameter", "tunable", _attrs(p, start=p.start)) for p in model.parameters]
    U = [d.add(u.name, "input", _attrs(u, start=u.start)) for u in model.inputs]
    output_names = {y.name for y in model.outputs}
    X = [d.add(x.name, "output" if x.name in output_names else "local", _attrs(x, start=x.start))
         for x in model.states]
    args = [ca.vertcat(*group) if group else ca.MX(0, 1) for group in (X, U, P)] + [t]
    xdot = model.ode(*args)
    for k, x in enumerate(X):
        d.eq(d.der(x), xdot[k])
    state_names = {x.name for x in model.states}
    y = model.out(*args)
    for k, out in enumerate(model.outputs):
        if out.name in state_names:
            continue
        d.eq(d.add(out.name, "output", _attrs(out)), y[k])
    return d


def _attrs(var, start=None):
    attrs = {}
    if start is not None:
        attrs["start"] = float(start)
    if var.unit:
        attrs["unit"] = var.unit
    if var.description:
        attrs["description"] = var.description
    return attrs


def _complete_model_description(xml_path, model, description):
    """Make CasADi's modelDescription valid and complete: define every unit used (FMI requires it), give states
    their start values (exact, so importers may set them), and drop CasADi's internal helper variables, whose
    names are not legal under the structured naming convention and which no importer needs."""
    tree = ET.parse(xml_path)
    root = tree.getroot()
    if description:
        root.set("description", description)
    variables = root.find("ModelVariables")
    referenced = {vr for element in root.iter() for key in ("dependencies", "derivative")
                  for vr in (element.get(key) or "").split()}
    for var in list(variables):
        if var.get("name", "").startswith("__") and var.get("valueReference") not in referenced:
            variables.remove(var)
    starts = {x.name: x.start for x in model.states}
    state_refs = set()
    for var in variables:
        if var.get("name") in starts:
            var.set("initial", "exact")
            var.set("start", repr(float(starts[var.get("name")])))
            state_refs.add(var.get("valueReference"))
    structure = root.find("ModelStructure")
    for unknown in list(structure.findall("InitialUnknown")):
        if unknown.get("valueReference") in state_refs:
            structure.remove(unknown)
    units = sorted({v.get("unit") for v in variables if v.get("unit")})
    if units:
        definitions = ET.Element("UnitDefinitions")
        for unit in units:
            element = ET.SubElement(definitions, "Unit", name=unit)
            parsed = base_unit(unit)
            if parsed:
                factor, exponents = parsed
                base = ET.SubElement(element, "BaseUnit", {k: str(v) for k, v in exponents.items()})
                if factor != 1.0:
                    base.set("factor", repr(factor))
        position = list(root).index(root.find("ModelVariables"))
        root.insert(position, definitions)
    ET.indent(tree, space="    ")
    tree.write(xml_path, encoding="UTF-8", xml_declaration=True)


def export_fmu(model, fmu_path, description=""):
    """Write ``model`` (a :class:`~cosim.compile.model.LoweredModel`) to ``fmu_path`` as an FMI 3.0 ME FMU.

    The file appears only when the build succeeded (written to a temporary name, then moved).

    Parameters
    ----------
    model : LoweredModel
    fmu_path : str or Path
        Target file; its stem is the FMU's model identifier.
    description : str, optional
        Written as the modelDescription's description attribute.

    Returns
    -------
    Path
    """
    fmu_path = Path(fmu_path).resolve()
    fmu_name = fmu_path.stem
    if not fmu_name.isidentifier():
        raise BuildError(f"FMU name {fmu_name!r} is not a valid C identifier")
    include = os.path.join(os.path.dirname(fmpy.__file__), "c-code")
    with tempfile.TemporaryDirectory(prefix="cosim-build-") as work, _CWD_LOCK:
        previous = os.getcwd()
        os.chdir(work)
        try:
            builder = _builder(model, fmu_name)
            files = builder.export_fmu({"no_warning": True, "with_serialization": False})
            _complete_model_description(os.path.join(work, "modelDescription.xml"), model, description)
            files = builder.compile_fmu(files, {
                "include_dirs": [include],
                "compiler_options": {"linker_flags": "-lm", "compiler_flags": "-O2"},
            })
            packed = builder.pack_fmu(files, {"path": os.path.join(work, f"{fmu_name}.fmu")})
        except RuntimeError as err:
            raise BuildError(f"{model.name}: FMU export failed: {str(err).strip().splitlines()[-1]}") from err
        finally:
            os.chdir(previous)
        fmu_path.parent.mkdir(parents=True, exist_ok=True)
        staging = fmu_path.with_name(f".{fmu_name}.fmu.partial")
        shutil.copyfile(packed, staging)
        os.replace(staging, fmu_path)
    return fmu_path
