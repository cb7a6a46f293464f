"""Cascaded control of a brushed DC drive: a speed PI (1 kHz) commanding a current PI (20 kHz, the PWM rate).

Two controllers, each at its real rate (examples/msl_drive/drive.toml): the master runs the speed loop first at the
instants they share, so the current loop reads the new current reference at once.

DcCurrentPI (inner loop, e.g. 20 kHz)
    ``v = Kp e + I + k_e w`` with ``e = i_ref - i``, the back-EMF ``k_e w`` fed forward; ``v`` saturated to
    ``+-V_bus`` (a full H-bridge, PWM averaged over a period); back-calculation anti-windup ``I += Ki e + (v_sat -
    v)``. Gains for a stated bandwidth from the armature's ``R`` and ``L`` by the FOC's design
    (:func:`controllers.foc.foc_gains`): the PI zero cancels the sampled R-L pole, the closed-loop pole is at
    ``exp(-2 pi f_bw T)``, so a current step follows a first-order response of time constant ``1 / (2 pi f_bw)``.
DcSpeedPI (outer loop, e.g. 1 kHz)
    ``i_ref = Kp e + I`` with ``e = w_ref - w`` (motor speed, rad/s), saturated to ``+-i_max`` (the current limit)
    with the same anti-windup. Gains for a crossover ``f_c`` on the rigid drive ``k / (J s)`` (``J`` the inertia
    seen at the motor shaft): ``Kp = J 2 pi f_c / k`` and the integral's zero a quarter of the crossover below it,
    ``Ki = Kp 2 pi f_c / 4`` per second. The reference ``w_ref`` is a trapezoid: 0 before ``t_start``, a ramp to
    ``speed_rpm`` over ``ramp_s`` (0: a step), held until ``t_down`` (infinite: for ever), then a ramp back to 0.
"""

import math

import numba
import numpy as np

from cosim.controller import Controller
from cosim_controllers.foc import foc_gains

__all__ = ["DcCurrentPI", "DcSpeedPI", "pi_step", "trapezoid"]

TWO_PI = 2.0 * math.pi
RPM = TWO_PI / 60.0

# DcCurrentPI packed parameters
_CKP, _CKI, _CKE, _CVMAX = range(4)
# DcSpeedPI packed parameters
_SKP, _SKI, _SIMAX, _SW, _ST0, _SRAMP, _STDOWN = range(7)


@numba.njit(cache=True)
def pi_step(e, ff, kp, ki, lo, hi, x, j):
    """One sample of a PI with feedforward ``ff``, output limits ``[lo, hi]`` and back-calculation anti-windup.

    The integral is ``x[j]`` (updated in place); ``ki`` is the integral gain per sample. Returns the saturated
    output ``min(max(kp e + x[j] + ff, lo), hi)``.
    """
    u = kp * e + x[j] + ff
    us = min(max(u, lo), hi)
    x[j] += ki * e + (us - u)
    return us


@numba.njit(cache=True)
def trapezoid(t, w, t0, ramp, t_down):
    """Speed reference at ``t``: 0 before ``t0``, ramp to ``w`` over ``ramp`` s (0: a step), back to 0 from ``t_down``."""
    if t < t0:
        return 0.0
    up = 1.0 if ramp <= 0.0 else min((t - t0) / ramp, 1.0)
    if t < t_down:
        return w * up
    down = 0.0 if ramp <= 0.0 else max(1.0 - (t - t_down) / ramp, 0.0)
    return w * min(up, down)


def _current_kernel(t, u, y, x, p):
    y[0] = pi_step(u[0] - u[1], p[_CKE] * u[2], p[_CKP], p[_CKI], -p[_CVMAX], p[_CVMAX], x, 0)


def _speed_kernel(t, u, y, x, p):
    w_ref = trapezoid(t, p[_SW], p[_ST0], p[_SRAMP], p[_STDOWN])
    y[0] = pi_step(w_ref - u[0], 0.0, p[_SKP], p[_SKI], -p[_SIMAX], p[_SIMAX], x, 0)
    y[1] = w_ref


class DcCurrentPI(Controller):
    """Armature current PI of a brushed DC motor (back-EMF feedforward, supply limit, anti-windup).

    Inputs: ``i_ref`` (A), ``i`` (measured armature current, A), ``w`` (motor speed, rad/s, for the back-EMF
    feedforward). Output: ``v`` (armature voltage, V). Parameters: ``R`` (ohm), ``L`` (H), ``k_e`` (back-EMF
    constant, V.s/rad; 0: no feedforward), ``V_bus`` (V), ``bandwidth_hz`` (Hz, below half the rate). Defaults:
    the motor of examples/msl_drive/DcDrive.mo.
    """

    parameters = {"R": 1.0, "L": 2e-4, "k_e": 0.03, "V_bus": 24.0, "bandwidth_hz": 2000.0}
    inputs = ("i_ref", "i", "w")
    outputs = ("v",)
    units = {"i_ref": "A", "i": "A", "w": "rad/s", "v": "V", "R": "Ohm", "L": "H", "k_e": "V.s/rad", "V_bus": "V",
             "bandwidth_hz": "Hz"}
    limits = {"R": "(0, inf)", "L": "(0, inf)", "k_e": "[0, inf)", "V_bus": "(0, inf)", "bandwidth_hz": "(0, inf)"}
    kernel = staticmethod(_current_kernel)

    def pack(self):
        v = self.values
        if v["bandwidth_hz"] >= self.rate / 2:
            self.refuse("bandwidth_hz", f"below half the rate ({self.rate / 2:g} Hz)", v["bandwidth_hz"])
        kp, ki = foc_gains(v["R"], v["L"], self.rate, v["bandwidth_hz"])
        return np.array([kp, ki, v["k_e"], v["V_bus"]])

    def initial_state(self):
        return np.zeros(1)


class DcSpeedPI(Controller):
    """Speed PI of a DC drive with a current limit and a trapezoidal (or step) speed reference.

    Input: ``w`` (motor speed, rad/s). Outputs: ``i_ref`` (A, to the current loop) and ``w_ref`` (rad/s, the
    reference). Parameters: ``J`` (inertia at the motor shaft, kg.m2: rotor plus load / ratio^2), ``k_t`` (N.m/A),
    ``crossover_hz`` (Hz), ``i_max`` (A), ``speed_rpm`` (motor rpm), ``t_start``, ``ramp_s`` (0: a step),
    ``t_down`` (s; inf: no way down). Defaults: the drive of examples/msl_drive/DcDrive.mo.
    """

    parameters = {"J": 2.2755e-5, "k_t": 0.03, "crossover_hz": 20.0, "i_max": 3.0, "speed_rpm": 4000.0,
                  "t_start": 0.01, "ramp_s": 0.0, "t_down": math.inf}
    inputs = ("w",)
    outputs = ("i_ref", "w_ref")
    units = {"w": "rad/s", "i_ref": "A", "w_ref": "rad/s", "J": "kg.m2", "k_t": "N.m/A", "crossover_hz": "Hz",
             "i_max": "A", "speed_rpm": "rpm", "t_start": "s", "ramp_s": "s", "t_down": "s"}
    limits = {"J": "(0, inf)", "k_t": "(0, inf)", "crossover_hz": "(0, inf)", "i_max": "(0, inf)",
              "speed_rpm": "(-inf, inf)", "t_start": "(-inf, inf)", "ramp_s": "[0, inf)", "t_down": "(-inf, inf]"}
    kernel = staticmethod(_speed_kernel)

    @classmethod
    def scenario(cls, values):
        """The speed reference and the current limit, e.g. "speed step to 4000 rpm at 0.01 s, 3 A limit"."""
        v = {**cls.parameters, **values}
        shape = f"ramp to {v['speed_rpm']:g} rpm in {v['ramp_s']:g} s" if v["ramp_s"] > 0 else \
            f"step to {v['speed_rpm']:g} rpm"
        down = f", back to 0 from {v['t_down']:g} s" if math.isfinite(v["t_down"]) else ""
        return f"speed {shape} at {v['t_start']:g} s{down}, {v['i_max']:g} A limit"

    def pack(self):
        v = self.values
        if v["crossover_hz"] >= self.rate / 10:
            self.refuse("crossover_hz", f"below a tenth of the rate ({self.rate / 10:g} Hz)", v["crossover_hz"])
        wc = TWO_PI * v["crossover_hz"]
        kp = v["J"] * wc / v["k_t"]
        return np.array([kp, kp * wc / 4.0 * self.dt, v["i_max"], v["speed_rpm"] * RPM, v["t_start"], v["ramp_s"],
                         v["t_down"]])

    def initial_state(self):
        return np.zeros(1)
