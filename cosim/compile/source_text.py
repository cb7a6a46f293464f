"""rumoca 0.10.2's errors without a line for constructs it does not carry (a ``while`` statement, a ``for`` loop
over the elements of an array in a function, ``der()`` of an expression it could not take): find the construct
in the Modelica text, lexically (comments and strings masked, nothing parsed), and name it with file and line.
"""

import re

from cosim.errors import UnsupportedConstructError

__all__ = ["masked", "locate_rumoca_error"]

_LEXICAL = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\])*"', re.S)


def masked(text):
    """``text`` with comments and string literals blanked (same length, same newlines)."""
    return _LEXICAL.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def _line(text, position):
    return text.count("\n", 0, position) + 1


def _function_span(text, name):
    match = re.search(rf"\bfunction\s+{re.escape(name)}\b.*?\bend\s+{re.escape(name)}\s*;", text, re.S)
    return (match.start(), match.end()) if match else (0, len(text))


_KNOWN = [
    # (pattern in rumoca's message, pattern of the construct in the text, what it is, what to do instead)
    (re.compile(r"`(?P<function>\w+)` contains a statement without a checked DAE owner"),
     re.compile(r"\bwhile\b"), "while-statement",
     "rumoca 0.10.2 does not carry it into its IR; write a for-loop with a fixed bound"),
    (re.compile(r"`(?P<function>\w+)` requires a compact dependent-domain transition"),
     re.compile(r"\bfor\s+\w+\s+in\s+[^:;]*?\s+loop\b"), "for-loop over the elements of an array",
     "loop over its indices (for i in 1:size(v, 1))"),
    (re.compile(r"while-statement"), re.compile(r"\bwhile\b"), "while-statement",
     "rumoca 0.10.2 does not carry it into its IR; write a for-loop with a fixed bound"),
    (re.compile(r"unsupported model algorithm in canonical DAE: (?P<reason>[^\n]+)"),
     re.compile(r"\balgorithm\b"), "algorithm section of a model",
     "write equations, or move the algorithm into a function"),
    (re.compile(r"der\(\.\.\.\) must have exactly one resolved variable-reference operand"),
     re.compile(r"\bder\s*\((?!\s*[A-Za-z_][\w.]*\s*(\[[^\]]*\])?\s*\))"), "der() of this expression",
     "write der() of a variable here, or move it into an equation (der() of an expression is supported there)"),
]


def locate_rumoca_error(message, files):
    """An :class:`UnsupportedConstructError` with file and line for a rumoca error about a construct it does
    not carry, or None when ``message`` is not one of those.

    Parameters
    ----------
    message : str
        rumoca's error text.
    files : list of Path
        The Modelica files rumoca read, the model's own first.
    """
    for said, construct, what, instead in _KNOWN:
        found = said.search(message)
        if not found:
            continue
        function = found.groupdict().get("function")
        if found.groupdict().get("reason"):
            instead = f"rumoca 0.10.2 says: {found.group('reason').strip()}; {instead}"
        for path in files:
            text = masked(path.read_text(encoding="utf-8"))
            start, end = _function_span(text, function) if function else (0, len(text))
            if function and (start, end) == (0, len(text)):
                continue
            hit = construct.search(text, start, end)
            if hit:
                where = f" in function {function}" if function else ""
                return UnsupportedConstructError(f"the {what}{where} is not supported: {instead}",
                                                 str(path), _line(text, hit.start()))
        return UnsupportedConstructError(f"the {what} is not supported: {instead} (rumoca: {message})",
                                         str(files[0]))
    return None
