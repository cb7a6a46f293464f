"""A minimal controller: a speed PI for the gripper's motor, commanding the FOC's q-axis current.

    i_q_ref = Kp e + I,   I <- I + Ki e T,   e = w_set - w,   w_set a step to speed_rpm at t_step,

the output saturated to +-i_max, the integral held while it saturates (anti-windup).
Run it: cosim run examples/controller/speed_pi.toml; its test: python3 -m pytest examples/controller.
Guide: docs/guide/controller.md.
"""

import math

import numpy as np

from cosim import Controller

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm


def speed_pi_kernel(t, u, y, x, p):
    """One sample: u = [w], y = [i_q_ref, w_set], x = [integral], p = [Kp, Ki T, i_max, w_set, t_step]."""
    w_set = p[3] if t >= p[4] else 0.0
    e = w_set - u[0]
    i = p[0] * e + x[0]
    if abs(i) < p[2]:
        x[0] += p[1] * e
    y[0] = min(max(i, -p[2]), p[2])
    y[1] = w_set


class SpeedPI(Controller):
    """Speed PI. Input ``w`` (rad/s); outputs ``i_q_ref`` (A) and ``w_set`` (rad/s, the reference)."""

    parameters = {"Kp": 0.01, "Ki": 0.5, "i_max": 2.0, "speed_rpm": 300.0, "t_step": 0.01}
    inputs = ("w",)
    outputs = ("i_q_ref", "w_set")
    units = {"w": "rad/s", "i_q_ref": "A", "w_set": "rad/s", "Kp": "A.s/rad", "Ki": "A/rad", "i_max": "A",
             "speed_rpm": "rpm", "t_step": "s"}
    kernel = staticmethod(speed_pi_kernel)

    def pack(self):
        v = self.values
        if not v["i_max"] > 0:
            raise ValueError(f"SpeedPI: parameter 'i_max' must be > 0; got {v['i_max']!r}")
        return np.array([v["Kp"], v["Ki"] * self.dt, v["i_max"], v["speed_rpm"] * RPM, v["t_step"]])

    def initial_state(self):
        return np.zeros(1)

    @classmethod
    def scenario(cls, values):
        return f"speed step to {values.get('speed_rpm', cls.parameters['speed_rpm']):g} rpm"
