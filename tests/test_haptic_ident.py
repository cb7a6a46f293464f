"""Identification recovers known generating parameters from simulated, noisy experiments (seeds 000 and 001)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from cosim.freqresp import coloured_noise, model_response, welch_tf, white_noise, zoh_freq_response
from cosim.haptic.experiments import arm_experiment, arm_robust_stability, arm_segment_length, device_experiment
from cosim.haptic.ident import ARM_PARAMS, DeviceUserFit, arm_ss, device_user_ss
from cosim.haptic.params import load_arm_params, load_user_params
from cosim.errors import NotFittedError
from cosim.haptic.tf import tf_arm, tf_user

import control


def test_state_space_equals_paper_transfer_functions():
    # the mechanical state-space models used by the fits against eqs. (2), (9) and seed 001 eq. (1)
    f = np.logspace(np.log10(0.5), np.log10(70), 50)
    for user, pos in ((1, 3), (1, 5), (7, 4)):
        p = load_user_params(user, pos)
        ref = tf_user(p)(2j * np.pi * f)
        assert_allclose(model_response(device_user_ss(p.values, p.structure), f), ref, rtol=1e-9)
    a = load_arm_params("Y", 1)
    assert_allclose(model_response(arm_ss(a.__dict__), f), tf_arm(a)(2j * np.pi * f), rtol=1e-9)


def test_zoh_response_equals_c2d():
    # independent: python-control's ZOH discretisation evaluated on the unit circle
    p = load_user_params(1, 3)
    f = np.array([0.5, 5, 50, 70])
    Gz = control.c2d(tf_user(p), 1e-3, "zoh")
    assert_allclose(zoh_freq_response(*device_user_ss(p.values, 11), f, 1000.0), Gz(np.exp(2j * np.pi * f * 1e-3)), rtol=1e-6)


def test_excitations():
    u = white_noise(20, 1000, band=(0.1, 150), rms=0.05)
    assert len(u) == 20000 and abs(np.sqrt(np.mean(u**2)) - 0.05) < 1e-12
    F = coloured_noise(60, 1000, cutoff=30, order=13, peak=5.0)
    assert len(F) == 60000 and abs(np.max(np.abs(F)) - 5.0) < 1e-12
    # 32 half-overlapping segments span the record
    n = arm_segment_length(60000)
    assert (60000 - n) // (n // 2) + 1 == 32


@pytest.mark.parametrize("user,position", [(1, 3), (1, 5), (5, 4), (8, 6)])
def test_device_fit_recovers_generating_parameters(user, position):
    p = load_user_params(user, position)
    fr, fit = device_experiment(tf_user(p), p.structure, position=position, seed=user * 10 + position)
    assert len(fr.band(0.5, 70).f) > 250
    # stiffnesses and masses shape Kp and the poles/zeros: they must be informative
    must = {"kc", "ks", "m1", "m2"}
    assert fit.converged_
    assert must <= set(fit.informative_), fit.relative_se_
    for name in fit.informative_:
        assert_allclose(fit.params_[name], p[name], rtol=0.05, err_msg=name)
    # the fitted model reproduces the data
    assert fit.rms_log_error_ < 0.05


def test_device_fit_not_fitted_and_bad_input():
    with pytest.raises(NotFittedError):
        DeviceUserFit(11).predict([1.0])
    with pytest.raises(TypeError):
        DeviceUserFit(11).fit(np.zeros(3))
    fr = welch_tf(np.random.default_rng(0).normal(size=8192), np.random.default_rng(1).normal(size=8192), 1000.0)
    with pytest.raises(ValueError, match="weighting"):
        DeviceUserFit(11, weighting="bad").fit(fr)


@pytest.mark.parametrize("axis,grip", [("X", 1), ("Y", 2), ("Z", 3), ("Z", "nominal")])
def test_arm_fit_recovers_table_values(axis, grip):
    # seed 001 experiment simulated on a Table I / II arm: coherence-weighted fit within 5 %
    a = load_arm_params(axis, grip)
    fr, fit = arm_experiment(a, seed=3)
    for name in ARM_PARAMS:
        assert_allclose(fit.params_[name], getattr(a, name), rtol=0.05, err_msg=name)


def test_robust_stability_check():
    # 67 % CI set of the X axis: robustly stable for the 10 Nm/rad wall; the max set is not (|W_u| ~ 3 dB at
    # low frequency with |T| ~ 0.8 already breaks the small-gain bound)
    assert arm_robust_stability("X", "67ci").robust
    c = arm_robust_stability("X", "max")
    assert c.nominal_stable and not c.robust and c.peak > 1
