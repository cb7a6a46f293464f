"""Experiment summaries written to summary.json: the static staircase and the impact trial.

Static (``kind = "static"``): for each staircase step (A, as a string like "1.5"), the mean force of
the step's last second (the last half of the step when steps are shorter than 2 s) on the way up
(``force_up_N``) and down (``force_down_N``); ``max_force_N`` (largest force over the run) and
``residual_force_N`` (mean force of the final 0 A step after the way down).

Impact (``kind = "impact"``): ``peak_force_N`` (largest force), ``min_force_after_peak_N`` (smallest
force from the peak to the end of tightening: 0 when the finger bounces off), ``steady_force_N``
(mean force over the last second of tightening, or of the recorded part of it when the run stops
earlier), ``t_switch_s`` (time of the velocity-to-current switch; None when the trigger never fired)
and ``t_contact_s`` (first time the force exceeds 1 N).
"""

import math

import numpy as np

from controllers.outer import staircase_steps

__all__ = ["summarize"]


def _window_mean(t, f, a, b):
    m = (t >= a - 1e-12) & (t < b - 1e-12)
    return float(np.mean(f[m])) if m.any() else None


def _static(result, spec, values):
    t = result.data["time"]
    f = result.data[spec.force]
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


def _impact(result, spec, values, ctrl):
    t = result.data["time"]
    f = result.data[spec.force]
    col = f"{ctrl}.t_switch"
    t_sw = None
    if col in result.data.dtype.names and len(t):
        v = float(result.data[col][-1])
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
    out["min_force_after_peak_N"] = float(np.min(f[after]))
    out["t_contact_s"] = float(t[contact[0]]) if len(contact) else None
    if t_sw is not None:
        a = max(end - 1.0, t_sw)
        m = (t >= a - 1e-12) & (t <= end + 1e-12)
        out["steady_force_N"] = float(np.mean(f[m])) if m.any() else None
        out["steady_window_s"] = [float(a), float(end)]
    return out


def summarize(result, config):
    """Return the summary dict of a run (run facts plus the experiment keys of ``config.summary``).

    Parameters
    ----------
    result : cosim.master.engine.RunResult
    config : cosim.config.Config
    """
    out = {
        "config": str(config.path),
        "overrides": list(config.overrides),
        "start_s": config.run.start,
        "stop_s": config.run.stop,
        "simulated_s": result.sim_s,
        "wall_s": result.wall_s,
        "wall_per_sim_s": result.wall_s / result.sim_s if result.sim_s > 0 else None,
        "interrupted": result.interrupted,
        "rows": int(len(result.data)),
        "controller_calls": dict(result.calls),
        "solver": {"method": config.solver.method, "substeps": config.solver.substeps},
        "engine": result.engine,
        "compile_s": result.compile_s,
    }
    if result.engine_note:
        out["engine_note"] = result.engine_note
    spec = config.summary
    if spec.kind == "none":
        return out
    values = result.controller_values.get(spec.controller, {})
    if spec.kind == "static":
        out.update(_static(result, spec, values))
    else:
        out.update(_impact(result, spec, values, spec.controller))
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}
