"""Hybrid models: read rumoca's event tables (relations, conditions, when-branches, reinit/assert/terminate,
sample clocks) into CasADi expressions, and build the :class:`~cosim.compile.model.EventPart` functions.

The event memory ``m`` holds, in order: the discrete variables, the value of each relation (held between
events so that an ``if`` does not chatter inside a step), the held value of each condition a ``when`` fires on
(a ``when`` fires on the rising edge of its condition against that value), one counter per ``sample``
clock (the index of its next tick, so that tick instants are ``start + k*interval`` exactly), and the held
integer value of each event-generating ``floor``/``ceil``/``integer``/``div``/``mod``/``rem``
(:mod:`cosim.compile.integer_events`).
"""

import graphlib
from dataclasses import dataclass, field

import casadi as ca

from cosim.compile import integer_events
from cosim.compile.model import DiscreteVariable, EventPart
from cosim.errors import StructureError, UnsupportedConstructError

__all__ = ["EventReader", "EventSystem", "Relation", "HybridContext", "memory_symbols", "between_events",
           "referenced_names", "event_part", "DISCRETE_ROLES"]

_COMPARISONS = {"less": ca.lt, "less_equal": ca.le, "greater": ca.gt, "greater_equal": ca.ge,
                "equal": ca.eq, "not_equal": ca.ne}
# The init passes run at initialisation: enough for a chain of initial() when-clauses feeding each other.
INIT_PASSES = 3
# A time event instant counts as reached within this relative distance (rounding of the importer's time).
TIME_TOLERANCE = 1e-12
DISCRETE_ROLES = ("discrete_real", "discrete_value")


@dataclass
class Relation:
    """A relation ``lhs OP rhs`` outside noEvent: its value is held in ``m`` between events."""

    sym: object      # the held value, as it appears in the equations
    g: object        # lhs - rhs
    op: str
    location: str
    kind: str = ""   # set by the lowering: state (an indicator), time (a time event) or discrete


@dataclass
class EventSystem:
    """The discrete side of a translated model, as SX expressions of the translator's symbols."""

    discretes: list              # translate.Variable of each discrete variable, in memory order
    pre: dict                    # variable name -> SX symbol of pre(variable)
    relations: list              # Relation
    held: list = field(default_factory=list)        # (SX symbol of the held condition, level expression)
    assignments: dict = field(default_factory=dict)  # discrete name -> new-value expression
    reinits: list = field(default_factory=list)      # (state name, active, value, location)
    asserts: list = field(default_factory=list)      # (failed, "file:line: message")
    terminates: list = field(default_factory=list)   # (active, "file:line: message")
    clocks: list = field(default_factory=list)       # (counter symbol, tick symbol, start, interval)
    init: object = None                              # SX symbol: 1 during initialisation
    terminal: object = None                          # SX symbol: 1 in the passes at the end of the simulation
    reads_terminal: bool = False                     # the model uses terminal()
    initial_values: dict = field(default_factory=dict)  # discrete name -> value from an initial equation
    steps: list = field(default_factory=list)        # integer_events.Step (floor, ceil, integer, div, mod, rem)


def _comparison(op, a, b):
    return _COMPARISONS[op](a, b)


class EventReader:
    """Reads the event tables of rumoca's IR with a translator's expressions."""

    def __init__(self, tr, discretes):
        self.tr = tr
        self.storage = tr.storage
        self.system = EventSystem(discretes, tr.pre_syms, tr.relations, init=ca.SX.sym("$initial"),
                                  terminal=ca.SX.sym("$terminal"), steps=tr.steps)
        self.levels, self.fires = {}, {}
        for v in discretes:
            tr.pre_syms.setdefault(v.name, ca.SX.sym(f"pre({v.name})"))

    def where(self, entry):
        return self.tr.location(entry)

    def level(self, j):
        """The value of condition ``j`` (true/false)."""
        if j not in self.levels:
            self.levels[j] = self._level(j)
        return self.levels[j]

    def _level(self, j):
        entry = self.storage["conditions"][j]
        node = entry["node"]
        if node == "always":
            return ca.SX(1)
        if node == "initial":
            return self.system.init
        (kind, body), = node.items()
        if kind == "relation" and self.tr.relations[body] is not None:
            return self.tr.relations[body].sym
        if kind == "not":
            return ca.logic_not(self.level(body))
        if kind in ("and", "or"):
            op = ca.logic_and if kind == "and" else ca.logic_or
            return op(self.level(body["lhs"]), self.level(body["rhs"]))
        if kind == "any_rise":
            return ca.logic_or(self.level(body["lhs"]), self.level(body["rhs"]))
        if kind == "discrete":
            return self.tr.expr(body)
        if kind == "clock":
            return self.clock(body, entry)
        self.tr.unsupported(f"the condition form '{kind}'" if kind != "quotient_owner"
                            else "mod(), rem() or div() (event-generating integer division)", entry)

    def fire(self, j):
        """True in the event pass where condition ``j`` rises (a vector condition: where any element rises)."""
        if j in self.fires:
            return self.fires[j]
        node = self.storage["conditions"][j]["node"]
        kind = node if isinstance(node, str) else next(iter(node))
        if kind == "initial":
            fire = self.system.init
        elif kind == "clock":
            fire = self.level(j)
        elif kind == "any_rise":
            fire = ca.logic_or(self.fire(node["any_rise"]["lhs"]), self.fire(node["any_rise"]["rhs"]))
        else:
            held = ca.SX.sym(f"$held{len(self.system.held)}")
            self.system.held.append((held, self.level(j)))
            fire = ca.logic_and(ca.logic_and(self.level(j), ca.logic_not(held)), ca.logic_not(self.system.init))
        self.fires[j] = fire
        return fire

    def clock(self, k, entry):
        clock = self.storage["clocks"][k]["kind"]
        lattice = clock.get("periodic", {}).get("lattice") if isinstance(clock, dict) else None
        if lattice is None:
            self.tr.unsupported("a clock that is not periodic (clocked synchronous construct)", entry)
        while len(self.system.clocks) <= k:
            self.system.clocks.append(None)
        if self.system.clocks[k] is None:
            start = lattice["phase"]["num"] / lattice["phase"]["den"]
            interval = lattice["period"]["num"] / lattice["period"]["den"]
            self.system.clocks[k] = (ca.SX.sym(f"$clock{k}"), ca.SX.sym(f"$tick{k}"), start, interval)
        return self.system.clocks[k][1]

    def active(self, activation):
        """When a branch or action applies: ``always``, or when its trigger rises and its guard holds."""
        if activation == "always":
            return ca.SX(1)
        when = activation["when"]
        fire = self.fire(when["trigger"])
        if when["guard"] == when["trigger"]:
            return fire
        return ca.logic_and(fire, self.level(when["guard"]))

    def action_active(self, action):
        trigger = self.storage["conditions"][action["trigger"]]["node"]
        if trigger == "always":
            return self.level(action["guard"])
        return self.active({"when": {"trigger": action["trigger"], "guard": action["guard"]}})

    def read(self):
        """The :class:`EventSystem` of the model, or None when the model has no event (continuous)."""
        for entry in self.storage.get("initial_discrete_values", []):
            var = self.tr.variables_by_index[entry["target"]]
            self.system.initial_values[var.name] = self.tr.expr(entry["value"])
        self._owners()
        self._discrete_reals()
        self._transactions()
        self._actions()
        system = self.system
        system.asserts += self.tr.guards.checks()
        listed = self.storage.get("relations", [])
        if any(r is None and "relation" in entry and not integer_events.generated_floor_relation(entry, self.tr.nodes)
               for r, entry in zip(system.relations, listed)):
            self.tr.unsupported("a relation rumoca lists that is not a comparison", listed)
        # rumoca's entries of div/mod/rem and its sin(pi*x) >= 0 of floor: their steps replace them
        system.relations[:] = [r for r in system.relations if r is not None]
        system.clocks = [c for c in system.clocks if c is not None]
        if not (system.discretes or system.relations or system.asserts or system.terminates or system.clocks
                or system.reads_terminal or system.steps):
            return None
        return system

    def _add_branches(self, var, branches):
        """New value of ``var``: the first active branch's value, else its pre() value (when-clauses)."""
        value = self.system.pre[var.name]
        always = None
        for active, expr in reversed(branches):
            if isinstance(active, ca.SX) and active.is_constant() and float(active) == 1.0:
                always = expr
                continue
            value = ca.if_else(active, expr, value)
        if var.name in self.system.assignments:
            self.tr.unsupported(f"a second equation for the discrete variable {var.name}", var.location)
        self.system.assignments[var.name] = always if always is not None else value

    def _owners(self):
        for owner in self.storage.get("discrete_value_owners", []):
            for t, target in enumerate(owner["targets"]):
                var = self.tr.variables_by_index[target]
                branches = [(self.active(b["activation"]), b["values"][t]["value"]) for b in owner["branches"]]
                branches = [(active, self._when_value(active, node)) for active, node in branches]
                self._add_branches(var, branches)

    def _discrete_reals(self):
        grouped = {}
        for eq in self.storage.get("discrete_real_equations", []):
            active = self.active(eq["activation"])
            with self.tr.guards.under(active):
                var, value = self._solve_discrete(eq)
            grouped.setdefault(var.name, (var, []))[1].append((active, value))
        for var, branches in grouped.values():
            self._add_branches(var, branches)

    def _when_value(self, active, node):
        """A value assigned when ``active``: the asserts of the functions it calls hold only then."""
        with self.tr.guards.under(active):
            return self.tr.expr(node)

    def _solve_discrete(self, eq):
        """A discrete Real equation ``d = expr`` (rumoca writes it as the residual ``d - expr``)."""
        solved = self._discrete_lhs(eq["residual"])
        if solved is None:
            self.tr.unsupported("a discrete Real equation that is not of the form 'v = expression' "
                                "(when-equation)", eq)
        return solved

    def _discrete_lhs(self, residual):
        """(variable, value) of a residual ``d - expr`` with a discrete Real ``d``, else None."""
        body = self.tr.nodes[residual].get("binary", {})
        lhs = self.tr.nodes[body["lhs"]] if body.get("operator") == "subtract" else {}
        coordinate = lhs.get("coordinate")
        if not isinstance(coordinate, dict) or "discrete_real" not in coordinate:
            return None
        return self.tr.variables_by_index[coordinate["discrete_real"]], self.tr.expr(body["rhs"])

    def initial_equation(self, operation):
        """Take an initial equation ``d = expr`` of a discrete Real as its initial value; True if taken."""
        body = operation.get("residual")
        solved = self._discrete_lhs(body["residual"]) if isinstance(body, dict) else None
        if solved is not None:
            self.system.initial_values[solved[0].name] = solved[1]
        return solved is not None

    def _transactions(self):
        """An algorithm's when-statements, as rumoca orders them: each step assigns its targets when it is active;
        a later step overrides an earlier one. They restate the owners' assignments in statement order."""
        for transaction in self.storage.get("model_event_transactions", []):
            values = {}
            for step in transaction["steps"]:
                active = self.active({"when": {"trigger": step["trigger"], "guard": step["guard"]}})
                for definition in step["definitions"]:
                    var = self.tr.variables_by_index[definition["target"]["variable"]]
                    previous = values.get(var.name, self.system.pre[var.name])
                    values[var.name] = ca.if_else(active, self._when_value(active, definition["value"]), previous)
            self.system.assignments.update(values)

    def _actions(self):
        for action in self.storage.get("event_actions", []):
            (kind, body), = action["kind"].items()
            location = self.where(action)
            active = self.action_active(action)
            if kind == "reinitialize":
                state = self.tr.variables_by_index[body["state"]]
                self.system.reinits.append((state.name, active, self._when_value(active, body["value"]), location))
            elif kind in ("assert", "terminate"):
                message = f"{self.tr.where(body['message']) or location}: {self._text(body['message'])}"
                (self.system.asserts if kind == "assert" else self.system.terminates).append((active, message))
            else:
                self.tr.unsupported(f"the event action '{kind}'", action)

    def _text(self, node_id):
        node = self.tr.nodes[node_id]
        literal = node.get("literal", {})
        if isinstance(literal, dict) and "string" in literal:
            return literal["string"]
        return "(message computed at run time; not available)"


def _names(expr):
    return {s.name() for s in ca.symvar(expr)}


def _vec(items):
    return ca.vertcat(*items) if items else ca.SX(0, 1)


def memory_symbols(events):
    """The symbols of ``m`` in memory order: discrete values, relations, held conditions, clock counters, held
    integer values (steps)."""
    return ([v.sym for v in events.discretes] + [r.sym for r in events.relations]
            + [h for h, _ in events.held] + [c[0] for c in events.clocks] + [s.sym for s in events.steps])


def referenced_names(events):
    """Names of every symbol the event expressions read (to evaluate only the continuous unknowns they need)."""
    exprs = [r.g for r in events.relations] + list(events.assignments.values()) + [lv for _, lv in events.held]
    exprs += [s.arg for s in events.steps]
    exprs += [e for _, active, value, _ in events.reinits for e in (active, value)]
    exprs += [active for active, _ in events.asserts + events.terminates]
    return set().union(*[_names(e) for e in exprs]) if exprs else set()


def between_events(events, variables):
    """(from, to) for the continuous equations: between events ``pre(v)`` is ``v``, ``initial()``,
    ``terminal()`` and ``sample()`` are false. ``variables``: name -> symbol of every variable ``pre`` may name."""
    pairs = [(sym, variables[n]) for n, sym in events.pre.items()]
    pairs += [(events.init, ca.SX(0)), (events.terminal, ca.SX(0))] + [(c[1], ca.SX(0)) for c in events.clocks]
    return [a for a, _ in pairs], [b for _, b in pairs]


@dataclass
class HybridContext:
    """What the event functions need from the continuous lowering."""

    X: object            # SX column of the active states
    U: object
    P: object
    T: object
    W: list              # symbols of the continuous unknowns the event expressions may read
    w_value: object      # w_value(x, u, p, t, m) -> values of W (MX), from ode/out/observe
    states: list         # names of the active states, in X order
    substitute: object   # parameter substitution (dependent parameters, constants)
    p_values: list       # default values of the tunable parameters
    x_values: list       # initial states at the default parameters
    location: str


def _tolerance(t):
    return TIME_TOLERANCE * ca.fmax(1, ca.fabs(t))


def _classify(events, ctx):
    """state relations and steps get indicators, affine ones on time a time event, the rest are discrete."""
    continuous = {s.name() for s in ca.vertsplit(ctx.X)} | {s.name() for s in ca.vertsplit(ctx.U)}
    continuous |= {s.name() for s in ctx.W}
    parameters = {s.name() for s in ca.vertsplit(ctx.P)}

    def kind(g):
        timed = ca.depends_on(g, ctx.T)
        if _names(g) & continuous or (timed and _names(ca.jacobian(g, ctx.T)) - parameters):
            return "state"
        return "time" if timed else "discrete"

    for rel in events.relations:
        rel.g = ctx.substitute(rel.g)
        rel.kind = "discrete" if rel.op in ("equal", "not_equal") else kind(rel.g)
    for step in events.steps:
        step.arg = ctx.substitute(step.arg)
        step.kind = kind(step.arg)


def _time_relation(rel, T, initial):
    """A relation on time: at an event instant, its limit from the right (``time > 0.35`` is true at 0.35)."""
    slope = ca.jacobian(rel.g, T)
    instant = -ca.substitute(rel.g, T, 0) / slope
    crossed = T >= instant - _tolerance(instant)
    positive = ca.if_else(slope > 0, crossed, ca.logic_not(crossed))
    right = positive if rel.op in ("greater", "greater_equal") else ca.logic_not(positive)
    return ca.if_else(initial, _comparison(rel.op, rel.g, 0), right), instant


def _resolve(assignments, discretes, location):
    """Substitute the discrete variables' new values into each other, in dependency order."""
    syms = {v.name: v.sym for v in discretes}
    deps = {n: _names(e) & set(syms) - {n} for n, e in assignments.items()}
    try:
        order = list(graphlib.TopologicalSorter(deps).static_order())
    except graphlib.CycleError as err:
        raise StructureError(f"discrete variables {', '.join(err.args[1])} are assigned from each other's new "
                             "values in a cycle (use pre() for one of them)", location) from None
    done = {}
    for n in order:
        if n not in assignments:
            continue
        e = assignments[n]
        inner = [m for m in _names(e) & set(done) if m != n]
        if inner:
            e = ca.substitute(e, ca.vertcat(*[syms[m] for m in inner]), ca.vertcat(*[done[m] for m in inner]))
        done[n] = e
    return done


def _step_values(events, ctx, d_to_pre, rel_new):
    """The new value of each step in an event pass: directly from its argument (discrete variables at pre, the
    relations' and the inner steps' new values), on time its value just after the instant."""
    values = []
    for step in events.steps:  # a step inside another's argument comes first and is replaced by its new value
        arg = step.arg if d_to_pre is None else ca.substitute(step.arg, *d_to_pre)
        inner = [r.sym for r in events.relations] + [s.sym for s in events.steps[:len(values)]]
        if inner:
            arg = ca.substitute(arg, ca.vertcat(*inner), ca.vertcat(*(rel_new + values)))
        if step.kind == "time":
            values.append(integer_events.right_limit(step, arg, ctx.T, _tolerance(ctx.T), events.init))
        else:
            values.append(integer_events.direct(step.mode, arg))
    return values


def _pass(events, ctx):
    """One event-iteration pass as an SX function (x, u, p, t, m_pre, w, initial, terminal, c) -> (x_new, m_new,
    status, fresh); ``terminal`` is 1 in the passes at the end of the simulation, where ``terminal()`` is true.
    ``c`` are candidate values of the relations and steps: the discrete variables, when-clauses and reinits read
    them, and ``m_new`` holds them; ``fresh`` are the values the relations and steps take at ``w`` (the mixed
    system of a pass is solved where ``fresh == c``, see :func:`event_part`)."""
    init = events.init
    pre_d = [events.pre[v.name] for v in events.discretes]
    d_to_pre = (ca.vertcat(*[v.sym for v in events.discretes]), ca.vertcat(*pre_d)) if pre_d else None
    rel_new = []
    for rel in events.relations:
        g = rel.g if d_to_pre is None else ca.substitute(rel.g, *d_to_pre)
        if rel.kind == "time":
            value, _ = _time_relation(Relation(rel.sym, g, rel.op, rel.location), ctx.T, init)
        else:
            value = _comparison(rel.op, g, 0)
        rel_new.append(value)
    step_new = _step_values(events, ctx, d_to_pre, rel_new)
    ticks, counters = [], []
    for counter, tick, start, interval in events.clocks:
        due = start + counter * interval
        ticks.append(ca.logic_and(ca.logic_not(init), ctx.T >= due - _tolerance(due)))
        first = ca.fmax(0, ca.ceil((ctx.T - start) / interval - 1e-6))
        after = ca.floor((ctx.T - start) / interval + 1e-6) + 1
        counters.append(ca.if_else(init, first, ca.if_else(ticks[-1], after, counter)))
    state_pre = [(events.pre[n], s) for n, s in zip(ctx.states, ca.vertsplit(ctx.X)) if n in events.pre]
    subs_from = [r.sym for r in events.relations] + [c[1] for c in events.clocks] + [a for a, _ in state_pre]
    subs_from += [s.sym for s in events.steps]
    candidates = [ca.SX.sym(f"$cand{k}") for k in range(len(rel_new) + len(step_new))]
    cand_rel, cand_step = candidates[:len(rel_new)], candidates[len(rel_new):]
    subs_to = cand_rel + ticks + [b for _, b in state_pre] + cand_step

    def known(expr):
        expr = ctx.substitute(expr)
        return ca.substitute(expr, ca.vertcat(*subs_from), ca.vertcat(*subs_to)) if subs_from else expr

    assignments = {v.name: known(events.assignments.get(v.name, events.pre[v.name])) for v in events.discretes}
    new = _resolve(assignments, events.discretes, ctx.location)
    d_syms = [v.sym for v in events.discretes]

    def final(expr):
        expr = known(expr)
        return ca.substitute(expr, ca.vertcat(*d_syms), ca.vertcat(*[new[v.name] for v in events.discretes])) \
            if d_syms else expr

    held_new = [final(level) for _, level in events.held]
    x_new = list(ca.vertsplit(ctx.X))
    for name, active, value, location in events.reinits:
        if name not in ctx.states:
            raise UnsupportedConstructError(
                f"reinit of {name}, which the lowering computes from a constraint (not a state)", location)
        k = ctx.states.index(name)
        x_new[k] = ca.if_else(final(active), final(value), x_new[k])
    status = ca.SX(0)
    for active, _ in events.terminates:
        status = ca.if_else(final(active), 1, status)
    for k in reversed(range(len(events.asserts))):
        status = ca.if_else(final(events.asserts[k][0]), 2 + k, status)
    m_pre = pre_d + [ca.SX.sym(f"$relpre{k}") for k in range(len(events.relations))] \
        + [h for h, _ in events.held] + [c[0] for c in events.clocks] \
        + [s.sym for s in events.steps]  # a relation on a step reads its value before this pass
    m_new = [new[v.name] for v in events.discretes] + cand_rel + held_new + counters + cand_step
    inputs = [ctx.X, ctx.U, ctx.P, ctx.T, _vec(m_pre), _vec(ctx.W), init, events.terminal, _vec(candidates)]
    outputs = [_vec(x_new), _vec(m_new), status, _vec(rel_new + step_new)]
    _check_free(outputs, inputs, ctx.location)
    return ca.Function("event_pass", inputs, outputs)


def _fresh_pass(given):
    """The pass that takes the relations' and steps' fresh values as its candidates: (x, u, p, t, m_pre, w,
    initial, terminal) -> (x_new, m_new, status)."""
    args = given.sx_in()
    outputs = given.call(args)
    fresh = outputs[3]
    inputs = args[:8]
    return ca.Function("event_pass", inputs, [ca.substitute(o, args[8], fresh) for o in outputs[:3]])


def _candidate_rows(events):
    """Rows of ``m`` that hold the relations' and the steps' values (the candidates of :func:`_mixed`)."""
    first = len(events.discretes)
    steps = len(events.steps)
    end = first + len(events.relations) + len(events.held) + len(events.clocks) + steps
    return list(range(first, first + len(events.relations))) + list(range(end - steps, end))


def _mixed(given, ctx, rows, symbols):
    """mixed(x, u, p, t, m_pre, c) -> (x_new, m_new, status, m_fresh): the pass with the relations and steps at
    their candidate values, the rows ``rows`` of ``c``: the discrete variables are computed from them (and
    ``pre()`` = ``m_pre``), the continuous unknowns from those, and ``m_fresh`` is ``m_new`` with the values the
    relations and steps take there. Where ``m_fresh == m_new`` the candidates solve the pass's mixed system
    (Booleans and the continuous unknowns that decide each other, as the friction elements' locked,
    startForward and sa): the C core searches for such candidates (fmu_c/model_core.c, ``solve_mixed``)."""
    Xm, Um, Pm, Tm, Mm = symbols
    c = ca.MX.sym("c", Mm.shape[0])
    cand = c[rows]
    discrete_side = given(Xm, Um, Pm, Tm, Mm, ctx.w_value(Xm, Um, Pm, Tm, Mm), 0, 0, cand)[1]
    w = ctx.w_value(Xm, Um, Pm, Tm, discrete_side)
    x_new, m_new, status, fresh = given(Xm, Um, Pm, Tm, Mm, w, 0, 0, cand)
    m_fresh = ca.vertsplit(m_new)
    for row, value in zip(rows, ca.vertsplit(fresh)):
        m_fresh[row] = value
    return ca.Function("mixed", [Xm, Um, Pm, Tm, Mm, c], [x_new, m_new, status, ca.vertcat(*m_fresh)],
                       ["x", "u", "p", "t", "m_pre", "c"], ["x_new", "m_new", "status", "m_fresh"])


def _check_free(outputs, inputs, location):
    free = set().union(*[_names(o) for o in outputs]) - set().union(*[_names(i) for i in inputs])
    if free:
        raise StructureError(f"the event equations read {', '.join(sorted(free))}, which are not known at an "
                             "event (a variable of the model the compiler could not express)", location)


def _next_time(events, ctx, M):
    """next_time(t, p, m): the earliest time event strictly after t (inf when none)."""
    best = ca.SX(ca.inf)
    for rel in events.relations:
        if rel.kind == "time":
            _, instant = _time_relation(rel, ctx.T, ca.SX(0))
            best = ca.fmin(best, ca.if_else(instant > ctx.T + _tolerance(ctx.T), instant, ca.inf))
    for counter, _, start, interval in events.clocks:
        best = ca.fmin(best, start + counter * interval)
    for step in events.steps:
        if step.kind == "time":
            instant = integer_events.next_instant(step, ctx.T)
            best = ca.fmin(best, ca.if_else(instant > ctx.T + _tolerance(ctx.T), instant, ca.inf))
    # after event iteration pre(d) = d: a relation like time >= (pre(count) + 1)*period (MSL Sources.Pulse)
    pre = [(events.pre[v.name], v.sym) for v in events.discretes if v.name in events.pre]
    if pre:
        best = ca.substitute(best, ca.vertcat(*[a for a, _ in pre]), ca.vertcat(*[b for _, b in pre]))
    _check_free([best], [ctx.T, ctx.P, M], ctx.location)
    return ca.Function("next_time", [ctx.T, ctx.P, M], [best], ["t", "p", "m"], ["t_next"])


def _start_value(v, events, ctx):
    """A discrete variable's value before the first event: its initial equation, else its start value."""
    start = events.initial_values.get(v.name, v.start)
    return ctx.substitute(start) if start is not None else ca.SX(0)


def _start_memory(events, ctx, M):
    starts = [_start_value(v, events, ctx) for v in events.discretes]
    zeros = [ca.SX(0)] * (M.numel() - len(starts))
    start = _vec(starts + zeros)
    _check_free([start], [ctx.X, ctx.U, ctx.P, ctx.T], ctx.location)
    return ca.Function("m_start", [ctx.X, ctx.U, ctx.P, ctx.T], [start])


def _reads_terminal(step):
    """Whether an event pass reads its ``terminal`` input (the model uses ``terminal()``)."""
    outputs = step.call(step.sx_in())
    return ca.depends_on(ca.vertcat(*[ca.vec(o) for o in outputs]), step.sx_in(7))


def event_part(events, ctx, M):
    """The :class:`EventPart` of a hybrid model (``ctx.w_value`` gives the continuous unknowns at (x,u,p,t,m))."""
    _classify(events, ctx)
    given = _pass(events, ctx)
    step = _fresh_pass(given)
    names = ["x", "u", "p", "t"]
    Xm, Um, Pm, Tm = (ca.MX.sym(n, s.shape[0]) for n, s in zip(names, (ctx.X, ctx.U, ctx.P, ctx.T)))
    Mm = ca.MX.sym("m", M.shape[0])
    w = ctx.w_value(Xm, Um, Pm, Tm, Mm)
    update = ca.Function("update", [Xm, Um, Pm, Tm, Mm], list(step(Xm, Um, Pm, Tm, Mm, w, 0, 0)),
                         names + ["m_pre"], ["x_new", "m_new", "status"])
    terminal = None
    if _reads_terminal(step):
        terminal = ca.Function("terminal", [Xm, Um, Pm, Tm, Mm], list(step(Xm, Um, Pm, Tm, Mm, w, 0, 1)),
                               names + ["m_pre"], ["x_new", "m_new", "status"])
    start = _start_memory(events, ctx, M)(Xm, Um, Pm, Tm)
    keep = ca.DM([1.0 if k < len(events.discretes) else 0.0 for k in range(M.shape[0])])
    m = start
    for _ in range(INIT_PASSES):  # pre() of a discrete variable is its start value in every init pass
        m_pre = keep * start + (1 - keep) * m
        m = step(Xm, Um, Pm, Tm, m_pre, ctx.w_value(Xm, Um, Pm, Tm, m), 1, 0)[1]
    initial = ca.Function("initial", [Xm, Um, Pm, Tm], [m], names, ["m"])
    state_relations = [r for r in events.relations if r.kind == "state"]
    z_steps = [g for s in events.steps if s.kind == "state" for g in integer_events.indicators(s)]
    z = ca.Function("z", [ctx.X, ctx.U, ctx.P, ctx.T, M, _vec(ctx.W)],
                    [_vec([_relation_indicator(r) for r in state_relations] + z_steps)])
    indicators = ca.Function("indicators", [Xm, Um, Pm, Tm, Mm],
                             [z(Xm, Um, Pm, Tm, Mm, ctx.w_value(Xm, Um, Pm, Tm, Mm))], names + ["m"], ["z"])
    rows = _candidate_rows(events)
    return EventPart(
        discretes=tuple(_discrete_variable(v, events, ctx) for v in events.discretes),
        n_memory=M.shape[0], n_indicators=len(state_relations) + len(z_steps), indicators=indicators, update=update,
        initial=initial, next_time=_next_time(events, ctx, M), terminal=terminal,
        messages=tuple(msg for _, msg in events.asserts) + tuple(msg for _, msg in events.terminates[:1]),
        mixed=_mixed(given, ctx, rows, (Xm, Um, Pm, Tm, Mm)) if rows else None, candidates=tuple(rows),
    )


def _relation_indicator(rel):
    """A state relation's event indicator: ``g``, and exactly 0 a DBL_MIN off on the side of the relation's held
    value, as the steps' are (integer_events.indicators). A ``g`` that starts at 0 and leaves it to the side that
    flips the relation is then a crossing a solver sees: CVode ignores a root at its initial point (fmpy's missed
    ``w_a < 0`` of LossyGear, whose w_a starts at 0)."""
    above = rel.sym if rel.op in ("greater", "greater_equal") else ca.logic_not(rel.sym)
    return rel.g + ca.if_else(above, integer_events.DBL_MIN, -integer_events.DBL_MIN)


def _discrete_variable(v, events, ctx):
    start = _start_value(v, events, ctx)
    value = float(ca.Function("start", [ctx.X, ctx.U, ctx.P, ctx.T], [start])(
        ctx.x_values, [0.0] * ctx.U.numel(), ctx.p_values, 0.0))
    return DiscreteVariable(v.name, v.kind, v.unit, v.description, value,
                            "output" if v.causality == "output" else "local")
