"""A PD controller holding a body at a position: F = Kp (x_set - x) - Kd v (docs/guide/ssp.md)."""

import numpy as np

from cosim import Controller


def hold_kernel(t, u, y, x, p):
    """One sample: u = [x, v], y = [F], p = [Kp, Kd, x_set]."""
    y[0] = p[0] * (p[2] - u[0]) - p[1] * u[1]


class Hold(Controller):
    """Position PD. Inputs ``x`` (m) and ``v`` (m/s); output ``F`` (N)."""

    parameters = {"Kp": 200.0, "Kd": 20.0, "x_set": 0.05}
    inputs = ("x", "v")
    outputs = ("F",)
    units = {"x": "m", "v": "m/s", "F": "N", "Kp": "N/m", "Kd": "N.s/m", "x_set": "m"}
    kernel = staticmethod(hold_kernel)

    def pack(self):
        return np.array([self.values["Kp"], self.values["Kd"], self.values["x_set"]])
