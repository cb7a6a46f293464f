"""The compiled engine (issue 8): same results as the Python engine on every shipped config and on the
FMI 2.0 ME/CS paths, fallback to the Python engine with a one-line reason, Ctrl-C, progress, compile time.

Reference: the Python engine (cosim.master.engine.Engine), itself tested against exact solutions in
test_master.py. Both engines do the same floating-point operations at the same instants, so the
tolerance is 1e-9 of each signal's range (issue 8); in practice they agree bitwise.
"""

import _thread
import json
import signal
import threading
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_controllers import _all_controller_classes, required_parameters
from test_master_support import EXAMPLES, ROOT, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

from cosim.config import load_config
from cosim.master import run, run_config
from cosim.errors import EngineFallbackWarning, ScaleWarning
from cosim.master.compiled import CompiledLoop
from cosim.master.engine import engine_for


@pytest.fixture(scope="module")
def haptic_dir(tmp_path_factory):
    """HapticDevice11.fmu, HapticDevice7.fmu and HapticDeviceArm.fmu built from modelica/Haptic."""
    from cosim.compile import build_fmu

    out = tmp_path_factory.mktemp("engine_haptic")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, model in (("HapticDevice11", "Device11"), ("HapticDevice7", "Device7"),
                            ("HapticDeviceArm", "DeviceArm")):
            built = build_fmu(ROOT / "modelica" / "Haptic" / "package.mo", f"Haptic.{model}", out_dir=out / model)
            built.rename(out / f"{name}.fmu")
    return out


def _both(path, sets):
    """Run ``path`` with both engines; returns (compiled result, python result)."""
    comp = run(load_config(path, sets + ["run.engine=compiled"]), progress=False)
    py = run(load_config(path, sets + ["run.engine=python"]), progress=False)
    assert comp.engine == "compiled" and py.engine == "python"
    return comp, py


def _assert_same(comp, py):
    assert comp.data.dtype.names == py.data.dtype.names
    assert len(comp.data) == len(py.data) > 0
    assert comp.calls == py.calls
    assert np.array_equal(comp.data["time"], py.data["time"])  # same instants, exactly
    for name in comp.data.dtype.names[1:]:
        rng = np.ptp(py.data[name]) or 1.0
        assert_allclose(comp.data[name], py.data[name], atol=1e-9 * rng, rtol=0, err_msg=name)


# shortened runs of every shipped config (the gripper ones include the impact at 0.32 s)
GRIPPER = [
    ("gripper_impact.toml", False, ["run.stop=0.45"]),
    ("gripper_impact_p3.toml", False, ["run.stop=0.45"]),
    ("gripper_impact_split.toml", True, ["run.stop=0.45"]),
    ("gripper_static.toml", False, ["run.stop=0.6", "controllers.outer.parameters.step_A=0.5",
                                    "controllers.outer.parameters.step_s=0.1"]),
]


@pytest.mark.parametrize("name,split,sets", GRIPPER, ids=[g[0] for g in GRIPPER])
@pytest.mark.slow
def test_engines_agree_on_gripper_configs(gripper_dir, name, split, sets):
    comp, py = _both(EXAMPLES / name, gripper_overrides(gripper_dir, split) + sets)
    _assert_same(comp, py)
    force = "F_g"
    assert comp.data[force].max() > 10.0  # the runs reach contact


@pytest.mark.parametrize("name,fmu", [("haptic_wall.toml", "HapticDevice11"),
                                      ("haptic_wall_adaptive.toml", "HapticDevice7"),
                                      ("haptic_wall_arm.toml", "HapticDeviceArm")])
@pytest.mark.slow
def test_engines_agree_on_haptic_configs(haptic_dir, name, fmu):
    comp, py = _both(EXAMPLES / name, [f'fmus.plant.path="{(haptic_dir / (fmu + ".fmu")).as_posix()}"', "run.stop=1.6"])
    _assert_same(comp, py)
    assert comp.data["wall.penetration"].max() > 0.0  # the runs reach the wall


@pytest.mark.parametrize("kind", ["ME", "CS"])
def test_engines_agree_on_fmi2_me_and_cs(master_dir, kind):
    # the hand-written FMI 2.0 FMU: ME integrated by the kernel, CS through fmi2DoStep by address
    path = osc_config(master_dir, stop=1.0)
    comp, py = _both(path, ["fmus.plant.path=Osc2.fmu", f"fmus.plant.kind={kind}", 'record.signals=["plant.y", "src.u"]'])
    _assert_same(comp, py)


def test_engines_agree_on_cs_feeding_me_with_gain_offset_and_substeps(master_dir):
    # FMI 2 CS -> FMI 3 ME, routed with a gain and an offset, 3 RK4 substeps, a recorder off the controller grid
    path = osc_config(master_dir, stop=0.5, record_rate=300, extra="""
        [fmus.cs]
        path = "Osc2.fmu"
        kind = "CS"
        parameters = { k = 9.0 }
        """)
    sets = ['connections=[{from = "src.u", to = "cs.u"}, {from = "cs.y", to = "plant.u", gain = 0.5, offset = 0.1}]',
            'record.signals=["cs.y", "plant.y", "src.u"]', "solver.substeps=3"]
    comp, py = _both(path, sets)
    _assert_same(comp, py)


def test_compiled_is_the_default_and_reports_compile_time(master_dir, tmp_path):
    cfg = load_config(osc_config(master_dir, stop=0.2))
    assert cfg.run.engine == "compiled"
    assert isinstance(engine_for(cfg).loop, CompiledLoop)
    result, summary, _ = run_config(osc_config(master_dir, stop=0.2), out=tmp_path / "o", progress=False)
    assert result.engine == "compiled" and result.compile_s > 0.0
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["engine"] == "compiled" and s["compile_s"] == pytest.approx(result.compile_s)


BAD_CTL = '''
import numpy as np
from cosim.controller import Controller


def _bad(t, u, y, x, p):
    y[0] = dict(gain=p[0])["gain"]


class Bad(Controller):
    """Uses dict(key=value), which numba cannot compile."""
    parameters = {"amp": 1.0}
    outputs = ("u",)
    kernel = staticmethod(_bad)
'''


def test_fallback_names_the_construct(master_dir, tmp_path):
    (master_dir / "bad_ctl.py").write_text(BAD_CTL)
    cfg = load_config(osc_config(master_dir, stop=0.1), ['controllers.src.class="bad_ctl.py:Bad"',
                                                         "controllers.src.parameters={}"])
    with pytest.warns(EngineFallbackWarning) as rec:
        result = run(cfg, progress=False)
    assert len(rec) == 1
    msg = str(rec[0].message)
    assert "\n" not in msg
    assert "running the Python engine (30-75 times slower" in msg and "'src'" in msg and "Bad" in msg  # cost, why
    assert "dict" in msg and 'dict(gain=p[0])["gain"]' in msg and "bad_ctl.py:7" in msg  # the construct and where it is
    assert result.engine == "python" and len(result.data) == 11
    assert_allclose(result.data["src.u"], 1.0)


def test_python_controllers_run_the_python_engine_with_a_note(master_dir):
    # a controller overriding step() in Python, or jit = false: the config asks for Python; a note, no warning
    extra = """
        [controllers.probe]
        class = "ctl.py:Probe"
        rate = 100
        """
    for sets in ([], ["controllers.src.jit=false"]):
        cfg = load_config(osc_config(master_dir, stop=0.1, extra=extra if not sets else ""), sets)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = run(cfg, progress=False)
        assert result.engine == "python"
        assert ("overrides step()" in result.engine_note) if not sets else ("jit = false" in result.engine_note)
        assert "30-75 times slower than the compiled one" in result.engine_note


@pytest.mark.slow
def test_ctrl_c_keeps_what_was_recorded(gripper_dir):
    # an interrupt during the kernel takes effect at the end of a chunk; the rows recorded so far are kept
    sets = gripper_overrides(gripper_dir) + ["record.rate=100", 'record.signals=["plant.F_g", "plant.w_m"]',
                                             "plot.panels=[]"]
    run(load_config(EXAMPLES / "gripper_impact.toml", sets + ["run.stop=0.01"]), progress=False)  # compiled now
    with pytest.warns(ScaleWarning, match="run.stop = 3000 s"):  # a run long enough to be interrupted is meant
        engine = engine_for(load_config(EXAMPLES / "gripper_impact.toml", sets + ["run.stop=3000"]))
    assert isinstance(engine.loop, CompiledLoop)
    # Ctrl-C as the default handler delivers it (an earlier test's Dask cluster may have left its own handler)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(1.0, _thread.interrupt_main)
    timer.start()
    try:
        result = engine.run(progress=False)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert result.interrupted
    n = len(result.data)
    assert 0 < n < 3000 * 100
    t = result.data["time"]
    assert_allclose(np.diff(t), 0.01, rtol=1e-9)
    assert not np.isnan(result.data["F_g"]).any()
    # what was kept equals the start of an uninterrupted run
    short = run(load_config(EXAMPLES / "gripper_impact.toml", sets + [f"run.stop={t[-1]}"]), progress=False)
    assert np.array_equal(short.data["F_g"][:n], result.data["F_g"])


def test_progress_bar_on_stderr(master_dir, capsys):
    result = run(load_config(osc_config(master_dir, stop=0.5)), progress=True)
    assert result.engine == "compiled"
    assert "sim s" in capsys.readouterr().err


@pytest.mark.parametrize("cls", _all_controller_classes(), ids=lambda c: f"{c.__module__}.{c.__name__}")
def test_every_shipped_controller_runs_as_a_cfunc(cls, tmp_path):
    # the compiled engine calls each kernel through its cfunc wrapper: same outputs and state as step()
    import numba

    from cosim.fmi import native
    from cosim.jit import native_kernel

    @numba.njit
    def call(addr, t, u, y, x, p):
        native.call_kernel(addr, t, u.ctypes.data, u.shape[0], y.ctypes.data, y.shape[0], x.ctypes.data, x.shape[0],
                           p.ctypes.data, p.shape[0])

    required = required_parameters(cls, tmp_path)
    a, b = cls(rate=10000.0, **required), cls(rate=10000.0, **required)
    rng = np.random.default_rng(1)
    addr = native_kernel(cls.kernel).address
    for j in range(20):
        u = rng.uniform(-1.0, 1.0, len(cls.inputs))
        a.u[:] = u
        b.u[:] = u
        a.step(j * 1e-4)
        call(addr, j * 1e-4, b.u, b.y, b.x, b.p)
        assert np.array_equal(a.y, b.y) and np.array_equal(a.x, b.x)


def test_fmi_error_in_the_kernel_raises_fmi_call_error(master_dir):
    # a GetReal of an unknown value reference (Osc2 answers fmi2Error) inside the kernel -> FmiCallError
    from cosim.errors import FmiCallError

    cfg = load_config(osc_config(master_dir, stop=0.1), ["fmus.plant.path=Osc2.fmu", 'record.signals=["plant.y"]'])
    engine = engine_for(cfg)
    assert isinstance(engine.loop, CompiledLoop)
    bad_vr = np.array([99], dtype=np.uint32)
    tables = engine.loop._tables

    def broken(plant):
        tab = tables(plant)
        tab["port"][0, 1] = bad_vr.ctypes.data  # the sampled port now reads value reference 99
        tab["port"][0, 2] = 1
        return tab

    engine.loop._tables = broken
    with pytest.raises(FmiCallError, match="GetReal.*Error"):
        engine.run(progress=False)


# a hand-written FMI 3.0 Co-Simulation FMU of the oscillator (our compiler exports ME only): exercises
# fmi3DoStep called by address (bool arguments, the terminate flag written through a pointer)
OSC3_C = r"""/* FMI 3.0 CS oscillator der(x) = v, der(v) = -k x - c v + u, y = 2 x; 10 RK4 steps per doStep. Tests only. */
#include <stdbool.h>
#include <stddef.h>
#include <stdlib.h>
typedef struct { double x[2], u, k, c; } M;
static void f(const M *m, const double *x, double *dx) { dx[0] = x[1]; dx[1] = -m->k * x[0] - m->c * x[1] + m->u; }
void* fmi3InstantiateCoSimulation(const char* n, const char* tok, const char* res, bool vis, bool log, bool ev, bool er,
    const unsigned* req, size_t nreq, void* env, void* logger, void* upd) {
    M *m = calloc(1, sizeof(M)); m->x[0] = 1.0; m->k = 4.0; m->c = 0.5; return m; }
void fmi3FreeInstance(void* c) { free(c); }
int fmi3EnterInitializationMode(void* c, bool td, double tol, double t0, bool sd, double t1) { return 0; }
int fmi3ExitInitializationMode(void* c) { return 0; }
int fmi3Terminate(void* c) { return 0; }
int fmi3SetDebugLogging(void* c, bool on, size_t n, const char* const cat[]) { return 0; }
const char* fmi3GetVersion(void) { return "3.0"; }
int fmi3GetFloat64(void* c, const unsigned vr[], size_t n, double v[], size_t nv) {
    M *m = c;
    for (size_t i = 0; i < n; i++) switch (vr[i]) {
        case 0: v[i] = m->x[0]; break; case 1: v[i] = m->x[1]; break; case 4: v[i] = m->u; break;
        case 5: v[i] = 2 * m->x[0]; break; case 6: v[i] = m->k; break; case 7: v[i] = m->c; break; default: return 3; }
    return 0; }
int fmi3SetFloat64(void* c, const unsigned vr[], size_t n, const double v[], size_t nv) {
    M *m = c;
    for (size_t i = 0; i < n; i++) switch (vr[i]) {
        case 4: m->u = v[i]; break; case 6: m->k = v[i]; break; case 7: m->c = v[i]; break; default: return 3; }
    return 0; }
int fmi3DoStep(void* c, double t, double H, bool noSet, bool* ev, bool* term, bool* early, double* last) {
    M *m = c; double h = H / 10, k1[2], k2[2], k3[2], k4[2], y[2];
    if (H < 0 || !noSet) return 3;
    for (int j = 0; j < 10; j++) {
        f(m, m->x, k1); for (int i = 0; i < 2; i++) y[i] = m->x[i] + h / 2 * k1[i];
        f(m, y, k2); for (int i = 0; i < 2; i++) y[i] = m->x[i] + h / 2 * k2[i];
        f(m, y, k3); for (int i = 0; i < 2; i++) y[i] = m->x[i] + h * k3[i];
        f(m, y, k4); for (int i = 0; i < 2; i++) m->x[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    }
    *ev = false; *term = (t + H > 0.75 && m->k == 99.0); *early = false; *last = t + H; return 0; }
#define STUB(name) int name(void) { return 3; }
""" + "\n".join(f"STUB({n})" for n in (
    "fmi3ActivateModelPartition", "fmi3CompletedIntegratorStep", "fmi3DeserializeFMUState", "fmi3EnterConfigurationMode",
    "fmi3EnterContinuousTimeMode", "fmi3EnterEventMode", "fmi3EnterStepMode", "fmi3EvaluateDiscreteStates",
    "fmi3ExitConfigurationMode", "fmi3FreeFMUState", "fmi3GetAdjointDerivative", "fmi3GetBinary", "fmi3GetBoolean",
    "fmi3GetClock", "fmi3GetContinuousStateDerivatives", "fmi3GetContinuousStates", "fmi3GetDirectionalDerivative",
    "fmi3GetEventIndicators", "fmi3GetFMUState", "fmi3GetFloat32", "fmi3GetInt16", "fmi3GetInt32", "fmi3GetInt64",
    "fmi3GetInt8", "fmi3GetIntervalDecimal", "fmi3GetIntervalFraction", "fmi3GetNominalsOfContinuousStates",
    "fmi3GetNumberOfContinuousStates", "fmi3GetNumberOfEventIndicators", "fmi3GetNumberOfVariableDependencies",
    "fmi3GetOutputDerivatives", "fmi3GetShiftDecimal", "fmi3GetShiftFraction", "fmi3GetString", "fmi3GetUInt16",
    "fmi3GetUInt32", "fmi3GetUInt64", "fmi3GetUInt8", "fmi3GetVariableDependencies", "fmi3InstantiateModelExchange",
    "fmi3InstantiateScheduledExecution", "fmi3Reset", "fmi3SerializeFMUState", "fmi3SerializedFMUStateSize",
    "fmi3SetBinary", "fmi3SetBoolean", "fmi3SetClock", "fmi3SetContinuousStates", "fmi3SetFMUState", "fmi3SetFloat32",
    "fmi3SetInt16", "fmi3SetInt32", "fmi3SetInt64", "fmi3SetInt8", "fmi3SetIntervalDecimal", "fmi3SetIntervalFraction",
    "fmi3SetShiftDecimal", "fmi3SetShiftFraction", "fmi3SetString", "fmi3SetTime", "fmi3SetUInt16", "fmi3SetUInt32",
    "fmi3SetUInt64", "fmi3SetUInt8", "fmi3UpdateDiscreteStates")) + "\n"

OSC3_XML = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Osc3" instantiationToken="{5b1e0c3a-0d6f-4a39-9b7e-3f3c1e0a0003}">
  <CoSimulation modelIdentifier="Osc3" canHandleVariableCommunicationStepSize="true"/>
  <ModelVariables>
    <Float64 name="x" valueReference="0" start="1"/>
    <Float64 name="v" valueReference="1" start="0"/>
    <Float64 name="u" valueReference="4" causality="input" start="0"/>
    <Float64 name="y" valueReference="5" causality="output"/>
    <Float64 name="k" valueReference="6" causality="parameter" variability="fixed" start="4"/>
    <Float64 name="c" valueReference="7" causality="parameter" variability="fixed" start="0.5"/>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="5"/>
  </ModelStructure>
</fmiModelDescription>
"""


@pytest.fixture(scope="module")
def osc3(master_dir):
    """Osc3.fmu (FMI 3.0 CS) next to the master tests' configs."""
    import subprocess
    import zipfile

    src = master_dir / "osc3_src"
    src.mkdir(exist_ok=True)
    (src / "osc3.c").write_text(OSC3_C)
    so = src / "Osc3.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", "-o", str(so), str(src / "osc3.c")], check=True)
    fmu = master_dir / "Osc3.fmu"
    with zipfile.ZipFile(fmu, "w") as zf:
        zf.writestr("modelDescription.xml", OSC3_XML)
        zf.write(so, "binaries/x86_64-linux/Osc3.so")
    return fmu


def test_engines_agree_on_fmi3_cs(master_dir, osc3):
    path = osc_config(master_dir, stop=1.0)
    comp, py = _both(path, ["fmus.plant.path=Osc3.fmu", 'record.signals=["plant.y", "src.u"]'])
    assert load_config(path, ["fmus.plant.path=Osc3.fmu", 'record.signals=["plant.y"]']).fmus["plant"].info.fmi_version == 3
    _assert_same(comp, py)
    assert comp.data["y"].std() > 0.1


def test_fmi3_cs_terminate_request_stops_the_run_in_both_engines(master_dir, osc3):
    """terminateSimulation from doStep: the run stops, keeps its rows and says who asked and when (issue 28)."""
    path = osc_config(master_dir, stop=1.0)
    sets = ["fmus.plant.path=Osc3.fmu", "fmus.plant.parameters={ k = 99.0 }", 'record.signals=["plant.y"]']
    comp, py = _both(path, sets)
    assert comp.stopped == py.stopped and comp.stopped["by"] == "plant" and 0 < comp.stopped["time"] < 1.0
    _assert_same(comp, py)
    assert comp.data["time"][-1] < comp.stopped["time"]
