"""Issue 31 items 2, 3, 4, 6: no user file lost to --out, what was recorded kept through faults, NaN and Inf
stopping the run with a name and a time, the Dask cluster on loopback only.

References are independent of the code under test: a hand-written RK4 of the oscillator's equations (where a
state overflows), the times a controller was written to fail at, the operating system's view of the sockets.
"""

import contextlib
import json
import os
import socket
import subprocess
import tempfile
import textwrap
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_master_support import master_dir, osc_config  # noqa: F401

from cosim.cli import main
from cosim.errors import ConfigError, ScaleWarning
from cosim.master import read_results
from cosim.outputs import MARKER, output_folder

ROOT = Path(__file__).resolve().parent.parent

FAULTY_PY = textwrap.dedent('''
    import os
    import signal

    from cosim.controller import Controller

    def _hold(t, u, y, x, p):
        y[0] = u[0]

    class Boom(Controller):
        """Passes its input through; raises at fail_at, or sends its own process SIGTERM at term_at."""
        parameters = {"fail_at": -1.0, "term_at": -1.0}
        inputs = ("u",)
        outputs = ("y",)
        kernel = staticmethod(_hold)

        def step(self, t):
            if 0.0 <= self.values["term_at"] <= t:
                os.kill(os.getpid(), signal.SIGTERM)
            if 0.0 <= self.values["fail_at"] <= t:
                raise RuntimeError("sensor cable cut")
            super().step(t)

    def _step(t, u, y, x, p):
        y[0] = p[0] if t >= p[1] else 0.0

    class Step(Controller):
        """Source: value after t_step (compiles with numba)."""
        parameters = {"value": 1.0, "t_step": 0.0}
        outputs = ("y",)
        kernel = staticmethod(_step)
    ''')


def _boom_config(master_dir, folder, **parameters):  # noqa: F811
    """The oscillator config with the Boom controller between the source and the plant's input."""
    (folder / "boom.py").write_text(FAULTY_PY)
    cfg = osc_config(master_dir, stop=2.0)
    text = cfg.read_text().replace('to = "plant.u"', 'to = "boom.u"').replace("Osc.fmu", str(master_dir / "Osc.fmu"))
    text = text.replace('"ctl.py:', f'"{master_dir / "ctl.py"}:')
    values = ", ".join(f"{k} = {v}" for k, v in parameters.items())
    text += textwrap.dedent(f"""
        [controllers.boom]
        class = "{folder / 'boom.py'}:Boom"
        rate = 100
        jit = false
        parameters = {{ {values} }}

        [[connections]]
        from = "boom.y"
        to = "plant.u"
        """)
    path = folder / "boom.toml"
    path.write_text(text)
    return path


def _users_folder(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("my notes")
    return folder


def _kept(folder):
    return sorted(os.listdir(folder)) == ["notes.txt"] and (folder / "notes.txt").read_text() == "my notes"


# -- item 2: --out never costs a user a file ----------------------------------------------------------------------

def test_run_into_a_users_folder_is_refused_and_a_previous_output_needs_force(master_dir,  # noqa: F811
                                                                             tmp_path, capsys):
    cfg = osc_config(master_dir, stop=0.2)
    mine = _users_folder(tmp_path)
    for extra in ([], ["--force"]):
        assert main(["run", str(cfg), "--out", str(mine), "--no-progress", *extra]) == 2
        assert "not a cosim output" in capsys.readouterr().err
        assert _kept(mine)
    out = tmp_path / "res"
    assert main(["run", str(cfg), "--out", str(out), "--no-progress"]) == 0
    assert (out / MARKER).is_file() and (out / "results.parquet").is_file()
    assert main(["run", str(cfg), "--out", str(out), "--no-progress"]) == 2
    assert "pass --force" in capsys.readouterr().err
    (out / "results.csv").write_text("stale")  # a file of the previous output: --force replaces the whole folder
    assert main(["run", str(cfg), "--out", str(out), "--no-progress", "--force"]) == 0
    assert not (out / "results.csv").exists() and (out / "summary.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "res"]  # no staging folder or lock left


def test_read_only_out_fails_before_the_run(master_dir, tmp_path, capsys):  # noqa: F811
    # a run of 10^5 s would take minutes: an answer within seconds shows the check came first
    cfg = osc_config(master_dir, stop=1e5)
    locked = tmp_path / "locked"
    locked.mkdir()
    with _read_only(locked):
        t0 = time.perf_counter()
        with pytest.warns(ScaleWarning, match="run.stop = 100000 s"):  # a long run is meant here
            assert main(["run", str(cfg), "--out", str(locked / "res"), "--no-progress"]) == 2
        elapsed = time.perf_counter() - t0
    assert "not writable" in capsys.readouterr().err
    assert elapsed < 20 and os.listdir(locked) == []


@contextlib.contextmanager
def _read_only(folder):
    """``folder`` read-only: by its mode for a user; for root, whom modes do not stop, immutable (chattr +i)."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            yield
        finally:
            folder.chmod(0o755)
        return
    subprocess.run(["chattr", "+i", str(folder)], check=True)
    try:
        yield
    finally:
        subprocess.run(["chattr", "-i", str(folder)], check=True)


def test_two_commands_cannot_write_one_out_at_once(master_dir, tmp_path, capsys):  # noqa: F811
    cfg = osc_config(master_dir, stop=0.2)
    out = tmp_path / "res"
    with output_folder(out, "run") as staging:  # another command writing out right now
        assert main(["run", str(cfg), "--out", str(out), "--no-progress", "--force"]) == 2
        assert "another cosim command is writing" in capsys.readouterr().err
        (staging / "a.txt").write_text("first")
    assert (out / "a.txt").read_text() == "first" and not (out / "results.parquet").exists()


def test_a_failed_command_leaves_the_previous_output_as_it_was(tmp_path):
    out = tmp_path / "res"
    with output_folder(out, "run") as staging:
        (staging / "a.txt").write_text("first")
    with pytest.raises(RuntimeError, match="the fit diverged"):
        with output_folder(out, "run", force=True) as staging:
            (staging / "a.txt").write_text("second")
            raise RuntimeError("the fit diverged")
    assert (out / "a.txt").read_text() == "first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]


def test_calibrate_keeps_a_users_folder_and_its_own_output_without_force(tmp_path, capsys):
    from test_calibrate import write_job

    job = write_job(tmp_path)
    mine = _users_folder(tmp_path)
    assert main(["calibrate", str(job), "--out", str(mine), "--no-progress"]) == 2
    assert "not a cosim output" in capsys.readouterr().err and _kept(mine)
    out = tmp_path / "fit"
    assert main(["calibrate", str(job), "--out", str(out), "--no-progress"]) == 0
    first = (out / "calibration.json").read_text()
    assert json.loads(first)["cost_after"] < json.loads(first)["cost_before"] and (out / MARKER).is_file()
    assert main(["calibrate", str(job), "--out", str(out), "--no-progress"]) == 2  # refused before the fit
    assert "pass --force" in capsys.readouterr().err and (out / "calibration.json").read_text() == first


@pytest.mark.slow
def test_diagnose_keeps_a_users_folder_and_writes_a_new_one(tmp_path, capsys):
    from diagnose_truth import make_case, write_job

    t, i, y, _ = make_case("none", np.random.default_rng(5), noise=0.3, levels=(0.0, 0.5, 1.0, 0.5, 0.0))
    job = write_job(tmp_path, pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), ())
    mine = _users_folder(tmp_path)
    sets = ["--no-progress", "--set", "experiment.duration=3.4"]
    assert main(["diagnose", str(job), "--out", str(mine), *sets]) == 2
    assert "not a cosim output" in capsys.readouterr().err and _kept(mine)
    out = tmp_path / "diag"
    assert main(["diagnose", str(job), "--out", str(out), *sets]) == 0
    assert (out / "diagnosis.json").is_file() and (out / MARKER).is_file()
    assert main(["diagnose", str(job), "--out", str(out), *sets]) == 2
    assert "pass --force" in capsys.readouterr().err and (out / "diagnosis.json").is_file()


def test_build_out_holding_other_files_is_refused_and_an_fmu_folder_is_kept(tmp_path, capsys):
    source = ROOT / "tests" / "models" / "hybrid" / "Hybrid.mo"
    mine = _users_folder(tmp_path)
    assert main(["build", str(source), "--model", "Hybrid.SampleHold", "--out", str(mine)]) == 2
    assert "not a cosim output" in capsys.readouterr().err and _kept(mine)
    assert main(["build", str(source), "--model", "Hybrid.SampleHold", "--out", str(mine / "notes.txt")]) == 2
    fmus = tmp_path / "fmus"
    fmus.mkdir()
    (fmus / "Other.fmu").write_bytes(b"an FMU built earlier")  # a folder of FMUs from before the marker
    assert main(["build", str(source), "--model", "Hybrid.SampleHold", "--out", str(fmus)]) == 0
    assert sorted(os.listdir(fmus)) == [MARKER, "Other.fmu", "SampleHold.fmu"]
    assert (fmus / "Other.fmu").read_bytes() == b"an FMU built earlier"


# -- item 3: what was recorded is kept through faults --------------------------------------------------------------

def test_a_controller_raising_mid_run_keeps_the_rows_before_and_says_why(master_dir, tmp_path, capsys):  # noqa: F811
    cfg = _boom_config(master_dir, tmp_path, fail_at=0.5)
    out = tmp_path / "res"
    assert main(["run", str(cfg), "--out", str(out), "--no-progress"]) == 3
    err = capsys.readouterr().err
    assert "boom raised RuntimeError: sensor cable cut" in err and "boom.py:" in err
    data, _, meta = read_results(out / "results.parquet")
    np.testing.assert_allclose(data["time"], np.arange(50) / 100, atol=1e-12)  # the rows before t = 0.5 s
    stopped = json.loads((out / "summary.json").read_text())["stopped"]
    assert stopped["by"] == "boom" and stopped["cause"] == "error" and stopped["time"] == pytest.approx(0.5)
    assert json.loads(meta["cosim.stopped"]) == stopped


def test_sigterm_stops_the_run_and_keeps_the_rows(master_dir, tmp_path, capsys):  # noqa: F811
    cfg = _boom_config(master_dir, tmp_path, term_at=0.3)
    out = tmp_path / "res"
    assert main(["run", str(cfg), "--out", str(out), "--no-progress"]) == 143
    assert "terminated by SIGTERM" in capsys.readouterr().err
    data, _, _ = read_results(out / "results.parquet")
    np.testing.assert_allclose(data["time"], np.arange(30) / 100, atol=1e-12)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["stopped"]["cause"] == "SIGTERM"


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_an_fmu_error_keeps_the_rows_and_leaves_no_unpacked_fmu(tmp_path, hybrid_fmu, capsys, engine):
    # Hybrid.Overheat: a Modelica assert fails when T passes its limit; the FMU returns an error status
    name = f"relout{os.getpid()}"
    cfg = tmp_path / "overheat.toml"
    cfg.write_text(f"""
[run]
stop = 2.0
engine = "{engine}"

[fmus.{name}]
path = "{hybrid_fmu("Overheat")}"

[record]
rate = 100
signals = ["{name}.T"]
""")
    assert main(["run", str(cfg), "--out", str(tmp_path / "res"), "--no-progress"]) == 3
    assert "temperature above limit" in capsys.readouterr().err
    summary = json.loads((tmp_path / "res" / "summary.json").read_text())
    assert summary["stopped"]["by"] == name and summary["stopped"]["cause"] == "error"
    # T = t reaches 0.5 at t = 0.5 s: the rows of 0 .. 0.49 s are kept (and of 0.5 s when T was still below there)
    assert 0.49 - 1e-9 <= summary["stopped"]["time"] <= 0.5 + 1e-9 and summary["rows"] in (50, 51)
    assert not [p for p in os.listdir(tempfile.gettempdir()) if p.startswith(f"cosim-{name}-")]


# -- item 4: NaN and Inf stop the run, named -----------------------------------------------------------------------

def _overflow_reference(k, h, stop):
    """A hand-written RK4 of der(x) = v, der(v) = -k x (x(0) = 1): the first step where a state is not finite,
    and which states are not finite there."""
    X = np.array([1.0, 0.0])

    def f(X):
        return np.array([X[1], -k * X[0]])

    with np.errstate(over="ignore", invalid="ignore"):
        for n in range(1, int(round(stop / h)) + 1):
            k1 = f(X)
            k2 = f(X + 0.5 * h * k1)
            k3 = f(X + 0.5 * h * k2)
            k4 = f(X + h * k3)
            X = X + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if not np.isfinite(X).all():
                return n * h, {name for name, value in zip("xv", X) if not np.isfinite(value)}
    raise AssertionError("no overflow")


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_state_overflowing_stops_the_run_naming_the_fmu_the_state_and_the_time(master_dir,  # noqa: F811
                                                                                  tmp_path, engine, capsys):
    # k = -1e6: x grows as cosh(1000 t); RK4 at 1 ms steps overflows a double near t = 0.7 s
    cfg = osc_config(master_dir, stop=1.0, amp=0.0)
    out = tmp_path / "res"
    sets = ["--set", "fmus.plant.parameters.k=-1e6", "--set", "fmus.plant.parameters.c=0", "--set",
            f"run.engine={engine}"]
    assert main(["run", str(cfg), "--out", str(out), "--no-progress", *sets]) == 3
    t_bad, bad = _overflow_reference(-1e6, 1e-3, 1.0)
    stopped = json.loads((out / "summary.json").read_text())["stopped"]
    assert stopped["cause"] == "non-finite" and stopped["by"] == "plant"
    assert stopped["time"] == pytest.approx(t_bad, abs=1e-9)
    assert any(f"plant.{name} = " in stopped["reason"] for name in bad), stopped["reason"]
    data, _, _ = read_results(out / "results.parquet")
    assert np.isfinite(data["y"]).all() and data["time"][-1] < t_bad


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_controller_output_going_infinite_is_named_at_its_instant(master_dir, tmp_path, engine):  # noqa: F811
    cfg = osc_config(master_dir, stop=1.0, amp=0.0, extra=f"""
        [controllers.kick]
        class = "{tmp_path / 'boom.py'}:Step"
        rate = 1000
        parameters = {{ value = inf, t_step = 0.25 }}
        """)
    (tmp_path / "boom.py").write_text(FAULTY_PY)
    out = tmp_path / "res"
    assert main(["run", str(cfg), "--out", str(out), "--no-progress", "--set", f"run.engine={engine}"]) == 3
    stopped = json.loads((out / "summary.json").read_text())["stopped"]
    assert stopped["by"] == "kick" and "kick.y = inf" in stopped["reason"]
    assert stopped["time"] == pytest.approx(0.25, abs=1e-12)


# -- item 6: Dask on loopback only ----------------------------------------------------------------------------------

def _listening(pid):
    import psutil

    return [c.laddr for c in psutil.Process(pid).net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]


@pytest.mark.slow
def test_the_local_dask_cluster_listens_on_loopback_only_without_a_dashboard():
    from cosim.parallel import map_on_dask, open_client

    with open_client(max_workers=2) as client:
        pids = [os.getpid(), *client.run(os.getpid).values()]
        listening = [addr for pid in pids for addr in _listening(pid)]
        assert client.scheduler.address.startswith("tcp://127.0.0.1:")
        assert all(w.startswith("tcp://127.0.0.1:") for w in client.scheduler_info()["workers"])
        assert len(listening) >= 3 and {a.ip for a in listening} == {"127.0.0.1"}, listening
        # the scheduler's HTTP server answers (its health page) but serves no dashboard
        http = f"http://127.0.0.1:{client.scheduler_info()['services']['dashboard']}"
        assert urllib.request.urlopen(f"{http}/health", timeout=5).read() == b"ok"
        with pytest.raises(urllib.error.HTTPError, match="404"):
            urllib.request.urlopen(f"{http}/status", timeout=5)
        # the cluster also serves a scheduler given by address
        assert map_on_dask(abs, [-1, 2, -3], scheduler=client.scheduler.address, progress=False) == [1, 2, 3]


def _pid(_):
    return os.getpid()


@pytest.mark.slow
def test_maps_inside_keep_local_cluster_share_one_cluster_and_it_closes_after():
    import psutil

    from cosim.parallel import keep_local_cluster, map_on_dask

    with keep_local_cluster(max_workers=2):
        first = map_on_dask(_pid, range(4), progress=False)
        second = map_on_dask(_pid, range(4), progress=False)
        with keep_local_cluster(max_workers=2):  # nested: the same cluster
            third = map_on_dask(_pid, range(4), progress=False)
        workers = set(first) | set(second) | set(third)
        assert len(workers) <= 2 and os.getpid() not in workers
        processes = [psutil.Process(pid) for pid in workers]
    _, alive = psutil.wait_procs(processes, timeout=10)  # the workers' processes end with the block
    assert not alive
    assert set(map_on_dask(_pid, range(2), max_workers=2, progress=False)).isdisjoint(workers)


def test_a_bad_scheduler_address_is_a_config_error_within_seconds(tmp_path, capsys):
    from diagnose_truth import make_case
    from diagnose_truth import write_job as write_diagnose_job
    from test_calibrate import write_job

    from cosim.parallel import map_on_dask

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for address in (f"tcp://127.0.0.1:{port}", "not-an-address"):
        t0 = time.perf_counter()
        with pytest.raises(ConfigError, match="no Dask scheduler answered at"):
            map_on_dask(abs, [1, 2], scheduler=address, progress=False)
        assert time.perf_counter() - t0 < 8
    # the commands: exit 2 within seconds, before any fit, nothing written
    address = f"tcp://127.0.0.1:{port}"
    t, i, y, _ = make_case("none", np.random.default_rng(5), noise=0.3, levels=(0.0, 0.5, 1.0, 0.5, 0.0))
    (tmp_path / "d").mkdir()
    (tmp_path / "c").mkdir()
    diagnose_job = write_diagnose_job(tmp_path / "d", pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), ())
    calibrate_job = write_job(tmp_path / "c")
    for argv in (["calibrate", str(calibrate_job), "--set", f"multistart.scheduler={address}"],
                 ["diagnose", str(diagnose_job), "--set", f"parallel.scheduler={address}"]):
        t0 = time.perf_counter()
        assert main([*argv, "--out", str(tmp_path / "res"), "--no-progress"]) == 2
        assert time.perf_counter() - t0 < 15
        assert f"no Dask scheduler answered at '{address}'" in capsys.readouterr().err
        assert not (tmp_path / "res").exists()
