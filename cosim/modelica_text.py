"""Modelica source text as classes: find a class by its full name, follow its ``extends``, list its replaceable
components, and check the ``redeclare`` modifiers of ``extends`` clauses against what rumoca 0.10.2 carries.

rumoca flattens ``extends Base(redeclare Block c(...))`` where ``c`` is a replaceable component that ``Base``
itself declares, but it drops three neighbouring forms without a word: a ``redeclare`` nested in a component's
modification (``extends Base(b(redeclare Block c))``), a ``redeclare`` of an element ``Base`` inherits or does not
declare replaceable, and the modifiers of a redeclared short class (``redeclare model M = Block(k = 1)``).
:func:`check_redeclares` rejects them with file and line (docs/compiler.md).
"""

import functools
import re

from cosim.errors import ConfigError, UnsupportedConstructError

__all__ = ["find_class", "own_text", "resolve", "class_chain", "modifiers", "replaceables", "check_redeclares",
           "line_of", "model_names"]

_KINDS = "(?:partial +)?(?:model|block|package|record|function|connector)"
_REPLACEABLE = re.compile(r"\breplaceable\s+([\w.]+)\s+(\w+)\s*(\((?:[^()]|\([^()]*\))*\))?\s*"
                          r"(?:constrainedby\s+([\w.]+))?")
_EXTENDS = re.compile(r"^\s*extends\s+([\w.]+)", re.M)


@functools.lru_cache(maxsize=512)
def find_class(text, name):
    """The text of class ``name`` (full name, e.g. ``Gripper.Components.PMSM``) in ``text``, or None. Kept for the
    same text and name: a diagnosis looks the same classes up thousands of times (the library's slots and
    declarations on every variant it writes), each a search of the whole package (3 % of an impact case's time,
    docs/dev/diagnose-rounds.md)."""
    body = text
    for part in name.split("."):
        match = re.search(rf"^( *){_KINDS} {re.escape(part)}\b.*?^\1end {re.escape(part)};", body, re.S | re.M)
        if match is None:
            return None
        text = match.group(0)
        body = text.partition("\n")[2]  # a member is declared inside, not on the class's own first line
    return text


_OPENS = re.compile(r"^\s*(?:(?:partial|encapsulated|final)\s+)*(model|block|class|package|record|function|connector|"
                    r"type|operator)\s+(\w+)\b(?!\s*=)")
_ENDS = re.compile(r"^\s*end\s+(\w+)\s*;")


def model_names(text):
    """The full names of the models and blocks declared in ``text`` (``Gripper.GripperPlant``), in order: what
    ``cosim build --model`` may name, for its "did you mean"."""
    stack, names = [], []
    for line in text.splitlines():
        opened = _OPENS.match(line)
        if opened:
            stack.append(opened.group(2))
            if opened.group(1) in ("model", "block", "class"):
                names.append(".".join(stack))
        ended = _ENDS.match(line)
        if ended and ended.group(1) in stack:
            del stack[len(stack) - 1 - stack[::-1].index(ended.group(1)):]
    return names


def own_text(body):
    """A class's text without the classes nested in it (a package's members are not its declarations)."""
    head, _, rest = body.partition("\n")
    return head + "\n" + re.sub(rf"^( *){_KINDS} (\w+)\b.*?^\1end \2;\n", "", rest, flags=re.S | re.M)


def resolve(text, name, scope):
    """Full name of class ``name`` referenced in class ``scope``: Modelica's lookup through the enclosing
    packages. A ConfigError when no enclosing package has it."""
    parts = scope.split(".")[:-1]
    for k in range(len(parts), -1, -1):
        full = ".".join(parts[:k] + [name])
        if find_class(text, full) is not None:
            return full
    raise ConfigError(f"class {name!r} used in {scope} is not in the Modelica source")


def class_chain(text, name):
    """``[(class name, own text)]`` of class ``name`` and of every class it extends, the class first.

    Raises
    ------
    ConfigError
        ``name`` (or a class it extends) is not in ``text``.
    """
    body = find_class(text, name)
    if body is None:
        raise ConfigError(f"no class {name!r} in the Modelica source")
    own = own_text(body)
    chain = [(name, own)]
    for base in _EXTENDS.findall(own):
        chain += class_chain(text, resolve(text, base, name))
    return chain


def modifiers(modification):
    """``(name, expression)`` pairs of a modification ``(a = 1, b = f(x, y))`` (None or "" gives none)."""
    inner, parts, depth, start = (modification or "()")[1:-1], [], 0, 0
    for i, ch in enumerate(inner + ","):
        depth += ch == "("
        depth -= ch == ")"
        if ch == "," and depth == 0:
            if inner[start:i].strip():
                key, _, expr = inner[start:i].partition("=")
                parts.append((key.strip(), expr.strip()))
            start = i + 1
    return tuple(parts)


def replaceables(text, name):
    """The replaceable components class ``name`` declares itself (not those it inherits):
    ``[(component, default class, constraining class, modifiers)]``, class names resolved to full names."""
    found = []
    for default, component, modification, constraint in _REPLACEABLE.findall(class_chain(text, name)[0][1]):
        default = resolve(text, default, name)
        found.append((component, default, resolve(text, constraint, name) if constraint else default,
                      modifiers(modification)))
    return found


def line_of(text, pos):
    """The 1-based line of character ``pos`` of ``text``."""
    return text.count("\n", 0, pos) + 1


def _extends_clauses(text):
    """``(position, base name, modification text)`` of every ``extends Base(...)`` of ``text``."""
    for match in re.finditer(r"\bextends\s+([\w.]+)\s*\(", text):
        depth, i = 1, match.end()
        while depth and i < len(text):
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            i += 1
        yield match.start(), match.group(1), text[match.end() - 1:i]


def check_redeclares(text, file):
    """Reject the ``redeclare`` forms of ``extends`` clauses that rumoca 0.10.2 ignores without a word.

    Raises
    ------
    UnsupportedConstructError
        With ``file`` and the line of the clause.
    """
    for pos, base, modification in _extends_clauses(text):
        where = (file, line_of(text, pos))
        for found in re.finditer(r"\bredeclare\b", modification):
            head = modification[:found.start()]
            if head.count("(") - head.count(")") != 1:
                raise UnsupportedConstructError(
                    f"a redeclare nested in a component modification of `extends {base}(...)` is ignored by rumoca "
                    f"0.10.2: redeclare the component in a subclass of its class instead (docs/compiler.md)", *where)
            clause = re.match(r"redeclare\s+(?:(?:model|block)\s+(\w+)\s*=\s*[\w.]+\s*(\()?|[\w.]+\s+(\w+))",
                              modification[found.start():])
            if clause and clause.group(2):
                raise UnsupportedConstructError(
                    f"the modifiers of the redeclared class {clause.group(1)} in `extends {base}(...)` are ignored "
                    f"by rumoca 0.10.2: put them on the component declarations (docs/compiler.md)", *where)
            if clause and clause.group(3):
                full = resolve(text, base, _enclosing_class(text, pos))
                declared = sorted(component for component, *_ in replaceables(text, full))
                if clause.group(3) not in declared:
                    raise UnsupportedConstructError(
                        f"`redeclare ... {clause.group(3)}` in `extends {base}(...)`: {full} does not itself declare "
                        f"a replaceable {clause.group(3)}, and rumoca 0.10.2 ignores a redeclare of an inherited or "
                        f"non-replaceable element (its own replaceable components: {', '.join(declared) or 'none'})",
                        *where)


def _enclosing_class(text, pos, outer=()):
    """Full name of the innermost class whose text contains position ``pos``."""
    for match in re.finditer(rf"^( *){_KINDS} (\w+)\b.*?^\1end \2;", text, re.S | re.M):
        if match.start() <= pos < match.end():
            head = len(match.group(0).partition("\n")[0]) + 1
            return _enclosing_class(match.group(0)[head:], pos - match.start() - head, outer + (match.group(2),))
    return ".".join(outer)
