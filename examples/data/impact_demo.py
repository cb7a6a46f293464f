"""Write impact_demo.csv: demonstration data for examples/diagnose_impact.toml (not a measurement).

A current-mode impact of the gripper (Gripper.GripperCurrentDriven): the current steps from 0 to 1 A at
t = 0.02 s and the bare fingers close 2 mm onto the ABS cylinders (k_obj = 3.53e7 N/m), recorded at 1 kHz. The
"plant" is the baseline model with a larger gear play (1.4 deg instead of the 0.8 deg of the datasheet), replayed
by CVODES, plus Gaussian load-cell noise (0.5 N, seed 7). It shows the impact segmentation and a parameter-only
effect (`gear_play`); the paper gives no impact time series to rebuild.

Run: python examples/data/impact_demo.py   (rewrites impact_demo.csv beside this file)
"""

from pathlib import Path

import numpy as np

from cosim.compile import lower
from cosim.diagnose.fitting import Replay
from cosim.experiment import Experiment

HERE = Path(__file__).resolve().parent
FIXED = {"gap0": 0.002, "k_obj": 3.53e7, "t_coat": 0.0, "k_P": 1e12, "C_p": 2000.0, "C_h": 2000.0}
PLAY_DEG = 1.4


def main():
    t = np.arange(0, 0.3, 1e-3)
    i = np.where(t >= 0.02 - 1e-9, 1.0, 0.0)
    model = lower(HERE.parent.parent / "modelica" / "Gripper" / "package.mo", "Gripper.GripperCurrentDriven")
    e = Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 1)), weights=np.ones(1),
                   mask=np.ones(len(t), bool))
    force = Replay(model, e, ["F_g"], ["play"], [1.0], FIXED, rtol=1e-8).outputs([np.radians(PLAY_DEG)])[0]
    force = force + np.random.default_rng(7).normal(0, 0.5, len(t))
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    rows = "\n".join(f"{a:.3f},{b:.1f},{c:.3f}" for a, b, c in zip(t, i, force))
    (HERE / "impact_demo.csv").write_text(header + "time,i_ref,F_g\n" + rows + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
