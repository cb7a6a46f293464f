"""The initial state ``x0(p)``: start values, overridden by the initial equations.

An initial equation may mix states, derivatives, algebraic variables and parameters (``der(x) = 0`` for a
steady state). The derivatives and algebraic variables are replaced by what the lowering solved them to (the
ODE's right-hand side, the algebraic chains; a nonlinear algebraic loop joins the initial problem with its own
unknowns), which leaves equations in the states and parameters. They determine the states they mention
(directly or through ``der()``) plus the states declared ``fixed = true`` (``x = start``); when that is fewer
states than equations (an equation on an algebraic variable, on ``der()`` of an expression), each equation left
without a state of its own takes the first state it depends on that is not fixed. The other states keep their
start values (a start without ``fixed = true`` is a guess the initial equations may override).

The equations are sorted into blocks as the model's are (:mod:`cosim.compile.causalise`): a parameter computed by
an initial equation is known before the states it is a coefficient of. Linear blocks are solved symbolically
(``x0`` is an SX function when all are). Nonlinear ones are solved in turn by Newton's method from the start
values, damped (a step that does not lower the residual is halved), written as CasADi expressions
(:mod:`cosim.compile.newton`), so that ``x0`` stays a CasADi function of ``p`` that C code can be generated for;
iterations that do not converge at the default parameters are refused. Inputs take their start values and
``time`` is 0.
"""

import dataclasses

import casadi as ca
import numpy as np

from cosim.compile import integer_events
from cosim.compile.causalise import causalise
from cosim.compile.newton import NEWTON_ITERATIONS, converged, newton
from cosim.compile.translate import Equation
from cosim.errors import StructureError

__all__ = ["initial_state"]


def _names(expr):
    return {s.name() for s in ca.symvar(expr)}


def _where(locations):
    """(message part, file, line) of a list of ``file:line`` locations."""
    first = locations[0] if locations else ""
    file, _, line = first.rpartition(":")
    located = (file, int(line)) if file and line.isdigit() else (first or None, None)
    return ", ".join(sorted(set(locations))), *located


def _starts(active, params):
    notes, starts = [], []
    free = {p.name for p in params.free}
    for s in active:
        start = params.substitute(s.start) if s.start is not None else ca.SX(0.0)
        starts.append(start)
        if _names(start) & free:
            notes.append(f"{s.location}: start of {s.name} depends on parameters; the FMU computes it from the "
                         "parameters set before initialisation (the modelDescription's start is its default value)")
    return starts, notes


def _knowns_at_start(system, blocks, params):
    """Substitution of every derivative, algebraic variable and demoted state by its solved expression, of the
    inputs by their start values and of time by 0 (also inside the solved expressions)."""
    inputs = system.by_role("input")
    at_start = [params.substitute(u.start) if u.start is not None else ca.SX(0.0) for u in inputs] + [ca.SX(0.0)]
    at = ca.vertcat(*[u.sym for u in inputs], system.time)
    names = list(blocks.solved)
    by_name = {v.sym.name(): v.sym for v in system.variables}
    by_name.update({d.name(): d for d in system.derivatives.values()})
    syms = [by_name[n] for n in names] + [u.sym for u in inputs] + [system.time]
    values = list(ca.substitute([blocks.solved[n] for n in names], [at], [ca.vertcat(*at_start)])) + at_start
    held, direct = _held_at_start(system.events)
    direct = [params.substitute(d) for d in direct]  # dependent and structural parameters by their values
    if held:  # relations and integer steps are evaluated from the values at the start, not held
        for _ in range(len(held) + 1):
            direct = list(ca.substitute(direct, [ca.vertcat(*syms)], [ca.vertcat(*values)]))
            values = list(ca.substitute(values, [ca.vertcat(*held)], [ca.vertcat(*direct)]))
            if not any(ca.depends_on(v, ca.vertcat(*held)) for v in values):
                break
        direct = list(ca.substitute(direct, [ca.vertcat(*syms)], [ca.vertcat(*values)]))
        syms, values = syms + held, values + direct  # the nonlinear blocks joined later read them too
    return ca.vertcat(*syms), ca.vertcat(*values)


_DIRECT = {"less": ca.lt, "less_equal": ca.le, "greater": ca.gt, "greater_equal": ca.ge}


def _held_at_start(events):
    """The symbols of the values an event memory holds between events (relations, integer steps), and their
    values computed directly, as initialisation computes them."""
    if events is None:
        return [], []
    held, direct = [], []
    for relation in events.relations:
        if relation is not None and relation.op in _DIRECT:
            held.append(relation.sym)
            direct.append(_DIRECT[relation.op](relation.g, 0))
    for step in events.steps:
        held.append(step.sym)
        direct.append(integer_events.direct(step.mode, step.arg))
    return held, direct


def _problem(system, params, active, blocks):
    """The initial equations as residuals in the states (and nonlinear-block unknowns), with the states they
    determine."""
    syms, values = _knowns_at_start(system, blocks, params)
    der_to_state = {system.derivatives[s.name].name(): s.name for s in active if s.name in system.derivatives}
    state_names = [s.name for s in active]
    residuals, locations, mentioned = [], [], []
    for e in system.initial_equations:
        residual = params.substitute(e.residual)
        for n in _names(residual):
            state = der_to_state.get(n, n)
            if state in state_names and state not in mentioned:
                mentioned.append(state)
        residuals.append(ca.substitute(residual, syms, values))
        locations.append(e.location)
    reached = set().union(*(_names(r) for r in residuals)) if residuals else set()
    for s in active:  # a fixed state reached through an algebraic variable or a demoted state: its start holds
        if s.fixed and s.name in reached and s.name not in mentioned:
            mentioned.append(s.name)
    for s in active:
        if s.fixed and s.name in mentioned:
            residuals.append(s.sym - params.substitute(s.start))
            locations.append(s.location)
    block_syms, guesses = [], []
    joined, grew = set(), True
    while grew:  # a joined block may read the unknowns of an earlier block: join until none is left out
        grew = False
        for k, (vs, residual, locs) in enumerate(blocks.nonlinear):
            if k in joined or not any(ca.depends_on(r, vs) for r in residuals):
                continue
            joined.add(k)
            grew = True
            residuals += list(ca.vertsplit(ca.substitute(residual, syms, values)))
            locations += locs
            for u in ca.vertsplit(vs):
                block_syms.append(u)
                var = next((v for v in system.variables if v.sym.name() == u.name()), None)  # None: a der()
                start = None if var is None else var.start
                guesses.append(params.substitute(start) if start is not None else ca.SX(0.0))
    _join_indirect_states(residuals, mentioned, active, len(block_syms))
    unknown_states = [s for s in active if s.name in mentioned]
    return residuals, locations, unknown_states, block_syms, guesses


def _join_indirect_states(residuals, mentioned, active, n_block):
    """Fewer states mentioned than equations (an equation on an algebraic variable, on der() of an
    expression): the equations the mentioned states cannot be matched to take states they depend on that are
    neither fixed nor mentioned, by augmenting paths (Kuhn's algorithm) from a matching of the mentioned states,
    so that an equation of one mentioned state keeps it and a state another equation reaches only indirectly
    is taken by that equation. Extends ``mentioned``."""
    if len(mentioned) + n_block >= len(residuals):
        return
    n_mentioned = len(mentioned)
    columns = list(mentioned) + [s.name for s in active if s.name not in mentioned and not s.fixed]
    incidence = [[k for k, name in enumerate(columns) if name in _names(r)] for r in residuals]
    owner = {}  # column -> row

    def augment(row, seen, allowed):
        for k in incidence[row]:
            if k < allowed and k not in seen:
                seen.add(k)
                if k not in owner or augment(owner[k], seen, allowed):
                    owner[k] = row
                    return True
        return False

    for row in range(len(residuals)):  # the mentioned states first: each keeps an equation where it can
        augment(row, set(), n_mentioned)
    for row in sorted(set(range(len(residuals))) - set(owner.values())):
        if len(mentioned) + n_block >= len(residuals):
            return
        if augment(row, set(), len(columns)):
            mentioned += [columns[k] for k in sorted(owner) if k >= n_mentioned and columns[k] not in mentioned]


def initial_state(system, params, active, P, blocks):
    """``x0(p)`` as a CasADi function, and notes for the build.

    Parameters
    ----------
    system : DaeSystem
        The translated model (its ``initial_equations``).
    params : parameter resolution of the lowering
        ``free`` (tunable parameters), ``substitute(expr)`` (dependent parameters replaced).
    active : list of Variable
        The states of the lowered model, in order.
    P : casadi.SX
        The tunable parameters, stacked.
    blocks : causalisation result of the lowering
        ``solved`` (name -> expression) and ``nonlinear`` (unknowns, residuals, locations).

    Returns
    -------
    (casadi.Function, list of str)

    Raises
    ------
    StructureError
        The initial equations do not determine as many states as there are equations, they are singular, or
        Newton's iterations do not solve them at the default parameters.
    """
    starts, notes = _starts(active, params)
    n_equations = len(system.initial_equations)
    system = _with_fixed_starts(system, active)
    optional = range(n_equations, len(system.initial_equations))  # the fixed starts of non-states
    if not system.initial_equations or not active:
        X0 = ca.vertcat(*starts) if active else ca.SX(0, 1)
        return _function(system, params, P, X0), notes
    residuals, locations, unknown_states, block_syms, guesses = _problem(system, params, active, blocks)
    unknowns = [s.sym for s in unknown_states] + block_syms
    V = ca.vertcat(*unknowns)
    others = [(s.sym, start) for s, start in zip(active, starts) if s not in unknown_states]
    if others:  # the states the initial equations leave alone sit at their start values
        residuals = ca.vertsplit(ca.substitute(ca.vertcat(*residuals), ca.vertcat(*[o for o, _ in others]),
                                               ca.vertcat(*[v for _, v in others])))
    redundant = _redundant_rows(residuals, V, optional, len(residuals) - len(unknowns))
    dropped = [residuals[k] for k in redundant]
    residuals = [r for k, r in enumerate(residuals) if k not in redundant]
    locations = [loc for k, loc in enumerate(locations) if k not in redundant]
    where, file, line = _where(locations)
    if len(residuals) != len(unknowns):
        names = ", ".join(s.name for s in unknown_states) or "none"
        raise StructureError(
            f"the initial equations at {where} give {len(residuals)} equations for the {len(unknowns)} unknowns "
            f"they determine (states mentioned or fixed: {names}; the other states keep their start values)",
            file, line)
    R = ca.vertcat(*residuals)
    stray = _names(R) - _names(V) - {p.name for p in params.free}
    if stray:
        raise StructureError(f"the initial equations at {where} depend on {', '.join(sorted(stray))}, which "
                             "the lowering could not express in states and parameters", file, line)
    guess = ca.vertcat(*[starts[active.index(s)] for s in unknown_states] + guesses)
    solution, ok, how = _solve(V, R, guess, P, locations)
    p_defaults = [params.defaults[p.name] for p in params.free]
    if ok is not None and not float(ok(p_defaults)):
        raise StructureError(f"the initial equations at {where} are not solved by Newton's method from the start "
                             "values at the default parameters: give the states and loop variables they determine "
                             "start values nearer the solution", file, line)
    if dropped:
        _check_consistent(dropped, V, solution, P, p_defaults, where)
        notes.append(f"fixed start values at {where} repeat what the other initial equations give; "
                     f"{len(dropped)} of them are left out")
    notes.append(f"initial equations at {where} determine {', '.join(s.name for s in unknown_states)} ({how})")
    S = ca.SX.sym("initial_solution", len(unknown_states))
    value = {s.name: S[k] for k, s in enumerate(unknown_states)}
    X0 = ca.vertcat(*[value.get(s.name, start) for s, start in zip(active, starts)])
    if isinstance(solution, ca.SX):
        return _function(system, params, P, ca.substitute(X0, S, solution[:S.shape[0]])), notes
    _function(system, params, P, ca.substitute(X0, S, ca.DM.zeros(S.shape)))  # checks what X0 depends on
    assemble = ca.Function("assemble_x0", [P, S], [X0])
    Pm = ca.MX.sym("p", P.shape[0])
    return ca.Function("x0", [Pm], [assemble(Pm, solution(Pm)[:S.shape[0]])], ["p"], ["x0"]), notes


def _with_fixed_starts(system, active):
    """``system`` with an initial equation ``v = start`` for each variable declared ``fixed = true`` that is not a
    state of the lowered model: a state index reduction demoted (a mass's position fixed, the spring's relative
    position kept as the state) and an algebraic variable (an acceleration ``a(fixed = true, start = 0)``), as
    the language defines ``fixed`` for them."""
    kept = {s.name for s in active}
    fixed = [Equation(v.sym - v.start, v.location) for v in system.by_role("state", "algebraic", "output")
             if v.name not in kept and v.fixed and v.start is not None]
    if not fixed:
        return system
    return dataclasses.replace(system, initial_equations=list(system.initial_equations) + fixed)


def _redundant_rows(residuals, V, optional, excess):
    """Up to ``excess`` of the ``optional`` rows (fixed starts of non-states) that the other equations already
    imply: removing one leaves the rank of the Jacobian in V (at a random point) unchanged. Two capacitors in
    parallel, both ``v(fixed = true)``: one start is enough."""
    if excess <= 0 or not optional:
        return []
    symbols = ca.symvar(ca.vertcat(*residuals))
    values = np.random.default_rng(12345).uniform(0.5, 1.5, len(symbols))
    jac = ca.Function("initial_rank", [ca.vertcat(*symbols)], [ca.jacobian(ca.vertcat(*residuals), V)])
    numeric = np.array(jac(values), dtype=float)
    rank, rows, redundant = np.linalg.matrix_rank(numeric), list(range(len(residuals))), []
    for k in reversed(optional):
        kept = [r for r in rows if r != k]
        if len(redundant) < excess and np.linalg.matrix_rank(numeric[kept]) == rank:
            rows, redundant = kept, redundant + [k]
    return redundant


def _check_consistent(dropped, V, solution, P, p_defaults, where):
    """Left-out fixed starts must hold at the solution (at the default parameters), else they contradict each
    other; checked on a nonlinear problem's Newton solution too."""
    at = solution if isinstance(solution, ca.Function) else ca.Function("initial_values", [P], [solution])
    values = np.array(at(p_defaults), dtype=float).ravel()[:V.shape[0]]
    left = ca.Function("redundant_starts", [V, P], [ca.vertcat(*dropped)])(values, p_defaults)
    left = np.abs(np.array(left, dtype=float)).max(initial=0.0)
    if not left <= 1e-9 * (1 + np.abs(values).max(initial=0.0)):
        raise StructureError(f"the fixed start values at {where} contradict each other (off by {left:g} at the "
                             "default parameters): give the coupled variables starts that agree, or fix one")


def _solve(V, R, guess, P, locations):
    """V solving ``0 = R(V, P)``, sorted into blocks as the model's equations are (:mod:`cosim.compile.causalise`):
    a parameter computed by an initial equation (a filter's pole) is found before the states whose equations it
    is a coefficient of, not iterated together with them from its start (a pole 0: a singular Jacobian). An SX
    expression of P when every block is linear (with None), else a function of P running the unrolled Newton
    iterations of each nonlinear block in turn from the start values, with a function of P that is 1 where every
    block's iterations converged."""
    unknowns = ca.vertsplit(V)
    blocks = causalise(list(zip(ca.vertsplit(R), locations)), unknowns, set())
    values = ca.vertcat(*[blocks.solved[v.name()] for v in unknowns])
    if not blocks.nonlinear:
        return ca.simplify(values), None, "linear, solved symbolically"
    start = dict(zip([v.name() for v in unknowns], ca.vertsplit(guess)))
    Pm = ca.MX.sym("p", P.shape[0])
    context, context_m, ok = P, Pm, []
    for k, (vs, residual, _) in enumerate(blocks.nonlinear):
        guess_k = ca.vertcat(*[start[u.name()] for u in ca.vertsplit(vs)])
        block_guess = ca.Function(f"initial_guess{k}", [P], [guess_k])
        solved = newton(f"_initial{k}", vs, residual, context, damped=True)(
            block_guess(Pm), ca.repmat(context_m, 1, NEWTON_ITERATIONS))
        ok.append(converged(f"_initial{k}", vs, residual, context)(solved, context_m))
        context, context_m = ca.vertcat(context, vs), ca.vertcat(context_m, solved)
    solution = ca.Function("initial_values", [context], [values])(context_m)
    how = (f"{len(blocks.nonlinear)} nonlinear block(s), {NEWTON_ITERATIONS} damped Newton iterations each from the "
           "start values")
    return (ca.Function("initial_newton", [Pm], [solution]),
            ca.Function("initial_converged", [Pm], [ca.mmin(ca.vertcat(*ok))]), how)


def _function(system, params, P, X0):
    others = _names(X0) - {p.name for p in params.free}
    if others:
        raise StructureError(f"{system.name}: start values depend on {', '.join(sorted(others))}, which are not "
                             "parameters")
    return ca.Function("x0", [P], [X0], ["p"], ["x0"])
