"""Other tools' co-simulation masters run our FMI 2.0 Co-Simulation FMU: libcosim (libcosimpy) and Ecos (ecospy)
step the gripper plant under constant inputs and agree with ``cosim run`` of the same FMU as a CS instance.

Both packages are in the ``test`` extra (ecospy needs Debian's libtbb12, which .ci/run installs); the masters run
in a subprocess (tests/other_tools_run.py), so that a crash in them fails the test instead of the session."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.master.run import run_config

RUNNER = Path(__file__).resolve().parent / "other_tools_run.py"
INPUTS = {"v_d": 0.5, "v_q": 2.0}  # V: the motor accelerates to about 45 rad/s and the jaws start to close
OUTPUTS = ["i_d", "i_q", "theta_m", "w_m", "x_jaw"]
STEP, STOP = 1e-3, 0.02  # s: communication step and end (before the jaws reach the object)


@pytest.fixture(scope="module")
def reference(fmi2_fmu, tmp_path_factory):
    """``cosim run`` of the plant FMU as a Co-Simulation instance, recorded at each communication point."""
    folder = tmp_path_factory.mktemp("other_tools")
    config = folder / "plant_cs.toml"
    start = ", ".join(f"{k} = {v}" for k, v in INPUTS.items())
    signals = json.dumps([f"plant.{name}" for name in OUTPUTS])
    config.write_text(f"""
[run]
stop = {STOP}
engine = "python"

[fmus.plant]
path = "{fmi2_fmu('GripperPlant')}"
kind = "CS"
start = {{ {start} }}

[record]
rate = {1 / STEP}
signals = {signals}
""")
    result, _, _ = run_config(config, out=folder / "out")
    return result.data


def _other_tool(tool, fmu):
    done = subprocess.run([sys.executable, str(RUNNER), tool, str(fmu), json.dumps(INPUTS), json.dumps(OUTPUTS),
                           str(STEP), str(STOP)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"{tool} failed (exit {done.returncode}):\n{done.stderr[-3000:]}"
    return np.array(json.loads(done.stdout.strip().splitlines()[-1]))


@pytest.mark.parametrize("tool", ["libcosim", "ecos"])
def test_other_master_runs_the_gripper_cs_fmu_like_cosim_run(tool, fmi2_fmu, reference):
    rows = _other_tool(tool, fmi2_fmu("GripperPlant"))
    assert rows.shape == (round(STOP / STEP), 1 + len(OUTPUTS))
    ours = reference[1:]  # the other tools report after each step; cosim also records t = 0
    np.testing.assert_allclose(rows[:, 0], ours["time"], atol=1e-9)
    for k, name in enumerate(OUTPUTS, start=1):
        span = np.ptp(ours[name])
        assert span > 0, f"{name} does not move under these inputs: the comparison would prove nothing"
        assert np.max(np.abs(rows[:, k] - ours[name])) <= 0.01 * span, name


def test_master_runs_the_gripper_as_cs_like_me_at_the_foc_rate(fmi2_fmu, tmp_path):
    """One config edit (``kind = "CS"``) runs the plant's embedded solver instead of the master's RK4; with one
    RK4 step per FOC period in both, the two implementations (Python master, C core) agree on the impact trial."""
    config = Path(__file__).resolve().parent.parent / "examples" / "gripper_impact.toml"
    common = ["run.stop=0.05", "run.engine=python", "controllers.foc.jit=false", "controllers.outer.jit=false",
              "summary.kind=none", f"fmus.plant.path={fmi2_fmu('GripperPlant')}"]
    me, _, _ = run_config(config, out=tmp_path / "me", overrides=common + ["fmus.plant.kind=ME"])
    cs, _, _ = run_config(config, out=tmp_path / "cs", overrides=common + [
        "fmus.plant.kind=CS", "fmus.plant.parameters._cs_step=1e-4"])  # >= the FOC period: one step per doStep
    for name in ("i_d", "i_q", "w_m"):  # the speed ramp: the jaws are still in their free travel
        assert np.ptp(me.data[name]) > 0
        np.testing.assert_allclose(cs.data[name], me.data[name], rtol=0, atol=1e-9 * np.ptp(me.data[name]))
