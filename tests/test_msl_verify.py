"""benchmarks/msl_verify.py's comparison with reference results, on hand-made results (no MSL needed): an error
it reports is the one computed by hand, and a comparison with no instant left (all near events) verifies
nothing."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))

from msl_verify import Row, compare, judge  # noqa: E402

# Every instant within a thousandth of the span (1 s) of an event: the rows at 0.5 and 0.5005 come twice.
T_EVENTS = np.array([0.5, 0.5, 0.5005, 0.5005])


def test_compare_gives_the_largest_error_relative_to_the_reference_range():
    t = np.linspace(0.0, 1.0, 101)
    # y_ref = 2 t (range 2), y = 2 t + 0.01 at every instant: 0.01 / 2
    assert compare(t, 2 * t, t, 2 * t + 0.01, 1.0) == pytest.approx(0.005, rel=1e-12)


def test_a_comparison_with_every_instant_near_an_event_is_none():
    y = np.array([0.0, 1.0, 1.0, 2.0])
    assert compare(T_EVENTS, y, T_EVENTS, y + 5.0, 1.0) is None  # off by 5, but nothing compared


def test_a_model_whose_signals_were_not_compared_is_not_verified():
    y = np.array([0.0, 1.0, 1.0, 2.0])
    result = {"time": T_EVENTS, "a": y, "b": y}
    row = judge(Row("M"), T_EVENTS, {"a": y, "b": y}, ["a", "b"], result, 1.0)
    assert row.stage == "uncompared" and "2 of 2 comparison signals not compared" in row.cause
    t = np.linspace(0.0, 1.0, 101)
    row = judge(Row("M"), t, {"a": t, "b": 2 * t}, ["a", "b"], {"time": t, "a": t, "b": 2 * t}, 1.0)
    assert row.stage == "verified" and row.worst_error == 0.0
