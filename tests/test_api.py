"""The public API's contract: numpydoc docstrings that document every parameter, and unknown keywords rejected;
and the calls of ``cosim.__all__`` (issue 53 item 1): ``cosim.run`` gives the records ``cosim run`` writes, writes
nothing without ``out``, and a config built in code is checked as a file is; ``cosim.calibrate``,
``cosim.diagnose`` and ``cosim.campaign`` give what their commands write, and are callable whether or not their
subpackages' modules were imported first.

The public API is ``cosim.__all__``; everything else is private, and the code a user reads in the guides, the
README and the examples imports nothing else of cosim. The docstrings checked are those of the modules below
(the API's and the internal ones a contributor reads); the list is written out here, so a module that drops out of
it fails this test instead of leaving the contract quietly.

References: the damped oscillator's closed-form free response (a run's frame), ``cosim run``'s results.parquet read
back with pyarrow (the API's records), the FMU's model description read by fmpy (the units), ``load_config`` on
the same tables written as TOML (a config built in code); the files ``cosim calibrate``, ``cosim diagnose`` and
``cosim campaign`` write for the same job, read back with json and pandas (the typed results), and the steady
forces' percentiles by numpy (a campaign's table).
"""

import dataclasses
import importlib
import inspect
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc
from test_campaign import GRID, job_path  # noqa: F401
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

from cosim.config import load_config
from cosim.errors import ConfigError, CosimError
from cosim.tomldoc import toml_text

DOCUMENTED_MODULES = [
    "cosim",
    "cosim.api",
    "cosim.compile",
    "cosim.fmi",
    "cosim.experiment",
    "cosim.parallel",
    "cosim.freqresp",
    "cosim.master",
    "cosim.calibrate",
    "cosim.diagnose",
    "cosim.haptic",
    "cosim.config",
    "cosim.plugins",
    "cosim.controller",
    "cosim_controllers.foc",
    "cosim_controllers.outer",
    "cosim_controllers.haptic",
    "cosim_controllers.playback",
]


def _public():
    """(qualified name, object) of every public function and class, once each: a name ``cosim`` exports is
    checked under that name."""
    seen = set()
    for module_name in DOCUMENTED_MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and id(obj) not in seen:
                seen.add(id(obj))
                yield f"{module_name}.{name}", obj


def _constructor(obj):
    """The callable whose parameters the docstring documents: a class's own ``__init__`` (an inherited one
    is documented where it is defined), or the function itself."""
    if inspect.isclass(obj):
        return obj.__dict__.get("__init__")
    return obj


def _documented(doc, obj):
    sections = ["Parameters", "Other Parameters"]
    if dataclasses.is_dataclass(obj):
        sections.append("Attributes")  # a dataclass's constructor arguments are its fields
    names = set()
    for section in sections:
        for param in doc[section]:
            names.update(part.strip().lstrip("*") for part in param.name.split(","))
    return names


@pytest.mark.parametrize("name, obj", list(_public()), ids=[name for name, _ in _public()])
def test_public_docstring_documents_every_parameter(name, obj):
    assert inspect.getdoc(obj), f"{name} has no docstring"
    function = _constructor(obj)
    if function is None:
        return
    doc = ClassDoc(obj) if inspect.isclass(obj) else FunctionDoc(obj)
    wanted = [p.name for p in inspect.signature(function).parameters.values()
              if p.name not in ("self", "cls") and p.kind is not p.VAR_POSITIONAL]
    missing = [p for p in wanted if p not in _documented(doc, obj)]
    assert not missing, f"{name}: parameters not in its docstring's Parameters section: {missing}"


def _takes_any_keyword(obj):
    function = _constructor(obj)
    if function is None:
        return False
    return any(p.kind is p.VAR_KEYWORD for p in inspect.signature(function).parameters.values())


def _controller_with_bogus_keyword():
    from cosim_controllers.foc import FOC

    FOC(rate=1000.0, jit=False, not_a_parameter=1.0)


# Every public callable that takes **kwargs, with a call that passes an unknown keyword: it must raise
# TypeError naming the keyword before doing any work.
UNKNOWN_KEYWORD_CALLS = {
    "cosim.Controller": _controller_with_bogus_keyword,
}


def test_every_public_callable_taking_any_keyword_is_checked_here():
    taking = {name for name, obj in _public() if _takes_any_keyword(obj)}
    assert taking == set(UNKNOWN_KEYWORD_CALLS)


@pytest.mark.parametrize("name", sorted(UNKNOWN_KEYWORD_CALLS))
def test_an_unknown_keyword_is_a_type_error_naming_it(name):
    with pytest.raises(TypeError, match="not_a_parameter"):
        UNKNOWN_KEYWORD_CALLS[name]()


# ----------------------------------------------------------------------------------------------
# the calls
# ----------------------------------------------------------------------------------------------
def _tree(folder):
    """Every path under ``folder`` with its size and modification time: what a call may not change (numba's cache
    of the compiled controller kernels, ``__pycache__`` beside a controller's file, aside)."""
    return {p: (p.stat().st_size, p.stat().st_mtime_ns) for p in Path(folder).rglob("*")
            if "__pycache__" not in p.parts}


def test_a_run_without_out_writes_nothing_and_its_frame_is_the_closed_form(master_dir, tmp_path, monkeypatch):  # noqa: F811
    import cosim

    monkeypatch.chdir(tmp_path)
    config = osc_config(master_dir, stop=1.0)
    before = _tree(master_dir)
    result = cosim.run(config, set={"controllers.src.parameters.amp": 0.0})
    assert list(tmp_path.iterdir()) == [] and result.out is None and result.files == []
    assert _tree(master_dir) == before
    # x'' + c x' + k x = 0, x(0) = 1, x'(0) = 0 (k = 9 from the config, c = 0.5 the model's); y = 2 x
    k, c = 9.0, 0.5
    wd = np.sqrt(k - c * c / 4)
    plant = result.frame("plant")
    t = plant.index.to_numpy()
    x = np.exp(-c * t / 2) * (np.cos(wd * t) + c / (2 * wd) * np.sin(wd * t))
    assert list(plant.columns) == ["y", "v_out"] and t[0] == 0.0 and t[-1] == pytest.approx(1.0)
    assert np.max(np.abs(plant.y.to_numpy() - 2 * x)) < 1e-6
    assert plant.attrs["units"] == {"y": "m", "v_out": "m/s"}
    assert result.summary["stop_s"] == 1.0 and result.config.overrides == ("controllers.src.parameters.amp=0.0",)
    with pytest.raises(KeyError, match="'plnt'.*plant, src"):
        result.frame("plnt")


@pytest.mark.slow
def test_cosim_run_gives_the_records_cosim_run_writes(gripper_dir, tmp_path, monkeypatch):  # noqa: F811
    import fmpy
    import pyarrow.parquet as pq

    import cosim
    from cosim.cli import main

    config = EXAMPLES / "gripper_impact.toml"
    sets = gripper_overrides(gripper_dir) + ["run.stop=0.45"]
    assert main(["run", str(config), "--out", str(tmp_path / "cli"), "--no-progress",
                 *[a for s in sets for a in ("--set", s)]]) == 0
    written = pq.read_table(tmp_path / "cli" / "results.parquet")
    monkeypatch.chdir(tmp_path / "cli")
    before = _tree(tmp_path)
    result = cosim.run(str(config), set=sets)
    assert _tree(tmp_path) == before  # nothing written beside the CLI's output, nor into it
    plant = result.frame("plant")
    assert np.array_equal(plant.F_g.to_numpy(), written.column("F_g").to_numpy())
    assert np.array_equal(plant.index.to_numpy(), written.column("time").to_numpy())
    assert np.array_equal(result.frame("outer")["mode"].to_numpy(), written.column("outer.mode").to_numpy())
    units = {v.name: v.unit for v in fmpy.read_model_description(gripper_dir / "GripperPlant.fmu").modelVariables}
    assert plant.attrs["units"] == {name: units[name] for name in plant.columns}
    assert result.summary["peak_force_N"] == pytest.approx(plant.F_g.max())
    figure = result.plot()
    assert len(figure.axes) >= 5  # the config's five panels (and the zoom around the impact)


def test_a_config_built_in_code_gives_the_loaders_errors(master_dir):  # noqa: F811
    import cosim

    data = tomllib.loads(osc_config(master_dir, stop=1.0).read_text())
    data["run"]["stop"] = -1.0
    data["controllers"]["src"]["rate"] = "fast"
    data["connections"][0]["to"] = "plant.uu"
    path = master_dir / "api_invalid.toml"  # beside the FMU and ctl.py, which the tables name relatively
    path.write_text(toml_text(data))

    def problems(make):
        with pytest.raises(ConfigError) as err:
            make()
        return {line.split(": ", 1)[1] for line in err.value.problems}  # the place (file:line or file) aside

    from_file = problems(lambda: load_config(path))
    assert len(from_file) == 3 and any("no input 'uu'" in p for p in from_file)
    assert problems(lambda: cosim.Config.from_data(data, path)) == from_file
    assert problems(lambda: cosim.Config.load(path)) == from_file


def _osc_specs(**changes):
    """The sections of osc_config(stop=1.0) as spec objects, ``changes`` replacing some."""
    from cosim.config import Connection, ControllerSpec, FmuSpec, RecordSpec, RunSpec

    specs = dict(run=RunSpec(stop=1.0), fmus={"plant": FmuSpec(path="Osc.fmu", parameters={"k": 9.0})},
                 controllers={"src": ControllerSpec(class_path="ctl.py:Sine", rate=1000.0,
                                                    parameters={"amp": 2.0, "f": 1.0})},
                 connections=(Connection(("src", "u"), ("plant", "u")),),
                 record=RecordSpec(100.0, (("plant", "y"), ("plant", "v_out"), ("src", "u"))))
    return {**specs, **changes}


def test_a_config_constructed_in_code_runs_to_the_numbers_of_its_file(master_dir):  # noqa: F811
    import cosim

    path = osc_config(master_dir, stop=1.0)
    code = cosim.Config(master_dir / "code.toml", **_osc_specs())
    from_file = load_config(path)
    assert code.fmus["plant"].info is not None and code.controllers["src"].cls.__name__ == "Sine"
    assert code.record == from_file.record and code.connections == from_file.connections
    ours, theirs = cosim.run(code).frame("plant"), cosim.run(from_file).frame("plant")
    assert np.ptp(theirs.y) > 0.1 and np.array_equal(ours.to_numpy(), theirs.to_numpy())
    # a loaded config changed with dataclasses.replace is checked again, its paths still the file's
    with pytest.raises(ConfigError, match=r"run\.stop: must be > run\.start \(0\.0\); got -1\.0"):
        dataclasses.replace(from_file, run=cosim.config.RunSpec(stop=-1.0))
    shorter = dataclasses.replace(from_file, run=cosim.config.RunSpec(stop=0.5))
    assert shorter.overrides == () and dataclasses.replace(shorter, overrides=("run.stop=0.5",)) == load_config(
        path, ["run.stop=0.5"])


@pytest.mark.parametrize("where, value, expected", [
    (("connections", 0, "to"), "plant.uu", "no input 'uu'"),
    (("controllers", "src", "rate"), -5.0, "must be > 0; got -5.0"),
    (("fmus", "plant", "path"), "Missing.fmu", "does not exist"),
])
def test_an_invalid_config_constructed_in_code_raises_the_files_error(master_dir, where, value, expected):  # noqa: F811
    """An unknown connection target, a negative rate, a missing FMU: the same problem as the TOML file of the same
    content, but at its key (a file built in code has no lines)."""
    import cosim
    from cosim.config import Connection

    data = tomllib.loads(osc_config(master_dir, stop=1.0).read_text())
    table = data
    for key in where[:-1]:
        table = table[key]
    table[where[-1]] = value
    path = master_dir / "api_invalid.toml"
    path.write_text(toml_text(data))
    changes = {"connections": (Connection(("src", "u"), ("plant", "uu")),)} if where[0] == "connections" else {}
    specs = _osc_specs(**changes)
    if where[0] == "controllers":
        specs["controllers"] = {"src": dataclasses.replace(specs["controllers"]["src"], rate=value)}
    if where[0] == "fmus":
        specs["fmus"] = {"plant": dataclasses.replace(specs["fmus"]["plant"], path=value)}
    with pytest.raises(ConfigError) as from_file:
        load_config(path)
    with pytest.raises(ConfigError) as from_code:
        cosim.Config(path, **specs)
    [file_line] = from_file.value.problems
    [code_line] = from_code.value.problems
    assert expected in code_line and file_line.startswith(f"{path}:") and code_line.startswith(f"{path}: ")
    assert file_line.split(": ", 1)[1] == code_line.split(": ", 1)[1]


def test_with_set_checks_the_changed_config_and_leaves_the_config_alone(master_dir):  # noqa: F811
    import cosim

    config = cosim.Config.load(osc_config(master_dir, stop=1.0))
    shorter = config.with_set({"run.stop": 0.5, "fmus.plant.parameters.k": 4})
    assert shorter.run.stop == 0.5 and shorter.fmus["plant"].parameters == {"k": 4}
    assert shorter.overrides == ("run.stop=0.5", "fmus.plant.parameters.k=4")
    assert config.run.stop == 1.0 and config.fmus["plant"].parameters == {"k": 9.0}
    assert shorter == load_config(config.path, ["run.stop=0.5", "fmus.plant.parameters.k=4"])
    with pytest.raises(ConfigError, match=r"osc\.toml: run\.stop: must be > run\.start \(2\.0\); got 1\.0"):
        config.with_set(["run.start=2.0"])
    with pytest.raises(ConfigError, match="did you mean --set fmus.plant.parameters.k="):
        config.with_set({"plant.k": 1.0})


def test_build_returns_the_fmus_of_a_model_and_of_a_model_list(tmp_path):
    import fmpy

    import cosim

    source = tmp_path / "Lag.mo"
    source.write_text("model Lag \"first-order lag\"\n  parameter Real tau = 0.1;\n  input Real u;\n"
                      "  output Real y(start = 0, fixed = true);\nequation\n  tau * der(y) = u - y;\nend Lag;\n")
    one = cosim.build(source, "Lag", out=tmp_path / "fmus")
    assert one == [tmp_path / "fmus" / "Lag.fmu"] and fmpy.read_model_description(one[0]).fmiVersion == "3.0"
    models = tmp_path / "models.toml"
    models.write_text('[[model]]\nname = "Lag2"\nsource = "Lag.mo"\nmodel = "Lag"\nfmi_version = 2\n')
    lines = []
    listed = cosim.build(models, out=tmp_path / "fmus", report=lines.append)
    assert listed == [tmp_path / "fmus" / "Lag2.fmu"] and lines == [f"Lag2: built {listed[0]}"]
    assert fmpy.read_model_description(listed[0]).fmiVersion == "2.0"
    assert cosim.build(models, out=tmp_path / "fmus", report=lines.append) == listed
    assert lines[-1] == f"Lag2: up to date ({listed[0]})"
    with pytest.raises(CosimError, match="name the model to build"):
        cosim.build(source)


def test_import_cosim_imports_none_of_the_api():
    """Only the standard-library module that points numba's cache at the user's cache folder (before any kernel is
    decorated) is imported with cosim."""
    done = subprocess.run([sys.executable, "-c", "import sys, cosim; print(sorted(m for m in sys.modules "
                                                 "if m.startswith(('cosim.', 'numpy', 'pandas', 'numba'))))"],
                          capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "['cosim.kernel_cache']"


def _python_a_user_reads():
    """(where, source) of the Python shown to users: the README's and the guides' ``python`` blocks, and the
    examples' files. examples/data/*.py are left out: they made the shipped synthetic measurements from the
    model's internals (docs/dev), and are no example of how to use cosim."""
    root = Path(__file__).resolve().parents[1]
    for page in [root / "README.md", *sorted((root / "docs" / "guide").glob("*.md"))]:
        blocks = page.read_text(encoding="utf-8").split("```python\n")[1:]
        for number, block in enumerate(blocks, 1):
            yield f"{page.relative_to(root)} (python block {number})", block.partition("```")[0]
    for path in sorted((root / "examples").rglob("*.py")):
        if path.parent.name != "data":
            yield str(path.relative_to(root)), path.read_text(encoding="utf-8")


def test_the_code_users_read_imports_only_the_public_api():
    """Everything outside ``cosim.__all__`` is private (cosim/__init__.py): what the guides and examples show a
    user imports ``cosim``, names of its ``__all__``, or the shipped controllers, and nothing else of cosim."""
    import ast

    import cosim

    private = []
    for where, source in _python_a_user_reads():
        for node in ast.walk(ast.parse(source, where)):
            if isinstance(node, ast.Import):
                private += [f"{where}: import {a.name}" for a in node.names if a.name.startswith("cosim.")]
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("cosim"):
                if node.module == "cosim":
                    private += [f"{where}: from cosim import {a.name}" for a in node.names
                                if a.name not in cosim.__all__]
                elif not node.module.startswith("cosim_controllers"):
                    private.append(f"{where}: from {node.module} import ...")
    assert not private, "private modules in code users read: " + "; ".join(private)


def test_the_job_packages_are_the_api_calls_before_and_after_their_modules_are_imported():
    code = ("import sys, cosim\n"
            "from cosim.errors import ConfigError\n"
            "def refused(call):\n"
            "    try:\n"
            "        call('no_such_job.toml')\n"
            "    except ConfigError as error:\n"
            "        return 'does not exist' in str(error)\n"
            "print([refused(getattr(cosim, n)) for n in ('calibrate', 'diagnose', 'campaign')])\n"
            "import cosim.calibrate.job, cosim.diagnose.job, cosim.campaign.job\n"
            "print([refused(getattr(cosim, n)) for n in ('calibrate', 'diagnose', 'campaign')])\n"
            "print(cosim.calibrate.job.load_job.__module__, cosim.campaign.load_campaign.__module__)\n")
    for first in ("", "import cosim.calibrate.job, cosim.diagnose.job, cosim.campaign.job\n"):
        done = subprocess.run([sys.executable, "-c", first + code], capture_output=True, text=True, check=True)
        assert done.stdout.split("\n")[:3] == ["[True, True, True]", "[True, True, True]",
                                               "cosim.calibrate.job cosim.campaign.job"]


# the shipped contact calibration on its first 0.6 s (free travel, impact and the start of the hold), one start of
# three iterations: the same fit twice in a few seconds each (docs/guide/python.md runs the whole job's first start)
SHORT_CALIBRATION = {"data.stop": 0.6, "multistart.count": 1, "fit.max_iter": 3}


@pytest.mark.slow
def test_cosim_calibrate_gives_the_calibration_json_cosim_calibrate_writes(tmp_path, monkeypatch):
    import json

    import cosim
    from cosim.cli import main

    job = EXAMPLES / "calibrate_contact.toml"
    sets = [a for k, v in SHORT_CALIBRATION.items() for a in ("--set", f"{k}={v}")]
    monkeypatch.chdir(tmp_path)  # (the provenance names the data file relative to the working folder)
    assert main(["calibrate", str(job), "--out", "cli", "--no-progress", *sets]) == 0
    written = json.loads((tmp_path / "cli" / "calibration.json").read_text())
    before = _tree(tmp_path)
    result = cosim.calibrate(job, set=SHORT_CALIBRATION)
    assert _tree(tmp_path) == before and result.out is None
    assert isinstance(result, cosim.CalibrationResult)
    got = json.loads(json.dumps(result.to_json()))
    assert got["provenance"].pop("date") and written["provenance"].pop("date")
    assert got == written
    assert list(result.parameters) == ["k_P", "d_lim", "C_h"] and result.multistart[0]["start"] == {
        "k_P": 5e4, "d_lim": 3.0e-4, "C_h": 1000.0}  # the job's starts
    assert result.values == {n: p["value"] for n, p in written["parameters"].items()}


@pytest.mark.slow
def test_cosim_campaign_gives_the_tables_cosim_campaign_writes(job_path, tmp_path, monkeypatch):  # noqa: F811
    import json

    import pandas as pd

    import cosim
    from cosim.cli import main

    sets = GRID + ["campaign.trials=1"]  # bare and P3 at 1000 rpm, 1 A: one trial each
    monkeypatch.chdir(tmp_path)  # (the parameters files are named relative to the working folder)
    assert main(["campaign", str(job_path), "--out", "cli", "--workers", "1", "--no-progress",
                 *[a for s in sets for a in ("--set", s)]]) == 0
    before = _tree(job_path.parent)
    result = cosim.campaign(job_path, set=sets, workers=1)
    assert _tree(job_path.parent) == before and sorted(p.name for p in tmp_path.iterdir()) == ["cli"]
    assert isinstance(result, cosim.CampaignResult) and result.out is None and not result.interrupted
    trials = pd.read_parquet(tmp_path / "cli" / "trials.parquet")
    pd.testing.assert_frame_equal(result.records, trials)
    pd.testing.assert_frame_equal(result.table, pd.read_csv(tmp_path / "cli" / "table1.csv"), check_dtype=False)
    assert result.table_markdown == (tmp_path / "cli" / "table1.md").read_text(encoding="utf-8")
    for row in result.table.itertuples():  # one trial a cell: its steady force is the cell's median, IQR 0
        f = trials[trials.coating == row.coating].steady_force_N.to_numpy()
        assert row.n == 1 and row.median_N == np.percentile(f, 50) and row.iqr_N == 0.0
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text(encoding="utf-8"))
    got = json.loads(json.dumps(result.to_json()))
    timings = ("wall_s", "setup_s", "loop_s", "trials_s", "trial_s", "overhead_share", "load_average_1min")
    for entry in (got, summary):
        entry["run"] = {k: v for k, v in entry["run"].items() if k not in timings}
    assert got == summary and result.trials == 2 and result.cells == 2


# the shipped static diagnosis on its first 60 s, one candidate, one round
SHORT_DIAGNOSIS = {"data.stop": 60.0, "candidates.effects": ["backdrive_efficiency"], "decision.rounds": 1,
                   "compare.max_nfev": 5}


@pytest.mark.slow
def test_cosim_diagnose_gives_the_diagnosis_json_cosim_diagnose_writes(tmp_path, monkeypatch):
    import json

    import cosim
    from cosim.cli import main

    job = EXAMPLES / "diagnose_static.toml"
    sets = [a for k, v in SHORT_DIAGNOSIS.items() for a in ("--set", f"{k}={v}")]  # a list as a TOML array
    monkeypatch.chdir(tmp_path)
    assert main(["diagnose", str(job), "--out", "cli", "--no-build", "--no-progress", *sets]) == 0
    written = json.loads((tmp_path / "cli" / "diagnosis.json").read_text())
    before = _tree(tmp_path)
    result = cosim.diagnose(job, set=SHORT_DIAGNOSIS, build=False)
    assert _tree(tmp_path) == before
    assert isinstance(result, cosim.Diagnosis) and result.fmu is None
    assert json.loads(json.dumps(result.to_json())) == written
    assert written["verdict"] == result.verdict and result.candidates[0].effect == "backdrive_efficiency"
