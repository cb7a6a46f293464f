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

__all__ = ["Blocks", "causalise", "depends", "file_line", "symbol_names"]


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
        self.constraints = []   # (expression in knowns, location)


def causalise(equations, unknowns, state_names, discrete=frozenset()):
    """Solve ``0 = equations`` for ``unknowns`` (SX symbols) in terms of everything else; ``discrete``: the names
    of the values held between events (Booleans, modes)."""
    result = Blocks()
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
                if _is_zero(exprs[i]):
                    continue
                if depends(exprs[i], state_names):
                    result.constraints.append((exprs[i], locs[i]))
                    continue
                raise StructureError(
                    f"equation has no unknown left to determine (over-determined or inconsistent): "
                    f"0 = {exprs[i]}", *file_line(locs[i]))
            if len(open_unknowns) == 1:
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
    _solve_blocks(result, pending, exprs, locs, (index, discrete), refresh)
    return result


def _solve_blocks(result, pending, exprs, locs, symbols, refresh):
    """Match the remaining equations to unknowns, order their strongly connected blocks and solve each.
    ``symbols``: the unknowns by name, and the names of the discrete values."""
    index, discrete = symbols
    incidence = {i: refresh(i) for i in pending}
    cols = sorted({n for ns in incidence.values() for n in ns})
    if len(cols) != len(pending):
        where = "; ".join(locs[i] for i in pending[:6])
        raise StructureError(
            f"{len(pending)} coupled equations for {len(cols)} unknowns ({', '.join(cols[:8])}) at {where}")
    col_of = {n: k for k, n in enumerate(cols)}
    rows, colidx = [], []
    for r, i in enumerate(pending):
        for n in incidence[i]:
            rows.append(r)
            colidx.append(col_of[n])
    graph = csr_matrix((np.ones(len(rows)), (rows, colidx)), shape=(len(pending), len(cols)))
    match = maximum_bipartite_matching(graph, perm_type="column")
    if (match < 0).any():
        bad = [locs[pending[r]] for r in np.flatnonzero(match < 0)]
        raise StructureError(
            "the equations are structurally singular (some unknown is determined twice and another not at all); "
            f"check the equations at {', '.join(bad[:6])}", *file_line(bad[0]))
    row_of_col = {int(c): r for r, c in enumerate(match)}
    dep_rows, dep_cols = [], []
    for r, i in enumerate(pending):
        for n in incidence[i]:
            dep_rows.append(r)
            dep_cols.append(row_of_col[col_of[n]])
    deps = csr_matrix((np.ones(len(dep_rows)), (dep_rows, dep_cols)), shape=(len(pending),) * 2)
    n_comp, labels = connected_components(deps, directed=True, connection="strong")
    order = graphlib.TopologicalSorter({c: set() for c in range(n_comp)})
    for r, c in zip(dep_rows, dep_cols):
        if labels[r] != labels[c]:
            order.add(int(labels[r]), int(labels[c]))
    for comp in order.static_order():
        members = [r for r in range(len(pending)) if labels[r] == comp]
        for r in members:
            refresh(pending[r])
        unknowns = ca.vertcat(*[index[cols[match[r]]] for r in members])
        residual = ca.vertcat(*[exprs[pending[r]] for r in members])
        jac = ca.jacobian(residual, unknowns)
        if not ca.depends_on(jac, unknowns):
            _check_generic_rank(jac, [locs[pending[r]] for r in members], discrete)
            rhs = -ca.substitute(residual, unknowns, ca.SX.zeros(unknowns.shape))
            solution = rhs / jac if unknowns.numel() == 1 else ca.solve(jac, rhs)
            for k in range(unknowns.numel()):
                result.solved[unknowns[k].name()] = ca.simplify(solution[k])
        else:
            result.nonlinear.append((unknowns, residual, [locs[pending[r]] for r in members]))
            for k in range(unknowns.numel()):
                result.solved[unknowns[k].name()] = unknowns[k]


def _check_generic_rank(jac, locations, discrete=frozenset()):
    """A linear block singular at a random point of its symbols is singular everywhere (with probability 1). Not
    so for the discrete values among them: at 0.5..1.5 every Boolean is true, a combination the model may never
    reach (LossyGear: ideal and locked). The block is singular when it is at every draw of them too, each an
    integer of -1..3 (Booleans, the friction elements' modes)."""
    symbols = ca.symvar(jac)
    rng = np.random.default_rng(12345)
    held = np.array([s.name() in discrete for s in symbols], dtype=bool)
    jacobian = ca.Function("block_jacobian", [ca.vertcat(*symbols)], [jac]) if symbols else (lambda _: ca.evalf(jac))
    for draw in range(1 + (_DISCRETE_DRAWS if held.any() else 0)):
        values = rng.uniform(0.5, 1.5, len(symbols))
        if draw:
            values[held] = rng.integers(-1, 4, int(held.sum()))
        if np.linalg.matrix_rank(np.array(ca.DM(jacobian(values)), dtype=float)) == jac.shape[0]:
            return
    raise StructureError(f"the linear equations at {', '.join(sorted(set(locations)))} are singular: they do not "
                         "determine their unknowns (a redundant or missing equation)", *file_line(locations[0]))
