"""The gripper's 100 Hz outer loop: velocity PID, dead-zone compensation, impact trigger, mode switch,
and the test profiles (impact trial and static current staircase), after section 3.1 of the paper.

Speed estimate
    ``w_n = (q_n - q_{n-1}) / T`` with ``q`` the motor angle quantised to ``enc_cpt`` counts per turn.
Velocity PID (velocity mode)
    ``i_PID = Kp e + Ki sum(e) T + Kd (e_n - e_{n-1}) / T`` with ``e = w_set - w``; the integral stops
    while the output saturates at ``i_max`` (anti-windup).
Dead-zone compensation, eq. (1)
    ``i_q,ref = sign(e) i_min`` if ``|e| > e_min`` and ``|i_PID| < i_min``, else ``i_PID``.
Impact trigger, eq. (2)
    fires when ``w_n <= w_{n-1} <= w_{n-2} <= w_{n-3}`` and ``w_n <= Thr w_{n-3}`` (speeds taken in
    the closing direction), on the same differenced encoder speed at 100 Hz as the PID, unfiltered.
    Arming (not in eq. (2); the paper switches "following the drive to the desired velocity"): the
    trigger is armed once a speed sample has reached ``arm_fraction`` of the set speed ``speed_rpm``,
    and stays armed until it fires; otherwise a standing start (all samples 0) would satisfy eq. (2).
    After a stiff impact that the four-sample window misses (a one-count step up before the drop, a
    rebound), eq. (2) fires on a later window, at the latest once the motor stands still.
Mode switch
    on the trigger the loop switches to current mode with ``i_q,ref = i_tight`` for ``hold_s``
    seconds, then 0 A (release).

Profiles (``profile``)
    "impact": velocity ramp from 0 at ``t_start`` to ``speed_rpm`` in ``ramp_s``, then the trigger and
    switch above. "staircase": current mode from ``t_start``: ``step_A`` steps of ``step_s`` up to
    ``top_A`` and back down to 0 A, held at 0 A afterwards. "velocity": the ramp without the trigger.

Summaries (``OuterLoop.summaries``, chosen by a run config's ``[summary] kind``)
    "static" (:class:`StaircaseSummary`) and "impact" (:class:`ImpactSummary`): the experiment keys a run of
    the staircase or the impact trial writes to summary.json, read from the recorded force.
"""

import math

import numba
import numpy as np

from cosim.controller import Controller

__all__ = ["OuterLoop", "staircase_current", "staircase_steps", "StaircaseSummary", "ImpactSummary"]

TWO_PI = 2.0 * math.pi

# parameter indices
(_PROF, _KP, _KI, _KD, _IMAX, _IMIN, _EMIN, _THR, _CPT, _WSET, _RAMP, _T0, _ITIGHT, _HOLD, _ARM, _DIR,
 _STEPA, _STEPS, _TOPA) = range(19)
# state indices
(_QPREV, _W1, _W2, _W3, _INT, _EPREV, _MODE, _TSW, _ARMED, _N) = range(10)


@numba.njit(cache=True)
def staircase_current(t, t0, step_a, step_s, top_a):
    """Staircase set-point (A) at time ``t``: ``step_a`` steps of ``step_s`` s up to ``top_a``, back to 0.

    The first step (``step_a``) starts at ``t0``; the way down starts after the ``top_a`` step and
    ends with a 0 A step held for ever.
    """
    if t < t0:
        return 0.0
    n_up = int(math.floor(top_a / step_a + 0.5))
    k = int(math.floor((t - t0) / step_s + 1e-9))  # 0-based step index
    if k < n_up:
        return (k + 1) * step_a
    k2 = k - n_up + 1  # 1.. on the way down
    if k2 >= n_up:
        return 0.0
    return (n_up - k2) * step_a


def staircase_steps(t0, step_a, step_s, top_a):
    """Every step of the staircase of :func:`staircase_current`, for summaries and measured-data alignment.

    Parameters
    ----------
    t0 : float
        Start of the first step, s.
    step_a : float
        Current increment per step, A.
    step_s : float
        Duration of each step, s.
    top_a : float
        Highest current, A.

    Returns
    -------
    list of tuple
        ``(current_A, t_begin, t_end, branch)`` per step, branch "up" or "down".
    """
    n_up = int(math.floor(top_a / step_a + 0.5))
    out = []
    for k in range(2 * n_up):
        cur = staircase_current(t0 + (k + 0.5) * step_s, t0, step_a, step_s, top_a)
        out.append((round(cur, 10), t0 + k * step_s, t0 + (k + 1) * step_s, "up" if k < n_up else "down"))
    return out


def _window_mean(t, f, a, b):
    m = (t >= a - 1e-12) & (t < b - 1e-12)
    return float(np.mean(f[m])) if m.any() else None


class StaircaseSummary:
    """The static staircase (``profile = "staircase"``) in summary.json.

    For each staircase step (A, as a string like "1.5"), the mean force of the step's last second (the
    last half of the step when steps are shorter than 2 s) on the way up (``force_up_N``) and down
    (``force_down_N``); ``max_force_N`` (largest force over the run), ``residual_force_N`` (mean force
    of the final 0 A step after the way down) and ``staircase_window_s`` (the averaging window).
    """

    signals = ("force",)  # [summary] keys naming a recorded column
    outputs = ()  # outputs of the controller it reads

    @staticmethod
    def summarize(data, values, columns):
        """The summary keys of a run.

        Parameters
        ----------
        data : numpy.ndarray
            The recorded structured array (``time`` first).
        values : dict
            The outer loop's parameter values (``t_start``, ``step_A``, ``step_s``, ``top_A``).
        columns : dict of str to str
            ``"force"`` -> the force column (N).

        Returns
        -------
        dict
        """
        t = data["time"]
        f = data[columns["force"]]
        steps = staircase_steps(values["t_start"], values["step_A"], values["step_s"], values["top_A"])
        win = 1.0 if values["step_s"] >= 2.0 else values["step_s"] / 2.0
        up, down = {}, {}
        residual = None
        for cur, a, b, branch in steps:
            mean = _window_mean(t, f, b - win, b)
            if mean is None:
                continue
            key = f"{cur:.1f}" if abs(cur * 10 - round(cur * 10)) < 1e-9 else f"{cur:g}"
            (up if branch == "up" else down)[key] = mean
            if branch == "down" and cur == 0.0:
                residual = mean
        return {
            "max_force_N": float(np.max(f)) if len(f) else None,
            "residual_force_N": residual,
            "force_up_N": up,
            "force_down_N": down,
            "staircase_window_s": win,
        }


class ImpactSummary:
    """The impact trial (``profile = "impact"``) in summary.json.

    ``peak_force_N`` (largest force), ``min_force_after_peak_N`` (smallest force from the peak to the end
    of tightening: 0 when the finger bounces off; None when the peak comes after the tightening),
    ``steady_force_N`` (mean force over the last second of tightening, or of the recorded part of it when the run
    stops earlier, with its ``steady_window_s``),
    ``t_switch_s`` (time of the velocity-to-current switch; None when the trigger never fired) and
    ``t_contact_s`` (first time the force exceeds 1 N).
    """

    signals = ("force",)  # [summary] keys naming a recorded column
    event = "t_contact_s"  # the summary key a run's plot zooms on
    outputs = ("t_switch",)  # outputs of the controller it reads (recorded even when the config does not list them)

    @staticmethod
    def summarize(data, values, columns):
        """The summary keys of a run.

        Parameters
        ----------
        data : numpy.ndarray
            The recorded structured array (``time`` first).
        values : dict
            The outer loop's parameter values (``hold_s``).
        columns : dict of str to str
            ``"force"`` -> the force column (N); ``"t_switch"`` -> the loop's switch time column (s).

        Returns
        -------
        dict
        """
        t = data["time"]
        f = data[columns["force"]]
        col = columns["t_switch"]
        t_sw = None
        if col in data.dtype.names and len(t):
            v = float(data[col][-1])
            t_sw = v if v >= 0 else None
        out = {"peak_force_N": None, "min_force_after_peak_N": None, "steady_force_N": None,
               "t_switch_s": t_sw, "t_contact_s": None}
        if not len(f):
            return out
        ipk = int(np.argmax(f))
        end = t[-1] if t_sw is None else min(t[-1], t_sw + values["hold_s"])
        after = (t >= t[ipk]) & (t <= end + 1e-12)
        contact = np.nonzero(f > 1.0)[0]
        out["peak_force_N"] = float(f[ipk])
        out["min_force_after_peak_N"] = float(np.min(f[after])) if after.any() else None  # peak after tightening
        out["t_contact_s"] = float(t[contact[0]]) if len(contact) else None
        if t_sw is not None:
            a = max(end - 1.0, t_sw)
            m = (t >= a - 1e-12) & (t <= end + 1e-12)
            out["steady_force_N"] = float(np.mean(f[m])) if m.any() else None
            out["steady_window_s"] = [float(a), float(end)]
        return out


def _outer_kernel(t, u, y, x, p):
    T = x[_N + 1]  # sample period, stored with the state
    cpt = p[_CPT]
    th = u[0] * p[_DIR]
    if cpt > 0.0:
        q = math.floor(th * cpt / TWO_PI) * (TWO_PI / cpt)
    else:
        q = th
    n = x[_N]
    if n == 0.0:
        w = 0.0
    else:
        w = (q - x[_QPREV]) / T
    x[_QPREV] = q
    prof = p[_PROF]
    t0 = p[_T0]
    # set-point
    if t < t0:
        wset = 0.0
    elif t < t0 + p[_RAMP]:
        wset = p[_WSET] * (t - t0) / p[_RAMP]
    else:
        wset = p[_WSET]
    iq = 0.0
    if prof == 1.0:  # staircase: current mode
        x[_MODE] = 1.0
        iq = staircase_current(t, t0, p[_STEPA], p[_STEPS], p[_TOPA])
        wset = 0.0
    else:
        if x[_MODE] == 0.0 and prof == 0.0:
            # impact trigger, eq. (2), armed (latched) once the speed has reached arm_fraction of the set speed
            if x[_ARMED] == 0.0 and n >= 1.0 and p[_WSET] > 0.0 and w >= p[_ARM] * p[_WSET]:
                x[_ARMED] = 1.0
            if x[_ARMED] == 1.0 and n >= 4.0:
                if w <= x[_W1] and x[_W1] <= x[_W2] and x[_W2] <= x[_W3] and w <= p[_THR] * x[_W3]:
                    x[_MODE] = 1.0
                    x[_TSW] = t
        if x[_MODE] == 0.0:
            e = wset - w
            deriv = 0.0
            if n >= 1.0:
                deriv = (e - x[_EPREV]) / T
            x[_EPREV] = e
            ipid = p[_KP] * e + p[_KI] * (x[_INT] + e * T) + p[_KD] * deriv
            imax = p[_IMAX]
            if ipid > imax:
                ipid = imax
            elif ipid < -imax:
                ipid = -imax
            else:
                x[_INT] += e * T
            # dead-zone compensation, eq. (1)
            if abs(e) > p[_EMIN] and abs(ipid) < p[_IMIN]:
                iq = p[_IMIN] if e > 0.0 else -p[_IMIN]
            else:
                iq = ipid
        else:
            if t < x[_TSW] + p[_HOLD]:
                iq = p[_ITIGHT]
            else:
                iq = 0.0
    x[_W3] = x[_W2]
    x[_W2] = x[_W1]
    x[_W1] = w
    x[_N] = n + 1.0
    y[0] = iq * p[_DIR]
    y[1] = w * p[_DIR]
    y[2] = wset * p[_DIR]
    y[3] = x[_MODE]
    y[4] = x[_TSW]


class OuterLoop(Controller):
    """Velocity PID with dead-zone compensation, impact trigger and velocity-to-current switch.

    Input: ``theta_m`` (rad, motor angle). Outputs: ``i_q_ref`` (A, to the FOC), ``w_est`` (rad/s,
    differenced encoder speed), ``w_set`` (rad/s), ``mode`` (0 velocity, 1 current), ``t_switch``
    (s, time of the switch; -1 before). ``summaries``: the summary.json keys of the staircase ("static")
    and of the impact trial ("impact").
    """

    parameters = {
        "profile": ("impact", "staircase", "velocity"),
        "Kp": 0.01,
        "Ki": 0.1,
        "Kd": 0.0,
        "i_max": 2.5,
        "i_min": 0.2,
        "e_min": 5.0,
        "thr": 0.9,
        "enc_cpt": 2048.0,
        "speed_rpm": 1000.0,
        "ramp_s": 0.2,
        "t_start": 0.0,
        "i_tight": 1.0,
        "hold_s": 5.0,
        "arm_fraction": 0.5,
        "direction": 1.0,
        "step_A": 0.1,
        "step_s": 5.0,
        "top_A": 2.5,
    }
    inputs = ("theta_m",)
    outputs = ("i_q_ref", "w_est", "w_set", "mode", "t_switch")
    units = {"theta_m": "rad", "i_q_ref": "A", "w_est": "rad/s", "w_set": "rad/s", "mode": "1", "t_switch": "s",
             "Kp": "A.s/rad", "Ki": "A/rad", "Kd": "A.s2/rad", "i_max": "A", "i_min": "A", "e_min": "rad/s",
             "speed_rpm": "rpm", "ramp_s": "s", "t_start": "s", "i_tight": "A", "hold_s": "s", "step_A": "A",
             "step_s": "s", "top_A": "A"}
    limits = {"Kp": "[0, inf)", "Ki": "[0, inf)", "Kd": "[0, inf)", "i_max": "(0, inf)", "i_min": "[0, inf)",
              "e_min": "[0, inf)", "thr": "(0, 1]", "enc_cpt": "integer [0, inf)", "speed_rpm": "[0, inf)",
              "ramp_s": "(0, inf)", "t_start": "[0, inf)", "i_tight": "[0, inf)", "hold_s": "(0, inf)",
              "arm_fraction": "(0, 1]", "direction": "integer [-1, 1]", "step_A": "(0, inf)", "step_s": "(0, inf)",
              "top_A": "(0, inf)"}
    kernel = staticmethod(_outer_kernel)
    summaries = {"static": StaircaseSummary, "impact": ImpactSummary}
    labels = {"mode": {0: "velocity", 1: "current"}}

    @classmethod
    def scenario(cls, values):
        """The profile and its key parameters, e.g. "impact at 1000 rpm, then 1 A for 1.5 s"."""
        v = {**{k: (d[0] if isinstance(d, tuple) else d) for k, d in cls.parameters.items()}, **values}
        if v["profile"] == "staircase":
            return f"current staircase 0-{v['top_A']:g} A in {v['step_A']:g} A steps of {v['step_s']:g} s"
        ramp = f"velocity ramp to {v['speed_rpm']:g} rpm in {v['ramp_s']:g} s"
        if v["profile"] == "velocity":
            return ramp
        return f"impact: {ramp}, then {v['i_tight']:g} A for {v['hold_s']:g} s"

    def pack(self):
        v = self.values
        if v["direction"] == 0:
            self.refuse("direction", "1 (closing towards positive angles) or -1", v["direction"])
        p = super().pack()
        p[_WSET] = v["speed_rpm"] * TWO_PI / 60.0
        return p

    def initial_state(self):
        x = np.zeros(_N + 2)
        x[_TSW] = -1.0
        x[_N + 1] = self.dt
        return x
