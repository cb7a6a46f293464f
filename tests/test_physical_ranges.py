"""Physical ranges (issue #44): the ``min``/``max`` a Modelica parameter declares reach the FMU's
modelDescription.xml (FMI 3.0 and 2.0) and the master refuses a value outside them before the run, naming the key,
the range and the unit; a rate far faster than the plant's declared step is warned of."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import tomllib
import xml.etree.ElementTree as ET
import zipfile

import pytest
from test_master_support import EXAMPLES, gripper_dir, gripper_overrides  # noqa: F401

from cosim.cli import main
from cosim.errors import ScaleWarning
from cosim.fmi import read_model_info

ROOT = EXAMPLES.parent
IMPACT = str(EXAMPLES / "gripper_impact.toml")

_MODEL = """
model Ranged
  parameter Real eta(unit = "1", min = 0, max = 1) = 0.7 "an efficiency";
  parameter Real m(unit = "kg", min = 1e-3) = 2 "a mass";
  parameter Real g(unit = "m/s2") = 9.81 "no range";
  Real v(start = 0);
equation
  m * der(v) = eta * m * g;
end Ranged;
"""


@pytest.mark.parametrize("version", [3, 2])
def test_the_exporter_writes_the_declared_range(tmp_path, capsys, version):
    (tmp_path / "Ranged.mo").write_text(textwrap.dedent(_MODEL))
    assert main(["build", str(tmp_path / "Ranged.mo"), "--model", "Ranged", "--out", str(tmp_path / "f"),
                 "--fmi-version", str(version)]) == 0
    with zipfile.ZipFile(tmp_path / "f" / "Ranged.fmu") as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    if version == 3:
        attrs = {v.get("name"): v.attrib for v in root.find("ModelVariables")}
    else:  # FMI 2.0: min and max are attributes of the <Real> element inside the ScalarVariable
        attrs = {v.get("name"): v.find("Real").attrib for v in root.find("ModelVariables") if v.find("Real") is not None}
    assert (float(attrs["eta"]["min"]), float(attrs["eta"]["max"])) == (0.0, 1.0)
    assert float(attrs["m"]["min"]) == 1e-3 and "max" not in attrs["m"]
    assert "min" not in attrs["g"] and "max" not in attrs["g"]


def test_a_percent_efficiency_is_refused_before_the_run(tmp_path, capsys, gripper_dir):  # noqa: F811
    out = tmp_path / "o"
    argv = ["run", IMPACT, "--out", str(out), "--no-progress"]
    for item in [*gripper_overrides(gripper_dir), "fmus.plant.parameters.eta_g=68"]:
        argv += ["--set", item]
    assert main(argv) == 2  # before: ran until the states were NaN
    err = capsys.readouterr().err
    assert ("--set fmus.plant.parameters.eta_g: fmus.plant.parameters.eta_g: 68 is outside the range "
            "GripperPlant.fmu declares for eta_g: [0, 1] (no unit: a ratio); a percentage? 68 % is 0.68") in err
    assert not out.exists()


def test_negative_mass_and_stiffness_are_refused_with_their_units(tmp_path, capsys, gripper_dir):  # noqa: F811
    argv = ["run", IMPACT, "--out", str(tmp_path / "o")]
    for item in [*gripper_overrides(gripper_dir), "fmus.plant.parameters.m_jf=-0.08",
                 "fmus.plant.parameters.k_obj=-3.53e7"]:
        argv += ["--set", item]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "m_jf: -0.08 is outside the range GripperPlant.fmu declares for m_jf: [0, inf] kg" in err
    assert "k_obj: -35300000.0 is outside the range GripperPlant.fmu declares for k_obj: [0, inf] N/m" in err


# what physics says of a quantity of this unit, whatever the model: it is not negative
_NOT_NEGATIVE = {"kg", "kg.m2", "N/m", "N.m/rad", "Ohm", "H", "Pa.s", "N.s/m", "N.m.s/rad"}


def test_shipped_gripper_parameters_declare_their_physical_ranges(gripper_dir):  # noqa: F811
    for fmu in ("GripperPlant", "PMSM", "Drivetrain"):
        parameters = [v for v in read_model_info(gripper_dir / f"{fmu}.fmu").variables.values()
                      if v.causality == "parameter" and not v.name.startswith("_")]
        for v in parameters:
            if v.unit in _NOT_NEGATIVE:
                assert v.min is not None and v.min >= 0, (fmu, v.name, v.unit)
            if v.name.startswith("eta_") and v.unit == "1":
                assert (v.min, v.max) == (0.0, 1.0), (fmu, v.name)
            lo, hi = v.min if v.min is not None else -float("inf"), v.max if v.max is not None else float("inf")
            assert lo <= float(v.start) <= hi, (fmu, v.name)  # the shipped values are inside
        assert sum(v.min is not None for v in parameters) > len(parameters) / 2


@pytest.mark.slow  # builds the haptic Device11 FMU
def test_haptic_user_stiffness_below_zero_is_refused(tmp_path, capsys):
    assert main(["build", str(ROOT / "modelica" / "Haptic" / "package.mo"), "--model", "Haptic.Device11",
                 "--out", str(tmp_path / "f")]) == 0
    capsys.readouterr()
    argv = ["run", str(EXAMPLES / "haptic_wall.toml"), "--out", str(tmp_path / "o"),
            "--set", f"fmus.plant.path={tmp_path / 'f' / 'Device11.fmu'}", "--set", "fmus.plant.parameters.ks=-3.5"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "ks: -3.5 is outside the range Device11.fmu declares for ks: [0, inf] N.m/rad" in err


def test_a_rate_a_thousand_times_too_fast_is_warned_of(tmp_path, capsys, gripper_dir):  # noqa: F811
    argv = ["run", IMPACT, "--out", str(tmp_path / "o"), "--no-progress"]
    for item in [*gripper_overrides(gripper_dir), "controllers.foc.rate=26.6e6", "run.stop=1e-3"]:
        argv += ["--set", item]
    with pytest.warns(ScaleWarning) as caught:  # before: no word, a 1.9 s run took 70 s
        assert main(argv) == 0
    # the step the FMU declares: its _cs_step's start, read from the XML
    with zipfile.ZipFile(gripper_dir / "GripperPlant.fmu") as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    h = float(next(v for v in root.find("ModelVariables") if v.get("name") == "_cs_step").get("start"))
    assert [str(w.message) for w in caught] == [
        f"controllers.foc.rate = 2.66e+07 Hz: a period of 3.76e-08 s, {26.6e6 * h:.3g} times shorter than the step "
        f"GripperPlant.fmu declares ({h:.3g} s); the shipped configs run controllers at periods of 1/20 of their "
        "plant's step or longer (a factor 1000 typed by mistake? 26600 Hz)"]


@pytest.mark.slow  # a subprocess that loads the gripper and is stopped by Ctrl-C
def test_a_run_length_typed_in_milliseconds_is_warned_of_and_the_run_goes_on(tmp_path, gripper_dir):  # noqa: F811
    # 5 s typed as 5000 on the static config: 5000 s at the FOC's 26.6 kHz, 1.33e8 steps (the longest shipped run,
    # this config's own 250 s, is 6.65e6); before: no word, the run went on for hours
    config = EXAMPLES / "gripper_static.toml"
    rate = tomllib.loads(config.read_text())["controllers"]["foc"]["rate"]
    argv = [sys.executable, "-m", "cosim", "run", str(config), "--out", str(tmp_path / "o"), "--no-progress",
            "--set", *gripper_overrides(gripper_dir), "--set", "run.stop=5000"]
    proc = subprocess.Popen(argv, cwd=ROOT, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            start_new_session=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    watchdog = threading.Timer(120, os.killpg, (proc.pid, signal.SIGKILL))
    watchdog.start()
    try:
        first = proc.stderr.readline()
        running = proc.poll() is None  # a warning: the run has gone on
        os.killpg(proc.pid, signal.SIGINT)  # as the user who read it
        rest = proc.communicate(timeout=240)[1]
    finally:
        watchdog.cancel()
    assert first == (f"cosim run: warning: run.stop = 5000 s: a run of 5000 s is {5000 * rate:.3g} steps of "
                     f"controllers.foc at {rate:g} Hz, more than 2e+07 (the longest shipped run, "
                     "examples/gripper_static.toml, takes 6.65e+06); milliseconds typed as seconds? run.stop = 5 "
                     "is a run of 5 s\n"), first + rest
    assert running and proc.returncode == 130, rest
