"""Shared fixtures: FMUs built once per test session from the Modelica sources they test."""

import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
COMPILER_MODELS = ROOT / "tests" / "models" / "compiler" / "CompilerTests.mo"
HYBRID_MODELS = ROOT / "tests" / "models" / "hybrid" / "Hybrid.mo"


def pytest_collection_modifyitems(items):
    """The slow tests first (in their order): started early on every xdist worker, they do not leave one worker
    running a long test alone while the other has finished."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


@pytest.fixture(scope="session")
def compiler_fmu(tmp_path_factory):
    """Build ``CompilerTests.<name>`` once per session; returns a function name -> FMU path."""
    from cosim.compile import build_fmu

    out = tmp_path_factory.mktemp("compiler_fmus")
    built = {}

    def get(name):
        if name not in built:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                built[name] = build_fmu(COMPILER_MODELS, f"CompilerTests.{name}", out_dir=out)
        return built[name]

    return get


@pytest.fixture(scope="session")
def hybrid_fmu(tmp_path_factory):
    """Build ``Hybrid.<name>`` (tests/models/hybrid, models with events) once per session: name -> FMU path."""
    from cosim.compile import build_fmu

    out = tmp_path_factory.mktemp("hybrid_fmus")
    built = {}

    def get(name):
        if name not in built:
            built[name] = build_fmu(HYBRID_MODELS, f"Hybrid.{name}", out_dir=out)
        return built[name]

    return get


@pytest.fixture(scope="session")
def gripper_fmus(tmp_path_factory):
    """GripperPlant, PMSM and Drivetrain FMUs (modelica/Gripper), built once per session: dict name -> path."""
    from test_gripper_support import build_gripper_fmus

    return build_gripper_fmus(tmp_path_factory.mktemp("gripper_fmus"))


@pytest.fixture(scope="session")
def third_party_fmu(tmp_path_factory):
    """The C test FMUs of tests/fmus (written like a third party's), built once per session: a function
    (name, fmi_version=3) -> FMU path, e.g. ``third_party_fmu("BouncingBall", 2)``."""
    from fmus.build import build

    out = tmp_path_factory.mktemp("third_party_fmus")
    built = {}

    def get(name, fmi_version=3):
        if (name, fmi_version) not in built:
            built[name, fmi_version] = build(name, out, fmi_version)
        return built[name, fmi_version]

    return get


@pytest.fixture(scope="session")
def fmi2_fmu(tmp_path_factory):
    """A model of modelica/models.toml built as an FMI 2.0 FMU (Model Exchange and Co-Simulation) with the
    list's settings, once per session: a function name -> FMU path, e.g. ``fmi2_fmu("GripperPlant")``."""
    from cosim.compile import build_fmu, read_model_list

    out = tmp_path_factory.mktemp("fmi2_fmus")
    entries = {entry["name"]: entry for entry in read_model_list(ROOT / "modelica" / "models.toml")}
    built = {}

    def get(name):
        if name not in built:
            entry = entries[name]
            solver = {key: entry[key] for key in ("cs_step", "cs_method") if key in entry}
            built[name] = build_fmu(entry["source"], entry["model"], out_dir=out, name=name, fmi_version=2,
                                    **solver)
        return built[name]

    return get
