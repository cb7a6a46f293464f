"""A new user's mistakes get the root cause first and a pointer to the fix (issue #44, "Errors"), through
``cosim.cli.main`` as a user types them: a missing or damaged FMU without its follow-on problems, a made-up
``--set`` key with the keys it may have meant, "did you mean" for model names and controller classes."""

import re
from pathlib import Path

import pytest
import rumoca
from test_master_support import EXAMPLES, cli_fails, gripper_dir, gripper_overrides  # noqa: F401

from cosim.cli import main

IMPACT = str(EXAMPLES / "gripper_impact.toml")


def _run(capsys, tmp_path, *sets):
    argv = ["run", IMPACT, "--out", str(tmp_path / "o"), "--no-progress"]
    for s in sets:
        argv += ["--set", s]
    return cli_fails(capsys, argv)


def test_missing_fmu_is_the_one_problem_and_says_how_to_build_it(tmp_path, capsys):
    config = tmp_path / "impact.toml"
    config.write_text(EXAMPLES.joinpath("gripper_impact.toml").read_text().replace("../fmus/", "fmus/"))
    err = cli_fails(capsys, ["run", str(config), "--out", str(tmp_path / "o")])
    # before: 6 problems, the 5 others about plot.panels and summary.force, which record the missing FMU's signals
    assert "1 problem in" in err and "plot.panels" not in err and "summary.force" not in err
    assert f"{config}:16: fmus.plant.path: FMU file '{tmp_path}/fmus/GripperPlant.fmu' does not exist" in err
    assert "`cosim build`" in err


def test_fmu_that_is_not_a_zip_set_on_the_command_line_comes_first(tmp_path, capsys):
    bad = tmp_path / "GripperPlant.fmu"
    bad.write_text("not a zip\n")
    err = _run(capsys, tmp_path, f"fmus.plant.path={bad}")
    lines = [line for line in err.splitlines() if line.startswith("  - ")]
    assert lines == [f"  - --set fmus.plant.path: fmus.plant.path: '{bad}' is not an FMU (not a zip archive); "
                     "if it is one cosim built, build it again: `cosim build --force`"]


def test_controller_class_that_cannot_load_hides_its_follow_on_problems(tmp_path, capsys, gripper_dir):  # noqa: F811
    err = _run(capsys, tmp_path, *gripper_overrides(gripper_dir), "controllers.outer.class=cosim_controllers.outr:OuterLoop")
    assert "1 problem in" in err and "summary" not in err and "plot.panels" not in err
    assert "controller module 'cosim_controllers.outr' not found" in err and "did you mean 'cosim_controllers.outer'?" in err


@pytest.mark.parametrize("item, meant", [
    ("plant.eta_g=0.7", "--set fmus.plant.parameters.eta_g=..."),     # the FMU instance's parameter
    ("foc.bandwidth=500", "--set controllers.foc.parameters.bandwidth_hz=..."),
])
def test_made_up_set_key_names_its_file_and_the_keys_meant(tmp_path, capsys, gripper_dir, item, meant):  # noqa: F811
    err = _run(capsys, tmp_path, *gripper_overrides(gripper_dir), item)
    key = item.partition("=")[0]
    assert f"--set {key}: {key}: unknown key in {IMPACT}; did you mean {meant}" in err
    assert "'plot'" not in err  # before: "plant: unknown key; did you mean 'plot'?", located at the file


def test_set_key_of_an_fmu_parameter_not_in_the_file_is_suggested(tmp_path, capsys, gripper_dir):  # noqa: F811
    # B_r is a parameter of GripperPlant.fmu that gripper_impact.toml does not set: known from the FMU
    err = _run(capsys, tmp_path, *gripper_overrides(gripper_dir), "plant.B_r=1e-6")
    assert "did you mean --set fmus.plant.parameters.B_r=...?" in err


def test_controller_class_case_slip(tmp_path, capsys, gripper_dir):  # noqa: F811
    err = _run(capsys, tmp_path, *gripper_overrides(gripper_dir), "controllers.foc.class=cosim_controllers.foc:Foc")
    assert "module 'cosim_controllers.foc' has no class 'Foc'; did you mean 'FOC'?" in err


@pytest.mark.parametrize("source, model, meant", [
    ("examples/hybrid/BouncingBall.mo", "BouncingBal", "'BouncingBall'"),
    ("modelica/Gripper/package.mo", "Gripper.GripperPlnt", "'Gripper.GripperPlant'"),
])
def test_build_misspelt_model_name(tmp_path, capsys, source, model, meant):
    root = EXAMPLES.parent
    err = cli_fails(capsys, ["build", str(root / source), "--model", model, "--out", str(tmp_path / "f")])
    assert f"no model named {model!r}" in err and f"did you mean {meant}" in err


# ---------------------------------------------------------------------------------------------- unbalanced models
# Each model's excess counted by hand: which unknowns no equation determines, which equations determine one unknown
@pytest.mark.parametrize("body, expected", [
    ("  Real x(start = 1);\n  Real y;\n  Real z;\nequation\n  der(x) = -x;\n  y = 2 * x;\n",
     "M.mo:4: model M is unbalanced (2 equations for 3 unknowns): 1 equation missing: z (M.mo:4) in no equation"),
    ("  Real x(start = 1);\n  Real y;\n  Real z;\nequation\n  der(x) = -x;\n  y + z = x;\n",
     "1 equation missing: y (M.mo:3), z (M.mo:4) determined only by the equations at M.mo:7, too few for them"),
    ("  Real x(start = 1);\n  Real y;\nequation\n  der(x) = -x;\n  y = 2 * x;\n  y = 3 * x;\n",
     "model M is unbalanced (3 equations for 2 unknowns): 1 equation too many: the equations at M.mo:6, M.mo:7 "
     "determine y (M.mo:3), 1 unknown"),
    ("  Real x(start = 1);\nequation\n  der(x) = -x;\n  x = 2;\n",
     "1 equation too many: M.mo:5 determine(s) no unknown (only states, parameters, inputs or constants)"),
])
def test_unbalanced_model_names_what_is_in_excess_with_its_line(tmp_path, capsys, body, expected):
    (tmp_path / "M.mo").write_text(f"model M\n{body}end M;\n")
    err = cli_fails(capsys, ["build", str(tmp_path / "M.mo"), "--model", "M", "--out", str(tmp_path / "f")])
    assert expected.replace("M.mo", f"{tmp_path}/M.mo") in err
    assert "b1c_definition" not in err and "rumoca" not in err  # before: rumoca's internal counts, no line


def _library(root, model, body):
    """A library folder ``root`` holding ``model`` (``Lib.Examples.Bad``) in a file of its own, with a
    ``package.mo`` for every package above it, as the MSL lays out its classes; returns the model's file."""
    *packages, name = model.split(".")
    folder = root
    for k, package in enumerate(packages):
        folder = folder / package
        folder.mkdir(parents=True, exist_ok=True)
        within = f"within {'.'.join(packages[:k])};\n" if k else ""
        (folder / "package.mo").write_text(f"{within}package {package}\nend {package};\n")
    path = folder / f"{name}.mo"
    path.write_text(f"within {'.'.join(packages)};\nmodel {name}\n{body}end {name};\n")
    return path


# Two equations for one algebraic unknown y beside the state: rumoca counts 3 equations, 2 unknowns.
OVERDETERMINED = "  Real x(start = 1);\n  Real y;\nequation\n  der(x) = -x;\n  y = 2 * x;\n  y = 3 * x;\n"


def test_front_end_refusal_names_rumoca_the_class_file_and_what_to_try(tmp_path, capsys):
    path = _library(tmp_path / "lib", "Lib.Examples.Bad", OVERDETERMINED)
    err = cli_fails(capsys, ["build", "--model", "Lib.Examples.Bad", "--modelica-path", str(tmp_path / "lib"),
                             "--out", str(tmp_path / "f")])
    # the class's own file and line (line 2: after "within"), not the library's top package.mo
    assert (f"{path}:2: rumoca {rumoca.version()}, the Modelica front end, refused Lib.Examples.Bad: unbalanced "
            "model: 3 equations, 2 unknowns (balance = 1)") in err
    assert "if another Modelica tool (OpenModelica, Dymola) accepts the model" in err
    assert "validation" not in err  # not an MSL example: the validation run says nothing of it


@pytest.mark.parametrize("model, expected", [
    # docs/validation.md, section msl-models: Blocks' Filter stopped at "rumoca", First was verified
    ("Modelica.Blocks.Examples.Filter",
     "cosim's validation run on the MSL 4.1.0 examples (docs/validation.md) saw rumoca refuse this model too: a "
     "limit of the front end, not a fault of the library"),
    ("Modelica.Mechanics.Rotational.Examples.First",
     "got this model further (stage verified); check that the library on --modelica-path is the MSL 4.1.0"),
    ("Modelica.Mechanics.Rotational.Examples.NotAnExample", "examples did not try this model"),
])
def test_front_end_refusal_of_an_msl_example_says_what_the_validation_run_saw(tmp_path, capsys, model, expected):
    # A stand-in library named Modelica whose example is unbalanced: the message comes from the table shipped in
    # the package (cosim/data/msl_validation.csv), the MSL itself is not needed
    _library(tmp_path / "lib", model, OVERDETERMINED)
    err = cli_fails(capsys, ["build", "--model", model, "--modelica-path", str(tmp_path / "lib"),
                             "--out", str(tmp_path / "f")])
    assert expected in err and f"refused {model}: unbalanced model" in err


def test_shipped_msl_validation_table_is_the_one_docs_validation_shows():
    from cosim.compile.refusal import validation_status

    text = (Path(__file__).resolve().parent.parent / "docs" / "validation.md").read_text(encoding="utf-8")
    section = text[text.index("<!-- validation:msl-models -->"):text.index("<!-- /validation:msl-models -->")]
    rows = re.findall(r"^\| (\S+) \| (\w+) \|", section, re.M)[1:]  # the header row left out
    assert len(rows) == 102
    for model, stage in rows:
        assert validation_status(f"Modelica.{model}")[0] == stage, model


@pytest.mark.parametrize("argv, expected", [
    (["margins", "--K", "nan"], "argument --K: expected a number > 0 in N.m/rad; got 'nan'"),
    (["margins", "--rate", "0"], "argument --rate: expected a number > 0 in Hz; got '0'"),
    (["arm", "--seed", "-1"], "argument --seed: expected a whole number >= 0; got '-1'"),
])
def test_haptic_arguments_out_of_range_are_refused_by_the_parser(tmp_path, capsys, argv, expected):
    # before: a ValueError traceback from cosim.haptic.margins, or from numpy's seeding
    with pytest.raises(SystemExit) as refused:
        main(["haptic", *argv, "--out", str(tmp_path / "o")])
    assert refused.value.code == 2 and expected in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
