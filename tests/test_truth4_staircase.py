"""The fourth truth of the static staircase (``diagnose_truth4_staircase.py``) against closed forms: the first
truth's kinetic tightening balance, the static band of its own friction laws, the load cell's settled offset, and
the size of every hidden effect. Its laws are checked on their own in ``tests/test_truth4_impact.py`` (the same
plant). No diagnosis is run on this truth here: it is reserved for the evaluation of issue #42.

The draws come from the seed 1095907558 (drawn once with ``python -c "import secrets;
print(secrets.randbelow(2**31))"``), not picked. Each staircase record takes 2.5-3.5 s on the loaded machine:
the tests run few of them and are marked slow where they run several.
"""

import numpy as np
import pytest

import diagnose_truth2
import diagnose_truth4_staircase as truth4
from diagnose_truth import F_GUIDE, GAIN, K_T, make_case, quasi_static_force, staircase
from diagnose_truth4_impact import BS_EPS, BS_ETA, BS_P

SEED = 1095907558
TIME, CURRENT = staircase()
ENDS = np.arange(69, len(CURRENT), 70)  # the last sample of each level
PATH = np.linspace(0.0, 10 * BS_EPS, 100001)
# the Bliman-Sorine friction's peak over its Coulomb level (closed form of the states from rest)
PEAK = ((1 + BS_P) * (1 - np.exp(-PATH / (BS_ETA * BS_EPS))) - BS_P * (1 - np.exp(-PATH / BS_EPS))).max()


@pytest.mark.slow
@pytest.mark.parametrize("effect", ["none", "backdrive_efficiency", "load_dependent_friction"])
def test_held_forces_lie_in_the_static_band_and_tightening_follows_the_kinetic_balance(effect):
    """At the end of every level the contact force lies in the closed-form static band of the motor friction's
    peak ``PEAK`` (tightening limit ``(K_T i - PEAK T_c0)/(1 + PEAK (1/eta - 1))``, back-driving limit ``(K_T i +
    PEAK T_c0)/(1 - PEAK (1 - eta_b))``, times GAIN, with the guides' ``1.5 F_guide`` and ``mu_F``). On the rising
    levels after the first it is the first truth's kinetic stick/slip rule (``quasi_static_force``) within 1 N (the
    drivetrain's rebound after each ramp; the first level holds the play's closing impact, about 3 N more)."""
    truth = truth4.draw_truth(effect, np.random.default_rng(SEED))
    _, contact, _ = truth4.simulate(truth, TIME, CURRENT)
    eta, eta_b, T_c0, mu_F = truth["eta_d"], truth.get("eta_b", truth["eta_d"]), truth["T_c0"], truth.get("mu_F", 0.0)
    i, held = CURRENT[ENDS], contact[ENDS]
    low = ((K_T * i - PEAK * T_c0) / (1 + PEAK * (1 / eta - 1)) * GAIN - 1.5 * F_GUIDE) / (1 + mu_F)
    high = ((K_T * i + PEAK * T_c0) / (1 - PEAK * (1 - eta_b)) * GAIN + 1.5 * F_GUIDE) / (1 - mu_F)
    assert np.all(held >= np.maximum(low, 0.0)) and np.all(held <= high), (held, low, high)
    kinetic = quasi_static_force(CURRENT, eta, T_c0, eta_b=eta_b, mu_F=mu_F)[ENDS]
    np.testing.assert_allclose(held[2:6], kinetic[2:6], atol=1.0)


def test_load_cell_reads_the_settled_force_plus_its_offset():
    """With the effect the converter's sinc^3 window (37-300 ms) has passed by the end of each 0.7 s level: the
    reading there is the contact force plus the drawn offset (0.05 N: the force's creep within the window)."""
    truth = truth4.draw_truth("loadcell_filter", np.random.default_rng(SEED))
    reading, contact, _ = truth4.simulate(truth, TIME, CURRENT)
    np.testing.assert_allclose(reading[ENDS] - contact[ENDS], truth["F_off"], atol=0.05)


@pytest.mark.slow
def test_a_seed_gives_the_same_case_and_the_other_staircase_truths_drivetrain():
    """One seed: the same record twice, and the same ``eta_d`` and ``T_c0`` as the first and second staircase
    truths' cases (drawn first, in the same order)."""
    one = truth4.make_case4("backdrive_efficiency", np.random.default_rng(SEED))
    two = truth4.make_case4("backdrive_efficiency", np.random.default_rng(SEED))
    for a, b in zip(one[:3], two[:3]):
        np.testing.assert_array_equal(a, b)
    first = make_case("backdrive_efficiency", np.random.default_rng(SEED))[3]
    second = diagnose_truth2.make_case2("none", np.random.default_rng(SEED))[3]
    for key in ("eta_d", "T_c0"):
        assert one[3][key] == first[key] == second[key]
    assert len(one[0]) == len(TIME) and np.all(np.isfinite(one[2]))


@pytest.mark.slow
@pytest.mark.parametrize("effect", truth4.TRUTH4_STAIRCASE_EFFECTS)
def test_every_effect_changes_the_record_measurably(effect):
    """Each hidden effect, drawn from the seed, changes the noise-free reading by more than a fifth of the case's
    noise (RMS); ``none`` changes nothing."""
    truth = truth4.draw_truth(effect, np.random.default_rng(SEED))
    base = {k: truth[k] for k in ("effect", "eta_d", "T_c0", "noise")}
    change = truth4.simulate(truth, TIME, CURRENT)[0] - truth4.simulate(base, TIME, CURRENT)[0]
    rms = float(np.sqrt(np.mean(change ** 2)))
    if effect == "none":
        assert rms == 0.0
    else:
        assert rms > 0.2 * truth["noise"], (rms, truth["noise"])
