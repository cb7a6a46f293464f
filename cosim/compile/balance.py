"""Which equations or unknowns an unbalanced model has in excess, by name and source line.

rumoca refuses an unbalanced model with counts only. :func:`~cosim.compile.frontend.load_flat_model` then loads it
made square (equations ``0.0 = 0.0`` or unknowns in no equation added at its end); here the padded model's
equations are matched to its unknowns (a maximum bipartite matching), and what no matching can pair, followed
along alternating paths (the over- or under-determined part of the Dulmage-Mendelsohn decomposition), is what
the message names: the equations that determine the same unknowns, or the unknowns no equation determines."""

import casadi as ca
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from cosim.compile.frontend import PAD
from cosim.errors import StructureError

__all__ = ["unbalanced_error"]


def _incidence(system):
    """The unknowns (derivatives of states, algebraic variables and outputs: name -> declaration line) and the
    equations (location, names of the unknowns each holds) of a translated model, padding left out."""
    unknowns = {f"der({name})": next(v.location for v in system.variables if v.name == name)
                for name in system.derivatives}
    unknowns.update({v.name: v.location for v in system.variables
                     if v.role in ("algebraic", "output") and not v.name.startswith(PAD)})
    by_symbol = {s.name(): f"der({name})" for name, s in system.derivatives.items()}
    equations = []
    for eq in system.equations:
        names = {by_symbol.get(s.name(), s.name()) for s in ca.symvar(eq.residual)}
        if ca.SX(eq.residual).is_zero():
            continue  # a padding equation 0.0 = 0.0
        equations.append((eq.location, sorted(n for n in names if n in unknowns)))
    return unknowns, equations


def _reach(start, neighbours, partner):
    """Everything reachable from ``start`` along alternating paths: a neighbour, then its matched partner."""
    seen, todo = set(start), list(start)
    while todo:
        for n in neighbours(todo.pop()):
            m = partner.get(n)
            if m is not None and m not in seen:
                seen.add(m)
                todo.append(m)
    return seen


def unbalanced_error(error, system):
    """``error`` (rumoca's count, a StructureError) told again with the equations or unknowns in excess.

    Parameters
    ----------
    error : StructureError
        The front end's error for the model.
    system : cosim.compile.translate.DaeSystem
        The padded model (``error.padded``) translated.

    Returns
    -------
    StructureError
        ``error`` itself when the matching finds nothing in excess (rumoca counted discrete equations).
    """
    unknowns, equations = _incidence(system)
    names = list(unknowns)
    col = {n: k for k, n in enumerate(names)}
    rows = [r for r, (_, held) in enumerate(equations) for _ in held]
    cols = [col[n] for _, held in equations for n in held]
    graph = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(equations), len(names)))
    match = maximum_bipartite_matching(graph, perm_type="column")  # per equation, its unknown's column or -1
    free_eqs = [r for r, c in enumerate(match) if c < 0]
    free_unknowns = [n for n in names if n not in {names[c] for c in match if c >= 0}]
    parts = [_over(free_eqs, equations, unknowns, names, match)] if free_eqs else []
    parts += [_under(free_unknowns, equations, unknowns, names, match)] if free_unknowns else []
    if not parts:
        return error
    message = (f"model {system.name} is unbalanced ({_count(len(equations), 'equation')} for "
               f"{_count(len(names), 'unknown')}): ")
    return StructureError(message + "; ".join(parts), *_where(error, equations, unknowns, free_eqs, free_unknowns))


def _over(free_eqs, equations, unknowns, names, match):
    """The over-determined part: the equations that compete for the unknowns they hold."""
    eq_of = {names[c]: r for r, c in enumerate(match) if c >= 0}
    part = _reach(free_eqs, lambda r: equations[r][1], eq_of)
    held = sorted({n for r in part for n in equations[r][1]})
    if not held:
        return (f"{_count(len(part), 'equation')} too many: {_lines(equations[r][0] for r in part)} determine(s) "
                "no unknown (only states, parameters, inputs or constants); remove it")
    return (f"{_count(len(part) - len(held), 'equation')} too many: the equations at "
            f"{_lines(equations[r][0] for r in part)} determine {', '.join(f'{n} ({unknowns[n]})' for n in held)}, "
            f"{_count(len(held), 'unknown')}; remove the one in excess, or make one of those unknowns an input")


def _under(free_unknowns, equations, unknowns, names, match):
    """The under-determined part: the unknowns that share too few equations, or are in none."""
    holders = {n: [r for r, (_, held) in enumerate(equations) if n in held] for n in names}
    var_of = {r: names[c] for r, c in enumerate(match) if c >= 0}
    part = _reach(free_unknowns, lambda n: holders[n], var_of)
    none = [n for n in sorted(part) if not holders[n]]
    shared = sorted(part - set(none))
    text = f"{_count(len(free_unknowns), 'equation')} missing"
    if none:
        text += f": {', '.join(f'{n} ({unknowns[n]})' for n in none)} in no equation"
    if shared:
        text += (f"{';' if none else ':'} {', '.join(f'{n} ({unknowns[n]})' for n in shared)} determined only by "
                 f"the equations at {_lines(equations[r][0] for n in shared for r in holders[n])}, too few for them")
    return text + "; add the missing equation, or make one of those unknowns a parameter"


def _count(n, word):
    return f"{n} {word}{'s' if n != 1 else ''}"


def _lines(locations):
    """``file:line`` locations, each once, in file and line order."""
    def key(location):
        file, _, line = location.rpartition(":")
        return (file, int(line) if line.isdigit() else 0)

    return ", ".join(sorted(set(locations), key=key))


def _where(error, equations, unknowns, free_eqs, free_unknowns):
    """(file, line) of the first thing named: an equation in excess, else an unknown left undetermined."""
    location = equations[free_eqs[0]][0] if free_eqs else unknowns[free_unknowns[0]] if free_unknowns else ""
    file, _, line = location.rpartition(":")
    return (file, int(line)) if line.isdigit() else (error.file, None)
