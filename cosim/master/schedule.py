"""Exact sample instants on an integer time base.

Every rate (Hz) is read as an exact rational from its decimal text; the time base is the least
common multiple of all rates, so each clock's period is a whole number of ticks even when the rates
do not divide each other (26.6 kHz and 1 kHz share a 133 kHz base). Time is computed from the tick
count as ``t0 + k * D / N`` in one correctly rounded division: it does not drift, however many steps.
"""

import math
from dataclasses import dataclass
from fractions import Fraction

from cosim.errors import ConfigError

__all__ = ["exact_rate", "TimeBase", "Clock"]

_TICKS_MAX = 2**62  # tick counts, periods and k * den stay below int64's range in the compiled loop


def exact_rate(rate):
    """Return ``rate`` (Hz, int/float/str) as a positive Fraction read from its shortest decimal text.

    Raises
    ------
    ValueError
        The rate is not a finite positive number.
    """
    if isinstance(rate, bool):
        raise ValueError(f"rate must be a number of Hz; got {rate!r}")
    if isinstance(rate, Fraction):
        r = rate
    elif isinstance(rate, int):
        r = Fraction(rate)
    else:
        f = float(rate)
        if not math.isfinite(f):
            raise ValueError(f"rate must be finite; got {rate!r}")
        r = Fraction(repr(f)) if not isinstance(rate, str) else Fraction(rate)
    if r <= 0:
        raise ValueError(f"rate must be > 0 Hz; got {rate!r}")
    return r


def _lcm_fraction(a, b):
    # lcm(p/q, r/s) = lcm(p, r) / gcd(q, s) for fractions in lowest terms
    return Fraction(math.lcm(a.numerator, b.numerator), math.gcd(a.denominator, b.denominator))


@dataclass(frozen=True)
class Clock:
    """A periodic clock on the time base: instants at ticks ``0, period, 2 period, ...``."""

    name: str
    rate: Fraction
    period: int


class TimeBase:
    """The common integer time base of a set of rates.

    Parameters
    ----------
    rates : dict of str to number
        Clock name -> rate in Hz.
    start : float
        Start time t0 in s.

    Attributes
    ----------
    base : Fraction
        Ticks per second.
    clocks : dict of str to Clock

    Raises
    ------
    ConfigError
        The rates need a time base or periods beyond the 64-bit tick counter.
    """

    def __init__(self, rates, start=0.0):
        self.start = float(start)
        exact = {name: exact_rate(r) for name, r in rates.items()}
        base = Fraction(1)
        first = True
        for r in exact.values():
            base = r if first else _lcm_fraction(base, r)
            first = False
        self.base = base
        self._num = base.numerator
        self._den = base.denominator
        self.clocks = {}
        for name, r in exact.items():
            period = base / r
            assert period.denominator == 1
            self.clocks[name] = Clock(name, r, int(period))
        longest = max((c.period for c in self.clocks.values()), default=1)
        if max(self._num, self._den, longest) > _TICKS_MAX:
            given = ", ".join(f"{n} {float(r):.6g} Hz" for n, r in exact.items())
            raise ConfigError(f"the rates ({given}) have no common time base a 64-bit tick counter holds (it "
                              f"needs {float(base):.3g} ticks per s and periods of up to {longest:.3g} ticks): "
                              "use rates whose ratios are simpler, none slower than the run is long")

    def time(self, k):
        """Time in s of tick ``k`` (an int): ``t0 + k / base``, correctly rounded."""
        return self.start + (k * self._den) / self._num

    def ticks(self, duration):
        """Whole ticks in ``duration`` s (rounded down, with a tolerance of 1e-9 tick for decimal input)."""
        x = Fraction(repr(float(duration))) * self.base
        k = math.floor(x + Fraction(1, 10**9))
        if k * self._den > _TICKS_MAX:
            raise ConfigError(f"a run of {float(duration):.6g} s is {k:.3g} ticks of the time base "
                              f"({float(self.base):.6g} per s), more than a 64-bit tick counter holds: shorten it")
        return int(k)

    def instants(self, name, k_stop):
        """Number of instants of clock ``name`` in ``[0, k_stop)`` ticks."""
        p = self.clocks[name].period
        return (k_stop + p - 1) // p
