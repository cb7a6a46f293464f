"""Export a lowered model as an FMI 3.0 FMU with Model Exchange and Co-Simulation: CasADi generates C for the
model functions and their exact derivatives, our own C wrapper (``fmu_c/``: a model core and an FMI 3 API layer
over it) gives them the FMI interface, gcc compiles both. The wrapper carries events (indicators,
``fmi3UpdateDiscreteStates``, time events, terminate, asserts), Integer and Boolean variables, recomputes results
lazily after any change of time, states or inputs, and for Co-Simulation an embedded fixed-step solver (RK4 or
implicit Euler) with the events handled inside ``fmi3DoStep``; FMU state and directional derivatives for both.
FMI 2.0 (``fmi_version=2``) is another API layer (``fmi2.c``) over the same core, with a modelDescription 2.0."""

import datetime
import os
import shutil
import subprocess
import tempfile
import uuid
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import fmpy
import numpy as np

from cosim import __version__
from cosim.compile.units import base_unit
from cosim.errors import BuildError, ConfigError

__all__ = ["export_fmu", "C_TEMPLATE_DIR", "METHODS", "DEFAULT_CS_STEP"]

C_TEMPLATE_DIR = Path(__file__).parent / "fmu_c"
"""The C sources of the FMU wrapper (copied into every FMU's ``sources/``)."""

# The wrapper's C files of each FMI version, and the C files compiled (with CasADi's model.c), in this order.
_TEMPLATES = {3: ("model_core.h", "model_core.c", "fmi3_common.h", "fmi3_me.c", "fmi3_cs.c"),
              2: ("model_core.h", "model_core.c", "fmi2.c")}
_SOURCES = {3: ("model.c", "model_core.c", "fmi3_me.c", "fmi3_cs.c"), 2: ("model.c", "model_core.c", "fmi2.c")}
_GENERATED = ("model.c", "model.h", "model_data.h")
# Discrete kinds -> (FMI 3 type element, code in model_data.h D_KIND). An enumeration is exposed as its ordinal,
# an Int64 (no enumeration type definitions in the modelDescription).
_KINDS = {"real": ("Float64", 0), "integer": ("Int64", 1), "boolean": ("Boolean", 2), "enumeration": ("Int64", 3)}
METHODS = ("rk4", "implicit_euler")
"""The embedded Co-Simulation solvers, in the order of their codes (``_cs_method``; CS_RK4, CS_IMPLICIT_EULER)."""
DEFAULT_CS_STEP = 1e-3
"""s: the internal step of the embedded solver when the model list gives none."""


ALIAS_DEPTH = 8
"""Levels of two observed expressions ``casadi.is_equal`` compares before it calls them different."""


@dataclass(frozen=True)
class _Layout:
    """Value references: 0 time, then parameters, inputs, states, derivatives, the outputs that are not states,
    discrete variables, event indicators, the embedded solver's settings (``_cs_step``, ``_cs_method``), the
    local variables (``observe``'s results; aliases share one reference), the calculated (dependent) parameters,
    the constants, each a contiguous block starting at the given reference."""

    p: int
    u: int
    x: int
    dx: int
    y: int
    d: int
    z: int
    cs: int
    v: int
    q: int
    k: int
    end: int
    y_index: tuple  # position in out()'s result of each output of the y block
    v_index: tuple = ()  # position in observe()'s result of each local of the v block
    v_vr: tuple = ()  # value reference of each observed variable (an alias has its first variable's)

    @classmethod
    def of(cls, model):
        states = {x.name for x in model.states}
        y_index = tuple(k for k, y in enumerate(model.outputs) if y.name not in states)
        first = _observed_aliases(model)
        v_index = tuple(k for k, j in enumerate(first) if j == k)
        events = model.events
        sizes = [len(model.parameters), len(model.inputs), len(model.states), len(model.states), len(y_index),
                 len(events.discretes) if events else 0, events.n_indicators if events else 0, 2, len(v_index),
                 len(model.dependent), len(model.constant_variables)]
        starts = [1]
        for size in sizes:
            starts.append(starts[-1] + size)
        slot = {k: starts[8] + i for i, k in enumerate(v_index)}
        return cls(*starts, y_index=y_index, v_index=v_index, v_vr=tuple(slot[j] for j in first))

    def output_vr(self, model, name):
        states = [x.name for x in model.states]
        if name in states:
            return self.x + states.index(name)
        return self.y + [model.outputs[k].name for k in self.y_index].index(name)


def _observed_aliases(model):
    """For each observed variable, the index of the first one with the same expression and unit (its own index
    when none): they share one value reference, as FMI allows for variables that always have the same value.
    The same expression: the same CasADi node, or equal to ALIAS_DEPTH levels (``casadi.is_equal``, which never
    calls different expressions equal), compared among the variables with bitwise the same value at a random
    point. A negated alias (a = -b) keeps its own reference. An MX ``observe`` (a Newton loop) is not compared:
    each variable gets its own reference."""
    n = len(model.observed)
    first = list(range(n))
    if n < 2 or not model.observe.is_a("SXFunction"):
        return tuple(first)
    _, args = _symbols(model.observe)
    expr = model.observe.call(args)[0]
    rng = np.random.default_rng(1)
    values = np.array(model.observe(*[rng.uniform(0.5, 1.5, a.numel()) for a in args]), dtype=float).ravel()
    buckets = {}
    for k, var in enumerate(model.observed):
        bucket = buckets.setdefault((var.unit, values[k].tobytes()), [])
        same = next((j for j in bucket if ca.is_equal(expr[j], expr[k], ALIAS_DEPTH)), None)
        if same is None:
            bucket.append(k)
        else:
            first[k] = same
    return tuple(first)


def _symbols(f, n_memory=None):
    """Dense symbols for ``f``'s inputs (SX for an SX function, so that it is inlined unchanged), plus an event
    memory of ``n_memory`` when given."""
    sym = ca.SX if f.is_a("SXFunction") else ca.MX
    args = [sym.sym(f.name_in(i), f.size1_in(i)) for i in range(f.n_in())]
    if n_memory is not None:
        args.append(sym.sym("m", n_memory))
    return sym, args


def _named(f, name, n_memory=None, n_guess=None):
    """``f`` as a function called ``name`` with dense results; with ``n_memory``, an extra (ignored) memory
    argument after (x, u, p, t), and with ``n_guess`` an extra (ignored) last argument g (a model without nonlinear
    loops), so that the C core calls every model function as f(x, u, p, t, m[, g])."""
    sym, args = _symbols(f)
    inputs = list(args)
    if n_memory is not None:
        args.insert(4, sym.sym("m", n_memory))
    if n_guess is not None:
        args.append(sym.sym("g", n_guess))
    results = f.call(inputs)
    return ca.Function(name, args, [ca.densify(r) for r in results])


def _continuous_events(model):
    """The event functions of a model without events: no indicators, an update that changes nothing."""
    sym, (x, u, p, t, m) = _symbols(model.ode, 0)
    none = sym(0, 1)
    return [ca.Function("cosim_indicators", [x, u, p, t, m], [none]),
            ca.Function("cosim_update", [x, u, p, t, m], [x, none, sym(0.0)]),
            ca.Function("cosim_terminal", [x, u, p, t, m], [x, none, sym(0.0)]),
            ca.Function("cosim_initial", [x, u, p, t], [none]),
            ca.Function("cosim_next_time", [t, p, none], [sym(float("inf"))])]


def _derivative_functions(ode, out):
    """Exact derivatives for the C core, from CasADi's algorithmic differentiation: ``cosim_jac_x(x, u, p, t, m, g)``
    the dense Jacobian of ode w.r.t. x (the implicit solver's Newton), ``cosim_dode`` and ``cosim_dout(x, u, p,
    t, m, g, dx, du)`` the forward derivatives of ode and out along seeds dx, du (directional derivatives)."""
    sym, args = _symbols(ode)
    x, u = args[0], args[1]
    dx, du = sym.sym("dx", x.numel()), sym.sym("du", u.numel())
    xdot, y = ode.call(args)[0], out.call(args)[0]
    return [ca.Function("cosim_jac_x", args, [ca.densify(ca.jacobian(xdot, x))]),
            *(ca.Function(name, args + [dx, du], [ca.densify(ca.jtimes(e, x, dx) + ca.jtimes(e, u, du))])
              for name, e in (("cosim_dode", xdot), ("cosim_dout", y)))]


def _c_functions(model):
    """The CasADi functions the C core calls, named cosim_ode, cosim_out, cosim_x0, cosim_indicators,
    cosim_update, cosim_terminal, cosim_initial, cosim_next_time (cosim_terminal: the update with terminal()
    true; one that changes nothing when the model does not use terminal()), then the derivatives
    (:func:`_derivative_functions`), then cosim_observe (the local variables), cosim_loops (which nonlinear
    loops converged), cosim_mixed(x, u, p, t, m_pre, c) (:func:`_mixed`) and, last, cosim_calculated (the
    dependent parameters), all but cosim_mixed f(x, u, p, t, m); those that solve the nonlinear loops take their
    Newton iterations' starting point g last (:func:`_carried`)."""
    events = model.events
    memory = 0 if events is None else None  # a continuous model's functions get an empty memory argument
    ode, out, observe, loops = _carried(model, memory)
    functions = [ode, out, _named(model.x0, "cosim_x0")]
    if events is None:
        functions += _continuous_events(model)
    else:
        functions += [_named(events.indicators, "cosim_indicators"), _named(events.update, "cosim_update"),
                      _terminal_pass(events), _named(events.initial, "cosim_initial"),
                      _named(events.next_time, "cosim_next_time")]
    return functions + _derivative_functions(ode, out) + [observe, loops, _mixed(model), _calculated(model, memory)]


def _mixed(model):
    """cosim_mixed(x, u, p, t, m_pre, c): the event pass with the relations and steps at candidate values
    (``EventPart.mixed``); for a model without it one that keeps x and m (the C core never calls it then)."""
    events = model.events
    if events is not None and events.mixed is not None:
        return _named(events.mixed, "cosim_mixed")
    sym, (x, u, p, t, m) = _symbols(model.ode, None if events else 0)
    c = sym.sym("c", m.numel())
    return ca.Function("cosim_mixed", [x, u, p, t, m, c], [x, m, sym(0.0), m])


def _calculated(model, memory):
    """cosim_calculated(x, u, p, t, m): the dependent parameters from p (``model.calculate``)."""
    sym, args = _symbols(model.ode, memory)
    q = model.calculate.call([args[2]])[0] if model.dependent else sym(0, 1)
    return ca.Function("cosim_calculated", args, [ca.densify(q)])


_CARRIED = ("cosim_ode", "cosim_out", "cosim_observe", "cosim_loops")


def _carried(model, memory):
    """cosim_ode, cosim_out, cosim_observe and cosim_loops as f(x, u, p, t, m, g), g the starting point of the
    nonlinear loops' Newton iterations (the C core's last solution); the first three also return the loops'
    solutions g_new there (``model.carried``). A model without such loops has an empty g and no g_new, and its
    cosim_loops returns nothing."""
    if model.carried is not None:
        carried = model.carried
        return [_named(f, name, memory) for f, name in zip((carried.ode, carried.out, carried.observe, carried.loops),
                                                           _CARRIED)]
    sym, args = _symbols(model.ode, memory)
    loops = ca.Function("cosim_loops", args + [sym.sym("g", 0)], [sym(0, 1)])
    return [_named(f, name, memory, 0) for f, name in zip((model.ode, model.out, model.observe), _CARRIED)] + [loops]


def _terminal_pass(events):
    """cosim_terminal: the model's terminal pass, or one that keeps x and m when it has no terminal()."""
    if events.terminal is not None:
        return _named(events.terminal, "cosim_terminal")
    sym, (x, u, p, t, m) = _symbols(events.update, None)
    return ca.Function("cosim_terminal", [x, u, p, t, m], [x, m, sym(0.0)])


def _c_array(name, ctype, values):
    body = ", ".join(values) if values else "0"
    return f"static const {ctype} {name}[{max(len(values), 1)}] = {{{body}}};"


def _c_string(text):
    return '"' + "".join(chr(b) if 32 <= b < 127 and chr(b) not in '"\\?' else f"\\{b:03o}"
                         for b in text.encode()) + '"'


def _data_header(model, layout, functions, identifier, token, cs_step, cs_method):
    """model_data.h: sizes, value-reference blocks, start values, messages and the default solver settings for
    the C core."""
    events = model.events
    discretes = events.discretes if events else ()
    n_memory = events.n_memory if events else 0
    memory_start = [d.start for d in discretes] + [0.0] * (n_memory - len(discretes))
    messages = events.messages if events else ()
    defines = {
        "MODEL_IDENTIFIER": _c_string(identifier), "INSTANTIATION_TOKEN": _c_string(token),
        "N_X": len(model.states), "N_U": len(model.inputs), "N_P": len(model.parameters),
        "N_Y": len(model.outputs), "N_M": n_memory, "N_D": len(discretes),
        "N_Z": events.n_indicators if events else 0, "N_MSG": len(messages), "N_LOOPS": len(model.loop_names),
        "N_CAND": len(events.candidates) if events and events.mixed is not None else 0,
        "N_G": 0 if model.carried is None else len(model.carried.guess),
        "VR_P": layout.p, "VR_U": layout.u, "VR_X": layout.x, "VR_DX": layout.dx, "VR_Y": layout.y,
        "VR_D": layout.d, "VR_Z": layout.z, "VR_CS": layout.cs, "N_VR": layout.end,
        "N_OBS": len(model.observed), "N_V": len(layout.v_index), "N_Q": len(model.dependent),
        "N_K": len(model.constant_variables), "VR_V": layout.v, "VR_Q": layout.q, "VR_K": layout.k,
        "CS_STEP": repr(float(cs_step)), "CS_METHOD": METHODS.index(cs_method),
        "SZ_ARG": max(f.sz_arg() for f in functions), "SZ_RES": max(f.sz_res() for f in functions),
        "SZ_IW": max(f.sz_iw() for f in functions), "SZ_W": max(f.sz_w() for f in functions),
    }
    lines = ["/* Generated by cosim.compile.export for " + identifier + ": the model's sizes and start values. */",
             "#ifndef COSIM_MODEL_DATA_H", "#define COSIM_MODEL_DATA_H"]
    lines += [f"#define {key} {value}" for key, value in defines.items()]
    lines += [
        _c_array("P_START", "double", [repr(float(v.start)) for v in model.parameters]),
        _c_array("U_START", "double", [repr(float(v.start)) for v in model.inputs]),
        _c_array("X_START", "double", [repr(float(v.start)) for v in model.states]),
        _c_array("X_NOMINAL", "double", [repr(float(v.nominal or 1.0)) for v in model.states]),
        _c_array("M_START", "double", [repr(float(v)) for v in memory_start]),
        _c_array("M_CAND", "int", [str(k) for k in (events.candidates if events else ())]),
        _c_array("G_START", "double", [] if model.carried is None else [repr(float(v)) for v in model.carried.guess]),
        _c_array("Y_INDEX", "int", [str(k) for k in layout.y_index]),
        _c_array("D_KIND", "int", [str(_KINDS[d.kind][1]) for d in discretes]),
        _c_array("V_INDEX", "int", [str(k) for k in layout.v_index]),
        _c_array("K_VALUE", "double", [repr(float(c.start)) for c in model.constant_variables]),
        _c_array("K_KIND", "int", [str(_KINDS[c.kind][1]) for c in model.constant_variables]),
        _c_array("MESSAGES", "char *const", [_c_string(m) for m in messages]),
        _c_array("LOOP_NAMES", "char *const", [_c_string(name) for name in model.loop_names]),
        "#endif", ""]
    return "\n".join(lines)


def _dependencies(f, layout, parameters=False):
    """Per result row of ``f(x, u, p, ...)``: the value references of the states and inputs (and with
    ``parameters``, the parameters) it depends on."""
    rows = [[] for _ in range(f.size1_out(0))]
    blocks = ((0, layout.x), (1, layout.u)) + (((2, layout.p),) if parameters else ())
    for i, first in blocks:
        sparsity = f.jac_sparsity(0, i)
        for row, col in zip(*sparsity.get_triplet()):
            rows[row].append(first + col)
    return [" ".join(str(vr) for vr in sorted(deps)) for deps in rows]


def _float(parent, name, vr, variable=None, **attrs):
    attrs = {"name": name, "valueReference": str(vr), **attrs}
    if variable is not None:
        if variable.unit:
            attrs["unit"] = variable.unit
        if variable.description:
            attrs["description"] = variable.description
    return ET.SubElement(parent, "Float64", attrs)


def _range(variable):
    """The ``min``/``max`` attributes of a parameter's declared physical range (FMI 2.0 and 3.0 spell them alike)."""
    return {key: repr(float(value)) for key, value in (("min", variable.min), ("max", variable.max))
            if value is not None}


def _nominal(variable):
    """The ``nominal`` attribute of a state that declares one (FMI 2.0 and 3.0 spell it alike)."""
    return {} if variable.nominal is None else {"nominal": repr(float(variable.nominal))}


def _solver_settings(variables, layout, cs_step, cs_method):
    """The embedded solver's settings as fixed parameters (an importer sets them before initialisation ends)."""
    _float(variables, "_cs_step", layout.cs, causality="parameter", variability="fixed", initial="exact",
           start=repr(float(cs_step)), unit="s", min="0",
           description="Co-Simulation: internal step of the embedded solver (at most; equal steps between events)")
    ET.SubElement(variables, "Int64", name="_cs_method", valueReference=str(layout.cs + 1), causality="parameter",
                  variability="fixed", initial="exact", start=str(METHODS.index(cs_method)), min="0",
                  max=str(len(METHODS) - 1),
                  description="Co-Simulation: embedded solver, 0 RK4, 1 implicit Euler (Newton, exact Jacobian)")


def _variables(root, model, layout, cs_step, cs_method):
    variables = ET.SubElement(root, "ModelVariables")
    _float(variables, "time", 0, causality="independent", variability="continuous")
    for k, p in enumerate(model.parameters):
        _float(variables, p.name, layout.p + k, p, causality="parameter", variability="tunable", initial="exact",
               start=repr(float(p.start)), **_range(p))
    for k, u in enumerate(model.inputs):
        _float(variables, u.name, layout.u + k, u, causality="input", start=repr(float(u.start)))
    outputs = {y.name for y in model.outputs}
    for k, x in enumerate(model.states):
        causality = "output" if x.name in outputs else "local"
        _float(variables, x.name, layout.x + k, x, causality=causality, initial="exact", start=repr(float(x.start)),
               **_nominal(x))
    for k, x in enumerate(model.states):
        _float(variables, f"der({x.name})", layout.dx + k, derivative=str(layout.x + k))
    for k, j in enumerate(layout.y_index):
        _float(variables, model.outputs[j].name, layout.y + k, model.outputs[j], causality="output",
               initial="calculated")
    events = model.events
    for k, d in enumerate(events.discretes if events else ()):
        attrs = {"name": d.name, "valueReference": str(layout.d + k), "causality": d.causality,
                 "variability": "discrete", "initial": "calculated"}
        if d.description:
            attrs["description"] = d.description
        if d.unit and d.kind == "real":
            attrs["unit"] = d.unit
        ET.SubElement(variables, _KINDS[d.kind][0], attrs)
    for k in range(events.n_indicators if events else 0):
        _float(variables, f"_eventIndicator{k + 1}", layout.z + k, causality="local", variability="continuous",
               initial="calculated", description="event indicator (a sign change is a state event)")
    _solver_settings(variables, layout, cs_step, cs_method)
    _locals(variables, model, layout)
    return variables


def _locals(variables, model, layout):
    """The local variables (an alias is an ``Alias`` element of its first variable), the calculated parameters
    and the constants (variability constant, their value as start)."""
    elements = {}
    for k, v in enumerate(model.observed):
        vr = layout.v_vr[k]
        if vr in elements:
            ET.SubElement(elements[vr], "Alias", {"name": v.name, **({"description": v.description}
                                                                       if v.description else {})})
        else:
            elements[vr] = _float(variables, v.name, vr, v, causality="local", variability="continuous",
                                  initial="calculated")
    for k, q in enumerate(model.dependent):
        _float(variables, q.name, layout.q + k, q, causality="calculatedParameter", variability="tunable",
               initial="calculated")
    for k, c in enumerate(model.constant_variables):
        attrs = {"name": c.name, "valueReference": str(layout.k + k), "causality": "local",
                 "variability": "constant", "initial": "exact", "start": _constant_start(c)}
        if c.description:
            attrs["description"] = c.description
        if c.unit and c.kind == "real":
            attrs["unit"] = c.unit
        ET.SubElement(variables, _KINDS[c.kind][0], attrs)


def _constant_start(c):
    """A constant's value as the start attribute of its type (FMI 2.0 and 3.0 write them alike)."""
    if c.kind == "boolean":
        return "true" if c.start else "false"
    return repr(float(c.start)) if c.kind == "real" else str(int(c.start))


def _structure(root, model, layout, functions):
    """ModelStructure: outputs, derivatives, initial unknowns and event indicators with their dependencies on
    states and inputs (a discrete variable's are left implicit: it may depend on everything; a calculated
    parameter's are the parameters it follows). Local variables have no entry."""
    structure = ET.SubElement(root, "ModelStructure")
    n = len(model.states)
    out_deps, ode_deps = _dependencies(functions[1], layout), _dependencies(functions[0], layout)
    z_deps = _dependencies(functions[3], layout)
    outputs = [(layout.output_vr(model, y.name), out_deps[k]) for k, y in enumerate(model.outputs)]
    events = model.events
    discretes = [(layout.d + k, None) for k, d in enumerate(events.discretes if events else ())
                 if d.causality == "output"]
    derivatives = [(layout.dx + k, ode_deps[k]) for k in range(n)]
    indicators = [(layout.z + k, z_deps[k]) for k in range(len(z_deps))]
    q_deps = _dependencies(functions[-1], layout, parameters=True)
    calculated = [(layout.q + k, q_deps[k]) for k in range(len(model.dependent))]
    for tag, entries in (("Output", outputs + discretes), ("ContinuousStateDerivative", derivatives),
                         ("InitialUnknown", [o for o in outputs if o[0] >= layout.y] + discretes + derivatives
                          + calculated),
                         ("EventIndicator", indicators)):
        for vr, deps in entries:
            attrs = {"valueReference": str(vr)}
            if deps is not None:
                attrs["dependencies"] = deps
            ET.SubElement(structure, tag, attrs)


def _unit_definitions(root, variables):
    """Define every unit used (FMI requires it), with its SI base-unit exponents where the unit is understood."""
    definitions = _unit_element({v.get("unit") for v in variables if v.get("unit")})
    if definitions is not None:
        root.insert(list(root).index(variables), definitions)


def _unit_element(units):
    """A UnitDefinitions element for ``units`` (the same in FMI 2.0 and 3.0), or None when there are none."""
    if not units:
        return None
    definitions = ET.Element("UnitDefinitions")
    for unit in sorted(units):
        element = ET.SubElement(definitions, "Unit", name=unit)
        parsed = base_unit(unit)
        if parsed:
            factor, exponents = parsed
            base = ET.SubElement(element, "BaseUnit", {k: str(v) for k, v in exponents.items()})
            if factor != 1.0:
                base.set("factor", repr(factor))
    return definitions


def _model_description(model, layout, functions, identifier, token, description, cs_step, cs_method):
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": identifier, "instantiationToken": token,
        "generationTool": f"cosim {__version__}",
        "generationDateAndTime": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "structured"})
    if description:
        root.set("description", description)
    services = {"modelIdentifier": identifier, "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
                "providesDirectionalDerivatives": "true"}
    ET.SubElement(root, "ModelExchange", services)
    ET.SubElement(root, "CoSimulation", services, canHandleVariableCommunicationStepSize="true",
                  fixedInternalStepSize=repr(float(cs_step)))
    variables = _variables(root, model, layout, cs_step, cs_method)
    _unit_definitions(root, variables)
    experiment = _default_experiment(model)
    if experiment is not None:
        root.insert(list(root).index(variables), experiment)
    _structure(root, model, layout, functions)
    tree = ET.ElementTree(root)
    ET.indent(tree, space="    ")
    return tree


_EXPERIMENT_ATTRIBUTES = {"StartTime": "startTime", "StopTime": "stopTime", "Tolerance": "tolerance",
                          "Interval": "stepSize"}


def _default_experiment(model):
    """The DefaultExperiment element (the same in FMI 2.0 and 3.0) of the model's experiment annotation, or
    None when it has none: an importer (fmpy, ``cosim run``) runs the model as its author meant where the user
    gives no other span, interval or tolerance."""
    if not model.experiment:
        return None
    return ET.Element("DefaultExperiment", {_EXPERIMENT_ATTRIBUTES[key]: repr(float(value))
                                            for key, value in model.experiment.items()})


def _build_description(identifier):
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    files = ET.SubElement(ET.SubElement(root, "BuildConfiguration", modelIdentifier=identifier), "SourceFileSet")
    for name in _SOURCES[3]:
        ET.SubElement(files, "SourceFile", name=name)
    tree = ET.ElementTree(root)
    ET.indent(tree, space="    ")
    return tree


# ---- FMI 2.0: the same layout and value references; variables are ScalarVariables, referred to by index ----

_KINDS_2 = {"real": "Real", "integer": "Integer", "boolean": "Boolean", "enumeration": "Integer"}
_TYPE_ATTRS_2 = ("unit", "start", "derivative", "min", "max", "nominal")


def _scalar(variables, index, name, vr, vtype="Real", variable=None, **attrs):
    """Append a ScalarVariable; ``attrs`` holds its own attributes and those of its type element
    (``_TYPE_ATTRS_2``); records its 1-based index by value reference in ``index``."""
    own = {"name": name, "valueReference": str(vr)}
    typed = {}
    if variable is not None:
        if variable.description:
            own["description"] = variable.description
        if variable.unit and vtype == "Real":
            typed["unit"] = variable.unit
    for key, value in attrs.items():
        (typed if key in _TYPE_ATTRS_2 else own)[key] = value
    element = ET.SubElement(variables, "ScalarVariable", own)
    ET.SubElement(element, vtype, typed)
    index.setdefault(vr, len(variables))  # an alias (a local sharing a reference) keeps its first variable's
    return element


def _variables_2(model, layout, cs_step, cs_method):
    """ModelVariables of FMI 2.0 and the index of each value reference (event indicators are no variables; the
    embedded solver's settings are fixed parameters, as in FMI 3.0)."""
    variables, index = ET.Element("ModelVariables"), {}
    _scalar(variables, index, "time", 0, causality="independent", variability="continuous")
    for k, p in enumerate(model.parameters):
        _scalar(variables, index, p.name, layout.p + k, variable=p, causality="parameter", variability="tunable",
                initial="exact", start=repr(float(p.start)), **_range(p))
    for k, u in enumerate(model.inputs):
        _scalar(variables, index, u.name, layout.u + k, variable=u, causality="input", start=repr(float(u.start)))
    outputs = {y.name for y in model.outputs}
    for k, x in enumerate(model.states):
        _scalar(variables, index, x.name, layout.x + k, variable=x,
                causality="output" if x.name in outputs else "local", initial="exact", start=repr(float(x.start)),
                **_nominal(x))
    for k, x in enumerate(model.states):
        _scalar(variables, index, f"der({x.name})", layout.dx + k, derivative=str(index[layout.x + k]))
    for k, j in enumerate(layout.y_index):
        _scalar(variables, index, model.outputs[j].name, layout.y + k, variable=model.outputs[j],
                causality="output", initial="calculated")
    for k, d in enumerate(model.events.discretes if model.events else ()):
        _scalar(variables, index, d.name, layout.d + k, _KINDS_2[d.kind], variable=d, causality=d.causality,
                variability="discrete", initial="calculated")
    fixed = {"causality": "parameter", "variability": "fixed", "initial": "exact", "min": "0"}
    _scalar(variables, index, "_cs_step", layout.cs, **fixed, start=repr(float(cs_step)), unit="s",
            description="Co-Simulation: internal step of the embedded solver (at most; equal steps between events)")
    _scalar(variables, index, "_cs_method", layout.cs + 1, "Integer", **fixed, start=str(METHODS.index(cs_method)),
            max=str(len(METHODS) - 1),
            description="Co-Simulation: embedded solver, 0 RK4, 1 implicit Euler (Newton, exact Jacobian)")
    _locals_2(variables, index, model, layout)
    return variables, index


def _locals_2(variables, index, model, layout):
    """FMI 2.0: the local variables (an alias is a ScalarVariable with its first variable's reference), the
    calculated parameters and the constants."""
    for k, v in enumerate(model.observed):
        _scalar(variables, index, v.name, layout.v_vr[k], variable=v, causality="local", variability="continuous",
                initial="calculated")
    for k, q in enumerate(model.dependent):
        _scalar(variables, index, q.name, layout.q + k, variable=q, causality="calculatedParameter",
                variability="tunable", initial="calculated")
    for k, c in enumerate(model.constant_variables):
        _scalar(variables, index, c.name, layout.k + k, _KINDS_2[c.kind], variable=c, causality="local",
                variability="constant", initial="exact", start=_constant_start(c))


def _structure_2(root, model, layout, functions, index):
    """ModelStructure of FMI 2.0: outputs and derivatives with their dependencies on states and inputs, initial
    unknowns (calculated outputs, derivatives, discrete outputs, calculated parameters) with theirs on states,
    inputs and parameters; a discrete output's dependencies are left implicit (it may depend on everything).
    Local variables have no entry."""
    def deps(vrs):
        return " ".join(str(i) for i in sorted(index[int(vr)] for vr in vrs.split()))

    out_deps, ode_deps = _dependencies(functions[1], layout), _dependencies(functions[0], layout)
    out_init = _dependencies(functions[1], layout, parameters=True)
    ode_init = _dependencies(functions[0], layout, parameters=True)
    events = model.events
    discretes = [(layout.d + k, None, None) for k, d in enumerate(events.discretes if events else ())
                 if d.causality == "output"]
    outputs = [(layout.output_vr(model, y.name), out_deps[k], out_init[k]) for k, y in enumerate(model.outputs)]
    derivatives = [(layout.dx + k, ode_deps[k], ode_init[k]) for k in range(len(model.states))]
    q_init = _dependencies(functions[-1], layout, parameters=True)
    calculated = [(layout.q + k, None, q_init[k]) for k in range(len(model.dependent))]
    initial = [o for o in outputs if o[0] >= layout.y] + discretes + derivatives + calculated
    structure = ET.SubElement(root, "ModelStructure")
    for tag, entries, which in (("Outputs", outputs + discretes, 1), ("Derivatives", derivatives, 1),
                                ("InitialUnknowns", initial, 2)):
        if not entries:
            continue
        group = ET.SubElement(structure, tag)
        for entry in sorted(entries, key=lambda e: index[e[0]]):
            attrs = {"index": str(index[entry[0]])}
            if entry[which] is not None:
                attrs["dependencies"] = deps(entry[which])
            ET.SubElement(group, "Unknown", attrs)


def _model_description_2(model, layout, functions, names, settings, source):
    """modelDescription.xml of FMI 2.0: Model Exchange and Co-Simulation in one FMU; ``names`` is (identifier,
    token, description), ``settings`` the embedded solver's (cs_step, cs_method)."""
    identifier, token, description = names
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": identifier, "guid": token, "generationTool": f"cosim {__version__}",
        "generationDateAndTime": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "structured",
        "numberOfEventIndicators": str(model.events.n_indicators if model.events else 0)})
    if description:
        root.set("description", description)
    common = {"modelIdentifier": identifier, "canNotUseMemoryManagementFunctions": "true",
              "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true", "providesDirectionalDerivative": "true"}
    for tag, flags in (("ModelExchange", {"completedIntegratorStepNotNeeded": "true"}),
                       ("CoSimulation", {"canHandleVariableCommunicationStepSize": "true"})):
        element = ET.SubElement(root, tag, {**common, **flags})
        if source:
            files = ET.SubElement(element, "SourceFiles")
            for name in _SOURCES[2]:
                ET.SubElement(files, "File", name=name)
    variables, index = _variables_2(model, layout, *settings)
    units = _unit_element({t.get("unit") for t in variables.iter("Real") if t.get("unit")})
    if units is not None:
        root.append(units)
    categories = ET.SubElement(root, "LogCategories")
    for name, text in (("logEvents", "events and terminate()"), ("logStatusError", "errors")):
        ET.SubElement(categories, "Category", name=name, description=text)
    experiment = _default_experiment(model)
    if experiment is not None:
        root.append(experiment)
    root.append(variables)
    _structure_2(root, model, layout, functions, index)
    tree = ET.ElementTree(root)
    ET.indent(tree, space="    ")
    return tree


def _compile(sources, files, binary, model_name):
    """gcc -O2 ``files`` into a shared library that exports only the FMI functions (the CasADi symbols are
    hidden, so several FMUs load into one process); the standard's headers are those fmpy installs."""
    include = os.path.join(os.path.dirname(fmpy.__file__), "c-code")
    command = [os.environ.get("CC", "gcc"), "-shared", "-fPIC", "-O2", "-fvisibility=hidden",
               "-DCASADI_SYMBOL_EXPORT=", f"-I{sources}", f"-I{include}",
               *(str(sources / name) for name in files), "-o", str(binary), "-lm"]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
    except OSError as err:
        raise BuildError(f"{model_name}: the C compiler {command[0]!r} could not run: {err}") from err
    if done.returncode != 0:
        raise BuildError(f"{model_name}: compiling the FMU failed:\n{done.stderr.strip()[-2000:]}")


def export_fmu(model, fmu_path, description="", cs_step=DEFAULT_CS_STEP, cs_method="rk4", fmi_version=3,
               source=False):
    """Write ``model`` (a :class:`~cosim.compile.model.LoweredModel`) to ``fmu_path`` as an FMU with both
    interfaces, Model Exchange and Co-Simulation (an embedded fixed-step solver).

    The file appears only when the build succeeded (written to a temporary name, then moved).

    Parameters
    ----------
    model : LoweredModel
        Continuous (``events`` is None) or hybrid (an :class:`~cosim.compile.model.EventPart`).
    fmu_path : str or Path
        Target file; its stem is the FMU's model identifier.
    description : str, optional
        Written as the modelDescription's description attribute.
    cs_step : float, default DEFAULT_CS_STEP (1e-3 s)
        Co-Simulation: the embedded solver's internal step in s (the default of parameter ``_cs_step``).
    cs_method : {"rk4", "implicit_euler"}, default "rk4"
        Co-Simulation: the embedded solver (the default of parameter ``_cs_method``).
    fmi_version : {3, 2}, default 3
        FMI 3.0 or FMI 2.0.
    source : bool, default False
        Also put the C sources in the FMU (``sources/``, listed in the modelDescription for FMI 2.0 and in
        ``sources/buildDescription.xml`` for FMI 3.0), so that an importer on another platform compiles them.

    Returns
    -------
    Path
    """
    if not (isinstance(cs_step, (int, float)) and 0.0 < cs_step < float("inf")):
        raise ConfigError(f"cs_step: expected a positive internal step in s, received {cs_step!r}")
    if cs_method not in METHODS:
        raise ConfigError(f"cs_method: expected one of {', '.join(METHODS)}, received {cs_method!r}")
    fmu_path = Path(fmu_path).resolve()
    identifier = fmu_path.stem
    if not identifier.isidentifier():
        raise BuildError(f"FMU name {identifier!r} is not a valid C identifier")
    if fmi_version not in _TEMPLATES:
        raise BuildError(f"{model.name}: FMI version {fmi_version!r} is not supported (expected 2 or 3)")
    _check_names(model)
    layout = _Layout.of(model)
    functions = _c_functions(model)
    token = "{" + str(uuid.uuid4()) + "}"
    with tempfile.TemporaryDirectory(prefix="cosim-build-") as work:
        root, sources = Path(work) / "fmu", Path(work) / "sources"
        binaries = root / "binaries" / (fmpy.platform_tuple if fmi_version == 3 else fmpy.platform)  # x86_64-linux, linux64
        binaries.mkdir(parents=True)
        settings = (cs_step, cs_method)
        _write_sources(sources, model, layout, functions, (identifier, token), settings, fmi_version)
        if fmi_version == 3:
            tree = _model_description(model, layout, functions, identifier, token, description, *settings)
        else:
            tree = _model_description_2(model, layout, functions, (identifier, token, description), settings,
                                        source)
        tree.write(root / "modelDescription.xml", encoding="UTF-8", xml_declaration=True)
        _compile(sources, _SOURCES[fmi_version], binaries / f"{identifier}{fmpy.sharedLibraryExtension}",
                 model.name)
        if source:
            shutil.copytree(sources, root / "sources")
        archive = shutil.make_archive(str(Path(work) / identifier), "zip", root)
        fmu_path.parent.mkdir(parents=True, exist_ok=True)
        staging = fmu_path.with_name(f".{identifier}.fmu.partial")
        shutil.copyfile(archive, staging)
        os.replace(staging, fmu_path)
    return fmu_path


def _check_names(model):
    """Every variable the modelDescription names is named once (a name with two references could give two
    values)."""
    events = model.events
    states = {x.name for x in model.states}
    names = ["time", "_cs_step", "_cs_method", *(f"der({x.name})" for x in model.states),
             *(f"_eventIndicator{k + 1}" for k in range(events.n_indicators if events else 0)),
             *(v.name for group in (model.parameters, model.inputs, model.states, model.observed, model.dependent,
                                    model.constant_variables, events.discretes if events else ()) for v in group),
             *(y.name for y in model.outputs if y.name not in states)]
    seen = set()
    twice = sorted({n for n in names if n in seen or seen.add(n)})
    if twice:
        raise BuildError(f"{model.name}: the FMU would name two variables {', '.join(twice)}")


def _write_sources(sources, model, layout, functions, names, settings, fmi_version):
    """The FMU's C sources: CasADi's model.c/model.h, model_data.h, the wrapper's files of ``fmi_version``
    (and for FMI 3.0 the buildDescription.xml that lists them); ``names`` is (identifier, token), ``settings``
    (cs_step, cs_method)."""
    identifier, token = names
    sources.mkdir(parents=True)
    generator = ca.CodeGenerator("model.c", {"with_header": True})
    for f in functions:
        generator.add(f)
    generator.generate(str(sources) + os.sep)
    (sources / "model_data.h").write_text(_data_header(model, layout, functions, identifier, token, *settings))
    for name in _TEMPLATES[fmi_version]:
        shutil.copyfile(C_TEMPLATE_DIR / name, sources / name)
    if fmi_version == 3:
        _build_description(identifier).write(sources / "buildDescription.xml", encoding="UTF-8",
                                             xml_declaration=True)
