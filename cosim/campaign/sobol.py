"""Variance-based (Sobol) sensitivity: the sample of parameter points and the indices with their confidence
intervals, through SALib (Saltelli's sampling on a scrambled Sobol sequence; Jansen's total-effect and Saltelli's
first-order estimators; bootstrap intervals), and the table and plot of ``cosim sensitivity``.

A factor may be sampled on a log scale (uniform in its logarithm: a damping or a stiffness ratio known to a
factor, not to an interval); the indices are of the factor whatever its scale.
"""

import math

import matplotlib
import numpy as np
import pandas as pd

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["Factor", "sample_points", "sobol_indices", "index_table", "TABLE_COLUMNS", "plot_indices"]

TABLE_COLUMNS = ("coating", "speed_rpm", "current_A", "statistic", "mean_N", "sd_N", "factor", "S1", "S1_conf",
                 "ST", "ST_conf")


class Factor:
    """One uncertain input: its name, range and scale (``"linear"`` or ``"log"``).

    Parameters
    ----------
    name : str
    low, high : float
        The range (low < high; both > 0 on a log scale).
    scale : {"linear", "log"}, default "linear"
    """

    def __init__(self, name, low, high, scale="linear"):
        self.name, self.low, self.high, self.scale = name, float(low), float(high), scale

    def bounds(self):
        """The range in the sampled coordinate (the logarithm on a log scale)."""
        if self.scale == "log":
            return [math.log(self.low), math.log(self.high)]
        return [self.low, self.high]

    def value(self, u):
        """The factor's value at sampled coordinate ``u`` (float; its logarithm on a log scale)."""
        return float(math.exp(u)) if self.scale == "log" else float(u)


def _problem(factors):
    return {"num_vars": len(factors), "names": [f.name for f in factors], "bounds": [f.bounds() for f in factors]}


def sample_points(factors, n, seed):
    """Saltelli's sample for first-order and total indices: ``n (D + 2)`` points, in the factors' own units.

    Parameters
    ----------
    factors : sequence of Factor
    n : int
        Base samples (a power of 2 keeps the Sobol sequence balanced).
    seed : int
        Seed of the sequence's scrambling: the same seed gives the same points.

    Returns
    -------
    list of dict
        factor name -> value, one dict a point, in SALib's order (the order :func:`sobol_indices` expects).
    """
    from SALib.sample import sobol

    raw = sobol.sample(_problem(factors), n, calc_second_order=False, seed=seed)
    return [{f.name: f.value(u) for f, u in zip(factors, row)} for row in raw]


def sobol_indices(factors, y, resamples=500, confidence=0.95, seed=0):
    """First-order and total Sobol indices of one output, with bootstrap confidence intervals.

    Parameters
    ----------
    factors : sequence of Factor
    y : array_like
        The output at the points of :func:`sample_points` (same order).
    resamples : int, default 500
        Bootstrap resamples of the intervals.
    confidence : float, default 0.95
    seed : int, default 0
        Seed of the bootstrap.

    Returns
    -------
    dict
        ``S1``, ``S1_conf``, ``ST``, ``ST_conf``: arrays, one value a factor (``*_conf``: half-width of the
        interval); all NaN when ``y`` has no variance or a non-finite value.
    """
    from SALib.analyze import sobol

    y = np.asarray(y, dtype=float)
    if not np.all(np.isfinite(y)) or np.var(y) == 0.0:
        nan = np.full(len(factors), np.nan)
        return {"S1": nan, "S1_conf": nan, "ST": nan, "ST_conf": nan}
    r = sobol.analyze(_problem(factors), y, calc_second_order=False, num_resamples=resamples,
                      conf_level=confidence, seed=seed)
    return {k: np.asarray(r[k], dtype=float) for k in ("S1", "S1_conf", "ST", "ST_conf")}


def plot_indices(table, path):
    """Total (bars) and first-order (dots) indices with their intervals, one panel an output.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`index_table`'s rows.
    path : path-like
        The PNG written.
    """
    outputs = list(table.groupby(["coating", "speed_rpm", "current_A", "statistic"], sort=False))
    cols = 2
    rows = math.ceil(len(outputs) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(11, 2.6 * rows), squeeze=False, sharey=True)
    for ax, ((coating, rpm, amp, stat), t) in zip(axes.flat, outputs):
        x = np.arange(len(t))
        ax.bar(x, t["ST"], yerr=t["ST_conf"], color="tab:blue", alpha=0.6, capsize=3, label="total ST")
        ax.errorbar(x, t["S1"], yerr=t["S1_conf"], fmt="o", color="tab:red", capsize=3, label="first order S1")
        ax.set_xticks(x, t["factor"], fontsize=8)
        ax.set_title(f"{coating} {rpm:g} rpm {amp:g} A: steady-force {stat} "
                     f"({t['mean_N'].iloc[0]:.1f} ± {t['sd_N'].iloc[0]:.1f} N)", fontsize=9)
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.set_ylim(-0.2, 1.2)
    for ax in list(axes.flat)[len(outputs):]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def index_table(factors, outputs, resamples, confidence, seed):
    """The table of ``cosim sensitivity``: one row an output and factor (:data:`TABLE_COLUMNS`).

    Parameters
    ----------
    factors : sequence of Factor
    outputs : dict
        ``(coating, speed_rpm, current_A, statistic)`` -> the output at every point.
    resamples, confidence, seed
        As :func:`sobol_indices`.

    Returns
    -------
    pandas.DataFrame
    """
    rows = []
    for (coating, rpm, amp, stat), y in outputs.items():
        r = sobol_indices(factors, y, resamples, confidence, seed)
        for k, f in enumerate(factors):
            rows.append((coating, rpm, amp, stat, float(np.mean(y)), float(np.std(y)), f.name,
                         *(float(r[c][k]) for c in ("S1", "S1_conf", "ST", "ST_conf"))))
    return pd.DataFrame(rows, columns=list(TABLE_COLUMNS))
