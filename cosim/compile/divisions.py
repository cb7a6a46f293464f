"""Division by zero found at build time: a denominator of the model's equations that depends on parameters and
constants only and is 0 at the parameter values (``x / c`` with ``c = 0``), or a division by a literal zero
(CasADi folds ``x / 0.0`` into an infinite constant). Either gives a derivative or an output of inf or NaN at
every instant, so the build refuses it and names the denominator and, found in the source text, its line."""

import re
from pathlib import Path

import casadi as ca
import numpy as np

from cosim.errors import ModelicaError
from cosim.modelica_text import line_of

__all__ = ["check_divisions"]


def _walk(outputs):
    """Denominators of every division in ``outputs`` (SX), and whether a non-finite constant occurs."""
    stack = [e for out in outputs for e in out.nonzeros()]
    seen, denominators, infinite = set(), [], False
    while stack:
        e = stack.pop()
        key = e.element_hash()
        if key in seen:
            continue
        seen.add(key)
        if e.is_constant():
            infinite = infinite or not np.isfinite(float(e))
            continue
        if e.is_op(ca.OP_DIV):
            denominators.append(e.dep(1))
        if e.is_op(ca.OP_IF_ELSE_ZERO) and e.dep(1).is_constant() and np.isnan(float(e.dep(1))):
            stack.append(e.dep(0))  # NaN as a branch's value: a loop that did not converge (lower._functions)
            continue
        stack.extend(e.dep(i) for i in range(e.n_dep()))
    return denominators, infinite


def _where(source, pattern):
    """``(file, line)`` of the first match of ``pattern`` in the ``.mo`` files beside ``source``, model file first;
    ``(None, None)`` for a model of a library (``source`` None)."""
    if source is None:
        return None, None
    source = Path(source)
    for mo in [source] + sorted(p for p in source.parent.glob("*.mo") if p != source):
        text = mo.read_text(encoding="utf-8")
        match = re.search(pattern, text)
        if match:
            return str(mo), line_of(text, match.start())
    return str(source), None


def check_divisions(model, source):
    """Refuse a model that divides by zero at its parameter values.

    Parameters
    ----------
    model : LoweredModel
    source : path-like or None
        The model's ``.mo`` file (None for a library's model), searched (with its folder's other files) for the line of the division.

    Raises
    ------
    ModelicaError
        A denominator depending on parameters and constants only is 0 at the parameter values, or the
        equations divide by a literal zero; the message names the denominator, its parameter values and file:line.
    """
    for f in (model.ode, model.out):
        inputs = f.sx_in()
        denominators, infinite = _walk(f.call(inputs))
        if infinite:
            file, line = _where(source, r"/\s*\(?\s*0*\.?0+(?:[eE][-+]?\d+)?(?![\w.])")
            raise ModelicaError(f"{model.name} divides by zero: a division by a literal 0 (or an infinite constant) "
                                "in its equations", file=file, line=line)
        if not denominators:
            continue
        # Only those of parameters and constants: NaN for x, u, t and the memory would not do, as a condition
        # NaN is true (a Boolean's both values in one expression, at an impossible combination, gave 0).
        others = ca.vertcat(*(i for k, i in enumerate(inputs) if k != 2))
        # one sparsity pass over the graph, not one per denominator (a model's unrolled Newton iterations hold
        # thousands of them)
        uses_others = set(ca.jacobian_sparsity(ca.vertcat(*denominators), others).row())
        denominators = [d for k, d in enumerate(denominators) if k not in uses_others]
        if not denominators:
            continue
        values = [np.zeros(i.numel()) for i in inputs]
        values[2] = model.parameter_values
        found = ca.Function("denominators", inputs, [ca.vertcat(*denominators)])(*values)
        for d, v in zip(denominators, np.array(found, dtype=float).ravel()):
            if v == 0.0:
                names = [str(s) for s in ca.symvar(d)]
                given = ", ".join(f"{p.name} = {p.start:g}" for p in model.parameters if p.name in names)
                first = names[0] if names else str(d)
                file, line = _where(source, r"/\s*\(?\s*" + re.escape(first) + r"\b")
                raise ModelicaError(f"{model.name} divides by zero: the denominator {d} is 0 at the parameter "
                                    f"values ({given or 'constants only'}); give it a value that is not 0",
                                    file=file, line=line)
