"""Calibration against synthetic data with known truth: data made by an independent integrator (scipy
solve_ivp on the hand-written equations, input held between samples) plus sensor noise."""

import json
import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cosim.calibrate import Calibrator
from cosim.calibrate.job import run_job
from cosim.compile import lower
from cosim.errors import ConfigError
from cosim.experiment import Experiment

from conftest import COMPILER_MODELS

M_TRUE, K_TRUE, D_TRUE = 0.5, 200.0, 1.5
SIGMA = 2e-4  # m, position sensor noise


@pytest.fixture(scope="module")
def msd():
    return lower(COMPILER_MODELS, "CompilerTests.MassSpringDamper")


def synthetic_msd(duration, seed=0, dt=0.01):
    """Position of the mass-spring-damper under a random staircase force, by scipy, plus noise."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(0, duration, dt), 10)
    force = np.repeat(rng.uniform(-2, 2, len(t) // 20 + 1), 20)[: len(t)]
    x, states = [0.01, 0.0], [[0.01, 0.0]]
    for k in range(len(t) - 1):
        sol = solve_ivp(lambda _, s: [s[1], (force[k] - K_TRUE * s[0] - D_TRUE * s[1]) / M_TRUE],
                        (t[k], t[k + 1]), x, rtol=1e-11, atol=1e-13)
        x = sol.y[:, -1]
        states.append(x)
    position = np.array(states)[:, 0] + SIGMA * rng.standard_normal(len(t))
    return t, force, position


def experiment(t, force, position):
    return Experiment(t, force[:, None], position[:, None], np.array([1 / SIGMA]), np.ones(len(t), bool))


def test_recovers_known_parameters_within_two_standard_errors(msd):
    fit = Calibrator(msd, ["x"], {"k": (150.0, 10.0, 1000.0), "d": (3.0, 0.01, 10.0)}, substeps=10)
    fit.fit(experiment(*synthetic_msd(3.0)))
    assert fit.success_
    for name, truth in (("k", K_TRUE), ("d", D_TRUE)):
        assert abs(fit.parameters_[name] - truth) < 2 * fit.std_errors_[name], (name, fit.parameters_, fit.std_errors_)
    # With weights 1/sigma the cost per sample is about 1/2 when the model is right (300 samples).
    assert 0.3 < fit.cost_after_ / 300 < 0.7


@pytest.mark.slow
def test_standard_errors_shrink_with_more_data(msd):
    free = {"k": (150.0, 10.0, 1000.0), "d": (3.0, 0.01, 10.0)}
    short = Calibrator(msd, ["x"], free, substeps=10).fit(experiment(*synthetic_msd(1.0, seed=1)))
    long = Calibrator(msd, ["x"], free, substeps=10).fit(experiment(*synthetic_msd(4.0, seed=1)))
    for name in free:
        assert long.std_errors_[name] < 0.75 * short.std_errors_[name]


def test_optimiser_derivative_agrees_with_finite_differences(msd):
    calibrator = Calibrator(msd, ["x"], {"k": (180.0, 10.0, 1000.0), "d": (2.0, 0.01, 10.0)}, substeps=5)
    tr = calibrator.transcription(experiment(*synthetic_msd(1.0, seed=2)))
    q = np.array([1.05, 0.9])
    _, r0, X, _ = tr.evaluate(q)
    exact = tr.reduced_jacobian(X, q)
    for k in range(2):
        dq = np.zeros(2)
        dq[k] = 1e-6
        fd = (tr.evaluate(q + dq)[1] - tr.evaluate(q - dq)[1]) / 2e-6
        np.testing.assert_allclose(exact[:, k], fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def write_job(tmp_path, data_name="data.csv", extra="", params=None):
    t, force, position = synthetic_msd(2.0, seed=3)
    import pandas as pd

    pd.DataFrame({"time": t, "force": force, "x_meas": position}).to_csv(tmp_path / data_name, index=False)
    params = params or '[parameters.k]\nstart = 150.0\nmin = 10.0\nmax = 1000.0\n\n' \
                       '[parameters.d]\nstart = 3.0\nmin = 0.01\nmax = 10.0\n'
    job = tmp_path / "job.toml"
    job.write_text(f"""[model]
source = "{COMPILER_MODELS}"
name = "CompilerTests.MassSpringDamper"

[data]
path = "{data_name}"
inputs = {{F = "force"}}

[fit]
signals = [{{output = "x", column = "x_meas", noise = {SIGMA}}}]
substeps = 10
{extra}
{params}""")
    return job


def test_job_writes_results_and_parameter_set(tmp_path):
    job = write_job(tmp_path)
    result = run_job(job, out=tmp_path / "out", progress=False)
    written = json.loads((tmp_path / "out" / "calibration.json").read_text())
    assert written == json.loads(json.dumps(result.to_json()))
    assert set(written["parameters"]["k"]) == {"value", "std_error", "identifiable", "start"}
    assert abs(written["parameters"]["k"]["value"] - K_TRUE) < 2 * written["parameters"]["k"]["std_error"]
    assert written["cost_after"] < written["cost_before"]
    assert len(written["correlation"]["matrix"]) == 2 and written["iterations"] > 0
    assert "k = " in (tmp_path / "out" / "parameters.toml").read_text()
    assert (tmp_path / "out" / "fit.png").stat().st_size > 10_000


@pytest.mark.slow
def test_multistart_on_a_local_dask_cluster(tmp_path):
    job = write_job(tmp_path, extra="\n[multistart]\ncount = 3\nseed = 7\n")
    result = run_job(job, out=tmp_path / "out", progress=False)
    assert len(result.multistart) == 3
    assert result.multistart[0]["start"] == {"k": 150.0, "d": 3.0}
    best = min(r["cost_after"] for r in result.multistart if r["success"])
    assert result.cost_after == pytest.approx(best)


@pytest.mark.parametrize("case,edit,message", [
    ("signal not in data", lambda job, data: job.write_text(job.read_text().replace("x_meas", "x_gone")),
     "missing column(s) x_gone"),
    ("non-monotonic time", lambda job, data: data.write_text(data.read_text().replace("\n0.03,", "\n0.01,", 1)),
     "time is not strictly increasing at row 3"),
    ("NaN", lambda job, data: data.write_text(re.sub(r"\n0\.05,[^,]+,", "\n0.05,nan,", data.read_text())),
     "column 'force' has 1 NaN/inf value(s), first at row 5"),
    ("parameter not in model", lambda job, data: job.write_text(job.read_text().replace("[parameters.d]",
                                                                                           "[parameters.dd]")),
     "has no tunable parameter 'dd'"),
    ("start outside bounds", lambda job, data: job.write_text(job.read_text().replace("start = 150.0",
                                                                                      "start = 5.0")),
     "parameters.k.start: 5 is outside the bounds [10, 1000]"),
])
def test_bad_input_names_the_field_and_writes_nothing(tmp_path, case, edit, message):
    job = write_job(tmp_path)
    edit(job, tmp_path / "data.csv")
    with pytest.raises(ConfigError) as err:
        run_job(job, out=tmp_path / "out", progress=False)
    assert message in str(err.value)
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_fmu_only_model_falls_back_to_finite_differences(tmp_path, compiler_fmu):
    job = write_job(tmp_path)
    text = job.read_text().replace(f'source = "{COMPILER_MODELS}"\nname = "CompilerTests.MassSpringDamper"',
                                   f'fmu = "{compiler_fmu("MassSpringDamper")}"')
    job.write_text(text)
    result = run_job(job, out=tmp_path / "out", progress=False)
    assert result.derivatives.startswith("finite differences through the FMU")
    k = result.parameters["k"]
    assert abs(k.value - K_TRUE) < 2 * k.std_error


def test_a_run_config_loads_the_calibrated_parameter_set(tmp_path, compiler_fmu):
    from cosim.config import load_config

    (tmp_path / "parameters.toml").write_text("[parameters]\nk = 210.5  # +- 0.1 (1 s.e.)\nd = 1.25\n")
    config = tmp_path / "run.toml"
    config.write_text(f"""[run]
stop = 0.1

[fmus.plant]
path = "{compiler_fmu("MassSpringDamper")}"
parameters_file = "parameters.toml"
parameters = {{ d = 1.5 }}
""")
    spec = load_config(config)
    assert spec.fmus["plant"].parameters == {"k": 210.5, "d": 1.5}  # the config's own values win
