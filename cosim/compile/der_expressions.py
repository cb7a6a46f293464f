"""``der()`` of an expression (``der(phi2 - phi1)``, ``der(k*x)``): rumoca 0.10.2 accepts only
``der(variable)``, so the front end rewrites the text before rumoca reads it. Each such ``der(e)`` becomes
``der(_der<file>_<offset>)``, with ``_der<file>_<offset> = e`` added to the same class as an equation and the
variable declared ``protected`` with ``stateSelect = StateSelect.never``; the insertion goes on the line of the
``equation`` keyword, so every line number stays what the user wrote. After translation, a variable of ``e`` that
rumoca made algebraic (it appears under no other ``der()``) becomes a state again
(:func:`promote_der_arguments`). The lowering then sees a constraint between states, demotes the new variable and
differentiates the constraint (index reduction): the chain rule ``d/dt e = J_x e * der(x) + de/dt``.
"""

import re

import casadi as ca

from cosim.compile.source_text import masked

__all__ = ["rewrite_der_expressions", "promote_der_arguments"]

_DER = re.compile(r"\bder\s*\(")
_REFERENCE = re.compile(r"\s*[A-Za-z_]\w*(\s*\[[^\]]*\])?(\s*\.\s*[A-Za-z_]\w*(\s*\[[^\]]*\])?)*\s*")
_SECTION = re.compile(r"\b(?:initial\s+)?equation\b")
_AUXILIARY = re.compile(r"(^|\.)_der\d+_\d+$")


def _closing(text, start):
    """Index of the parenthesis closing the one before ``start``, or None."""
    depth = 1
    for k in range(start, len(text)):
        depth += {"(": 1, ")": -1}.get(text[k], 0)
        if depth == 0:
            return k
    return None



def _plainly_inside(between):
    """Whether the text from an equation keyword to a ``der(`` stays in that equation section and outside
    ``for`` loops (whose index the new equation, outside the loop, could not see)."""
    if re.search(r"\b(?:end\s+(?!(?:for|if|when|while)\b)\w+\s*;|(?:public|protected|algorithm)\b)", between):
        return False
    return len(re.findall(r"\bfor\b", between)) == 2 * len(re.findall(r"\bend\s+for\b", between))


def rewrite_der_expressions(text, tag=""):
    """``text`` with every ``der(expression)`` replaced by ``der`` of a new variable bound to the expression.

    Parameters
    ----------
    text : str
        Modelica source.
    tag : str
        Part of the new variables' names (``_der<tag>_<offset>``), distinct per file.

    Returns
    -------
    (str, int)
        The new text (same lines) and how many ``der()`` calls were rewritten.
    """
    blank = masked(text)
    edits = []  # (position, length replaced, new text)
    for match in _DER.finditer(blank):
        close = _closing(blank, match.end())
        if close is None or _REFERENCE.fullmatch(blank[match.end():close]):
            continue
        sections = [s for s in _SECTION.finditer(blank, 0, match.start())]
        if not sections or not _plainly_inside(blank[sections[-1].end():match.start()]):
            continue  # rumoca then reports it, and the front end says where (source_text.py)
        name = f"_der{tag}_{match.start()}"
        expression = " ".join(text[match.end():close].split())
        edits.append((sections[-1].start(), 0, f"protected Real {name}(stateSelect = StateSelect.never); "
                                               f"equation {name} = {expression}; "))
        edits.append((match.start(), close + 1 - match.start(), f"der({name})"))
    for position, length, new in sorted(edits, key=lambda e: e[0], reverse=True):
        text = text[:position] + new + text[position + length:]
    return text, len(edits) // 2


def promote_der_arguments(system):
    """Make every algebraic variable of a rewritten ``der(e)``'s ``e`` a state (with a derivative symbol), as
    the language's ``der(e)`` does; rumoca saw only ``der`` of the new variable. Modifies ``system``."""
    for aux in [v for v in system.variables if _AUXILIARY.search(v.name)]:
        for equation in system.equations:
            if not ca.depends_on(equation.residual, aux.sym):
                continue
            names = {s.name() for s in ca.symvar(equation.residual)}
            for v in system.variables:
                if v.role in ("algebraic", "output") and v.name in names:
                    v.role = "state"
                    system.derivatives[v.name] = ca.SX.sym(f"der({v.name})")
