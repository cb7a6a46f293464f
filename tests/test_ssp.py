"""SSP in and out (cosim/ssp): an SSP that ``cosim export-ssp`` writes runs in libcosim to the numbers of ``cosim run``;
an SSP written by hand after the standard's examples runs in ``cosim run`` to the numbers of FMPy stepping the same
FMUs by hand; a bad SSP is an SspError naming the element."""

import json
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from ssp_support import TWO_BODIES, fmpy_by_hand, hand_ssp, libcosim_ssp
from test_master_support import cli_fails

import cosim
from cosim.config import load_config
from cosim.errors import NonFiniteError, SspError
from cosim.master.run import run_config
from cosim.ssp.write import export_ssp, write_ssp

ROOT = Path(__file__).resolve().parent.parent


# ---- (a) cosim export-ssp -> libcosim ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def body_fmu(tmp_path_factory):
    """examples/ssp/Oscillators.mo's Body as an FMI 2.0 FMU (libcosim runs FMI 2.0 Co-Simulation only)."""
    from cosim.compile import build_fmu

    return build_fmu(ROOT / "examples" / "ssp" / "Oscillators.mo", "Oscillators.Body",
                     out_dir=tmp_path_factory.mktemp("ssp_fmus"), fmi_version=2)


@pytest.mark.slow
def test_libcosim_runs_the_exported_ssp_like_cosim_run(body_fmu, tmp_path):
    """Two coupled bodies (two instances of one FMI 2.0 FMU, their parameters in SSVs) exported, then run by
    libcosim's SSP loader. Both masters step each FMU over the communication step h = 1 ms with its inputs held from
    the step's start (Jacobi), so they should agree to round-off; the tolerance is a thousandth of what one step
    moves a body at its fastest (1e-3 * h * max|v|, about 6e-7 m here): an exchange one step early or late, the
    difference between Gauss-Seidel and Jacobi coupling, moves the positions by about h * max|v| and fails it."""
    step, stop = 1e-3, 1.0
    config = tmp_path / "two_bodies.toml"
    config.write_text(TWO_BODIES.format(stop=stop, fmu=body_fmu, rate=1 / step))
    ours = run_config(config, out=tmp_path / "out")[0].data[1:]  # libcosim reports after each step
    ssp = export_ssp(config, tmp_path / "two_bodies.ssp")
    signals = ["a.x", "b.x", "a.v", "b.v"]
    rows = libcosim_ssp(ssp, signals, step, stop)
    assert rows.shape == (len(ours), 1 + len(signals))
    np.testing.assert_allclose(rows[:, 0], ours["time"], atol=1e-9)
    v_max = max(np.max(np.abs(ours["a.v"])), np.max(np.abs(ours["b.v"])))
    for k, name in enumerate(signals[:2], start=1):
        assert np.ptp(ours[name]) > 0.01, f"{name} does not move: the comparison would prove nothing"
        assert np.max(np.abs(rows[:, k] - ours[name])) <= 1e-3 * step * v_max, name


# ---- (b) an SSP written by hand -> cosim run, against FMPy ------------------------------------------------------

@pytest.mark.parametrize("version", ["1.0", "2.0"])
def test_hand_written_ssp_runs_like_fmpy_stepping_the_fmus(third_party_fmu, version, tmp_path):
    """SSP 1.0 (validated by FMPy's schema) and 2.0 (read unvalidated): the default experiment (2 s), the SSV
    parameter (the ball's restitution 0.5, not its FMU's 0.7), the connection and the FMUs' step (0.01 s) all reach
    the run: cosim's numbers are FMPy's to round-off."""
    ssp = hand_ssp(tmp_path, third_party_fmu, version)
    result = run_config(ssp, out=tmp_path / "out")[0]
    reference = fmpy_by_hand(third_party_fmu("BouncingBall"), third_party_fmu("Feedthrough"), 0.01, 2.0)
    assert result.data["time"][-1] == pytest.approx(2.0)
    np.testing.assert_allclose(result.data["time"], reference[:, 0], atol=1e-12)
    assert np.min(reference[:, 1]) < 0.05 and np.max(reference[-50:, 1]) < 0.3  # it bounced at e = 0.5
    np.testing.assert_allclose(result.data["h"], reference[:, 1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.data["x"], reference[:, 2], rtol=0, atol=1e-12)


def test_a_connections_linear_transformation_reaches_the_run(third_party_fmu, tmp_path):
    """``ssc:LinearTransformation`` (factor 2, offset 0.5) on the connection: FMPy's reader misses it (it looks in
    the ssd namespace; the gap cosim.ssp.read fills), the run applies it as FMPy's loop does by hand."""
    from fmpy.ssp.ssd import read_ssd

    transform = '\n        <ssc:LinearTransformation factor="2" offset="0.5"/>'
    ssp = hand_ssp(tmp_path, third_party_fmu, transform=transform)
    assert not hasattr(read_ssd(str(ssp)).system.connections[0], "linearTransformation")
    result = run_config(ssp, out=tmp_path / "out")[0]
    reference = fmpy_by_hand(third_party_fmu("BouncingBall"), third_party_fmu("Feedthrough"), 0.01, 2.0, 2.0, 0.5)
    assert reference[-1, 2] > 1.0  # the offset alone integrates to 1 over 2 s
    np.testing.assert_allclose(result.data["x"], reference[:, 2], rtol=0, atol=1e-12)


def test_a_config_naming_an_ssp_runs_its_system_under_its_own_values(third_party_fmu, tmp_path):
    """``[system] ssp = ...``: the SSP's FMUs and connections, its SSV values under the config's (and --set's)."""
    ssp = hand_ssp(tmp_path, third_party_fmu)
    config = tmp_path / "ball.toml"
    config.write_text(f'[system]\nssp = "{ssp.name}"\n\n[fmus.ball.parameters]\ng = 3.0\n\n'
                      '[record]\nrate = 100\nsignals = ["integrator.x"]\n')
    loaded = load_config(config, ["fmus.ball.parameters.e=0.25"])
    assert loaded.fmus["ball"].parameters == {"e": 0.25, "g": 3.0}
    assert loaded.run.stop == 2.0
    assert [(c.src, c.dst) for c in loaded.connections] == [(("ball", "h"), ("integrator", "u_f64"))]


# ---- (c) bad SSPs ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("spoil, expected", [
    ({"ball": "resources/Ball.fmu"}, r"SystemStructure\.ssd:9: component 'ball': FMU 'resources/Ball\.fmu' is "
                                     r"neither in the archive nor beside it"),
    ({"input": "u_64"}, r"SystemStructure\.ssd:25: connection ball\.h -> integrator\.u_f64: no connector "
                        r"'integrator\.u_f64'"),
    ({"unit": ' unit="s"'}, r"SystemStructure\.ssd:25: connection ball\.h -> integrator\.u_f64: unit mismatch: h is "
                            r"in 'm', u_f64 in 's'"),
])
def test_a_bad_ssp_is_an_ssp_error_naming_the_element(third_party_fmu, tmp_path, spoil, expected):
    ssp = hand_ssp(tmp_path, third_party_fmu, **spoil)
    with pytest.raises(SspError, match=expected):
        load_config(ssp)


ATTACHED = """
[system]
ssp = "two_bodies.ssp"

[controllers.hold]
class = "hold.py:Hold"
rate = 1000
parameters = { x_set = 0.05 }

[[connections]]
from = "a.x"
to = "hold.x"

[[connections]]
from = "a.v"
to = "hold.v"

[[connections]]
from = "hold.F"
to = "a.F"

[record]
rate = 1000
signals = ["a.x", "b.x", "hold.F"]
"""


@pytest.mark.slow
def test_an_exported_ssp_with_a_controller_runs_in_cosim_like_its_config(body_fmu, tmp_path):
    """examples/ssp/held.toml: the Python controller, an external component of the SSD described by its TOML
    resource (and its file shipped beside it), runs again in ``cosim run`` of the SSP; and attached by the
    connectors' names in a config naming the SSP of the bodies alone: the same numbers both ways."""
    config = tmp_path / "held.toml"
    text = (ROOT / "examples" / "ssp" / "held.toml").read_text().replace("fmus/Body.fmu", str(body_fmu))
    config.write_text(text)
    (tmp_path / "hold.py").write_text((ROOT / "examples" / "ssp" / "hold.py").read_text())
    ours = run_config(config, out=tmp_path / "out")[0].data
    ssp = export_ssp(config, tmp_path / "held.ssp")
    again = run_config(ssp, out=tmp_path / "again")[0].data
    assert abs(ours["a.x"][-1] - 0.05) < 0.03  # held near x_set against the coupling spring
    for name in ("a.x", "b.x", "hold.F"):
        np.testing.assert_array_equal(again[name], ours[name], err_msg=name)
    # the same controller attached by the connectors' names to the SSP of the two bodies alone, in a config naming it
    plain = tmp_path / "two_bodies.toml"
    plain.write_text(TWO_BODIES.format(stop=2.0, fmu=body_fmu, rate=1000))
    export_ssp(plain, tmp_path / "two_bodies.ssp")
    attached = tmp_path / "attached.toml"
    attached.write_text(ATTACHED)
    assert len(load_config(attached).connections) == 5  # the SSP's two, then the config's three
    third = run_config(attached, out=tmp_path / "attached")[0].data
    for name in ("a.x", "b.x", "hold.F"):
        np.testing.assert_array_equal(third[name], ours[name], err_msg=name)


# ---- (d) what a run and an export leave on disk ----------------------------------------------------------------

BALL = """
[run]
stop = 1.0

[fmus.ball]
path = "{fmu}"
kind = "CS"
parameters = {{ e = 0.5 }}

[record]
rate = 100
signals = ["ball.h"]
"""


def test_export_ssp_replaces_an_existing_file_only_with_force(third_party_fmu, tmp_path, capsys):
    """``cosim export-ssp --out`` follows ``cosim simulate --out``: an existing file is refused (named) and left as
    it was; with ``--force`` it is replaced by the archive, and no staging file or lock is left beside it."""
    from cosim.cli import main
    from fmpy.ssp.ssd import read_ssd

    config = tmp_path / "ball.toml"
    config.write_text(BALL.format(fmu=third_party_fmu("BouncingBall")))
    out = tmp_path / "out" / "ball.ssp"
    out.parent.mkdir()
    out.write_text("a user's file\n")
    err = cli_fails(capsys, ["export-ssp", str(config), "--out", str(out)])
    assert f"--out {out}: the file exists; pass --force to replace it" in err
    assert out.read_text() == "a user's file\n"
    assert main(["export-ssp", str(config), "--out", str(out), "--force"]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    assert [c.name for c in read_ssd(str(out)).system.elements] == ["ball"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["ball.ssp"]
    (tmp_path / "dir.ssp").mkdir()
    assert "dir.ssp: is a folder" in cli_fails(capsys, ["export-ssp", str(config), "--out", str(tmp_path / "dir.ssp"),
                                                        "--force"])


def test_an_export_that_fails_half_way_leaves_the_file_as_it_was(third_party_fmu, tmp_path):
    """The FMU gone between the config's load and the export: the copy into the archive fails, with ``force`` the
    existing archive is still the old one, and nothing half written is left beside it."""
    fmu = tmp_path / "BouncingBall.fmu"
    fmu.write_bytes(third_party_fmu("BouncingBall").read_bytes())
    config_path = tmp_path / "ball.toml"
    config_path.write_text(BALL.format(fmu=fmu))
    config = load_config(config_path)
    out = tmp_path / "out" / "ball.ssp"
    write_ssp(config, out)
    before = out.read_bytes()
    fmu.unlink()
    with pytest.raises(FileNotFoundError):
        write_ssp(config, out, force=True)
    assert out.read_bytes() == before
    assert sorted(p.name for p in out.parent.iterdir()) == ["ball.ssp"]


@pytest.mark.slow
def test_a_run_of_an_ssp_leaves_no_unpacked_folder(body_fmu, tmp_path, monkeypatch):
    """examples/ssp/held.toml exported, then run from Python: the archive's unpacked folder (and each FMU
    instance's) is removed when the run ends, whether it ran, stopped on a fault inside the loop (a gain of 1e308
    makes the force infinite at the first step) or failed at its load; the result holds no path into it but its
    config's (the config is the archive's: ``config.path``)."""
    config = tmp_path / "held.toml"
    config.write_text((ROOT / "examples" / "ssp" / "held.toml").read_text().replace("fmus/Body.fmu", str(body_fmu)))
    (tmp_path / "hold.py").write_text((ROOT / "examples" / "ssp" / "hold.py").read_text())
    ssp = export_ssp(config, tmp_path / "held.ssp")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    result = cosim.run(ssp)
    assert abs(result.data["a.x"][-1] - 0.05) < 0.03  # it ran: held near x_set
    assert list(scratch.iterdir()) == []
    assert result.config.path == ssp and result.out is None and result.files == []
    assert str(scratch) not in json.dumps(result.summary, default=str)
    with pytest.raises(NonFiniteError, match="hold.F = inf"):
        cosim.run(ssp, set={"controllers.hold.parameters.Kp": 1e308})
    assert list(scratch.iterdir()) == []
    with pytest.raises(cosim.CosimError, match="run.stp"):
        cosim.run(ssp, set={"run.stp": 1.0})
    assert list(scratch.iterdir()) == []
    with zipfile.ZipFile(ssp) as zf:  # the archive itself is the user's and stays
        assert "resources/hold.py" in zf.namelist()


@pytest.mark.slow
def test_a_second_run_of_an_ssp_with_a_controller_compiles_nothing_again(body_fmu, tmp_path):
    """The controller file of an archive is unpacked into a new temporary folder each run; numba keys its cache on
    the file's path, so each run compiled the controller's kernels anew (seconds). Two ``cosim run`` processes of
    the same archive, in a user cache folder of their own: the second adds no file to numba's cache."""
    import os
    import subprocess
    import sys

    config = tmp_path / "held.toml"
    config.write_text((ROOT / "examples" / "ssp" / "held.toml").read_text().replace("fmus/Body.fmu", str(body_fmu)))
    (tmp_path / "hold.py").write_text((ROOT / "examples" / "ssp" / "hold.py").read_text())
    ssp = export_ssp(config, tmp_path / "held.ssp")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"} | {"XDG_CACHE_HOME": str(tmp_path / "c")}

    def cached_files_after_a_run(n):
        subprocess.run([sys.executable, "-m", "cosim", "run", str(ssp), "--out", str(tmp_path / f"out{n}"),
                        "--no-progress"], check=True, env=env, capture_output=True)
        return sorted(p for p in (tmp_path / "c" / "cosim").rglob("*") if p.is_file())

    first = cached_files_after_a_run(1)
    assert any(p.suffix == ".nbi" and "hold" in p.name for p in first)  # the controller's kernels were cached
    assert cached_files_after_a_run(2) == first
