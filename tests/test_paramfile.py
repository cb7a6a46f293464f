"""The calibration chain (issue 43, item 1): ``cosim calibrate`` writes parameters.toml with its provenance; a run
config, a campaign job and another calibration job read it (``parameters_file``); the downstream outputs record the
file, its hash and provenance; a bad or missing file is a ConfigError naming the file and the key.

Reference for the run: the free response of a mass-spring-damper written here in closed form, with the stiffness
and damping read from the file (not from the code that loads it); data for the calibration from scipy."""

import hashlib
import json
import math
import tomllib

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from hypothesis import given, settings
from hypothesis import strategies as st

from cosim.cli import main
from cosim.config import load_config
from cosim.errors import ConfigError
from cosim.paramfile import read_parameters_file, write_parameters_file

from conftest import COMPILER_MODELS

M, K_TRUE, D_TRUE = 0.5, 320.0, 2.5  # the FMU's own values are k = 200, d = 1.5: the file must change them
SIGMA = 2e-4  # m
X0 = 0.01  # m, the model's start position


def _data(path, seed=3):
    """Position of the mass-spring-damper (k = 320, d = 2.5) under a random force staircase, by scipy, + noise."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(0, 2.0, 0.01), 10)
    force = np.repeat(rng.uniform(-2, 2, len(t) // 20 + 1), 20)[: len(t)]
    x, states = [X0, 0.0], [[X0, 0.0]]
    for k in range(len(t) - 1):
        sol = solve_ivp(lambda _, s: [s[1], (force[k] - K_TRUE * s[0] - D_TRUE * s[1]) / M], (t[k], t[k + 1]), x,
                        rtol=1e-11, atol=1e-13)
        x = sol.y[:, -1]
        states.append(x)
    position = np.array(states)[:, 0] + SIGMA * rng.standard_normal(len(t))
    pd.DataFrame({"time": t, "force": force, "x_meas": position}).to_csv(path, index=False)


def _job(folder, free, model_extra=""):
    params = "".join(f"[parameters.{n}]\nstart = {s}\nmin = {lo}\nmax = {hi}\n\n" for n, (s, lo, hi) in free.items())
    job = folder / "job.toml"
    job.write_text(f"""[model]
source = "{COMPILER_MODELS}"
name = "CompilerTests.MassSpringDamper"
{model_extra}

[data]
path = "data.csv"
inputs = {{F = "force"}}

[fit]
signals = [{{output = "x", column = "x_meas", noise = {SIGMA}}}]
substeps = 10

{params}""")
    return job


def _free_response(t, k, d):
    """x(t) of m x'' + d x' + k x = 0 from x(0) = X0 at rest (underdamped), in closed form."""
    w0 = math.sqrt(k / M)
    zeta = d / (2 * math.sqrt(k * M))
    wd = w0 * math.sqrt(1 - zeta**2)
    return X0 * np.exp(-zeta * w0 * t) * (np.cos(wd * t) + zeta * w0 / wd * np.sin(wd * t))


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A real calibration of k and d: (its folder, parameters.toml)."""
    folder = tmp_path_factory.mktemp("chain")
    _data(folder / "data.csv")
    job = _job(folder, {"k": (150.0, 10.0, 1000.0), "d": (3.0, 0.01, 10.0)})
    assert main(["calibrate", str(job), "--out", str(folder / "up"), "--no-progress"]) == 0
    return folder, folder / "up" / "parameters.toml"


@pytest.mark.slow
def test_the_file_holds_the_fit_and_its_provenance(calibrated):
    folder, path = calibrated
    doc = tomllib.loads(path.read_text())
    fit = json.loads((folder / "up" / "calibration.json").read_text())["parameters"]
    for name, truth in (("k", K_TRUE), ("d", D_TRUE)):
        assert doc["parameters"][name] == fit[name]["value"]
        assert abs(doc["parameters"][name] - truth) < 2 * fit[name]["std_error"]
    prov = doc["provenance"]
    assert prov["job_sha256"] == hashlib.sha256((folder / "job.toml").read_bytes()).hexdigest()
    assert prov["data"][0]["sha256"] == hashlib.sha256((folder / "data.csv").read_bytes()).hexdigest()
    assert prov["data"][0]["file"].endswith("data.csv") and prov["job"].endswith("job.toml")
    assert len(prov["commit"].removesuffix("+dirty")) in (40, 7) or prov["commit"] == "unknown"
    assert prov["date"].endswith("Z") and prov["upstream"] == []


@pytest.mark.slow
def test_cosim_run_reads_the_file_and_the_plant_follows_it(calibrated, compiler_fmu, tmp_path):
    _, path = calibrated
    values = tomllib.loads(path.read_text())["parameters"]
    config = tmp_path / "free.toml"
    config.write_text(f"""[run]
stop = 1.0

[solver]
method = "rk4"
substeps = 1

[fmus.plant]
path = "{compiler_fmu("MassSpringDamper")}"
parameters_file = "{path}"

[record]
rate = 1000
signals = ["plant.x"]
""")
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--no-progress", "--csv"]) == 0
    data = pd.read_csv(tmp_path / "o" / "results.csv")
    t, x = data["time [s]"].to_numpy(), data["x [m]"].to_numpy()
    np.testing.assert_allclose(x, _free_response(t, values["k"], values["d"]), atol=1e-6)
    assert np.max(np.abs(x - _free_response(t, 200.0, 1.5))) > 1e-3  # the FMU's own k, d would be far off
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    record = summary["parameters_files"]["plant"]
    assert record["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert record["provenance"] == tomllib.loads(path.read_text())["provenance"]


@pytest.mark.slow
def test_a_calibration_builds_on_another_and_records_it(calibrated, tmp_path):
    folder, path = calibrated
    (tmp_path / "data.csv").write_bytes((folder / "data.csv").read_bytes())
    job = _job(tmp_path, {"d": (1.0, 0.01, 10.0)}, f'parameters_file = "{path}"')
    assert main(["calibrate", str(job), "--out", str(tmp_path / "down"), "--no-progress"]) == 0
    doc = tomllib.loads((tmp_path / "down" / "parameters.toml").read_text())
    assert list(doc["parameters"]) == ["d"]  # k came fixed from upstream
    d_up = tomllib.loads(path.read_text())["parameters"]["d"]
    assert doc["parameters"]["d"] == pytest.approx(d_up, rel=0.02)  # the same data, k fixed at its fitted value
    (upstream,) = doc["provenance"]["upstream"]
    assert upstream["file"] == str(path) and upstream["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert upstream["provenance"]["job_sha256"] == tomllib.loads(path.read_text())["provenance"]["job_sha256"]


@pytest.mark.parametrize("content, message", [
    (None, "cannot read the parameters file"),
    ("[parameters]\nk = 'stiff'\n", "[parameters] values must be finite numbers; got k = 'stiff'"),
    ("k = 3.0\n", "needs a [parameters] table"),
    ("[parameters\nk = 3.0\n", "not a TOML parameters file"),
])
def test_a_bad_or_missing_file_names_the_file_and_the_key(tmp_path, content, message):
    path = tmp_path / "p.toml"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ConfigError) as err:
        read_parameters_file(path, "campaign.parameters_file")
    assert str(err.value).startswith("campaign.parameters_file: ") and str(path) in str(err.value)
    assert message in str(err.value)


def test_a_missing_file_in_a_campaign_and_a_calibration_job(tmp_path):
    from cosim.campaign import load_campaign
    from cosim.calibrate.job import load_job

    job = tmp_path / "c.toml"
    job.write_text('[campaign]\nseed = 1\ntrials = 1\ncoatings = []\nspeeds_rpm = [1000]\ncurrents_A = [1.0]\n'
                   'parameters_file = "gone.toml"\n')
    with pytest.raises(ConfigError) as err:
        load_campaign(job)
    assert f"{job}:7: campaign.parameters_file: {tmp_path / 'gone.toml'}: cannot read" in str(err.value)
    pd.DataFrame({"time": [0.0, 0.01], "force": [0.0, 0.0], "x_meas": [X0, X0]}).to_csv(tmp_path / "data.csv")
    cal = _job(tmp_path, {"d": (1.0, 0.01, 10.0)}, 'parameters_file = "gone.toml"')
    with pytest.raises(ConfigError) as err:
        load_job(cal)
    assert f"{cal}:4: model.parameters_file: {tmp_path / 'gone.toml'}: cannot read" in str(err.value)


# ------------------------------------------------------------------------------------- names as FMUs spell them
_PROV = {"job": "job.toml", "commit": "unknown", "upstream": []}
_IDENT = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,6}", fullmatch=True)
_SUBSCRIPT = st.lists(st.integers(1, 12), min_size=1, max_size=3).map(lambda ix: f"[{','.join(map(str, ix))}]")
_PART = st.tuples(_IDENT, st.one_of(st.just(""), _SUBSCRIPT)).map("".join)
_NAMES = st.lists(_PART, min_size=1, max_size=4).map(".".join)  # load.J, x[1], a.b[2].c, A[1,2]


def test_dotted_and_subscripted_names_read_back(tmp_path):
    # issue 53 item 6: "load.J" written bare was a nested table, "x[1]" a TOML syntax error
    values = {"k": 320.0, "load.J": 0.3, "x[1]": -1.5, "a.b[2].c": 2e-5, "A[1,2]": 7.0}
    path = tmp_path / "parameters.toml"
    write_parameters_file(path, values, {"load.J": "+- 0.01 (1 sd)"}, _PROV)
    assert read_parameters_file(path).values == values
    assert tomllib.loads(path.read_text())["parameters"] == values  # any TOML reader reads the names as written


@settings(max_examples=200, deadline=None)
@given(names=st.lists(_NAMES | st.text(min_size=1, max_size=8), min_size=1, max_size=6, unique=True),
       value=st.floats(allow_nan=False, allow_infinity=False))
def test_any_name_reads_back(tmp_path_factory, names, value):
    path = tmp_path_factory.mktemp("names") / "parameters.toml"
    values = {n: value + i for i, n in enumerate(names)}
    write_parameters_file(path, values, {}, _PROV)
    assert tomllib.loads(path.read_text(encoding="utf-8"))["parameters"] == values


def test_a_dotted_name_written_bare_reads_as_that_name(tmp_path):
    # what cosim calibrate wrote before it quoted names, or a user by hand: TOML's nested table {load = {J = 0.3}}
    path = tmp_path / "p.toml"
    path.write_text('[parameters]\nload.J = 0.3\nk = 1.0\n\n[parameters.gear]\nratio = 4.0\n')
    assert read_parameters_file(path).values == {"load.J": 0.3, "k": 1.0, "gear.ratio": 4.0}
    path.write_text('[parameters]\nload.J = 0.3\n"load.J" = 0.4\n')
    with pytest.raises(ConfigError, match=r"\[parameters\] names 'load.J' twice"):
        read_parameters_file(path)


@pytest.mark.slow
def test_a_run_config_reads_component_and_array_parameters_back(compiler_fmu, tmp_path):
    """What cosim calibrate writes for an MSL-style model's parameters, a run config's parameters_file reads: each
    name is checked against the FMU's own (a name it did not resolve would be "has no parameter")."""
    from cosim.compile import build_fmu

    arrays = build_fmu(COMPILER_MODELS.parent.parent / "arrays" / "Arrays.mo", "Arrays.LinearSystem", out_dir=tmp_path)
    for fmu, values in ((compiler_fmu("Drive"), {"load.J": 0.45, "gear.ratio": 3.0}),
                        (arrays, {"b[1]": 1.25, "A[2,3]": 0.75})):
        path = tmp_path / f"{fmu.stem}.toml"
        write_parameters_file(path, values, {}, _PROV)
        config = tmp_path / "run.toml"
        config.write_text(f'[run]\nstop = 0.1\n\n[fmus.plant]\npath = "{fmu}"\nparameters_file = "{path.name}"\n')
        spec = load_config(config).fmus["plant"]
        assert spec.parameters == values and spec.parameters_file.values == values
