"""Lower a translated DAE to an explicit ODE: parameter resolution, index reduction of redundant states
(dummy derivatives), causalisation (one-unknown equations first, then strongly connected blocks solved
symbolically when linear and by a generated Newton rootfinder when not)."""

import casadi as ca
import numpy as np

from cosim.compile import events as hybrid
from cosim.compile.causalise import causalise, depends, file_line, generic_rank, symbol_names
from cosim.compile.guess import better_guess, continued_guess
from cosim.compile.initial import initial_state
from cosim.compile.model import Carried, LoweredModel, ModelVariable
from cosim.compile.newton import NEWTON_ITERATIONS, RETRY_ITERATIONS, converged, loop_solvers
from cosim.compile.translate import HOMOTOPY, Equation
from cosim.errors import StructureError, UnsupportedConstructError

__all__ = ["lower_system"]

# Which redundant state to demote first when a constraint ties states together.
_DEMOTE_ORDER = {"never": 0, "avoid": 1, "default": 2, "prefer": 3, "always": 4}


def _evaluate(expr, where):
    if not expr.is_constant() and ca.symvar(expr):
        names = ", ".join(sorted(symbol_names(expr)))
        raise StructureError(f"{where}: value depends on {names}, which are not parameters with values")
    return float(ca.evalf(expr))


class _Parameters:
    """Split parameters into tunable ones (free symbols in the FMU), dependent ones (substituted, so they
    follow the tunable ones) and constants (Integer, Boolean, non-tunable: evaluated at build time)."""

    def __init__(self, system):
        params = system.by_role("parameter", "constant")
        param_names = {p.name for p in params}
        self.notes = []
        self.free = []
        dependent = {}
        for p in params:
            value = p.binding if p.binding is not None else p.start
            structural = p.kind != "real" or p.role == "constant" or not p.tunable
            if value is None:
                value = ca.SX(0.0)
                self.notes.append(f"{p.location}: parameter {p.name} has no value; using 0")
            if not structural and not depends(value, param_names):
                self.free.append(p)
            dependent[p.name] = (p, value)
        free_names = {p.name for p in self.free}
        self.defaults = {p.name: _evaluate(dependent[p.name][1], p.location) for p in self.free}
        # Resolve dependent bindings to expressions of the free parameters only.
        resolved = {}
        syms = {p.name: p.sym for p in params}
        pending = {n: v for n, (p, v) in dependent.items() if n not in free_names}
        for _ in range(len(pending) + 1):
            if not pending:
                break
            done = {}
            for name, expr in pending.items():
                unresolved = symbol_names(expr) & set(pending)
                if not unresolved:
                    done[name] = expr
            if not done:
                cycle = ", ".join(sorted(pending))
                p = dependent[next(iter(pending))][0]
                raise StructureError(f"parameter bindings form a cycle: {cycle}", *file_line(p.location))
            for name, expr in done.items():
                del pending[name]
                resolved[name] = expr
            for name in pending:
                inner = [n for n in symbol_names(pending[name]) if n in resolved]
                if inner:
                    pending[name] = ca.substitute(
                        pending[name], ca.vertcat(*[syms[n] for n in inner]),
                        ca.vertcat(*[resolved[n] for n in inner]))
        self.constants = {}
        self.declared = {p.name: p for p in params}
        free_syms = ca.vertcat(*[p.sym for p in self.free]) if self.free else ca.SX(0, 1)
        free_vals = ca.vertcat(*[self.defaults[p.name] for p in self.free]) if self.free else ca.SX(0, 1)
        self.subs_from, self.subs_to, self.subs_names = [], [], []
        for name, expr in resolved.items():
            p = dependent[name][0]
            structural = p.kind != "real" or p.role == "constant" or not p.tunable
            if structural:
                value = _evaluate(ca.substitute(expr, free_syms, free_vals), p.location)
                self.constants[name] = int(value) if p.kind != "real" else value
                expr = ca.SX(value)
            self.subs_from.append(syms[name])
            self.subs_to.append(expr)
            self.subs_names.append(name)
        # Constants inside dependent expressions are numbers now.
        if self.subs_from:
            const_from = [syms[n] for n in self.constants]
            const_to = [ca.SX(v) for v in self.constants.values()]
            if const_from:
                self.subs_to = list(ca.substitute(self.subs_to, const_from, const_to))

    def dependent(self):
        """The dependent parameters (bound to others, not structural): [(variable, expression in the tunable
        parameters)] in binding order."""
        return [(self.declared[n], e) for n, e in zip(self.subs_names, self.subs_to) if n not in self.constants]

    def substitute(self, expr):
        if not self.subs_from or expr is None:
            return expr
        return ca.substitute(expr, ca.vertcat(*self.subs_from), ca.vertcat(*self.subs_to))


def _pick_state_to_demote(constraints, states, demoted, fresh, discrete):
    """The state the last of this pass's ``constraints`` computes: state_select never/avoid first, then the last
    declared, among those that keep the pass's constraints regular in the states they demote (``fresh`` before
    it), as the dummy derivative method asks; None when every state it ties is already demoted."""
    g = constraints[-1]
    candidates = [k for k, s in enumerate(states) if k not in demoted and ca.depends_on(g, s.sym)]
    candidates.sort(key=lambda k: (_DEMOTE_ORDER.get(states[k].state_select.lower(), 2), -k))
    rows = ca.vertcat(*constraints)
    for k in candidates:
        jacobian = ca.jacobian(rows, ca.vertcat(*[states[j].sym for j in fresh + [k]]))
        if generic_rank(jacobian, discrete) == len(fresh) + 1:
            return k
    return candidates[0] if candidates else None


def _reduce_index(system, equations, states, ders, algebraics, input_names):
    """Causalise ``equations`` for the state derivatives and algebraics; for each constraint between states, demote
    one of its states to an algebraic and add the constraint's time derivative (index reduction by dummy
    derivatives: the demoted state's derivative is an algebraic unknown). The constraint's equation is designated
    to determine the demoted state (when it holds it): solved for it from the derivative instead (the pendulum's
    ``x*vx + y*vy = 0`` for ``y``), the constraint would be left over in the states. A constraint that appears only
    once the derivative is added (the pendulum's velocity one) is reduced in the next pass. Returns the blocks, the
    demoted states' indices and a note for each."""
    demoted, extra, reduction_notes, designated = [], [], [], {}
    discrete = set() if system.events is None else {s.name() for s in hybrid.memory_symbols(system.events)}
    all_states = ca.vertcat(*[s.sym for s in states]) if states else ca.SX(0, 1)
    for _ in range(len(states) + 1):
        unknowns = ders + [z.sym for z in algebraics] + [states[k].sym for k in demoted]
        active_names = {s.name for k, s in enumerate(states) if k not in demoted}
        blocks = causalise(equations + extra, unknowns, active_names, discrete, designated)
        if not blocks.constraints:
            break
        accepted, fresh = [], []
        for g, loc, i in blocks.constraints:
            _check_differentiable(g, loc, input_names, blocks, states)
            jacobian = ca.jacobian(ca.vertcat(*accepted, g), all_states)
            if accepted and generic_rank(jacobian, discrete) == len(accepted):
                continue  # implied by the pass's others (three node voltages, two constraints): the next pass sees
            k = _pick_state_to_demote(accepted + [g], states, demoted, fresh, discrete)
            if k is None:  # on states this pass already demoted (a repeated constraint): the next pass sees it
                continue
            accepted.append(g)
            fresh.append(k)
            demoted.append(k)
            dg = ca.mtimes(ca.jacobian(g, all_states), ca.vertcat(*ders)) + ca.jacobian(g, system.time)
            if ca.depends_on((equations + extra)[i][0], states[k].sym) and i not in designated:
                designated[i] = states[k].name
            extra.append((dg, loc))
            reduction_notes.append(f"{loc}: constraint 0 = {g} ties states together; {states[k].name} is computed "
                                   f"from it (index reduction)")
        if not fresh:
            g, loc, _ = blocks.constraints[0]
            raise StructureError(f"the constraint 0 = {g} between states has no state left to compute from it: the "
                                 "equations over-determine the states", *file_line(loc))
    return blocks, demoted, reduction_notes


def _check_differentiable(g, loc, input_names, blocks, states):
    """A constraint is differentiated through the states only: one that involves an input (whose derivative is
    not known) or an unknown of a nonlinear algebraic loop (not a demoted state) is refused."""
    if depends(g, input_names):
        raise StructureError(
            f"a constraint between states involves an input ({g}); it would need the input's derivative",
            *file_line(loc))
    loop = symbol_names(ca.vertcat(*[vs for vs, _, _ in blocks.nonlinear])) if blocks.nonlinear else set()
    inside = sorted((symbol_names(g) & loop) - {s.name for s in states})
    if inside:
        raise StructureError(f"the constraint 0 = {g} between states goes through the nonlinear algebraic loop in "
                             f"{', '.join(inside[:6])}: index reduction would need the loop's derivative, which is "
                             "not implemented", *file_line(loc))


def _without_vanished(system, equations, states, algebraics, notes):
    """The states and algebraic variables, a state whose derivative vanishes moved to the latter (with a note)."""
    written = ca.vertcat(*[e.residual for e in system.equations]) if system.equations else ca.SX(0, 1)
    vanished = _states_without_derivative(equations, [s for s in states if ca.depends_on(
        written, system.derivatives[s.name])], system.derivatives, algebraics)
    notes += [f"{s.location}: der({s.name}) is in no equation once the parameters are evaluated (a coefficient "
              f"0); {s.name} is an algebraic variable" for s in vanished]
    names = {v.name for v in vanished}
    return [s for s in states if s.name not in names], algebraics + vanished


def _states_without_derivative(equations, states, derivatives, algebraics):
    """Of the ``states`` whose derivative the model writes, those whose derivative is in no equation once the
    algebraic variables the equations fix to numbers are substituted: ``C*der(v) = i`` with a capacitance evaluated
    to 0 (the MSL's ``Evaluate = true``) is ``i = 0``, and ``v`` an algebraic variable, as in a tool that evaluates
    the parameter before sorting (a variable made a state for ``der()`` of an expression is left alone)."""
    exprs = [e for e, _ in equations]
    syms = {z.sym.name(): z.sym for z in algebraics}
    for _ in range(len(algebraics) + 1):
        fixed = {}
        for e in exprs:
            free = ca.symvar(e)
            if len(free) == 1 and free[0].name() in syms and free[0].name() not in fixed:
                a = ca.jacobian(e, free[0])
                if a.is_constant() and float(ca.evalf(a)) != 0.0:
                    fixed[free[0].name()] = -ca.substitute(e, free[0], 0) / a
        if not fixed:
            break
        names = list(fixed)
        exprs = list(ca.substitute(exprs, [ca.vertcat(*[syms.pop(n) for n in names])],
                                   [ca.vertcat(*[fixed[n] for n in names])]))
    used = ca.vertcat(*exprs) if exprs else ca.SX(0, 1)
    return [s for s in states if not ca.depends_on(used, derivatives[s.name])]


def lower_system(system):
    """Lower a :class:`~cosim.compile.translate.DaeSystem` to a :class:`LoweredModel`.

    Raises
    ------
    StructureError
        The equations cannot be made explicit: over- or under-determined, structurally singular, or a
        constraint between states that involves an input (it would need the input's derivative).
    """
    written = _actual_model(system)
    params = _Parameters(system)
    notes = list(params.notes)
    states = system.by_role("state")
    algebraics = [v for v in system.variables if v.role in ("algebraic", "output")]
    inputs = system.by_role("input")
    equations = [(params.substitute(e.residual), e.location) for e in system.equations]
    M, equations = _hybrid_memory(system, equations)
    input_names = {u.name for u in inputs}
    states, algebraics = _without_vanished(system, equations, states, algebraics, notes)
    ders = [system.derivatives[s.name] for s in states]
    blocks, demoted, reduction_notes = _reduce_index(system, equations, states, ders, algebraics, input_names)
    simplified = _homotopy_residuals(system, params, written, blocks, (states, ders, algebraics, input_names))
    notes += reduction_notes
    active = [s for k, s in enumerate(states) if k not in demoted]
    solved = blocks.solved

    active_names = {s.name for s in active}

    def value_of(var):
        return var.sym if var.name in active_names else solved[var.sym.name()]

    outputs = [v for v in system.variables if v.causality == "output" and v.role not in hybrid.DISCRETE_ROLES]
    observed = [v for v in algebraics + [states[k] for k in demoted] if v.causality != "output"]
    X = ca.vertcat(*[s.sym for s in active]) if active else ca.SX(0, 1)
    U = ca.vertcat(*[u.sym for u in inputs]) if inputs else ca.SX(0, 1)
    P = ca.vertcat(*[p.sym for p in params.free]) if params.free else ca.SX(0, 1)
    T = system.time
    xdot = ca.vertcat(*[solved[system.derivatives[s.name].name()] for s in active]) if active else ca.SX(0, 1)
    y = ca.vertcat(*[value_of(v) for v in outputs]) if outputs else ca.SX(0, 1)
    obs = ca.vertcat(*[value_of(v) for v in observed]) if observed else ca.SX(0, 1)
    known = {s.name for s in active} | input_names | {p.name for p in params.free} | {T.name()}
    known |= set() if M is None else {m.name() for m in ca.vertsplit(M)}
    block_names = {u.name() for vs, _, _ in blocks.nonlinear for u in ca.vertsplit(vs)}
    for expr, what in ((xdot, "state derivatives"), (y, "outputs")):
        stray = symbol_names(expr) - known - block_names
        if stray:
            raise StructureError(f"{system.name}: {what} still depend on {', '.join(sorted(stray))} after lowering")
    x0, x0_notes = initial_state(system, params, active, P, blocks)
    notes += x0_notes
    p_defaults = [params.defaults[p.name] for p in params.free]
    x0_values = np.array(x0(p_defaults), dtype=float).ravel() if active else np.zeros(0)
    undefined = [s.name for s, v in zip(active, x0_values) if not np.isfinite(v)]
    if undefined:
        raise StructureError(f"{system.name}: the initial value of {', '.join(undefined[:6])} is not a number at the "
                             "default parameters (the initial equations or start values divide by zero there)",
                             *file_line(active[[s.name for s in active].index(undefined[0])].location))
    start_point = [x0_values, np.array([_start(u) for u in inputs]), np.array(p_defaults), np.zeros(1)]
    start_point += [] if M is None else [np.zeros(M.shape[0])]
    start_of = {v.name: _start_at_defaults(v, params, P, p_defaults) for v in system.variables}
    loop_names = tuple(f"nonlinear algebraic loop in {', '.join(u.name() for u in ca.vertsplit(vs))} (equations "
                       f"at {', '.join(sorted(set(locs)))})" for vs, _, locs in blocks.nonlinear)
    ode, out, observe, loops, carried, guess_notes = _functions(X, U, P, T, xdot, y, obs, blocks.nonlinear, start_of, M,
                                                                start_point, (loop_names, simplified))
    notes += guess_notes
    notes += [f"{name} solved by Newton's method ({NEWTON_ITERATIONS} iterations; in the FMU from the loop's last "
              "solution, from its start values at first)" for name in loop_names]
    if system.events is not None:
        notes += [f"sample(start = {start:g} s, interval = {interval:g} s) is fixed at build time (rumoca evaluates "
                  "its arguments): a parameter in them does not follow its run-time value"
                  for _, _, start, interval in system.events.clocks]
    return LoweredModel(
        name=system.name,
        states=tuple(ModelVariable(s.name, s.unit, s.description, float(v), nominal=s.nominal)
                     for s, v in zip(active, x0_values)),
        inputs=tuple(ModelVariable(u.name, u.unit, u.description, _start(u), u.kind) for u in inputs),
        outputs=tuple(ModelVariable(v.name, v.unit, v.description, _start(v)) for v in outputs),
        parameters=tuple(ModelVariable(p.name, p.unit, p.description, params.defaults[p.name], min=p.bounds[0],
                                       max=p.bounds[1]) for p in params.free),
        ode=ode, out=out, observe=observe,
        observed=tuple(ModelVariable(v.name, v.unit, v.description, _start(v)) for v in observed),
        x0=x0, constants=dict(params.constants), notes=tuple(notes), **_parameter_variables(params, P),
        loops=loops, loop_names=loop_names, carried=carried,
        events=None if M is None else _event_part(system, params, active, outputs, observed, (X, U, P, T, M),
                                                  (ode, out, observe), (p_defaults, x0_values)),
    )


def _actual_model(system):
    """Substitute HOMOTOPY = 1 (the actual model of each homotopy(), as at run time) into ``system``; return its
    continuous equations as they were when they hold homotopy() (else None): the loops' starting points are
    continued from the simplified model's solution (:func:`cosim.compile.guess.continued_guess`)."""
    if not any(ca.depends_on(e.residual, HOMOTOPY) for e in system.equations):
        written = None
    else:
        written = system.equations
        system.equations = [Equation(ca.substitute(e.residual, HOMOTOPY, ca.SX(1)), e.location) for e in written]
    system.initial_equations = [Equation(ca.substitute(e.residual, HOMOTOPY, ca.SX(1)), e.location)
                                if ca.depends_on(e.residual, HOMOTOPY) else e for e in system.initial_equations]
    for v in system.variables:
        v.start, v.binding = (None if e is None else ca.substitute(e, HOMOTOPY, ca.SX(1)) for e in (v.start, v.binding))
    return written


def _homotopy_residuals(system, params, written, blocks, unknowns):
    """Per nonlinear block of ``blocks``, its residual with homotopy() as written (a function of HOMOTOPY), or None
    where it has none: the blocks of the equations as written, matched by their unknowns."""
    if written is None:
        return [None] * len(blocks.nonlinear)
    _, equations = _hybrid_memory(system, [(params.substitute(e.residual), e.location) for e in written])
    try:
        as_written, _, _ = _reduce_index(system, equations, *unknowns)
    except StructureError:  # the blend sorts differently: the loops start from their start values
        return [None] * len(blocks.nonlinear)
    by_unknowns = {tuple(u.name() for u in ca.vertsplit(vs)): (vs, residual)
                   for vs, residual, _ in as_written.nonlinear}
    found = [by_unknowns.get(tuple(u.name() for u in ca.vertsplit(vs))) for vs, _, _ in blocks.nonlinear]
    return [None if f is None or not ca.depends_on(f[1], HOMOTOPY) else ca.substitute(f[1], f[0], vs)
            for f, (vs, _, _) in zip(found, blocks.nonlinear)]


def _parameter_variables(params, P):
    """The LoweredModel fields of the parameters that are not tunable: ``dependent`` (with their values at the
    defaults) and ``calculate(p)``, their values from the tunable ones; ``constant_variables`` (kind, value)."""
    dependent = params.dependent()
    q = ca.vertcat(*[e for _, e in dependent]) if dependent else ca.SX(0, 1)
    calculate = ca.Function("calculate", [P], [q], ["p"], ["q"])
    values = np.array(calculate([params.defaults[p.name] for p in params.free]), dtype=float).ravel()
    return {
        "dependent": tuple(ModelVariable(v.name, v.unit, v.description, float(value))
                           for (v, _), value in zip(dependent, values)),
        "calculate": calculate,
        "constant_variables": tuple(ModelVariable(name, params.declared[name].unit,
                                                  params.declared[name].description, float(value),
                                                  params.declared[name].kind)
                                    for name, value in params.constants.items()),
    }


def _check_pre_names(events, variables, equations):
    """Refuse a pre() of a name the lowered model holds no variable of (the MSL's Polyphase.Ideal switches'
    ``control``), named, with the first equation that reads it where one does."""
    missing = sorted(n for n in events.pre if n not in variables)
    if not missing:
        return
    pre_missing = ca.vertcat(*[events.pre[n] for n in missing])
    reading = next((loc for e, loc in equations if ca.depends_on(e, pre_missing)), None)
    where = (None, None) if reading is None else file_line(reading)
    names = "a name" if len(missing) == 1 else "names"
    raise UnsupportedConstructError(f"pre() of {', '.join(missing)}, {names} the flattened model holds no variable "
                                    "of: the lowering cannot give its value between events", *where)


def _hybrid_memory(system, equations):
    """The event memory's symbols (None for a continuous model) and the continuous equations as they hold
    between events."""
    if system.events is None:
        return None, equations
    memory = hybrid.memory_symbols(system.events)
    for e, loc in equations:
        if ca.depends_on(e, system.events.terminal):
            raise UnsupportedConstructError("terminal() in an equation that holds in continuous time (it is "
                                            "supported as the condition of a when-clause)", *file_line(loc))
    variables = {v.name: v.sym for v in system.variables}
    _check_pre_names(system.events, variables, equations)
    pre_from, pre_to = hybrid.between_events(system.events, variables)
    equations = [(ca.substitute(e, ca.vertcat(*pre_from), ca.vertcat(*pre_to)), loc) for e, loc in equations]
    return (ca.vertcat(*memory) if memory else ca.SX(0, 1)), equations


def _event_part(system, params, active, outputs, observed, symbols, functions, defaults):
    """The EventPart. Event expressions may read continuous unknowns (derivatives, algebraic variables): those
    they read are evaluated by ode/out/observe at (x, u, p, t, m), the others not at all."""
    X, U, P, T, M = symbols
    ode, out, observe = functions
    used = hybrid.referenced_names(system.events)
    active_names = [s.name for s in active]
    ders = [system.derivatives[s.name] for s in active]
    groups = [(ode, [k for k, d in enumerate(ders) if d.name() in used], ders),
              (out, [k for k, v in enumerate(outputs) if v.name not in active_names and v.name in used],
               [v.sym for v in outputs]),
              (observe, [k for k, v in enumerate(observed) if v.name in used], [v.sym for v in observed])]
    W = [syms[k] for _, rows, syms in groups for k in rows]

    def w_value(x, u, p, t, m):
        return ca.vertcat(*[f(x, u, p, t, m)[rows] for f, rows, _ in groups if rows])

    location = file_line(system.variables[0].location)[0] if system.variables else system.name
    ctx = hybrid.HybridContext(X, U, P, T, W, w_value, active_names, params.substitute, *defaults, location)
    return hybrid.event_part(system.events, ctx, M)


def _start(var):
    if var is None or var.start is None or not var.start.is_constant():
        return 0.0
    return float(ca.evalf(var.start))


def _functions(X, U, P, T, xdot, y, obs, nonlinear, start_of, M, start_point, names_simplified):
    """CasADi functions of (x, u, p, t), and the event memory m for a hybrid model; nonlinear blocks are
    solved by a generated Newton iteration from a starting point g: in the :class:`Carried` functions an argument
    (the FMU's last solution), in the others the start values (``start_of``: name -> value at the default
    parameters; a der() in a block has none and starts at 0) or, where it does not converge from them at
    ``start_point`` (numeric x, u, p, t[, m]), the block's solution there (:mod:`cosim.compile.guess`), which is
    also the Carried functions' first g. Where the iterations did not converge, RETRY_ITERATIONS more run from where
    they ended, damped (a step that does not lower the residual is halved: full steps can cycle on a
    piecewise-linear limiter), then the chord method from g (:func:`~cosim.compile.newton.loop_solvers`), then
    Newton's again from the start values; a block that still did not gives NaN, and ``loops`` says which (1
    converged, 0 not, in ``loop_names`` order; None without blocks), so that the FMU reports an error, not a number.
    ``names_simplified``: the loops' names, and their residuals with homotopy() (or None), from whose simplified
    model's solution their starting points are continued (:func:`cosim.compile.guess.continued_guess`).
    Returns the three functions, ``loops``, the :class:`Carried` functions (None without blocks) and notes."""
    loop_names, simplified = names_simplified
    names = ["x", "u", "p", "t"] + ([] if M is None else ["m"])
    args = [X, U, P, T] + ([] if M is None else [M])
    if not nonlinear:
        return (ca.Function("ode", args, [xdot], names, ["xdot"]),
                ca.Function("out", args, [y], names, ["y"]),
                ca.Function("observe", args, [obs], names, ["v"]), None, None, [])
    block_syms = [vs for vs, _, _ in nonlinear]
    explicit = ca.Function("explicit", [*args, *block_syms], [xdot, y, obs])
    margs = [ca.MX.sym(n, s.shape[0]) for n, s in zip(names, args)]
    G = ca.MX.sym("g", sum(vs.shape[0] for vs in block_syms))
    solved, flags, guesses, notes = [], [], [], []
    context_value = np.concatenate([np.ravel(v) for v in start_point])
    for k, (vs, residual, _) in enumerate(nonlinear):
        context = ca.vertcat(*args, *block_syms[:k])
        solvers = loop_solvers(k, vs, residual, context)
        guess = np.array([start_of.get(u.name(), 0.0) for u in ca.vertsplit(vs)], dtype=float)
        guess = continued_guess(k, vs, simplified[k], context, context_value, guess)
        guess, note, at_start = better_guess(solvers[0], vs, residual, context, context_value, guess,
                                             loop_names[k])
        notes += [note] if note else []
        context_value = np.concatenate([context_value, at_start])
        ctx_value = ca.vertcat(*margs, *solved)
        offset = sum(len(g) for g in guesses)
        guesses.append(guess)
        outcome = _block_solver(k, solvers, converged(k, vs, residual, context), guess)(
            G[offset:offset + vs.shape[0]], ctx_value)
        flags.append(outcome[-1])
        solved.append(ca.if_else(flags[-1], outcome[:-1], ca.DM.nan(vs.shape[0], 1)))
    xd, yy, oo = explicit(*margs, *solved)
    solution = ca.vertcat(*solved)
    carried = Carried(ca.Function("ode", margs + [G], [xd, solution], names + ["g"], ["xdot", "g_new"]),
                      ca.Function("out", margs + [G], [yy, solution], names + ["g"], ["y", "g_new"]),
                      ca.Function("observe", margs + [G], [oo, solution], names + ["g"], ["v", "g_new"]),
                      ca.Function("loops", margs + [G], [ca.vertcat(*flags)], names + ["g"], ["converged"]),
                      np.concatenate(guesses))
    start = ca.DM(carried.guess)
    fixed = [ca.Function(f.name(), margs, [f(*margs, start)[0]], names, [f.name_out(0)])
             for f in (carried.ode, carried.out, carried.observe, carried.loops)]
    return (*fixed, carried, notes)


def _block_solver(k, solvers, test, guess):
    """A function of (g, context) -> (solution, 1 where it converged else 0) of block ``k``: NEWTON_ITERATIONS of
    Newton's method from g; where they did not converge, RETRY_ITERATIONS damped ones more from where they ended
    (their end polished by Newton's), then the chord method from g (``solvers``:
    :func:`~cosim.compile.newton.loop_solvers`; ``test``: their convergence), then both Newton attempts from the
    start values ``guess`` (as the code did before it carried the last solution). Each fallback is a branch of a
    CasADi conditional, evaluated only where the one before did not converge, and each attempt once."""
    solver, retry, chord = solvers
    n, n_context = test.size1_in(0), test.size1_in(1)
    v, w, g, c = ca.MX.sym("v", n), ca.MX.sym("w", n + 1), ca.MX.sym("g", n), ca.MX.sym("c", n_context)

    def otherwise(name, value, fallback, args):
        """A conditional of (flag, *args): value (the last row its flag) where flag is 1, else fallback."""
        return ca.Function.conditional(name, [ca.Function(f"{name}_else", args, [fallback])],
                                       ca.Function(f"{name}_then", args, [value]))

    retried = retry(v, ca.repmat(c, 1, RETRY_ITERATIONS))
    # the damped retry's end polished by Newton's steps where those converge: it can stop within the convergence
    # test's tolerance but not at the root (a step that does not lower the residual's norm is cut, down to a
    # 256th), and where the loops start from their last solution a stiff model's integrator sees the difference
    # as noise (the MSL's AmplifierWithOpAmpDetailed: off by 4 % of the range past the output's saturation)
    polished = solver(retried, ca.repmat(c, 1, NEWTON_ITERATIONS))
    retried = ca.if_else(test(polished, c), polished, retried)
    retrying = otherwise(f"retry{k}", ca.vertcat(v, 1), ca.vertcat(retried, test(retried, c)), [v, c])

    def newton_from(start):
        first = solver(start, ca.repmat(c, 1, NEWTON_ITERATIONS))
        return retrying(test(first, c), first, c)

    held = chord(g, c)
    from_start = otherwise(f"held{k}", ca.vertcat(v, 1), newton_from(ca.DM(guess)), [v, g, c])(
        test(held, c), held, g, c)
    from_last = newton_from(g)
    outcome = otherwise(f"fallback{k}", w, from_start, [w, g, c])(from_last[-1], from_last, g, c)
    return ca.Function(f"solve{k}", [g, c], [outcome])


def _start_at_defaults(var, params, P, p_defaults):
    """A variable's start value, a start bound to parameters (``T_heatPort(start = T)``) evaluated at their
    defaults; 0 when it has none or it depends on anything else."""
    if var.start is None:
        return 0.0
    value = params.substitute(var.start)
    if P.shape[0]:
        value = ca.substitute(value, P, ca.DM(p_defaults))
    return float(ca.evalf(value)) if value.is_constant() or not ca.symvar(value) else 0.0
