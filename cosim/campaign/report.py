"""A campaign's files: trials.parquet, table1.csv (steady-force statistics a cell), table1.md beside the paper's
IQRs (Table 1 and the Fig. 11 text, shipped in ``cosim/data/gripper_force_iqr.csv``), boxplots.png in the
style of the paper's Fig. 12 and summary.json."""

import json
import math
import os
from importlib import resources

import numpy as np
import pandas as pd

from cosim.campaign.execute import parameters_files

__all__ = ["TABLE_COLUMNS", "table1", "paper_iqrs", "campaign_result", "write_report"]

TABLE_COLUMNS = ("coating", "speed_rpm", "current_A", "n", "median_N", "q1_N", "q3_N", "iqr_N", "outlier_share")
_CELL = ["coating", "speed_rpm", "current_A"]


def table1(trials, coatings=None):
    """Steady-force statistics of each cell: median, quartiles (numpy's linear percentiles), IQR and the
    share of outliers (beyond 1.5 IQR from the quartiles, the box plot's whiskers).

    Parameters
    ----------
    trials : pandas.DataFrame
        Rows of trials.parquet; trials without a steady force (NaN) are left out of ``n``.
    coatings : sequence of str, optional
        Row order of the coatings (default: as they appear).

    Returns
    -------
    pandas.DataFrame
        :data:`TABLE_COLUMNS`, one row a cell, forces in N.
    """
    rows = []
    order = list(coatings) if coatings is not None else list(dict.fromkeys(trials["coating"]))
    for (c, v, i), g in trials.groupby(_CELL, sort=False):
        f = g["steady_force_N"].to_numpy(dtype=float)
        f = f[np.isfinite(f)]
        if len(f):
            q1, med, q3 = np.percentile(f, [25, 50, 75])
            iqr = q3 - q1
            out = np.mean((f < q1 - 1.5 * iqr) | (f > q3 + 1.5 * iqr))
        else:
            q1 = med = q3 = iqr = out = math.nan
        rows.append((c, float(v), float(i), len(f), med, q1, q3, iqr, out))
    table = pd.DataFrame(rows, columns=list(TABLE_COLUMNS))
    table["_o"] = table["coating"].map({c: k for k, c in enumerate(order)})
    return table.sort_values(["_o", "speed_rpm", "current_A"]).drop(columns="_o").reset_index(drop=True)


def paper_iqrs():
    """The paper's steady-force IQRs by (coating, speed_rpm, current_A): Table 1, else the Fig. 11 text.

    Returns
    -------
    dict of tuple to float
        N.
    """
    with resources.files("cosim").joinpath("data", "gripper_force_iqr.csv").open("r", encoding="utf-8") as fh:
        t = pd.read_csv(fh)
    out = {}
    for r in t.itertuples():
        key = (r.coating, float(r.speed_rpm), float(r.current_A))
        if key not in out or "Table 1" in r.source:
            out[key] = float(r.iqr_N)
    return out


def _fmt(x, digits=2):
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.{digits}f}"


def _markdown(table, paper, job):
    """table1.md: per cell the median and IQR of each coating beside the paper's IQR."""
    coatings = [c.name for c in job.coatings]
    head = ["speed (rpm)", "current (A)"]
    for c in coatings:
        head += [f"{c} median (N)", f"{c} IQR (N)", f"{c} paper IQR (N)"]
    lines = ["# Steady-state force by cell: this campaign beside the paper's Table 1", "",
             f"{job.trials} trials a cell; steady force = mean of the load cell's {job.load_cell_rate:g} Hz samples "
             f"over the last {job.steady_s:g} s of {job.hold_s:g} s of tightening. Paper IQRs: Table 1 (bare, P3) "
             "and the text on Fig. 11 (P1, P2 at 1000 rpm); – where the paper gives none.", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    idx = table.set_index(_CELL)
    for v in job.speeds_rpm:
        for i in job.currents_A:
            cells = [f"{v:g}", f"{i:g}"]
            for c in coatings:
                r = idx.loc[(c, v, i)] if (c, v, i) in idx.index else None
                cells += [_fmt(r["median_N"] if r is not None else None), _fmt(r["iqr_N"] if r is not None else None),
                          _fmt(paper.get((c, v, i)))]
            lines.append("| " + " | ".join(cells) + " |")
    lines += ["", _comparison(table, paper, "P3", "bare")]
    return "\n".join(lines) + "\n"


def _comparison(table, paper, soft, hard):
    """One sentence: in how many cells the soft coating's IQR is below the hard one's, here and in the paper."""
    idx = table.set_index(_CELL)
    cells = [(v, i) for (c, v, i) in idx.index if c == soft and (hard, v, i) in idx.index]
    if not cells:
        return f"(no cell with both {soft} and {hard})"
    here = sum(idx.loc[(soft, v, i), "iqr_N"] < idx.loc[(hard, v, i), "iqr_N"] for v, i in cells)
    both = [(v, i) for v, i in cells if (soft, v, i) in paper and (hard, v, i) in paper]
    there = sum(paper[(soft, v, i)] < paper[(hard, v, i)] for v, i in both)
    return (f"{soft}'s IQR below {hard}'s: {here} of {len(cells)} cells here; in the paper {there} of {len(both)} "
            "of the same cells.")


def _boxplots(trials, job, path):
    """boxplots.png: one panel a coating, boxes of the steady force grouped by speed, one colour a current."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    coatings = [c.name for c in job.coatings]
    fig, axes = plt.subplots(len(coatings), 1, figsize=(9, 2.6 * len(coatings)), sharex=True, sharey=True,
                             squeeze=False)
    colors = plt.get_cmap("viridis")(np.linspace(0.1, 0.9, len(job.currents_A)))
    n_i = len(job.currents_A)
    for ax, c, letter in zip(axes[:, 0], coatings, "abcdefgh"):
        for kv, v in enumerate(job.speeds_rpm):
            for ki, i in enumerate(job.currents_A):
                g = trials[(trials.coating == c) & (trials.speed_rpm == v) & (trials.current_A == i)]
                f = g["steady_force_N"].to_numpy(dtype=float)
                f = f[np.isfinite(f)]
                if not len(f):
                    continue
                b = ax.boxplot(f, positions=[kv * (n_i + 1) + ki], widths=0.7, patch_artist=True,
                               flierprops={"marker": "o", "markersize": 3, "markerfacecolor": "none"})
                b["boxes"][0].set_facecolor(colors[ki])
        ax.set_title(f"({letter}) {c}", loc="left", fontsize=10)
        ax.set_ylabel("steady-state force (N)")
        ax.grid(axis="y", alpha=0.3)
    ticks = [kv * (n_i + 1) + (n_i - 1) / 2 for kv in range(len(job.speeds_rpm))]
    axes[-1, 0].set_xticks(ticks, [f"{v:g} rpm" for v in job.speeds_rpm])
    axes[-1, 0].set_xlabel("impact speed (motor, rpm); boxes: tightening current (A)")
    handles = [plt.Rectangle((0, 0), 1, 1, color=colors[k]) for k in range(n_i)]
    axes[0, 0].legend(handles, [f"{i:g} A" for i in job.currents_A], ncol=n_i, fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def campaign_result(trials, job, run_info):
    """The :class:`~cosim.campaign.result.CampaignResult` of a campaign's trials.

    Parameters
    ----------
    trials : pandas.DataFrame
        Every trial of the campaign (trials.parquet's rows), in grid order (as
        :func:`cosim.campaign.execute.read_parts` returns them).
    job : cosim.campaign.job.CampaignJob
    run_info : dict
        What :func:`cosim.campaign.execute.run_trials` returned (timings, workers); the result's ``run`` adds
        ``trial_s`` (wall time a trial, on its worker), ``overhead_share`` (the part of it outside the engine's
        loop) and the machine's load average.

    Returns
    -------
    CampaignResult
    """
    from cosim.campaign.result import CampaignResult

    table = table1(trials, [c.name for c in job.coatings])
    paper = paper_iqrs()
    ran = run_info["ran"]
    return CampaignResult(
        job=str(job.path), overrides=list(job.overrides), trials=int(len(trials)), cells=int(len(table)),
        no_steady_force=int(trials["steady_force_N"].isna().sum()),
        bounced_share=float(trials["bounced"].mean()) if len(trials) else None,
        p3_iqr_below_bare=_comparison(table, paper, "P3", "bare"), parameters_files=parameters_files(job),
        run={**run_info,
             "trial_s": run_info["trials_s"] / ran if run_info["ran"] else None,
             "overhead_share": 1.0 - run_info["loop_s"] / run_info["trials_s"] if run_info["trials_s"] else None,
             "load_average_1min": float(os.getloadavg()[0])},
        records=trials, table=table, table_markdown=_markdown(table, paper, job))


def write_report(result, job, out):
    """Write trials.parquet, table1.csv, table1.md, boxplots.png and summary.json into ``out``.

    Parameters
    ----------
    result : CampaignResult
        What :func:`campaign_result` made of the trials.
    job : cosim.campaign.job.CampaignJob
    out : pathlib.Path
    """
    result.records.to_parquet(out / "trials.parquet", index=False)
    result.table.to_csv(out / "table1.csv", index=False)
    (out / "table1.md").write_text(result.table_markdown, encoding="utf-8")
    _boxplots(result.records, job, out / "boxplots.png")
    (out / "summary.json").write_text(json.dumps(result.to_json(), indent=2) + "\n", encoding="utf-8")
