"""How a sequence of rounds ends (issue 51, item 0), on frequency responses of a haptic plant with two hidden effects:
a second mode and a loop delay (``diagnose_truth_haptic``: the plant written independently of the Modelica device,
the identification experiment simulated and Welch-estimated), and, in most cases, a phase error of 10 degrees over
60-75 Hz (a sensor's, say) that no candidate explains.

The endings: two findings, then a third round that names nothing (the check of the findings against each other then
starts from that round's baseline fit; this path once ended the whole run in a TypeError); the rounds capped at two
with a gap left; no candidate left to offer after two with a gap left; what two findings leave within the noise. A
form then an effect is tests/test_diagnose_forms.py's ``test_a_form_and_an_effect_are_found_in_two_rounds``.
"""

import numpy as np
import pytest

from cosim.diagnose import load_diagnose_job, run_diagnosis
from diagnose_truth_haptic import FS, delayed_response, measure, random_plant, second_mode_ss, write_job

SEED = 1563035938  # drawn once (secrets.randbelow(2**31)), not chosen
BAND = (60.0, 75.0)  # Hz, where the phase error is
PHASE_ERROR = 10.0  # deg
EFFECTS = ["vibration_mode", "loop_delay"]


def _two_effects(phase_error):
    """The measured table of a 7-parameter plant with a second mode whose torque is delayed by T (0.5-3 ms), and
    ``phase_error`` [deg] added over ``BAND``; and the truth."""
    rng = np.random.default_rng(SEED)
    _, truth = random_plant("vibration_mode", rng)
    truth["T"] = rng.uniform(0.5e-3, 3e-3)
    A, B, C, _ = second_mode_ss(truth)
    frame = measure(lambda u: delayed_response(A, B, C, u, FS, truth["T"]), int(rng.integers(1 << 30)))
    inside = (frame["frequency"] >= BAND[0]) & (frame["frequency"] <= BAND[1])
    frame.loc[inside, "phase_deg"] += phase_error
    return frame, truth


@pytest.mark.slow
@pytest.mark.parametrize("offered, rounds, phase_error, named, tail", [
    (EFFECTS + ["hand_mass"], 3, PHASE_ERROR, 3, "remains that no candidate explains (largest in band"),
    (EFFECTS + ["hand_mass"], 2, PHASE_ERROR, 2, "remains after 2 rounds (the job's decision.rounds)"),
    (EFFECTS, 3, PHASE_ERROR, 2, "remains after 2 rounds and no candidate is left to offer"),
    (EFFECTS + ["hand_mass"], 3, 0.0, 2, "what remains is within the noise"),
], ids=["nothing named third", "cap reached", "none left to offer", "within the noise"])
def test_how_the_rounds_end(offered, rounds, phase_error, named, tail, tmp_path):
    """Both effects found, one a round, neither dropped, with the truth's mode frequency (3 %) and delay (5 %, 10 %
    with the phase error, which the delay partly takes); the verdict says how the rounds ended."""
    frame, truth = _two_effects(phase_error)
    path = write_job(tmp_path, frame, offered)
    path.write_text(path.read_text(encoding="utf-8") + f"[decision]\nrounds = {rounds}\n", encoding="utf-8")
    d = run_diagnosis(load_diagnose_job(path), progress=False, build=False)
    assert sorted(d.findings) == sorted(EFFECTS) and not any(r.dropped for r in d.rounds), d.verdict
    assert len(d.rounds) == named and [r.effect for r in d.rounds[2:]] == ["none"] * (named - 2), d.verdict
    assert d.verdict.startswith(f"found in {named} rounds: ") and tail in d.verdict, d.verdict
    fitted = d.after_parameters
    np.testing.assert_allclose(np.sqrt(fitted["k3"] / fitted["m3"]) / (2 * np.pi), truth["f3"], rtol=0.03)
    np.testing.assert_allclose(fitted["T_d"], truth["T"], rtol=0.1 if phase_error else 0.05)
