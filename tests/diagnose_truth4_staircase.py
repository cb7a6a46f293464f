"""A fourth hidden-effect truth of the gripper's static current staircase, written before issue #42's model-form
candidates were evaluated and reserved for that evaluation: never used to tune anything.

The plant is the fourth impact truth's (``diagnose_truth4_impact.py``: Bliman-Sorine motor friction carrying the
mesh loss, a mesh whose stiffness varies with the tooth contact, rate-and-state guides, the tabulated hysteretic
coating, a sinc^3 load-cell converter), run dynamically at 10 us on the first staircase truth's current staircase
(``diagnose_truth.staircase``: 100 Hz, ramps held between samples), the coated fingers resting on the ABS cylinder
(``CONDITION``) at the start. None of its laws is in the candidate library, among the forms issue #42 adds, or in
the staircase truths 1 and 2 (Karnopp stick/slip on a rigid drivetrain; Dahl and LuGre on a compliant mesh).

Drawn per case, in the order of the other staircase truths so a seed gives their ``eta_d`` and ``T_c0``: ``eta_d``
0.6-0.8, ``T_c0`` 4-12 mN.m, then the noise 0.2-0.5 N, then the effect: ``backdrive_efficiency`` (the mesh
friction's back-driven factor ``1 - eta_b``, ``eta_b = eta_d +- 0.12-0.25`` within 0.3-0.97),
``load_dependent_friction`` (the guides' rate-and-state force scaled by ``1 + mu_F F_c/F_GUIDE``, ``mu_F``
0.01-0.05, the plant's range), ``loadcell_filter`` (the converter at a data rate of 10-80 Hz, the range of precision
load-cell converters such as the HX711 and ADS1232, so a sinc^3 window of 37-300 ms, and an offset of +-1-3 N),
``cogging`` (the permeance model, ``eps`` 0.2-0.5, peak 1.5-4 mN.m), ``stiction`` (the guides' healing, a breakaway
3-10 N above sliding after 0.25 s at rest), or ``none``.

The checks (``tests/test_truth4_staircase.py``) use the seed 1095907558 of the impact truth's checks, drawn once
with ``python -c "import secrets; print(secrets.randbelow(2**31))"``.
"""

import numpy as np

import diagnose_truth4_impact as plant
from diagnose_truth import staircase

__all__ = ["TRUTH4_STAIRCASE_EFFECTS", "simulate", "draw_truth", "make_case4", "diagnose_case4"]

TRUTH4_STAIRCASE_EFFECTS = ("none", "backdrive_efficiency", "load_dependent_friction", "loadcell_filter", "cogging",
                            "stiction")


def plant_truth(truth):
    """The impact truth's parameters (``diagnose_truth4_impact.simulate``) for a staircase truth dict."""
    names = {"eta_d": "eta_g", "T_c0": "T_c0", "eta_b": "eta_b", "mu_F": "mu_F", "dF_s": "dF_s", "T_cog": "T_cog",
             "eps_cog": "eps_cog", "phase_cog": "phase_cog", "f_notch": "f_notch", "F_off": "F_off"}
    return {names[k]: v for k, v in truth.items() if k in names}


def simulate(truth, time, current):
    """Noise-free load-cell reading [N] (with its offset), contact force [N] and motor angle [rad] along the
    current ``current`` [A] given at the 100 Hz instants ``time`` [s] and held between them."""
    corners = tuple(zip(time, current)) + ((time[-1] + 0.01, current[-1]),)  # the plant runs to the last corner
    _, _, reading, contact, theta, _, _ = plant.simulate(plant_truth(truth), "impact", plant.T_COAT, corners)
    return reading, contact, theta


def draw_truth(effect, rng):
    """The drawn parameters of one case of ``effect`` (module docstring: the ranges)."""
    if effect not in TRUTH4_STAIRCASE_EFFECTS:
        raise ValueError(f"effect must be one of {', '.join(TRUTH4_STAIRCASE_EFFECTS)}; got {effect!r}")
    u = rng.uniform
    truth = {"effect": effect, "eta_d": float(u(0.6, 0.8)), "T_c0": float(u(4e-3, 1.2e-2)), "noise": float(u(0.2, 0.5))}
    if effect == "backdrive_efficiency":
        truth["eta_b"] = float(np.clip(truth["eta_d"] + rng.choice([-1.0, 1.0]) * u(0.12, 0.25), 0.3, 0.97))
    elif effect == "load_dependent_friction":
        truth["mu_F"] = float(u(0.01, 0.05))
    elif effect == "loadcell_filter":
        truth.update(f_notch=float(u(10.0, 80.0)), F_off=float(rng.choice([-1.0, 1.0]) * u(1.0, 3.0)))
    elif effect == "cogging":
        truth.update(T_cog=float(u(1.5e-3, 4e-3)), eps_cog=float(u(0.2, 0.5)), phase_cog=float(u(0, 2 * np.pi)))
    elif effect == "stiction":
        truth["dF_s"] = float(u(3.0, 10.0))
    return truth


def make_case4(effect, rng):
    """A random hidden-effect case: (time, current, measured force, truth dict), the force with Gaussian noise of
    the drawn sd (``truth["noise"]``), as ``diagnose_truth2.make_case2`` gives its cases."""
    t, i = staircase()
    truth = draw_truth(effect, rng)
    reading = simulate(truth, t, i)[0]
    return t, i, reading + rng.normal(0.0, truth["noise"], len(t)), truth


def diagnose_case4(effect, seed, folder, effects=None, workers=2):
    """Diagnose this truth's case (``effect``, ``seed``) with the staircase job of ``diagnose_truth.write_job``
    offering ``effects`` (default: the whole library); one row (``diagnose_truth2.diagnose_frame``). Reserved for
    the evaluation of issue #42: run it only once the code under evaluation is final."""
    import pandas as pd

    from diagnose_truth2 import diagnose_frame

    t, i, y, truth = make_case4(effect, np.random.default_rng(seed))
    return diagnose_frame(pd.DataFrame({"time": t, "i_ref": i, "F_g": y}), truth, seed, folder, effects, workers)
