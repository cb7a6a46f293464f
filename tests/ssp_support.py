"""What the SSP tests (tests/test_ssp.py) and their benchmark (benchmarks/ssp.py) both build and run: the config of
two coupled bodies, an SSP written by hand after the standard's examples, FMPy stepping its FMUs by hand, and
libcosim running an SSP (in a subprocess: a crash of libcosim must not end the caller)."""

import json
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import fmpy
import numpy as np
from fmpy.fmi3 import FMU3Slave

RUNNER = Path(__file__).resolve().parent / "other_tools_run.py"

TWO_BODIES = """
[run]
stop = {stop}

[fmus.a]
path = "{fmu}"
kind = "CS"
parameters = {{ x0 = 0.1, c = 30.0 }}

[fmus.b]
path = "{fmu}"
kind = "CS"
parameters = {{ m = 2.0 }}

[[connections]]
from = "a.x"
to = "b.x_other"

[[connections]]
from = "b.x"
to = "a.x_other"

[record]
rate = {rate}
signals = ["a.x", "b.x", "a.v", "b.v"]
"""


SSD = """<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription version="{version}" name="BallIntegrator"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">
  <ssd:System name="BallIntegrator">
    <ssd:Elements>
      <ssd:Component name="ball" type="application/x-fmu-sharedlibrary" source="{ball}"
          implementation="CoSimulation">
        <ssd:Connectors>
          <ssd:Connector name="h" kind="output"><ssc:Real unit="m"/></ssd:Connector>
        </ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding source="resources/ball.ssv"/>
        </ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="integrator" source="resources/Feedthrough.fmu" implementation="CoSimulation">
        <ssd:Connectors>
          <ssd:Connector name="{input}" kind="input"><ssc:Real{unit}/></ssd:Connector>
          <ssd:Connector name="x" kind="output"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="ball" startConnector="h" endElement="integrator" endConnector="u_f64">{transform}
      </ssd:Connection>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="2"/>
</ssd:SystemStructureDescription>
"""

SSV = """<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet version="{version}" name="ball"
    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">
  <ssv:Parameters>
    <ssv:Parameter name="e"><ssv:Real value="0.5"/></ssv:Parameter>
    <ssv:Parameter name="g"><ssv:Real value="9.81" unit="m/s2"/></ssv:Parameter>
  </ssv:Parameters>
  <ssv:Units><ssc:Unit name="m/s2" xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">
    <ssc:BaseUnit m="1" s="-2"/></ssc:Unit></ssv:Units>
</ssv:ParameterSet>
"""


def hand_ssp(folder, third_party_fmu, version="1.0", ball="resources/BouncingBall.fmu", input="u_f64", unit="",
              transform=""):
    """BouncingBall's height integrated by Feedthrough (x = integral of u_f64), the ball's restitution 0.5 set by
    an SSV: an SSP written after the standard's examples; the keywords spoil one element or add to one."""
    path = folder / f"ball_{version}.ssp"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("SystemStructure.ssd", SSD.format(version=version, ball=ball, input=input, unit=unit,
                                                      transform=transform))
        zf.writestr("resources/ball.ssv", SSV.format(version=version))
        zf.write(third_party_fmu("BouncingBall"), "resources/BouncingBall.fmu")
        zf.write(third_party_fmu("Feedthrough"), "resources/Feedthrough.fmu")
    return path


def fmpy_by_hand(ball_fmu, integrator_fmu, step, stop, factor=1.0, offset=0.0):
    """FMPy's FMI 3.0 Co-Simulation of the two FMUs stepped by hand: at each communication point the ball's height
    is read and set (times ``factor`` plus ``offset``) as the integrator's input, then both step (ball.e = 0.5).
    Rows ``[t, h, x]``."""
    slaves, refs = [], []
    for fmu, start in ((ball_fmu, {"e": 0.5}), (integrator_fmu, {})):
        md = fmpy.read_model_description(str(fmu))
        slave = FMU3Slave(guid=md.guid, unzipDirectory=fmpy.extract(str(fmu), unzipdir=tempfile.mkdtemp()),
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=md.modelName)
        slave.instantiate()
        vr = {v.name: v.valueReference for v in md.modelVariables}
        for name, value in start.items():
            slave.setFloat64([vr[name]], [value])
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        slaves.append(slave)
        refs.append(vr)
    ball, integrator = slaves
    rows = []
    for k in range(round(stop / step) + 1):
        t = k * step
        h = ball.getFloat64([refs[0]["h"]])[0]
        rows.append([t, h, integrator.getFloat64([refs[1]["x"]])[0]])
        if k < round(stop / step):
            integrator.setFloat64([refs[1]["u_f64"]], [factor * h + offset])
            ball.doStep(t, step)
            integrator.doStep(t, step)
    for slave in slaves:
        slave.terminate()
        slave.freeInstance()
    return np.array(rows)


def libcosim_ssp(ssp, signals, step, stop):
    """libcosim's run of an SSP archive at the fixed step ``step``: rows ``[t, signal...]`` after each step
    (``signals`` as ``"instance.variable"``)."""
    done = subprocess.run([sys.executable, str(RUNNER), "libcosim-ssp", str(ssp), "{}", json.dumps(signals),
                           str(step), str(stop)], capture_output=True, text=True, timeout=300)
    if done.returncode != 0:
        raise RuntimeError(f"libcosim failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    return np.array(json.loads(done.stdout.strip().splitlines()[-1]))
