"""P3's impact as the model runs it: force, q current and outer-loop mode around the contact, for the shipped
P3 impact config (examples/gripper_impact_p3.toml) with the outer loop started 0, 3 and 6 ms late (three
contact phases of the 100 Hz loop), and the instants that make the mechanism (docs/models/gripper.md, "P3's
impact, as measured in runs"): contact, end of the soft region (the force reaches k_P d_lim), peak, switch.

Run from the repository root (builds nothing: uses fmus/GripperPlant.fmu; about 1 min on 2 quiet cores):
    python3 docs/models/p3_impact_plot.py [--speed 1000] [--current 2.5]
Writes docs/models/gripper_p3_impact.png and prints one line of instants and forces per phase.
"""

import argparse
import sys
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from cosim.config import load_config  # noqa: E402
from cosim.master.engine import engine_for  # noqa: E402
from cosim.master.summary import summarize  # noqa: E402

CONFIG = ROOT / "examples" / "gripper_impact_p3.toml"
DELAYS = (0.0, 0.003, 0.006)  # s: the outer loop's ramp started this late (controller_phase)


def run(delay, speed, current):
    """One trial: (recorded data, summary, plant parameters)."""
    sets = [f"controllers.outer.parameters.t_start={delay!r}", f"controllers.outer.parameters.speed_rpm={speed!r}",
            f"controllers.outer.parameters.i_tight={current!r}", "record.rate=26600",
            'record.signals=["plant.F_g", "plant.i_q", "outer.mode", "outer.i_q_ref"]', "plot.panels=[]"]
    config = load_config(CONFIG, sets)
    result = engine_for(config).run(progress=False)
    return result.data, summarize(result, config), config.fmus["plant"].parameters


def instants(data, summary, params):
    """Contact, end of the soft region, peak and switch (s), and the steady force (N)."""
    t, f = np.asarray(data["time"]), np.asarray(data["F_g"])
    f_lim = params["k_P"] * params["d_lim"]
    contact = summary["t_contact_s"]
    soft_end = t[np.argmax((t > contact) & (f >= f_lim))]
    peak = t[np.argmax(f)]
    return {"contact": contact, "soft_end": soft_end, "peak": peak, "switch": summary["t_switch_s"],
            "F_lim": f_lim, "peak_N": summary["peak_force_N"], "steady_N": summary["steady_force_N"],
            "i_q_at_peak": float(np.asarray(data["i_q"])[np.argmax(f)])}


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--speed", type=float, default=1000.0, help="impact speed (motor rpm)")
    args.add_argument("--current", type=float, default=2.5, help="tightening current (A)")
    opts = args.parse_args()
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    for delay, color in zip(DELAYS, ("tab:blue", "tab:orange", "tab:green")):
        data, summary, params = run(delay, opts.speed, opts.current)
        m = instants(data, summary, params)
        t = (np.asarray(data["time"]) - m["contact"]) * 1e3
        window = (t > -5) & (t < 60)
        label = f"loop {delay * 1e3:.0f} ms late"
        axes[0].plot(t[window], np.asarray(data["F_g"])[window], color=color, label=label)
        axes[1].plot(t[window], np.asarray(data["i_q"])[window], color=color)
        axes[2].plot(t[window], np.asarray(data["outer.mode"])[window], color=color)
        for ax in axes:
            ax.axvline((m["switch"] - m["contact"]) * 1e3, color=color, ls=":", lw=1)
        axes[0].plot((m["peak"] - m["contact"]) * 1e3, m["peak_N"], "v", color=color)
        print(f"{label}: soft region ends {1e3 * (m['soft_end'] - m['contact']):.1f} ms after contact "
              f"(F = k_P d_lim = {m['F_lim']:.1f} N); peak {m['peak_N']:.0f} N at {1e3 * (m['peak'] - m['contact']):.1f}"
              f" ms, i_q {m['i_q_at_peak']:.2f} A; switch {1e3 * (m['switch'] - m['peak']):.1f} ms after the peak; "
              f"steady {m['steady_N']:.1f} N")
    axes[0].axhline(m["F_lim"], color="0.5", lw=0.8, ls="--", label="k_P d_lim (end of the soft region)")
    axes[0].set_ylabel("F_g [N]")
    axes[0].legend(fontsize=8)
    axes[0].set_title(f"P3, {opts.speed:g} rpm, {opts.current:g} A: examples/gripper_impact_p3.toml "
                      "(dotted: the switch)", fontsize=10)
    axes[1].set_ylabel("i_q [A]")
    axes[2].set_ylabel("mode (0 velocity, 1 current)")
    axes[2].set_xlabel("time after contact [ms]")
    fig.tight_layout()
    fig.savefig(Path(__file__).resolve().parent / "gripper_p3_impact.png", dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
