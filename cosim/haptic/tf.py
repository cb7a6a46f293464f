"""Transfer functions of the haptic device + user models (seed 000 eqs. 2, 9) and the Fu arm (seed 001 eq. 1).

Device + user, input motor torque at the phi axis (N.m), output encoder angle (rad):

* 11-parameter, eq. (2): ``G = (ph p2 - ps^2) / ((ph p2 - ps^2) p1 - pc^2 ph)`` with
  ``pc = bc s + kc``, ``ps = bs s + ks``, ``p1 = m1 s^2 + b1 s + pc``, ``p2 = m2 s^2 + b2 s + pc + ps``,
  ``ph = mh s^2 + bh s + kh + ps`` (p1, p2, ph are lost in the text extraction and reconstructed so that
  G(0) = 1/kc + 1/ks + 1/kh, eq. 8; see cosim/data/README.md).
* 7-parameter, eq. (9): ``H = q2 / (q2 q1 - qc^2)`` with ``qc = bc s + kc``, ``q1 = m1 s^2 + b1 s + qc``,
  ``q2 = m2 s^2 + bs s + ks + qc``.

Fu arm, eq. (1): ``H_arm = (M s^2 + (b1+b2) s + k1 + k2) / ((b1 s + k1)(M s^2 + b2 s + k2))``, force at the
stylus (N) to stylus position (m).
"""

import numpy as np
from numpy.polynomial import polynomial as P

import control

from cosim.haptic.params import PARAMS_11, PARAMS_7, HapticParams, ArmParams, R_POINT_A
from cosim.errors import HapticDataError

__all__ = [
    "tf_11",
    "tf_7",
    "tf_user",
    "tf_arm",
    "tf_device_arm",
    "uncertainty_weight_tf",
]


def _poly(*coeffs_high_first):
    """Polynomial coefficients, lowest order first (numpy.polynomial convention)."""
    return np.array(coeffs_high_first[::-1], dtype=float)


def _tf(num_low, den_low):
    num = np.trim_zeros(num_low[::-1], "f")
    den = np.trim_zeros(den_low[::-1], "f")
    return control.tf(num, den)


def _need(values, names):
    missing = [n for n in names if n not in values]
    if missing:
        raise HapticDataError(f"missing parameter(s) {', '.join(missing)}; the model needs {', '.join(names)}")
    return [float(values[n]) for n in names]


def tf_11(values):
    """Return G(s) = phi/tau of the 11-parameter device + user model (eq. 2), rad/(N.m).

    Parameters
    ----------
    values : mapping of str to float
        m1, b1, bc, kc, m2, b2, bs, ks, mh, bh, kh in SI units at the phi axis.

    Returns
    -------
    control.TransferFunction
    """
    m1, b1, bc, kc, m2, b2, bs, ks, mh, bh, kh = _need(values, PARAMS_11)
    pc = _poly(bc, kc)
    ps = _poly(bs, ks)
    p1 = P.polyadd(_poly(m1, b1, 0.0), pc)
    p2 = P.polyadd(P.polyadd(_poly(m2, b2, 0.0), pc), ps)
    ph = P.polyadd(_poly(mh, bh, kh), ps)
    num = P.polysub(P.polymul(ph, p2), P.polymul(ps, ps))
    den = P.polysub(P.polymul(num, p1), P.polymul(P.polymul(pc, pc), ph))
    return _tf(num, den)


def tf_7(values):
    """Return H(s) = phi/tau of the 7-parameter device + user model (eq. 9), rad/(N.m).

    Parameters
    ----------
    values : mapping of str to float
        m1, b1, bc, kc, m2, bs, ks in SI units at the phi axis.

    Returns
    -------
    control.TransferFunction
    """
    m1, b1, bc, kc, m2, bs, ks = _need(values, PARAMS_7)
    qc = _poly(bc, kc)
    q1 = P.polyadd(_poly(m1, b1, 0.0), qc)
    q2 = P.polyadd(_poly(m2, bs, ks), qc)
    den = P.polysub(P.polymul(q2, q1), P.polymul(qc, qc))
    return _tf(q2, den)


def tf_user(params):
    """Return the device + user transfer function of a Table I row, with the row's structure.

    Parameters
    ----------
    params : HapticParams

    Returns
    -------
    control.TransferFunction
    """
    if not isinstance(params, HapticParams):
        raise TypeError(f"params must be a HapticParams (from load_user_params); got {type(params).__name__}")
    return tf_11(params.values) if params.structure == 11 else tf_7(params.values)


def tf_arm(arm):
    """Return H_arm(s) = X/F of the five-parameter arm model (seed 001 eq. 1), m/N.

    Parameters
    ----------
    arm : ArmParams or mapping
        M (kg), k1, k2 (N/m), b1, b2 (N.s/m).

    Returns
    -------
    control.TransferFunction
    """
    if isinstance(arm, ArmParams):
        M, k1, k2, b1, b2 = arm.M, arm.k1, arm.k2, arm.b1, arm.b2
    else:
        M, k1, k2, b1, b2 = _need(arm, ("M", "k1", "k2", "b1", "b2"))
    num = [M, b1 + b2, k1 + k2]
    den = [b1 * M, b1 * b2 + k1 * M, b2 * k1 + b1 * k2, k1 * k2]
    return control.tf(num, den)


def tf_device_arm(device, arm, r=R_POINT_A):
    """Return phi/tau of the PHANToM device with the Fu arm attached at point A.

    The arm's linear parameters become phi-axis ones by multiplying by r**2, and the arm plays the 11-parameter
    user (ks, bs = k1, b1; mh, bh, kh = M, b2, k2).

    Parameters
    ----------
    device : mapping of str to float
        m1, b1, bc, kc, m2, b2 at the phi axis (SI).
    arm : ArmParams
    r : float, optional
        Lever arm of point A, m (default 0.17).

    Returns
    -------
    control.TransferFunction
    """
    values = dict(zip(("m1", "b1", "bc", "kc", "m2", "b2"), _need(device, ("m1", "b1", "bc", "kc", "m2", "b2"))))
    values.update(arm.to_rotational(r))
    return tf_11(values)


def uncertainty_weight_tf(weight):
    """Return V(s) = K prod(s - z_i)/prod(s - p_i) (seed 001 eq. 5) as a real transfer function.

    Parameters
    ----------
    weight : UncertaintyWeight

    Returns
    -------
    control.TransferFunction
    """
    num = weight.K * np.real(np.poly(weight.zeros))
    den = np.real(np.poly(weight.poles))
    return control.tf(num, den)
