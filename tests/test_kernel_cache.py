"""numba's on-disk cache of the compiled engine (cosim.kernel_cache, issue 54): in the user's cache directory, its
folder changing with the loop's sources, one cached loop serving FMUs of different layouts with the same records as
a loop compiled afresh and as the Python engine, ``precompile`` (what ``cosim build`` runs) leaving nothing
for a run to compile, and a controller's compiled kernel found again by the next process, but not once its file
changed."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim import kernel_cache
from cosim.config import load_config
from cosim.master import run
from test_compiled_events import _config

ROOT = Path(__file__).resolve().parent.parent

# A run of the compiled engine in a fresh process (its kernels from the cache named by the environment)
CHILD = """
import sys
import numpy as np
from cosim.config import load_config
from cosim.master import run
result = run(load_config(sys.argv[1], ["run.engine=compiled"]), progress=False)
assert result.engine == "compiled", result.engine_note
np.save(sys.argv[2], result.data)
"""


@pytest.mark.skipif(sys.platform in ("win32", "darwin"), reason="XDG_CACHE_HOME is the Linux convention")
def test_the_cache_folder_is_the_users_and_changes_with_the_loops_sources(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    first = kernel_cache.cache_dir()
    assert first.parent == tmp_path / "xdg" / "cosim" and first.name.startswith("numba-")
    copy = tmp_path / "src"
    for name in kernel_cache._LOOP_SOURCES:
        (copy / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / "cosim" / name, copy / name)
    monkeypatch.setattr(kernel_cache, "_ROOT", copy)
    assert kernel_cache.cache_dir() == first
    with open(copy / "master" / "events.py", "a") as f:  # the loop inlines these functions: a new folder
        f.write("\n# edited\n")
    assert kernel_cache.cache_dir().parent == first.parent and kernel_cache.cache_dir() != first
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert kernel_cache.cache_dir() == tmp_path / "mine"


def _child(config, out, cache):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(cache)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    subprocess.run([sys.executable, "-c", CHILD, str(config), str(out)], env=env, check=True)
    return np.load(out)


@pytest.mark.slow
def test_one_cached_loop_runs_two_fmu_layouts_as_a_fresh_compile_does(third_party_fmu, tmp_path):
    """The bouncing ball (2 states, 1 event indicator) compiles the loop into a new cache; the sawtooth (1 state,
    step events, other value references and offsets) then runs in another process on that same cached loop
    (no new code is written) and records exactly what a process with an empty cache and the Python engine
    record."""
    ball = _config(tmp_path, third_party_fmu("BouncingBall"), ["h", "v"], stop=3.0)
    saw_dir = tmp_path / "saw"
    saw_dir.mkdir()
    saw = _config(saw_dir, third_party_fmu("Sawtooth"), ["x"], stop=3.5, max_step=0.005)
    shared = tmp_path / "cache"
    ball_rows = _child(ball, tmp_path / "ball.npy", shared)
    code = sorted(p.relative_to(shared) for p in shared.rglob("ckernel.run_chunk*"))
    assert code and all(p.parts[0] == "cosim" and p.parts[1].startswith("numba-") for p in code)
    stamps = {p: (shared / p).stat().st_mtime_ns for p in code}
    saw_rows = _child(saw, tmp_path / "saw.npy", shared)
    assert {p: (shared / p).stat().st_mtime_ns for p in code} == stamps  # loaded, not compiled again
    assert sorted(p.relative_to(shared) for p in shared.rglob("ckernel.run_chunk*")) == code
    fresh = _child(saw, tmp_path / "saw_fresh.npy", tmp_path / "empty")
    for rows, path in ((ball_rows, ball), (saw_rows, saw)):
        py = run(load_config(path, ["run.engine=python"]), progress=False).data
        assert rows.dtype == py.dtype and all(np.array_equal(rows[n], py[n]) for n in py.dtype.names)
    assert saw_rows.dtype == fresh.dtype and all(np.array_equal(saw_rows[n], fresh[n]) for n in fresh.dtype.names)


@pytest.mark.slow
def test_precompile_leaves_nothing_for_a_run_to_compile(third_party_fmu, gripper_fmus, tmp_path):
    """After ``precompile`` a run with events and one without (the gripper) use its versions of the loop: numba
    compiles no other (the tables' types are those a run passes)."""
    from cosim_controllers.foc import FOC
    from cosim_controllers.outer import OuterLoop
    from cosim.master.ckernel import run_chunk
    from cosim.master.compiled import precompile

    precompile([FOC, OuterLoop])
    loops = len(run_chunk.signatures)
    run(load_config(_config(tmp_path, third_party_fmu("BouncingBall"), ["h"], stop=0.5)), progress=False)
    gripper = load_config(ROOT / "examples" / "gripper_impact.toml",
                          [f"fmus.plant.path={gripper_fmus['GripperPlant']}", "run.stop=0.01", "plot.panels=[]"])
    assert run(gripper, progress=False).engine == "compiled"
    assert len(run_chunk.signatures) == loops == 4


RAMP = """
from cosim import Controller


def ramp_kernel(t, u, y, x, p):
    y[0] = {slope} * t


class Ramp(Controller):
    parameters = {{}}
    inputs = ()
    outputs = ("y",)
    kernel = staticmethod(ramp_kernel)
"""


@pytest.mark.slow
def test_a_controllers_kernel_is_compiled_once_and_again_when_its_file_changes(third_party_fmu, tmp_path):
    """A controller of the user's own file (y = 2 t) run in three processes sharing a cache: the second compiles
    nothing (no file added to the cache: numba keys the engine's wrapper of the kernel on the kernel, not on an
    id new in every process); after an edit of the file (y = 3 t), the third records the new law (the wrapper,
    which holds the kernel's code, is not taken stale from the cache)."""
    config = _config(tmp_path, third_party_fmu("BouncingBall"), ["h"], stop=0.5)
    config.write_text(config.read_text().replace('signals = ["m.h"]', 'signals = ["m.h", "ramp.y"]')
                      + '\n[controllers.ramp]\nclass = "ramp.py:Ramp"\nrate = 100\n')
    (tmp_path / "ramp.py").write_text(RAMP.format(slope=2.0))
    cache = tmp_path / "cache"
    first = _child(config, tmp_path / "1.npy", cache)
    files = sorted(cache.rglob("*"))
    second = _child(config, tmp_path / "2.npy", cache)
    assert sorted(cache.rglob("*")) == files
    (tmp_path / "ramp.py").write_text(RAMP.format(slope=3.0))
    third = _child(config, tmp_path / "3.npy", cache)
    np.testing.assert_array_equal(first["ramp.y"], second["ramp.y"])
    # every sample the controller took (the run's last instant, its stop, holds the sample before it)
    np.testing.assert_allclose(first["ramp.y"][:-1], 2.0 * first["time"][:-1], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(third["ramp.y"][:-1], 3.0 * third["time"][:-1], rtol=1e-12, atol=1e-15)
