"""cosim.fmi: model description records, safe unpacking, the status checker, and driving an ME FMU."""

import re
import zipfile

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_master_support import gripper_dir, master_dir  # noqa: F401  (fixtures)

from cosim.errors import FmiCallError
from cosim.errors import FmuFileError
from cosim.fmi import FmuInstance, check, read_model_info, safe_extract


def test_model_info_of_a_compiled_model(master_dir):
    info = read_model_info(master_dir / "Osc.fmu")
    assert info.fmi_version == 3 and info.kinds == ("ME", "CS")  # both interfaces in one FMU
    assert info.n_states == 2
    assert info.names("input") == ["u"]
    assert set(info.names("output")) == {"y", "v_out"}
    assert info.variables["y"].unit == "m"
    assert info.variables["k"].causality == "parameter"
    assert info.output_deps["y"] == ()  # y depends on states only


@pytest.mark.slow
def test_split_gripper_declares_feedthrough(gripper_dir):
    info = read_model_info(gripper_dir / "Drivetrain.fmu")
    deps = set(info.output_deps["tau_load"])
    assert "w_m" in deps and deps <= {"theta_m", "w_m"}  # direct feedthrough of the speed
    assert info.output_deps["F_g"] == ()


def test_derivatives_match_the_equations(master_dir):
    # der(x) = v, der(v) = -k x - c v + u with k set to 9 and c = 0.5 (exact arithmetic: atol 1e-12)
    with FmuInstance(master_dir / "Osc.fmu", "osc") as inst:
        inst.setup(0.0, parameters={"k": 9.0})
        assert_allclose(inst.x, [1.0, 0.0])
        u = inst.port(["u"])
        u.values[0] = 0.25
        inst.set(u)
        inst.x[:] = [0.3, -0.7]
        inst.set_time(0.1)
        inst.push_states()
        inst.pull_derivatives()
        assert_allclose(inst.dx, [-0.7, -9 * 0.3 - 0.5 * -0.7 + 0.25], atol=1e-12)
        assert_allclose(inst.get_values(["y", "v_out"])["y"], 0.6, atol=1e-12)


def test_check_raises_with_function_and_status():
    check("fmi3DoStep", 0)
    check("fmi3DoStep", 1)  # warning passes
    with pytest.raises(FmiCallError) as err:
        check("fmi3DoStep", 3)
    assert err.value.function == "fmi3DoStep" and err.value.status == "Error"
    assert "fmi3DoStep returned Error" in str(err.value)


def test_hot_calls_go_through_the_checker(master_dir):
    with FmuInstance(master_dir / "Osc.fmu", "osc") as inst:
        inst.setup(0.0)
        inst._f_set_time = lambda comp, t: 4  # the C entry point reports Fatal
        with pytest.raises(FmiCallError) as err:
            inst.set_time(0.0)
        assert err.value.function == "SetTime" and err.value.status == "Fatal"


def test_missing_and_invalid_files(tmp_path):
    with pytest.raises(FmuFileError, match="does not exist"):
        read_model_info(tmp_path / "nope.fmu")
    bad = tmp_path / "bad.fmu"
    bad.write_text("not a zip")
    with pytest.raises(FmuFileError, match="not an FMU"):
        read_model_info(bad)


def test_cs_requested_from_an_me_only_fmu(master_dir, tmp_path):
    # our FMUs carry both interfaces: a copy whose modelDescription declares Model Exchange only
    me_only = tmp_path / "Osc.fmu"
    with zipfile.ZipFile(master_dir / "Osc.fmu") as source, zipfile.ZipFile(me_only, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb"<CoSimulation[^>]*/>", b"", data)
            target.writestr(item, data)
    assert read_model_info(me_only).kinds == ("ME",)
    with pytest.raises(FmiCallError, match="not CS"):
        FmuInstance(me_only, "osc", kind="CS")


def test_safe_extract_refuses_escaping_members(tmp_path):
    evil = tmp_path / "evil.fmu"
    with zipfile.ZipFile(evil, "w") as zf:
        zf.writestr("modelDescription.xml", "<x/>")
        zf.writestr("../outside.txt", "boo")
    target = tmp_path / "unpack"
    target.mkdir()
    with pytest.raises(FmuFileError, match="outside"):
        safe_extract(evil, target)
    assert not (tmp_path / "outside.txt").exists()
    link = tmp_path / "link.fmu"
    with zipfile.ZipFile(link, "w") as zf:
        info = zipfile.ZipInfo("binaries/lib.so")
        info.external_attr = (0o120777 << 16)
        zf.writestr(info, "/etc/passwd")
    with pytest.raises(FmuFileError, match="symbolic link"):
        safe_extract(link, target)


def test_instances_clean_up_their_files(master_dir):
    inst = FmuInstance(master_dir / "Osc.fmu", "osc")
    inst.setup(0.0)
    folder = inst._tmp
    inst.close()
    import os

    assert not os.path.exists(folder)
    np.testing.assert_equal(inst.component, None)


def test_entry_points_for_a_compiled_engine(master_dir):
    with FmuInstance(master_dir / "Osc.fmu", "osc") as inst:
        inst.setup(0.0)
        ep = inst.entry_points()
        assert ep["component"] and ep["SetTime"] and ep["GetDerivatives"] and ep["SetReal"]
        assert all(isinstance(v, int) for v in ep.values())
