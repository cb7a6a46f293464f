"""Files and plots of the haptic analyses: what the ``cosim haptic ...`` commands write."""

from pathlib import Path

import numpy as np

from cosim.analysis.haptic_margins import MARGIN_COLUMNS, adaptive_damping, margins_table, position_means

__all__ = ["write_margins", "plot_margins"]


def plot_margins(table, path, title="Virtual wall margins"):
    """Plot K_CR and PM against grasp position (each user a thin line, the mean thick) to a PNG.

    Parameters
    ----------
    table : pandas.DataFrame
        A `margins_table`.
    path : str or Path
        Output PNG.
    title : str, optional
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    means = position_means(table)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, col, label in (
        (axes[0], "K_CR_Nm_per_rad", "K_CR (N.m/rad)"),
        (axes[1], "PM_deg", "phase margin (deg)"),
        (axes[2], "settling_s", "predicted settling 4/(zeta w_cg) (s)"),
    ):
        for u, g in table.groupby("user"):
            ax.plot(g["position"], g[col], color="0.7", lw=0.8, marker=".")
        ax.plot(means["position"], means[col], color="C0", lw=2.5, marker="o", label="mean of 13 users")
        u1 = table[table["user"] == 1]
        ax.plot(u1["position"], u1[col], color="C3", lw=1.5, marker="s", label="user 1")
        ax.set_xlabel("grasp position")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[1].axhline(50, color="k", ls=":", lw=1)
    axes[2].set_yscale("log")
    axes[0].legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_margins(out_dir, K=10.0, rate=1000.0, adaptive=False):
    """Compute the wall margins for 13 users x 6 positions and write them with per-position means and a plot.

    Parameters
    ----------
    out_dir : str or Path
        Directory to write into (created if needed).
    K : float, optional
        Wall stiffness, N.m/rad (default 10).
    rate : float, optional
        Loop rate, Hz (default 1000).
    adaptive : bool, optional
        Also tune B per position on user 1 for PM >= 50 deg and write the damped table (default False).

    Returns
    -------
    list of Path
        The files written: ``margins.csv``, ``margins_means.csv``, ``margins.png`` and, with ``adaptive``,
        ``adaptive_damping.csv``, ``margins_adaptive.csv``, ``margins_adaptive_means.csv``, ``margins_adaptive.png``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = margins_table(K=K, rate=rate)
    written = []
    p = out / "margins.csv"
    table[MARGIN_COLUMNS].to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    p = out / "margins_means.csv"
    position_means(table).to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    p = out / "margins.png"
    plot_margins(table, p, title=f"Virtual wall K = {K:g} N.m/rad, B = 0, {rate:g} Hz loop")
    written.append(p)
    if adaptive:
        B = adaptive_damping(user=1, K=K, rate=rate)
        p = out / "adaptive_damping.csv"
        with open(p, "w", encoding="utf-8") as fh:
            fh.write("position,B_Nms_per_rad\n")
            for pos, b in B.items():
                fh.write(f"{pos},{b:.6g}\n")
        written.append(p)
        damped = margins_table(K=K, rate=rate, damping=B)
        p = out / "margins_adaptive.csv"
        damped[MARGIN_COLUMNS + ["B_Nms_per_rad"]].to_csv(p, index=False, float_format="%.6g")
        written.append(p)
        p = out / "margins_adaptive_means.csv"
        position_means(damped).to_csv(p, index=False, float_format="%.6g")
        written.append(p)
        p = out / "margins_adaptive.png"
        plot_margins(damped, p, title=f"Adaptive wall K = {K:g} N.m/rad, B tuned on user 1 (PM >= 50 deg)")
        written.append(p)
    return written
