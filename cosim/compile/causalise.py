"""Causalisation of a square system of equations: one-unknown equations solved first, then the strongly
connected blocks of a matching, in order, each solved symbolically when linear or left to Newton's method when
not. Used by the lowering (the model's equations) and by the initial problem (cosim.compile.initial)."""

import graphlib

import casadi as ca
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, maximum_bipartite_matching

from cosim.errors import StructureError

# Draws of the discrete values before a linear block that reads them is judged singular.
_DISCRETE_DRAWS = 64

__all__ = ["Blocks", "causalise", "depends", "file_line", "generic_rank", "symbol_names"]


def symbol_names(expr):
    """The names of the symbols ``expr`` depends on."""
    return {s.name() for s in ca.symvar(expr)}


def depends(expr, names):
    return not symbol_names(expr).isdisjoint(names)


def _is_zero(expr):
    expr = ca.simplify(expr)
    return expr.is_zero() or (expr.is_constant() and float(ca.evalf(expr)) == 0.0)


def file_line(location):
    file, _, line = location.rpartition(":")
    return (file, int(line)) if file and line.isdigit() else (location, None)


class Blocks:
    """Result of causalising a square system: solved expressions, nonlinear blocks, leftover constraints."""

    def __init__(self):
        self.solved = {}        # unknown name -> expression in knowns and nonlinear-block symbols
        self.nonlinear = []     # (unknown symbols, residual expressions, locations)
        self.constraints = []   # (expression in knowns, location, index of the equation)


def causalise(equations, unknowns, state_names, discrete=frozenset(), designated=None):
    """Solve ``0 = equations`` for ``unknowns`` (SX symbols) in terms of everything else; ``discrete``: the names
    of the values held between events (Booleans, modes); ``designated``: equation index -> the name of the one
    unknown it must determine, which no other equation may (index reduction's pairs: a constraint and the state it
    computes, its derivative and the state's derivative). An equation left with no unknown of its own that holds
    states is a constraint between them: it is returned, the rest unsolved."""
    result = Blocks()
    designated = designated or {}
    reserved = set(designated.values())
    index = {u.name(): u for u in unknowns}
    exprs = [e for e, _ in equations]
    locs = [loc for _, loc in equations]
    pending = list(range(len(exprs)))

    def refresh(i):
        names = symbol_names(exprs[i])
        done = [n for n in names if n in result.solved]
        if done:
            exprs[i] = ca.substitute(exprs[i], ca.vertcat(*[index[n] for n in done]),
                                     ca.vertcat(*[result.solved[n] for n in done]))
            names = symbol_names(exprs[i])
        return [n for n in names if n in index and n not in result.solved]

    progress = True
    while progress:
        progress = False
        remaining = []
        for i in pending:
            open_unknowns = refresh(i)
            if not open_unknowns:
                _leftover(result, exprs[i], locs[i], i, state_names)
                continue
            if len(open_unknowns) == 1 and designated.get(i, open_unknowns[0]) == open_unknowns[0] and (
                    open_unknowns[0] not in reserved or designated.get(i) == open_unknowns[0]):
                u = index[open_unknowns[0]]
                a = ca.jacobian(exprs[i], u)
                if not ca.depends_on(a, u) and not _is_zero(a):
                    result.solved[u.name()] = ca.simplify(-ca.substitute(exprs[i], u, 0) / a)
                    progress = True
                    continue
            remaining.append(i)
        pending = remaining
    if result.constraints or not pending:
        return result
    _solve_blocks(result, pending, (exprs, locs), (index, discrete, state_names), (refresh, designated))
    return result


def _leftover(result, expr, loc, i, state_names):
    """An equation all of whose unknowns are solved: an identity, a constraint between states, or an error."""
    if _is_zero(expr):
        return
    if depends(expr, state_names):
        result.constraints.append((expr, loc, i))
        return
    raise StructureError(f"equation has no unknown left to determine (over-determined or inconsistent): 0 = {expr}",
                         *file_line(loc))


def _matching(pending, incidence, designated, reserved):
    """A maximum matching of the equations ``pending`` to their unknowns (a designated equation to its own one,
    no other equation to a reserved one): {position in pending: unknown name}, and the unknowns' names."""
    allowed = {i: ([designated[i]] if designated[i] in incidence[i] else []) if i in designated
               else [n for n in incidence[i] if n not in reserved] for i in pending}
    cols = sorted({n for ns in incidence.values() for n in ns})
    col_of = {n: k for k, n in enumerate(cols)}
    rows = [r for r, i in enumerate(pending) for _ in allowed[i]]
    colidx = [col_of[n] for i in pending for n in allowed[i]]
    graph = csr_matrix((np.ones(len(rows)), (rows, colidx)), shape=(len(pending), len(cols)))
    match = maximum_bipartite_matching(graph, perm_type="column")
    return {r: cols[c] for r, c in enumerate(match) if c >= 0}, cols


def _solve_blocks(result, pending, equations, symbols, how):
    """Match the remaining equations to unknowns, order their strongly connected blocks and solve each. When the
    matching leaves equations over, the blocks that do not wait on an unmatched unknown are solved, and the
    equations over become constraints between states (index reduction follows) or, holding unknowns still,
    a structural singularity. ``symbols``: the unknowns by name, the names of the discrete values and of the
    states; ``how``: the refresh of an equation and the designated pairs."""
    exprs, locs = equations
    index, discrete, state_names = symbols
    refresh, designated = how
    incidence = {i: refresh(i) for i in pending}
    match, cols = _matching(pending, incidence, designated, set(designated.values()))
    row_of = {n: r for r, n in match.items()}
    dep_rows, dep_cols = [], []
    for r, i in enumerate(pending):
        for n in incidence[i]:
            if n in row_of:
                dep_rows.append(r)
                dep_cols.append(row_of[n])
    deps = csr_matrix((np.ones(len(dep_rows)), (dep_rows, dep_cols)), shape=(len(pending),) * 2)
    n_comp, labels = connected_components(deps, directed=True, connection="strong")
    order = graphlib.TopologicalSorter({c: set() for c in range(n_comp)})
    for r, c in zip(dep_rows, dep_cols):
        if labels[r] != labels[c]:
            order.add(int(labels[r]), int(labels[c]))
    blocked = set()  # components that wait on an unknown no equation determines
    for comp in order.static_order():
        members = [r for r in range(len(pending)) if labels[r] == comp]
        waits = any(r not in match or any(n not in row_of or labels[row_of[n]] in blocked
                                          for n in incidence[pending[r]]) for r in members)
        if waits:
            blocked.add(comp)
            continue
        for r in members:
            refresh(pending[r])
        _solve_block(result, [pending[r] for r in members], [match[r] for r in members], (exprs, locs),
                     (index, discrete))
    if len(match) == len(pending) == len(cols):
        return
    unmatched = [pending[r] for r in range(len(pending)) if r not in match]
    for i in unmatched:
        if not refresh(i):
            _leftover(result, exprs[i], locs[i], i, state_names)
    if not result.constraints:
        bad = [locs[i] for i in unmatched] or [locs[i] for i in pending]
        raise StructureError(
            "the equations are structurally singular (some unknown is determined twice and another not at all); "
            f"check the equations at {', '.join(bad[:6])}", *file_line(bad[0]))


def _solve_block(result, members, names, equations, symbols):
    """Solve the equations ``members`` (indices) for the unknowns ``names``: symbolically when linear, else
    left to Newton's method (a nonlinear block)."""
    exprs, locs = equations
    index, discrete = symbols
    unknowns = ca.vertcat(*[index[n] for n in names])
    residual = ca.vertcat(*[exprs[i] for i in members])
    jac = ca.jacobian(residual, unknowns)
    if not ca.depends_on(jac, unknowns):
        _check_generic_rank(jac, [locs[i] for i in members], discrete)
        rhs = -ca.substitute(residual, unknowns, ca.SX.zeros(unknowns.shape))
        solution = rhs / jac if unknowns.numel() == 1 else ca.solve(jac, rhs)
        for k in range(unknowns.numel()):
            result.solved[unknowns[k].name()] = ca.simplify(solution[k])
    else:
        result.nonlinear.append((unknowns, residual, [locs[i] for i in members]))
        for k in range(unknowns.numel()):
            result.solved[unknowns[k].name()] = unknowns[k]


def generic_rank(matrix, discrete=frozenset()):
    """The rank of a matrix of expressions at random points of its symbols, which is its rank almost everywhere.
    Not so for the discrete values among them: at 0.5..1.5 every Boolean is true, a combination the model may
    never reach (LossyGear: ideal and locked); they are drawn too, each an integer of -1..3 (Booleans, the friction
    elements' modes), and the largest rank seen counts. A draw where the matrix is not finite tells nothing; with
    none finite the rank is taken as full."""
    symbols = ca.symvar(matrix)
    rng = np.random.default_rng(12345)
    held = np.array([s.name() in discrete for s in symbols], dtype=bool)
    at = ca.Function("generic_matrix", [ca.vertcat(*symbols)], [matrix]) if symbols else (lambda _: ca.evalf(matrix))
    best, finite = 0, False
    for draw in range(1 + (_DISCRETE_DRAWS if held.any() else 0)):
        values = rng.uniform(0.5, 1.5, len(symbols))
        if draw:
            values[held] = rng.integers(-1, 4, int(held.sum()))
        numbers = np.array(ca.DM(at(values)), dtype=float)
        if np.isfinite(numbers).all():
            finite = True
            best = max(best, int(np.linalg.matrix_rank(numbers)))
            if best == matrix.shape[0]:
                break
    return best if finite else matrix.shape[0]


def _check_generic_rank(jac, locations, discrete=frozenset()):
    """A linear block singular at a random point of its symbols is singular everywhere (with probability 1)."""
    if generic_rank(jac, discrete) < jac.shape[0]:
        raise StructureError(f"the linear equations at {', '.join(sorted(set(locations)))} are singular: they do "
                             "not determine their unknowns (a redundant or missing equation)", *file_line(locations[0]))
