"""Shipped Table I / arm tables: values, SI conversion, errors (references: numbers printed in the seed papers)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from cosim.errors import HapticDataError
from cosim.haptic.params import (
    load_arm_params, load_uncertainty_weight, load_user_params, user_params_table,
)
from cosim.haptic.tf import tf_11, tf_7, tf_arm, tf_user


def test_user1_position3_row_in_si():
    # seed 000 Table I, user 1 pos 3: m1 0.9 g.m2, b1 0.04, bc 0.07, kc 94, m2 1.3 g.m2, b2 0.02, bs 0.02,
    # ks 3.5, mh 4.2 g.m2, bh 0.10, kh 2.3
    p = load_user_params(1, 3)
    assert p.structure == 11 and p.kind == "paper"
    expected = dict(m1=0.9e-3, b1=0.04, bc=0.07, kc=94, m2=1.3e-3, b2=0.02, bs=0.02, ks=3.5, mh=4.2e-3, bh=0.10, kh=2.3)
    for k, v in expected.items():
        assert_allclose(p[k], v, rtol=1e-12)


def test_user1_positions_4_to_6_are_seven_parameter():
    # seed 000 Sec. II-D: user 1 used the 7-parameter model at positions 4-6
    for pos in (4, 5, 6):
        assert load_user_params(1, pos).structure == 7
    assert load_user_params(1, 4)["ks"] == 1.6


def test_table_counts_and_kc_means():
    rows = user_params_table()
    assert len(rows) == 78
    assert sum(r.structure == 11 for r in rows) == 49  # 49 values in each b2/mh/bh/kh column
    # paper Fig. 7 bottom: means of kc per position; table rounding explains up to ~0.12
    paper = [32.3346, 47.7432, 46.5039, 65.2242, 78.7207, 83.3428]
    for pos, ref in zip(range(1, 7), paper):
        kc = np.mean([r["kc"] for r in rows if r.position == pos])
        assert_allclose(kc, ref, atol=0.15)


def test_dc_gain_is_series_stiffness():
    # eq. (8): Kp = 1/kc + 1/ks + 1/kh; eq. (13): Kp = 1/kc + 1/ks
    p = load_user_params(2, 2)
    assert_allclose(tf_user(p)(0).real, 1 / p["kc"] + 1 / p["ks"] + 1 / p["kh"], rtol=1e-10)
    q = load_user_params(1, 5)
    assert_allclose(tf_user(q)(0).real, 1 / q["kc"] + 1 / q["ks"], rtol=1e-10)


def test_model_orders():
    # Sec. II-D: 6 poles / 4 zeros and 4 poles / 2 zeros
    g11 = tf_11(load_user_params(1, 1).values)
    g7 = tf_7(load_user_params(1, 4).values)
    assert (len(g11.poles()), len(g11.zeros())) == (6, 4)
    assert (len(g7.poles()), len(g7.zeros())) == (4, 2)


def test_point_a_conversion():
    # 10 Nm/rad at r = 0.17 m is 346 N/m (seed 000 Sec. IV-B); linear kc of user 1 pos 1 = 39/0.0289
    p = load_user_params(1, 1)
    assert_allclose(p.to_linear()["kc"], 1349.481, rtol=1e-6)


@pytest.mark.parametrize("user,position", [(0, 1), (14, 1), (1, 0), (1, 7), ("1", 1), (1.5, 2), (True, 1)])
def test_unknown_user_or_position(user, position):
    with pytest.raises(HapticDataError, match="unknown"):
        load_user_params(user, position)


def test_missing_value_for_structure():
    with pytest.raises(HapticDataError, match="needs b2, mh, bh, kh"):
        load_user_params(1, 4, structure=11)
    with pytest.raises(HapticDataError, match="unknown structure"):
        load_user_params(1, 4, structure=5)
    with pytest.raises(HapticDataError, match="missing parameter"):
        tf_11(load_user_params(1, 4).values)


def test_zero_as_replaces_printed_zeros():
    # user 8 pos 2: m2 printed as 0 (< 0.001 g.m2)
    assert load_user_params(8, 2)["m2"] == 0.0
    assert_allclose(load_user_params(8, 2, zero_as=5e-4)["m2"], 5e-7)
    with pytest.raises(HapticDataError):
        load_user_params(8, 2, zero_as=0.01)


def test_arm_tables():
    # seed 001 Table II, X axis; Table I Z 2 N
    a = load_arm_params("X")
    assert (a.M, a.k1, a.k2, a.b1, a.b2) == (0.2179, 379.5, 78.75, 1.839, 4.645)
    assert load_arm_params("Z", 2).k1 == 868.3
    # eq. (1): DC compliance = 1/k1 + 1/k2
    assert_allclose(tf_arm(a)(0).real, 1 / 379.5 + 1 / 78.75, rtol=1e-12)
    with pytest.raises(HapticDataError):
        load_arm_params("W")
    with pytest.raises(HapticDataError):
        load_arm_params("X", 4)


def test_uncertainty_weights():
    w = load_uncertainty_weight("X", "max")
    assert w.K == 1.322 and len(w.zeros) == 10 and len(w.poles) == 10 and not w.garbled
    assert len(load_uncertainty_weight("X", "67ci").poles) == 8
    assert load_uncertainty_weight("Z", "67ci").garbled
    assert all(np.real(w.poles) < 0) and all(np.real(w.zeros) < 0)
    with pytest.raises(HapticDataError):
        load_uncertainty_weight("X", "95ci")
