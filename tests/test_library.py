"""Libraries: `cosim build --modelica-path`, MODELICAPATH and models.toml's `libraries` find the classes a user's
model uses; a model of a library is built by its name alone; a library that is not there is named with the
line that uses it and the folders looked in. The library here is a small one written by the test; the Modelica
Standard Library is tested in tests/test_msl.py."""

import os
import textwrap
from pathlib import Path

import fmpy
import numpy as np
import pytest
import rumoca

from cosim.cli import main
from cosim.compile import build_all, build_fmu
from cosim.compile.frontend import load_flat_model
from cosim.compile.library import find_class_file, library_path
from cosim.compile.library_subset import library_subset
from cosim.errors import ModelicaError

# A library of two files (a package folder), as users' and vendors' libraries are laid out.
LIBRARY = {
    "package.mo": "package Mech\n  import SI = Mech.Units;\nend Mech;\n",
    "Units.mo": "within Mech;\npackage Units\n  type Force = Real(unit = \"N\");\nend Units;\n",
    "Spring.mo": textwrap.dedent("""\
        within Mech;
        model Spring "linear spring to ground with a viscous damper"
          parameter Real k(unit = "N/m") = 4;
          parameter Real d(unit = "N.s/m") = 0.4;
          Real s(unit = "m");
          Real v(unit = "m/s");
          input Real f_ext;
          Mech.Units.Force f "force of spring and damper";
        equation
          f = -k*s - d*v;
        end Spring;
        """),
    "Examples.mo": textwrap.dedent("""\
        within Mech;
        package Examples
          model Oscillator "a mass on the spring, let go at s = 0.1 m"
            parameter Real m = 1;
            Mech.Spring spring(s(start = 0.1, fixed = true), v(start = 0, fixed = true));
            output Real x = spring.s;
          equation
            spring.f_ext = 0;
            der(spring.s) = spring.v;
            m*der(spring.v) = spring.f + spring.f_ext;
          end Oscillator;
        end Examples;
        """),
}


def _library(folder):
    package = folder / "Mech"
    package.mkdir(parents=True)
    for name, text in LIBRARY.items():
        (package / name).write_text(text)
    return folder


def _oscillator_closed_form(t, m=1.0, k=4.0, d=0.4, x0=0.1):
    """x(t) of m x'' + d x' + k x = 0 from x0 at rest (underdamped)."""
    wn, zeta = np.sqrt(k / m), d / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - zeta**2)
    return x0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))


def _check_oscillator(fmu):
    result = fmpy.simulate_fmu(str(fmu), stop_time=5.0, output_interval=0.01, relative_tolerance=1e-8,
                               fmi_type="ModelExchange", output=["x"])
    # rtol 1e-8 in CVode: the closed form to 1e-6 of the 0.1 m amplitude
    np.testing.assert_allclose(result["x"], _oscillator_closed_form(result["time"]), atol=1e-6)


def test_a_library_model_is_built_by_its_name_alone(tmp_path, capsys):
    libs = _library(tmp_path / "libs")
    out = tmp_path / "out"
    assert main(["build", "--model", "Mech.Examples.Oscillator", "--modelica-path", str(libs),
                 "--out", str(out)]) == 0
    _check_oscillator(out / "Oscillator.fmu")


def test_a_users_file_uses_a_library_through_modelicapath(tmp_path, monkeypatch):
    libs = _library(tmp_path / "libs")
    user = tmp_path / "user"
    user.mkdir()
    (user / "Plant.mo").write_text(textwrap.dedent("""\
        model Plant
          extends Mech.Examples.Oscillator(m = 1);
        end Plant;
        """))
    monkeypatch.setenv("MODELICAPATH", os.pathsep.join([str(tmp_path / "empty"), str(libs)]))
    (tmp_path / "empty").mkdir()
    assert main(["build", str(user / "Plant.mo"), "--model", "Plant", "--out", str(tmp_path / "out")]) == 0
    fmu = tmp_path / "out" / "Plant.fmu"
    _check_oscillator(fmu)
    units = {v.name: v.unit for v in fmpy.read_model_description(str(fmu)).modelVariables}
    assert units["spring.k"] == "N/m"  # the library's declarations carried into the FMU


def test_models_toml_lists_libraries_and_a_library_change_rebuilds(tmp_path):
    libs = _library(tmp_path / "libs")
    models = tmp_path / "modelica" / "models.toml"
    models.parent.mkdir()
    models.write_text('libraries = ["../libs"]\n\n[[model]]\nname = "Osc"\nmodel = "Mech.Examples.Oscillator"\n')
    out = tmp_path / "fmus"
    assert list(build_all(models, out_dir=out)) == [f"Osc: built {out / 'Osc.fmu'}"]
    _check_oscillator(out / "Osc.fmu")
    assert "up to date" in list(build_all(models, out_dir=out))[0]
    spring = libs / "Mech" / "Spring.mo"
    spring.write_text(spring.read_text().replace("= 4;", "= 9;"))
    assert "built" in list(build_all(models, out_dir=out))[0]


def test_a_class_no_library_holds_is_named_with_its_line_and_the_folders_looked_in(tmp_path, capsys):
    user = tmp_path / "user"
    user.mkdir()
    (user / "Plant.mo").write_text("model Plant\n  Real y;\n  Mech.Spring spring;\nequation\n  y = 1;\nend Plant;\n")
    with pytest.raises(ModelicaError) as err:
        build_fmu(user / "Plant.mo", "Plant", out_dir=tmp_path / "out", modelica_path=[tmp_path])
    assert err.value.file == str(user / "Plant.mo") and err.value.line == 3
    assert "class Mech.Spring not found" in str(err.value) and str(tmp_path) in str(err.value)
    assert main(["build", "--model", "Mech.Examples.Oscillator", "--out", str(tmp_path / "out")]) == 2
    said = capsys.readouterr().err
    assert "no library holds Mech" in said and "--modelica-path" in said and "MODELICAPATH" in said
    assert not (tmp_path / "out").exists()


def test_the_library_path_is_ordered_and_checked(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    for folder in (first, second):
        (folder / "Lib").mkdir(parents=True)
        (folder / "Lib" / "package.mo").write_text("package Lib\nend Lib;\n")
    roots = library_path([first], environ={"MODELICAPATH": os.pathsep.join([str(second), str(first)])})
    assert roots == (first.resolve(), second.resolve())
    assert find_class_file("Lib.X.Y", roots) == first.resolve() / "Lib" / "package.mo"
    (tmp_path / "c" / "Versioned 2.1").mkdir(parents=True)
    (tmp_path / "c" / "Versioned 2.1" / "package.mo").write_text("package Versioned\nend Versioned;\n")
    (tmp_path / "c" / "Single.mo").write_text("package Single\nend Single;\n")
    assert find_class_file("Versioned.A", [tmp_path / "c"]).parent.name == "Versioned 2.1"
    assert find_class_file("Single.A", [tmp_path / "c"]).name == "Single.mo"
    assert find_class_file("Absent.A", [tmp_path / "c"]) is None
    with pytest.raises(ModelicaError, match="from MODELICAPATH"):
        library_path([], environ={"MODELICAPATH": str(tmp_path / "nope")})


# A library whose classes name each other relative to their enclosing packages, with a package the model never uses.
RELATIVE = {
    "package.mo": "package Lib\nend Lib;\n",
    "Interfaces.mo": "within Lib;\npackage Interfaces\n  connector Port\n    Real x;\n  end Port;\nend Interfaces;\n",
    "Parts/package.mo": "within Lib;\npackage Parts\nend Parts;\n",
    "Parts/Decay.mo": textwrap.dedent("""\
        within Lib.Parts;
        model Decay "x' = -x/tau"
          parameter Real tau = 2;
          Interfaces.Port port(x(start = 1, fixed = true));
        equation
          der(port.x) = -port.x/tau;
        end Decay;
        """),
    "Unused/package.mo": "within Lib;\npackage Unused\n  model Big\n    Real z = 1;\n  end Big;\nend Unused;\n",
    "Examples.mo": textwrap.dedent("""\
        within Lib;
        package Examples
          model Demo "see Lib.Unused.Big, a name in a string: not a use"
            Parts.Decay decay;
            output Real y = decay.port.x;
          end Demo;
        end Examples;
        """),
}


def _without_spans(ir):
    if isinstance(ir, dict):
        return {k: _without_spans(v) for k, v in ir.items() if k not in ("span", "source_map")}
    return [_without_spans(v) for v in ir] if isinstance(ir, list) else ir


def _relative_library(libs):
    for name, text in RELATIVE.items():
        (libs / "Lib" / name).parent.mkdir(parents=True, exist_ok=True)
        (libs / "Lib" / name).write_text(text)
    return libs


def test_a_library_model_is_flattened_from_the_library_files_it_uses_alone(tmp_path):
    libs = _relative_library(tmp_path / "libs")
    (libs / "Other.mo").write_text("package Other\n  model M\n    Real q = 2;\n  end M;\nend Other;\n")
    copies = library_subset("Lib.Examples.Demo", [], [libs], tmp_path / "subset")
    used = {"package.mo", "Examples.mo", "Parts/package.mo", "Parts/Decay.mo", "Interfaces.mo"}
    assert set(copies.values()) == {str(libs / "Lib" / name) for name in used}
    assert all(Path(copy).read_text() == Path(original).read_text() for copy, original in copies.items())
    flat = load_flat_model(None, "Lib.Examples.Demo", [libs])
    whole = rumoca.Session(roots=[str(libs)]).load(str(libs / "Lib" / "package.mo"), model="Lib.Examples.Demo")
    assert _without_spans(flat.ir) == _without_spans(whole.to_dict("dae"))
    assert {name for _, name, _ in flat.ir["source_map"]["files"]} == {str(libs / "Lib" / name) for name in used}


def test_a_class_the_scan_misses_is_found_in_the_whole_library(tmp_path):
    """A wildcard import hides Decay's package from the text scan: rumoca fails on the copy, the whole path serves."""
    libs = _relative_library(tmp_path / "libs")
    user = tmp_path / "user"
    user.mkdir()
    (user / "Plant.mo").write_text("model Plant\n  import Lib.Parts.*;\n  Decay decay;\nend Plant;\n")
    assert str(libs / "Lib" / "Parts" / "Decay.mo") not in library_subset(
        "Plant", [(user / "Plant.mo").read_text()], [libs], tmp_path / "subset").values()
    flat = load_flat_model(user / "Plant.mo", "Plant", [libs])
    whole = rumoca.Session(roots=[str(libs)]).load(str(user / "Plant.mo"), model="Plant")
    assert _without_spans(flat.ir) == _without_spans(whole.to_dict("dae"))
    assert [v["name"] for v in flat.ir["storage"]["variables"] if v["role"] == "state"] == ["decay.port.x"]
