"""The FMU's interface (modelDescription), its binary outside Python, and the compiler's error handling."""

import subprocess
import textwrap
import warnings
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from cosim.cli import main
from cosim.compile import build_all, build_fmu, lower
from cosim.errors import ModelicaError, StructureError, UnsupportedConstructError

from conftest import COMPILER_MODELS


def variables(fmu):
    return {v.name: v for v in read_model_description(str(fmu)).modelVariables}


@pytest.mark.parametrize("name", ["MassSpringDamper", "Drive", "PMSM", "NonlinearLoop", "InitialAndInteger"])
def test_model_description_is_valid(compiler_fmu, name):
    assert validate_fmu(str(compiler_fmu(name))) == []


def test_model_description_carries_declarations(compiler_fmu):
    v = variables(compiler_fmu("PMSM"))
    assert v["v_q"].causality == "input" and v["v_q"].unit == "V" and v["v_q"].description == "q voltage"
    assert v["w"].causality == "output" and v["w"].unit == "rad/s"  # an output that is also a state
    assert v["i_q"].causality == "output" and v["i_q"].description == "q current"
    rs = v["Rs"]
    assert (rs.causality, rs.variability, float(rs.start), rs.unit) == ("parameter", "tunable", 0.45, "Ohm")
    assert v["theta"].unit == "rad" and float(v["theta"].start) == 0.0
    units = {u.name for u in read_model_description(str(compiler_fmu("PMSM"))).unitDefinitions}
    assert {"V", "A", "rad/s", "Ohm", "H", "Wb", "kg.m2", "N.m.s/rad", "N.m"} <= units


def test_dependent_parameter_is_a_calculated_parameter_not_a_separate_tunable(compiler_fmu):
    v = variables(compiler_fmu("DependentParameters"))
    assert v["k"].variability == "tunable" and float(v["k"].start) == 2.0
    # Substituted into the equations, so they follow k (checked numerically in the model tests), and visible as
    # calculated parameters: c = k*k + 1 = 5, c2 = 0.5*c = 2.5 at k = 2.
    assert v["c"].causality == v["c2"].causality == "calculatedParameter"
    assert v["c"].variability == v["c2"].variability == "tunable"
    for k in (2.0, 3.0):
        result = fmpy.simulate_fmu(str(compiler_fmu("DependentParameters")), stop_time=0.1, start_values={"k": k},
                                   output=["c", "c2"])
        assert result["c"][-1] == k * k + 1 and result["c2"][-1] == 0.5 * (k * k + 1)


HARNESS = r"""
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi3Functions.h"

int main(int argc, char** argv) {
  void* lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
  if (!lib) { printf("dlopen: %s\n", dlerror()); return 1; }
  fmi3InstantiateModelExchangeTYPE* inst = (fmi3InstantiateModelExchangeTYPE*)dlsym(lib, "fmi3InstantiateModelExchange");
  fmi3EnterInitializationModeTYPE* enter = (fmi3EnterInitializationModeTYPE*)dlsym(lib, "fmi3EnterInitializationMode");
  fmi3ExitInitializationModeTYPE* leave = (fmi3ExitInitializationModeTYPE*)dlsym(lib, "fmi3ExitInitializationMode");
  fmi3EnterContinuousTimeModeTYPE* cont = (fmi3EnterContinuousTimeModeTYPE*)dlsym(lib, "fmi3EnterContinuousTimeMode");
  fmi3SetContinuousStatesTYPE* setx = (fmi3SetContinuousStatesTYPE*)dlsym(lib, "fmi3SetContinuousStates");
  fmi3SetFloat64TYPE* setf = (fmi3SetFloat64TYPE*)dlsym(lib, "fmi3SetFloat64");
  fmi3GetContinuousStateDerivativesTYPE* getdx = (fmi3GetContinuousStateDerivativesTYPE*)dlsym(lib, "fmi3GetContinuousStateDerivatives");
  if (!inst || !setx || !getdx || !setf) { printf("missing symbol\n"); return 1; }
  fmi3Instance m = inst("harness", argv[2], NULL, fmi3False, fmi3False, NULL, NULL);
  if (!m) { printf("instantiate failed\n"); return 1; }
  int n = atoi(argv[3]);
  fmi3Float64 x[16], dx[16];
  for (int i = 0; i < n; ++i) x[i] = atof(argv[4 + i]);
  int nu = atoi(argv[4 + n]);
  fmi3ValueReference vr[16]; fmi3Float64 u[16];
  for (int i = 0; i < nu; ++i) { vr[i] = atoi(argv[5 + n + 2*i]); u[i] = atof(argv[6 + n + 2*i]); }
  if (enter(m, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK) return 1;
  if (leave(m) != fmi3OK || cont(m) != fmi3OK) return 1;
  if (nu && setf(m, vr, nu, u, nu) != fmi3OK) return 1;
  if (setx(m, x, n) != fmi3OK || getdx(m, dx, n) != fmi3OK) return 1;
  for (int i = 0; i < n; ++i) printf("%.17g\n", dx[i]);
  return 0;
}
"""


@pytest.mark.parametrize("name,state,inputs", [
    ("PMSM", [0.3, 1.2, 50.0, 0.1], {"v_d": 0.2, "v_q": 3.0, "tau_load": 0.002}),
    ("Drive", [0.4, 2.0, 0.05, 0.3], {"tau_m": 0.5}),  # tanh needs libm
    ("NonlinearLoop", [0.7], {"u": 0.1}),
])
def test_binary_runs_from_c_and_agrees_with_python(compiler_fmu, tmp_path, name, state, inputs):
    fmu = compiler_fmu(name)
    unzipped = Path(fmpy.extract(str(fmu), unzipdir=str(tmp_path / "fmu")))
    md = read_model_description(str(fmu))
    source = tmp_path / "harness.c"
    source.write_text(HARNESS)
    exe = tmp_path / "harness"
    include = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-O1", f"-I{include}", str(source), "-o", str(exe), "-ldl"], check=True)
    so = unzipped / "binaries" / "x86_64-linux" / f"{md.modelExchange.modelIdentifier}.so"
    refs = {v.name: v.valueReference for v in md.modelVariables}
    args = [str(exe), str(so), md.instantiationToken, str(len(state)), *map(repr, state), str(len(inputs))]
    for key, value in inputs.items():
        args += [str(refs[key]), repr(value)]
    run = subprocess.run(args, capture_output=True, text=True, env={})  # empty env: no LD_PRELOAD, no Python libm
    assert run.returncode == 0, run.stdout + run.stderr
    from_c = np.array([float(line) for line in run.stdout.split()])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = lower(COMPILER_MODELS, f"CompilerTests.{name}")
    u = [inputs[i.name] for i in model.inputs]
    np.testing.assert_allclose(from_c, model.derivatives(state, u), rtol=1e-12, atol=1e-12)


def _package(tmp_path, body, name="T"):
    folder = tmp_path / name
    folder.mkdir()
    path = folder / f"{name}.mo"
    path.write_text(textwrap.dedent(f"package {name}\n{body}\nend {name};\n"))
    return path


UNSUPPORTED = {
    "delay": ("""
  model M
    Real x(start = 1);
    Real y;
  equation
    der(x) = -x;
    y = delay(x, 0.1);
  end M;""", "delay()", 8),
    "terminal": ("""
  model M
    Real x(start = 1);
    Real y;
  equation
    der(x) = -x;
    y = if terminal() then 1 else 0;
  end M;""", "terminal() in an equation that holds in continuous time", 8),
    "clocked": ("""
  model M
    Real x(start = 1);
    Real y;
    Real z;
    Clock c = Clock(0.1);
  equation
    der(x) = -x;
    y = sample(x, c);
    z = previous(y) + 1;
  end M;""", "clocked synchronous construct", 10),
    "string in a number": ("""
  model M
    parameter String mode = "fast";
    Real x(start = 1);
  equation
    der(x) = if mode == "fast" then -2*x else -x;
  end M;""", 'a String expression ("fast") where a number is computed', 7),
}


@pytest.mark.parametrize("construct", sorted(UNSUPPORTED))
def test_unsupported_construct_is_named_with_file_and_line(tmp_path, construct):
    body, expected, line = UNSUPPORTED[construct]
    path = _package(tmp_path, body)
    out = tmp_path / "out"
    with pytest.raises(UnsupportedConstructError) as err:
        build_fmu(path, "T.M", out_dir=out)
    assert expected in str(err.value)
    assert err.value.file.endswith("T.mo") and err.value.line == line, str(err.value)
    assert not out.exists()


BAD_INPUT = {
    "syntax": ("\n  model M\n    Real x(start = 1);\n  equation\n    der(x) = -x +;\n  end M;", "T.M",
               ModelicaError, "T.mo:6: unexpected"),
    "unknown model": ("\n  model M\n    Real x(start = 1);\n  equation\n    der(x) = -x;\n  end M;", "T.Nope",
                      ModelicaError, "no model named 'T.Nope'"),
    "under-determined": ("\n  model M\n    Real x(start = 1);\n    Real y;\n  equation\n    der(x) = -x;\n  end M;",
                         "T.M", StructureError, "unbalanced"),
    "over-determined": ("\n  model M\n    Real x(start = 1);\n  equation\n    der(x) = -x;\n    x = 2;\n  end M;",
                        "T.M", StructureError, "unbalanced"),
    "singular": ("\n  model M\n    Real x(start = 1);\n    Real a;\n    Real b;\n  equation\n    der(x) = -x;\n"
                 "    a + b = x;\n    2*a + 2*b = 3*x;\n  end M;", "T.M", StructureError, "singular"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUT))
def test_bad_model_gives_one_line_error_and_exit_code_2(tmp_path, capsys, case):
    body, model, error_type, message = BAD_INPUT[case]
    path = _package(tmp_path, body)
    out = tmp_path / "out"
    with pytest.raises(error_type) as err:
        build_fmu(path, model, out_dir=out)
    assert message in str(err.value)
    assert main(["build", str(path), "--model", model, "--out", str(out)]) == 2
    stderr = capsys.readouterr().err
    assert message in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert not out.exists()


def test_missing_file_exit_code_2(tmp_path, capsys):
    assert main(["build", str(tmp_path / "nope.mo"), "--model", "A.B", "--out", str(tmp_path / "o")]) == 2
    assert "no such Modelica file" in capsys.readouterr().err


def test_build_all_skips_unchanged_models(tmp_path):
    source = _package(tmp_path, "\n  model M\n    Real x(start = 1);\n  equation\n    der(x) = -x;\n  end M;")
    models = tmp_path / "modelica" / "models.toml"
    models.parent.mkdir()
    models.write_text(f'[[model]]\nname = "Decay"\nmodel = "T.M"\nsource = "{source}"\n')
    out = tmp_path / "fmus"
    assert list(build_all(models, out_dir=out)) == [f"Decay: built {out / 'Decay.fmu'}"]
    assert "up to date" in list(build_all(models, out_dir=out))[0]
    source.write_text(source.read_text().replace("-x;", "-2*x;"))
    assert "built" in list(build_all(models, out_dir=out))[0]


def test_a_model_is_lowered_anew_only_when_a_file_of_its_folder_changed(tmp_path):
    # a diagnosis lowers its baseline and each variant in every stage: the same sources give the same lowered model
    source = _package(tmp_path, "\n  model M\n    Real x(start = 1);\n  equation\n    der(x) = -x;\n  end M;")
    first = lower(source, "T.M")
    assert lower(source, "T.M") is first
    np.testing.assert_allclose(first.derivatives([3.0], []), [-3.0])  # der(x) = -x
    source.write_text(source.read_text().replace("-x;", "-2*x;"))
    np.testing.assert_allclose(lower(source, "T.M").derivatives([3.0], []), [-6.0])
    # rumoca reads every .mo file of the folder: a change of another file the model uses counts too
    source.write_text(source.read_text().replace("-2*x;", "-K.k*x;"))
    (source.parent / "K.mo").write_text("package K\n  constant Real k = 5;\nend K;\n")
    np.testing.assert_allclose(lower(source, "T.M").derivatives([3.0], []), [-15.0])
    (source.parent / "K.mo").write_text("package K\n  constant Real k = 7;\nend K;\n")
    np.testing.assert_allclose(lower(source, "T.M").derivatives([3.0], []), [-21.0])


def test_model_list_rejects_unknown_keys(tmp_path):
    from cosim.errors import ConfigError

    models = tmp_path / "models.toml"
    models.write_text('[[model]]\nname = "A"\nmodel = "P.A"\nsource = "P/package.mo"\nsorce = "x"\n')
    with pytest.raises(ConfigError, match=r"models.toml:2: model\[0\] has unknown key 'sorce'"):
        list(build_all(models, out_dir=tmp_path / "o"))


def test_string_parameters_that_no_equation_computes_with_are_left_out(tmp_path):
    """The MSL's tables carry file and table names (String parameters): the model builds without them."""
    path = _package(tmp_path, """
  model M
    parameter String fileName = "NoName" "file of the table";
    parameter Real k = 3;
    Real x(start = 1, fixed = true);
  equation
    der(x) = -k*x;
  end M;""")
    model = lower(path, "T.M")
    assert [p.name for p in model.parameters] == ["k"]
    assert model.derivatives([2.0], []) == pytest.approx([-6.0])
