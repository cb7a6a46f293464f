"""Write impact_p3.csv: a synthetic "measured" impact of the gripper with P3 coated fingers on the ABS cylinder
(1000 rpm, 1 A tightening), for the contact calibration job. Known truth: the plant parameters of
examples/gripper_impact_p3.toml with the coating's region boundary d_lim = 0.5 mm, and the shaft inertia and the
second-region damping pinned to the model's defaults (J_r = 1e-5 kg.m2, C_h = 2000 N.s/m), which the calibration
job assumes (the impact config itself carries the values fitted to the paper, cosim/data/gripper_impact_fit.csv).

How it is measured, as in the gripper paper's setup: the co-simulation (GripperPlant FMU, FOC at 26.6 kHz,
outer loop at 100 Hz) is run by `cosim run`; the q current is logged at 2660 Hz (the drive's log); the load
cell is sampled at 100 Hz with 0.5 N noise (1 sd); the motor angle comes from the 2048 cpt encoder (quantised to
whole counts) at the same instants. Rows where a channel was not sampled hold no value.

Run: python examples/data/impact_measurement.py   (needs the FMUs: cosim build)
"""

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from cosim.master import run_config

HERE = Path(__file__).resolve().parent
TRUTH = {"d_lim": 0.0005, "J_r": 1e-5, "C_h": 2000.0}
DAQ_HZ, FORCE_NOISE_N, COUNTS = 100.0, 0.5, 2048


def main():
    overrides = [f"fmus.plant.parameters.{k}={v}" for k, v in TRUTH.items()]
    overrides.append('record.signals=["plant.F_g", "plant.i_q", "plant.w_m", "plant.theta_m"]')
    with tempfile.TemporaryDirectory() as out:
        run_config(HERE.parent / "gripper_impact_p3.toml", out=out, overrides=overrides, progress=False)
        run = pd.read_parquet(Path(out) / "results.parquet")
    t = run["time"].to_numpy()
    rng = np.random.default_rng(2026)
    # The DAQ instants k/100 s fall between logged rows (2660 Hz): take the nearest row (<= 0.19 ms away).
    daq = np.zeros(len(t), bool)
    daq[np.searchsorted(t, np.arange(0.0, t[-1], 1.0 / DAQ_HZ))] = True
    force = np.full(len(t), np.nan)
    force[daq] = run["F_g"].to_numpy()[daq] + FORCE_NOISE_N * rng.standard_normal(daq.sum())
    angle = np.full(len(t), np.nan)
    angle[daq] = np.floor(run["theta_m"].to_numpy()[daq] * COUNTS / (2 * np.pi)) * (2 * np.pi / COUNTS)
    table = pd.DataFrame({"time": t, "i_q": run["i_q"].to_numpy(), "F_g": force, "theta_m": angle})
    path = HERE / "impact_p3.csv"
    header = "# " + __doc__.strip().replace("\n", "\n# ") + "\n"
    path.write_text(header + table.to_csv(index=False, float_format="%.6g"))
    print(f"wrote {path}: {len(t)} rows, {daq.sum()} load-cell samples")


if __name__ == "__main__":
    main()
