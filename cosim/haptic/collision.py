"""Virtual-wall contacts simulated by the co-simulation master, measured beside the margins' prediction.

Two scenarios per user x grasp position, both run through ``cosim run`` machinery (a generated config: the
Haptic FMU with the Table I row, `cosim_controllers.haptic.VirtualWall` or `AdaptiveWall` at the loop rate, and
`cosim_controllers.haptic.UserIntent`):

* ``step``: the stylus rests at the wall surface (states start at phi_wall) and a motor-torque step of
  ``tau_step`` pushes it in; phi/tau_step then has the shape of K G/(1 + K G), the closed loop whose phase
  margin predicts zeta (eq. 17): overshoot over the final penetration and the 2 % settling time are
  compared with exp(-pi zeta / sqrt(1 - zeta^2)) and 4/(zeta w_cg) (eq. 18).
* ``collision``: the hand reference approaches the wall at ``v_approach`` and stops where the steady wall
  torque is ``tau_final`` (the paper's "same velocity and force"); measured: the contact velocity, the final
  penetration, the peak penetration, and the settling time from contact to the last excursion of
  |phi - phi_final| above 2 % of its largest value after contact (the time the oscillation envelope takes to
  decay by 50x, which is ~ 4/(zeta w) for a decaying oscillation).
"""

import math
from pathlib import Path

import numpy as np
import pandas as pd

from cosim.haptic.fmu import fmu_parameters
from cosim.haptic.ident import device_user_ss
from cosim.haptic.margins import adaptive_damping, wall_margins
from cosim.haptic.params import POSITIONS, load_user_params
from cosim.haptic.tf import tf_user

__all__ = [
    "user_static_stiffness",
    "collision_config_data",
    "simulate_contact",
    "step_metrics",
    "collision_metrics",
    "collision_study",
]

_STATE_ANGLES = {11: ("phi1", "phi2", "phih"), 7: ("phi1", "phi2")}


def user_static_stiffness(params):
    """Static stiffness from the encoder (m1) to the user's reference, N.m/rad: kc, ks, kh in series (11
    parameters) or kc, ks (7): the inverse of Kp, eqs. (8) and (13)."""
    v = params.values
    if params.structure == 11:
        return 1.0 / (1.0 / v["kc"] + 1.0 / v["ks"] + 1.0 / v["kh"])
    return 1.0 / (1.0 / v["kc"] + 1.0 / v["ks"])


def _substeps(params, rate):
    A = device_user_ss(params.values, params.structure)[0]
    wmax = float(np.max(np.abs(np.linalg.eigvals(A))))
    return max(4, int(math.ceil(wmax / rate / 1.0)))  # RK4 with h*|lambda| <= 1 (stable, accurate)


def collision_config_data(params, scenario="collision", B=0.0, adaptive=False, K=10.0, rate=1000.0, phi_wall=0.7,
                          v_approach=0.5, tau_final=0.1, tau_step=0.1, fmu_dir="fmus", stop=None):
    """The tables of a contact run's config for one Table I row (for :func:`cosim.config.config_from_data`).

    Parameters
    ----------
    params : HapticParams
        The row (use ``zero_as`` to avoid zero masses).
    scenario : {"collision", "step"}
    B : float, optional
        Wall damping, N.m.s/rad (ignored when ``adaptive``).
    adaptive : bool, optional
        Use `AdaptiveWall` with ``position = params.position`` and its default (user-1) table.
    K, rate, phi_wall : float, optional
        Wall stiffness (N.m/rad), loop rate (Hz), wall position (rad).
    v_approach, tau_final : float, optional
        Collision: approach speed of the hand reference (rad/s) and steady wall torque (N.m).
    tau_step : float, optional
        Step: motor-torque step (N.m) applied at 0.05 s.
    fmu_dir : path-like, optional
        Folder with the built Haptic FMUs (default ``fmus``).
    stop : float, optional
        Run length, s (default: 1.0 for the step, approach time + 1.0 for the collision).

    Returns
    -------
    dict
    """
    if scenario not in ("collision", "step"):
        raise ValueError(f"scenario must be 'collision' or 'step'; got {scenario!r}")
    name, par = fmu_parameters(params)
    fmu = (Path(fmu_dir) / f"{name}.fmu").resolve()
    if not fmu.is_file():
        raise FileNotFoundError(f"{fmu} does not exist; build the Haptic FMUs first (cosim build)")
    wall = {"phi_wall": phi_wall, "K": K}
    if adaptive:
        wall_class = "cosim_controllers.haptic:AdaptiveWall"
        wall["position"] = int(params.position)
    else:
        wall_class = "cosim_controllers.haptic:VirtualWall"
        wall["B"] = B
    start = {}
    if scenario == "step":
        wall.update(t_step=0.05, tau_step=tau_step)
        intent = {"phi_start": phi_wall, "phi_end": phi_wall}
        start = {s: phi_wall for s in _STATE_ANGLES[params.structure]}
        stop = 1.0 if stop is None else stop
    else:
        intent = {"phi_start": 0.0, "v_approach": v_approach, "accel_s": 0.1, "tau_final": tau_final,
                  "phi_wall": phi_wall, "K_wall": K, "k_user": user_static_stiffness(params)}
        stop = (phi_wall / v_approach + 0.3 + 1.0) if stop is None else stop
    plant = {"path": fmu.as_posix(), "parameters": par, **({"start": start} if start else {})}
    return {
        "run": {"start": 0.0, "stop": float(stop)},
        "solver": {"method": "rk4", "substeps": _substeps(params, rate)},
        "fmus": {"plant": plant},
        "controllers": {"wall": {"class": wall_class, "rate": float(rate), "parameters": wall},
                        "intent": {"class": "cosim_controllers.haptic:UserIntent", "rate": float(rate),
                                   "parameters": intent}},
        "connections": [{"from": a, "to": b} for a, b in (("plant.phi", "wall.phi"), ("wall.tau", "plant.tau"),
                                                           ("intent.phi_ref", "plant.phi_ref"),
                                                           ("intent.tau_h", "plant.tau_h"))],
        "record": {"rate": float(rate), "signals": ["plant.phi", "wall.tau", "intent.phi_ref"]},
    }


def simulate_contact(params, scenario="collision", workdir=None, **kwargs):
    """Run one contact through the master; returns the recorded structured array (time, phi, wall.tau, ...).

    Parameters
    ----------
    params : HapticParams
    scenario : {"collision", "step"}
    workdir : path-like, optional
        Where the run's config is also written, for ``cosim run`` to repeat it (default: nowhere; the config is
        built in code).
    **kwargs
        Passed to `collision_config_data`.
    """
    from cosim.config import config_from_data
    from cosim.master.run import run
    from cosim.tomldoc import toml_text

    data = collision_config_data(params, scenario, **kwargs)
    path = Path(workdir or ".") / f"haptic_u{params.user}_p{params.position}_{scenario}.toml"
    if workdir is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(toml_text(data, f"generated by cosim.haptic.collision: user {params.user} position "
                                        f"{params.position}, {scenario}"), encoding="utf-8")
    return run(config_from_data(data, path), progress=False).data


def step_metrics(t, phi, phi_wall=0.7, t_step=0.05, band=0.02):
    """Overshoot (fraction of the final penetration) and settling time (s, band of the final value) of a step.

    Returns
    -------
    dict
        ``pen_final`` (rad), ``overshoot``, ``settling_s``.
    """
    t = np.asarray(t)
    y = np.asarray(phi) - phi_wall
    k = t >= t_step
    tt, yy = t[k] - t_step, y[k]
    final = float(np.mean(yy[tt >= tt[-1] - 0.1]))
    over = float((np.max(yy) - final) / final)
    out = np.nonzero(np.abs(yy - final) > band * abs(final))[0]
    settling = float(tt[out[-1] + 1]) if len(out) and out[-1] + 1 < len(tt) else (0.0 if not len(out) else math.nan)
    return {"pen_final": final, "overshoot": over, "settling_s": settling}


def collision_metrics(t, phi, phi_wall=0.7, band=0.02):
    """Contact velocity, penetrations, overshoot and settling time of a collision (see the module notes).

    Returns
    -------
    dict
        ``t_contact`` (s), ``v_contact`` (rad/s, mean over the 10 ms before contact), ``pen_final``,
        ``pen_peak`` (rad), ``overshoot`` ((peak - final)/final), ``settling_s`` (s from contact).
    """
    t = np.asarray(t)
    phi = np.asarray(phi)
    inside = np.nonzero(phi > phi_wall)[0]
    if not len(inside):
        raise ValueError("the stylus never reaches the wall")
    kc = int(inside[0])
    tc = float(t[kc])
    j = max(0, kc - 10)
    v = float((phi[kc] - phi[j]) / (t[kc] - t[j])) if kc > j else math.nan
    after = t >= tc
    tt, pp = t[after] - tc, phi[after]
    final = float(np.mean(pp[tt >= tt[-1] - 0.2]))
    e = np.abs(pp - final)
    out = np.nonzero(e > band * np.max(e))[0]
    settling = float(tt[out[-1] + 1]) if out[-1] + 1 < len(tt) else math.nan
    pen_final = final - phi_wall
    pen_peak = float(np.max(pp) - phi_wall)
    return {"t_contact": tc, "v_contact": v, "pen_final": pen_final, "pen_peak": pen_peak,
            "overshoot": (pen_peak - pen_final) / pen_final, "settling_s": settling}


def collision_study(users=(1,), positions=POSITIONS, adaptive=False, K=10.0, rate=1000.0, fmu_dir="fmus",
                    scenarios=("step", "collision")):
    """Simulate contacts for users x positions and put predicted and measured figures side by side.

    Parameters
    ----------
    users, positions : sequence of int
    adaptive : bool, optional
        Damping from the user-1 adaptive table (`adaptive_damping`) instead of B = 0.
    K, rate : float, optional
    fmu_dir : path-like, optional
    scenarios : sequence of {"step", "collision"}

    Returns
    -------
    pandas.DataFrame
        One row per user x position: ``B_Nms_per_rad``, predicted ``PM_deg``, ``zeta``, ``overshoot_pred``,
        ``settling_pred_s``; for ``step``: ``step_overshoot``, ``step_settling_s``; for ``collision``:
        ``v_contact``, ``pen_final``, ``pen_peak``, ``coll_overshoot``, ``coll_settling_s``.
    """
    table = adaptive_damping(user=1, K=K, rate=rate) if adaptive else {}
    rows = []
    for u in users:
        for p in positions:
            params = load_user_params(u, p, zero_as=5e-4)
            B = float(table.get(p, 0.0))
            m = wall_margins(tf_user(load_user_params(u, p)), K=K, B=B, rate=rate)
            row = {"user": u, "position": p, "model": params.structure, "B_Nms_per_rad": B, "PM_deg": m.PM_deg,
                   "zeta": m.zeta, "f_cross_Hz": m.f_cross_Hz, "overshoot_pred": m.overshoot,
                   "settling_pred_s": m.settling_s}
            common = dict(adaptive=adaptive, B=B, K=K, rate=rate, fmu_dir=fmu_dir)
            if "step" in scenarios:
                d = simulate_contact(params, "step", **common)
                s = step_metrics(d["time"], d["phi"])
                row.update(step_overshoot=s["overshoot"], step_settling_s=s["settling_s"])
            if "collision" in scenarios:
                d = simulate_contact(params, "collision", **common)
                c = collision_metrics(d["time"], d["phi"])
                row.update(v_contact=c["v_contact"], pen_final=c["pen_final"], pen_peak=c["pen_peak"],
                           coll_overshoot=c["overshoot"], coll_settling_s=c["settling_s"])
            rows.append(row)
    return pd.DataFrame(rows)
