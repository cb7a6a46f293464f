"""Records of different experiments of one plant in one diagnosis job (issue 42, item 3): ``[[experiments]]``
tables, each record cut and its noise estimated as its own kind says, the fits summing every record's
chi-square over one set of parameters, and the answer saying which record showed each finding. Checked on the
impact truth (tests/diagnose_truth_impact.py): one drawn gripper measured by an impact and a slide, each record's
load cell with its own noise level.
"""

import re

import numpy as np
import pytest

from cosim.diagnose import load_diagnose_job, run_diagnosis
from cosim.diagnose.kinds import Records, Several, SpeedRun
from cosim.errors import ConfigError

from diagnose_truth import SOURCE
from diagnose_truth_impact import draw_truth, measured_records, record_of, write_experiments_job

SEED = 722727826  # drawn once (secrets.randbelow(2**31)), not chosen
NOISE = {"impact": 0.5, "slide": 1.5}  # N (1 sd): each record's load cell


def _records(effect, seed, noise):
    """One gripper of the impact truth with ``effect`` hidden, measured by an impact and a slide, the load cell's
    noise [N] per experiment as given."""
    rng = np.random.default_rng(seed)
    truth = draw_truth(effect, rng)
    return {e: measured_records(record_of, truth, rng, noise[e], 1, e)[0] for e in ("impact", "slide")}, truth


def _job_text(tmp_path, experiments, extra=""):
    """A job of the given ``[[experiments]]`` TOML text on two small records (any content: loading checks the
    job, not the data)."""
    for name in ("a.csv", "b.csv"):
        (tmp_path / name).write_text("time,i_ref,F_g,theta_m\n0,0,0,0\n", encoding="utf-8")
    path = tmp_path / "job.toml"
    path.write_text(f'[model]\nsource = "{SOURCE.as_posix()}"\nname = "Gripper.GripperCurrentDriven"\n'
                    f'{experiments}{extra}[compare]\nsignals = [{{ output = "F_g", noise = 0.1 }}]\n'
                    '[parameters.eta_g]\nstart = 0.7\nmin = 0.3\nmax = 1.0\n[candidates]\neffects = ["gear_play"]\n',
                    encoding="utf-8")
    return path


IMPACT = '[[experiments]]\nname = "impact"\nkind = "impact"\npath = "a.csv"\ninputs = { i_ref = "i_ref" }\n' \
         'parameters = { gap0 = 0.0075 }\n'
SLIDE = '[[experiments]]\nkind = "staircase"\npath = "b.csv"\ninputs = { i_ref = "i_ref" }\nmin_hold_s = 0.1\n'


def test_experiments_are_read_each_with_its_kind_settings_and_fixed_values(tmp_path):
    job = load_diagnose_job(_job_text(tmp_path, IMPACT + SLIDE))
    assert isinstance(job.kind, Several)
    assert [p.name for p in job.kind.parts] == ["impact", "staircase 2"]
    assert isinstance(job.kind.parts[0].kind, Records) and isinstance(job.kind.parts[1].kind, SpeedRun)
    assert job.kind.parts[1].min_hold_s == 0.1
    assert [(path.name, fixed) for path, fixed in job.records] == [("a.csv", {"gap0": 0.0075}), ("b.csv", {})]
    part = job.kind.part_job(job, 1)
    assert part.records == (job.records[1],) and part.min_hold_s == 0.1 and part.inputs == {"i_ref": "i_ref"}


@pytest.mark.parametrize("experiments, extra, message", [
    (IMPACT + SLIDE, '[data]\npath = "a.csv"\n', "data: give either [data] and [experiment] (one experiment) or "
                                                  "[[experiments]] (several), not both"),
    (IMPACT + SLIDE.replace('"staircase"', '"frequency"'), "", "experiments[1].kind: a frequency response is not a "
                                                                "time series: diagnose it in a job of its own"),
    (IMPACT + IMPACT.replace('"a.csv"', '"b.csv"'), "", "experiments: name 'impact' is given to more than one "
                                                         "experiment"),
    (IMPACT + SLIDE.replace('"b.csv"', '"a.csv"'), "", "is given to more than one experiment"),
    (IMPACT.replace("gap0", "eta_g") + SLIDE, "", "experiments[0].parameters.eta_g: is a free parameter"),
    (IMPACT + SLIDE + "steady = 1\n", "", "experiments[1].steady: unknown key; allowed: name, kind, path"),
    (IMPACT + SLIDE.replace("inputs = { i_ref = \"i_ref\" }\n", ""), "", "experiments[1].inputs: must map model "
                                                                         "inputs to data columns"),
])
def test_a_bad_experiments_table_is_a_job_error(tmp_path, experiments, extra, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        load_diagnose_job(_job_text(tmp_path, experiments, extra))


def test_each_record_is_weighed_by_its_own_noise_and_cut_as_its_kind_says(tmp_path):
    """One gripper of the impact truth (no hidden effect) measured by an impact with a 0.5 N load cell and a slide
    with a 1.5 N one, in one job: each record's noise is estimated as its kind does (the impact's from its
    approach and hold, the slide's from the steady ends of its holds) and within 25 % of the truth; every sample
    is weighed by its own record's level; the impact is cut into its phases and the slide into its holds, each
    segment named by its experiment; the slide's every load-cell sample and the impact's every sample are cost
    samples."""
    from cosim.diagnose.workflow import estimate_noise, load_samples, split_segments

    records, _ = _records("none", SEED, NOISE)
    job = load_diagnose_job(write_experiments_job(tmp_path, SOURCE, records, [], workers=0))
    samples = load_samples(job)
    noise = estimate_noise(job, samples)
    split = split_segments(job, samples, noise)
    n_impact = len(records["impact"][0])
    for k, (name, cut) in enumerate((("impact", slice(0, n_impact)), ("slide", slice(n_impact, None)))):
        assert noise.parts[k].estimated[0] == pytest.approx(NOISE[name], rel=0.25), (name, noise.parts[k])
        np.testing.assert_array_equal(noise.sigma[0, cut], noise.parts[k].sigma[0])
        measured = np.isfinite(records[name][2])
        np.testing.assert_array_equal(samples.mask[cut], measured)
    labels = [seg.label for seg in split.segments]
    assert any(x.startswith("impact: ") for x in labels) and any(x.startswith("slide: ") for x in labels)
    impact = {seg.kind for seg in split.segments if seg.label.startswith("impact: ")}
    slide = {seg.kind for seg in split.segments if seg.label.startswith("slide: ")}
    assert impact <= {"approach", "impact", "tightening", "steady"} and "impact" in impact, impact
    assert slide <= {"up", "down", "hold"} and len(slide) > 1, slide


def test_a_finding_is_shown_by_the_records_it_removes_chi_square_from():
    """The gaps per experiment against a hand count: record "one" (4 samples, noise 0.5) from 2 to 1 noise
    levels, record "two" (6 samples, noise 2) 3 before and after; chi-square removed (4 - 1) * 4 = 12 and 0."""
    from types import SimpleNamespace

    from cosim.diagnose.kinds import Part
    from cosim.diagnose.result import Noise
    from cosim.diagnose.stages import Samples
    from cosim.diagnose.workflow import experiment_gaps, shown_by
    from cosim.experiment import Experiment

    def record(n):
        return Experiment(time=np.arange(n) * 0.01, inputs=np.zeros((n, 1)), measured=np.zeros((n, 1)),
                          weights=np.ones(1), mask=np.ones(n, bool)), {}

    records = [record(4), record(6)]
    sigma = np.r_[np.full(4, 0.5), np.full(6, 2.0)][None, :]
    noise = Noise(estimated=np.array([1.0]), floor=np.zeros(1), sigma=sigma,
                  parts=(Noise(np.array([0.5]), np.zeros(1), np.array([0.5])),
                         Noise(np.array([2.0]), np.zeros(1), np.array([2.0]))))
    samples = Samples(model=None, records=records, experiment=record(10)[0], shifts=[0.0, 0.05], sampled=[],
                      present=None, mask=np.ones(10, bool), channels=["F_g"], units=["N"], floor=np.zeros(1))
    job = SimpleNamespace(kind=Several(parts=(Part("one", Records(), {}), Part("two", SpeedRun(), {}))))
    before = np.r_[np.full(4, 1.0), np.full(6, 6.0)][None, :]
    after = np.r_[np.full(4, 0.5), np.full(6, -6.0)][None, :]
    one, two = experiment_gaps(job, samples, noise, before, after)
    assert (one.gap_before, one.gap_after, one.chi2_removed) == pytest.approx((2.0, 1.0, 12.0))
    assert (two.gap_before, two.gap_after, two.chi2_removed) == pytest.approx((3.0, 3.0, 0.0))
    assert (one.kind, two.kind, one.samples, one.noise) == ("impact", "staircase", 4, [0.5])
    assert shown_by((one, two), 10.0) == ("one",)
    assert shown_by((two, one), 20.0) == ("one",)  # none reaches it: the one it removes most from


def test_an_experiment_without_cost_samples_is_a_job_error(tmp_path):
    """A staircase (steady_s: the settled ends of its holds) whose holds are all shorter than its min_hold_s gives
    no cost sample: the job says which experiment, instead of diagnosing the others without a word."""
    from cosim.diagnose.workflow import load_samples

    records, _ = _records("none", SEED, NOISE)
    path = write_experiments_job(tmp_path, SOURCE, records, [], workers=0)
    path.write_text(path.read_text(encoding="utf-8").replace("min_hold_s = 0.1", "steady_s = 0.3\nmin_hold_s = 5.0"),
                    encoding="utf-8")
    with pytest.raises(ConfigError, match=re.escape("experiments[1] (slide): no sample enters the cost (a staircase: "
                                                    "no hold lasts its min_hold_s = 5 s)")):
        load_samples(load_diagnose_job(path))
