"""rumoca 0.10.2's errors without a line for constructs it does not carry (a ``while`` statement, a ``for`` loop
over the elements of an array in a function, ``der()`` of an expression it could not take): find the construct
in the Modelica text, lexically (comments and strings masked, nothing parsed), and name it with file and line.
Also where a class is (:func:`class_source`): its file, line and text, in a user's file or in a library.
"""

import re
from pathlib import Path

from cosim.errors import UnsupportedConstructError
from cosim.modelica_text import find_class, line_of

__all__ = ["masked", "locate_rumoca_error", "class_source"]

_LEXICAL = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\])*"', re.S)


def masked(text):
    """``text`` with comments and string literals blanked (same length, same newlines)."""
    return _LEXICAL.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def class_source(path, model, roots=()):
    """``(file, line, text)`` of class ``model``: in the file ``path``, or, when ``path`` is None, in the library
    folders ``roots`` (its own file, ``Examples/PID_Controller.mo``, or its span in the ``package.mo`` that
    declares it); ``(None, None, "")`` when it is not found."""
    if path is not None:
        source = Path(path).read_text(encoding="utf-8")
        body = find_class(source, model)
        return (str(path), line_of(source, source.index(body)), body) if body else (None, None, "")
    parts = model.split(".")
    for root in roots:
        here = Path(root)
        for k, part in enumerate(parts):
            if (here / part).is_dir() and k < len(parts) - 1:
                here = here / part
                continue
            mo = here / f"{part}.mo" if (here / f"{part}.mo").is_file() else here / "package.mo"
            if mo.is_file():
                return _span(mo, parts[-1])
            break
    return None, None, ""


def _span(mo, name):
    """``(file, line, text)`` from ``model|block|class name`` to ``end name;`` in the file ``mo``."""
    text = mo.read_text(encoding="utf-8", errors="replace")
    hidden = masked(text)
    start = re.search(rf"\b(?:model|block|class)\s+{re.escape(name)}\b", hidden)
    end = re.search(rf"\bend\s+{re.escape(name)}\s*;", hidden[start.end():]) if start else None
    if end is None:
        return None, None, ""
    return str(mo), line_of(text, start.start()), text[start.start():start.end() + end.end()]


def _function_span(text, name):
    match = re.search(rf"\bfunction\s+{re.escape(name)}\b.*?\bend\s+{re.escape(name)}\s*;", text, re.S)
    return (match.start(), match.end()) if match else (0, len(text))


_WHILE = "rumoca 0.10.2 does not carry it into its IR; write a for-loop with a fixed bound"
_KNOWN = [
    # (pattern in rumoca's message, pattern of the construct in the text (formatted with the message's named
    # groups), what it is, what to do instead). The first entry whose construct is found in the text wins.
    (r"`(?P<function>\w+)` contains a statement without a checked DAE owner", r"\bwhile\b", "while-statement",
     _WHILE),
    (r"`(?P<function>\w+)` requires a compact dependent-domain transition", r"\bfor\s+\w+\s+in\s+[^:;]*?\s+loop\b",
     "for-loop over the elements of an array", "loop over its indices (for i in 1:size(v, 1))"),
    (r"`function loop reduction`: `(?P<function>\w+)`", r"\bbreak\b", "break-statement",
     "rumoca 0.10.2 cannot unroll a loop that may stop early; run the whole range and guard the body with if"),
    (r"`function loop reduction`: `(?P<function>\w+)`", r"\bfor\b", "for-loop",
     "rumoca 0.10.2 cannot bound it: loop over a range whose size is known at build time"),
    (r"`function return`: `(?P<function>\w+)`", r"\breturn\b", "return-statement",
     "rumoca 0.10.2 rejects it; use if-statements"),
    (r"(?P<call>\w+)\(\) is not allowed in functions", r"\b{call}\s*\(", "{call}() in a function",
     "the language forbids it"),
    (r"while-statement", r"\bwhile\b", "while-statement", _WHILE),
    (r"unsupported model algorithm in canonical DAE: (?P<reason>[^\n]+)", r"\balgorithm\b",
     "algorithm section of a model", "rumoca 0.10.2 says: {reason}; write equations, or move the algorithm into a "
     "function"),
    (r"der\(\.\.\.\) must have exactly one resolved variable-reference operand",
     r"\bder\s*\((?!\s*[A-Za-z_][\w.]*\s*(\[[^\]]*\])?\s*\))", "der() of this expression",
     "write der() of a variable here (der() of an expression is supported in equations, outside for-loops)"),
]


def _find(message, files):
    """(what, instead, function, file, line) of the first known construct the message names and the text has;
    None when the message is not about one; file and line None when the text does not show it."""
    known = None
    for said, construct, what, instead in _KNOWN:
        found = re.search(said, message)
        if not found:
            continue
        groups = {k: v.strip() for k, v in found.groupdict().items()}
        what, instead = what.format(**groups), instead.format(**groups)
        known = known or (what, instead, groups.get("function"), None, None)
        for path in files:
            text = masked(path.read_text(encoding="utf-8"))
            start, end = _function_span(text, groups["function"]) if "function" in groups else (0, len(text))
            if "function" in groups and (start, end) == (0, len(text)):
                continue
            hit = re.search(construct.format(**groups), text[start:end])
            if hit:
                return what, instead, groups.get("function"), str(path), line_of(text, start + hit.start())
    return known


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
    found = _find(message, files)
    if found is None:
        return None
    what, instead, function, file, line = found
    where = f" in function {function}" if function else ""
    if file is None:
        return UnsupportedConstructError(f"the {what}{where} is not supported: {instead} (rumoca: {message})",
                                         str(files[0]))
    return UnsupportedConstructError(f"the {what}{where} is not supported: {instead}", file, line)
