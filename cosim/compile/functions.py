"""Inline Modelica functions with algorithm sections into the caller's expressions, once per call site with that
site's arguments.

rumoca 0.10.2 numbers every value a function's statements define, in textual order, and a read refers to a
definition by that number (``function_value``): each assignment defines one value, an ``if`` statement is an
``assignment_group`` whose right-hand sides are already conditional expressions, and a ``for`` statement defines
one value per assigned variable at the top of its body (the loop-carried value) and one after the loop (the
result). The body's numbers are the same on every pass, so unrolling the loop re-runs the body with those
numbers rebound. Loop ranges, sizes and subscripts must be known at build time (they are, for arrays whose
sizes are parameters). ``while`` statements do not reach the IR: rumoca rejects them (the front end says where).
"""

import casadi as ca

from cosim.compile import arrays
from cosim.errors import ModelicaError

__all__ = ["inline"]

# Statement kinds of the IR the inlining does not lower, by their Modelica names.
_MODELICA_NAMES = {"assertion": "assert()"}


class _Frame:
    """One call: the arguments, the values defined so far (by number) and each variable's current value."""

    def __init__(self, tr, function, args):
        self.tr = tr
        self.function = function
        self.args = args
        self.defs = {}
        self.current = {}
        self.next_def = 0

    def define(self, target, value):
        self.defs[self.next_def] = value
        self.current[target] = value
        self.next_def += 1

    def evaluate(self, node, binders):
        ctx = self.tr.context(args=self.args, defs=dict(self.defs), binders=binders)
        return self.tr.expr(node, ctx)

    def run(self, statements, binders):
        for statement in statements:
            (kind, body), = statement.items()
            if kind == "assignment":
                self.define(body["target"], self.evaluate(body["rhs"], binders))
            elif kind == "assignment_group":
                for assignment in body["assignments"]:
                    self.define(assignment["target"], self.evaluate(assignment["rhs"], binders))
            elif kind == "for":
                self.run_for(body, binders)
            elif kind == "assertion":
                self.assertion(body, binders)
            else:
                name = _MODELICA_NAMES.get(kind, f"'{kind}' statement")
                self.tr.reject(f"{name} inside function {self.function['name']} (put it in the model's equations)",
                               statement)

    def assertion(self, body, binders):
        """An ``assert`` of level error: checked where the model's own asserts are (at events, initialisation
        included) with this call's arguments; refused at build time when it fails whatever the values. An assert of
        level warning stops nothing: it is not checked."""
        if body.get("level", "error") != "error":
            return
        holds = self.evaluate(body["condition"], binders)
        literal = self.tr.nodes[body["message"]].get("literal", {})
        text = literal.get("string") if isinstance(literal, dict) else None
        where = self.tr.location(body)
        message = f"{where}: {text or '(message computed at run time; not available)'}"
        if holds.is_constant():
            if float(ca.evalf(holds)) == 0.0:
                file, _, line = where.rpartition(":")
                raise ModelicaError(f"the assert in function {self.function['name']} fails whatever the values: "
                                    f"{text}", file or where, int(line) if line.isdigit() else None)
            return
        self.tr.guards.add_assert(ca.logic_not(holds), message)

    def run_for(self, body, binders):
        """Unroll a ``for`` statement: the loop-carried values are rebound before every pass of the body."""
        if body.get("iteration_locals"):
            self.tr.reject(f"a for-loop with iteration locals in function {self.function['name']}", body)
        targets = body["targets"]
        top = self.next_def
        for values in arrays.domain_values(self.tr, body["domain"], binders):
            self.next_def = top
            for target in targets:
                self.define(target, self.current.get(target))
            self.run(body["statements"], values)
        if self.next_def == top:  # an empty range: the body never ran, its numbers are skipped
            self.next_def = top + len(targets) + _count_defs(body["statements"])
        for target in targets:
            self.define(target, self.current.get(target))


def _count_defs(statements):
    """How many values a list of statements defines (a ``for`` counts its loop-carried and result values)."""
    count = 0
    for statement in statements:
        (kind, body), = statement.items()
        if kind == "assignment":
            count += 1
        elif kind == "assignment_group":
            count += len(body["assignments"])
        elif kind == "for":
            count += 2 * len(body["targets"]) + _count_defs(body["statements"])
    return count


def inline(tr, index, args):
    """The outputs of function ``index`` of rumoca's IR called with ``args`` (SX, arrays as columns or
    matrices), as expressions of the arguments.

    Parameters
    ----------
    tr : translator
        Evaluates IR nodes (``expr``, ``context``) and reports rejected constructs (``reject``, ``unsupported``).
    index : int
        The function's position in the IR's function table.
    args : list of casadi.SX
        The call site's arguments.

    Returns
    -------
    list of casadi.SX
        One value per output, in declaration order.
    """
    function = tr.storage["functions"][index]
    if function.get("external"):
        tr.unsupported(f"the external function {function['name']}", function)
    if index in tr.inlining:
        chain = " -> ".join(tr.storage["functions"][k]["name"] for k in tr.inlining[tr.inlining.index(index):])
        tr.unsupported(f"the recursive function {function['name']} ({chain} -> {function['name']}: functions are "
                       "inlined, and a recursive one never ends)", function)
    tr.inlining.append(index)
    frame = _Frame(tr, function, args)
    frame.run(function["statements"], {})
    tr.inlining.pop()
    outputs = []
    for k, output in enumerate(function["outputs"]):
        if frame.current.get(k) is None:
            tr.reject(f"function {function['name']} leaving output {output['name']} unassigned", function)
        outputs.append(frame.current[k])
    return outputs
