"""Translate rumoca's DAE IR into CasADi SX expressions: variables by role, residual equations with their
source lines, user functions inlined. Constructs the compiler does not support are rejected here, with the
file and line where they appear."""

import dataclasses
import itertools
import warnings
from dataclasses import dataclass, field

import casadi as ca

from cosim.compile import arrays
from cosim.compile.der_expressions import promote_der_arguments
from cosim.compile.functions import inline
from cosim.errors import UnsupportedConstructError

__all__ = ["Variable", "Equation", "DaeSystem", "translate"]

_BINARY = {
    "add": lambda a, b: a + b,
    "subtract": lambda a, b: a - b,
    "multiply": lambda a, b: a * b,
    "divide": lambda a, b: a / b,
    "power": lambda a, b: a**b,
    "greater": lambda a, b: a > b,
    "greater_equal": lambda a, b: a >= b,
    "less": lambda a, b: a < b,
    "less_equal": lambda a, b: a <= b,
    "equal": lambda a, b: a == b,
    "not_equal": lambda a, b: a != b,
    "and": ca.logic_and,
    "or": ca.logic_or,
}
_BUILTIN_1 = {
    "abs": ca.fabs, "sign": ca.sign, "sqrt": ca.sqrt, "exp": ca.exp, "log": ca.log, "log10": ca.log10,
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "asin": ca.asin, "acos": ca.acos, "atan": ca.atan,
    "sinh": ca.sinh, "cosh": ca.cosh, "tanh": ca.tanh,
}
_BUILTIN_2 = {"min": ca.fmin, "max": ca.fmax, "atan2": ca.atan2}
# Event structures rumoca fills for constructs with discrete semantics, and how a user wrote them.
_EVENT_TABLES = {
    "discrete_real_equations": "when-equation (discrete equations)",
    "discrete_value_owners": "discrete variable assignment",
    "model_event_transactions": "when-equation",
    "event_actions": "reinit or when-equation action",
    "previous_values": "pre()",
    "clocks": "clocked construct (sample, Clock)",
    "clock_ownerships": "clocked construct (sample, Clock)",
    "time_events": "time event (sample)",
    "delays": "delay()",
}
_STRUCTURAL_ROLES = {"state", "algebraic", "input", "output", "parameter", "constant"}


@dataclass
class Variable:
    """One flat Modelica variable.

    Attributes
    ----------
    name : str
        Flat name, e.g. ``motor.w``.
    role : str
        ``state``, ``algebraic``, ``input``, ``output``, ``parameter`` or ``constant``.
    kind : str
        Value type: ``real``, ``integer`` or ``boolean``.
    sym : casadi.SX
        The variable's symbol.
    start, binding : casadi.SX or None
        The start attribute and the declaration binding, as expressions.
    """

    name: str
    role: str
    kind: str
    sym: object
    unit: str = ""
    description: str = ""
    start: object = None
    binding: object = None
    fixed: bool = False
    tunable: bool = True
    state_select: str = "Default"
    causality: str = "local"
    location: str = ""


@dataclass
class Equation:
    """A residual equation ``0 = residual`` and where it was written."""

    residual: object
    location: str


@dataclass
class DaeSystem:
    """The model as CasADi symbols and residuals, before causalisation."""

    name: str
    variables: list
    derivatives: dict  # state name -> SX symbol of der(state)
    time: object
    equations: list
    initial_equations: list
    warnings: list = field(default_factory=list)

    def by_role(self, *roles):
        return [v for v in self.variables if v.role in roles]


def _span_of(entry):
    """Find the first source span inside an IR entry (they nest under 'provenance')."""
    if isinstance(entry, dict):
        if "span" in entry and isinstance(entry["span"], dict):
            return entry["span"]
        for value in entry.values():
            span = _span_of(value)
            if span:
                return span
    elif isinstance(entry, list):
        for value in entry:
            span = _span_of(value)
            if span:
                return span
    return None


class _Translator:
    def __init__(self, flat):
        self.flat = flat
        storage = flat.ir["storage"]
        self.storage = storage
        exprs = storage["expressions"]
        self.nodes = exprs["nodes"]
        self.provenance = exprs.get("provenance", [])
        self.operands = self._operand_table(exprs["operands"], "operand_count")
        self.subscripts = self._operand_table(exprs.get("subscripts", []), "subscript_count")
        self.value_types = [vt["scalar"] for vt in storage["value_types"]]
        self.dims = [vt.get("dimensions") or [] for vt in storage["value_types"]]
        self.element_of = {}  # element symbol name -> (variable index, row-major position)
        self.time = ca.SX.sym("time")
        self.syms = []
        self.der_syms = {}
        self.memo = {}  # (node, context serial) -> expression; None is the model's own context
        self.call_serials = itertools.count()

    def where(self, node_id):
        prov = self.provenance[node_id] if node_id < len(self.provenance) else None
        return self.flat.locate(_span_of(prov))

    def unsupported(self, what, span_holder):
        raise UnsupportedConstructError(
            f"{what} is not supported: plant models are continuous; put discrete logic in a Python controller "
            "(see docs/compiler.md)",
            *self._file_line(self.flat.locate(_span_of(span_holder))),
        )

    def reject(self, what, span_holder):
        """A construct rumoca's IR carries that the compiler does not lower (not an event construct)."""
        raise UnsupportedConstructError(f"{what} is not supported (see docs/compiler.md)",
                                        *self._file_line(self.flat.locate(_span_of(span_holder))))

    @staticmethod
    def _file_line(location):
        file, _, line = location.rpartition(":")
        if file and line.isdigit():
            return file, int(line)
        return location, None

    def _operand_table(self, operands, count_key):
        """Variadic nodes take their operands (and subscripts) from one flat array, in node order."""
        table, pos = {}, 0
        for i, node in enumerate(self.nodes):
            (kind, body), = node.items()
            count = body.get(count_key, 0) if isinstance(body, dict) else 0
            if count:
                table[i] = operands[pos:pos + count]
                pos += count
        if pos != len(operands):
            raise UnsupportedConstructError(
                f"rumoca IR of {self.flat.name} has {len(operands)} operands but its nodes consume {pos}: "
                "a construct the compiler does not understand", str(self.flat.path))
        return table

    # -- expressions ---------------------------------------------------------
    def expr(self, node_id, ctx=None):
        key = (node_id, None if ctx is None else ctx["serial"])
        if key not in self.memo:
            self.memo[key] = self._expr(node_id, ctx)
        return self.memo[key]

    def _expr(self, i, ctx):
        node = self.nodes[i]
        (kind, body), = node.items()
        if kind == "literal":
            (_, value), = body.items()
            return ca.SX(float(value))
        if kind == "coordinate":
            return self._coordinate(i, body, ctx)
        if kind == "unary":
            a = self.expr(body["operand"], ctx)
            if body["operator"] == "negate":
                return -a
            if body["operator"] == "not":
                return ca.logic_not(a)
            if body["operator"] == "plus":
                return a
        elif kind in arrays.NODES:
            return arrays.NODES[kind](self, i, body, ctx)
        elif kind == "binary" and body["operator"] == "multiply":
            return arrays.multiply(self.expr(body["lhs"], ctx), self.expr(body["rhs"], ctx))
        elif kind == "binary":
            op = _BINARY.get(body["operator"])
            if op is not None:
                return op(self.expr(body["lhs"], ctx), self.expr(body["rhs"], ctx))
        elif kind == "builtin":
            return self._builtin(i, body["builtin"], ctx)
        elif kind == "conditional":
            args = [self.expr(j, ctx) for j in self.operands[i]]
            result = args[-1]
            for c, e in reversed(list(zip(args[:-1:2], args[1:-1:2]))):
                result = ca.if_else(c, e, result)
            return result
        elif kind == "call":
            return self._call(i, body, ctx)
        elif kind == "function_value":
            return ctx["defs"][body["definition_ordinal"]]
        what = body.get("operator") or body.get("builtin") if isinstance(body, dict) else None
        self.unsupported(f"the construct {kind}{' ' + what if what else ''}", self.provenance[i])

    def _coordinate(self, i, body, ctx):
        if body == "time":
            return self.time
        (ref, index), = body.items()
        if ref in ("state", "algebraic", "input", "parameter", "output", "constant"):
            return self.syms[index]
        if ref == "derivative":
            return self.der_syms[index]
        if ref == "function_parameter":
            return ctx["args"][index["ordinal"]]
        if ref == "binder":
            return ca.SX(ctx["binders"][(index["domain"], index["ordinal"])])
        self.unsupported(f"a reference to a {ref} variable", self.provenance[i])

    def _builtin(self, i, name, ctx):
        args = [self.expr(j, ctx) for j in self.operands[i]]
        if name in ("no_event", "noEvent"):
            return args[0]
        if name == "smooth":
            return args[-1]
        if name == "homotopy":
            return args[0]
        if name in _BUILTIN_1 and len(args) == 1:
            return _BUILTIN_1[name](args[0])
        if name in _BUILTIN_2 and len(args) == 2:
            return _BUILTIN_2[name](args[0], args[1])
        if name in arrays.BUILTINS:
            function, integer_args = arrays.BUILTINS[name]
            args = [self.integer(a, i) if k in integer_args else a for k, a in enumerate(args)]
            return function(*args)
        self.reject(f"the built-in {name}()", self.provenance[i])

    def _call(self, i, body, ctx):
        owner = body["owner"]
        key = ("call", owner, None if ctx is None else ctx["serial"])
        if key not in self.memo:
            args = [self.expr(j, ctx) for j in self.operands[owner]]
            self.memo[key] = inline(self, body["function"], args)
        return self.memo[key][body["output"]]

    def context(self, parent=None, **values):
        """A fresh evaluation context (function arguments, definitions, loop binders) with its own memo serial:
        a serial, not id(): a finished call's context is freed and its id reused by the next call, whose body
        nodes would then hit the first call's memo entries."""
        ctx = dict(parent or {"binders": {}})
        ctx.update(values, serial=next(self.call_serials))
        return ctx

    def integer(self, value, node_id):
        """An integer the build must know (a subscript, a size, a loop bound): parameters are replaced by
        their bindings until none is left."""
        for _ in range(len(self.element_of) + 1):
            free = ca.symvar(value)
            if not free:
                number = float(ca.evalf(value))
                if number == round(number):
                    return int(round(number))
                break
            bindings = [self._binding(s.name()) for s in free]
            if any(b is None for b in bindings):
                break
            value = ca.substitute(value, ca.vertcat(*free), ca.vertcat(*bindings))
        self.reject(f"an array size, subscript or loop range that is not an Integer known at build time ({value})",
                    self.provenance[node_id])

    def _binding(self, name):
        """The binding of a parameter element, None for anything else."""
        if name not in self.element_of:
            return None
        i, k = self.element_of[name]
        v = self.storage["variables"][i]
        node = v["attributes"].get("binding")
        node = v["attributes"].get("start") if node is None else node
        if v["role"] not in ("parameter", "constant") or node is None:
            return None
        value = self.expr(node)
        return value if value.numel() == 1 else arrays.elements(value)[k]

    # -- variables and equations ----------------------------------------------
    def run(self):
        storage = self.storage
        for table, what in _EVENT_TABLES.items():
            if storage.get(table):
                self.unsupported(what, storage[table][0])
        raw = storage["variables"]
        for v in raw:
            if v["role"] not in _STRUCTURAL_ROLES:
                self.unsupported(f"the {v['role'].replace('_', ' ')} variable {v['name']}", v)
        self._declare(raw)
        system_warnings = []
        for rel in storage.get("relations", []):
            if "quotient_owner" in rel:
                self.unsupported("mod/div/rem", storage.get("conditions", [rel]))
            system_warnings.append(
                f"{self.flat.locate(_span_of(rel))}: 'if' without noEvent is evaluated without events")
        variables = []
        for i, v in enumerate(raw):
            a = v["attributes"]
            variables.append(Variable(
                name=v["name"],
                role=v["role"],
                kind=self.value_types[v["value_type"]],
                sym=self.syms[i],
                unit=a.get("unit") or "",
                description=a.get("description") or "",
                start=None if a.get("start") is None else self.expr(a["start"]),
                binding=None if a.get("binding") is None else self.expr(a["binding"]),
                fixed=bool(a.get("fixed")) and a.get("fixed") not in ([False], [None]),
                tunable=bool(a.get("is_tunable", True)),
                state_select=a.get("state_select") or "Default",
                causality=a.get("causality") or "local",
                location=self.flat.locate(_span_of(v.get("declaration"))),
            ))
        variables = [element for var in variables for element in _elements(var)]
        equations = [e for op in storage["continuous_equation_operations"] for e in self._equations(op)]
        initial = [e for op in storage.get("initialization_equation_operations", []) for e in self._equations(op)]
        derivatives = {name: s for i, der in self.der_syms.items()
                       for name, s in zip(self._element_names(raw[i]), arrays.elements(der))}
        return DaeSystem(self.flat.name, variables, derivatives, self.time, equations, initial, system_warnings)

    def _element_names(self, v):
        return [v["name"] + s for s in arrays.element_suffixes(self.dims[v["value_type"]])]

    def _declare(self, raw):
        """One symbol per array element (``T[2]``), and the variable's value as an SX of its shape."""
        self.syms, self.der_syms = [], {}
        for i, v in enumerate(raw):
            dims = self.dims[v["value_type"]]
            if len(dims) > 2 or not all(isinstance(d, int) for d in dims):
                self.reject(f"the array {v['name']} with dimensions {dims} (at most two, known at build time)", v)
            names = self._element_names(v)
            for k, name in enumerate(names):
                self.element_of[name] = (i, k)
            self.syms.append(arrays.shaped([ca.SX.sym(n) for n in names], dims))
            if v["role"] == "state":
                self.der_syms[i] = arrays.shaped([ca.SX.sym(f"der({n})") for n in names], dims)

    def _equations(self, operation):
        """The scalar equations of one IR equation: an array equation gives one per element, a ``for``
        equation (a structured one) one per value of its loop variables."""
        (kind, body), = operation.items()
        location = self.flat.locate(_span_of(operation))
        if kind == "residual":
            return [Equation(r, location) for r in arrays.elements(self.expr(body["residual"]))]
        if kind != "structured":
            self.unsupported(f"the equation form '{kind}'", operation)
        if body.get("scalar_view") == "RowMajorProjection":
            try:  # an array equation whose body does not read its index: evaluated once, split in elements
                return [Equation(e, location) for node in body["bodies"]
                        for e in arrays.elements(self.expr(node, self.context()))]
            except KeyError:  # it reads the index (a binder): element by element below
                pass
        result = []
        for binders in arrays.domain_values(self, body["domain"]):
            ctx = self.context(binders=binders)
            position = [binders[key] - 1 for key in sorted(binders)]
            for node in body["bodies"]:
                value = self.expr(node, ctx)
                if value.numel() > 1:  # an array equation projected on its elements, row-major
                    value = value[tuple(position)] if len(position) == 2 else value[position[0]]
                result.append(Equation(value, location))
        return result


def _elements(var):
    """An array variable as one scalar variable per element (``T[2]``), start and binding split likewise."""
    if var.sym.numel() == 1:
        return [var]
    syms = arrays.elements(var.sym)

    def per_element(value):
        if value is None or value.numel() == 1:
            return [value] * len(syms)
        return arrays.elements(value)

    return [dataclasses.replace(var, name=sym.name(), sym=sym, start=start, binding=binding)
            for sym, start, binding in zip(syms, per_element(var.start), per_element(var.binding))]


def translate(flat):
    """Translate a :class:`~cosim.compile.frontend.FlatModel` into a :class:`DaeSystem` of SX expressions.

    Plain ``if`` expressions (without ``noEvent``) are accepted and evaluated without events; one warning per
    model names their places.
    """
    system = _Translator(flat).run()
    promote_der_arguments(system)
    if system.warnings:
        warnings.warn(
            f"{flat.name}: {len(system.warnings)} 'if' expression(s) without noEvent are evaluated without "
            "events (the master's step bounds the error): " + "; ".join(system.warnings),
            stacklevel=2,
        )
    return system
