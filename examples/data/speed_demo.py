"""Write speed_demo.csv: demonstration data for examples/diagnose_speed.toml (not a measurement).

A slow run of the gripper under a PI speed loop (Gripper.GripperSpeedControlled, K_pw = 0.05 A.s/rad,
K_iw = 2.5 A/rad): jaws open and free (the object 15 mm away), the motor speed reference held at 0, 2, 3.5, 2.5
and 4 rad/s (0.05 s, then 0.35 s each). The "plant" is the baseline model with a motor cogging torque (the
`cogging` candidate's own Modelica: 2.5 mN.m, phase -1 rad), replayed by CVODES. Recorded at 1 kHz as the drive
logs it: the q current with Gaussian sensor noise (10 mA, seed 7) and the 2048 cpt encoder (whole counts).

Run: python examples/data/speed_demo.py   (rewrites speed_demo.csv beside this file)
"""

import tempfile
from pathlib import Path

import numpy as np

from cosim.compile import lower
from cosim.diagnose import EFFECTS, write_variant
from cosim.diagnose.fitting import Replay
from cosim.experiment import Experiment

HERE = Path(__file__).resolve().parent
FIXED = {"gap0": 0.015}
SPEEDS = ((0.0, 0.0), (0.05, 2.0), (0.4, 3.5), (0.75, 2.5), (1.1, 4.0))  # (from time [s], motor speed [rad/s])
COGGING = (2.5e-3, -1.0)  # N.m, rad: T_cog, phase_cog
COUNT = 2 * np.pi / 2048  # rad


def main():
    t = np.round(np.arange(0, 1.45, 1e-3), 6)
    w_ref = np.zeros(len(t))
    for start, speed in SPEEDS:
        w_ref[t >= start - 1e-9] = speed
    source = HERE.parent.parent / "modelica" / "Gripper" / "package.mo"
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(source, "Gripper.GripperSpeedControlled", EFFECTS["cogging"], folder)
        model = lower(path, name)
    e = Experiment(time=t, inputs=w_ref[:, None], measured=np.zeros((len(t), 2)), weights=np.ones(2),
                   mask=np.ones(len(t), bool))
    current, theta = Replay(model, e, ["i_q", "theta_m"], ["T_cog", "phase_cog"], [1.0, 1.0], FIXED,
                            rtol=1e-8).outputs(list(COGGING))
    noisy = current + np.random.default_rng(7).normal(0, 0.01, len(t))
    angle = np.floor(theta / COUNT) * COUNT
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    rows = "\n".join(f"{a:.3f},{b:.1f},{c:.4f},{d:.6f}" for a, b, c, d in zip(t, w_ref, noisy, angle))
    (HERE / "speed_demo.csv").write_text(header + "time,w_ref,i_q,theta_m\n" + rows + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
