"""Write impact_trial0.csv .. impact_trial2.csv: demonstration data for examples/diagnose_impact_trials.toml (not
a measurement).

Three repeated current-mode impacts of the gripper (Gripper.GripperCurrentDriven): the current steps from 0 to 1 A
at t = 0.02 s and the bare fingers close onto the ABS cylinders (k_obj = 3.53e7 N/m), the cylinder placed at 2.000,
2.028 and 2.056 mm (a third of a cogging period of jaw travel apart), 0.5 s each. The "plant" is the baseline
model with a motor cogging torque (the `cogging` candidate's own Modelica: 3 mN.m, phase 1 rad), replayed by
CVODES. Recorded as on a bench with two clocks: current and 2048 cpt encoder (whole counts) at 1 kHz, the load
cell at 100 Hz with Gaussian noise (0.5 N, seed 7), empty between its samples.

Run: python examples/data/impact_trials_demo.py   (rewrites the three files beside this file)
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
PLACEMENTS = (0.002, 0.002028, 0.002056)  # m: gap0 of each trial
COGGING = (3e-3, 1.0)  # N.m, rad: T_cog, phase_cog
COUNT = 2 * np.pi / 2048  # rad


def main():
    t = np.round(np.arange(0, 0.5, 1e-3), 6)
    i = np.where(t >= 0.02 - 1e-9, 1.0, 0.0)
    source = HERE.parent.parent / "modelica" / "Gripper" / "package.mo"
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(source, "Gripper.GripperCurrentDriven", EFFECTS["cogging"], folder)
        model = lower(path, name)
    e = Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 2)), weights=np.ones(2),
                   mask=np.ones(len(t), bool))
    rng = np.random.default_rng(7)
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    for k, gap0 in enumerate(PLACEMENTS):
        force, theta = Replay(model, e, ["F_g", "theta_m"], ["T_cog", "phase_cog"], [1.0, 1.0],
                              {**FIXED, "gap0": gap0}, rtol=1e-8).outputs(list(COGGING))
        load_cell = np.arange(len(t)) % 10 == 0
        noisy = force + rng.normal(0, 0.5, len(t))
        angle = np.floor(theta / COUNT) * COUNT
        rows = "\n".join(f"{a:.3f},{b:.1f},{f'{c:.3f}' if on else ''},{d:.6f}"
                         for a, b, c, d, on in zip(t, i, noisy, angle, load_cell))
        (HERE / f"impact_trial{k}.csv").write_text(header + "time,i_ref,F_g,theta_m\n" + rows + "\n",
                                                   encoding="utf-8")


if __name__ == "__main__":
    main()
