"""FMI 2.0 export (cosim build --fmi-version 2; cosim/compile/fmu_c/fmi2.c over the model core): every shipped
model validates and runs in fmpy as Model Exchange (CVode, Euler) and Co-Simulation; events against the closed
form of a bouncing ball; directional derivatives against central differences; FMU state save/restore; source
FMUs that compile without cosim."""

import ctypes
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.validation import validate_fmu

from cosim.cli import main
from cosim.compile import build_fmu, read_model_list
from cosim.errors import ConfigError
from fmus.reference import bounce_times

ROOT = Path(__file__).resolve().parent.parent
HYBRID_MODELS = ROOT / "tests" / "models" / "hybrid" / "Hybrid.mo"
SHIPPED = [entry["name"] for entry in read_model_list(ROOT / "modelica" / "models.toml")]
# Constant inputs that move each model's outputs within the first 20 ms, away from end stops and contacts.
INPUTS = {"GripperPlant": {"v_q": 2.0, "v_d": 0.5}, "PMSM": {"v_q": 2.0, "tau_load": 0.01},
          "Drivetrain": {"theta_m": 0.5}, "HapticArm": {"F": 1.0}, "HapticDevice11": {"tau": 0.01, "phi_ref": 0.1},
          "HapticDevice7": {"tau": 0.01, "phi_ref": 0.1}, "HapticDeviceArm": {"tau": 0.01, "phi_ref": 0.1}}
STOP, EULER_STEP = 0.02, 1e-5


def _outputs(fmu):
    md = fmpy.read_model_description(str(fmu))
    return md, [v.name for v in md.modelVariables if v.causality == "output"]


def _run(fmu, kind, solver="CVode", inputs=None, step=EULER_STEP, **kwargs):
    """fmpy's own simulation, sampled every millisecond (Euler: one ``step`` per output)."""
    _, outputs = _outputs(fmu)
    if solver == "Euler":
        kwargs.update(step_size=step, output_interval=step)
    else:
        kwargs.setdefault("output_interval", 1e-3)
    r = fmpy.simulate_fmu(str(fmu), fmi_type=kind, solver=solver, stop_time=STOP, start_values=inputs or {},
                          output=outputs, **kwargs)
    keep = np.isclose(np.remainder(r["time"] + 1e-9, 1e-3), 1e-9, atol=1e-8)
    return r[keep], outputs


def _error(r, ref, outputs):
    """Largest deviation from ``ref`` of each output, as a fraction of the output's range in ``ref``."""
    assert len(r) == len(ref)
    return {name: np.max(np.abs(r[name] - ref[name])) / np.ptp(ref[name]) for name in outputs if np.ptp(ref[name])}


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_model_as_fmi2_validates_and_runs_me_and_cs_in_fmpy(name, fmi2_fmu):
    fmu = fmi2_fmu(name)
    assert validate_fmu(str(fmu)) == []
    md, _ = _outputs(fmu)
    assert md.fmiVersion == "2.0" and md.modelExchange and md.coSimulation
    ref, outputs = _run(fmu, "ModelExchange", "CVode", INPUTS[name], relative_tolerance=1e-10)
    assert len(ref) == 21 and all(np.isfinite(ref[o]).all() for o in outputs)
    assert any(np.ptp(ref[o]) > 0 for o in outputs), "the inputs move no output: the comparison would be empty"
    cs, _ = _run(fmu, "CoSimulation", inputs=INPUTS[name])  # the model list's step (the gripper's: one FOC
    assert all(np.isfinite(cs[o]).all() for o in outputs)  # period, chosen for the coupled plant, not for this)
    cs, _ = _run(fmu, "CoSimulation", inputs={**INPUTS[name], "_cs_step": 1e-6})  # converged embedded RK4
    assert max(_error(cs, ref, outputs).values()) < 0.01
    errors = []
    for step in (EULER_STEP, EULER_STEP / 2):
        euler, _ = _run(fmu, "ModelExchange", "Euler", INPUTS[name], step=step)
        assert all(np.isfinite(euler[o]).all() for o in outputs)
        errors.append(max(_error(euler, ref, outputs).values()))
    if name != "Drivetrain":  # its play and stick-slip friction: Euler at 10 us is not yet in its first-order range
        assert 0.4 < errors[1] / errors[0] < 0.6  # first order: half the step, half the error


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    return build_fmu(HYBRID_MODELS, "Hybrid.BouncingBall", out_dir=tmp_path_factory.mktemp("ball2"),
                     fmi_version=2, cs_step=1e-3)


def _bounce_times(r):
    n = r["bounces"]
    return np.array([r["time"][np.argmax(n >= k)] for k in range(1, int(n[-1]) + 1)])


@pytest.mark.parametrize("kind, solver, interval, tolerance", [
    ("ModelExchange", "CVode", 1e-2, 1e-6),  # fmpy records a row at each event CVode locates
    ("ModelExchange", "Euler", 1e-4, 3e-3),  # first order: 30 steps, as the FMI 3.0 test
    ("CoSimulation", "CVode", 1e-4, 1e-4 + 1e-9)])  # located inside doStep, seen at the end of the step
def test_bouncing_ball_fmi2_bounces_at_the_closed_form_times(ball, kind, solver, interval, tolerance):
    assert validate_fmu(str(ball)) == []
    md = fmpy.read_model_description(str(ball))
    assert md.numberOfEventIndicators == 1
    assert {v.name: v.type for v in md.modelVariables}["bounces"] == "Integer"
    kwargs = {"step_size": interval} if solver == "Euler" else {"relative_tolerance": 1e-10}
    r = fmpy.simulate_fmu(str(ball), fmi_type=kind, solver=solver, stop_time=2.0, output_interval=interval,
                          output=["bounces"], **kwargs)
    expected = bounce_times(e=0.8, v_min=0.0, stop=2.0)
    assert r["bounces"][-1] == len(expected) == 3
    assert np.max(np.abs(_bounce_times(r) - expected)) < tolerance


@pytest.fixture(scope="module")
def relay(tmp_path_factory):
    return build_fmu(HYBRID_MODELS, "Hybrid.Relay", out_dir=tmp_path_factory.mktemp("relay2"), fmi_version=2)


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_relay_fmi2_maps_enumeration_and_booleans_to_integer_and_boolean(relay, kind):
    fmu = relay
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    types = {v.name: v.type for v in md.modelVariables if v.variability == "discrete"}
    assert types == {"dir": "Integer", "up": "Boolean", "rises": "Integer", "late": "Boolean"}
    r = fmpy.simulate_fmu(str(fmu), fmi_type=kind, stop_time=3.0, output_interval=1e-3, relative_tolerance=1e-10,
                          output=["dir", "up", "rises", "late"])
    # Hand-computed (tests/test_export.py): x = 0.5 + t reaches 0.9 at 0.4, 0.1 at 1.2, 0.9 at 2.0, 0.1 at 2.8;
    # dir is the ordinal (Up = 1, Down = 2); ``late`` is a time event at 0.9. CS shows a change at the end of
    # the step holding it: one output interval.
    changes = {name: np.flatnonzero(np.diff(r[name].astype(float))) + 1 for name in ("dir", "rises", "late")}
    tolerance = 1e-6 if kind == "ModelExchange" else 1e-3 + 1e-9
    assert r["time"][changes["dir"]] == pytest.approx([0.4, 1.2, 2.0, 2.8], abs=tolerance)
    assert list(r["dir"][changes["dir"]]) == [2, 1, 2, 1] and r["dir"].dtype.kind == "i"
    assert list(r["up"][changes["dir"]]) == [False, True, False, True] and r["up"].dtype == bool
    assert r["time"][changes["rises"]] == pytest.approx([1.2, 2.8], abs=tolerance)
    assert r["time"][changes["late"]] == pytest.approx([0.9], abs=tolerance)


def _model2(fmu, tmp_path):
    md = fmpy.read_model_description(str(fmu))
    unzipped = fmpy.extract(str(fmu), unzipdir=tmp_path / "unzipped")
    model = FMU2Model(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName="test")
    model.instantiate()
    model.setupExperiment(startTime=0.0)
    model.enterInitializationMode()
    model.exitInitializationMode()
    while model.newDiscreteStates()[0]:
        pass
    model.enterContinuousTimeMode()
    return md, model, {v.name: v.valueReference for v in md.modelVariables}


def test_directional_derivatives_equal_central_differences(fmi2_fmu, tmp_path):
    md, model, vrs = _model2(fmi2_fmu("GripperPlant"), tmp_path)
    derivatives = [v for v in md.modelVariables if v.derivative is not None]
    n = len(derivatives)
    x = np.array([0.3, 1.2, 0.7, 25.0, 0.01, 0.002, 1e-4, 0.01])[:n]  # a moving drive, jaws in free travel
    model.setReal([vrs["v_q"], vrs["v_d"]], [2.0, 0.5])
    unknowns = [v.valueReference for v in derivatives] + [vrs[name] for name in ("i_q", "w_m", "x_jaw")]
    knowns = [v.derivative.valueReference for v in derivatives] + [vrs["v_q"]]

    def set_states(x):
        model.setContinuousStates((ctypes.c_double * n)(*x), n)

    def values(x, v_q):
        set_states(x)
        model.setReal([vrs["v_q"]], [v_q])
        return np.array(model.getReal(unknowns))

    for k, known in enumerate(knowns):
        set_states(x)
        model.setReal([vrs["v_q"]], [2.0])
        exact = np.array(model.getDirectionalDerivative(unknowns, [known], [1.0]))
        dx = np.zeros(n)
        h = 1e-6 * max(1.0, abs(x[k])) if k < n else 1e-6 * 2.0
        if k < n:
            dx[k] = h
            central = (values(x + dx, 2.0) - values(x - dx, 2.0)) / (2 * h)
        else:
            central = (values(x, 2.0 + h) - values(x, 2.0 - h)) / (2 * h)
        np.testing.assert_allclose(exact, central, rtol=1e-6, atol=1e-6 * np.max(np.abs(central)))
    model.terminate()
    model.freeInstance()


def _slave(fmu, tmp_path, name):
    md = fmpy.read_model_description(str(fmu))
    unzipped = fmpy.extract(str(fmu), unzipdir=tmp_path / name)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return slave, {v.name: v.valueReference for v in md.modelVariables}


def test_fmu_state_restored_repeats_the_run_bitwise(fmi2_fmu, tmp_path):
    """Saved, the run continued, restored (in place and, deserialised, in a second instance): the same outputs."""
    fmu = fmi2_fmu("GripperPlant")
    slave, vrs = _slave(fmu, tmp_path, "first")
    outputs = [vrs[name] for name in ("i_d", "i_q", "theta_m", "w_m", "x_jaw")]
    slave.setReal([vrs["v_q"], vrs["v_d"]], [2.0, 0.5])

    def run(instance, t0):
        rows = []
        for k in range(5):
            instance.doStep(t0 + k * 1e-3, 1e-3)
            rows.append(instance.getReal(outputs))
        return np.array(rows)

    run(slave, 0.0)
    state = slave.getFMUstate()
    serialized = slave.serializeFMUstate(state)
    first = run(slave, 5e-3)
    slave.setFMUstate(state)
    again = run(slave, 5e-3)
    other, _ = _slave(fmu, tmp_path, "second")
    other.setFMUstate(other.deSerializeFMUstate(serialized))
    elsewhere = run(other, 5e-3)
    assert np.ptp(first[:, 3]) > 0  # the motor accelerates over the repeated steps
    assert np.array_equal(first, again) and np.array_equal(first, elsewhere)
    slave.freeFMUstate(state)
    for instance in (slave, other):
        instance.terminate()
        instance.freeInstance()


def test_source_fmu_compiles_without_cosim_and_runs_the_same(tmp_path):
    """``cosim build --fmi-version 2 --source``: the sources listed in the modelDescription compile with the
    standard's headers alone (no cosim flags) into a binary that gives the shipped binary's results."""
    source = ROOT / "modelica" / "Haptic" / "package.mo"
    assert main(["build", str(source), "--model", "Haptic.Device7", "--fmi-version", "2", "--source",
                 "--out", str(tmp_path)]) == 0
    fmu = tmp_path / "Device7.fmu"
    unzipped = tmp_path / "unzipped"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unzipped)
    files = _source_files(unzipped / "modelDescription.xml")
    assert files["ModelExchange"] == files["CoSimulation"] and "fmi2.c" in files["CoSimulation"]
    files = files["CoSimulation"]
    binary = unzipped / "binaries" / fmpy.platform / f"Device7{fmpy.sharedLibraryExtension}"
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", f"-I{unzipped / 'sources'}", f"-I{headers}",
                    *(str(unzipped / "sources" / f) for f in files), "-o", str(binary), "-lm"], check=True)
    rebuilt = Path(shutil.make_archive(str(tmp_path / "rebuilt"), "zip", unzipped)).rename(tmp_path / "Device7b.fmu")
    inputs = {"tau": 0.01, "phi_ref": 0.1}
    shipped, outputs = _run(fmu, "ModelExchange", "CVode", inputs)
    compiled, _ = _run(rebuilt, "ModelExchange", "CVode", inputs)
    for name in outputs:
        np.testing.assert_allclose(compiled[name], shipped[name], rtol=1e-12, atol=0)


def _source_files(model_description):
    """The SourceFiles of each interface element of an FMI 2.0 modelDescription.xml."""
    root = ET.parse(model_description).getroot()
    return {kind: [f.get("name") for f in root.find(kind).iter("File")] for kind in ("ModelExchange", "CoSimulation")}


def test_default_fmu_ships_no_sources(fmi2_fmu):
    with zipfile.ZipFile(fmi2_fmu("GripperPlant")) as archive:
        assert not [n for n in archive.namelist() if n.startswith("sources/")]
        with archive.open("modelDescription.xml") as md:
            assert _source_files(md) == {"ModelExchange": [], "CoSimulation": []}


@pytest.mark.parametrize("line, message", [("fmi_version = 4", "fmi_version must be 2 or 3, not 4"),
                                           ("cs_step = -1e-3", "cs_step must be a positive step in s, not -0.001"),
                                           ('cs_method = "bdf"', "cs_method must be one of rk4, implicit_euler")])
def test_model_list_rejects_bad_fmu_settings_with_the_line(tmp_path, line, message):
    models = tmp_path / "models.toml"
    models.write_text(f'[[model]]\nname = "M"\nmodel = "P.M"\nsource = "P/package.mo"\n{line}\n')
    with pytest.raises(ConfigError, match=f"models.toml:2: model\\[0\\] {message}"):
        read_model_list(models)


def test_terminal_when_clauses_fire_at_fmi2_terminate_after_co_simulation_steps(tmp_path):
    fmu = build_fmu(HYBRID_MODELS, "Hybrid.Terminal", out_dir=tmp_path, fmi_version=2, cs_step=1e-3)
    slave, vrs = _slave(fmu, tmp_path, "terminal")
    for k in range(500):
        slave.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
    assert slave.getReal([vrs["x_end"]]) == [0.0]  # terminal() false while the simulation runs
    slave.terminate()
    x_end, y = slave.getReal([vrs["x_end"], vrs["y"]])
    # der(x) = -x from x = 1: x(0.5) = exp(-0.5) (RK4 at 1 ms: error ~1e-14); y = 2 x_end
    assert x_end == pytest.approx(np.exp(-0.5), rel=1e-10) and y == 2 * x_end
    assert slave.getInteger([vrs["n_end"]]) == [1]
    slave.freeInstance()
