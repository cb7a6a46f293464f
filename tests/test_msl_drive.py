"""examples/msl_drive: a DC drive of Modelica Standard Library components under the cascaded PI controllers.

References written here, independent of the compiler and the master: the drive's ODEs by hand (armature R-L with
back-EMF, rotor with the viscous gear loss, ideal gear, the MSL ElastoBacklash law as its documentation states it,
load inertia and torque step) integrated by scipy's solve_ivp; the steady state in closed form; the controllers on
exactly discretised plants. The FMU is built from the example's own files with the MSL passed explicitly.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from cosim_controllers.dc_drive import DcCurrentPI, DcSpeedPI

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "msl_drive"
MSL = ROOT.parent / "shared" / "msl" / "ModelicaStandardLibrary-4.1.0"

# DcDrive.mo's parameter values, written again here (the references must not read them from the FMU)
R, L, K, J_M, RATIO, D_G = 1.0, 2e-4, 0.03, 1e-5, 28.0, 1.7e-5
C_G, D_C, B, J_L, T_L, T_LOAD = 1000.0, 1.0, 0.0175, 0.01, 1.0, 0.2


# --- the controllers on exact plants (fast) -------------------------------------------------------------------

def test_current_step_follows_the_designed_first_order_response():
    """On the armature sampled with zero-order hold (exact: i+ = a i + (1 - a) (v - k w) / R, a = exp(-R T / L))
    at a constant speed, with the back-EMF fed forward, a current step follows 1 - p^n with p = exp(-2 pi f_bw T)."""
    rate, f_bw, w = 20000.0, 2000.0, 300.0
    c = DcCurrentPI(rate=rate, R=R, L=L, k_e=K, V_bus=24.0, bandwidth_hz=f_bw)
    T = 1.0 / rate
    a, p = math.exp(-R * T / L), math.exp(-2 * math.pi * f_bw * T)
    i, currents = 0.0, []
    for n in range(40):
        c.u[:] = (1.0, i, w)
        c.step(n * T)
        i = a * i + (1.0 - a) * (c.y[0] - K * w) / R
        currents.append(i)
    assert_allclose(currents, 1.0 - p ** np.arange(1, 41), rtol=0, atol=1e-12)


def test_current_loop_saturates_at_the_supply_without_windup():
    """A reference the supply cannot reach (5 A against a blocked rotor whose current reads 0) holds v at V_bus
    for 0.1 s; when the reference falls to 0.5 A the voltage leaves the limit at the next sample (a wound-up
    integral, 2000 samples of 5 A error, would hold it there for thousands of samples)."""
    c = DcCurrentPI(rate=20000.0, R=R, L=L, k_e=0.0, V_bus=12.0, bandwidth_hz=2000.0)
    out = []
    for n in range(2000):
        c.u[:] = (5.0, 0.0, 0.0)
        c.step(n / 20000.0)
        out.append(c.y[0])
    assert max(out) == 12.0 and out[-1] == 12.0
    c.u[:] = (0.5, 0.0, 0.0)
    c.step(0.1)
    assert 0.0 < c.y[0] < 12.0


def test_speed_reference_is_the_trapezoid():
    """The reference against numpy's interpolation between the trapezoid's corners (and a step when ramp_s = 0)."""
    s = DcSpeedPI(rate=1000.0, speed_rpm=3000.0, t_start=0.1, ramp_s=0.05, t_down=0.3)
    w = 3000.0 * 2 * math.pi / 60
    t = np.arange(0, 0.5, 1e-3)
    expected = np.interp(t, [0.1, 0.15, 0.3, 0.35], [0.0, w, w, 0.0])
    got = []
    for tk in t:
        s.step(tk)
        got.append(s.y[1])
    assert_allclose(got, expected, rtol=0, atol=1e-9 * w)
    step = DcSpeedPI(rate=1000.0, speed_rpm=3000.0, t_start=0.1, ramp_s=0.0)
    step.step(0.0999)
    assert step.y[1] == 0.0
    step.step(0.1)
    assert step.y[1] == pytest.approx(w)


def test_speed_loop_limits_the_current_and_removes_a_load_error():
    """On the rigid drive (ideal current loop, exact: w+ = w + T (k i - tau_L) / J) a step beyond reach at the
    current limit holds i_ref at i_max, and under a constant load torque the speed settles on the reference
    (integral action: zero steady error) with i_ref = tau_L / k."""
    J, i_max, tau_l, rate = J_M + J_L / RATIO ** 2, 3.0, 0.02, 1000.0
    s = DcSpeedPI(rate=rate, J=J, k_t=K, crossover_hz=20.0, i_max=i_max, speed_rpm=4000.0, t_start=0.0)
    w, refs = 0.0, []
    for n in range(1000):
        s.u[0] = w
        s.step(n / rate)
        refs.append(s.y[0])
        w += (K * s.y[0] - tau_l) / (J * rate)
    assert max(refs) == i_max and refs[0] == i_max
    assert w == pytest.approx(4000.0 * 2 * math.pi / 60, rel=1e-6)
    assert refs[-1] == pytest.approx(tau_l / K, rel=1e-6)


# --- the FMU of the example (slow: the MSL load alone takes about 15 s) -----------------------------------------

@pytest.fixture(scope="module")
def drive_fmu(tmp_path_factory):
    """DcDrive.fmu built by cosim build's model list (examples/msl_drive/models.toml) with the MSL's folder."""
    if not (MSL / "Modelica" / "package.mo").is_file():
        pytest.skip(f"the Modelica Standard Library 4.1.0 is not at {MSL}")
    from cosim.compile import build_all

    out = tmp_path_factory.mktemp("msl_drive_fmus")
    lines = list(build_all(models_toml=EXAMPLE / "models.toml", out_dir=out, modelica_path=[MSL]))
    assert lines == [f"DcDrive: built {out / 'DcDrive.fmu'}"]
    return out / "DcDrive.fmu"


def _backlash_torque(phi, w):
    """MSL 4.1.0 ElastoBacklash (b > 0, after initialisation): the torque between its flanges, as documented."""
    b2, td = B / 2, D_C * w
    if phi > b2:
        tc = C_G * (phi - b2)
        return 0.0 if tc + td <= 0 else tc + min(tc, td)
    if phi < -b2:
        tc = C_G * (phi + b2)
        return 0.0 if tc + td >= 0 else tc + max(tc, td)
    return 0.0


def _drive_rhs(t, x, v):
    """States: armature current, motor angle and speed, the play's relative angle and speed (load - gear output)."""
    i, _, w_m, phi_r, w_r = x
    tau = _backlash_torque(phi_r, w_r)  # acts on the load as -tau, on the gear output as +tau
    dw_m = (K * i - D_G * w_m + tau / RATIO) / J_M
    dw_l = (-tau - (T_L if t >= T_LOAD else 0.0)) / J_L
    return [(v - R * i - K * w_m) / L, w_m, dw_m, w_r, dw_l - dw_m / RATIO]


def _run(config, overrides):
    from cosim.config import load_config
    from cosim.master import run

    return run(load_config(config, overrides)).data


@pytest.mark.slow
def test_open_loop_voltage_step_follows_the_hand_written_odes(drive_fmu, tmp_path):
    """A 12 V step from standstill, the load torque step at 0.2 s: the FMU of the MSL components (cosim's RK4 at
    20 kHz) against the hand-written ODEs (LSODA, rtol 1e-10): current, speed, play and load angle within 1e-4 of
    their range (measured: 1.5e-5 for the current, 2e-6 or less for the others)."""
    config = tmp_path / "open_loop.toml"
    config.write_text(f"""
[run]
stop = 0.3
[fmus.plant]
path = "{drive_fmu}"
start = {{ v = 12.0 }}
[record]
rate = 20000
signals = ["plant.i_a", "plant.w_m", "plant.phi_load", "plant.backlash.phi_rel", "plant.load.w"]
""")
    data = _run(config, [])
    t = data["time"]
    sol = solve_ivp(_drive_rhs, (0.0, 0.3), np.zeros(5), args=(12.0,), method="LSODA", t_eval=t, rtol=1e-10,
                    atol=1e-12, max_step=1e-5)
    assert sol.success
    i, phi_m, w_m, phi_r, w_r = sol.y
    for name, ref in (("i_a", i), ("w_m", w_m), ("backlash.phi_rel", phi_r), ("phi_load", phi_m / RATIO + phi_r),
                      ("load.w", w_m / RATIO + w_r)):
        assert np.max(np.abs(data[name] - ref)) < 1e-4 * np.ptp(ref), name


@pytest.mark.slow
def test_cascade_reaches_the_speed_within_the_current_limit(drive_fmu):
    """drive.toml as shipped: the current never exceeds the 3 A limit (by more than the current loop's tracking,
    1 %) and the voltage stays within the 24 V supply; the speed settles on the reference (integral action: the
    last 50 ms within 1e-5 of it) after the load step; the recorded local backlash.phi_rel is the play's."""
    data = _run(EXAMPLE / "drive.toml", [f"fmus.plant.path={drive_fmu}"])
    w_ref = 4000.0 * 2 * math.pi / 60
    assert np.max(np.abs(data["speed.i_ref"])) <= 3.0
    assert np.max(np.abs(data["i_a"])) <= 3.0 * 1.01
    assert np.max(np.abs(data["i_a"])) > 2.9  # the step drives the current to its limit
    assert np.max(np.abs(data["current.v"])) <= 24.0
    late = data["time"] >= 0.45
    assert np.max(np.abs(data["w_m"][late] - w_ref)) < 1e-5 * w_ref
    # the steady state in closed form at the measured speed: k i = d_g w + T_L / ratio, V = R i + k w;
    # the play closed on its negative flank: phi_rel = -b/2 - T_L / c, the load at w / ratio
    w = np.mean(data["w_m"][late])
    i = (D_G * w + T_L / RATIO) / K
    assert np.mean(data["i_a"][late]) == pytest.approx(i, rel=1e-4)
    assert np.mean(data["current.v"][late]) == pytest.approx(R * i + K * w, rel=1e-4)
    assert np.mean(data["backlash.phi_rel"][late]) == pytest.approx(-B / 2 - T_L / C_G, rel=1e-4)
    assert np.mean(data["load.w"][late]) == pytest.approx(w / RATIO, rel=1e-6)


@pytest.mark.slow
def test_cascade_at_a_low_supply_saturates_the_voltage_and_settles_in_closed_form(drive_fmu):
    """With a 12 V supply the 4000 rpm reference needs 14 V: the voltage holds at 12 V (never above) and the drive
    settles where V_bus = R i + k w and k i = d_g w + T_L / ratio (two linear equations) instead of winding up."""
    data = _run(EXAMPLE / "drive.toml", [f"fmus.plant.path={drive_fmu}",
                                         "controllers.current.parameters.V_bus=12.0"])
    assert np.max(np.abs(data["current.v"])) <= 12.0
    late = data["time"] >= 0.45
    assert np.all(data["current.v"][late] == 12.0)
    i, w = np.linalg.solve([[R, K], [K, -D_G]], [12.0, T_L / RATIO])
    assert np.mean(data["w_m"][late]) == pytest.approx(w, rel=1e-4)
    assert np.mean(data["i_a"][late]) == pytest.approx(i, rel=1e-4)
