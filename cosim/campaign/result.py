"""The typed result of a campaign (:func:`cosim.campaign.campaign`): what ``summary.json`` holds is
:meth:`CampaignResult.to_json`, and its tables are those of trials.parquet, table1.csv and table1.md."""

from dataclasses import dataclass, field, fields
from pathlib import Path

import pandas as pd

__all__ = ["CampaignResult"]


@dataclass(frozen=True)
class CampaignResult:
    """The result of a campaign job: the attributes down to ``run`` are the keys of that name in summary.json
    (:meth:`to_json`).

    Attributes
    ----------
    job : str
        The job file.
    overrides : list of str
        Its ``--set`` items.
    trials, cells : int
        The trials in ``records`` and the cells (coating x speed x current) of ``table``.
    no_steady_force : int
        Trials without a steady force.
    bounced_share : float or None
        The share of trials whose jaw bounced (None without trials).
    p3_iqr_below_bare : str
        In how many cells P3's IQR is below the bare fingers', here and in the paper.
    parameters_files : dict
        The parameters files the trials read, with their SHA-256 and provenance.
    run : dict
        Trials run and resumed, times, workers, and ``interrupted`` (True after Ctrl-C: the other attributes are
        those of the trials finished, and nothing but the finished trials' parts was written).
    records : pandas.DataFrame
        Every trial (trials.parquet), in grid order.
    table : pandas.DataFrame
        Steady-force statistics of each cell (table1.csv, :func:`cosim.campaign.report.table1`).
    table_markdown : str
        table1.md: the medians and IQRs beside the paper's IQRs.
    out : pathlib.Path or None
        The campaign folder (None when the trials ran in a temporary folder).
    """

    job: str
    overrides: list
    trials: int
    cells: int
    no_steady_force: int
    bounced_share: float | None
    p3_iqr_below_bare: str
    parameters_files: dict
    run: dict
    records: pd.DataFrame = field(repr=False, compare=False)
    table: pd.DataFrame = field(repr=False, compare=False)
    table_markdown: str = field(repr=False)
    out: Path | None = None

    @property
    def interrupted(self):
        """Whether the campaign was interrupted (Ctrl-C) before every trial ran."""
        return self.run["interrupted"]

    def to_json(self):
        """The content of summary.json."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in _NOT_IN_SUMMARY}


_NOT_IN_SUMMARY = ("records", "table", "table_markdown", "out")
