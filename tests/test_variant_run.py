"""One way to make a variant run (issue #41 item 3): a run config built in code (``config_from_data``), written for
``cosim run`` by ``toml_text``, and ``Engine.run_variant``, which re-runs a config with changed parameter values,
start values, controller parameters or stop time.

References: tomllib (the standard library's TOML parser) reads back what ``toml_text`` writes; a config built in
code equals the one ``load_config`` reads from the same tables; a variant run equals a fresh run of the config
loaded with the same values as ``--set`` overrides, on both engines (the same floating-point operations at the
same instants: equal to 1e-12 of each signal's range, as tests/test_engine.py compares the two engines).
"""

import tomllib

import numpy as np
import pytest
from test_master_support import master_dir, osc_config  # noqa: F401

from cosim.config import config_from_data, load_config
from cosim.errors import ConfigError
from cosim.master.engine import Engine, engine_for
from cosim.master.loop import PythonLoop
from cosim.tomldoc import toml_text


def test_toml_text_reads_back_with_tomllib():
    data = {"run": {"start": 0.0, "stop": 1.5, "engine": "python", "progress": False},
            "fmus": {"plant": {"path": 'a "quoted" \\ back\\slashed\nnew-line \u00e9 \x7f.fmu',
                               "parameters": {"k": 2.0, "n": 3, "inf": float("inf")},
                               "start": {"motor.phi": -0.25}}},
            "controllers": {"play": {"class": "cosim_controllers.playback:Playback", "rate": 1000.0,
                                     "parameters": {"file": "inputs.csv", "column": "i_ref"}}},
            "connections": [{"from": "play.y", "to": "plant.i_ref", "gain": 0.5}, {"from": "a.y", "to": "b.u"}],
            "record": {"rate": 100.0, "signals": ["plant.F_g", "plant.phi"]},
            "empty": {}}
    assert tomllib.loads(toml_text(data, "a comment\nof two lines")) == data


def test_config_from_data_is_what_load_config_reads(master_dir):  # noqa: F811
    path = osc_config(master_dir, stop=0.7)
    from_file = load_config(path)
    built = config_from_data(tomllib.loads(path.read_text()), path)
    assert built == from_file
    with pytest.raises(ConfigError, match="run.stopp: unknown key"):
        config_from_data({**from_file.raw, "run": {"stopp": 1.0}}, path)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_variant_run_is_a_fresh_run_of_the_changed_config(master_dir, compiled):  # noqa: F811
    path = osc_config(master_dir, stop=2.0)
    sets = [] if compiled else ['run.engine="python"']
    base = load_config(path, sets)
    engine = engine_for(base) if compiled else Engine(base, PythonLoop)
    variant = engine.run_variant(stop=1.2, parameters={"plant": {"k": 2.5}}, start={"plant": {"x": 0.3}},
                                 controllers={"src": {"amp": 0.5}})
    fresh = engine_for(load_config(path, sets + ["run.stop=1.2", "fmus.plant.parameters.k=2.5",
                                                 "fmus.plant.start.x=0.3", "controllers.src.parameters.amp=0.5"]))
    _assert_same(variant, fresh.run(progress=False))
    _assert_same(engine.run_variant(), engine_for(load_config(path, sets)).run(progress=False))  # nothing kept
    with pytest.raises(ConfigError, match="no FMU instance 'plnt'"):
        engine.run_variant(parameters={"plnt": {"k": 1.0}})


def _assert_same(a, b):
    assert a.data.dtype.names == b.data.dtype.names and len(a.data) == len(b.data)
    for name in a.data.dtype.names:
        span = float(np.ptp(b.data[name])) or 1.0
        np.testing.assert_allclose(a.data[name], b.data[name], rtol=0, atol=1e-12 * span, err_msg=name)
