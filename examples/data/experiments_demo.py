"""Write experiments_impact.csv and experiments_slide.csv: demonstration data for
examples/diagnose_experiments.toml (not a measurement).

Two experiments on one gripper (Gripper.GripperCurrentDriven, bare fingers, ABS cylinder), recorded at 500 Hz:
- an impact: the current steps from 0 to 1 A at t = 0.02 s and the fingers close 2 mm onto the cylinder;
- a slide: the current moves the jaws, stops them, ramps to 0.55 A to restart them against the guides, stops them
  again and ramps to 0.8 A, closing them on the cylinder 15 mm away.
The "plant" differs from the baseline in two ways: its gear play is 1.5 deg (the baseline's 0.8 deg; the
`gear_play` candidate frees it) and its jaw guides stick (the `stiction` candidate's own Modelica: breakaway 6 N
per jaw). Replayed by CVODES, plus Gaussian noise (load cell 0.5 N, seed 5) and whole encoder counts (2048 per
revolution). The impact shows the play, the slide the stiction.

Run: python examples/data/experiments_demo.py   (rewrites the two files beside this file)
"""

import tempfile
from pathlib import Path

import numpy as np

from cosim.compile import lower
from cosim.diagnose import EFFECTS, write_variant
from cosim.diagnose.fitting import Replay
from cosim.experiment import Experiment

HERE = Path(__file__).resolve().parent
FIXED = {"k_obj": 3.53e7, "t_coat": 0.0, "k_P": 1e12, "C_p": 2000.0, "C_h": 2000.0}
PLAY, F_SJ = np.radians(1.5), 6.0  # rad, N
COUNT = 2 * np.pi / 2048  # rad
SLIDE = ((0.0, 0.3), (0.1, 0.3), (0.1, 0.1), (0.25, 0.1), (0.65, 0.55), (0.65, 0.1), (0.9, 0.1), (1.4, 0.8),
         (1.7, 0.8))  # (time [s], current [A]) corners
RUNS = {"impact": 0.002, "slide": 0.015}  # m: travel to the cylinder


def current(name, t):
    """The current [A] of the experiment ``name`` at the times ``t``."""
    if name == "impact":
        return np.where(t >= 0.02 - 1e-9, 1.0, 0.0)
    corners = np.array(SLIDE)
    return np.interp(t, corners[:, 0], corners[:, 1])


def main():
    source = HERE.parent.parent / "modelica" / "Gripper" / "package.mo"
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(source, "Gripper.GripperCurrentDriven", [EFFECTS["stiction"]], folder)
        model = lower(path, name)
    rng = np.random.default_rng(5)
    for run, gap0 in RUNS.items():
        t = np.round(np.arange(0, 0.5 if run == "impact" else 1.7, 2e-3), 6)
        i = current(run, t)
        e = Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 2)), weights=np.ones(2),
                       mask=np.ones(len(t), bool))
        force, theta = Replay(model, e, ["F_g", "theta_m"], ["F_sj", "play"], [1.0, 1.0],
                              {**FIXED, "gap0": gap0}, rtol=1e-8).outputs([F_SJ, PLAY])
        force = force + rng.normal(0, 0.5, len(t))
        angle = np.floor(theta / COUNT) * COUNT
        header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
        rows = "\n".join(f"{a:.3f},{b:.4f},{c:.3f},{d:.6f}" for a, b, c, d in zip(t, i, force, angle))
        (HERE / f"experiments_{run}.csv").write_text(header + "time,i_ref,F_g,theta_m\n" + rows + "\n",
                                                     encoding="utf-8")


if __name__ == "__main__":
    main()
