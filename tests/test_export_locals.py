"""Every variable of a compiled model is visible in its FMU (FMI 3.0 and 2.0, Model Exchange and Co-Simulation):
the local variables (``LoweredModel.observed``, aliases sharing one value reference), the dependent parameters
(calculatedParameter) and the structural constants, against closed forms with fmpy's own solvers, and recorded
by name by ``cosim run`` with both engines."""

import tempfile
import warnings

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from cosim.compile import build_fmu
from cosim.config import load_config
from cosim.errors import ConfigError, EngineFallbackWarning
from cosim.master import run
from modelica_support import write_package

MODELS = """
connector Pin
  Real v(unit = "V") "potential";
  flow Real i(unit = "A") "current into the pin";
end Pin;
model Resistor
  parameter Real R(unit = "Ohm") = 100 "resistance";
  Real v(unit = "V") "voltage drop from p to n";
  Real i(unit = "A") "current from p to n";
  Pin p;
  Pin n;
equation
  v = p.v - n.v;
  p.i + n.i = 0;
  i = p.i;
  v = R * i;
end Resistor;
model Capacitor
  parameter Real C(unit = "F") = 1e-3 "capacitance";
  Real v(unit = "V", start = 0, fixed = true) "voltage";
  Real i(unit = "A") "current from p to n";
  Pin p;
  Pin n;
equation
  v = p.v - n.v;
  p.i + n.i = 0;
  i = p.i;
  C * der(v) = i;
end Capacitor;
model Source
  parameter Real V(unit = "V") = 10 "source voltage";
  Pin p;
  Pin n;
equation
  V = p.v - n.v;
  p.i + n.i = 0;
end Source;
model Ground
  Pin p;
equation
  p.v = 0;
end Ground;
model RC "a source charging a capacitor through a resistor; only the capacitor voltage is an output"
  parameter Real V0(unit = "V") = 10 "source voltage";
  parameter Real tau(unit = "s") = r.R * c.C "time constant";
  parameter Integer n = 3 "an Integer constant";
  parameter Boolean on = true "a Boolean constant";
  constant Real two(unit = "1") = 2 "a Real constant";
  Source s(V = V0);
  Resistor r(R = 100);
  Capacitor c(C = 1e-3);
  Ground g;
  Real p_R(unit = "W") "power in the resistor";
  output Real vc(unit = "V") "capacitor voltage";
equation
  connect(s.p, r.p);
  connect(r.n, c.p);
  connect(c.n, s.n);
  connect(s.n, g.p);
  p_R = r.v * r.i;
  vc = c.v;
end RC;
model Cubic "z solves z^3 + z = x (a Newton loop: observe is an MX function), x = 2 exp(-t)"
  Real x(start = 2, fixed = true) "state";
  Real z(start = 1) "root of z^3 + z - x";
  Real w "twice the root";
  output Real y "the state";
equation
  der(x) = -x;
  z ^ 3 + z = x;
  w = 2 * z;
  y = x;
end Cubic;
model Switch "a local that changes at a state event: s = 1 while x > 0.5, then 2; der(x) = -s x"
  Real x(start = 1, fixed = true) "state";
  Real s "rate factor";
  output Real y "the state";
equation
  s = if x > 0.5 then 1 else 2;
  der(x) = -s * x;
  y = x;
end Switch;
"""

KINDS = [(3, "ModelExchange"), (3, "CoSimulation"), (2, "ModelExchange"), (2, "CoSimulation")]


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("locals")
    source = write_package(folder, MODELS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {(name, version): build_fmu(source, f"T.{name}", out_dir=folder / f"fmi{version}",
                                           fmi_version=version)
                for name in ("RC", "Cubic", "Switch") for version in (2, 3)}


def _simulate(fmu, kind, names, stop, **kwargs):
    kwargs = {"output_interval": 0.01, **kwargs}
    if kind == "ModelExchange":
        kwargs["relative_tolerance"] = 1e-10
    else:
        kwargs.setdefault("start_values", {})["_cs_step"] = 1e-4
    return fmpy.simulate_fmu(str(fmu), fmi_type=kind, stop_time=stop, output=names, **kwargs)


def _rc_closed_form(t, V0, R, C):
    """Every variable of the RC circuit: a source V0 charging C through R from 0 V."""
    i = V0 / R * np.exp(-t / (R * C))
    vc = V0 - R * i
    zero = np.zeros_like(t)
    return {"vc": vc, "c.v": vc, "r.v": R * i, "r.i": i, "c.i": i, "r.p.i": i, "c.p.i": i, "s.n.i": i,
            "r.n.i": -i, "c.n.i": -i, "s.p.i": -i, "g.p.i": zero, "s.p.v": V0 + zero, "r.p.v": V0 + zero,
            "s.n.v": zero, "c.n.v": zero, "g.p.v": zero, "r.n.v": vc, "c.p.v": vc, "p_R": R * i ** 2,
            "tau": R * C + zero, "s.V": V0 + zero, "two": 2 + zero, "n": 3 + zero, "on": 1 + zero}


@pytest.mark.parametrize("version,kind", KINDS)
def test_every_variable_of_the_rc_circuit_matches_the_closed_form(fmus, version, kind):
    V0, R, C = 5.0, 200.0, 1e-3
    names = list(_rc_closed_form(np.zeros(1), V0, R, C))
    r = _simulate(fmus["RC", version], kind, names, 0.6, start_values={"V0": V0, "r.R": R})
    expected = _rc_closed_form(r["time"], V0, R, C)
    tolerance = {"ModelExchange": 1e-7, "CoSimulation": 1e-9}[kind]  # CVode at 1e-10; RK4 at 0.1 ms
    for name in names:
        scale = max(1.0, np.max(np.abs(expected[name])))
        assert np.max(np.abs(r[name] - expected[name])) < tolerance * scale, name


@pytest.mark.parametrize("version", [3, 2])
def test_model_description_declares_locals_calculated_parameters_and_constants(fmus, version):
    fmu = fmus["RC", version]
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    for name, unit, description in (("p_R", "W", "power in the resistor"), ("r.v", "V", "voltage drop from p to n"),
                                    ("c.i", "A", "current from p to n"), ("r.n.v", "V", "potential")):
        v = by_name[name]
        assert (v.causality, v.variability, v.type) == ("local", "continuous", "Float64" if version == 3 else "Real")
        assert (v.unit or v.declaredType and v.declaredType.unit, v.description) == (unit, description)
        assert v.start is None
    assert {"W", "A", "V", "Ohm", "F", "s"} <= {u.name for u in md.unitDefinitions}
    for name, unit in (("tau", "s"), ("s.V", "V")):
        assert (by_name[name].causality, by_name[name].variability, by_name[name].unit) == (
            "calculatedParameter", "tunable", unit)
    assert {u.variable.name for u in md.initialUnknowns} >= {"tau", "s.V"}
    integer, boolean = ("Int64", "Boolean") if version == 3 else ("Integer", "Boolean")
    for name, vtype, start in (("n", integer, 3), ("on", boolean, True), ("two", by_name["vc"].type, 2.0)):
        v = by_name[name]
        assert (v.causality, v.variability, v.type) == ("local", "constant", vtype)
        assert (v.start in ("true", True) if vtype == "Boolean" else float(v.start) == start)
    assert not any(u.variable.causality == "local" for u in md.outputs)


@pytest.mark.parametrize("version", [3, 2])
def test_aliases_share_one_value_reference_and_negated_ones_keep_their_own(fmus, version):
    md = fmpy.read_model_description(str(fmus["RC", version]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    assert vr["r.i"] == vr["c.i"] == vr["r.p.i"] == vr["c.p.i"] == vr["s.n.i"]
    assert vr["r.n.i"] == vr["c.n.i"] == vr["s.p.i"] != vr["r.i"]  # -i
    assert vr["r.n.v"] == vr["c.p.v"] != vr["c.v"]  # a local equal to a state keeps a reference of the locals
    assert vr["g.p.i"] != vr["g.p.v"]  # both 0, other units
    if version == 3:  # FMI 3.0 writes an alias as an Alias element of its first variable
        assert sum(v.alias is not None for v in md.modelVariables) >= 8


def test_a_local_cannot_be_set(fmus):
    fmu = fmus["RC", 3]
    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = fmpy.extract(str(fmu), unzipdir=tempfile.mkdtemp(dir=fmu.parent))  # removed with the fixture's folder
    model = fmpy.instantiate_fmu(unzipped, md, fmi_type="ModelExchange")
    model.enterInitializationMode()
    with pytest.raises(FMICallException):
        model.setFloat64([vr["r.v"]], [1.0])
    model.exitInitializationMode()
    assert model.getFloat64([vr["r.v"], vr["tau"]]) == [10.0, 0.1]
    model.terminate()
    model.freeInstance()


@pytest.mark.parametrize("version,kind", [(3, "ModelExchange"), (2, "CoSimulation")])
def test_locals_of_a_newton_loop_match_the_closed_root(fmus, version, kind):
    r = _simulate(fmus["Cubic", version], kind, ["x", "z", "w"], 1.0)
    x = 2.0 * np.exp(-r["time"])
    root = np.sqrt(x ** 2 / 4 + 1 / 27)
    z = np.cbrt(x / 2 + root) + np.cbrt(x / 2 - root)  # Cardano: the real root of z^3 + z - x
    assert np.max(np.abs(r["x"] - x)) < 1e-7
    assert np.max(np.abs(r["z"] - z)) < 1e-7 and np.max(np.abs(r["w"] - 2 * z)) < 2e-7


@pytest.mark.parametrize("version,kind", [(3, "CoSimulation"), (2, "ModelExchange")])
def test_a_local_of_a_hybrid_model_follows_its_event(fmus, version, kind):
    r = _simulate(fmus["Switch", version], kind, ["x", "s"], 1.5)
    t, t_event = r["time"], np.log(2.0)
    away = np.abs(t - t_event) > 1e-3
    assert np.array_equal(r["s"][away], np.where(t[away] < t_event, 1.0, 2.0))
    x = np.where(t < t_event, np.exp(-t), 0.5 * np.exp(-2.0 * (t - t_event)))
    assert np.max(np.abs(r["x"][away] - x[away])) < 1e-6


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_cosim_run_records_locals_calculated_parameters_and_constants_by_name(fmus, tmp_path, engine):
    config = tmp_path / "rc.toml"
    config.write_text(f"""
[run]
stop = 0.5
engine = "{engine}"

[solver]
max_step = 1e-4

[fmus.rc]
path = "{fmus["RC", 3]}"
parameters = {{ "r.R" = 50.0 }}

[record]
rate = 100
signals = ["rc.vc", "rc.r.v", "rc.c.i", "rc.r.n.i", "rc.p_R", "rc.tau", "rc.two"]
""")
    with warnings.catch_warnings():
        warnings.simplefilter("error", EngineFallbackWarning)  # locals are Float64: the compiled engine stays
        result = run(load_config(config), progress=False)
    t = result.data["time"]
    expected = _rc_closed_form(t, 10.0, 50.0, 1e-3)
    for name in ("vc", "r.v", "c.i", "r.n.i", "p_R", "tau", "two"):
        assert np.max(np.abs(result.data[name] - expected[name])) < 1e-6 * max(1.0, np.max(np.abs(expected[name])))
    assert result.units["p_R"] == "W" and result.units["tau"] == "s"


def test_a_config_cannot_set_the_start_of_a_local(fmus, tmp_path):
    config = tmp_path / "rc.toml"
    config.write_text(f"""
[run]
stop = 0.1

[fmus.rc]
path = "{fmus["RC", 3]}"
start = {{ "r.v" = 1.0 }}

[record]
signals = ["rc.r.v"]
""")
    with pytest.raises(ConfigError, match="r.v.* local variable the FMU calculates"):
        load_config(config)
