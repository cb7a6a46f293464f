"""The discrepancy workflow (cosim diagnose): effect library, residual analysis, bad input, and hidden-effect cases.

Hidden-effect data come from ``diagnose_truth.py``: a quasi-static stick/slip gripper written independently of the
Modelica plant and of the candidates (no ODE, no bristles), with random parameters and load-cell noise. The
workflow must name the effect the truth contains, say "none" when it contains none, and the named effect must cut
the gap above the noise by at least 80 %.
"""

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from cosim.diagnose import EFFECTS, load_diagnose_job, run_diagnosis
from cosim.diagnose.analysis import _best_lag, hold_segments, noise_level, whiteness
from cosim.diagnose.effects import applicable, variant_text
from cosim.diagnose.workflow import rivals_of
from cosim.errors import ConfigError
from cosim.experiment import steady_mask
from diagnose_truth import SOURCE, make_case, write_job

CANDIDATES = ("backdrive_efficiency", "loadcell_filter")
EXPECTED = {"Gripper.GripperCurrentDriven": ["backdrive_efficiency", "load_dependent_friction", "stiction", "cogging",
                                             "loadcell_filter", "contact_damping", "gear_play", "coating_relaxation"]}
LIBRARY = applicable(SOURCE.read_text(encoding="utf-8"), "Gripper.GripperCurrentDriven")  # every effect that applies


def _write_job(folder, frame, effects=CANDIDATES, workers=2, extra=""):
    return write_job(folder, frame, effects, workers, extra)


def _case_frame(effect, seed, noise=0.3):
    t, i, y, truth = make_case(effect, np.random.default_rng(seed), noise=noise)
    return pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), truth


# -- effect library ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", EXPECTED["Gripper.GripperCurrentDriven"])
@pytest.mark.slow
def test_every_effect_variant_lowers_with_its_parameters(name, tmp_path):
    """Each variant of GripperCurrentDriven builds (rumoca + lowering) and exposes the effect's parameters; the
    baseline part of the source is unchanged (the variant only adds a Diagnosis sub-package)."""
    from cosim.compile import lower
    from cosim.diagnose import write_variant

    path, model = write_variant(SOURCE, "Gripper.GripperCurrentDriven", EFFECTS[name], tmp_path)
    lowered = lower(path, model)
    names = {p.name for p in lowered.parameters}
    assert {p.name for p in EFFECTS[name].parameters} <= names
    assert {n for n, _, _ in EFFECTS[name].frees} <= names
    original = SOURCE.read_text(encoding="utf-8")
    assert path.read_text(encoding="utf-8").startswith(original.rpartition("end Gripper;")[0])


@pytest.mark.slow
def test_variant_without_effect_parameters_reproduces_the_baseline(tmp_path):
    """backdrive_efficiency with eta_b = eta_g is the baseline: same outputs along a staircase (the variant's
    extra branch is the same expression; tolerance: CVODES rtol 1e-8 on forces of ~40 N)."""
    from cosim.experiment import Experiment
    from cosim.compile import lower
    from cosim.diagnose import write_variant
    from cosim.diagnose.fitting import Replay
    from diagnose_truth import staircase

    t, i = staircase()
    e = Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 1)), weights=np.ones(1),
                   mask=np.ones(len(t), bool))
    fixed = {"gap0": 0.0, "play": 0.0, "k_obj": 1.2e9}
    base = Replay(lower(SOURCE, "Gripper.GripperCurrentDriven"), e, ["F_g"], ["eta_g"], [1.0], fixed, rtol=1e-8)
    path, name = write_variant(SOURCE, "Gripper.GripperCurrentDriven", EFFECTS["backdrive_efficiency"], tmp_path)
    var = Replay(lower(path, name), e, ["F_g"], ["eta_g", "eta_b"], [1.0, 1.0], fixed, rtol=1e-8)
    np.testing.assert_allclose(var.outputs([0.7, 0.7]), base.outputs([0.7]), atol=1e-4)
    released = var.outputs([0.7, 0.5])[0]
    assert released[-1] > base.outputs([0.7])[0][-1] + 5  # harder back-driving holds more force at 0 A


def test_effect_that_does_not_apply_is_a_clear_error():
    text = SOURCE.read_text(encoding="utf-8")
    with pytest.raises(ConfigError, match="does not apply to Gripper.PMSM"):
        variant_text(text, "Gripper.PMSM", EFFECTS["loadcell_filter"])


# -- residual analysis -----------------------------------------------------------------------------------------

def test_noise_level_from_the_data():
    """White noise of sd 0.3 on a staircase: the difference-based MAD estimate is within 10 % (4000 samples:
    the estimator's relative sd is about 2 %)."""
    rng = np.random.default_rng(0)
    t = np.arange(4000) * 0.01
    u = np.repeat(np.arange(10.0), 400)[:, None]
    y = 5 * u[:, 0] + rng.normal(0, 0.3, len(t))
    est = noise_level(t, y[None, :], steady_mask(t, u, 2.0))
    np.testing.assert_allclose(est, [0.3], rtol=0.1)


def test_whiteness_tells_white_from_coloured():
    rng = np.random.default_rng(1)
    e = rng.normal(size=2000)
    ar = np.empty_like(e)
    ar[0] = e[0]
    for k in range(1, len(e)):
        ar[k] = 0.8 * ar[k - 1] + e[k]
    assert whiteness(e)["white"]
    assert not whiteness(ar)["white"]


def test_lag_of_a_delayed_record_and_of_one_that_stands_still():
    """A record 4 samples behind the prediction is found 4 samples late (the shape "phase lag"); a prediction that
    moves only outside the compared window (an angle standing still, as an encoder's can over a segment) gives
    lag 0 rather than an all-NaN correlation."""
    n = np.arange(204)
    s = np.sin(0.07 * n) + 0.3 * np.sin(0.23 * n)
    assert _best_lag(s[:-4], s[4:]) == 4
    still = np.zeros(200)
    still[:10] = 1.0
    assert _best_lag(s[:200], still) == 0


def test_staircase_segments_are_the_holds():
    t = np.arange(600) * 0.01
    u = np.repeat([0.0, 1.0, 2.0, 1.0, 0.0, 0.0], 100)[:, None]
    segs = hold_segments(t, u)
    assert [s.kind for s in segs] == ["hold", "up", "up", "down", "down"]
    assert [s.level for s in segs] == [0.0, 1.0, 2.0, 1.0, 0.0]


def test_linearised_fit_of_a_linear_replay_is_its_least_squares_fit():
    """The screen's one Gauss-Newton step is exact on outputs linear in the parameters: the predicted chi-square is
    the least-squares minimum (numpy's lstsq), with a bound active the fit of the other column alone; a column given
    (the baseline's from its fit) is used instead of a difference."""
    from cosim.diagnose.fitting import LinearisedFit
    from cosim.fitting import FreeParameter

    rng = np.random.default_rng(3)
    a = rng.normal(size=(2, 40))
    replay = SimpleNamespace(free=["p", "q"], scale=np.array([2.0, 0.5]),
                             evaluate=lambda x: (a.T @ (x * np.array([2.0, 0.5])))[None, :])
    measured = (a.T @ [1.0, -0.3])[None, :] + rng.normal(0.0, 0.1, (1, 40))
    weights, mask = np.array([10.0]), np.ones(40, bool)
    wide = {"p": FreeParameter(0.5, -5.0, 5.0), "q": FreeParameter(0.5, -5.0, 5.0)}
    free = LinearisedFit(replay, weights, mask, wide, {}).fit(measured)
    best = np.linalg.lstsq(10 * a.T, 10 * measured[0], rcond=None)
    np.testing.assert_allclose(free.chi2_predicted_, best[1][0], rtol=1e-6)
    np.testing.assert_allclose([free.parameters_["p"], free.parameters_["q"]], best[0], rtol=1e-6)
    positive_q = {**wide, "q": FreeParameter(0.5, 0.0, 5.0)}
    bounded = LinearisedFit(replay, weights, mask, positive_q,
                            {"p": 10 * a[0]}).fit(measured)  # d(weighted residual)/dp: weight times p's outputs
    alone = np.linalg.lstsq(10 * a[:1].T, 10 * measured[0], rcond=None)
    np.testing.assert_allclose(bounded.chi2_predicted_, alone[1][0], rtol=1e-6)
    np.testing.assert_allclose(bounded.parameters_["p"], alone[0][0], rtol=1e-6)
    assert bounded.parameters_["q"] == pytest.approx(0.0, abs=1e-9) and bounded.replays_ == 2


def test_sample_fit_moves_a_parameter_that_starts_at_zero():
    """A phase starting at 0 is fitted: the fit's forward differences step DIFF_STEP * max(1, |q|), not scipy's
    diff_step * |q| (1.5e-8 at 0, below a replay's error, here 1e-4 and changing with the parameters: the phase's
    column was noise, and the speed job's fold fit stopped at phase 0). Data made with amplitude 1.2 and phase
    -1 rad, no noise: the fit from 0.8 and 0 must give them back to the replay's error."""
    from cosim.diagnose.fitting import SampleFit
    from cosim.fitting import FreeParameter

    t = np.linspace(0.0, 1.0, 400)
    scale = np.array([0.8, 1.0])  # a start of 0 is scaled by 1 (tasks._replay)

    def evaluate(q):  # with an error that changes with the parameters, as an ODE solver's
        amplitude, phase = q * scale
        error = 1e-4 * np.sin(1e9 * (q[0] + 2 * q[1]) + 37 * t)
        return (amplitude * np.sin(2 * np.pi * 12 * t + phase) + error)[None, :]

    replay = SimpleNamespace(free=["T", "phase"], scale=scale, evaluate=evaluate)
    measured = 1.2 * np.sin(2 * np.pi * 12 * t - 1.0)[None, :]
    free = {"T": FreeParameter(0.8, 0.0, 5.0), "phase": FreeParameter(0.0, -3.1416, 3.1416)}
    fit = SampleFit(replay, np.array([1e3]), np.ones(len(t), bool), free, max_nfev=20).fit(measured)
    assert fit.parameters_["phase"] == pytest.approx(-1.0, abs=1e-3)
    assert fit.parameters_["T"] == pytest.approx(1.2, abs=1e-3)


def test_a_rival_must_also_leave_a_residual_like_the_winners():
    """'Also explained by' asks for a score within 0.1 of the winner's and a held-out mean square within 1.5 times
    its own. Numbers of two shipped demos (held-out mean squares in noise units from their RMSE after and the
    0.5 N floor): on the impact a jaw friction removes 97 % of a 180-sigma^2 gap but leaves 7 times gear play's
    residual (not a rival); on the paper's static curve cogging leaves 1.2 times the load-cell filter's (a rival)."""
    def candidate(effect, score, rmse):
        return SimpleNamespace(effect=effect, score=score, heldout_ms_sigma2=(rmse / 0.5) ** 2)

    play, friction = candidate("gear_play", 1.001, 0.4647), candidate("stiction", 0.973, 1.232)
    assert rivals_of(play, [play, friction]) == []
    filt, cog = candidate("loadcell_filter", 0.709, 0.9194), candidate("cogging", 0.629, 1.0046)
    far = candidate("backdrive_efficiency", 0.55, 0.95)
    assert rivals_of(filt, [filt, cog, far]) == ["cogging"]
    assert rivals_of(None, [filt, cog]) == []


# -- bad input -------------------------------------------------------------------------------------------------

def test_bad_inputs_are_clear_errors(tmp_path):
    from cosim.compile import lower
    from cosim.diagnose.job import load_experiment

    frame, _ = _case_frame("none", 0)
    model = lower(SOURCE, "Gripper.GripperCurrentDriven")
    # a missing channel
    path = _write_job(tmp_path, frame.drop(columns=["F_g"]))
    with pytest.raises(ConfigError, match="missing column"):
        load_experiment(load_diagnose_job(path), model)
    # misaligned time bases: a stretch sampled on another clock
    bad = frame.copy()
    bad.loc[300:, "time"] = bad.loc[300:, "time"] + 0.004
    path = _write_job(tmp_path, bad)
    with pytest.raises(ConfigError, match="time base is not uniform"):
        load_experiment(load_diagnose_job(path), model)
    # data shorter than the experiment
    path = _write_job(tmp_path, frame[frame["time"] < 5.0])
    with pytest.raises(ConfigError, match="experiment.duration"):
        load_experiment(load_diagnose_job(path, ["experiment.duration=8.0"]), model)
    # an effect of another system (the haptic hand mass on the gripper), an unknown effect, an unknown key: all
    # reported at once
    path = _write_job(tmp_path, frame, effects=["hand_mass", "warp_drive"], extra="[compare.x]\n")
    with pytest.raises(ConfigError) as err:
        load_diagnose_job(path)
    assert "'hand_mass' does not apply to Gripper.GripperCurrentDriven" in str(err.value)
    assert "unknown effect 'warp_drive'" in str(err.value) and "compare.x" in str(err.value)
    text = (tmp_path / "job.toml").read_text().replace("GripperCurrentDriven", "PMSM").replace(
        '["hand_mass", "warp_drive"]', '["loadcell_filter"]')
    (tmp_path / "job.toml").write_text(text)
    with pytest.raises(ConfigError, match="does not apply to Gripper.PMSM"):
        load_diagnose_job(tmp_path / "job.toml")


def test_records_job_errors_name_the_key(tmp_path):
    """data.records (repeated trials): every problem reported at once with its key; a job gives data.path or
    data.records; each record's table is checked; a trial may fix a parameter but not free one."""
    frame, _ = _case_frame("none", 0)
    path = _write_job(tmp_path, frame)
    text = path.read_text()
    both = text.replace('path = "data.csv"\n', 'path = "data.csv"\nrecords = [{ path = "data.csv" }]\n')
    path.write_text(both)
    with pytest.raises(ConfigError, match="give exactly one of data.path .* and data.records"):
        load_diagnose_job(path)
    records = text.replace('path = "data.csv"\n', 'records = [{ path = "data.csv", parameters = { gap0 = 0.002 } }, '
                                                   '{ file = "x.csv" }, { path = "data.csv", colour = 1, '
                                                   'parameters = { eta_g = 0.7 } }]\n')
    path.write_text(records)
    with pytest.raises(ConfigError) as err:
        load_diagnose_job(path)
    message = str(err.value)
    assert "3 problems" in message
    assert "data.records[1]: must be a table with a path" in message
    assert "data.records[2].colour: unknown key" in message
    assert "data.records[2].parameters.eta_g: is a free parameter" in message
    path.write_text(records.replace(', { file = "x.csv" }, { path = "data.csv", colour = 1, '
                                    'parameters = { eta_g = 0.7 } }', ', { path = "data.csv" }'))
    job = load_diagnose_job(path)
    assert [trial for _, trial in job.records] == [{"gap0": 0.002}, {}]
    assert job.data_path == tmp_path / "data.csv"


# -- hidden-effect cases ------------------------------------------------------------------------------------------

# The seeds were drawn once at random (python -c "import secrets; print(secrets.randbelow(2**31))"), not picked for
# the workflow's success; a failing draw is a finding, not a reason to draw again. Every case is offered the whole
# effect library of the model.
@pytest.mark.parametrize("effect, seed", [("backdrive_efficiency", 1965006390), ("loadcell_filter", 470831167),
                                          ("none", 1621119728)])
@pytest.mark.slow
def test_workflow_names_the_hidden_effect(effect, seed, tmp_path):
    frame, truth = _case_frame(effect, seed)
    job = load_diagnose_job(_write_job(tmp_path, frame, effects=LIBRARY))
    rebuild = effect == "backdrive_efficiency"  # one case also builds the FMUs and re-runs them through the master
    result = run_diagnosis(job, progress=False, build=rebuild, out=tmp_path / "out")
    s = result.to_json()
    assert s["effect"] == effect, s["verdict"]
    np.testing.assert_allclose(s["noise"]["estimated"], [0.3], rtol=0.15)  # truth: 0.3 N
    if effect != "none":
        assert s["gap_removed"] >= 0.8
        assert s["rmse_after"] < 0.5 * s["rmse_before"]
        # fitted values against the truth; tolerances allow for the baseline's ~1 N model-form error
        if effect == "backdrive_efficiency":
            assert abs(s["after"]["parameters"]["eta_b"] - truth["eta_b"]) < 0.05
        else:
            assert abs(s["after"]["parameters"]["F_off"] - truth["F_off"]) < 0.5
    if rebuild:
        # the FMUs (generated C, the master's BDF, inputs played by controllers.playback) against the CVODES replay
        # of the same equations: the gap before and after is the same within the two solvers' tolerances
        r = s["rerun"]
        assert max(r["max_difference_to_replay_before"], r["max_difference_to_replay_after"]) < 0.05  # N
        assert r["rmse_before"] == pytest.approx(s["rmse_before"], abs=0.01)
        assert r["rmse_after"] == pytest.approx(s["rmse_after"], abs=0.01)
        assert (tmp_path / "out" / "rerun" / f"{effect}.toml").is_file()


@pytest.mark.slow
def test_cli_writes_diagnosis_json_and_report(tmp_path):
    """`cosim diagnose JOB --out DIR --set ...` on a short staircase with no candidates: the output files and the
    diagnosis.json keys other tools rely on."""
    from cosim.cli import main

    t, i, y, _ = make_case("none", np.random.default_rng(5), noise=0.3, levels=(0.0, 0.5, 1.0, 0.5, 0.0))
    path = _write_job(tmp_path, pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), effects=())
    out = tmp_path / "out"
    assert main(["diagnose", str(path), "--out", str(out), "--no-progress", "--set", "experiment.duration=3.4"]) == 0
    summary = json.loads((out / "diagnosis.json").read_text())
    assert summary["effect"] == "none"
    assert {"effect", "rmse_before", "rmse_after", "segments", "candidates"} <= set(summary)
    assert [s["kind"] for s in summary["segments"]] == ["hold", "up", "up", "down", "down"]
    assert (out / "report.md").is_file() and (out / "fit.png").is_file() and (out / "curve.png").is_file()
    assert main(["diagnose", str(path), "--out", str(out), "--set", "data.path=missing.csv"]) == 2
