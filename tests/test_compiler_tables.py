"""The MSL 4.1.0 table blocks (Blocks.Sources.CombiTimeTable, Blocks.Tables.CombiTable1Ds/1Dv, through them
BooleanTable and IntegerTable) lowered natively (cosim/compile/tables.py, the semantics of ModelicaStandardTables.c).
Small user models built to FMUs and simulated with fmpy's CVode on the Model Exchange interface (and the FMU's
own Co-Simulation solver), against numpy on the same tables (np.interp, np.searchsorted) away from the event
instants; the event instants against the hand-listed ones; the integral of a table of constant segments is
exact only if its time events are located. Plus the MSL examples that use the tables against the Modelica
Association's reference results. The tests that load the MSL (about 15 s) are marked slow."""

import sys
import textwrap
from pathlib import Path

import fmpy
from fmpy.fmi1 import FMICallException
import numpy as np
import pytest

from cosim.compile import build_fmu, lower
from cosim.errors import ModelicaError, UnsupportedConstructError
from modelica_support import away, event_instants, simulate, write_package

ROOT = Path(__file__).resolve().parents[1]
MSL = Path(__file__).resolve().parents[2] / "shared" / "msl" / "ModelicaStandardLibrary-4.1.0"
REFS = MSL.parent / "reference"

needs_msl = pytest.mark.skipif(not MSL.is_dir(), reason=f"no MSL 4.1.0 at {MSL}")

TABLES = """
  model Time "CombiTimeTable: linear segments with a jump, extrapolations, start and shift, periodic, constant"
    import Modelica.Blocks.Types.Extrapolation;
    import Modelica.Blocks.Types.Smoothness;
    import Modelica.Blocks.Types.TimeEvents;
    Modelica.Blocks.Sources.CombiTimeTable hold(table = [0, 1, 10; 1, 3, 20; 2, 2, 30; 2, 5, 40; 3, 4, 50],
      columns = {3, 2}, extrapolation = Extrapolation.HoldLastPoint, startTime = 0.3, shiftTime = 0.5,
      offset = {0.25, -1});
    Modelica.Blocks.Sources.CombiTimeTable last2(table = [0, 1; 1, 3; 2, 2; 2, 5; 3, 4],
      extrapolation = Extrapolation.LastTwoPoints, shiftTime = 0.5);
    Modelica.Blocks.Sources.CombiTimeTable disc(table = [0, 1; 1, 3; 2, 2; 2, 5; 3, 4],
      timeEvents = TimeEvents.AtDiscontinuities, extrapolation = Extrapolation.HoldLastPoint, shiftTime = 0.05);
    Modelica.Blocks.Sources.CombiTimeTable periodic(table = [0, 0; 0.5, 2; 1, 1],
      extrapolation = Extrapolation.Periodic, timeScale = 2, shiftTime = 0.2);
    Modelica.Blocks.Sources.CombiTimeTable steps(table = [0, 1; 0.35, -2; 0.8, 3; 1.3, 0.5],
      smoothness = Smoothness.ConstantSegments, extrapolation = Extrapolation.HoldLastPoint);
    Modelica.Blocks.Sources.CombiTimeTable steps2(table = [0, 1; 0.35, -2; 0.8, 3; 1.3, 0.5],
      smoothness = Smoothness.ConstantSegments, extrapolation = Extrapolation.LastTwoPoints);
    Modelica.Blocks.Sources.BooleanTable boolean(table = {0.25, 0.6, 1.7});
    Modelica.Blocks.Sources.IntegerTable integer(table = [0, 3; 0.45, -1; 1.1, 7]);
    Real x(start = 0, fixed = true);
    output Real y1 = hold.y[1];
    output Real y2 = hold.y[2];
    output Real l = last2.y[1];
    output Real d = disc.y[1];
    output Real p = periodic.y[1];
    output Real s = steps.y[1];
    output Real s2 = steps2.y[1];
    output Boolean b = boolean.y;
    output Integer k = integer.y;
  equation
    der(x) = steps.y[1];
  end Time;

  model OneD "CombiTable1Ds and CombiTable1Dv of u = 4 time - 2"
    import Modelica.Blocks.Types.Extrapolation;
    import Modelica.Blocks.Types.Smoothness;
    Modelica.Blocks.Tables.CombiTable1Ds lin(table = [-1, 2, 0; 0, 1, 1; 2, 3, -1]);
    Modelica.Blocks.Tables.CombiTable1Dv hold(table = [-1, 2, 0; 0, 1, 1; 2, 3, -1],
      extrapolation = Extrapolation.HoldLastPoint);
    Modelica.Blocks.Tables.CombiTable1Ds steps(table = [0, 1; 0.5, 4; 1, 2], columns = {2},
      smoothness = Smoothness.ConstantSegments, extrapolation = Extrapolation.Periodic);
    output Real a1 = lin.y[1];
    output Real a2 = lin.y[2];
    output Real h1 = hold.y[1];
    output Real h2 = hold.y[2];
    output Real c = steps.y[1];
  equation
    lin.u = 4*time - 2;
    hold.u = {4*time - 2, 2 - 4*time};
    steps.u = 4*time - 2;
  end OneD;

  model NoExtrapolation "a time table and a 1D table that must not extrapolate"
    parameter Real p = 1 "slope of the 1D table's input";
    Modelica.Blocks.Sources.CombiTimeTable time_table(table = [0, 0; 1, 1],
      extrapolation = Modelica.Blocks.Types.Extrapolation.NoExtrapolation);
    Modelica.Blocks.Tables.CombiTable1Ds table_1d(table = [-1, 0; 0.6, 1],
      extrapolation = Modelica.Blocks.Types.Extrapolation.NoExtrapolation);
    output Real y = time_table.y[1] + table_1d.y[1];
  equation
    table_1d.u = p*time;
  end NoExtrapolation;

  model Spline "a cubic Hermite spline is not lowered"
    Modelica.Blocks.Sources.CombiTimeTable spline(table = [0, 0; 1, 1; 2, 0],
      smoothness = Modelica.Blocks.Types.Smoothness.ContinuousDerivative);
    output Real y = spline.y[1];
  end Spline;

  model OnFile "a table read from a file"
    Modelica.Blocks.Sources.CombiTimeTable fromFile(tableOnFile = true, tableName = "tab", fileName = "tab.txt");
    output Real y = fromFile.y[1];
  end OnFile;

  model TwoD "a table in two dimensions"
    Modelica.Blocks.Tables.CombiTable2Ds table(table = [0, 1, 2; 1, 3, 4; 2, 5, 6]);
    output Real y = table.y;
  equation
    table.u1 = time;
    table.u2 = time;
  end TwoD;

  model Interpolated "Blocks.Sources.TimeTable: Modelica functions, no table object"
    Modelica.Blocks.Sources.TimeTable timeTable(table = [0, 0; 1, 1]);
    output Real y = timeTable.y;
  end Interpolated;
"""

FMI_TYPES = ["ModelExchange", "CoSimulation"]


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    return write_package(tmp_path_factory.mktemp("tables"), TABLES)


@pytest.fixture(scope="module")
def fmu(package):
    built = {}

    def get(name):
        if name not in built:
            built[name] = build_fmu(package, f"T.{name}", out_dir=package.parent / "fmus", modelica_path=[MSL])
        return built[name]

    return get


def jump_table(u, hold=True):
    """The table [0, 1; 1, 3; 2, 2; 2, 5; 3, 4] (a jump at 2) by np.interp on each side of the jump; outside
    [0, 3] the first/last row (hold) or the line through the first/last two rows of each side."""
    left = np.interp(u, [0, 1, 2], [1, 3, 2])
    value = np.where(u < 2, left, np.interp(u, [2, 3], [5, 4]))
    if hold:
        return value
    return np.where(u < 0, 1 + 2 * u, np.where(u >= 3, 4 - (u - 3), value))


def constant_segments(u, times, values):
    """The row at or before u (np.searchsorted), the first row before the table."""
    return np.asarray(values)[np.clip(np.searchsorted(times, u, side="right") - 1, 0, None)]


@pytest.mark.slow
@needs_msl
@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_time_tables_follow_numpy_on_the_same_tables(fmu, fmi_type):
    outputs = ["y1", "y2", "l", "d", "p", "s", "s2", "x"]
    r = simulate(fmu("Time"), fmi_type, outputs, 4.0)
    t = r["time"]
    # hold: its start, then 0, 1, 2, 3 shifted by 0.5 (last2 too); disc: 0, the jump at 2, 3 shifted by 0.05;
    # periodic: 0.5 and 1 of every period, in scaled time, shifted; steps: its times after 0; boolean, integer
    instants = np.sort([0.3, 0.5, 1.5, 2.5, 3.5, 0.05, 2.05, 3.05, 0.2, 1.2, 2.2, 3.2, 0.35, 0.8, 1.3,
                        0.25, 0.6, 1.7, 0.45, 1.1])
    if fmi_type == "ModelExchange":
        np.testing.assert_allclose(event_instants(r), instants, atol=1e-12)
    ok = away(t, instants)
    t, u = t[ok], t[ok] - 0.5
    col3 = np.where(u < 2, np.interp(u, [0, 1, 2], [10, 20, 30]), np.interp(u, [2, 3], [40, 50]))
    np.testing.assert_allclose(r["y1"][ok], 0.25 + np.where(t < 0.3, 0, col3), atol=1e-12)
    np.testing.assert_allclose(r["y2"][ok], -1 + np.where(t < 0.3, 0, jump_table(u)), atol=1e-12)
    np.testing.assert_allclose(r["l"][ok], jump_table(u, hold=False), atol=1e-12)
    np.testing.assert_allclose(r["d"][ok], jump_table(t - 0.05), atol=1e-12)
    np.testing.assert_allclose(r["p"][ok], np.interp(np.mod(t / 2 - 0.1, 1), [0, 0.5, 1], [0, 2, 1]), atol=1e-12)
    times, values = [0, 0.35, 0.8, 1.3], [1, -2, 3, 0.5]
    np.testing.assert_array_equal(r["s"][ok], constant_segments(t, times, values))
    np.testing.assert_allclose(r["s2"][ok], np.where(t >= 1.3, 0.5 - 5 * (t - 1.3), constant_segments(t, times, values)),
                               atol=1e-12)  # LastTwoPoints extrapolates constant segments linearly too (the C code)
    edges = times + [np.inf]  # the integral of the constant segments, segment by segment
    exact = np.array([sum(v * max(0.0, min(tt, b) - a) for a, b, v in zip(edges[:-1], edges[1:], values))
                      for tt in r["time"]])
    np.testing.assert_allclose(r["x"], exact, atol=1e-9 if fmi_type == "ModelExchange" else 1e-12)


@pytest.mark.slow
@needs_msl
@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_boolean_and_integer_tables_switch_at_their_instants(fmu, fmi_type):
    r = simulate(fmu("Time"), fmi_type, ["b", "k"], 2.0)
    t = r["time"]
    ok = away(t, [0.25, 0.6, 1.7, 0.45, 1.1])
    np.testing.assert_array_equal(r["b"][ok], np.searchsorted([0.25, 0.6, 1.7], t[ok], side="right") % 2 == 1)
    np.testing.assert_array_equal(r["k"][ok], constant_segments(t[ok], [0, 0.45, 1.1], [3, -1, 7]))


@pytest.mark.slow
@needs_msl
def test_a_tables_data_is_a_constant_of_the_fmu(fmu):
    """The lowered expressions hold the table's numbers: its parameters are constants, not tunable."""
    variables = {v.name: v for v in fmpy.read_model_description(str(fmu("Time"))).modelVariables}
    assert variables["hold.table[2,2]"].variability == "constant"
    assert float(variables["hold.table[2,2]"].start) == 3.0
    assert variables["hold.startTime"].causality == "parameter"  # start and shift stay tunable


@pytest.mark.slow
@needs_msl
@pytest.mark.parametrize("fmi_type", FMI_TYPES)
def test_1d_tables_follow_numpy_on_the_same_tables(fmu, fmi_type):
    r = simulate(fmu("OneD"), fmi_type, ["a1", "a2", "h1", "h2", "c"], 1.2)
    t = r["time"]
    u = 4 * t - 2
    col2 = np.interp(u, [-1, 0, 2], [2, 1, 3])
    col3 = np.interp(u, [-1, 0, 2], [0, 1, -1])
    np.testing.assert_allclose(r["a1"], np.where(u < -1, 2 - (u + 1), np.where(u > 2, 3 + (u - 2), col2)),
                               atol=1e-12)
    np.testing.assert_allclose(r["a2"], np.where(u < -1, u + 1, np.where(u > 2, -1 - (u - 2), col3)), atol=1e-12)
    np.testing.assert_allclose(r["h1"], col2, atol=1e-12)  # np.interp holds the end values
    np.testing.assert_allclose(r["h2"], np.interp(-u, [-1, 0, 2], [0, 1, -1]), atol=1e-12)
    ok = away(t, (np.arange(-4, 6) * 0.5 + 2) / 4)  # where u crosses a multiple of 0.5: a jump
    np.testing.assert_array_equal(r["c"][ok], constant_segments(np.mod(u[ok], 1), [0, 0.5], [1, 4]))


@pytest.mark.slow
@needs_msl
def test_no_extrapolation_fails_where_the_input_leaves_the_table(fmu):
    """A time table at t = 1 (its last time), the 1D table where u = p t passes 0.6: an assertion with the
    table's name and where it is written, not values."""
    path = fmu("NoExtrapolation")

    def failure(stop_time, p):
        messages = []
        with pytest.raises(FMICallException, match="fmi3UpdateDiscreteStates"):
            simulate(path, "ModelExchange", ["y"], stop_time, start_values={"p": p},
                     logger=lambda env, status, category, message: messages.append(message.decode()))
        return messages[-1]

    simulate(path, "ModelExchange", ["y"], 0.55)
    assert "T.mo:" in failure(0.65, 1.0) and "Extrapolation error in table_1d" in failure(0.65, 1.0)
    simulate(path, "ModelExchange", ["y"], 0.99, start_values={"p": 0.0})
    assert "Extrapolation error in time_table" in failure(1.05, 0.0)


@pytest.mark.slow
@needs_msl
def test_splines_are_rejected_with_file_and_line(package):
    with pytest.raises(UnsupportedConstructError, match="smoothness = ContinuousDerivative in spline") as err:
        lower(package, "T.Spline", modelica_path=[MSL])
    assert err.value.file.endswith("T.mo")
    lines = textwrap.dedent(TABLES).strip("\n").splitlines()  # the package's first line is "package T"
    assert err.value.line == 2 + next(i for i, line in enumerate(lines) if "Smoothness.ContinuousDerivative" in line)


@pytest.mark.slow
@needs_msl
def test_a_table_on_file_is_refused(package):
    """rumoca 0.10.2 refuses the MSL block with tableOnFile = true (its isCsvExt calls Strings.findLast)."""
    with pytest.raises(ModelicaError, match="findLast"):
        lower(package, "T.OnFile", modelica_path=[MSL])


MSL_EXAMPLES = [
    "Modelica.Blocks.Examples.LogicalNetwork1",
    "Modelica.Blocks.Examples.ShowLogicalSources",
    "Modelica.Electrical.Analog.Examples.CharacteristicThyristors",
    "Modelica.Mechanics.Translational.Examples.Vehicle",
]


@pytest.mark.slow
@needs_msl
@pytest.mark.parametrize("model", MSL_EXAMPLES)
def test_msl_examples_with_tables_match_the_reference(model, tmp_path):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from msl_verify import verify

    row = verify(model, MSL, REFS, workdir=tmp_path)
    assert row.stage == "verified", f"{row.stage}: {row.cause}"


@pytest.mark.slow
@needs_msl
def test_2d_tables_and_the_time_table_block_are_refused(package):
    """rumoca 0.10.2 refuses the 2D table object; Blocks.Sources.TimeTable is no table object but a Modelica
    function indexing the table with a run-time Integer (table[next, 1] in a bounded loop): rejected where."""
    with pytest.raises(ModelicaError, match="ExternalCombiTable2D"):
        lower(package, "T.TwoD", modelica_path=[MSL])
    with pytest.raises(UnsupportedConstructError, match="subscript") as err:
        lower(package, "T.Interpolated", modelica_path=[MSL])
    assert err.value.file.endswith("Sources.mo") and err.value.line is not None


def test_an_external_function_other_than_the_tables_is_rejected_with_file_and_line(tmp_path):
    path = write_package(tmp_path, """
  function f
    input Real x;
    output Real y;
  external "C" y = my_c_function(x);
  end f;

  model M
    output Real y;
  equation
    y = f(time);
  end M;""")
    with pytest.raises(UnsupportedConstructError, match="the external function f is not supported") as err:
        lower(path, "T.M")
    assert (Path(err.value.file).name, err.value.line) == ("T.mo", 11)


# The MSL's own C implementation as the reference: ModelicaStandardTables.c compiled with stubs for the
# ModelicaUtilities callbacks and without file reading (NO_FILE_SYSTEM), called through ctypes as a simulator would.
C_STUBS = r"""
#include <stdarg.h>
#include <stdlib.h>
void ModelicaMessage(const char *s) { }
void ModelicaFormatMessage(const char *s, ...) { }
void ModelicaVFormatMessage(const char *s, va_list a) { }
void ModelicaWarning(const char *s) { }
void ModelicaFormatWarning(const char *s, ...) { }
void ModelicaVFormatWarning(const char *s, va_list a) { }
void ModelicaError(const char *s) { }
void ModelicaFormatError(const char *s, ...) { }
void ModelicaVFormatError(const char *s, va_list a) { }
char* ModelicaAllocateString(size_t n) { return calloc(n + 1, 1); }
char* ModelicaAllocateStringWithErrorReturn(size_t n) { return calloc(n + 1, 1); }
char* ModelicaDuplicateString(const char* s) { return NULL; }
char* ModelicaDuplicateStringWithErrorReturn(const char* s) { return NULL; }
int usertab(char* name, int nipo, int dim[], int* colWise, double** table) { return 1; }
"""


@pytest.fixture(scope="module")
def c_tables(tmp_path_factory):
    import ctypes
    import shutil
    import subprocess

    sources = MSL / "Modelica" / "Resources" / "C-Sources"
    if shutil.which("gcc") is None or not (sources / "ModelicaStandardTables.c").is_file():
        pytest.skip("needs gcc and the MSL's C sources")
    folder = tmp_path_factory.mktemp("c_tables")
    (folder / "stubs.c").write_text(C_STUBS)
    library = folder / "libtables.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-DNO_FILE_SYSTEM", f"-I{sources}", str(folder / "stubs.c"),
                    str(sources / "ModelicaStandardTables.c"), "-o", str(library)], check=True)
    lib = ctypes.CDLL(str(library))
    D, I, P, S = ctypes.c_double, ctypes.c_int, ctypes.c_void_p, ctypes.c_size_t
    lib.ModelicaStandardTables_CombiTimeTable_init3.restype = P
    lib.ModelicaStandardTables_CombiTimeTable_init3.argtypes = [
        ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(D), S, S, D, ctypes.POINTER(I), S, I, I, D, I, I,
        ctypes.c_char_p, I]
    lib.ModelicaStandardTables_CombiTimeTable_getValue.restype = D
    lib.ModelicaStandardTables_CombiTimeTable_getValue.argtypes = [P, I, D, D, D]
    lib.ModelicaStandardTables_CombiTimeTable_nextTimeEvent.restype = D
    lib.ModelicaStandardTables_CombiTimeTable_nextTimeEvent.argtypes = [P, D]
    lib.ModelicaStandardTables_CombiTable1D_init3.restype = P
    lib.ModelicaStandardTables_CombiTable1D_init3.argtypes = [
        ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(D), S, S, ctypes.POINTER(I), S, I, I, I, ctypes.c_char_p, I]
    lib.ModelicaStandardTables_CombiTable1D_getValue.restype = D
    lib.ModelicaStandardTables_CombiTable1D_getValue.argtypes = [P, I, D]
    keep = []  # the tables' arrays, alive while the C objects point at them

    def init(kind, rows, *options):
        flat = np.ascontiguousarray(rows, dtype=float).ravel()
        columns = (I * 2)(2, 3)
        keep.append((flat, columns))
        data = flat.ctypes.data_as(ctypes.POINTER(D))
        if kind == "time":
            start, smoothness, extrapolation, shift, events = options
            return lib.ModelicaStandardTables_CombiTimeTable_init3(b"NoName", b"NoName", data, len(rows), 3, start,
                                                                   columns, 2, smoothness, extrapolation, shift,
                                                                   events, 0, b",", 0)
        smoothness, extrapolation = options
        return lib.ModelicaStandardTables_CombiTable1D_init3(b"NoName", b"NoName", data, len(rows), 3, columns, 2,
                                                             smoothness, extrapolation, 0, b",", 0)

    lib.init = init
    return lib


def simulate_time_table(next_event, value, t_grid):
    """A simulator's calls: the next event at the start, at each event instant reached the next one (the event
    handled before the value at that instant is read), the values with the held next event."""
    held, events, values = next_event(t_grid[0]), [], []
    for t in t_grid:
        while t >= held and held < 1e300:
            events.append(held)
            held = next_event(held)
        values.append(value(t, held))
    return np.array(events), np.array(values)


def random_table(rng, strictly_increasing=False):
    n = int(rng.integers(1, 7))
    if strictly_increasing:
        times = np.cumsum(rng.choice([0.25, 0.5, 1.0], size=n)) - 1.0
    else:  # repeated times: jumps, also at the first and the last time
        times = np.sort(rng.choice([-0.5, 0.0, 0.5, 0.75, 1.0, 1.5, 2.0], size=n))
    return np.column_stack([times, rng.integers(-3, 4, size=(n, 2)).astype(float)])


@needs_msl
@pytest.mark.parametrize("at_events", [False, True])
def test_time_table_expressions_agree_with_the_msl_c_code_on_random_tables(c_tables, at_events):
    """Random tables (repeated times, one row, any smoothness, extrapolation and timeEvents, start and shift):
    the same event instants, and the same values on a grid away from them (1e-9) or at them after the event is
    handled (with a shift exactly representable: an inexact one rounds t - shift below a first time in the C code
    where the expressions, deciding by the held next event, take the value after the event)."""
    import casadi as ca

    from cosim.compile import tables

    rng = np.random.default_rng(40)
    tau, held = ca.SX.sym("tau"), ca.SX.sym("held")
    checked = 0
    while checked < 150:
        rows = random_table(rng)
        smoothness, extrapolation = int(rng.choice([1, 3])), int(rng.choice([1, 2, 3]))
        events = int(rng.choice([1, 2, 3])) if smoothness == 1 else 1  # the block passes Always for constants
        if extrapolation == 3 and not rows[-1, 0] > rows[0, 0]:
            continue
        start = float(rng.choice([-1e60, 0.0, 0.3, 1.1, -0.7]))
        shift = float(rng.choice([0.0, 0.25, -0.375, 1.0] if at_events else [0.0, 0.2, -0.35, 1.0]))
        table_id = c_tables.init("time", rows, start, smoothness, extrapolation, shift, events)
        c_next = lambda t: c_tables.ModelicaStandardTables_CombiTimeTable_nextTimeEvent(table_id, t)  # noqa: E731
        c_value = lambda t, h: [c_tables.ModelicaStandardTables_CombiTimeTable_getValue(table_id, k, t, h, h)  # noqa: E731
                                for k in (1, 2)]
        table = tables.TableData("t", rows, [2, 3], smoothness, extrapolation, "", events, ca.SX(start), ca.SX(shift))
        next_f = ca.Function("next", [tau], [tables.next_time_event(table, tau)])
        value_f = ca.Function("value", [tau, held], [ca.vertcat(*[tables.time_table_value(table, k, tau, held)
                                                                  for k in (1, 2)])])
        grid = np.round(np.arange(-1.0, 6.0, 0.05), 10)
        c_events, _ = simulate_time_table(c_next, c_value, grid)
        if at_events:
            grid = c_events[(c_events >= -1) & (c_events <= 6)] if c_events.size else grid
        c_events, c_values = simulate_time_table(c_next, c_value, grid)
        events_found, values = simulate_time_table(lambda t: float(next_f(t)),
                                                   lambda t, h: np.array(value_f(t, h)).ravel(), grid)
        np.testing.assert_allclose(events_found, c_events, atol=1e-12)
        ok = grid == grid if at_events else away(grid, np.append(c_events, 1e300), 1e-9)
        np.testing.assert_allclose(values[ok], c_values[ok], atol=1e-9, err_msg=f"{rows}, {smoothness}, "
                                   f"{extrapolation}, {events}, {start}, {shift}")
        checked += 1


@needs_msl
def test_1d_table_expressions_agree_with_the_msl_c_code_on_random_tables(c_tables):
    import casadi as ca

    from cosim.compile import tables

    rng = np.random.default_rng(41)
    u = ca.SX.sym("u")
    grid = np.arange(-4, 6, 0.0625)  # through every abscissa: the values at the breakpoints too
    for _ in range(150):
        rows = random_table(rng, strictly_increasing=True)
        smoothness, extrapolation = int(rng.choice([1, 3])), int(rng.choice([1, 2, 3]))
        if extrapolation == 3 and len(rows) < 2:
            continue
        table_id = c_tables.init("1d", rows, smoothness, extrapolation)
        expected = [[c_tables.ModelicaStandardTables_CombiTable1D_getValue(table_id, k, x) for k in (1, 2)]
                    for x in grid]
        table = tables.TableData("t", rows, [2, 3], smoothness, extrapolation, "")
        f = ca.Function("f", [u], [ca.vertcat(*[tables.table_1d_value(table, k, u) for k in (1, 2)])])
        np.testing.assert_allclose(np.array(f(ca.DM(grid).T)).T, expected, atol=1e-12)
