"""Write rounds_demo.csv: demonstration data for examples/diagnose_rounds.toml (not a measurement).

A current-mode impact of the gripper (Gripper.GripperCurrentDriven) with P2-coated fingers: the current steps from 0
to 1 A at t = 0.05 s and the coated fingers close 5 mm onto the ABS cylinders, recorded at 500 Hz. The "plant"
differs from the baseline in two ways: its coating's first region follows a power law with exponent 1.8 (the
Gripper.Forms.PowerLawCoatingContact block; the baseline's is linear) and its load cell lags by 5 ms with a 1.5 N
offset (Gripper.Effects.LoadCell; the baseline's is ideal). Replayed by CVODES, plus Gaussian load-cell noise
(0.5 N, seed 11). It shows a form and an effect found in two rounds.

Run: python examples/data/rounds_demo.py   (rewrites rounds_demo.csv beside this file)
"""

import tempfile
from pathlib import Path

import numpy as np

from cosim.compile import lower
from cosim.diagnose import EFFECTS, write_variant
from cosim.diagnose.fitting import Replay
from cosim.experiment import Experiment

HERE = Path(__file__).resolve().parent
FIXED = {"gap0": 0.0075, "t_coat": 0.0025, "k_obj": 3.53e7, "k_P": 1.8e5, "k_H_ratio": 100.0, "d_lim": 0.0015,
         "C_p": 10.0, "C_h": 2000.0}
N_C, TAU_LC, F_OFF = 1.8, 0.005, 1.5


def main():
    t = np.arange(0, 1.0, 2e-3)
    i = np.where(t >= 0.05 - 1e-9, 1.0, 0.0)
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(HERE.parent.parent / "modelica" / "Gripper" / "package.mo",
                                   "Gripper.GripperCurrentDriven",
                                   [EFFECTS["power_law_coating"], EFFECTS["loadcell_filter"]], folder)
        model = lower(path, name)
    e = Experiment(time=t, inputs=i[:, None], measured=np.zeros((len(t), 1)), weights=np.ones(1),
                   mask=np.ones(len(t), bool))
    force = Replay(model, e, ["F_g"], ["n_c", "tau_lc", "F_off"], [1.0, 1.0, 1.0], FIXED, rtol=1e-8).outputs(
        [N_C, TAU_LC, F_OFF])[0]
    force = force + np.random.default_rng(11).normal(0, 0.5, len(t))
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    rows = "\n".join(f"{a:.3f},{b:.1f},{c:.3f}" for a, b, c in zip(t, i, force))
    (HERE / "rounds_demo.csv").write_text(header + "time,i_ref,F_g\n" + rows + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
