"""Library transforms (cosim.compile.workarounds): a library with a construct rumoca 0.10.2 miscounts (a parameter
bound to a table lookup, as the MSL's Clutch binds mu0) is refused by rumoca as it is and builds from a transformed
private copy, with the user's files untouched. The library is a stand-in for the MSL's lookups, in
tests/models/library_transform: its lookup takes the table as an array, which rumoca 0.10.2 miscounts alike."""

import hashlib
from pathlib import Path

import fmpy
import numpy as np
import pytest

from cosim.compile import build_fmu, workarounds
from cosim.compile.workarounds import transform_table_bindings
from cosim.errors import LibraryTransformWarning, StructureError

LIBRARY = Path(__file__).parent / "models" / "library_transform"


def _hashes(folder):
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_parameter_bound_to_a_lookup_is_refused_as_is_and_built_from_a_transformed_copy(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    before = _hashes(LIBRARY)
    monkeypatch.setattr(workarounds, "RUMOCA_VERSION", "0.0.0")  # another rumoca: the library is handed as it is
    with pytest.raises(StructureError, match="unbalanced"):
        build_fmu(None, "Lookup.Ramp", out_dir=tmp_path / "out", modelica_path=[LIBRARY])
    monkeypatch.undo()
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    with pytest.warns(LibraryTransformWarning, match="table-lookup-binding: 1 parameter bindings"):
        fmu = build_fmu(None, "Lookup.Ramp", out_dir=tmp_path / "out", modelica_path=[LIBRARY])
    result = fmpy.simulate_fmu(str(fmu), stop_time=2.0, output_interval=0.1, fmi_type="ModelExchange", output=["x"])
    # p is the table [0, 0.5; 1, 0.7] at u = 0.5: 0.6, so x = 0.6 t
    np.testing.assert_allclose(result["x"], 0.6 * result["time"], atol=1e-9)
    assert _hashes(LIBRARY) == before
    copies = list((tmp_path / "cache" / "cosim" / "library-transforms").rglob("package.mo"))
    assert len(copies) == 1 and "= 1.0*(getTable1DValueNoDer2(tableID, 1, 0.5))" in copies[0].read_text()


def test_the_transform_wraps_the_msl_bindings_and_keeps_the_lines():
    # Modelica/Mechanics/Rotational/Components/Clutch.mo of MSL 4.1.0 (its mu0), and a lookup in an equation
    text = ('  final parameter Real mu0 =\n'
            '    if     smoothness == Smoothness.ConstantSegments then getTable1DValueNoDer(tableID, 1, 0)\n'
            '    else                                                  getTable1DValue(tableID, 1, 0)\n'
            '    "Friction coefficient for w=0 and forward sliding";\n'
            '  parameter SI.Torque tau_bf1_0 = abs(getTable1DValueNoDer2(tableID, 3, 0));\n'
            '  parameter Real u_min = getTable1DAbscissaUmin(tableID);\n'
            'equation\n'
            '  mu = getTable1DValueNoDer2(tableID, 1, w_rel);\n')
    out, count = transform_table_bindings(text)
    assert count == 2
    assert out == ('  final parameter Real mu0 = 1.0*(\n'
                   '    if     smoothness == Smoothness.ConstantSegments then getTable1DValueNoDer(tableID, 1, 0)\n'
                   '    else                                                  getTable1DValue(tableID, 1, 0))\n'
                   '    "Friction coefficient for w=0 and forward sliding";\n'
                   '  parameter SI.Torque tau_bf1_0 = 1.0*(abs(getTable1DValueNoDer2(tableID, 3, 0)));\n'
                   '  parameter Real u_min = getTable1DAbscissaUmin(tableID);\n'
                   'equation\n'
                   '  mu = getTable1DValueNoDer2(tableID, 1, w_rel);\n')


def test_a_copy_left_without_its_count_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    with pytest.warns(LibraryTransformWarning):
        (copy,) = workarounds.transformed_roots((LIBRARY,), workarounds.RUMOCA_VERSION, "state 1")
    (copy.parent / "count").unlink()  # as an interrupted or older cosim leaves it
    with pytest.warns(LibraryTransformWarning, match="1 parameter bindings"):
        assert workarounds.transformed_roots((LIBRARY,), workarounds.RUMOCA_VERSION, "state 1") == (copy,)
    assert "1.0*(" in (copy / "Lookup" / "package.mo").read_text()
    assert workarounds.transformed_roots((LIBRARY,), "0.10.3", "state 1") == (LIBRARY,)
