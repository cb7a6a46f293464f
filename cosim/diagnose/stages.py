"""The results of the discrepancy workflow's stages (:mod:`cosim.diagnose.workflow`): each stage returns one of
these frozen records, and the next stages read it."""

from dataclasses import dataclass, field

import numpy as np

from cosim.experiment import Experiment

__all__ = ["Samples", "Split", "Scores", "Decision", "Show"]


@dataclass(frozen=True)
class Samples:
    """The measured records end to end, as every stage reads them.

    Attributes
    ----------
    model : cosim.compile.LoweredModel
        The baseline, lowered.
    records : list of (Experiment, dict)
        Each record and its trial's fixed values (:func:`~cosim.diagnose.job.load_records`).
    experiment : Experiment
        The records end to end (:func:`_end_to_end`).
    shifts : list of float
        Time shift of each record in ``experiment`` [s].
    sampled : list of ndarray of bool
        Per record, the instants where every compared channel has a sample.
    present, mask : ndarray of bool, shape (N,)
        The instants every channel has; the cost samples among them.
    channels, units : list of str
        Names and units of the compared channels.
    floor : ndarray, shape (n_signals,)
        The job's noise floor of each channel.
    """

    model: object
    records: list
    experiment: Experiment
    shifts: list
    sampled: list
    present: np.ndarray
    mask: np.ndarray
    channels: list
    units: list
    floor: np.ndarray

    @property
    def time(self):
        """Time [s] (frequency [Hz] for a frequency response), shape (N,)."""
        return self.experiment.time

    @property
    def measured(self):
        """The compared channels, shape (n_signals, N)."""
        return self.experiment.measured.T

    @property
    def n_fit(self):
        """The number of weighted residuals in the cost."""
        return int(self.mask.sum()) * self.measured.shape[0]


@dataclass(frozen=True)
class Split:
    """The segments (holds, impact phases, frequency bands; labelled by record for repeated trials), the segment
    ``shape`` classifier (None: the time-domain default) and the two folds, each (train, test) masks."""

    segments: list
    shape: object
    folds: list


@dataclass(frozen=True)
class Scores:
    """The baseline's fit on every cost sample (``base``, a :class:`~cosim.diagnose.fitting.Fit`, refitted when
    a candidate showed it a better start), the fits per fold (``fits``: "baseline" and each refitted effect ->
    [fold 0, fold 1]), the refitted ``candidates`` in the job's order and the ``screen`` of every candidate
    (effect -> :class:`~cosim.diagnose.fitting.Screen`)."""

    base: dict
    fits: dict
    candidates: tuple
    screen: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Decision:
    """The baseline's residual per segment (``rows``, :func:`~cosim.diagnose.analysis.segment_table`), its
    shapes, whiteness and cross-correlation with the input; whether it shows a gap (``mean_square`` in noise
    levels squared against ``chance``), the ``winner`` (None: "none") and its ``rivals``; the ``outcome``
    ("named", "unexplained gap" or "within noise"), the gap's size (``gap_levels``: RMS residual in noise levels)
    and ``where`` it is (:func:`~cosim.diagnose.advice.gap_locations`), the candidates ``plausible`` but not
    identifiable here (:func:`~cosim.diagnose.advice.plausible`)."""

    rows: list
    shapes: list
    whiteness: dict
    cross_correlation: object
    mean_square: float
    chance: float
    gap_found: bool
    winner: object
    rivals: list
    outcome: str = "within noise"
    gap_levels: float = 0.0
    where: list = ()
    plausible: list = ()

    @property
    def effect(self):
        """The winner's name, or ``"none"``."""
        return "none" if self.winner is None else self.winner.effect


@dataclass(frozen=True)
class Show:
    """The winner added: its fit on every cost sample (``final``, None for "none"), its replay ``after`` (the
    baseline's for "none"), its built ``fmu``, the package with its variant and the diff, the ``rerun``."""

    final: object
    after: np.ndarray
    fmu: object = None
    variant_source: str = ""
    variant_diff: str = ""
    rerun: object = None
