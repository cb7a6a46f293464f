"""Modelica arrays as CasADi SX: a vector ``[n]`` is an n x 1 column, a matrix ``[n, m]`` an n x m matrix, a
scalar 1 x 1. rumoca 0.10.2 keeps arrays whole in its DAE IR (index, slice, array constructor, comprehension,
array built-ins); the translator scalarises variables into one symbol per element (``T[3]``, ``A[1,2]``) and
builds array expressions from them with the helpers here. Arrays of more than two dimensions are rejected."""

import itertools

import casadi as ca
import numpy as np

__all__ = ["element_suffixes", "shaped", "elements", "multiply", "array_of", "index", "update", "domain_values",
           "BUILTINS", "NODES"]


def element_suffixes(dims):
    """``['']`` for a scalar, ``['[1]', '[2]', ...]`` or ``['[1,1]', '[1,2]', ...]`` (row-major) otherwise."""
    if not dims:
        return [""]
    return ["[" + ",".join(str(k) for k in idx) + "]" for idx in itertools.product(*(range(1, d + 1) for d in dims))]


def shaped(items, dims):
    """An SX of shape ``dims`` from its elements in row-major order."""
    column = ca.vertcat(*items) if items else ca.SX(0, 1)
    if len(dims) < 2:
        return column
    return ca.reshape(column, dims[1], dims[0]).T


def elements(value):
    """The scalar elements of an SX, row-major (a column vector: top to bottom)."""
    return ca.vertsplit(ca.vec(value.T)) if value.numel() else []


def _is_scalar(value):
    return value.shape == (1, 1)


def multiply(a, b):
    """Modelica ``*``: scalar times array elementwise, vector times vector the scalar product, matrix times
    vector or matrix the matrix product, vector times matrix ``transpose(M) * v``."""
    if _is_scalar(a) or _is_scalar(b):
        return a * b
    if a.shape[1] == 1 and b.shape[1] == 1:
        return ca.dot(a, b)
    if a.shape[1] == 1:
        return ca.mtimes(b.T, a)
    return ca.mtimes(a, b)


def array_of(items):
    """Modelica's array constructor ``{a, b, ...}``: scalars make a vector, vectors make the rows of a matrix."""
    if all(_is_scalar(v) for v in items):
        return ca.vertcat(*items)
    if all(v.shape[1] == 1 for v in items):
        return ca.horzcat(*items).T
    raise ValueError("arrays of more than two dimensions")


def _positions(sub, extent):
    """0-based positions a subscript selects: an int, a list of ints (a slice), or None (``:``)."""
    if sub is None:
        return list(range(extent))
    if isinstance(sub, list):
        return [k - 1 for k in sub]
    return sub - 1


def index(base, subs):
    """``base[subs]``; a selection that keeps one dimension is a vector (a column)."""
    if len(subs) == 1 and base.shape[1] == 1:
        return base[_positions(subs[0], base.shape[0]), 0]
    if len(subs) == 1:
        subs = [subs[0], None]
    rows = _positions(subs[0], base.shape[0])
    cols = _positions(subs[1], base.shape[1])
    picked = base[rows, cols]
    if isinstance(rows, int) and not isinstance(cols, int):
        return picked.T
    return picked


def update(base, value, subs):
    """A copy of ``base`` with ``base[subs] = value`` (an assignment to array elements in a function)."""
    result = ca.SX(base)
    if len(subs) == 1 and base.shape[1] == 1:
        result[_positions(subs[0], base.shape[0]), 0] = value
        return result
    if len(subs) == 1:
        subs = [subs[0], None]
    rows = _positions(subs[0], base.shape[0])
    cols = _positions(subs[1], base.shape[1])
    result[rows, cols] = value.T if isinstance(rows, int) and not isinstance(cols, int) else value
    return result


def _linspace(a, b, n):
    return ca.vertcat(*[a + (b - a) * k / (n - 1) for k in range(n)])


def _reduce(op):
    def reduce(value):
        items = elements(value)
        result = items[0]
        for item in items[1:]:
            result = op(result, item)
        return result
    return reduce


def _size(value, dim=None):
    """``size(A, k)`` counts Modelica dimensions: a column vector has one."""
    shape = [value.shape[0]] if value.shape[1] == 1 else list(value.shape)
    return ca.SX(shape[dim - 1]) if dim is not None else ca.SX(np.array(shape, dtype=float))


def _fill(value, *dims):
    return shaped([value] * int(np.prod(dims)), list(dims))


def _extremum(pairwise, reduce):
    def extremum(*args):
        return reduce(args[0]) if len(args) == 1 else pairwise(*args)
    return extremum


# Array built-ins: name in rumoca's IR -> (function of SX arguments, positions of arguments that must be
# integers known at build time).
BUILTINS = {
    "sum": (_reduce(lambda a, b: a + b), ()),
    "product": (_reduce(lambda a, b: a * b), ()),
    "min": (_extremum(ca.fmin, _reduce(ca.fmin)), ()),
    "max": (_extremum(ca.fmax, _reduce(ca.fmax)), ()),
    "size": (_size, (1,)),
    "fill": (_fill, (1, 2)),
    "zeros": (lambda *dims: _fill(ca.SX(0.0), *dims), (0, 1)),
    "ones": (lambda *dims: _fill(ca.SX(1.0), *dims), (0, 1)),
    "linspace": (_linspace, (2,)),
    "transpose": (lambda a: a.T, ()),
    "identity": (lambda n: ca.SX.eye(n), (0,)),
    "diagonal": (lambda v: ca.diag(v), ()),
    "outer_product": (lambda a, b: ca.mtimes(a, b.T), ()),
    "cross": (lambda a, b: ca.cross(a, b), ()),
    "skew": (lambda v: ca.skew(v), ()),
    "promoted_cat1": (lambda *parts: ca.vertcat(*parts), ()),
    "promoted_cat2": (lambda *parts: ca.horzcat(*parts), ()),
}


def domain_values(tr, domain, bound=None):
    """Every assignment of a loop domain's binders (a ``for`` equation, a ``for`` statement, a comprehension)
    as dicts ``{(domain, ordinal): value}``; binders of enclosing domains already in ``bound`` stay fixed."""
    bound = dict(bound or {})
    return [{**bound, **dict(combo)} for combo in itertools.product(*_axes(tr, domain, bound))]


def _axes(tr, domain, bound):
    """The values of each binder of a domain (outermost first) that ``bound`` does not fix."""
    chain = []
    while domain is not None:
        chain.append(domain)
        domain = tr.storage["domains"][domain]["parent"]
    axes = []
    for d in reversed(chain):
        entry = tr.storage["domains"][d]
        for ordinal, b in enumerate(entry["domain"]["binders"]):
            if (d, ordinal) in bound:
                continue
            if not all(isinstance(b.get(k), int) for k in ("lower", "upper", "step")):
                tr.reject(f"the loop over {b.get('display_name')} whose range is not Integer", entry)
            values = range(b["lower"], b["upper"] + (1 if b["step"] > 0 else -1), b["step"])
            axes.append([((d, ordinal), v) for v in values])
    return axes


def _subscripts(tr, i, ctx):
    """The subscripts of node ``i``: an int, a list of ints (a slice or an index vector) or None (``:``)."""
    subs = []
    for s in tr.subscripts.get(i, []):
        kind = s["kind"]
        if kind == "whole":
            subs.append(None)
        elif "index" in kind:
            value = tr.expr(kind["index"], ctx)
            ints = [tr.integer(e, kind["index"]) for e in elements(value)]
            subs.append(ints[0] if value.numel() == 1 else ints)
        elif "slice" in kind:
            subs.append(_range_values(tr, tr.nodes[kind["slice"]]["range"], ctx, kind["slice"]))
        else:
            tr.reject(f"the subscript {kind}", s)
    return subs


def _range_values(tr, body, ctx, node_id):
    start = tr.integer(tr.expr(body["start_expression"], ctx), node_id)
    stop = tr.integer(tr.expr(body["stop_expression"], ctx), node_id)
    step_node = body.get("explicit_step_expression")
    step = 1 if step_node is None else tr.integer(tr.expr(step_node, ctx), node_id)
    return list(range(start, stop + (1 if step > 0 else -1), step))


def _index_node(tr, i, body, ctx):
    base, subs = tr.expr(body["base"], ctx), _subscripts(tr, i, ctx)
    try:
        return index(base, subs)
    except RuntimeError as err:  # CasADi's bounds check
        tr.reject(f"a subscript {subs} outside the array's {base.shape[0]}x{base.shape[1]} elements ({err})",
                  tr.provenance[i])


def _update_node(tr, i, body, ctx):
    base, subs = tr.expr(body["base"], ctx), _subscripts(tr, i, ctx)
    try:
        return update(base, tr.expr(body["value"], ctx), subs)
    except RuntimeError as err:  # CasADi's bounds check: an array whose size the inlining did not know
        tr.reject(f"an assignment to element {subs} of an array the compiler sized {base.shape[0]}x{base.shape[1]} "
                  f"({str(err).splitlines()[-1]})", tr.provenance[i])


def _array_node(tr, i, body, ctx):
    try:
        return array_of([tr.expr(j, ctx) for j in tr.operands.get(i, [])])
    except ValueError:
        tr.reject("an array of more than two dimensions", tr.provenance[i])


def _comprehension_node(tr, i, body, ctx):
    """``{f(i) for i in 1:n}`` (rumoca also writes a loop that only accumulates as ``sum`` of one)."""
    bound = (ctx or {}).get("binders", {})
    values = [tr.expr(body["body"], tr.context(ctx, binders=b)) for b in domain_values(tr, body["domain"], bound)]
    sizes = [len(axis) for axis in _axes(tr, body["domain"], bound)]
    if len(sizes) == 2 and all(v.numel() == 1 for v in values):  # {f(i, j) for i in 1:m, j in 1:n}: m x n
        return ca.reshape(ca.vertcat(*values), sizes[1], sizes[0]).T
    try:
        return array_of(values)
    except ValueError:
        tr.reject("an array of more than two dimensions", tr.provenance[i])


def _range_node(tr, i, body, ctx):
    return ca.SX(np.array(_range_values(tr, body, ctx, i), dtype=float))


# IR node kinds that build or take apart arrays -> handler(translator, node id, node body, context).
NODES = {
    "index": _index_node,
    "array_update": _update_node,
    "array": _array_node,
    "comprehension": _comprehension_node,
    "range": _range_node,
}
