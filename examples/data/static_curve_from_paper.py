"""Write static_paper.csv: the gripper's static force-current curve rebuilt from the figures the gripper paper
reports in its Sec. 4.2 (Fig. 8), as a time series of the current staircase that produced it.

What the paper gives (experiment, bare fingers on aluminium cylinders + load cell, 100 Hz DAQ):
  - current mode, 0.1 A steps lasting 5 s, up to 2.5 A; the way back down is implied by the release results
    and assumed symmetric;
  - 76.8 N at 2.5 A (end of the rising branch);
  - an initial force peak of 25.6 N (gearbox play) when the fingers first touch, then a friction plateau of
    13.2 N at 0.2-0.4 A;
  - on the way down the force stays constant down to about 0.9 A; 10 N residual at 0 A.
What is reconstructed (not in the paper): the rising branch is taken linear between the plateau (13.2 N at
0.4 A) and 76.8 N at 2.5 A; the release branch linear from 76.8 N at 0.9 A to 10 N at 0 A; the first touch at
the start of the 0.2 A step, the 25.6 N peak decaying to the plateau in 0.3 s; step changes of force are
otherwise immediate (only the last second of each step is used for fitting).

Run: python examples/data/static_curve_from_paper.py   (rewrites static_paper.csv beside this file)
"""

from pathlib import Path

import numpy as np

STEP_S, RATE_HZ = 5.0, 100.0
F_MAX, F_PLATEAU, F_PEAK, F_RESIDUAL = 76.8, 13.2, 25.6, 10.0
I_MAX, I_TOUCH, I_PLATEAU_END, I_HOLD = 2.5, 0.2, 0.4, 0.9


def force_up(i):
    if i < I_TOUCH - 1e-9:
        return 0.0
    if i <= I_PLATEAU_END + 1e-9:
        return F_PLATEAU
    return F_PLATEAU + (F_MAX - F_PLATEAU) * (i - I_PLATEAU_END) / (I_MAX - I_PLATEAU_END)


def force_down(i):
    if i >= I_HOLD - 1e-9:
        return F_MAX
    return F_RESIDUAL + (F_MAX - F_RESIDUAL) * i / I_HOLD


def staircase():
    up = np.round(np.arange(0.0, I_MAX + 1e-9, 0.1), 2)
    down = np.round(np.arange(I_MAX - 0.1, -1e-9, -0.1), 2)
    levels = np.concatenate([up, down])
    forces = [force_up(i) for i in up] + [force_down(i) for i in down]
    t = np.arange(0.0, len(levels) * STEP_S, 1.0 / RATE_HZ)
    k = np.minimum((t // STEP_S).astype(int), len(levels) - 1)
    current, force = levels[k], np.array(forces)[k]
    touch = np.flatnonzero(np.isclose(levels, I_TOUCH))[0] * STEP_S
    after = (t >= touch) & (t < touch + 0.3)
    force[after] = F_PEAK + (F_PLATEAU - F_PEAK) * (t[after] - touch) / 0.3
    return t, current, force


def main():
    t, current, force = staircase()
    out = Path(__file__).with_name("static_paper.csv")
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    rows = "\n".join(f"{a:.2f},{b:.1f},{c:.3f}" for a, b, c in zip(t, current, force))
    out.write_text(header + "time,i_ref,F_g\n" + rows + "\n")
    print(f"wrote {out} ({len(t)} samples, {t[-1] + 1 / RATE_HZ:.0f} s)")


if __name__ == "__main__":
    main()
