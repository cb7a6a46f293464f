"""Every problem a user can cause ends with exit status 2 and one message naming the file:line or key, what was
expected and what was received, never a traceback (issue #31 items 1 and 5): through ``cosim.cli.main``."""

import json
import textwrap
import zipfile

import numpy as np
import pytest
from test_master_support import EXAMPLES, cli_fails, gripper_dir, gripper_overrides  # noqa: F401

from cosim.cli import main
from cosim.errors import ConfigError

STATIC = str(EXAMPLES / "gripper_static.toml")
CALIBRATE = str(EXAMPLES / "calibrate_static.toml")
DIAGNOSE = str(EXAMPLES / "diagnose_static.toml")


def _run(capsys, gripper_dir, *sets, out):  # noqa: F811
    argv = ["run", STATIC, "--out", str(out), "--no-progress"]
    for s in [*gripper_overrides(gripper_dir), *sets]:
        argv += ["--set", s]
    return cli_fails(capsys, argv)


# ---------------------------------------------------------------------------------------------- text not UTF-8
def test_config_not_utf8_names_line_and_column(tmp_path, capsys):
    path = tmp_path / "latin1.toml"
    path.write_bytes("[run]\nstop = 1.0  # d\u00e9but\n".encode("latin-1"))
    err = cli_fails(capsys, ["run", str(path), "--out", str(tmp_path / "o")])
    # "stop = 1.0  # d" is 15 characters: the byte 0xe9 is the 16th of line 2
    assert f"{path}:2:16: the config must be UTF-8 text; got byte 0xe9" in err


def test_parameters_file_not_utf8(tmp_path, capsys, gripper_dir):  # noqa: F811
    p = tmp_path / "p.toml"
    p.write_bytes("[parameters]\neta_g = 0.7  # \u00e9\n".encode("latin-1"))
    err = _run(capsys, gripper_dir, f"fmus.plant.parameters_file={p}", out=tmp_path / "o")
    assert "fmus.plant.parameters_file" in err and f"{p}:2:16: the parameters file must be UTF-8" in err


# ---------------------------------------------------------------------------------------------- --set paths
@pytest.mark.parametrize("item, expected", [
    ("record.signals.0.x=1", "record.signals[0] is a value ('plant.F_g'), not a table or a list"),
    ("record.signals.0.a.b=1", "record.signals[0] is a value ('plant.F_g'), not a table or a list"),
    ("..=1", "expected key=value with a dotted key such as run.stop"),
    ("record.signals.7=1", "record.signals is a list of 5 elements; expected an index 0 to 4, got 7"),
])
def test_set_paths_through_values(tmp_path, capsys, item, expected):
    err = cli_fails(capsys, ["run", STATIC, "--out", str(tmp_path), "--set", item])
    assert expected in err and "--set" in err


# ---------------------------------------------------------------------------------------------- NUL bytes
@pytest.mark.parametrize("command, text, line, key", [
    ("run", '[run]\nstop = 1.0\n\n[fmus.plant]\npath = "\\u0000"\n', 5, "fmus.plant.path"),
    ("calibrate", '[model]\nsource = "m.mo"\nparameters_file = "up/\\u0000.toml"\n', 3, "model.parameters_file"),
    ("diagnose", '[model]\nsource = "m.mo"\n\n[data]\npath = "a\\u0000b.csv"\n', 5, "data.path"),
    ("campaign", '[campaign]\nseed = 1\nparameters_file = "\\u0000"\n', 3, "campaign.parameters_file"),
    ("sensitivity", '[sensitivity]\ncampaign = "c\\u0000.toml"\n', 2, "sensitivity.campaign"),
    # in a list in an inline table (the fuzz's case): the line of the key that holds them
    ("diagnose", '[model]\nsource = {plant = ["\\u0000"]}\n', 2, "model.source.plant[0]"),
])
def test_a_nul_byte_in_a_path_is_a_config_error_at_its_line(tmp_path, capsys, command, text, line, key):
    # found by the loader fuzz: the operating system's ValueError "embedded null byte" escaped from reading the file
    path = tmp_path / "job.toml"
    path.write_text(text)
    err = cli_fails(capsys, [command, str(path), "--out", str(tmp_path / "o")])
    assert f"{path}:{line}: {key}: holds a NUL byte (\\u0000)" in err


def test_a_nul_byte_given_by_set_names_the_set_item(tmp_path, capsys):
    err = cli_fails(capsys, ["calibrate", CALIBRATE, "--out", str(tmp_path / "o"), "--set", 'data.path="\\u0000"'])
    assert "--set data.path: data.path: holds a NUL byte (\\u0000): '\\x00'" in err


def test_debug_shows_the_traceback(tmp_path):
    with pytest.raises(ConfigError):
        main(["--debug", "run", STATIC, "--out", str(tmp_path), "--set", "..=1"])


# ---------------------------------------------------------------------------------------------- config types
def test_summary_controller_of_the_wrong_type(tmp_path, capsys, gripper_dir):  # noqa: F811
    err = _run(capsys, gripper_dir, "summary.controller=[1]", out=tmp_path / "o")
    assert "--set summary.controller: summary.controller: must be a string; got [1]" in err


@pytest.mark.parametrize("spec", [":FOC", ".foc:FOC", "cosim_controllers.foc:", "a b:FOC"])
def test_malformed_controller_class(tmp_path, capsys, gripper_dir, spec):  # noqa: F811
    err = _run(capsys, gripper_dir, f'controllers.foc.class="{spec}"', out=tmp_path / "o")
    assert "controllers.foc.class" in err
    assert f"must be written 'package.module:Class' or 'file.py:Class'; got {spec!r}" in err


def test_controller_module_with_a_syntax_error(tmp_path, capsys, gripper_dir):  # noqa: F811
    (tmp_path / "bad.py").write_text("from cosim_controllers.foc import FOC\nx = (\n")
    err = _run(capsys, gripper_dir, f'controllers.foc.class="{tmp_path / "bad.py"}:FOC"', out=tmp_path / "o")
    assert f"has a syntax error at {tmp_path / 'bad.py'}:2" in err


def test_controller_module_raising_on_import(tmp_path, capsys, gripper_dir):  # noqa: F811
    (tmp_path / "boom.py").write_text("import math\n\nraise RuntimeError('no licence')\n")
    err = _run(capsys, gripper_dir, f'controllers.foc.class="{tmp_path / "boom.py"}:FOC"', out=tmp_path / "o")
    assert f"raised RuntimeError while it was imported, at {tmp_path / 'boom.py'}:3: no licence" in err


def test_controller_constructor_raising_names_controller_and_parameters(tmp_path, capsys, gripper_dir):  # noqa: F811
    # the shipped FOC with L_q = 1e20: exp(-R/L dt) rounds to 1, and its gain formula divides by 1 - 1
    err = _run(capsys, gripper_dir, "controllers.foc.parameters.L_q=1e20", out=tmp_path / "o")
    assert "controllers.foc.parameters" in err and "FOC(rate=26600, " in err and "L_q=1e+20" in err
    assert "raised ZeroDivisionError" in err
    assert not (tmp_path / "o").exists()


def test_unknown_plot_panel_signal_before_the_run(tmp_path, capsys, gripper_dir):  # noqa: F811
    err = _run(capsys, gripper_dir, 'plot.panels=[["F_g"], ["i_q", "F_jaw"]]', out=tmp_path / "o")
    assert "plot.panels[1][1]: 'F_jaw' is not a recorded column" in err and "recorded: F_g, i_q" in err
    assert not (tmp_path / "o").exists()  # checked at load: nothing ran, nothing written


# ---------------------------------------------------------------------------------------------- bounds
@pytest.mark.parametrize("item, key, expected", [
    ("run.stop=1e15", "controllers.foc.rate", "the run would take about 5.34e+19 steps"),
    ("record.rate=1e13", "record.rate", "more than run.max_steps = 1e+09"),
    ("controllers.foc.rate=1e15", "controllers.foc.rate", "the run would take about 5e+17 steps"),
    ("solver.substeps=1000000000", "solver.substeps", "6.65e+15 integrator steps over 250 s"),
    ("record.rate=1e-300", "record.rate", "must be >= 1 / (run.stop - run.start) = 0.004 Hz"),
])
def test_run_size_bounded_before_the_run(tmp_path, capsys, gripper_dir, item, key, expected):  # noqa: F811
    # steps: 250 s x (26600 + 100 + 100 Hz) instants + 250 s x 26600 Hz x substeps RK4 steps (hand-computed)
    err = _run(capsys, gripper_dir, item, out=tmp_path / "o")
    assert f"{key}: " in err and expected in err


def test_recording_memory_checked_against_available_memory(tmp_path, capsys, gripper_dir):  # noqa: F811
    # 1e12 rows x 6 columns x 8 bytes x 3 copies = 1.3e5 GiB: more than any machine running the suite has
    err = _run(capsys, gripper_dir, "record.rate=4e9", "run.max_steps=1e300", out=tmp_path / "o")
    assert "record.rate: recording 1e+12 rows of 6 columns" in err and "GiB of memory is available" in err


def test_time_base_beyond_64_bits(tmp_path, capsys, gripper_dir):  # noqa: F811
    # 1e-300 Hz: a period of 26600e300 ticks of the 26.6 kHz base
    err = _run(capsys, gripper_dir, "controllers.outer.rate=1e-300", "run.stop=1", out=tmp_path / "o")
    assert "no common time base a 64-bit tick counter holds" in err and "ctrl:outer 1e-300 Hz" in err


# ---------------------------------------------------------------------------------------------- FMU archives
def _bad_fmu(tmp_path, gripper_dir, name, corrupt):  # noqa: F811
    src = gripper_dir / "GripperPlant.fmu"
    path = tmp_path / name
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            zout.writestr(info, zin.read(info))
        if not corrupt:
            with zout.open("resources/padding.bin", "w", force_zip64=True) as f:
                for _ in range(40):
                    f.write(bytes(2**20))  # 40 MiB of zeros: deflate packs them about 1000:1
    if corrupt:
        data = bytearray(path.read_bytes())
        with zipfile.ZipFile(path) as z:
            info = next(i for i in z.infolist() if i.filename.endswith(".so"))
        start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
        data[start + 10:start + 60] = bytes(b ^ 0xA5 for b in data[start + 10:start + 60])
        path.write_bytes(data)
    return path


def test_corrupt_fmu_member(tmp_path, capsys, gripper_dir):  # noqa: F811
    fmu = _bad_fmu(tmp_path, gripper_dir, "corrupt.fmu", corrupt=True)
    err = _run(capsys, gripper_dir, f"fmus.plant.path={fmu}", "run.stop=0.01", out=tmp_path / "o")
    assert f"{fmu}: not a valid zip archive (corrupt or unsupported member)" in err


def test_zip_bomb_refused_before_inflating(tmp_path, capsys, gripper_dir):  # noqa: F811
    fmu = _bad_fmu(tmp_path, gripper_dir, "bomb.fmu", corrupt=False)
    assert fmu.stat().st_size < 2**20
    err = _run(capsys, gripper_dir, f"fmus.plant.path={fmu}", "run.stop=0.01", out=tmp_path / "o")
    assert "member 'resources/padding.bin' inflates" in err and "to 41943040 (more than 200:1)" in err


# ---------------------------------------------------------------------------------------------- cosim build
def _mo(tmp_path, text):
    (tmp_path / "src").mkdir(exist_ok=True)
    path = tmp_path / "src" / "P.mo"
    path.write_text(textwrap.dedent(text))
    return path


def test_build_non_utf8_source(tmp_path, capsys):
    (tmp_path / "src").mkdir()
    path = tmp_path / "src" / "M.mo"
    path.write_bytes('model M "r\u00e9sum\u00e9"\n  Real x(start = 1);\nequation\n  der(x) = -x;\nend M;\n'
                     .encode("latin-1"))
    err = cli_fails(capsys, ["build", str(path), "--model", "M", "--out", str(tmp_path / "fmus")])
    assert f"{path}:1:11: the Modelica source must be UTF-8 text; got byte 0xe9" in err


def test_build_out_is_an_existing_file(tmp_path, capsys):
    path = _mo(tmp_path, "model M\n  Real x(start = 1);\nequation\n  der(x) = -x;\nend M;\n")
    (tmp_path / "taken").write_text("mine")
    err = cli_fails(capsys, ["build", str(path), "--model", "M", "--out", str(tmp_path / "taken")])
    assert "exists and is not a folder" in err and (tmp_path / "taken").read_text() == "mine"


def test_build_recursive_function(tmp_path, capsys):
    path = _mo(tmp_path, """\
        package P
          function f
            input Real x;
            output Real y;
          algorithm
            y := if x > 1 then f(x - 1) else x;
          end f;
          model M
            Real x(start = 1);
          equation
            der(x) = -f(x);
          end M;
        end P;
        """)
    err = cli_fails(capsys, ["build", str(path), "--model", "P.M", "--out", str(tmp_path / "fmus")])
    assert "the recursive function P.f (P.f -> P.f" in err and f"{path}:" in err


@pytest.mark.parametrize("model, line, expected", [
    ("A", 5, "the denominator a is 0 at the parameter values (a = 0)"),
    ("B", 9, "a division by a literal 0"),
])
def test_build_division_by_zero(tmp_path, capsys, model, line, expected):
    path = _mo(tmp_path, """\
        package P
          model A
            parameter Real a = 0.0;
            Real x(start = 1);
          equation der(x) = -x / a;
          end A;
          model B
            Real x(start = 1);
          equation der(x) = -x + x / 0.0;
          end B;
        end P;
        """)
    err = cli_fails(capsys, ["build", str(path), "--model", f"P.{model}", "--out", str(tmp_path / "fmus")])
    assert f"{path}:{line}: P.{model} divides by zero: {expected}" in err


# ---------------------------------------------------------------------------------------------- jobs
@pytest.mark.parametrize("item, expected", [
    ("model.source=5", "model.source: must be a non-empty string; got 5"),
    ('fit.segments=[["a", 1]]', "fit.segments: must be a list of [start, stop] time windows in s"),
    ("model.parameters=3", "model.parameters: must be a table of name = number"),
    ("fit.signals=3", "fit.signals: must be a list of tables"),
])
def test_calibration_job_keys_of_the_wrong_type(tmp_path, capsys, item, expected):
    err = cli_fails(capsys, ["calibrate", CALIBRATE, "--out", str(tmp_path / "o"), "--set", item])
    assert f"--set {item.partition('=')[0]}: {expected}" in err


@pytest.mark.parametrize("item, expected", [
    ("model.source=5", "model.source: must be a non-empty string; got 5"),
    ("model.parameters=3", "model.parameters: must be a table of name = number"),
    ("compare.signals=[3]", "compare.signals[0]: must be a table {output"),
    ("parallel.workers=-1", "parallel.workers: must be >= 0"),
])
def test_diagnosis_job_keys_of_the_wrong_type(tmp_path, capsys, item, expected):
    err = cli_fails(capsys, ["diagnose", DIAGNOSE, "--out", str(tmp_path / "o"), "--set", item, "--no-build"])
    assert expected in err


def test_calibration_data_with_text_in_a_numeric_column(tmp_path, capsys):
    lines = (EXAMPLES / "data" / "static_paper.csv").read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("time"))
    row = lines[header + 4].split(",")
    lines[header + 4] = ",".join([*row[:-1], "abc"])
    data = tmp_path / "text.csv"
    data.write_text("\n".join(lines) + "\n")
    err = cli_fails(capsys, ["calibrate", CALIBRATE, "--out", str(tmp_path / "o"), "--set", f"data.path={data}", "--no-progress"])
    assert "data.path (text.csv): column 'F_g' must hold numbers" in err and "got 'abc' at data row 3" in err


# ---------------------------------------------------------------------------------------------- identifiability
def test_parameter_without_effect_is_not_identifiable(tmp_path, capsys):
    """x' = -k x, y = x + 0 c: the data determine k (closed form y = exp(-k t)) and not c, whose standard error a
    pseudo-inverse reported as exactly 0."""
    src = _mo(tmp_path, """\
        package P
          model Decay
            parameter Real k = 1.0;
            parameter Real c = 1.0;
            input Real u;
            output Real y;
            Real x(start = 1, fixed = true);
          equation
            der(x) = -k * x + 0 * c + 0 * u;
            y = x;
          end Decay;
        end P;
        """)
    t = np.linspace(0.0, 2.0, 201)
    rng = np.random.default_rng(3)
    y = np.exp(-2.0 * t) + rng.normal(0.0, 0.01, t.size)
    (tmp_path / "data.csv").write_text("time,u,y\n" + "\n".join(f"{a:.4f},0,{b:.6f}" for a, b in zip(t, y)) + "\n")
    (tmp_path / "job.toml").write_text(textwrap.dedent(f"""\
        [model]
        source = "{src}"
        name = "P.Decay"
        [data]
        path = "data.csv"
        inputs = {{ u = "u" }}
        [fit]
        signals = [{{ output = "y", noise = 0.01 }}]
        [parameters.k]
        start = 1.5
        min = 0.1
        max = 10.0
        [parameters.c]
        start = 1.0
        min = 0.0
        max = 2.0
        """))
    out = tmp_path / "out"
    assert main(["calibrate", str(tmp_path / "job.toml"), "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    result = json.loads((out / "calibration.json").read_text())
    k, c = result["parameters"]["k"], result["parameters"]["c"]
    assert k["identifiable"] and abs(k["value"] - 2.0) < 3 * k["std_error"] and 0 < k["std_error"] < 0.01
    assert not c["identifiable"] and c["std_error"] is None
    assert "c = 1 not identifiable: the fitted samples do not determine it" in printed
    assert "not identifiable" in (out / "parameters.toml").read_text()


def test_shipped_examples_still_load(gripper_dir):  # noqa: F811
    """The new checks refuse none of the shipped configs and jobs (their FMUs pointed at the session's)."""
    from cosim.calibrate.job import load_job
    from cosim.config import load_config
    from cosim.diagnose.job import load_diagnose_job

    assert load_config(STATIC, gripper_overrides(gripper_dir)).run.stop == 250.0
    split = load_config(EXAMPLES / "gripper_impact_split.toml", gripper_overrides(gripper_dir, split=True))
    assert set(split.fmus) == {"plant", "drive"}
    assert [load_job(job).model for job in sorted(EXAMPLES.glob("calibrate_*.toml"))] == \
        ["Gripper.GripperCurrentDriven"] * 2
    assert load_diagnose_job(DIAGNOSE).effects[0] == "backdrive_efficiency"


def test_build_newton_block_solving_for_a_derivative(tmp_path, capsys):
    """a.tau = tau_c tanh(der(a.phi) / w_s) with the unconnected flow a.tau = 0: the Newton block's unknown is
    der(a.phi), no variable of the model; its start guess is 0 (it raised StopIteration). Closed form: der = 0."""
    from cosim.compile import lower

    source = str(EXAMPLES.parent / "tests" / "models" / "compiler" / "CompilerTests.mo")
    assert main(["build", source, "--model", "CompilerTests.TanhFriction", "--out", str(tmp_path / "fmus")]) == 0
    assert "built" in capsys.readouterr().out and (tmp_path / "fmus" / "TanhFriction.fmu").is_file()
    model = lower(source, "CompilerTests.TanhFriction")
    assert model.derivatives(np.array([0.3]), np.zeros(0)).tolist() == [0.0]
