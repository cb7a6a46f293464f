"""The discrepancy workflow on impacts: the coating_relaxation effect, and hidden effects in an independent truth.

Hidden-effect data come from ``diagnose_truth_impact.py``: a reduced gripper written from the paper's equations in
numpy (Karnopp and Dahl frictions, a dead-band spring, a Prony coating), not from the Modelica, with random
parameters, a 100 Hz load cell with 0.5 N noise and a 2048 cpt encoder; its cogging is a tabulated detent energy
with a second harmonic. The workflow compares F_g and theta_m of
Gripper.GripperCurrentDriven, must name the effect the truth contains ("none" when it contains none), and the named
effect must cut the force gap above the noise by at least 80 %.
"""

import math
import tempfile

import numpy as np
import pytest

from cosim.compile import lower
from cosim.diagnose import EFFECTS, load_diagnose_job, run_diagnosis, write_variant
from cosim.diagnose.analysis import noise_level, quiet_phases
from cosim.diagnose.effects import applicable
from cosim.diagnose.fitting import Replay
from cosim.experiment import Experiment
from diagnose_truth_impact import (CONDITION, COUNTS, CURRENT_NOISE, DURATION, F_GUIDE, FORCE_NOISE, I_STEP,
                                   PLAY_NOMINAL, RATE_HZ, SLIDE_GAP0, SLIDE_PROFILE, T_STEP, make_case, simulate,
                                   write_job)
from test_gripper_support import ROOT

pytestmark = pytest.mark.slow  # lowered gripper variants, numpy truths at 10 us steps, diagnosis fits

SOURCE = ROOT / "modelica" / "Gripper" / "package.mo"
MODEL = "Gripper.GripperCurrentDriven"
BARE = {"gap0": 0.005, "t_coat": 0.0, "k_obj": 3.53e7, "k_P": 1e12, "C_p": 2000.0, "C_h": 2000.0}
COUNT = 2 * math.pi / COUNTS  # rad, one encoder count
LIBRARY = applicable(SOURCE.read_text(encoding="utf-8"), MODEL)  # every effect that applies
SPEED_LIBRARY = applicable(SOURCE.read_text(encoding="utf-8"), "Gripper.GripperSpeedControlled")


def _experiment():
    """The truth's current step on its sampling instants, for replays of the Modelica."""
    t = np.arange(int(round(DURATION * RATE_HZ))) / RATE_HZ
    i = np.where(t >= T_STEP - 1e-12, I_STEP, 0.0)
    return Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 2)), weights=np.ones(2),
                      mask=np.ones(len(t), bool))


@pytest.fixture(scope="module")
def relaxing():
    """The coating_relaxation variant of GripperCurrentDriven, lowered."""
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(SOURCE, MODEL, EFFECTS["coating_relaxation"], folder)
        return lower(path, name)


def test_coating_relaxation_variant_exposes_parameters_and_is_neutral_at_k_rel_0(relaxing):
    """k_rel = 0 is the baseline on coated (P2) fingers; k_rel = 1 stiffens the impact and the held force then
    relaxes; on bare fingers the branch has nothing to relax (tolerances: CVODES rtol 1e-8 on forces of ~60 N)."""
    assert {"k_rel", "tau_rel"} <= {p.name for p in relaxing.parameters}
    e = _experiment()
    base = lower(SOURCE, MODEL)
    for condition in (CONDITION, BARE):
        before = Replay(base, e, ["F_g", "theta_m"], ["eta_g"], [1.0], dict(condition), rtol=1e-8).outputs([0.68])
        variant = Replay(relaxing, e, ["F_g", "theta_m"], ["k_rel", "tau_rel"], [1.0, 1.0], dict(condition),
                         rtol=1e-8)
        np.testing.assert_allclose(variant.outputs([0.0, 0.1]), before, atol=1e-3)
        relaxed = variant.outputs([1.0, 0.1])
        if condition is BARE:
            np.testing.assert_allclose(relaxed, before, atol=1e-2)
        else:
            force = relaxed[0]
            assert abs(force[-1] - before[0][-1]) > 5.0  # N: a different held force
            assert force[30] - force[-1] > 1.0  # N: decaying between 0.3 s and 1 s


def test_truth_baseline_agrees_with_the_modelica_baseline():
    """Model-form gap: the truth without effect against the Modelica baseline at the same (nominal) parameters.
    Measured: force RMSE 0.15 N (the load-cell noise is 0.5 N), angle RMSE 1.0 count."""
    _, _, force, angle = simulate()
    e = _experiment()
    y = Replay(lower(SOURCE, MODEL), e, ["F_g", "theta_m"], ["eta_g"], [1.0], dict(CONDITION),
               rtol=1e-8).outputs([0.68])
    assert np.sqrt(np.mean((force - y[0]) ** 2)) < 0.5 * FORCE_NOISE
    assert np.sqrt(np.mean((angle - y[1]) ** 2)) < 2 * COUNT
    assert np.max(np.abs(force - y[0])) < 4 * FORCE_NOISE


def test_jaw_stiction_does_not_show_in_the_impact():
    """Why stiction has no hidden-effect case here: a 10 N breakaway in the jaw guides (127x the sliding level)
    changes the truth's force record by less than the load-cell noise; the rack pushes the jaw with ~34 N and,
    once clamped, the gear's holding band, not the guide, holds the force."""
    _, _, force, angle = simulate()
    _, _, sticky, sticky_angle = simulate(F_s=10.0)
    assert np.sqrt(np.mean((sticky - force) ** 2)) < FORCE_NOISE
    assert np.sqrt(np.mean((sticky_angle - angle) ** 2)) < 3 * COUNT


def _restarts(t, angle, after=(0.25, 0.9), counts=5):
    """First instant after each time in ``after`` at which the motor has turned ``counts`` counts past its angle
    there: when the slide's jaws restart after a stop."""
    return [t[np.argmax((t > t0) & (angle > angle[np.searchsorted(t, t0)] + counts * COUNT))] for t0 in after]


@pytest.mark.parametrize("eta, T_c0, F_s", [(0.68, 7.88e-3, 4.0), (0.68, 7.88e-3, 8.0), (0.631, 8.34e-3, 8.33)])
def test_stiction_variant_restarts_the_jaws_when_the_truth_does(eta, T_c0, F_s):
    """The slide (two stops, then ramps of the current that restart the jaws against their guides), the current
    and encoder at 1 kHz: the truth's Karnopp breakaway holds the jaws until the rack force reaches F_s; the
    stiction variant at the same values restarts them within 10 ms of the truth and follows its angle within 40
    counts RMS, the baseline (Coulomb guide) restarts them as soon as the motor's drag is overcome. The third case
    (a slow motor: low efficiency, high drag) is stick-slip: the truth's jaw chatters along the play's flank and
    rests off it at the first stop, so its first restart is the motor running free through the play at the drag
    current (0.24 A) and hammering the jaw loose. Measured: the variant 0-5 ms early, angle RMS 7.5, 13.1 and
    23.6 counts (before its friction was made continuous in time and its bristle fast: 6-12 ms early, 111 and 138
    counts at 4 and 8 N, 160 ms late on the chatter case); the baseline 409, 1602 and 580 counts, its second
    restart 52-135 ms early."""
    t, i, _, theta = simulate(eta=eta, T_c0=T_c0, F_s=F_s, gap0=SLIDE_GAP0, profile=SLIDE_PROFILE,
                              duration=SLIDE_PROFILE[-1][0], rate_hz=1000.0)
    e = Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 2)), weights=np.ones(2),
                   mask=np.ones(len(t), bool))
    fixed = {**CONDITION, "gap0": SLIDE_GAP0, "play": PLAY_NOMINAL, "T_c0": T_c0}
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(SOURCE, MODEL, EFFECTS["stiction"], folder)
        sticky = Replay(lower(path, name), e, ["F_g", "theta_m"], ["F_sj", "eta_g"], [1.0, 1.0], fixed,
                        rtol=1e-6).outputs([F_s, eta])
    base = Replay(lower(SOURCE, MODEL), e, ["F_g", "theta_m"], ["eta_g"], [1.0], fixed, rtol=1e-6).outputs([eta])
    truth = _restarts(t, theta)
    for when, now in zip(truth, _restarts(t, sticky[1])):
        assert abs(now - when) <= 0.01, (truth, _restarts(t, sticky[1]))
    assert np.sqrt(np.mean((sticky[1] - theta) ** 2)) < 40 * COUNT
    assert _restarts(t, base[1])[1] <= truth[1] - 0.04, (truth, _restarts(t, base[1]))
    assert np.sqrt(np.mean((base[1] - theta) ** 2)) > 100 * COUNT


def test_impact_noise_is_estimated_from_the_approach_and_the_hold():
    """The truth's impacts (100 Hz load cell, 0.5 N noise): differences of every sample include the impact's
    and the rebound's, which inflate the robust scale (measured: mean 0.594 N over 16 draws); those of the
    approach and the steady hold alone are noise (mean 0.518 N; one draw 0.46-0.61 N)."""
    rng = np.random.default_rng(4)
    every, quiet = [], []
    for _ in range(16):
        (t, _, force, _, _), = make_case("none", rng)[0]
        rough = noise_level(t, force[None, :], np.ones(len(t), bool))[0]
        every.append(rough)
        quiet.append(noise_level(t, force[None, :], quiet_phases(t, force, rough))[0])
    assert abs(np.mean(quiet) - FORCE_NOISE) < 0.05 * FORCE_NOISE
    assert np.mean(every) > 1.1 * FORCE_NOISE


def test_repeated_trials_are_replayed_each_with_its_own_fixed_values(tmp_path):
    """Two impacts on an object placed at two distances (7.5 and 6 mm of travel), diagnosed together as records:
    with each trial's gap0 given in data.records the baseline fits both within the noise; with the 7.5 mm of
    [model] for both, the second trial's early contact is a gap, largest in that record's segments."""
    rng = np.random.default_rng(5)
    records = []
    for gap0 in (CONDITION["gap0"], 0.006):
        t, i, force, theta = simulate(gap0=gap0)
        records.append((t, i, force + rng.normal(0.0, FORCE_NOISE, len(t)),
                        np.floor(theta / COUNT) * COUNT, {"gap0": gap0}))
    path = write_job(tmp_path, SOURCE, (records, {}), [], workers=0)
    text = path.read_text()
    s = run_diagnosis(load_diagnose_job(path), progress=False, build=False).to_json()
    assert [r["parameters"] for r in s["records"]] == [{"gap0": CONDITION["gap0"]}, {"gap0": 0.006}]
    force_rows = [r for r in s["segments"] if r["signal"] == "F_g"]  # a row per segment and compared signal
    assert len(force_rows) == 8 and force_rows[4]["segment"] == "record 1 (data1.csv): approach"
    assert not s["gap_found"], s["verdict"]
    assert s["rmse_before"] < 1.3 * FORCE_NOISE
    path.write_text(text.replace("parameters = { gap0 = 0.006 }", "parameters = {}"))
    s = run_diagnosis(load_diagnose_job(path), progress=False, build=False).to_json()
    assert s["gap_found"] and s["rmse_before"] > 3 * FORCE_NOISE
    worst = max(s["segments"], key=lambda r: r["sigmas"])  # the shared fit spreads some of it over record 0
    assert worst["segment"].startswith("record 1"), worst


def test_multi_rate_data_are_compared_where_every_channel_was_sampled(tmp_path):
    """A 1 kHz log (current, encoder) beside a 100 Hz load cell, NaN between its samples: the inputs are played
    at 1 kHz, the fit and its statistics use the instants where both channels were sampled. The independent
    reference is the same diagnosis of the 100 Hz rows alone: same noise estimate, same verdict, the same fit
    (up to the CVODES steps, which the denser output instants change; rtol 1e-6)."""
    rng = np.random.default_rng(9)
    t, i, force, theta = simulate(play=math.radians(1.4), rate_hz=1000.0)
    slow = np.arange(len(t)) % 10 == 0
    force = np.where(slow, force + rng.normal(0.0, FORCE_NOISE, len(t)), np.nan)
    angle = np.floor(theta / COUNT) * COUNT
    summaries = []
    for rows in (np.ones(len(t), bool), slow):
        folder = tmp_path / ("1kHz" if rows.all() else "100Hz")
        folder.mkdir()
        case = ([(t[rows], i[rows], force[rows], angle[rows], {})], {})
        job = load_diagnose_job(write_job(folder, SOURCE, case, ["gear_play"], workers=0))
        summaries.append(run_diagnosis(job, progress=False, build=False).to_json())
    mixed, single = summaries
    assert mixed["effect"] == single["effect"] == "gear_play", (mixed["verdict"], single["verdict"])
    np.testing.assert_allclose(mixed["noise"]["estimated"], single["noise"]["estimated"], rtol=1e-12)
    assert [r["segment"] for r in mixed["segments"]] == [r["segment"] for r in single["segments"]]
    assert [r["samples"] for r in mixed["segments"]] == [r["samples"] for r in single["segments"]]
    for key in ("rmse_before", "rmse_after"):
        assert abs(mixed[key] - single[key]) < 0.02 * FORCE_NOISE, key
    assert abs(mixed["after"]["parameters"]["play"] - single["after"]["parameters"]["play"]) < 0.01 * math.radians(1.4)


def test_shipped_repeated_trials_job_loads_three_multi_rate_records():
    """examples/diagnose_impact_trials.toml: three trials, each with its object position, 1 kHz rows with the
    100 Hz load cell between them (its runs are in docs/dev/diagnose-history.md)."""
    from cosim.diagnose.job import load_records

    job = load_diagnose_job(ROOT / "examples" / "diagnose_impact_trials.toml")
    records = load_records(job, lower(SOURCE, MODEL))
    assert [trial["gap0"] for _, trial in records] == [0.002, 0.002028, 0.002056]
    for e, _ in records:
        assert len(e.time) == 500 and np.isfinite(e.measured[:, 0]).sum() == 50
        assert np.isfinite(e.measured[:, 1]).all() and np.isfinite(e.inputs).all()


def test_shipped_speed_job_loads_the_speed_run():
    """examples/diagnose_speed.toml: the speed-controlled model with the loop's gains, one 1 kHz record of the speed
    reference, current and encoder angle, cut into its four speed holds (its runs are in docs/dev/diagnose-history.md)."""
    from cosim.diagnose.analysis import hold_segments
    from cosim.diagnose.job import load_records

    job = load_diagnose_job(ROOT / "examples" / "diagnose_speed.toml")
    assert job.fixed["K_pw"] == 0.05 and job.fixed["K_iw"] == 2.5
    [(e, _)] = load_records(job, lower(SOURCE, "Gripper.GripperSpeedControlled"))
    assert len(e.time) == 1450 and np.isfinite(e.measured).all()
    holds = hold_segments(e.time, e.inputs, job.min_hold_s)
    assert [h.level for h in holds] == [2.0, 3.5, 2.5, 4.0]


# One random case per effect, each offered the whole effect library of the model. The seeds here and in the slide's
# and the speed run's tests were drawn once at random (python -c "import secrets; print(secrets.randbelow(2**31))"),
# not picked for the workflow's success; a failing draw is a finding, not a reason to draw again. Cogging is
# diagnosed over three repeated impacts (one impact sees the detent torque at one rest angle); that case also builds
# both FMUs and re-runs every record through the master.
@pytest.mark.parametrize("effect, seed, trials", [
    ("gear_play", 758604987, 1),
    ("contact_damping", 1424536644, 1),
    ("coating_relaxation", 1660404856, 1),
    # finding of the drawn seed (docs/dev/diagnose-history.md, "Speed (issue 32)"): the baseline fits the three
    # impacts within the noise (mean square 0.706 noise levels squared), so no gap is found and "none" is answered
    pytest.param("cogging", 1974176483, 3, marks=[pytest.mark.finding,
                                                   pytest.mark.xfail(strict=True, reason="detent below the noise")]),
    ("load_dependent_friction", 847392348, 1),
    ("none", 1955914767, 1),
])
def test_workflow_names_the_hidden_impact_effect(effect, seed, trials, tmp_path):
    case = make_case(effect, np.random.default_rng(seed), trials=trials)
    truth = case[1]
    job = load_diagnose_job(write_job(tmp_path, SOURCE, case, LIBRARY, workers=0))
    rebuild = trials > 1
    s = run_diagnosis(job, progress=False, build=rebuild, out=tmp_path / "out").to_json()
    assert s["effect"] == effect, s["verdict"]
    # the force noise from ~100 differences: the robust scale alone spreads by ~12 % (1 sd), the impact adds more
    np.testing.assert_allclose(s["noise"]["used"], [FORCE_NOISE, COUNT], rtol=0.3)
    if effect == "none":
        return
    assert s["gap_removed"] >= 0.8
    assert s["rmse_after_per_signal"][1] < s["rmse_before_per_signal"][1]  # the angle improves as well
    fitted = s["after"]["parameters"]
    assert abs(fitted["eta_g"] - truth["eta_g"]) < 0.03
    if effect == "gear_play":
        assert abs(fitted["play"] - truth["play"]) < 0.1 * truth["play"]
    elif effect == "coating_relaxation":
        assert abs(fitted["k_rel"] - truth["k_rel"]) < 0.2 * truth["k_rel"]
        assert abs(fitted["tau_rel"] - truth["tau_rel"]) < 0.25 * truth["tau_rel"]
    elif effect == "load_dependent_friction":
        assert abs(fitted["mu_F"] - truth["mu_F"]) < 0.5 * truth["mu_F"]
    elif effect == "cogging":  # the candidate's one sinusoid also takes up the truth's second harmonic
        assert abs(fitted["T_cog"] - truth["T_cog"]) < 0.4 * truth["T_cog"]
    if rebuild:  # the FMUs through the master, record by record, against the CVODES replay of the same equations
        r = s["rerun"]
        assert sorted(p.parent.name for p in (tmp_path / "out" / "rerun").glob("record*/cogging.toml")) == \
            ["record0", "record1", "record2"]
        assert abs(r["rmse_after"] - s["rmse_after"]) < 0.1 * FORCE_NOISE
        assert r["rmse_after"] < r["rmse_before"]
    # contact_damping: the truth's law c_hc*pen^p_hc*v has no parameter in common with lambda_hc*F_s*v


@pytest.mark.finding
@pytest.mark.xfail(strict=True, reason="finding (issue 32): with the whole library offered and every candidate fitted "
                   "(the screen ranked stiction low; the fits go on in its order while the gap is unexplained), "
                   "stiction's fold fits from the screen's best start find the breakaway (F_sj 7.13 N, truth 6.91 N) "
                   "but not the sliding level (F_cj 0.26 N), and remove 48 % of the held-out gap, under the 50 % "
                   "needed; a gap of ~105 noise levels is reported as unexplained")
def test_workflow_names_guide_stiction_on_the_slide(tmp_path):
    """The slide (1 kHz current and encoder, the 100 Hz load cell), a Karnopp breakaway in the truth's guides: the
    stiction candidate (a Stribeck bristle, not the truth's rule) is named, removes >= 80 % of the force gap above
    the noise and brings the angle back from over 30 counts RMS to under 5, with the breakaway level within 5 % and
    the sliding level within 0.05 N. Two Dask workers: the stiff bristle makes the fits slow. The whole library is
    offered; the benchmark (``--experiment slide``) also runs the no-effect cases."""
    case = make_case("stiction", np.random.default_rng(2077593043), experiment="slide")
    truth = case[1]
    job = load_diagnose_job(write_job(tmp_path, SOURCE, case, LIBRARY, workers=2, experiment="slide"))
    s = run_diagnosis(job, progress=False, build=False).to_json()
    assert s["effect"] == "stiction", s["verdict"]
    assert s["gap_removed"] >= 0.8
    assert s["rmse_before_per_signal"][1] > 30 * COUNT and s["rmse_after_per_signal"][1] < 5 * COUNT
    fitted = s["after"]["parameters"]
    assert abs(fitted["F_sj"] - truth["F_sj"]) < 0.05 * truth["F_sj"]
    assert abs(fitted["F_cj"] - F_GUIDE) < 0.05


def test_workflow_names_cogging_on_the_speed_run(tmp_path):
    """Where an impact hardly sees a detent (the rotor runs through it fast and rests at a few angles), a slow run
    under a PI speed loop shows it as a ripple of the current the loop takes, phase-locked to the rotor angle:
    the truth's tabulated detent energy (fundamental and a second harmonic) against the cogging candidate (one
    sinusoid) on Gripper.GripperSpeedControlled. Named, >= 80 % of the gap above the noise removed, the current
    brought to within 1.5 times its noise and the fundamental's amplitude within 10 % and phase within 0.1 rad
    (the second harmonic, 10-30 % of it, is left). The whole library of the speed-controlled model is offered."""
    case = make_case("cogging", np.random.default_rng(590588296), experiment="speed")
    truth = case[1]
    job = load_diagnose_job(write_job(tmp_path, SOURCE, case, SPEED_LIBRARY, workers=0, experiment="speed"))
    s = run_diagnosis(job, progress=False, build=False).to_json()
    assert s["effect"] == "cogging", s["verdict"]
    assert s["gap_removed"] >= 0.8
    assert s["rmse_before_per_signal"][0] > 3 * CURRENT_NOISE
    assert s["rmse_after_per_signal"][0] < 1.5 * CURRENT_NOISE
    fitted = s["after"]["parameters"]
    assert abs(fitted["T_cog"] - truth["T_cog"]) < 0.1 * truth["T_cog"]
    assert abs(fitted["phase_cog"] - truth["phase_cog"]) < 0.1
