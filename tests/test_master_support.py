"""Shared fixtures and helpers of the master/config/controller/FMI tests (no tests here).

FMUs are built once per session with ``cosim.compile.build_fmu``: a small driven oscillator whose
equations the tests integrate independently with scipy, and the three gripper FMUs.
"""

import textwrap
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"

OSC_MO = textwrap.dedent(
    """
    package MasterTests "Small models for the master's tests"
      model Osc "Damped oscillator driven by an input force; y = 2 x"
        parameter Real k(unit = "N/m") = 4.0 "Stiffness";
        parameter Real c(unit = "N.s/m") = 0.5 "Damping";
        input Real u(unit = "N") "Force";
        output Real y(unit = "m") "Twice the position";
        output Real v_out(unit = "m/s") "Velocity";
        Real x(unit = "m", start = 1.0, fixed = true) "Position";
        Real v(unit = "m/s", start = 0.0, fixed = true) "Velocity";
      equation
        der(x) = v;
        der(v) = -k*x - c*v + u;
        y = 2*x;
        v_out = v;
      end Osc;
    end MasterTests;
    """
)

# controllers used by the tests, loaded from a file by the configs ("ctl.py:Name")
CTL_PY = textwrap.dedent(
    '''
    import math
    import numpy as np
    from cosim.controller import Controller

    def _sine(t, u, y, x, p):
        y[0] = p[0] * math.sin(2.0 * math.pi * p[1] * t)

    class Sine(Controller):
        """Source: amp * sin(2 pi f t)."""
        parameters = {"amp": 1.0, "f": 1.0}
        outputs = ("u",)
        kernel = staticmethod(_sine)

    def _step(t, u, y, x, p):
        y[0] = p[0] if t >= p[1] else 0.0

    class Step(Controller):
        """Source: value after t_step."""
        parameters = {"value": 1.0, "t_step": 0.0}
        outputs = ("y",)
        kernel = staticmethod(_step)

    def _hold(t, u, y, x, p):
        y[0] = u[0]

    CALLS = {}

    class Probe(Controller):
        """Passes its input through and logs the time of every call (plain Python)."""
        parameters = {"interrupt_at": -1.0}
        inputs = ("u",)
        outputs = ("y",)
        kernel = staticmethod(_hold)

        def step(self, t):
            if 0.0 <= self.values["interrupt_at"] <= t:
                raise KeyboardInterrupt
            CALLS.setdefault(id(self), []).append(t)
            super().step(t)
    '''
)


# a hand-written FMI 2.0 FMU (ME and CS) of the same oscillator, compiled with gcc: exercises the
# FMI 2 and Co-Simulation paths (our compiler emits FMI 3 ME only)
OSC2_C = r"""/* A hand-written FMI 2.0 FMU (ME and CS) of the driven oscillator der(x) = v, der(v) = -k x - c v + u, y = 2 x;
   CS integrates with 10 RK4 steps per doStep. For the tests of cosim.fmi only. */
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

typedef struct { double x[2]; double u, k, c, t; int cs; } M;

static void f(const M *m, const double *x, double *dx) { dx[0] = x[1]; dx[1] = -m->k * x[0] - m->c * x[1] + m->u; }

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean l, size_t n, const fmi2String cat[]) { return fmi2OK; }
fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions* cb, fmi2Boolean vis, fmi2Boolean log) {
    M *m = calloc(1, sizeof(M)); m->x[0] = 1.0; m->k = 4.0; m->c = 0.5; m->cs = (type == fmi2CoSimulation); return m; }
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1) { ((M*)c)->t = t0; return fmi2OK; }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    M *m = c; double dx[2]; f(m, m->x, dx);
    for (size_t i = 0; i < n; i++) switch (vr[i]) {
        case 0: v[i] = m->x[0]; break; case 1: v[i] = m->x[1]; break; case 2: v[i] = dx[0]; break; case 3: v[i] = dx[1]; break;
        case 4: v[i] = m->u; break; case 5: v[i] = 2 * m->x[0]; break; case 6: v[i] = m->k; break; case 7: v[i] = m->c; break;
        default: return fmi2Error; }
    return fmi2OK; }
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    M *m = c;
    for (size_t i = 0; i < n; i++) switch (vr[i]) {
        case 4: m->u = v[i]; break; case 6: m->k = v[i]; break; case 7: m->c = v[i]; break; default: return fmi2Error; }
    return fmi2OK; }
#define STUB(name, ...) fmi2Status name(__VA_ARGS__) { return fmi2Error; }
STUB(fmi2GetInteger, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
STUB(fmi2GetBoolean, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
STUB(fmi2GetString, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
STUB(fmi2SetInteger, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
STUB(fmi2SetBoolean, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
STUB(fmi2SetString, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
STUB(fmi2GetFMUstate, fmi2Component c, fmi2FMUstate* s)
STUB(fmi2SetFMUstate, fmi2Component c, fmi2FMUstate s)
STUB(fmi2FreeFMUstate, fmi2Component c, fmi2FMUstate* s)
STUB(fmi2SerializedFMUstateSize, fmi2Component c, fmi2FMUstate s, size_t* n)
STUB(fmi2SerializeFMUstate, fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
STUB(fmi2DeSerializeFMUstate, fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate* s)
STUB(fmi2GetDirectionalDerivative, fmi2Component c, const fmi2ValueReference a[], size_t na, const fmi2ValueReference b[], size_t nb, const fmi2Real dv[], fmi2Real df[])
STUB(fmi2SetRealInputDerivatives, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[])
STUB(fmi2GetRealOutputDerivatives, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[])
STUB(fmi2CancelStep, fmi2Component c)
STUB(fmi2GetStatus, fmi2Component c, const fmi2StatusKind s, fmi2Status* v)
STUB(fmi2GetRealStatus, fmi2Component c, const fmi2StatusKind s, fmi2Real* v)
STUB(fmi2GetIntegerStatus, fmi2Component c, const fmi2StatusKind s, fmi2Integer* v)
STUB(fmi2GetBooleanStatus, fmi2Component c, const fmi2StatusKind s, fmi2Boolean* v)
STUB(fmi2GetStringStatus, fmi2Component c, const fmi2StatusKind s, fmi2String* v)
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo* e) { memset(e, 0, sizeof(*e)); return fmi2OK; }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean p, fmi2Boolean* e, fmi2Boolean* t) { *e = 0; *t = 0; return fmi2OK; }
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((M*)c)->t = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) { memcpy(((M*)c)->x, x, 2 * sizeof(double)); return n == 2 ? fmi2OK : fmi2Error; }
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) { f(c, ((M*)c)->x, dx); return fmi2OK; }
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) { return fmi2OK; }
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { memcpy(x, ((M*)c)->x, 2 * sizeof(double)); return fmi2OK; }
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { x[0] = x[1] = 1.0; return fmi2OK; }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real H, fmi2Boolean p) {
    M *m = c; double h = H / 10, k1[2], k2[2], k3[2], k4[2], y[2];
    if (H < 0) return fmi2Error;
    for (int j = 0; j < 10; j++) {
        f(m, m->x, k1); for (int i = 0; i < 2; i++) y[i] = m->x[i] + h / 2 * k1[i];
        f(m, y, k2); for (int i = 0; i < 2; i++) y[i] = m->x[i] + h / 2 * k2[i];
        f(m, y, k3); for (int i = 0; i < 2; i++) y[i] = m->x[i] + h * k3[i];
        f(m, y, k4); for (int i = 0; i < 2; i++) m->x[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    }
    m->t = t + H; return fmi2OK; }
"""

OSC2_XML = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Osc2" guid="{8c4e810f-3df3-4a00-8276-176fa3c9f000}" numberOfEventIndicators="0">
  <ModelExchange modelIdentifier="Osc2"/>
  <CoSimulation modelIdentifier="Osc2" canHandleVariableCommunicationStepSize="true"/>
  <ModelVariables>
    <ScalarVariable name="x" valueReference="0"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="v" valueReference="1"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="2"><Real derivative="1"/></ScalarVariable>
    <ScalarVariable name="der(v)" valueReference="3"><Real derivative="2"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="4" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="5" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="k" valueReference="6" causality="parameter" variability="fixed"><Real start="4"/></ScalarVariable>
    <ScalarVariable name="c" valueReference="7" causality="parameter" variability="fixed"><Real start="0.5"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="6" dependencies="1"/></Outputs>
    <Derivatives><Unknown index="3"/><Unknown index="4"/></Derivatives>
  </ModelStructure>
</fmiModelDescription>
"""


def build_osc2(folder):
    """Compile and zip Osc2.fmu (FMI 2.0, ME + CS) into ``folder``; returns its path."""
    import os
    import subprocess
    import zipfile

    import fmpy

    folder = Path(folder)
    src = folder / "osc2_src"
    (src / "binaries" / "linux64").mkdir(parents=True, exist_ok=True)
    (src / "osc2.c").write_text(OSC2_C)
    (src / "modelDescription.xml").write_text(OSC2_XML)
    include = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", f"-I{include}", "-o", str(src / "binaries" / "linux64" / "Osc2.so"),
                    str(src / "osc2.c")], check=True)
    fmu = folder / "Osc2.fmu"
    with zipfile.ZipFile(fmu, "w") as zf:
        zf.write(src / "modelDescription.xml", "modelDescription.xml")
        zf.write(src / "binaries" / "linux64" / "Osc2.so", "binaries/linux64/Osc2.so")
    os.chmod(fmu, 0o644)
    return fmu


@pytest.fixture(scope="session")
def master_dir(tmp_path_factory):
    """A folder with Osc.fmu, the test controllers (ctl.py) and the gripper FMUs."""
    from cosim.compile import build_fmu

    d = tmp_path_factory.mktemp("master")
    (d / "MasterTests.mo").write_text(OSC_MO)
    (d / "ctl.py").write_text(CTL_PY)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        build_fmu(d / "MasterTests.mo", "MasterTests.Osc", out_dir=d)
    build_osc2(d)
    return d


@pytest.fixture(scope="session")
def gripper_dir(tmp_path_factory):
    """A folder with GripperPlant.fmu, PMSM.fmu and Drivetrain.fmu built from modelica/Gripper."""
    from cosim.compile import build_fmu

    d = tmp_path_factory.mktemp("gripper_master")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in ("GripperPlant", "PMSM", "Drivetrain"):
            build_fmu(ROOT / "modelica" / "Gripper" / "package.mo", f"Gripper.{name}", out_dir=d)
    return d


def osc_config(folder, extra="", stop=2.0, rate=1000, record_rate=100, solver="", amp=2.0, f=1.0):
    """Write an Osc + Sine config into ``folder`` and return its path."""
    text = textwrap.dedent(
        f"""
        [run]
        stop = {stop}

        {solver}

        [fmus.plant]
        path = "Osc.fmu"
        parameters = {{ k = 9.0 }}

        [controllers.src]
        class = "ctl.py:Sine"
        rate = {rate}
        parameters = {{ amp = {amp}, f = {f} }}

        [[connections]]
        from = "src.u"
        to = "plant.u"

        [record]
        rate = {record_rate}
        signals = ["plant.y", "plant.v_out", "src.u"]
        """
    ) + textwrap.dedent(extra)
    path = Path(folder) / "osc.toml"
    path.write_text(text)
    return path


def gripper_overrides(gripper_dir, split=False):
    """``--set`` items pointing a shipped gripper config at the session's FMUs."""
    if split:
        return [f"fmus.plant.path={gripper_dir / 'PMSM.fmu'}", f"fmus.drive.path={gripper_dir / 'Drivetrain.fmu'}"]
    return [f"fmus.plant.path={gripper_dir / 'GripperPlant.fmu'}"]


def cli_fails(capsys, argv):
    """Run the CLI as a user types ``argv``; assert exit 2 with one error message and no traceback; return it."""
    from cosim.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("error:") == 1
    return err
