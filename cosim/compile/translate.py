"""Translate rumoca's DAE IR into CasADi SX expressions: variables by role, residual equations with their
source lines, user functions inlined. Constructs the compiler does not support are rejected here, with the
file and line where they appear."""

import dataclasses
import itertools
from dataclasses import dataclass

import casadi as ca

from cosim.compile import arrays, integer_events, tables
from cosim.compile.der_expressions import promote_der_arguments
from cosim.compile.events import EventReader, Relation
from cosim.compile.functions import inline
from cosim.compile.guards import Guards
from cosim.errors import UnsupportedConstructError

__all__ = ["Variable", "Equation", "DaeSystem", "translate", "HOMOTOPY"]

# The parameter of homotopy(actual, simplified): 1 at run time (the lowering substitutes it), 0 for the simplified
# model, from whose solution the lowering continues a nonlinear loop's starting point to the actual one.
HOMOTOPY = ca.SX.sym("$homotopy")

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
    # Element-wise operators (.* ./ .+ .- .^): CasADi's arithmetic on equal shapes is element-wise.
    "elementwise_add": lambda a, b: a + b,
    "elementwise_subtract": lambda a, b: a - b,
    "elementwise_multiply": lambda a, b: a * b,
    "elementwise_divide": lambda a, b: a / b,
    "elementwise_power": lambda a, b: a**b,
}
_BUILTIN_1 = {
    "abs": ca.fabs, "sign": ca.sign, "sqrt": ca.sqrt, "exp": ca.exp, "log": ca.log, "log10": ca.log10,
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "asin": ca.asin, "acos": ca.acos, "atan": ca.atan,
    "sinh": ca.sinh, "cosh": ca.cosh, "tanh": ca.tanh,
}
_BUILTIN_2 = {"min": ca.fmin, "max": ca.fmax, "atan2": ca.atan2}
# IR tables of constructs the compiler does not lower, and the constructs' Modelica names.
_REJECTED_TABLES = {
    "delays": "delay()",
    "previous_values": "previous() (clocked synchronous construct)",
}
_COMPARISON_OPERATORS = ("less", "less_equal", "greater", "greater_equal")
# References to values the compiler does not lower, by the construct a user wrote.
_COORDINATE_NAMES = {
    "delay": "delay()",
    "previous": "previous() (clocked synchronous construct)",
}
_ROLES = {"state", "algebraic", "input", "output", "parameter", "constant", "discrete_real", "discrete_value"}


@dataclass
class Variable:
    """One flat Modelica variable.

    Attributes
    ----------
    name : str
        Flat name, e.g. ``motor.w``.
    role : str
        ``state``, ``algebraic``, ``input``, ``output``, ``parameter``, ``constant``, ``discrete_real`` or
        ``discrete_value`` (a discrete Integer, Boolean or enumeration).
    kind : str
        Value type: ``real``, ``integer``, ``boolean`` or ``enumeration``.
    sym : casadi.SX
        The variable's symbol.
    start, binding : casadi.SX or None
        The start attribute and the declaration binding, as expressions.
    bounds : tuple
        The ``min`` and ``max`` attributes as numbers (None: not declared, or not a constant).
    nominal : float or None
        The ``nominal`` attribute's magnitude (None: not declared, not a constant, or zero).
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
    bounds: tuple = (None, None)
    nominal: float = None


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
    events: object = None  # cosim.compile.events.EventSystem of a hybrid model

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
        storage = dict(flat.ir["storage"])  # its own copy: the variables' roles may change (fixed = false)
        self.storage = storage
        exprs = storage["expressions"]
        self.nodes, self.provenance = integer_events.target_arena(exprs["nodes"], exprs.get("provenance", []))
        self.operands = self._operand_table(exprs["operands"], "operand_count")
        self.subscripts = self._operand_table(exprs.get("subscripts", []), "subscript_count")
        self.value_types = [vt["scalar"] for vt in storage["value_types"]]
        self.dims = [vt.get("dimensions") or [] for vt in storage["value_types"]]
        self.element_of = {}  # element symbol name -> (variable index, row-major position)
        self.time = ca.SX.sym("time")
        self.syms = []
        self.der_syms = {}
        self.memo = {}  # (node, context serial) -> expression; None is the model's own context
        self.inlining = []  # the functions being inlined, outermost first: a recursive call is refused
        self.relations = []  # events.Relation: rumoca's (in its order), then relations on time it leaves out
        self.pre_syms = {}  # variable name -> symbol of pre(variable)
        self.variables_by_index = []
        self.reader = None  # events.EventReader, once the variables are known
        self.relation_nodes = {}
        self.no_event_nodes = set()
        self.direct_nodes = set()  # floor/ceil/integer/div/mod/rem evaluated without events (noEvent, when, initial)
        self.steps = []  # integer_events.Step of each event-generating floor/ceil/integer/div/mod/rem
        self.parametric = set()  # names of parameter and constant elements
        self.call_serials = itertools.count()
        self.tables = tables.Registry()  # the MSL table blocks' table objects (external C functions lowered)
        self.guards = Guards()  # the if-branch and when-clause conditions around what is translated, and the asserts
        self.structural = set()  # parameter elements whose build-time values the lowering decided on

    def where(self, node_id):
        prov = self.provenance[node_id] if node_id < len(self.provenance) else None
        return self.flat.locate(_span_of(prov))

    def location(self, entry):
        """``file:line`` of the first source span inside an IR entry."""
        return self.flat.locate(_span_of(entry))

    def unsupported(self, what, span_holder):
        raise UnsupportedConstructError(
            f"{what} is not supported (see docs/compiler.md)",
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
        return self.guards.memoised(self.memo, key, lambda: self._expr(node_id, ctx))

    def _expr(self, i, ctx):
        node = self.nodes[i]
        (kind, body), = node.items()
        if kind == "literal":
            (literal_type, value), = body.items()
            if literal_type == "string":
                self.reject(f"a String expression (\"{value}\") where a number is computed", self.provenance[i])
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
            if body["operator"] in _COMPARISON_OPERATORS or i in self.relation_nodes:
                return self._relation(i, body, ctx)
            op = _BINARY.get(body["operator"])
            if op is not None:
                return op(self.expr(body["lhs"], ctx), self.expr(body["rhs"], ctx))
        elif kind == "builtin":
            return self._builtin(i, body["builtin"], ctx)
        elif kind == "conditional":
            return self._conditional(i, ctx)
        elif kind == "call":
            return self._call(i, body, ctx)
        elif kind == "runtime_quotient_owner" and body.get("builtin") in integer_events.QUOTIENT_MODES:
            return self._quotient(i, body, ctx)
        elif kind == "function_value":
            return ctx["defs"][body["definition_ordinal"]]
        what = body.get("operator") or body.get("builtin") if isinstance(body, dict) else None
        self.unsupported(f"the construct {kind}{' ' + what if what else ''}", self.provenance[i])

    def _conditional(self, i, ctx):
        """An if-expression, evaluated as Modelica does: a branch whose condition is constant false is not
        evaluated, nor those after one constant true. A branch that cannot be evaluated (a subscript out of
        range, as in the guarded passes rumoca makes of a ``while`` loop) is left out when the parameters'
        bindings show it is not taken; otherwise its error stands. Each condition and branch is translated under
        the conditions that reach it, so that an assert in a function it calls holds only there."""
        operands = self.operands[i]
        values, reached = [], ca.SX(1)
        for c_node, e_node in list(zip(operands[:-1:2], operands[1:-1:2])) + [(None, operands[-1])]:
            with self.guards.under(reached):
                c = None if c_node is None else self.expr(c_node, ctx)
            if c is not None and c.is_constant():
                if float(ca.evalf(c)) == 0.0:
                    continue
                c = None
            taken = reached if c is None else c if reached.is_one() else ca.logic_and(reached, c)
            try:
                with self.guards.under(taken):
                    values.append((c, self.expr(e_node, ctx)))
            except UnsupportedConstructError:
                if self.at_build_time(taken) != 0.0:
                    raise
            if c is None:
                break
            reached = ca.logic_and(reached, ca.logic_not(c))
        result = None
        for c, value in reversed(values):
            result = value if result is None or c is None else ca.if_else(c, value, result)
        return result

    def _coordinate(self, i, body, ctx):
        if body == "time":
            return self.time
        (ref, index), = body.items()
        if ref in ("state", "algebraic", "input", "parameter", "output", "constant"):
            return self.syms[index]
        if ref == "derivative":
            return self.der_syms[index]
        if ref in ("discrete_real", "discrete_value"):
            return self.syms[index]
        if ref in ("pre_discrete_real", "pre_discrete_value", "pre_state"):
            return self._pre(index)
        if ref == "condition":
            return self.reader.level(index)
        if ref == "terminal":
            self.reader.system.reads_terminal = True
            return self.reader.system.terminal
        if ref in _COORDINATE_NAMES:
            self.unsupported(_COORDINATE_NAMES[ref], self.provenance[i])
        if ref == "function_parameter":
            return ctx["args"][index["ordinal"]]
        if ref == "binder":
            return ca.SX(ctx["binders"][(index["domain"], index["ordinal"])])
        self.unsupported(f"a reference to a {ref} variable", self.provenance[i])

    def _pre(self, index):
        name = self.storage["variables"][index]["name"]
        if name not in self.pre_syms:
            self.pre_syms[name] = ca.SX.sym(f"pre({name})")
        return self.pre_syms[name]

    def _relation(self, i, body, ctx):
        """A relation outside noEvent/smooth and outside functions is held between events (a symbol of m)."""
        lhs, rhs = self.expr(body["lhs"], ctx), self.expr(body["rhs"], ctx)
        direct = _BINARY[body["operator"]](lhs, rhs)
        if i in self.no_event_nodes:
            return direct
        if ctx is not None and "args" not in ctx and ca.symvar(direct):  # a for-equation's body, not a function
            self.reject("a relation generating events inside a for-equation (write noEvent(...) around it, or "
                        "the equations one by one)", self.provenance[i])
        if ctx is not None:
            return direct
        if i not in self.relation_nodes:
            if not ca.depends_on(direct, self.time):
                return direct
            self.relation_nodes[i] = len(self.relations)  # a relation on time: rumoca gives only its instant
            self.relations.append(None)
        k = self.relation_nodes[i]
        self.relations[k] = Relation(ca.SX.sym(f"$rel{k}"), lhs - rhs, body["operator"], self.where(i))
        return self.relations[k].sym

    def _builtin(self, i, name, ctx):
        args = [self.expr(j, ctx) for j in self.operands[i]]
        if name in ("no_event", "noEvent"):
            return args[0]
        if name == "smooth":
            return args[-1]
        if name == "homotopy":  # actual where HOMOTOPY is 1, as it is at run time (cosim.compile.lower)
            return ca.if_else(HOMOTOPY == 1, args[0], args[1] + HOMOTOPY * (args[0] - args[1]))
        if name in _BUILTIN_1 and len(args) == 1:
            return _BUILTIN_1[name](args[0])
        if name in _BUILTIN_2 and len(args) == 2:
            return _BUILTIN_2[name](args[0], args[1])
        if name in integer_events.MODES and len(args) == 1:
            return self._step(i, name, integer_events.MODES[name], args[0], ctx)
        if name in integer_events.QUOTIENT_MODES and len(args) == 2:  # rumoca's form on parameters
            return self._quotient_of(i, name, args[0], args[1], ctx)
        if name in arrays.BUILTINS:
            function, integer_args = arrays.BUILTINS[name]
            args = [self.integer(a, i) if k in integer_args else a for k, a in enumerate(args)]
            return function(*args)
        self.reject(f"the built-in {name}()", self.provenance[i])

    def _quotient(self, i, body, ctx):
        """rumoca's ``runtime_quotient_owner`` of ``div``, ``mod`` or ``rem``."""
        return self._quotient_of(i, body["builtin"], self.expr(body["lhs"], ctx), self.expr(body["rhs"], ctx), ctx)

    def _quotient_of(self, i, builtin, x, y, ctx):
        """``div``, ``mod`` or ``rem``: from the held (or direct) integer part of x/y."""
        k = self._step(i, builtin, integer_events.QUOTIENT_MODES[builtin], x / y, ctx)
        return integer_events.quotient(builtin, x, y, k)

    def _step(self, i, name, mode, arg, ctx):
        """An integer-valued function outside noEvent, when-clauses, initialisation and functions, of an argument
        that varies in time: held in the event memory (:class:`~cosim.compile.integer_events.Step`); else direct.
        In a for-equation each value of the loop variables gets its own step."""
        if (i in self.direct_nodes or (ctx is not None and "args" in ctx)
                or not {s.name() for s in ca.symvar(arg)} - self.parametric):
            return integer_events.direct(mode, arg)
        location = self.where(i)
        held = []
        for element in ca.vertsplit(ca.vec(arg)):
            k = len(self.steps)
            self.steps.append(integer_events.Step(ca.SX.sym(f"$step{k}"), element, mode, location))
            held.append(self.steps[-1].sym)
        return ca.reshape(ca.vertcat(*held), arg.shape[0], arg.shape[1])

    def _call(self, i, body, ctx):
        owner = body["owner"]
        key = ("call", owner, None if ctx is None else ctx["serial"])
        return self.guards.memoised(self.memo, key, lambda: self._inline(i, body, ctx))[body["output"]]

    def _inline(self, i, body, ctx):
        args = [self.expr(j, ctx) for j in self.operands[body["owner"]]]
        function = self.storage["functions"][body["function"]]
        if function.get("external"):
            return tables.call(self, function, args, self.where(i))
        return inline(self, body["function"], args)

    def context(self, parent=None, **values):
        """A fresh evaluation context (function arguments, definitions, loop binders) with its own memo serial:
        a serial, not id(): a finished call's context is freed and its id reused by the next call, whose body
        nodes would then hit the first call's memo entries."""
        ctx = dict(parent or {"binders": {}})
        ctx.update(values, serial=next(self.call_serials))
        return ctx

    def integer(self, value, node_id):
        """An integer the build must know (a subscript, a size, a loop bound), from the parameters' bindings."""
        number = self.at_build_time(value)
        if number is not None and number == round(number):
            return int(round(number))
        self.reject(f"an array size, subscript or loop range that is not an Integer known at build time ({value})",
                    self.provenance[node_id])

    def at_build_time(self, value):
        """The number a scalar expression has at build time, its parameters replaced by their bindings until
        none is left; None when one has no binding. Those parameters become structural (not tunable): what the
        build decided from their values holds for those values only."""
        used = set()
        for _ in range(len(self.element_of) + 1):
            free = ca.symvar(value)
            if not free:
                self.structural.update(used)
                return float(ca.evalf(value))
            bindings = [self._binding(s.name()) for s in free]
            if any(b is None for b in bindings):
                return None
            used.update(s.name() for s in free)
            value = ca.substitute(value, ca.vertcat(*free), ca.vertcat(*bindings))
        return None

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
        self._reject_tables()
        for v in storage["variables"]:
            if v["role"] not in _ROLES:
                self.unsupported(f"the {v['role'].replace('_', ' ')} variable {v['name']}", v)
        computed = self._computed_parameters(storage["variables"])
        raw = storage["variables"] = [dict(v, role="state") if i in computed else v
                                      for i, v in enumerate(storage["variables"])]
        self._declare(raw)
        self._mark_no_event()
        self._mark_direct()
        rumoca_relations = storage.get("relations", [])
        for k, rel in enumerate(rumoca_relations):
            if "relation" in rel and not integer_events.generated_floor_relation(rel, self.nodes):
                self.relation_nodes[rel["relation"]["expression"]] = k
        # the entries of div/mod/rem and rumoca's sin(pi*x) >= 0 for floor stay None (events.py drops them)
        self.relations = [None] * len(rumoca_relations)
        variables = []
        for i, v in enumerate(raw):
            a = v["attributes"]
            if self.value_types[v["value_type"]] == "string":  # table and file names: no number to compute
                a = {key: value for key, value in a.items() if key not in ("start", "binding")}
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
                bounds=(self._bound(a.get("min")), self._bound(a.get("max"))),
                nominal=abs(self._bound(a.get("nominal")) or 0.0) or None,
            ))
        self.variables_by_index = variables
        self.reader = EventReader(self, [v for v in variables if v.role in ("discrete_real", "discrete_value")])
        with self.guards.under(ca.SX(0)):  # the asserts in them hold where the equations reach them
            for node in list(self.relation_nodes):
                self.expr(node)
        variables = [element for var in variables if var.kind != "string" for element in _elements(var)]
        equations = [e for op in storage["continuous_equation_operations"] for e in self._equations(op)]
        initial = [e for op in storage.get("initialization_equation_operations", [])
                   if not self.reader.initial_equation(op) for e in self._equations(op)]
        equations += [Equation(d, self.location(raw[i])) for i in computed for d in arrays.elements(self.der_syms[i])]
        derivatives = {name: s for i, der in self.der_syms.items()
                       for name, s in zip(self._element_names(raw[i]), arrays.elements(der))}
        events = self.reader.read()
        for var in variables:  # numbers the build decided on (table data, subscripts): constants
            if var.name in self.tables.frozen or var.name in self.structural:
                var.tunable = False
        return DaeSystem(self.flat.name, variables, derivatives, self.time, equations, initial, events)

    def _bound(self, node):
        """A ``min``, ``max`` or ``nominal`` attribute as a float; None when absent or not one constant (an array's,
        a parameter's)."""
        if node is None:
            return None
        value = self.expr(node)
        return float(value) if value.numel() == 1 and value.is_constant() else None

    def _computed_parameters(self, raw):
        """Real parameters declared ``fixed = false`` (the MSL's ``t0 = time`` in an initial equation): computed by
        the initial equations and constant after them, so each becomes a state with ``der() = 0`` (the role and
        the equation are set by :meth:`run`). Returns their indices."""
        return [i for i, v in enumerate(raw) if v["role"] == "parameter" and v["attributes"].get("fixed")
                and not any(v["attributes"]["fixed"]) and self.value_types[v["value_type"]] == "real"]

    def _reject_tables(self):
        """Constructs rumoca carries that the compiler does not lower, named as the user wrote them."""
        for owner in self.storage.get("clock_ownerships", []):
            if owner.get("sampled"):
                self.unsupported("sample(expression, clock) (clocked synchronous construct)", owner)
        used = {c["node"]["clock"] for c in self.storage.get("conditions", [])
                if isinstance(c["node"], dict) and "clock" in c["node"]}
        for k, clock in enumerate(self.storage.get("clocks", [])):
            if k not in used:
                self.unsupported("Clock (clocked synchronous construct; only sample(start, interval) is lowered)",
                                 clock)
        for table, what in _REJECTED_TABLES.items():
            if self.storage.get(table):
                self.unsupported(what, self.storage[table][0])

    def _mark_no_event(self):
        """Every node inside noEvent() or smooth(): its relations are evaluated directly, without events."""
        self.no_event_nodes = self._below([j for i, node in enumerate(self.nodes) if "builtin" in node
                                           and node["builtin"]["builtin"] in ("no_event", "noEvent", "smooth")
                                           for j in self.operands[i]])

    def _mark_direct(self):
        """Every node where floor/ceil/integer/div/mod/rem are evaluated directly: inside noEvent/smooth, in
        when-clauses (their values are computed at the event) and in what holds at initialisation only."""
        storage = self.storage
        roots = [entry["value"] for entry in storage.get("initial_discrete_values", [])]
        roots += [node for op in storage.get("initialization_equation_operations", [])
                  for node in _residual_nodes(op)]
        roots += [value["value"] for owner in storage.get("discrete_value_owners", []) for branch in owner["branches"]
                  if branch["activation"] != "always" for value in branch["values"]]
        roots += [eq["residual"] for eq in storage.get("discrete_real_equations", []) if eq["activation"] != "always"]
        roots += [d["value"] for t in storage.get("model_event_transactions", []) for step in t["steps"]
                  for d in step["definitions"]]
        roots += [a["kind"]["reinitialize"]["value"] for a in storage.get("event_actions", [])
                  if "reinitialize" in a["kind"]]
        self.direct_nodes = self.no_event_nodes | self._below(roots)

    def _below(self, stack):
        """The nodes ``stack`` and every node under them."""
        found = set()
        while stack:
            i = stack.pop()
            if i in found:
                continue
            found.add(i)
            (kind, body), = self.nodes[i].items()
            if isinstance(body, dict):
                stack += [body[key] for key in ("lhs", "rhs", "operand") if isinstance(body.get(key), int)]
                if kind == "call":
                    stack += self.operands.get(body["owner"], [])
            stack += self.operands.get(i, [])
        return found

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
            if v["role"] in ("parameter", "constant"):
                self.parametric.update(names)
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
            n_steps = len(self.steps)
            try:  # an array equation whose body does not read its index: evaluated once, split in elements
                return [Equation(e, location) for node in body["bodies"]
                        for e in arrays.elements(self.expr(node, self.context()))]
            except KeyError:  # it reads the index (a binder): element by element below
                del self.steps[n_steps:]
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


def _residual_nodes(operation):
    """The expression nodes of an equation operation (a residual's, a structured equation's bodies)."""
    (kind, body), = operation.items()
    if kind == "residual":
        return [body["residual"]]
    return list(body.get("bodies", [])) if isinstance(body, dict) else []


def _elements(var):
    """An array variable as one scalar variable per element (``T[2]``), start and binding split likewise."""
    if var.sym.numel() == 1 and var.sym.name() == var.name:  # a scalar; an array of one element is x[1]
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

    A model with discrete variables, relations outside ``noEvent``, ``when``, ``assert`` or ``terminate`` gets
    ``events`` (an :class:`~cosim.compile.events.EventSystem`); a continuous model gets ``None``.
    """
    system = _Translator(flat).run()
    promote_der_arguments(system)
    return system
