"""Integer, Boolean, Float32 and Int64 variables in the master: routed between FMUs and from controllers by the
type rules of docs/master.md, recorded in their own dtype (results.parquet and read_results keep it), and the
config errors (a real driving an Integer input, reserved column names, empty signal lists) found at load."""

import re
import zipfile

import numpy as np
import pyarrow.parquet as pq
import pytest

from cosim.cli import main
from cosim.config import load_config
from cosim.errors import ConfigError
from cosim.master import read_results, run, run_config

F32 = np.float32


def _write(tmp_path, text, name="types.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _two_feedthroughs(fmu, connections, extra=""):
    return f"""
[run]
stop = 0.5
engine = "python"

[fmus.a]
path = "{fmu}"
start = {{ u_f64 = 1.25, u_f32 = 0.1, u_i32 = 41, u_i64 = 7, u_b = false }}

[fmus.b]
path = "{fmu}"
{extra}
{connections}
[record]
rate = 10
signals = ["a.y_f32", "a.y_i32", "a.y_i64", "a.y_b", "b.y_f64", "b.y_f32", "b.y_i32", "b.y_i64", "b.y_b", "b.x"]
"""


GOOD = """
[[connections]]
from = "a.y_i32"
to = "b.u_i32"
[[connections]]
from = "a.y_b"
to = "b.u_b"
[[connections]]
from = "a.y_b"
to = "b.u_f64"
[[connections]]
from = "a.y_f32"
to = "b.u_f32"
[[connections]]
from = "a.y_i64"
to = "b.u_i64"
gain = 2
"""


def test_typed_variables_route_and_keep_their_dtype(tmp_path, third_party_fmu):
    cfg = _write(tmp_path, _two_feedthroughs(third_party_fmu("Feedthrough", 3), GOOD))
    result, _, _ = run_config(cfg, out=tmp_path / "out", csv=True, progress=False)
    d = result.data
    # a: y_f32 = 2 u_f32 in Float32, y_i32 = u_i32 + 1, y_i64 = 3 u_i64, y_b = not u_b (hand-computed)
    y_f32 = F32(2) * F32(0.1)
    assert d["a.y_f32"].dtype == np.float32 and (d["a.y_f32"] == y_f32).all()
    assert d["a.y_i32"].dtype == np.int32 and (d["a.y_i32"] == 42).all()
    assert d["a.y_i64"].dtype == np.int64 and (d["a.y_i64"] == 21).all()
    assert d["a.y_b"].dtype == np.bool_ and d["a.y_b"].all()
    # b, fed by a: u_i32 = 42, u_b = true, u_f64 = 1 (a Boolean true as 1.0), u_f32 = y_f32, u_i64 = 2 * 21
    assert (d["b.y_i32"] == 43).all() and not d["b.y_b"].any()
    assert (d["y_f64"] == 2.0).all() and (d["b.y_f32"] == F32(2) * y_f32).all()
    assert (d["b.y_i64"] == 126).all()
    np.testing.assert_allclose(d["x"], d["time"], atol=1e-12)  # b.x integrates u_f64 = 1
    schema = pq.read_schema(tmp_path / "out" / "results.parquet")
    assert [str(schema.field(n).type) for n in ("a.y_f32", "a.y_i32", "a.y_i64", "a.y_b", "x")] == \
        ["float", "int32", "int64", "bool", "double"]
    back, _, _ = read_results(tmp_path / "out" / "results.parquet")
    assert back.dtype == d.dtype and all((back[n] == d[n]).all() for n in d.dtype.names)
    header, first = (tmp_path / "out" / "results.csv").read_text().splitlines()[:2]
    row = dict(zip([h.split(" [")[0] for h in header.split(",")], first.split(",")))
    assert row["b.y_i32"] == "43" and row["a.y_b"] == "1" and row["b.y_b"] == "0"


def _replay(tmp_path, *inputs):
    """A Playback controller at 10 Hz (u = 2.6 from 0 s, -0.4 from 0.2 s) driving ``inputs`` with ``round``."""
    (tmp_path / "u.csv").write_text("time,u\n0,2.6\n0.2,-0.4\n")
    text = '[controllers.replay]\nclass = "cosim_controllers.playback:Playback"\nrate = 10\n'
    text += 'parameters = { file = "u.csv", column = "u" }\n'
    return "\n" + text + "".join(f'[[connections]]\nfrom = "replay.y"\nto = "{i}"\nround = true\n' for i in inputs)


def _same_rows(path, overrides=()):
    """Run ``path`` with both engines: the compiled one must run (no fallback) and give the Python engine's rows,
    dtypes and events to the last bit."""
    runs = {e: run(load_config(path, [*overrides, f"run.engine={e}"]), progress=False) for e in ("compiled", "python")}
    comp, py = runs["compiled"], runs["python"]
    assert comp.engine == "compiled" and comp.engine_note == "", comp.engine_note
    assert comp.data.dtype == py.data.dtype
    for name in py.data.dtype.names:
        np.testing.assert_array_equal(comp.data[name], py.data[name], err_msg=name)
    assert comp.events == py.events and comp.stopped == py.stopped
    return comp


@pytest.mark.parametrize("kind", ["ME", "CS"])
def test_compiled_engine_carries_typed_ports(tmp_path, third_party_fmu, kind):
    """Float32, Int32, Int64 and Boolean ports routed between FMUs, driven by a controller (``round``) and
    recorded: the compiled engine runs them, with the Python engine's values (checked by hand in the test above)."""
    replay = _replay(tmp_path, "a.u_i64", "a.u_b")
    text = _two_feedthroughs(third_party_fmu("Feedthrough", 3), GOOD + replay).replace('engine = "python"', "")
    path = _write(tmp_path, text.replace("[fmus.b]", f'[fmus.b]\nkind = "{kind}"'))
    d = _same_rows(path).data
    early, late = (d["time"] > 0) & (d["time"] < 0.2 + 1e-9), d["time"] > 0.2 + 1e-9  # u = 2.6, then -0.4
    assert (d["a.y_i64"][early] == 9).all() and (d["a.y_i64"][late] == 0).all()  # y_i64 = 3 rint(u)
    assert d["a.y_b"][0] and not d["a.y_b"][early].any() and d["a.y_b"][late].all()  # y_b = not (rint(u) != 0)


@pytest.mark.parametrize("version", [2, 3])
def test_compiled_engine_records_integer_and_boolean_outputs_of_an_evented_fmu(tmp_path, third_party_fmu, version):
    """The bouncing ball's Integer ``bounces`` and Boolean ``flying`` (FMI 2.0 fmi2GetInteger/Boolean, FMI 3.0
    fmi3GetInt32/Boolean) recorded through its impacts until it rests."""
    path = _write(tmp_path, f"""[run]
stop = 3.0

[fmus.ball]
path = "{third_party_fmu("BouncingBall", version)}"

[record]
rate = 100
signals = ["ball.h", "ball.bounces", "ball.flying"]
""")
    d = _same_rows(path).data
    assert d["bounces"].dtype == np.int32 and d["flying"].dtype == np.bool_
    assert d["bounces"][0] == 0 and d["bounces"][-1] > 3 and (np.diff(d["bounces"]) >= 0).all()


def test_controller_output_into_integer_and_boolean_inputs_needs_round(tmp_path, third_party_fmu):
    conns = _replay(tmp_path, "b.u_i32", "b.u_b")
    result = run(load_config(_write(tmp_path, _two_feedthroughs(third_party_fmu("Feedthrough", 3), conns))))
    d = result.data
    # 2.6 -> 3 (nearest), true (3 != 0); -0.4 -> 0, false; y_i32 = u_i32 + 1, y_b = not u_b. A row samples the
    # FMUs before the controllers step: the row at 0 has the start values (0, false), the rows up to 0.2 s the 2.6
    assert d["time"][0] == 0 and d["b.y_i32"][0] == 1 and d["b.y_b"][0]
    early = (d["time"] > 0) & (d["time"] < 0.2 + 1e-9)
    assert early.sum() == 2 and (d["b.y_i32"][early] == 4).all() and not d["b.y_b"][early].any()
    late = d["time"] > 0.2 + 1e-9
    assert late.sum() == 3 and (d["b.y_i32"][late] == 1).all() and d["b.y_b"][late].all()
    with pytest.raises(ConfigError, match=r"types.toml:\d+: connections\[0\]\.to: replay.y \(Float64 \(a controller "
                                          r"signal\)\) -> b.u_i32 \(Int32\): a real value does not drive"):
        load_config(_write(tmp_path, _two_feedthroughs(third_party_fmu("Feedthrough", 3),
                                                       conns.replace("round = true", ""))))


@pytest.mark.parametrize("connection, message", [
    ('from = "a.y_f64"\nto = "b.u_i32"', r"connections\[0\]\.to: a.y_f64 \(Float64\) -> b.u_i32 \(Int32\): a real value"),
    ('from = "a.y_f32"\nto = "b.u_b"', r"connections\[0\]\.to: a.y_f32 \(Float32\) -> b.u_b \(Boolean\): a real value"),
    ('from = "a.y_i32"\nto = "b.u_b"', r"connections\[0\]\.to: .* an Integer does not drive a Boolean input"),
    ('from = "a.y_i32"\nto = "b.u_i64"\ngain = 1.5', r"connections\[0\]: .* needs an integer gain and offset; got gain=1.5"),
    ('from = "a.y_b"\nto = "b.u_b"\noffset = 1', r"connections\[0\]: .* with gain 1 and offset 0 only"),
])
def test_type_mismatches_are_config_errors_at_load(tmp_path, third_party_fmu, connection, message):
    text = _two_feedthroughs(third_party_fmu("Feedthrough", 3), f"[[connections]]\n{connection}\n")
    lines = text.splitlines()
    key = "to = " if ".to:" in message else "[[connections]]"
    line = next(i for i, t in enumerate(lines, 1) if t.startswith(key))
    with pytest.raises(ConfigError, match=rf"types.toml:{line}: " + message):
        load_config(_write(tmp_path, text))


def test_reserved_column_and_empty_signal_list_are_config_errors(tmp_path, third_party_fmu):
    base = f"""[run]
stop = 1.0

[fmus.ball]
path = "{third_party_fmu("BouncingBall", 3)}"

[record]
rate = 10
"""
    with pytest.raises(ConfigError, match=r"types.toml:9: record.signals\[1\]: ball.time: the column 'time' is "
                                          r"reserved"):
        load_config(_write(tmp_path, base + 'signals = ["ball.h", "ball.time"]\n'))
    with pytest.raises(ConfigError, match=r"types.toml:9: record.signals: is empty"):
        load_config(_write(tmp_path, base + "signals = []\n"))


def test_parameter_and_start_values_must_fit_their_type(tmp_path, third_party_fmu):
    text = f"""[run]
stop = 1.0

[fmus.ft]
path = "{third_party_fmu("Feedthrough", 3)}"
start = {{ u_i32 = 1.5, u_b = 1, u_f32 = true }}

[record]
signals = ["ft.x"]
"""
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, text))
    problems = "\n".join(err.value.problems)
    assert "types.toml:6: fmus.ft.start.u_i32: 'u_i32' is Int32: the value must be an integer; got 1.5" in problems
    assert "fmus.ft.start.u_b: 'u_b' is Boolean: the value must be true or false; got 1" in problems
    assert "fmus.ft.start.u_f32: 'u_f32' is Float32: the value must be a number; got True" in problems
    ok = text.replace("u_i32 = 1.5, u_b = 1, u_f32 = true", "u_i32 = 2, u_b = true, u_f32 = 0.5")
    assert load_config(_write(tmp_path, ok)).fmus["ft"].start == {"u_i32": 2, "u_b": True, "u_f32": 0.5}


def _out_of_step(fmu, variable, vr, folder):
    """A copy of ``fmu`` whose modelDescription.xml gives ``variable`` a value reference its binary does not know,
    as a third party's FMU whose description was regenerated without its binary: the FMU's own Get or Set of that
    variable's type answers Error."""
    out = folder / f"{fmu.stem}_{variable}.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                xml = data.decode()
                old = re.search(rf'name="{variable}" valueReference="(\d+)"', xml).group(1)
                data = re.sub(rf'(valueReference|dependencies)="{old}"', rf'\1="{vr}"', xml).encode()
            dst.writestr(item, data)
    return out


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("version,model,variable,call", [
    (3, "Feedthrough", "y_i32", "fmi3GetInt32"),  # a recorded Int32 output
    (3, "Feedthrough", "u_b", "fmi3SetBoolean"),  # a Boolean input fed by another FMU
    (2, "BouncingBall", "bounces", "fmi2GetInteger"),  # a recorded Integer output
])
def test_an_fmi_error_on_a_typed_port_names_the_call_made(tmp_path, third_party_fmu, capsys, engine, version,
                                                          model, variable, call):
    # before: the compiled engine said GetReal or SetReal whatever the port's type
    fmu = _out_of_step(third_party_fmu(model, version), variable, 97, tmp_path)
    if model == "Feedthrough":
        text = f"""
[fmus.a]
path = "{fmu}"
[fmus.b]
path = "{third_party_fmu(model, version)}"
[[connections]]
from = "b.y_b"
to = "a.u_b"
[record]
signals = ["a.y_i32", "a.x"]
"""
    else:
        text = f'[fmus.a]\npath = "{fmu}"\n[record]\nsignals = ["a.h", "a.bounces"]\n'
    path = _write(tmp_path, f'[run]\nstop = 0.1\nengine = "{engine}"\n' + text)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 3
    err = capsys.readouterr().err
    assert f"a raised FmiCallError: {call} returned Error" in err, err
    assert ("(in the instant after t=" in err) == (engine == "compiled")  # the message of the engine that ran
