"""The shipped sensitivity job (examples/sensitivity_table1.toml) at a larger Saltelli sample than its default:
which estimated constant of the impact decides bare's and P3's steady-force median and IQR at 1000 rpm and 1 and
2 A, with intervals narrow enough to rank them, and the wall time it took.

    PYTHONPATH=. python benchmarks/sensitivity.py [--samples 32] [--out DIR] [--workers N] [--validation]

Runs ``cosim sensitivity`` on the job with ``--set sensitivity.samples=N`` (N a power of 2; the job's 8 trials a
cell, its seed, factors and ranges unchanged) into DIR (default: a new temporary folder), prints for every
statistic the factors with their total and first-order indices and 95 % intervals, the wall time and the load
average, and with ``--validation`` writes them into docs/validation.md (section ``sensitivity-table1``).
Needs fmus/GripperPlant.fmu (``cosim build``).
"""

import argparse
import os
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
JOB = ROOT / "examples" / "sensitivity_table1.toml"


def _interval(value, half):
    return f"{value:.2f} ± {half:.2f}"


def index_rows(table):
    """One row a (statistic, factor) with a total index whose interval is clear of 0, largest first per statistic;
    a statistic with none gets one row saying so."""
    rows = []
    for (coating, rpm, amp, stat), group in table.groupby(["coating", "speed_rpm", "current_A", "statistic"],
                                                          sort=False):
        name = f"{coating} {stat} at {amp:g} A ({group['mean_N'].iloc[0]:.1f} ± {group['sd_N'].iloc[0]:.1f} N)"
        resolved = group[group["ST"] - group["ST_conf"] > 0].sort_values("ST", ascending=False)
        for r in resolved.itertuples():
            rows.append([name, r.factor, _interval(r.ST, r.ST_conf), _interval(r.S1, r.S1_conf)])
        if resolved.empty:
            top = group.sort_values("ST", ascending=False).iloc[0]
            rows.append([name, f"none resolved (largest: {top.factor})", _interval(top.ST, top.ST_conf),
                         _interval(top.S1, top.S1_conf)])
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=32, help="Saltelli's base samples N (a power of 2)")
    parser.add_argument("--out", type=Path, help="output folder (new); default a temporary one")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--validation", action="store_true", help="write the table into docs/validation.md")
    args = parser.parse_args(argv)
    from cosim.campaign.sensitivity import load_sensitivity, run_sensitivity

    out = args.out or Path(tempfile.mkdtemp(prefix="cosim-sensitivity-")) / "out"
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    summary = run_sensitivity(JOB, out, overrides=[f"sensitivity.samples={args.samples}"], workers=args.workers)
    wall = time.perf_counter() - t0
    table = pd.read_csv(out / "indices.csv")
    rows = index_rows(table)
    for row in rows:
        print(" | ".join(row))
    note = (f"N = {args.samples}: {summary['points']} parameter points, {summary['trials']} co-simulated impacts "
            f"on {args.workers} workers in {wall / 60:.1f} min wall (load average {load_before:.1f} before, "
            f"{os.getloadavg()[0]:.1f} after); outputs in {out}.")
    print(note)
    if args.validation:
        from validation import write_section

        notes = [note, "Listed: the factors whose total index's 95 % interval is clear of 0, largest first; "
                       "the statistic's mean ± sd over the points beside its name."]
        write_section("sensitivity-table1", ["statistic", "factor", "total index ST", "first-order S1"], rows,
                      seeds=[load_sensitivity(JOB).seed], notes=notes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
