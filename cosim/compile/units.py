"""Modelica unit strings ("N.m", "kg.m2", "rad/s", "V.s/rad") as FMI base-unit exponents, so the FMU's
modelDescription carries a UnitDefinitions entry for every unit it uses."""

import re

__all__ = ["base_unit"]

_BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
# Symbol -> (factor, exponents over _BASE)
_SYMBOLS = {
    "kg": (1.0, (1, 0, 0, 0, 0, 0, 0, 0)),
    "g": (1e-3, (1, 0, 0, 0, 0, 0, 0, 0)),
    "m": (1.0, (0, 1, 0, 0, 0, 0, 0, 0)),
    "s": (1.0, (0, 0, 1, 0, 0, 0, 0, 0)),
    "A": (1.0, (0, 0, 0, 1, 0, 0, 0, 0)),
    "K": (1.0, (0, 0, 0, 0, 1, 0, 0, 0)),
    "mol": (1.0, (0, 0, 0, 0, 0, 1, 0, 0)),
    "cd": (1.0, (0, 0, 0, 0, 0, 0, 1, 0)),
    "rad": (1.0, (0, 0, 0, 0, 0, 0, 0, 1)),
    "deg": (0.017453292519943295, (0, 0, 0, 0, 0, 0, 0, 1)),
    "rev": (6.283185307179586, (0, 0, 0, 0, 0, 0, 0, 1)),
    "min": (60.0, (0, 0, 1, 0, 0, 0, 0, 0)),
    "h": (3600.0, (0, 0, 1, 0, 0, 0, 0, 0)),
    "Hz": (1.0, (0, 0, -1, 0, 0, 0, 0, 0)),
    "N": (1.0, (1, 1, -2, 0, 0, 0, 0, 0)),
    "Pa": (1.0, (1, -1, -2, 0, 0, 0, 0, 0)),
    "J": (1.0, (1, 2, -2, 0, 0, 0, 0, 0)),
    "W": (1.0, (1, 2, -3, 0, 0, 0, 0, 0)),
    "C": (1.0, (0, 0, 1, 1, 0, 0, 0, 0)),
    "V": (1.0, (1, 2, -3, -1, 0, 0, 0, 0)),
    "Ohm": (1.0, (1, 2, -3, -2, 0, 0, 0, 0)),
    "F": (1.0, (-1, -2, 4, 2, 0, 0, 0, 0)),
    "H": (1.0, (1, 2, -2, -2, 0, 0, 0, 0)),
    "Wb": (1.0, (1, 2, -2, -1, 0, 0, 0, 0)),
    "T": (1.0, (1, 0, -2, -1, 0, 0, 0, 0)),
    "1": (1.0, (0,) * 8),
}
_PREFIX = {"m": 1e-3, "u": 1e-6, "n": 1e-9, "k": 1e3, "M": 1e6, "c": 1e-2}
_FACTOR = re.compile(r"^(?P<sym>[A-Za-z]+|1)(?P<exp>-?\d+)?$")


def _factor(token):
    match = _FACTOR.match(token)
    if not match:
        return None
    sym, exp = match.group("sym"), int(match.group("exp") or 1)
    if sym in _SYMBOLS:
        factor, dims = _SYMBOLS[sym]
    elif len(sym) > 1 and sym[0] in _PREFIX and sym[1:] in _SYMBOLS:
        factor, dims = _SYMBOLS[sym[1:]]
        factor *= _PREFIX[sym[0]]
    else:
        return None
    return factor**exp, tuple(d * exp for d in dims)


def base_unit(unit):
    """Return ``(factor, {base: exponent})`` for a Modelica unit string, or ``None`` when it is not understood.

    Examples
    --------
    >>> base_unit("N.m")
    (1.0, {'kg': 1, 'm': 2, 's': -2})
    """
    numerator, _, denominator = unit.partition("/")
    if "/" in denominator:
        return None
    factor, dims = 1.0, [0] * len(_BASE)
    for part, sign in ((numerator, 1), (denominator, -1)):
        part = part.strip("()")
        if not part:
            continue
        for token in part.split("."):
            parsed = _factor(token)
            if parsed is None:
                return None
            f, d = parsed
            factor *= f**sign
            dims = [a + sign * b for a, b in zip(dims, d)]
    return factor, {b: e for b, e in zip(_BASE, dims) if e}
