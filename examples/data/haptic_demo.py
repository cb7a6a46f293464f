"""Write haptic_demo.csv: demonstration data for examples/diagnose_haptic.toml (not a measurement).

The identification experiment of seed 000 Sec. II-C simulated on the PHANToM phi axis held by user 1 at grasp
position 4 (Table I, the 7-parameter row) whose torque command arrives 1.5 ms late: the "plant" is the Modelica
variant Haptic.Diagnosis.Device7_loop_delay (cosim diagnose's own loop_delay candidate, third-order Pade, so this
demonstrates the workflow, it does not test it: tests/diagnose_truth_haptic.py holds the independent truths). A
white-noise torque (0.1-150 Hz, 0.05 N.m RMS, 20 s at 1 kHz, seed 7) held by the DAC drives the linearised
plant; the encoder angle is quantised to 2 pi/(2048 * 20) rad (2048 counts per motor turn, 20:1 cable reduction
assumed); the frequency response phi/tau and its coherence are the Welch estimate (4096-point Hann, 50 %
overlap), kept over 1-100 Hz.

Run: python examples/data/haptic_demo.py   (rewrites haptic_demo.csv beside this file)
"""

import tempfile
from pathlib import Path

import control
import numpy as np

from cosim.freqresp import simulate_lti, welch_tf, white_noise
from cosim.haptic.params import load_user_params
from cosim.compile import lower
from cosim.diagnose import EFFECTS, write_variant

HERE = Path(__file__).resolve().parent
DELAY_S = 1.5e-3
FS = 1000.0
ENCODER_STEP = 2 * np.pi / (2048 * 20.0)


def main():
    values = {**load_user_params(1, 4).values, "T_d": DELAY_S}
    with tempfile.TemporaryDirectory() as folder:
        path, name = write_variant(HERE.parent.parent / "modelica" / "Haptic" / "package.mo", "Haptic.Device7",
                                   EFFECTS["loop_delay"], Path(folder))
        model = lower(path, name)
    p = np.array([values.get(q.name, q.start) for q in model.parameters])
    plant = control.ss(*model.linearization("tau", "phi")(p))
    u = white_noise(20.0, FS, band=(0.1, 150.0), rms=0.05, seed=7)
    y = ENCODER_STEP * np.round(simulate_lti(plant, u, FS) / ENCODER_STEP)
    fr = welch_tf(u, y, FS, window="hann", nperseg=4096).band(1.0, 100.0)
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    rows = "\n".join(f"{f:.6f},{20 * np.log10(abs(h)):.5f},{np.degrees(a):.4f},{c:.6f}"
                     for f, h, a, c in zip(fr.f, fr.H, np.unwrap(np.angle(fr.H)), fr.coherence))
    (HERE / "haptic_demo.csv").write_text(header + "frequency,magnitude_db,phase_deg,coherence\n" + rows + "\n",
                                          encoding="utf-8")


if __name__ == "__main__":
    main()
