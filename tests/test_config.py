"""cosim.config: frozen spec, --set overrides, and every bad input reported with file:line, exit 2, nothing written."""

import dataclasses
import json
import shutil
import textwrap
import tomllib
import warnings
from pathlib import Path

import pytest
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

from cosim.cli import main
from cosim.config import load_config, parse_overrides
from cosim.errors import ConfigError, ScaleWarning
from cosim.master import run_config

ROOT = EXAMPLES.parent
MSL = ROOT.parent / "shared" / "msl" / "ModelicaStandardLibrary-4.1.0"


def _problems(path, overrides=()):
    with pytest.raises(ConfigError) as err:
        load_config(path, overrides)
    return str(err.value)


def test_valid_config_is_frozen_and_typed(master_dir):
    cfg = load_config(osc_config(master_dir))
    assert cfg.run.stop == 2.0 and cfg.solver.method == "rk4"
    assert cfg.fmus["plant"].parameters == {"k": 9.0}
    assert cfg.controllers["src"].rate == 1000
    assert cfg.connections[0].src == ("src", "u") and cfg.connections[0].dst == ("plant", "u")
    assert cfg.record.signals == (("plant", "y"), ("plant", "v_out"), ("src", "u"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.run.stop = 3.0


def test_set_overrides_any_key(master_dir):
    cfg = load_config(osc_config(master_dir), ["fmus.plant.parameters.c=0.7", "run.stop=0.5",
                                               "controllers.src.parameters.amp=3", "connections.0.gain=2.5",
                                               "solver.method=radau"])
    assert cfg.fmus["plant"].parameters == {"k": 9.0, "c": 0.7}
    assert cfg.run.stop == 0.5 and cfg.controllers["src"].parameters["amp"] == 3
    assert cfg.connections[0].gain == 2.5 and cfg.solver.method == "radau"


def test_parse_overrides_values():
    assert parse_overrides(["a.b=1", "c=[1, 2]", "d=word", "e=\"q\"", "f=true"]) == [
        (("a", "b"), 1), (("c",), [1, 2]), (("d",), "word"), (("e",), "q"), (("f",), True)]
    with pytest.raises(ConfigError, match="key=value"):
        parse_overrides(["novalue"])


def test_unknown_keys_with_lines_and_close_names(master_dir):
    path = osc_config(master_dir, extra="\n[recrod]\nrate = 5\n")
    text = path.read_text().replace("[run]\n", "[run]\nstpo = 3\n")
    path.write_text(text)
    msg = _problems(path)
    line_stpo = text.splitlines().index("stpo = 3") + 1
    line_rec = text.splitlines().index("[recrod]") + 1
    assert f"osc.toml:{line_stpo}: run.stpo: unknown key; did you mean 'stop'?" in msg
    assert f"osc.toml:{line_rec}: recrod: unknown key; did you mean 'record'?" in msg
    assert "2 problems" in msg


def test_unknown_variable_lists_close_names(master_dir):
    path = osc_config(master_dir)
    path.write_text(path.read_text().replace('to = "plant.u"', 'to = "plant.uu"'))
    msg = _problems(path)
    line = path.read_text().splitlines().index('to = "plant.uu"') + 1
    assert f"osc.toml:{line}: connections[0].to: plant has no input 'uu'; did you mean 'u'?" in msg


def test_wrong_causality(master_dir):
    path = osc_config(master_dir)
    path.write_text(path.read_text().replace('to = "plant.u"', 'to = "plant.y"'))
    msg = _problems(path)
    assert "plant.y has causality 'output'; a connection's 'to' end must be an input" in msg


def test_missing_fmu_negative_rate_unknown_parameter(master_dir):
    path = osc_config(master_dir)
    text = path.read_text().replace('path = "Osc.fmu"', 'path = "Missing.fmu"').replace("rate = 1000", "rate = -1000")
    path.write_text(text)
    msg = _problems(path, ["controllers.src.parameters.ampl=1"])
    lines = text.splitlines()
    line_path = lines.index('path = "Missing.fmu"') + 1
    assert f"osc.toml:{line_path}: fmus.plant.path: FMU file" in msg
    assert "Missing.fmu' does not exist" in msg
    assert f"osc.toml:{lines.index('rate = -1000') + 1}: controllers.src.rate: must be > 0; got -1000" in msg
    assert "--set controllers.src.parameters.ampl: controllers.src.parameters.ampl: Sine has no parameter 'ampl'; " \
           "did you mean 'amp'?" in msg


def test_parameter_of_the_fmu_checked(master_dir):
    msg = _problems(osc_config(master_dir), ["fmus.plant.parameters.kk=2", "fmus.plant.parameters.y=1"])
    assert "has no parameter 'kk'; did you mean 'k'?" in msg
    assert "'y' is a continuous output, not a settable parameter" in msg


def test_malformed_toml_has_line_and_column(master_dir):
    path = master_dir / "broken.toml"
    path.write_text("[run]\nstop = 1.0\n[fmus.plant\npath = 'x'\n")
    msg = _problems(path)
    assert "broken.toml:3:" in msg and "malformed TOML" in msg


@pytest.mark.parametrize(
    "edit",
    [
        ("stop = 2.0", "stop = 2.0\nbogus = 1"),  # unknown key
        ('path = "Osc.fmu"', 'path = "Nope.fmu"'),  # missing FMU
        ('to = "plant.u"', 'to = "plant.q"'),  # unknown variable
        ('from = "src.u"', 'from = "plant.u"'),  # wrong causality (input as source)
        ("rate = 1000", "rate = -5"),  # negative rate
        ("[run]", "[run"),  # malformed TOML
    ],
)
def test_cli_bad_input_exit_2_nothing_written(master_dir, tmp_path, capsys, edit):
    path = osc_config(tmp_path)
    shutil.copy(master_dir / "Osc.fmu", tmp_path)
    shutil.copy(master_dir / "ctl.py", tmp_path)
    path.write_text(path.read_text().replace(*edit))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "osc.toml:" in err and err.count("cosim run: error") == 1
    assert not out.exists()


@pytest.fixture(scope="module")
def shipped_fmus(tmp_path_factory):
    """Every FMU a shipped run config names, built as the guides say (cosim build's model lists, so with their
    cs_step: the plant step the time-scale warnings are told against): a folder; DcDrive only with the MSL."""
    from cosim.compile import build_all, build_fmu

    out = tmp_path_factory.mktemp("shipped_fmus")
    lists = [(ROOT / "modelica" / "models.toml", [])]
    if (MSL / "Modelica" / "package.mo").is_file():
        lists.append((EXAMPLES / "msl_drive" / "models.toml", [MSL]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for models, path in lists:
            list(build_all(models_toml=models, out_dir=out, modelica_path=path))
        build_fmu(EXAMPLES / "hybrid" / "BouncingBall.mo", "BouncingBall", out_dir=out)
        build_fmu(EXAMPLES / "ssp" / "Oscillators.mo", "Oscillators.Body", out_dir=out, fmi_version=2)
    return out


@pytest.mark.slow
def test_shipped_configs_validate(gripper_dir):
    for name in ("gripper_static", "gripper_impact", "gripper_impact_p3"):
        cfg = load_config(EXAMPLES / f"{name}.toml", gripper_overrides(gripper_dir))
        assert set(cfg.controllers) == {"foc", "outer"} and "plant" in cfg.fmus
    cfg = load_config(EXAMPLES / "gripper_impact_split.toml", gripper_overrides(gripper_dir, split=True))
    assert set(cfg.fmus) == {"plant", "drive"}
    assert cfg.summary.columns == {"force": "F_g", "t_switch": "outer.t_switch"}


@pytest.mark.slow
def test_every_shipped_run_config_loads_without_a_scale_warning(shipped_fmus):
    # every examples/**/*.toml with a [run] table, its FMUs as cosim build makes them: no rate, no run length is
    # far from its plant's time scale (gripper_static, 6.65e6 FOC steps, is the longest)
    configs = [p for p in sorted(EXAMPLES.rglob("*.toml")) if "run" in tomllib.loads(p.read_text())]
    assert len(configs) >= 9
    loaded = []
    for path in configs:
        fmus = tomllib.loads(path.read_text()).get("fmus", {})
        if not all((shipped_fmus / Path(f["path"]).name).is_file() for f in fmus.values()):
            assert path.name == "drive.toml"  # the MSL's DcDrive, built when the MSL is there
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error", ScaleWarning)
            load_config(path, [f"fmus.{n}.path={shipped_fmus / Path(f['path']).name}" for n, f in fmus.items()])
        loaded.append(path.name)
    assert {"gripper_static.toml", "gripper_impact.toml", "speed_pi.toml", "haptic_wall.toml", "two_bodies.toml",
            "held.toml"} <= set(loaded)


def test_summary_kind_none_keeps_the_keys_of_the_controllers_summaries(gripper_dir):
    overrides = gripper_overrides(gripper_dir) + ["plot.panels=[[\"F_g\"]]", "summary.kind=none",
                                                  "record.signals=[\"plant.F_g\"]"]
    cfg = load_config(EXAMPLES / "gripper_impact.toml", overrides)
    assert cfg.summary.plugin is None and cfg.record.signals == (("plant", "F_g"),)
    cfg = load_config(EXAMPLES / "gripper_impact.toml", overrides[:-2] + ["record.signals=[\"plant.F_g\"]"])
    assert cfg.record.signals == (("plant", "F_g"), ("outer", "t_switch"))  # the impact summary reads it


# a controller that provides a summary plugin: the master and the config know nothing of it
RAMP_PY = textwrap.dedent(
    '''
    import numpy as np
    from cosim.controller import Controller

    def _ramp(t, u, y, x, p):
        y[0] = p[0] * t
        y[1] = p[0]

    class PeakSummary:
        """The largest value of a recorded column, the ramp's slope output and its gain parameter."""
        signals = ("column",)
        outputs = ("slope",)

        @staticmethod
        def summarize(data, values, columns):
            return {"peak": float(np.max(data[columns["column"]])), "slope": float(data[columns["slope"]][-1]),
                    "gain": values["gain"]}

    class Ramp(Controller):
        """Source: gain * t, and the slope."""
        parameters = {"gain": 1.0}
        outputs = ("u", "slope")
        kernel = staticmethod(_ramp)
        summaries = {"peak": PeakSummary}
    '''
)

RAMP_TOML = textwrap.dedent(
    """
    [run]
    stop = 0.5
    engine = "python"

    [fmus.plant]
    path = "Osc.fmu"

    [controllers.src]
    class = "ramp.py:Ramp"
    rate = 100
    jit = false
    parameters = { gain = 3.0 }

    [[connections]]
    from = "src.u"
    to = "plant.u"

    [record]
    rate = 100
    signals = ["plant.y"]

    [summary]
    kind = "peak"
    controller = "src"
    column = "y"
    """
)


@pytest.fixture
def ramp_config(master_dir, tmp_path):
    shutil.copy(master_dir / "Osc.fmu", tmp_path)
    (tmp_path / "ramp.py").write_text(RAMP_PY)
    path = tmp_path / "ramp.toml"
    path.write_text(RAMP_TOML)
    return path


def test_summary_plugin_of_a_controller(ramp_config, tmp_path):
    result, summary, _ = run_config(ramp_config, out=tmp_path / "out", progress=False)
    assert summary["peak"] == pytest.approx(float(max(result.data["y"])))
    assert summary["slope"] == 3.0 and summary["gain"] == 3.0  # src.slope recorded for the summary
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["peak"] == summary["peak"]


def test_summary_problems(ramp_config, master_dir):
    msg = _problems(ramp_config, ["summary.column=v_out", "summary.force=y"])
    assert "--set summary.column: summary.column: 'v_out' is not among record.signals" in msg
    assert "--set summary.force: summary.force: unknown key (allowed: kind, controller, column)" in msg
    msg = _problems(ramp_config, ["summary.kind=peek"])
    assert "summary.kind: must be one of 'none', 'peak' (the summaries Ramp provides); got 'peek'; " \
           "did you mean 'peak'?" in msg
    text = ramp_config.read_text()
    ramp_config.write_text(text.replace('column = "y"\n', ""))
    assert "summary.column: is required: the recorded column the 'peak' summary reads" in _problems(ramp_config)
    ramp_config.write_text(text.replace('controller = "src"\n', ""))
    assert "summary.controller: is required" in _problems(ramp_config)
    msg = _problems(osc_config(master_dir), ["summary.kind=impact", "summary.controller=src"])
    assert "summary.kind: must be one of 'none' (the summaries Sine provides); got 'impact'" in msg


@pytest.mark.parametrize("key", ["run.bogus", "solver.bogus", "fmus.plant.bogus", "controllers.src.bogus",
                                 "connections.0.bogus", "record.bogus", "plot.bogus", "summary.bogus", "bogus"])
def test_unknown_key_in_every_table(master_dir, key):
    msg = _problems(osc_config(master_dir), [f"{key}=1"])
    assert f"--set {key}: " in msg and "unknown key" in msg
