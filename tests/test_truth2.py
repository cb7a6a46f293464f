"""The second truth of the static staircase (tests/diagnose_truth2.py) against the first one's closed form.

The two are written from different formulations (a path-following equilibrium with Dahl and LuGre friction, a
compliant mesh with backlash, against Karnopp's stick/slip rule on a rigid drivetrain), so where both describe
the same physics their settled forces must agree: that checks the second truth's equations, not the diagnosis.
"""

import numpy as np
import pytest

from diagnose_truth import quasi_static_force, staircase
from diagnose_truth2 import cogging_table, make_case2, simulate

# Tolerance: Dahl's breakaway is gradual. Across a reversal the shaft turns a few presliding angles (0.5 mrad, about
# 0.2 N of force each through the chain's 0.27 N.m/rad at the motor) before it slides, so near Karnopp's threshold
# the force leaves the held value up to about 1 N early; elsewhere the two agree to 0.01 N. Steps are 5-15 N.
ATOL = 1.0


def _ends(current, per=70):
    return np.arange(per - 1, len(current), per)


@pytest.mark.parametrize("effect", ["none", "backdrive_efficiency", "load_dependent_friction"])
def test_settled_forces_match_the_stick_slip_rule(effect):
    t, i = staircase()
    _, _, _, truth = make_case2(effect, np.random.default_rng(11))
    y = simulate(truth, t, i)
    reference = quasi_static_force(i, truth["eta_d"], truth["T_c0"], eta_b=truth.get("eta_b"),
                                   mu_F=truth.get("mu_F", 0.0))
    ends = _ends(i)
    np.testing.assert_allclose(y[ends], reference[ends], atol=ATOL)


def test_load_cell_offset_and_second_order_settling():
    """The load cell adds its offset to the settled force; its second-order lag (f_lc >= 2 Hz, zeta >= 0.5)
    settles within the 0.7 s hold to under 1e-3 of the step."""
    t, i = staircase()
    _, _, _, truth = make_case2("loadcell_filter", np.random.default_rng(12))
    bare = {k: v for k, v in truth.items() if k not in ("f_lc", "zeta_lc", "F_off")}
    ends = _ends(i)
    np.testing.assert_allclose(simulate(truth, t, i)[ends] - simulate(bare, t, i)[ends], truth["F_off"], atol=0.05)


def test_cogging_table_is_periodic_with_its_peak():
    angles, torque = cogging_table(3e-3, 0.4)
    assert np.max(np.abs(torque)) == pytest.approx(3e-3)
    assert angles[-1] < 2 * np.pi / 24 and abs(np.mean(torque)) < 1e-4  # one slot pitch, no mean torque
