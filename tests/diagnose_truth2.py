"""A second hidden-effect truth of the gripper's static current staircase, written from other textbook
formulations than the candidates' and than ``diagnose_truth.py``; never used to tune anything (issue #32 item 3).

Formulation: the staircase's current changes slowly against the drivetrain's modes (hundreds of Hz), so at each
100 Hz sample the drivetrain sits in the static equilibrium reached along the path from the previous one (a
quasi-static path; every friction below is rate-independent at rest, so the path, not time, sets its state).
Written in jaw coordinates (a motor angle ``theta`` is the jaw travel ``theta/GAIN``, a motor torque ``T`` the
gripping force ``GAIN*T``):

* motor: ``K_T i = T_c0 s_m + L s_g + T_cog(theta) + F_mesh/GAIN``; Dahl friction (Dahl 1968) at the shaft, its
  normalised state ``ds/dtheta = (1 - s sgn dtheta)/phi``, and a torque-proportional gear loss of level
  ``L = c |F_mesh|/GAIN`` with its own Dahl state ``s_g``: ``c = (1 - eta_d)/eta_d`` when the motor drives the
  load, ``1 - eta_b`` when the load back-drives it (power flow from the sign of ``s_g F_mesh``);
* gear mesh: a stiffness with backlash (a dead zone of total width ``b``), instead of the candidates' rigid gear
  with a play;
* jaw: ``F_mesh = F_g + F_guide`` with LuGre guide friction (Canudas de Wit et al. 1995) in its limit at rest, a
  bristle law of level ``g(0) = max(F_s, F_c + mu_F F_g)`` (breakaway ``F_s``; Coulomb level growing with the
  gripping force when load-dependent), and a linear contact spring ``F_g = k x`` (the fingers on the cylinder);
* cogging: a detent torque interpolated in a tabulated, FEM-like profile over one slot pitch (24 a revolution,
  with a flat top and harmonics 2 and 3), not the candidate's sine;
* load cell: a second-order sensor (natural frequency ``f_lc``, damping ``zeta_lc``, by ``solve_ivp``) with an
  offset, sampled at 100 Hz with Gaussian noise; the candidate is a first-order lag.

:func:`make_case2` draws the baseline's parameters and the effect's size from stated ranges (ranges of the plant,
not of the first truth's successes) and the noise level.
"""

import re

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.stats import binomtest

from cosim.diagnose import EFFECTS
from diagnose_truth import F_GUIDE, GAIN, K_T, staircase

__all__ = ["TRUTH2_EFFECTS", "SHOWN_ON_STAIRCASE", "cogging_table", "simulate", "make_case2", "case_frame2"]

TRUTH2_EFFECTS = ("none", "backdrive_efficiency", "load_dependent_friction", "loadcell_filter", "cogging",
                  "stiction")
# the effects docs/guide/diagnose.md says a static staircase shows (the targets of issue #32 count on these)
SHOWN_ON_STAIRCASE = ("backdrive_efficiency", "loadcell_filter")

K_MESH = 2.0e6     # N/m, gear mesh stiffness in jaw coordinates
K_CONTACT = 1.0e6  # N/m, fingers on the cylinder
PHI_M = 5e-4       # rad, Dahl presliding angle of the motor friction and the gear loss
SIGMA0 = 1e7       # N/m, LuGre bristle stiffness of the guides (presliding 1 µm at 10 N)
SLOTS = 24         # detents a revolution
PITCH = 2 * np.pi / SLOTS


def cogging_table(amplitude, phase, n=64):
    """A tabulated detent torque over one slot pitch [N.m] at ``n`` angles: a flattened sine with harmonics 2
    and 3 (the shape a finite-element run of a surface-magnet motor gives), scaled to ``amplitude`` peak and shifted
    by ``phase`` [rad of the slot period]. Returns (angles [rad] over one pitch, torque)."""
    x = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    shape = np.sin(x + phase) + 0.25 * np.sin(2 * (x + phase) + 0.6) - 0.12 * np.sin(3 * (x + phase))
    return x / SLOTS, amplitude * shape / np.max(np.abs(shape))


def _dahl(s, step, width):
    """Dahl's state after a monotonic move ``step`` from ``s`` (normalised friction in [-1, 1]): the closed form of
    ``ds/dx = (1 - s sgn dx)/width``, rate-independent, so a quasi-static path needs no time."""
    if step == 0:
        return s
    sign = np.sign(step)
    return sign + (s - sign) * np.exp(-abs(step) / width)


class _Drivetrain:
    """The quasi-static drivetrain of the module docstring: its state after the last equilibrium and the
    equilibrium at a new current, found by following the path from the last one."""

    def __init__(self, truth):
        self.truth = truth
        eta_d = truth["eta_d"]
        self.c_drive, self.c_back = (1 - eta_d) / eta_d, 1 - truth.get("eta_b", eta_d)
        self.table = cogging_table(truth["T_cog"], truth["phase_cog"]) if "T_cog" in truth else None
        self.theta, self.x, self.s_m, self.s_g, self.f_guide = 0.0, 0.0, 0.0, 0.0, 0.0

    def _guide(self, x):
        """LuGre guide force at rest (its v -> 0 limit: a Dahl law of level g(0)) after moving to ``x``."""
        t = self.truth
        level = max(t.get("F_s", F_GUIDE), F_GUIDE + t.get("mu_F", 0.0) * K_CONTACT * max(x, 0.0))
        return level * _dahl(self.f_guide / level, x - self.x, level / SIGMA0)

    def _mesh(self, theta, x):
        delta = theta / GAIN - x
        return K_MESH * np.sign(delta) * max(abs(delta) - self.truth.get("backlash", 0.0) / 2, 0.0)

    def _jaw(self, theta):
        """The jaw travel where mesh force = contact force + guide friction, at motor angle ``theta``."""
        def balance(x):
            return self._mesh(theta, x) - K_CONTACT * max(x, 0.0) - self._guide(x)
        return brentq(balance, theta / GAIN - 1e-3, theta / GAIN + 1e-3, xtol=1e-13)

    def _torque(self, theta, current):
        """Net torque on the motor at ``theta`` [N.m] (positive: it turns on)."""
        t, step = self.truth, theta - self.theta
        x = self._jaw(theta)
        F = self._mesh(theta, x)
        s_m, s_g = _dahl(self.s_m, step, PHI_M), _dahl(self.s_g, step, PHI_M)
        loss = (self.c_drive if s_g * F >= 0 else self.c_back) * abs(F) / GAIN
        cog = 0.0 if self.table is None else np.interp(theta % PITCH, *self.table, period=PITCH)
        return K_T * current - t["T_c0"] * s_m - loss * s_g - cog - F / GAIN

    def settle(self, current):
        """Move to the first equilibrium along the path at ``current`` [A]; returns the contact force [N]."""
        start = self._torque(self.theta, current)
        if start != 0.0:
            direction, step, a = np.sign(start), 1e-5, self.theta
            for _ in range(200):
                b = a + direction * step
                if np.sign(self._torque(b, current)) != direction:
                    break
                a, step = b, 1.5 * step
            else:
                raise RuntimeError(f"second truth: no equilibrium at {current} A")
            theta = brentq(lambda th: self._torque(th, current), min(a, b), max(a, b), xtol=1e-12)
            x = self._jaw(theta)
            step = theta - self.theta
            self.s_m, self.s_g = _dahl(self.s_m, step, PHI_M), _dahl(self.s_g, step, PHI_M)
            self.f_guide, self.theta, self.x = self._guide(x), theta, x
        return K_CONTACT * max(self.x, 0.0)


def _load_cell(time, force, f_lc, zeta):
    """The second-order load cell's reading of ``force`` (linear between samples), by solve_ivp (RK45)."""
    w = 2 * np.pi * f_lc

    def rhs(t, q):
        return [q[1], w ** 2 * (np.interp(t, time, force) - q[0]) - 2 * zeta * w * q[1]]

    sol = solve_ivp(rhs, (time[0], time[-1]), [force[0], 0.0], t_eval=time, rtol=1e-8, atol=1e-8,
                    max_step=float(np.median(np.diff(time))))
    return sol.y[0]


def simulate(truth, time, current):
    """The load cell's reading (without noise) along the current ``current`` [A] sampled at ``time`` [s] for the
    parameters ``truth`` (a dict from :func:`make_case2`): the quasi-static equilibrium at each sample (the
    drivetrain settles within a sample), then the load cell."""
    drive, force, last = _Drivetrain(truth), np.empty(len(time)), None
    for k, i in enumerate(current):
        force[k] = drive.settle(i) if i != last else force[k - 1]
        last = i
    if "f_lc" in truth:
        force = _load_cell(time, force, truth["f_lc"], truth["zeta_lc"])
    return force + truth.get("F_off", 0.0)


def make_case2(effect, rng, levels=None):
    """A random hidden-effect case of the second truth: (time, current, measured force, truth dict).

    The baseline's values are drawn as in the plant's spread (efficiency 0.6-0.8, shaft drag 4-12 mN.m, backlash
    0.2-1 µm of jaw travel: a loaded gear), the noise 0.2-0.5 N, and the effect's size from the stated range."""
    t, i = staircase() if levels is None else staircase(levels)
    truth = {"effect": effect, "eta_d": rng.uniform(0.6, 0.8), "T_c0": rng.uniform(4e-3, 1.2e-2),
             "backlash": rng.uniform(2e-7, 1e-6), "noise": rng.uniform(0.2, 0.5)}
    if effect == "backdrive_efficiency":
        truth["eta_b"] = float(np.clip(truth["eta_d"] + rng.choice([-1.0, 1.0]) * rng.uniform(0.12, 0.25), 0.3,
                                       0.97))
    elif effect == "load_dependent_friction":
        truth["mu_F"] = rng.uniform(0.1, 0.25)
    elif effect == "loadcell_filter":
        truth.update(f_lc=rng.uniform(2.0, 8.0), zeta_lc=rng.uniform(0.5, 1.0),
                     F_off=rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 3.0))
    elif effect == "cogging":
        truth.update(T_cog=rng.uniform(1.5e-3, 4e-3), phase_cog=rng.uniform(0, 2 * np.pi))
    elif effect == "stiction":
        truth["F_s"] = rng.uniform(2.0, 8.0)
    elif effect != "none":
        raise ValueError(f"effect must be one of {TRUTH2_EFFECTS}; got {effect!r}")
    y = simulate(truth, t, i)
    return t, i, y + rng.normal(0.0, truth["noise"], len(t)), truth


def case_frame2(effect, seed):
    """The case of ``effect`` drawn with ``seed`` as the data frame a diagnosis job reads, and its truth."""
    import pandas as pd

    t, i, y, truth = make_case2(effect, np.random.default_rng(seed))
    return pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), truth


# -- the evaluation: diagnose drawn cases and count (benchmarks/diagnose.py may call these) ------------------------

# The gripper truths' library offers the forms too (issue 42's evaluation): set by benchmarks/diagnose.py --forms.
OFFER_FORMS = False


def library(source_text=None):
    """Every effect of the library that applies to the gripper's current-driven model (the full library the
    issue asks the evaluation to offer), and every form with ``OFFER_FORMS``."""
    from cosim.diagnose.effects import applicable
    from diagnose_truth import SOURCE

    text, model = source_text or SOURCE.read_text(encoding="utf-8"), "Gripper.GripperCurrentDriven"
    return applicable(text, model) + (applicable(text, model, forms=True) if OFFER_FORMS else [])


def diagnose_case2(effect, seed, folder, effects=None, workers=2):
    """Diagnose the second truth's case (``effect``, ``seed``) with the job of ``diagnose_truth.write_job``
    offering ``effects`` (default: the full library) in ``folder``; no FMU build. Returns one row
    (:func:`diagnose_frame`)."""
    frame, truth = case_frame2(effect, seed)
    return diagnose_frame(frame, truth, seed, folder, effects, workers)


def diagnose_frame(frame, truth, seed, folder, effects=None, workers=2):
    """Diagnose a staircase case of either truth (``frame``: time, i_ref, F_g; ``truth``: its dict, with the
    ``effect`` and the ``noise`` sd) with the job of ``diagnose_truth.write_job`` offering ``effects`` (default:
    the full library) in ``folder``; no FMU build. Returns one row: the truth, the named effect, its verdict, the
    gap removed and the figures the counts need."""
    import time
    from pathlib import Path

    from cosim.diagnose import load_diagnose_job, run_diagnosis
    from diagnose_truth import write_job

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    job = load_diagnose_job(write_job(folder, frame, library() if effects is None else effects, workers))
    start = time.perf_counter()
    s = run_diagnosis(job, progress=False, build=False).to_json()
    return diagnosis_row(s, truth, seed, truth["noise"], time.perf_counter() - start)


def diagnosis_row(summary, truth, seed, noise, seconds):
    """One evaluation row from a diagnosis's summary (``Diagnosis.to_json()``) of a truth's case: the truth, the
    named effect, its verdict, the gap removed and the figures the counts need (``noise``: the truth's noise)."""
    s = summary
    findings = list(dict.fromkeys(r["effect"] for r in s.get("rounds", ()) if r["effect"] != "none"
                                  and not r.get("dropped")))
    return {"truth": truth["effect"], "seed": seed, "named": s["effect"], "findings": findings,
            "verdict": s["verdict"],
            "gap_found": s["gap_found"], "gap_removed": s["gap_removed"],
            "baseline_mean_square": s["baseline_mean_square"], "rmse_before": s["rmse_before"],
            "rmse_after": s["rmse_after"], "noise": noise, "seconds": seconds,
            "truth_parameters": {k: float(v) for k, v in truth.items() if k != "effect"}}


def _findings(row):
    """A row's findings (a row written before the rounds: its one named effect)."""
    return row.get("findings", [] if row["named"] == "none" else [row["named"]])


def _effects_named(row):
    """The effects (not forms) among a row's findings."""
    return [f for f in _findings(row) if not EFFECTS[f].is_form]


def _forms_named(row):
    """The forms of laws among a row's findings."""
    return [f for f in _findings(row) if EFFECTS[f].is_form]


# The verdict's words when a gap is left above the noise (cosim.diagnose.answer.verdict and rounds' verdict): "a gap
# of 2.1 noise levels remains ...", "a diffuse gap of 1.2 noise levels RMS remains"; not "what remains is within
# the noise (1.4 noise levels RMS)".
_GAP_LEFT = re.compile(r"gap of [0-9.]+ noise levels (RMS )?remains")


def gap_left(row):
    """Whether a row's answer says that a gap above the noise remains unexplained (after its findings, if any)."""
    return bool(_GAP_LEFT.search(row["verdict"]))


def wilson(k, n):
    """The Wilson score 95 % interval of ``k`` successes in ``n`` (nan, nan when ``n`` is 0)."""
    if n == 0:
        return (float("nan"), float("nan"))
    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    return (float(ci.low), float(ci.high))


def count_rows(rows, shown=SHOWN_ON_STAIRCASE):
    """Counts over diagnosed rows (:func:`diagnose_case2`): per truth effect, named right / cases; false alarms
    on ``none``; named with at least 80 % of the gap removed; each with its Wilson 95 % interval. The target
    "named right" counts only the effects the experiment is said to show (``shown``). After rounds (issue 42) an
    effect is named right when it is among a case's findings, and a false alarm is an effect (not a form of a law
    the model has) among the findings of a case without one; a form named is counted apart (``forms_named``), as
    are the answers that leave a gap unexplained (``gap_left``)."""
    out = {}
    for effect in sorted({r["truth"] for r in rows}):
        mine = [r for r in rows if r["truth"] == effect]
        right = [r for r in mine if (not _effects_named(r) if effect == "none" else effect in _findings(r))]
        entry = {"cases": len(mine), "named_right": len(right), "interval": wilson(len(right), len(mine)),
                 "named": sorted("+".join(_findings(r)) or "none" for r in mine),
                 "forms_named": sum(bool(_forms_named(r)) for r in mine), "gap_left": sum(map(gap_left, mine))}
        if effect != "none":
            entry["gap_removed_80"] = sum(r["gap_removed"] >= 0.8 for r in right)
        out[effect] = entry
    none = [r for r in rows if r["truth"] == "none"]
    alarms = sum(bool(_effects_named(r)) for r in none)
    shown_rows = [r for r in rows if r["truth"] in shown]
    named = sum(r["truth"] in _findings(r) for r in shown_rows)
    out["summary"] = {"false_alarms": alarms, "none_cases": len(none), "false_alarm_interval": wilson(alarms, len(none)),
                      "forms_on_none": sum(bool(_forms_named(r)) for r in none),
                      "named_right_shown": named, "shown_cases": len(shown_rows),
                      "named_right_interval": wilson(named, len(shown_rows)),
                      "gap_left": sum(map(gap_left, rows)), "cases": len(rows)}
    return out
