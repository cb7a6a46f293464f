"""Fuzz of the run-config, calibration-job, diagnosis-job, campaign-job and sensitivity-job loaders and of ``--set``
(every command that takes it): the shipped examples with mutated values, lines, keys and overrides
(tests/fuzz_cases.py) must load or raise one of the project's own errors (a CosimError subclass); any other
exception is a bug. The haptic command's table loaders and arguments likewise. benchmarks/fuzz.py runs the same cases by the ten thousand and
counts them by error class."""

import pytest
from fuzz_cases import cases, check, check_haptic, haptic_cases, workspace
from hypothesis import HealthCheck, given, settings
from test_master_support import gripper_dir  # noqa: F401

# 2,000 cases in all, 76 s with -n 2 on the 2-core machine at a load of 9 (the FMUs built included): 20 ms (calibration
# job) to 60 ms (diagnosis job) a case, 25 ms (sensitivity job)
_SETTINGS = dict(deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def folder(tmp_path_factory, gripper_dir):  # noqa: F811
    return workspace(tmp_path_factory.mktemp("fuzz"), gripper_dir)


@settings(max_examples=300, **_SETTINGS)
@given(case=cases("run"))
def test_run_config_loader_raises_only_cosim_errors(folder, case):
    assert check("run", folder, case)


@settings(max_examples=600, **_SETTINGS)
@given(case=cases("calibrate"))
def test_calibration_job_loader_raises_only_cosim_errors(folder, case):
    assert check("calibrate", folder, case)


@settings(max_examples=200, **_SETTINGS)
@given(case=cases("diagnose"))
def test_diagnosis_job_loader_raises_only_cosim_errors(folder, case):
    assert check("diagnose", folder, case)


@settings(max_examples=300, **_SETTINGS)
@given(case=cases("campaign"))
def test_campaign_job_loader_raises_only_cosim_errors(folder, case):
    assert check("campaign", folder, case)


@settings(max_examples=200, **_SETTINGS)
@given(case=cases("sensitivity"))
def test_sensitivity_job_loader_raises_only_cosim_errors(folder, case):
    # cosim sensitivity JOB --set ...: the job, the campaign job it names and its reduced grid
    assert check("sensitivity", folder, case)


@settings(max_examples=400, **_SETTINGS)
@given(case=haptic_cases())
def test_haptic_loaders_and_arguments_raise_only_cosim_errors(case, capsys):
    assert check_haptic(case)
    capsys.readouterr()  # argparse's usage lines for the refused arguments
