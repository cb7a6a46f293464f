"""Haptic rendering controllers of seed 000 (Puerto et al. 2012, Sec. IV-V) and a user-intent source.

VirtualWall
    One-sided viscoelastic wall at ``phi_wall`` (rad), rendered at the controller rate; the torque is held
    (zero-order hold) by the master until the next sample; ``tau_step`` (N.m) is added to the command from
    ``t_step`` on (a motor-torque step: with the stylus resting in the wall, phi/tau_step has the shape of the
    closed-loop step response K G/(1 + K G) the margins predict)::

        pen = phi - phi_wall   (the wall occupies phi > phi_wall; the user approaches from below)
        v   = (phi_n - phi_{n-1}) / T            (backward difference of the encoder angle)
        tau = -(K pen + B v)  if pen > 0,  else 0

    With pen > 0 this is C(z) = K + B (1 - z^-1)/T of cosim.haptic.margins, applied without delay
    (the loop of eq. 15). K = 10 N.m/rad and B = 0 are the paper's wall (346 N/m at point A).
AdaptiveWall
    The same wall with B taken from a per-grasp-position table (seed 000 Sec. V, Table II, lost in the text
    extraction and re-derived by cosim.haptic.margins.adaptive_damping for user 1: PM >= 50 deg).
    The grasp position is a parameter (the paper detected it by vision; here each run has one position).
UserIntent
    The hand's intended position ``phi_ref`` (the reference of the user's grounded elements in the Haptic
    FMUs) moves from ``phi_start`` towards the wall at ``v_approach`` (rad/s), with a smooth start over
    ``accel_s``, and stops at ``phi_end``; ``tau_h`` (extra hand torque) steps to ``tau_push`` at
    ``t_push``. With ``tau_final`` > 0 and ``k_user`` > 0, ``phi_end`` is set so that the steady wall torque is
    ``tau_final``: phi_end = phi_wall + tau_final (1/K_wall + 1/k_user), k_user the static stiffness from the
    encoder to the hand reference (kc, ks, kh in series = 1/Kp of eq. 8, or kc, ks = 1/Kp of eq. 13). Same
    intent -> same approach velocity and same final force in every run.
"""


import numpy as np

from cosim.controller import Controller

__all__ = ["VirtualWall", "AdaptiveWall", "UserIntent"]

# VirtualWall / AdaptiveWall packed parameters: phi_wall, K, B, T, t_step, tau_step
_PW, _K, _B, _T, _TS, _TAUS = range(6)


def _wall_kernel(t, u, y, x, p):
    phi = u[0]
    if x[1] == 0.0:  # first sample: no velocity estimate yet
        x[0] = phi
        x[1] = 1.0
    v = (phi - x[0]) / p[_T]
    x[0] = phi
    pen = phi - p[_PW]
    if pen > 0.0:
        y[0] = -(p[_K] * pen + p[_B] * v)
    else:
        y[0] = 0.0
    if t >= p[_TS]:
        y[0] += p[_TAUS]
    y[1] = pen if pen > 0.0 else 0.0
    y[2] = v


class VirtualWall(Controller):
    """One-sided spring-damper wall on the phi axis.

    Input ``phi`` (rad, encoder). Outputs ``tau`` (N.m, motor torque command), ``penetration`` (rad, >= 0),
    ``velocity`` (rad/s, backward difference).
    """

    parameters = {"phi_wall": 0.7, "K": 10.0, "B": 0.0, "t_step": 1e9, "tau_step": 0.0}
    inputs = ("phi",)
    outputs = ("tau", "penetration", "velocity")
    units = {"phi": "rad", "tau": "N.m", "penetration": "rad", "velocity": "rad/s", "phi_wall": "rad",
             "K": "N.m/rad", "B": "N.m.s/rad", "t_step": "s", "tau_step": "N.m"}
    limits = {"phi_wall": "(-inf, inf)", "K": "[0, inf)", "B": "[0, inf)", "t_step": "(-inf, inf]",
              "tau_step": "(-inf, inf)"}
    kernel = staticmethod(_wall_kernel)

    def _damping(self):
        return float(self.values["B"])

    def pack(self):
        v = self.values
        B = self._damping()
        return np.array([float(v["phi_wall"]), float(v["K"]), B, self.dt, float(v["t_step"]), float(v["tau_step"])])

    def initial_state(self):
        return np.zeros(2)


# B per grasp position tuned on user 1 of Table I for PM >= 50 deg at K = 10 N.m/rad, 1 kHz
# (cosim.haptic.margins.adaptive_damping(user=1); tests/test_haptic_controllers.py checks the values)
ADAPTIVE_B_USER1 = (0.0, 0.0, 0.0265, 0.0297, 0.0943, 0.1193)


class AdaptiveWall(VirtualWall):
    """Virtual wall whose damping is picked from a per-grasp-position table (B1..B6, N.m.s/rad).

    ``position`` (1..6) selects the entry; the defaults are the user-1 table re-derived for seed 000 Table II.
    """

    parameters = {"phi_wall": 0.7, "K": 10.0, "t_step": 1e9, "tau_step": 0.0, "position": 1,
                  **{f"B{i}": b for i, b in enumerate(ADAPTIVE_B_USER1, start=1)}}
    units = {**VirtualWall.units, **{f"B{i}": "N.m.s/rad" for i in range(1, 7)}, "position": "1"}
    limits = {**VirtualWall.limits, "position": "integer [1, 6]", **{f"B{i}": "[0, inf)" for i in range(1, 7)}}
    kernel = staticmethod(_wall_kernel)

    def _damping(self):
        return float(self.values[f"B{int(self.values['position'])}"])


# UserIntent packed parameters
_PS, _VA, _T0, _ACC, _PE, _TP, _TAUP = range(7)


def _intent_kernel(t, u, y, x, p):
    s = t - p[_T0]
    if s <= 0.0:
        ref = p[_PS]
    else:
        a = p[_ACC]
        # smooth start: velocity ramps linearly from 0 to v over a, then constant
        if s < a:
            d = 0.5 * p[_VA] * s * s / a
        else:
            d = 0.5 * p[_VA] * a + p[_VA] * (s - a)
        ref = p[_PS] + d if p[_PE] >= p[_PS] else p[_PS] - d
        if (p[_PE] - ref) * (p[_PE] - p[_PS]) <= 0.0:
            ref = p[_PE]
    y[0] = ref
    y[1] = p[_TAUP] if t >= p[_TP] else 0.0


class UserIntent(Controller):
    """User-intent source: the hand's reference position and an extra hand torque.

    Outputs ``phi_ref`` (rad, to the FMU input of the same name) and ``tau_h`` (N.m).
    """

    parameters = {"phi_start": 0.0, "v_approach": 0.5, "t_start": 0.0, "accel_s": 0.1, "phi_end": 0.75,
                  "tau_final": 0.0, "phi_wall": 0.7, "K_wall": 10.0, "k_user": 0.0, "t_push": 1e9, "tau_push": 0.0}
    outputs = ("phi_ref", "tau_h")
    units = {"phi_ref": "rad", "tau_h": "N.m", "phi_start": "rad", "v_approach": "rad/s", "t_start": "s",
             "accel_s": "s", "phi_end": "rad", "tau_final": "N.m", "phi_wall": "rad", "K_wall": "N.m/rad",
             "k_user": "N.m/rad", "t_push": "s", "tau_push": "N.m"}
    limits = {"phi_start": "(-inf, inf)", "v_approach": "(0, inf)", "t_start": "(-inf, inf)", "accel_s": "(0, inf)",
              "phi_end": "(-inf, inf)", "tau_final": "[0, inf)", "phi_wall": "(-inf, inf)", "K_wall": "[0, inf)",
              "k_user": "[0, inf)", "t_push": "(-inf, inf]", "tau_push": "(-inf, inf)"}
    kernel = staticmethod(_intent_kernel)

    def pack(self):
        v = self.values
        phi_end = float(v["phi_end"])
        if v["tau_final"] > 0:
            for name in ("k_user", "K_wall"):
                if not v[name] > 0:
                    self.refuse(name, f"a number in (0, inf) {self.units[name]} when tau_final > 0 (it places "
                                      f"phi_end)", v[name])
            phi_end = v["phi_wall"] + v["tau_final"] * (1.0 / v["K_wall"] + 1.0 / v["k_user"])
        return np.array([float(v["phi_start"]), float(v["v_approach"]), float(v["t_start"]), float(v["accel_s"]),
                         phi_end, float(v["t_push"]), float(v["tau_push"])])

    @property
    def phi_end(self):
        """The end of the reference ramp actually used (rad)."""
        return float(self.p[_PE])
