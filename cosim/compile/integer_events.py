"""Event-generating integer functions (Modelica 3.7.2): ``floor``, ``ceil``, ``integer``, ``div``, ``mod``, ``rem``.

Outside ``noEvent``/``smooth``, functions and when-clauses, each call is a :class:`Step`: the integer value
(``floor(x)``, ``ceil(x)``, or ``x/y`` truncated toward zero for ``div`` and ``rem``) is held in the event memory
between events and recomputed in every event pass; ``mod(x, y) = x - floor(x/y)*y`` and ``rem(x, y) =
x - div(x, y)*y`` are continuous between events. A step is located like a relation: on continuous variables by
two event indicators, the distances of its argument to the bounds of the held value's interval; affine in
``time`` by a time event at the instant its argument reaches the next bound; on parameters and discrete
variables it is re-evaluated at events. Inside ``noEvent`` (and the other places) the functions are evaluated
directly.

rumoca 0.10.2 writes a model's ``mod``/``rem``/``div`` call as one ``runtime_quotient_owner`` node whose
references count six more nodes it leaves out of its IR (:func:`target_arena`), and lists a relation
``sin(pi*x) >= 0`` for each ``floor``/``ceil``/``integer`` call (:func:`generated_floor_relation`); the compiler
uses its own indicators instead of both.
"""

import sys
from dataclasses import dataclass

import casadi as ca

__all__ = ["Step", "MODES", "QUOTIENT_MODES", "direct", "quotient", "bounds", "indicators", "target_arena",
           "generated_floor_relation", "right_limit", "next_instant"]

# The integer-valued function of each built-in: floor, ceil, or truncation toward zero.
MODES = {"floor": "floor", "integer": "floor", "ceil": "ceil"}
QUOTIENT_MODES = {"mod": "floor", "div": "trunc", "rem": "trunc"}
# Nodes rumoca 0.10.2 generates after a model's runtime_quotient_owner and leaves out of its wire IR.
_OWNER_HIDDEN_NODES = 6
DBL_MIN = sys.float_info.min


@dataclass
class Step:
    """An integer-valued function of ``arg`` held in the event memory between events."""

    sym: object      # the held integer value, as it appears in the equations
    arg: object      # x (floor, ceil, integer) or x/y (div, mod, rem)
    mode: str        # floor, ceil or trunc
    location: str
    kind: str = ""   # set by the lowering: state (two indicators), time (a time event) or discrete


def direct(mode, q):
    """``floor``, ``ceil`` or truncation toward zero of ``q``, evaluated directly."""
    if mode == "floor":
        return ca.floor(q)
    if mode == "ceil":
        return ca.ceil(q)
    return ca.if_else(q < 0, ca.ceil(q), ca.floor(q))


def quotient(builtin, x, y, k):
    """``div``, ``mod`` or ``rem`` of ``x`` and ``y`` from ``k``, the integer part of ``x/y`` (floored for ``mod``,
    truncated for ``div`` and ``rem``)."""
    return k if builtin == "div" else x - k * y


def bounds(mode, k):
    """(lo, hi): the argument keeps the integer value ``k`` while it stays between them (``floor``: [k, k+1),
    ``ceil``: (k-1, k], truncation: [k, k+1) above 0, (k-1, k] below, (-1, 1) at 0)."""
    if mode == "floor":
        return k, k + 1
    if mode == "ceil":
        return k - 1, k
    return ca.if_else(k > 0, k, k - 1), ca.if_else(k < 0, k, k + 1)


def indicators(step):
    """The two event indicators of a step on continuous variables, positive while its value holds: the
    distances of the argument to the bounds, plus DBL_MIN at a closed bound (``floor`` at x = k), so that an
    argument exactly at it (a start at z = 0) is strictly inside: a solver sees no root where an indicator
    starts at 0 (fmpy's CVode then missed ``ceil(z)`` of a z rising from 0)."""
    k = step.sym
    lo, hi = bounds(step.mode, k)
    closed_lo = {"floor": 1, "ceil": 0}.get(step.mode, k > 0)
    closed_hi = {"floor": 0, "ceil": 1}.get(step.mode, k < 0)
    return [step.arg - lo + closed_lo * DBL_MIN, hi - step.arg + closed_hi * DBL_MIN]


def right_limit(step, arg, T, tolerance, initial):
    """A step on time at an event instant: its value just after (``floor(3*time)`` is 1 at the event at 1/3,
    whatever the rounding of 3*t), directly at initialisation."""
    after = ca.substitute(arg, T, T + tolerance)
    return ca.if_else(initial, direct(step.mode, arg), direct(step.mode, after))


def next_instant(step, T):
    """A step whose argument is affine in time (slope of parameters): the instant the argument reaches the
    bound in its direction of motion (inf for a slope 0)."""
    slope = ca.jacobian(step.arg, T)
    at_zero = ca.substitute(step.arg, T, 0)
    lo, hi = bounds(step.mode, step.sym)
    bound = ca.if_else(slope > 0, hi, lo)
    return ca.if_else(slope == 0, ca.inf, (bound - at_zero) / slope)


def target_arena(nodes, provenance):
    """rumoca's expression nodes and their provenance as its references count them: each model
    ``runtime_quotient_owner`` is followed by the six nodes rumoca generates for it and leaves out of the IR
    (placeholders here, with the owner's provenance; nothing refers to them)."""
    full_nodes, full_provenance = [], []
    for i, node in enumerate(nodes):
        full_nodes.append(node)
        full_provenance.append(provenance[i] if i < len(provenance) else None)
        owner = node.get("runtime_quotient_owner")
        if isinstance(owner, dict) and "model" in owner.get("kind", {}):
            full_nodes += [{"quotient_generated": {"owner_node": i}}] * _OWNER_HIDDEN_NODES
            full_provenance += [full_provenance[-1]] * _OWNER_HIDDEN_NODES
    return full_nodes, full_provenance


def generated_floor_relation(entry, nodes):
    """Whether a relation rumoca lists is the one it generates for ``floor``/``ceil``/``integer``:
    ``sin(pi*x) >= 0``, of origin ``runtime_discontinuity``."""
    relation = entry.get("relation")
    if not relation or relation.get("provenance", {}).get("origin") != {"generated": "runtime_discontinuity"}:
        return False
    body = nodes[relation["expression"]].get("binary", {})
    lhs = nodes[body["lhs"]] if body.get("operator") == "greater_equal" else {}
    return lhs.get("builtin", {}).get("builtin") == "sin"
