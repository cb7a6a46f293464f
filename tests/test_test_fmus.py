"""The C test FMUs of tests/fmus (third-party style, FMI 2.0 and 3.0, Model Exchange and Co-Simulation) pass
fmpy's validation and, simulated by fmpy's own solvers, follow their closed forms (tests/fmus/reference.py).
These FMUs are the independent reference the master's event tests rely on."""

import fmpy
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from fmus.build import names
from fmus.reference import ball_state, bounce_times


def _jumps(result, name):
    """Instants at which the discrete output ``name`` changes in an fmpy result."""
    values = result[name].astype(float)
    return result["time"][1:][np.diff(values) != 0]


@pytest.mark.parametrize("name, version", names())
def test_validates(third_party_fmu, name, version):
    assert validate_fmu(str(third_party_fmu(name, version))) == []


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_me_cvode_bounce_times(third_party_fmu, version):
    r = fmpy.simulate_fmu(str(third_party_fmu("BouncingBall", version)), fmi_type="ModelExchange", solver="CVode",
                          relative_tolerance=1e-10, stop_time=3, output_interval=0.01,
                          output=["h", "v", "bounces", "flying"])
    expected = bounce_times()
    assert len(expected) == 11
    np.testing.assert_allclose(_jumps(r, "bounces"), expected, atol=1e-6)
    assert r["bounces"].dtype == np.int32 and r["bounces"][-1] == 11
    assert r["flying"].dtype == np.bool_ and not r["flying"][-1] and r["flying"][0]
    h, v, _, _ = ball_state(r["time"])
    np.testing.assert_allclose(r["h"], h, atol=1e-5)


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_me_euler_bounce_times(third_party_fmu, version):
    """fmpy's Euler takes one step per output interval and only notices a crossing at the end of a step: each
    impact is late by up to a step and the ball rebounds a little faster, so the error grows with the bounces."""
    r = fmpy.simulate_fmu(str(third_party_fmu("BouncingBall", version)), fmi_type="ModelExchange", solver="Euler",
                          step_size=1e-4, stop_time=3, output_interval=1e-4, output=["h", "bounces"])
    times = _jumps(r, "bounces")
    expected = bounce_times()
    assert len(times) == len(expected)
    assert 0 <= times[0] - expected[0] <= 1e-4
    np.testing.assert_allclose(times, expected, atol=1e-2)


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_cs_follows_closed_form(third_party_fmu, version):
    """RK4 is exact on the parabola and the impacts are located to 1e-12 s inside doStep."""
    r = fmpy.simulate_fmu(str(third_party_fmu("BouncingBall", version)), fmi_type="CoSimulation", stop_time=3,
                          output_interval=0.01, output=["h", "v", "bounces", "flying"])
    h, v, n, flying = ball_state(r["time"])
    np.testing.assert_allclose(r["h"], h, atol=1e-9)
    np.testing.assert_allclose(r["v"], v, atol=1e-8)
    np.testing.assert_array_equal(r["bounces"], n)
    np.testing.assert_array_equal(r["flying"], flying)
