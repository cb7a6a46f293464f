"""The conditions under which an expression is evaluated, for the asserts inside inlined functions: an assert in a
function called in an untaken branch of an if-expression (or in a when-clause that is not active) must not fire.

Translation evaluates every branch (CasADi's ``if_else`` selects among values computed on both sides), so each
branch and each when-value is translated under its condition (:meth:`Guards.under`), and an assert records the
conditions around it. Expressions are memoised; one reached again under other conditions (rumoca's relations are
translated once before the equations that hold them) makes the asserts its first translation recorded hold there
too.
"""

import contextlib
import functools
from dataclasses import dataclass, field

import casadi as ca

__all__ = ["Guards"]


@dataclass
class _Assert:
    failed: ca.SX   # the assert's condition is false, at the call site's values
    message: str    # "file:line: message"
    first: tuple    # the conditions it was translated under, outermost first
    others: list = field(default_factory=list)  # the conditions of other places its expression is reached from


class Guards:
    """The stack of conditions being translated under and the asserts recorded under them."""

    def __init__(self):
        self.stack = []
        self.asserts = []
        self.spans = {}  # memo key -> (first assert, end, depth of the stack) of the asserts its translation recorded

    @contextlib.contextmanager
    def under(self, condition):
        self.stack.append(condition)
        try:
            yield
        finally:
            self.stack.pop()

    def add_assert(self, failed, message):
        self.asserts.append(_Assert(failed, message, tuple(self.stack)))

    def memoised(self, memo, key, translate):
        """``memo[key]``, translated by ``translate()`` the first time; a later reach widens its asserts' conditions."""
        if key in memo:
            self._reached_again(key)
            return memo[key]
        start, depth = len(self.asserts), len(self.stack)
        memo[key] = translate()
        if len(self.asserts) > start:
            self.spans[key] = (start, len(self.asserts), depth)
        return memo[key]

    def _reached_again(self, key):
        if key not in self.spans:
            return
        start, end, depth = self.spans[key]
        for check in self.asserts[start:end]:
            conditions = tuple(self.stack) + check.first[depth:]
            if not any(_same(conditions, known) for known in [check.first] + check.others):
                check.others.append(conditions)

    def checks(self):
        """(failed, message) of each assert that can fire: failed, under the conditions of one place it is in."""
        result = []
        for check in self.asserts:
            places = [functools.reduce(ca.logic_and, c) if c else ca.SX(1) for c in [check.first] + check.others]
            places = [p for p in places if not (p.is_constant() and float(ca.evalf(p)) == 0.0)]
            if places:
                where = functools.reduce(ca.logic_or, places)
                result.append((check.failed if where.is_one() else ca.logic_and(where, check.failed), check.message))
        return result


def _same(a, b):
    return len(a) == len(b) and all(ca.is_equal(x, y, 4) for x, y in zip(a, b))
