"""The compiled engine (issue 8): same results as the Python engine on every shipped config and on the
FMI 2.0 ME/CS paths, fallback to the Python engine with a one-line reason, Ctrl-C, progress, compile time.

Reference: the Python engine (cosim.master.engine.Engine), itself tested against exact solutions in
test_master.py. Both engines do the same floating-point operations at the same instants, so the
tolerance is 1e-9 of each signal's range (issue 8); in practice they agree bitwise.
"""

import _thread
import json
import threading
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_controllers import _all_controller_classes
from test_master_support import EXAMPLES, ROOT, gripper_dir, gripper_overrides, master_dir, osc_config  # noqa: F401

from cosim.config import load_config
from cosim.master import run, run_config
from cosim.master.compiled import CompiledEngine, EngineFallbackWarning, engine_for


@pytest.fixture(scope="module")
def haptic_dir(tmp_path_factory):
    """HapticDevice11.fmu and HapticDevice7.fmu built from modelica/Haptic."""
    from cosim.compile import build_fmu

    out = tmp_path_factory.mktemp("engine_haptic")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, model in (("HapticDevice11", "Device11"), ("HapticDevice7", "Device7")):
            built = build_fmu(ROOT / "modelica" / "Haptic" / "package.mo", f"Haptic.{model}", out_dir=out / model)
            built.rename(out / f"{name}.fmu")
    return out


def _both(path, sets):
    """Run ``path`` with both engines; returns (compiled result, python result)."""
    comp = run(load_config(path, sets + ["run.engine=compiled"]), progress=False)
    py = run(load_config(path, sets + ["run.engine=python"]), progress=False)
    assert comp.engine == "compiled" and py.engine == "python"
    return comp, py


def _assert_same(comp, py):
    assert comp.data.dtype.names == py.data.dtype.names
    assert len(comp.data) == len(py.data) > 0
    assert comp.calls == py.calls
    assert np.array_equal(comp.data["time"], py.data["time"])  # same instants, exactly
    for name in comp.data.dtype.names[1:]:
        rng = np.ptp(py.data[name]) or 1.0
        assert_allclose(comp.data[name], py.data[name], atol=1e-9 * rng, rtol=0, err_msg=name)


# shortened runs of every shipped config (the gripper ones include the impact at 0.32 s)
GRIPPER = [
    ("gripper_impact.toml", False, ["run.stop=0.45"]),
    ("gripper_impact_p3.toml", False, ["run.stop=0.45"]),
    ("gripper_impact_split.toml", True, ["run.stop=0.45"]),
    ("gripper_static.toml", False, ["run.stop=0.6", "controllers.outer.parameters.step_A=0.5",
                                    "controllers.outer.parameters.step_s=0.1"]),
]


@pytest.mark.parametrize("name,split,sets", GRIPPER, ids=[g[0] for g in GRIPPER])
def test_engines_agree_on_gripper_configs(gripper_dir, name, split, sets):
    comp, py = _both(EXAMPLES / name, gripper_overrides(gripper_dir, split) + sets)
    _assert_same(comp, py)
    force = "F_g"
    assert comp.data[force].max() > 10.0  # the runs reach contact


@pytest.mark.parametrize("name,fmu", [("haptic_wall.toml", "HapticDevice11"),
                                      ("haptic_wall_adaptive.toml", "HapticDevice7")])
def test_engines_agree_on_haptic_configs(haptic_dir, name, fmu):
    comp, py = _both(EXAMPLES / name, [f'fmus.plant.path="{(haptic_dir / (fmu + ".fmu")).as_posix()}"', "run.stop=1.6"])
    _assert_same(comp, py)
    assert comp.data["wall.penetration"].max() > 0.0  # the runs reach the wall


@pytest.mark.parametrize("kind", ["ME", "CS"])
def test_engines_agree_on_fmi2_me_and_cs(master_dir, kind):
    # the hand-written FMI 2.0 FMU: ME integrated by the kernel, CS through fmi2DoStep by address
    path = osc_config(master_dir, stop=1.0)
    comp, py = _both(path, ["fmus.plant.path=Osc2.fmu", f"fmus.plant.kind={kind}", 'record.signals=["plant.y", "src.u"]'])
    _assert_same(comp, py)


def test_engines_agree_on_cs_feeding_me_with_gain_offset_and_substeps(master_dir):
    # FMI 2 CS -> FMI 3 ME, routed with a gain and an offset, 3 RK4 substeps, a recorder off the controller grid
    path = osc_config(master_dir, stop=0.5, record_rate=300, extra="""
        [fmus.cs]
        path = "Osc2.fmu"
        kind = "CS"
        parameters = { k = 9.0 }
        """)
    sets = ['connections=[{from = "src.u", to = "cs.u"}, {from = "cs.y", to = "plant.u", gain = 0.5, offset = 0.1}]',
            'record.signals=["cs.y", "plant.y", "src.u"]', "solver.substeps=3"]
    comp, py = _both(path, sets)
    _assert_same(comp, py)


def test_compiled_is_the_default_and_reports_compile_time(master_dir, tmp_path):
    cfg = load_config(osc_config(master_dir, stop=0.2))
    assert cfg.run.engine == "compiled"
    assert isinstance(engine_for(cfg), CompiledEngine)
    result, summary, _ = run_config(osc_config(master_dir, stop=0.2), out=tmp_path / "o", progress=False)
    assert result.engine == "compiled" and result.compile_s > 0.0
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["engine"] == "compiled" and s["compile_s"] == pytest.approx(result.compile_s)


BAD_CTL = '''
import numpy as np
from controllers.base import Controller


def _bad(t, u, y, x, p):
    y[0] = dict(gain=p[0])["gain"]


class Bad(Controller):
    """Uses dict(key=value), which numba cannot compile."""
    parameters = {"amp": 1.0}
    outputs = ("u",)
    kernel = staticmethod(_bad)
'''


def test_fallback_names_the_construct(master_dir, tmp_path):
    (master_dir / "bad_ctl.py").write_text(BAD_CTL)
    cfg = load_config(osc_config(master_dir, stop=0.1), ['controllers.src.class="bad_ctl.py:Bad"',
                                                         "controllers.src.parameters={}"])
    with pytest.warns(EngineFallbackWarning) as rec:
        result = run(cfg, progress=False)
    assert len(rec) == 1
    msg = str(rec[0].message)
    assert "\n" not in msg
    assert "running the Python engine" in msg and "'src'" in msg and "Bad" in msg
    assert "dict" in msg and 'dict(gain=p[0])["gain"]' in msg and "bad_ctl.py:7" in msg  # the construct and where it is
    assert result.engine == "python" and len(result.data) == 11
    assert_allclose(result.data["src.u"], 1.0)


def test_python_controllers_run_the_python_engine_with_a_note(master_dir):
    # a controller overriding step() in Python, or jit = false: the config asks for Python; a note, no warning
    extra = """
        [controllers.probe]
        class = "ctl.py:Probe"
        rate = 100
        """
    for sets in ([], ["controllers.src.jit=false"]):
        cfg = load_config(osc_config(master_dir, stop=0.1, extra=extra if not sets else ""), sets)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = run(cfg, progress=False)
        assert result.engine == "python"
        assert ("overrides step()" in result.engine_note) if not sets else ("jit = false" in result.engine_note)


def test_ctrl_c_keeps_what_was_recorded(gripper_dir):
    # an interrupt during the kernel takes effect at the end of a chunk; the rows recorded so far are kept
    cfg = load_config(EXAMPLES / "gripper_impact.toml", gripper_overrides(gripper_dir) + ["run.stop=60"])
    engine = engine_for(cfg)
    assert isinstance(engine, CompiledEngine)
    timer = threading.Timer(1.0, _thread.interrupt_main)
    timer.start()
    try:
        result = engine.run(progress=False)
    finally:
        timer.cancel()
    assert result.interrupted
    n = len(result.data)
    assert 0 < n < 60 * 2660
    t = result.data["time"]
    assert_allclose(np.diff(t), 1 / 2660, rtol=1e-9)
    assert not np.isnan(result.data["F_g"]).any()
    # what was kept equals the start of an uninterrupted run
    short = run(load_config(EXAMPLES / "gripper_impact.toml",
                            gripper_overrides(gripper_dir) + [f"run.stop={t[-1]}"]),
                progress=False)
    assert np.array_equal(short.data["F_g"][:n], result.data["F_g"])


def test_progress_bar_on_stderr(master_dir, capsys):
    result = run(load_config(osc_config(master_dir, stop=0.5)), progress=True)
    assert result.engine == "compiled"
    assert "sim s" in capsys.readouterr().err


@pytest.mark.parametrize("cls", _all_controller_classes(), ids=lambda c: f"{c.__module__}.{c.__name__}")
def test_every_shipped_controller_runs_as_a_cfunc(cls):
    # the compiled engine calls each kernel through its cfunc wrapper: same outputs and state as step()
    import numba

    from controllers.base import native_kernel
    from cosim.fmi import native

    @numba.njit
    def call(addr, t, u, y, x, p):
        native.call_kernel(addr, t, u.ctypes.data, u.shape[0], y.ctypes.data, y.shape[0], x.ctypes.data, x.shape[0],
                           p.ctypes.data, p.shape[0])

    a, b = cls(rate=10000.0), cls(rate=10000.0)
    rng = np.random.default_rng(1)
    addr = native_kernel(cls.kernel).address
    for j in range(20):
        u = rng.uniform(-1.0, 1.0, len(cls.inputs))
        a.u[:] = u
        b.u[:] = u
        a.step(j * 1e-4)
        call(addr, j * 1e-4, b.u, b.y, b.x, b.p)
        assert np.array_equal(a.y, b.y) and np.array_equal(a.x, b.x)


def test_fmi_error_in_the_kernel_raises_fmi_call_error(master_dir):
    # a GetReal of an unknown value reference (Osc2 answers fmi2Error) inside the kernel -> FmiCallError
    from cosim.errors import FmiCallError

    cfg = load_config(osc_config(master_dir, stop=0.1), ["fmus.plant.path=Osc2.fmu", 'record.signals=["plant.y"]'])
    engine = engine_for(cfg)
    assert isinstance(engine, CompiledEngine)
    bad_vr = np.array([99], dtype=np.uint32)
    tables = engine._tables

    def broken(plant):
        tab = tables(plant)
        tab["port"][0, 1] = bad_vr.ctypes.data  # the sampled port now reads value reference 99
        tab["port"][0, 2] = 1
        return tab

    engine._tables = broken
    with pytest.raises(FmiCallError, match="GetReal.*Error"):
        engine.run(progress=False)
