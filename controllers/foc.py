"""Field-oriented current control of a PMSM (the gripper's 26.6 kHz inner loop).

Signal path per sample (all transforms amplitude-invariant):

1. phase-current sensing: the plant's d/q currents are turned into phase currents a, b, c with the
   true electrical angle (inverse Park, inverse Clarke), as the board's current sensors see them;
2. Clarke and Park with the *measured* electrical angle (encoder quantised to ``enc_cpt`` counts per
   turn; 0 = exact) give the measured i_d, i_q;
3. two PI current loops (d and q; i_d -> ``i_d_ref`` = 0) with back-EMF and cross-coupling
   decoupling, voltage limited to the bus (``V_bus / sqrt(3)`` for space-vector PWM, ``V_bus / 2``
   for sine PWM, times sqrt(3/2) for a power-invariant plant frame; the d axis has priority) and back-calculation anti-windup;
4. inverse Park with the measured angle, and the inverter applies the voltage in the plant's frame.

Gains (a stated bandwidth, from the motor parameters): the PI zero cancels the discrete R-L pole
``a = exp(-R T / L)`` of each axis sampled with zero-order hold at ``T = 1 / rate``, and the gain
puts the closed-loop pole at ``p = exp(-2 pi f_bw T)``: with the decoupling, a current step follows
``1 - p**k`` at the samples, a first-order response with time constant ``1 / (2 pi f_bw)``.
``Kp = (1 - p) R / (1 - a)`` (-> ``L 2 pi f_bw`` for f_bw T << 1) and the integral gain per second
``Kp (1 - a) / T`` (-> ``R 2 pi f_bw``), as in Modelica's DQCurrentController.
"""

import math

import numpy as np

from cosim.controller import Controller

__all__ = ["FOC", "foc_gains"]

TWO_PI = 2.0 * math.pi
SQRT3_2 = math.sqrt(3.0) / 2.0

# indices into p
_KPD, _KID, _KPQ, _KIQ, _LD, _LQ, _PP, _PSI, _VMAX, _CPT, _IDREF, _DEC = range(12)


def foc_gains(R, L, rate, bandwidth_hz):
    """Return ``(Kp, Ki_per_sample)`` of one axis for the discrete pole-placement design above.

    Parameters
    ----------
    R : float
        Phase resistance (ohm).
    L : float
        Axis inductance (H).
    rate : float
        Sample rate (Hz).
    bandwidth_hz : float
        Closed-loop bandwidth (Hz); time constant ``1 / (2 pi bandwidth_hz)``.
    """
    T = 1.0 / rate
    a = math.exp(-R * T / L)
    p = math.exp(-TWO_PI * bandwidth_hz * T)
    kp = (1.0 - p) * R / (1.0 - a)
    return kp, kp * (1.0 - a)


def _foc_kernel(t, u, y, x, p):
    iq_ref = u[0]
    i_d = u[1]
    i_q = u[2]
    th = u[3]
    w = u[4]
    pp = p[_PP]
    the = pp * th
    cpt = p[_CPT]
    if cpt > 0.0:
        thm = math.floor(th * cpt / TWO_PI) * (TWO_PI / cpt)
    else:
        thm = th
    them = pp * thm
    # 1. phase currents seen by the sensors (true angle)
    c = math.cos(the)
    s = math.sin(the)
    ial = i_d * c - i_q * s
    ibe = i_d * s + i_q * c
    ia = ial
    ib = -0.5 * ial + SQRT3_2 * ibe
    # 2. Clarke + Park with the measured angle
    al = ia
    be = (ia + 2.0 * ib) / math.sqrt(3.0)
    cm = math.cos(them)
    sm = math.sin(them)
    idm = al * cm + be * sm
    iqm = -al * sm + be * cm
    # 3. PI + decoupling + limit + anti-windup
    ed = p[_IDREF] - idm
    eq = iq_ref - iqm
    we = pp * w
    ffd = 0.0
    ffq = 0.0
    if p[_DEC] > 0.5:
        ffd = -we * p[_LQ] * iqm
        ffq = we * (p[_LD] * idm + p[_PSI])
    vd = p[_KPD] * ed + x[0] + ffd
    vq = p[_KPQ] * eq + x[1] + ffq
    vmax = p[_VMAX]
    vds = min(max(vd, -vmax), vmax)
    vqmax = math.sqrt(max(vmax * vmax - vds * vds, 0.0))
    vqs = min(max(vq, -vqmax), vqmax)
    x[0] += p[_KID] * ed + (vds - vd)
    x[1] += p[_KIQ] * eq + (vqs - vq)
    # 4. inverse Park (measured angle) -> inverter -> plant frame (true angle)
    val = vds * cm - vqs * sm
    vbe = vds * sm + vqs * cm
    y[0] = val * c + vbe * s
    y[1] = -val * s + vbe * c
    y[2] = idm
    y[3] = iqm


class FOC(Controller):
    """Field-oriented current controller (d/q PI, decoupling, bus limit, anti-windup).

    Inputs: ``i_q_ref`` (A), ``i_d``, ``i_q`` (A, plant frame), ``theta_m`` (rad, mechanical),
    ``w_m`` (rad/s, mechanical). Outputs: ``v_d``, ``v_q`` (V, plant frame) and the measured
    ``i_d_meas``, ``i_q_meas`` (A).

    Parameters (defaults: the gripper estimates of gripper_params.csv): ``R_s`` (ohm), ``L_d``,
    ``L_q`` (H), ``pole_pairs``, ``psi_m`` (Wb, back-EMF ``pole_pairs * w * psi_m`` on the q axis),
    ``V_bus`` (V), ``modulation`` ("svpwm" or "sine"), ``park`` ("power": the plant's d/q quantities
    use the power-invariant Park transform, so the bus limit on ``|v_dq|`` is sqrt(3/2) times the
    phase-voltage amplitude limit; "amplitude": amplitude-invariant), ``bandwidth_hz`` (Hz), ``enc_cpt``
    (encoder counts per turn, 0 = exact angle), ``i_d_ref`` (A), ``decouple`` (bool).
    """

    parameters = {
        "R_s": 0.45,
        "L_d": 2.5e-4,
        "L_q": 2.5e-4,
        "pole_pairs": 4.0,
        "psi_m": 0.009848,
        "V_bus": 24.0,
        "modulation": ("svpwm", "sine"),
        "park": ("power", "amplitude"),
        "bandwidth_hz": 1000.0,
        "enc_cpt": 2048.0,
        "i_d_ref": 0.0,
        "decouple": True,
    }
    inputs = ("i_q_ref", "i_d", "i_q", "theta_m", "w_m")
    outputs = ("v_d", "v_q", "i_d_meas", "i_q_meas")
    units = {"i_q_ref": "A", "i_d": "A", "i_q": "A", "theta_m": "rad", "w_m": "rad/s", "v_d": "V", "v_q": "V",
             "i_d_meas": "A", "i_q_meas": "A", "R_s": "Ohm", "L_d": "H", "L_q": "H", "psi_m": "Wb", "V_bus": "V",
             "bandwidth_hz": "Hz", "i_d_ref": "A"}
    limits = {"R_s": "(0, inf)", "L_d": "(0, inf)", "L_q": "(0, inf)", "pole_pairs": "integer [1, inf)",
              "psi_m": "[0, inf)", "V_bus": "(0, inf)", "bandwidth_hz": "(0, inf)", "enc_cpt": "integer [0, inf)",
              "i_d_ref": "(-inf, inf)"}
    kernel = staticmethod(_foc_kernel)

    def pack(self):
        v = self.values
        if v["bandwidth_hz"] >= self.rate / 2:
            self.refuse("bandwidth_hz", f"below half the rate ({self.rate / 2:g} Hz)", v["bandwidth_hz"])
        kpd, kid = foc_gains(v["R_s"], v["L_d"], self.rate, v["bandwidth_hz"])
        kpq, kiq = foc_gains(v["R_s"], v["L_q"], self.rate, v["bandwidth_hz"])
        vmax = v["V_bus"] / math.sqrt(3.0) if v["modulation"] == "svpwm" else v["V_bus"] / 2.0
        if v["park"] == "power":  # |v_dq| = sqrt(3/2) x phase amplitude with the power-invariant transform
            vmax *= math.sqrt(1.5)
        return np.array([kpd, kid, kpq, kiq, v["L_d"], v["L_q"], v["pole_pairs"], v["psi_m"], vmax,
                         v["enc_cpt"], v["i_d_ref"], float(bool(v["decouple"]))])

    def initial_state(self):
        return np.zeros(2)

    @property
    def time_constant(self):
        """Designed closed-loop time constant in s: ``1 / (2 pi bandwidth_hz)``."""
        return 1.0 / (TWO_PI * self.values["bandwidth_hz"])
