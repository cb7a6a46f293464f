"""What makes each cell of a campaign's Table 1 disagree with the paper: for every cell where the model's order of
P3's and bare's steady-force IQR differs from the paper's, the figures that tell the mechanisms apart.

    PYTHONPATH=. python benchmarks/campaign_causes.py OUT        # OUT: a finished `cosim campaign` folder

Per coating of such a cell: the steady force's median and 10-90 % range beside the gear's holding band at the
cell's current (a force between the driving level eta N (k_t i - T_c0) / (2 r_p) and the back-driving level
N (k_t i + T_c0) / (eta 2 r_p) is held by the gear's friction; the values the campaign's configs ran with), the
peak's median and IQR, the correlation of steady force with peak (near 1: the force stays where the peak left it;
near 0 with a tight peak: the rebound was frozen at a varying point), the share of bounced trials, and the
sources of variability that explain most of the steady force's variance on their own (correlation ratio over five
quantile bins; with 100 trials, values below about 0.1 are noise).
"""

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from cosim.campaign import load_campaign
from cosim.campaign.report import paper_iqrs
from cosim.config import load_config

SOURCES = ["free_travel_m", "play_position", "encoder_phase", "friction_scatter", "gear_efficiency",
           "load_cell_noise_N"]


def holding_band(config, current):
    """(driving, back-driving) force in N at ``current`` (A) with the plant parameters the run config sets."""
    plant = config.fmus["plant"]
    p = {n: float(plant.parameters.get(n, plant.info.variables[n].start)) for n in ("eta_g", "ratio", "k_t", "T_c0",
                                                                                     "r_p")}
    drive = p["eta_g"] * p["ratio"] * (p["k_t"] * current - p["T_c0"]) / (2 * p["r_p"])
    back = p["ratio"] * (p["k_t"] * current + p["T_c0"]) / (p["eta_g"] * 2 * p["r_p"])
    return drive, back


def correlation_ratio(x, y, bins=5):
    """Share of the variance of ``y`` explained by the quantile bin of ``x``."""
    group = pd.qcut(x, bins, labels=False, duplicates="drop")
    mean = y.groupby(group).transform("mean")
    return 1.0 - float(((y - mean) ** 2).sum() / ((y - y.mean()) ** 2).sum())


def describe(cell, band):
    y, peak = cell["steady_force_N"], cell["peak_force_N"]
    q1, q3 = np.percentile(y, [25, 75])
    p10, p90 = np.percentile(y, [10, 90])
    shares = sorted(((correlation_ratio(cell[s], y), s) for s in SOURCES), reverse=True)[:2]
    return (f"median {y.median():.1f} N, IQR {q3 - q1:.1f} N, 10-90 % {p10:.0f}-{p90:.0f} N (band {band[0]:.0f}-"
            f"{band[1]:.0f} N); peak {peak.median():.0f} N (IQR {np.subtract(*np.percentile(peak, [75, 25])):.1f}); "
            f"corr(steady, peak) {np.corrcoef(y, peak)[0, 1]:.2f}; bounced {100 * cell['bounced'].mean():.0f} %; "
            "largest source shares " + ", ".join(f"{s} {v:.2f}" for v, s in shares))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="a finished cosim campaign output folder")
    args = ap.parse_args(argv)
    summary = json.loads((args.out / "summary.json").read_text(encoding="utf-8"))
    trials = pd.read_parquet(args.out / "trials.parquet")
    paper = paper_iqrs()
    job = load_campaign(summary["job"], summary["overrides"])
    configs = {c.name: load_config(c.config, [f"fmus.plant.parameters.{k}={v!r}" for k, v in c.parameters.items()])
               for c in job.coatings}
    for (speed, current), cell in trials[trials.coating.isin(["bare", "P3"])].groupby(["speed_rpm", "current_A"]):
        iqr = {c: np.subtract(*np.percentile(g["steady_force_N"], [75, 25])) for c, g in cell.groupby("coating")}
        model, measured = iqr["P3"] < iqr["bare"], paper[("P3", speed, current)] < paper[("bare", speed, current)]
        if model == measured:
            continue
        print(f"{speed:g} rpm, {current:g} A: P3's IQR {'below' if model else 'above'} bare's here, "
              f"{'below' if measured else 'above'} in the paper (P3 {paper[('P3', speed, current)]:.2f} N, bare "
              f"{paper[('bare', speed, current)]:.2f} N)")
        for coating, g in cell.groupby("coating"):
            print(f"  {coating}: {describe(g, holding_band(configs[coating], current))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
