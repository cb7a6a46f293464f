"""Haptic controllers (wall, adaptive wall, user intent) and master-run contacts against the margins' prediction."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from cosim_controllers.haptic import ADAPTIVE_B_USER1, AdaptiveWall, UserIntent, VirtualWall
from cosim.haptic.margins import adaptive_damping

FMUS = __import__("pathlib").Path(__file__).resolve().parent.parent / "fmus"


def test_wall_law_one_sided_with_backward_difference():
    w = VirtualWall(1000.0, jit=False, phi_wall=0.7, K=10.0, B=0.05)
    w.u[0] = 0.6
    w.step(0.0)
    assert w.y[0] == 0.0  # outside the wall: no torque
    w.u[0] = 0.71
    w.step(0.001)
    v = (0.71 - 0.6) / 0.001
    assert_allclose(w.y[0], -(10.0 * 0.01 + 0.05 * v), rtol=1e-12)
    assert_allclose(w.y[2], v, rtol=1e-12)


def test_wall_kernel_compiles_and_matches_python():
    a = VirtualWall(1000.0, B=0.02)
    b = VirtualWall(1000.0, jit=False, B=0.02)
    assert a.compiled
    for k, phi in enumerate(np.linspace(0.69, 0.72, 20)):
        for c in (a, b):
            c.u[0] = phi
            c.step(k * 1e-3)
        assert a.y[0] == b.y[0]


def test_adaptive_table_is_the_derived_one():
    # the shipped defaults equal what adaptive_damping derives for user 1 (PM >= 50 deg)
    derived = adaptive_damping(user=1)
    assert_allclose(ADAPTIVE_B_USER1, [derived[p] for p in range(1, 7)], atol=1e-12)
    assert AdaptiveWall(1000.0, jit=False, position=5).p[2] == ADAPTIVE_B_USER1[4]
    with pytest.raises(ValueError):
        AdaptiveWall(1000.0, jit=False, position=7)
    with pytest.raises(TypeError):
        VirtualWall(1000.0, jit=False, stiffness=3.0)


def test_user_intent_ramp_and_final_force_target():
    c = UserIntent(1000.0, jit=False, phi_start=0.0, v_approach=0.5, accel_s=0.1, tau_final=0.1, phi_wall=0.7,
                   K_wall=10.0, k_user=2.0)
    assert_allclose(c.phi_end, 0.7 + 0.1 * (1 / 10 + 1 / 2))
    c.step(0.05)
    assert_allclose(c.y[0], 0.5 * 0.5 * 0.05**2 / 0.1)
    c.step(1.0)
    assert_allclose(c.y[0], 0.5 * 0.5 * 0.1 + 0.5 * 0.9)
    c.step(5.0)
    assert c.y[0] == c.phi_end
    with pytest.raises(ValueError):
        UserIntent(1000.0, jit=False, tau_final=0.1)


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    import warnings
    from cosim.compile import build_fmu

    out = tmp_path_factory.mktemp("haptic_fmus_ctrl")
    src = FMUS.parent / "modelica" / "Haptic" / "package.mo"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, model in (("HapticDevice11", "Device11"), ("HapticDevice7", "Device7"), ("HapticDeviceArm", "DeviceArm")):
            built = build_fmu(src, f"Haptic.{model}", out_dir=out / model)
            built.rename(out / f"{name}.fmu")
    return out


@pytest.mark.slow
def test_step_contact_matches_margin_prediction(fmu_dir):
    # master run: the motor-torque step on the stylus resting in the wall; final penetration = tau/(K + k_user)
    # (statics, independent of the dynamics) and overshoot/settling near exp(-pi z/sqrt(1-z^2)), 4/(z w_cg)
    from cosim.haptic.collision import collision_study

    df = collision_study(users=(1,), positions=(3, 5), fmu_dir=fmu_dir, scenarios=("step",))
    for _, r in df.iterrows():
        # more damped <-> less overshoot; model-based prediction within 0.1 (eq. 17 is an approximation)
        assert abs(r.step_overshoot - r.overshoot_pred) < 0.1
        assert 0.6 < r.step_settling_s / r.settling_pred_s < 1.6
    # seed 000 Sec. IV: position 5 settles much later than position 3
    s3, s5 = df.step_settling_s
    assert s5 > 1.5 * s3


@pytest.mark.slow
def test_adaptive_wall_equalises_settling(fmu_dir):
    # seed 000 Sec. V-C: with the adaptive impedances positions 3 and 5 settle alike (0.183 vs 0.185 s measured)
    from cosim.haptic.collision import collision_study

    df = collision_study(users=(1,), positions=(3, 5), adaptive=True, fmu_dir=fmu_dir, scenarios=("step",))
    s3, s5 = df.step_settling_s
    assert abs(s5 - s3) / s3 < 0.25


@pytest.mark.slow
def test_collision_reaches_target_force(fmu_dir):
    from cosim.haptic.collision import collision_metrics, simulate_contact
    from cosim.haptic.params import load_user_params

    d = simulate_contact(load_user_params(1, 3), "collision", fmu_dir=fmu_dir, v_approach=0.5, tau_final=0.1)
    m = collision_metrics(d["time"], d["phi"])
    assert_allclose(m["pen_final"], 0.1 / 10.0, rtol=0.01)  # steady wall torque = tau_final
    assert_allclose(m["v_contact"], 0.5, rtol=0.05)  # the hand reference's approach speed
    assert m["settling_s"] > 0


@pytest.mark.parametrize("name,fmu", [("haptic_wall.toml", "HapticDevice11"), ("haptic_wall_adaptive.toml", "HapticDevice7"),
                                      ("haptic_wall_arm.toml", "HapticDeviceArm")])
@pytest.mark.slow
def test_shipped_configs_run(fmu_dir, name, fmu):
    # the example configs load and run; final wall torque = tau_final = 0.1 N.m (statics)
    from cosim.config import load_config
    from cosim.master.run import run

    path = FMUS.parent / "examples" / name
    cfg = load_config(path, overrides=[f'fmus.plant.path="{(fmu_dir / (fmu + ".fmu")).as_posix()}"'])
    data = run(cfg, progress=False).data
    assert_allclose(data["wall.tau"][-1], -0.1, rtol=2e-3)
