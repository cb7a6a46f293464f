"""The typed result of a diagnosis (:func:`cosim.diagnose.workflow.run_diagnosis`) and its JSON form: what
``diagnosis.json`` holds is :meth:`Diagnosis.to_json`."""

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["Round", "ExperimentGap", "Noise", "Candidate", "Rerun", "RecordSummary", "SegmentRow", "Traces",
           "Diagnosis"]

FOLD_SCHEME = "two-fold over segments: fit on the even ones, score on the odd ones, and back"


@dataclass(frozen=True)
class Noise:
    """The noise level (1 sd) of each channel: ``estimated`` from the data, the job's ``floor`` and the level
    ``sigma`` the residuals are weighed with, shape (n_signals,), or per sample (n_signals, N) for a frequency
    response and for records of several experiments, whose ``parts`` are each record's own Noise."""

    estimated: np.ndarray
    floor: np.ndarray
    sigma: np.ndarray
    parts: tuple = ()

    @property
    def weights(self):
        """1 / ``sigma``."""
        return 1.0 / self.sigma

    @property
    def used(self):
        """One level per channel: ``sigma``, or its median over the frequencies."""
        return (self.sigma if self.sigma.ndim == 1 else np.median(self.sigma, axis=1)).tolist()

    def to_json(self):
        """The ``noise`` entry of ``diagnosis.json``."""
        entry = {"estimated": self.estimated.tolist(), "floor": self.floor.tolist(), "used": self.used}
        return {**entry, "per_record": [n.to_json() for n in self.parts]} if self.parts else entry


@dataclass(frozen=True)
class Candidate:
    """A candidate effect scored on the held-out folds (the keys of a ``candidates`` entry of diagnosis.json);
    ``free`` (name -> [start, min, max] of its fold-0 fit) starts the winner's final fit."""

    effect: str
    score: float
    rmse_after: float
    max_error_after: float
    parameters: dict
    parameters_other_fold: dict
    added_parameters: list
    heldout_ms_sigma2: float
    aic: float
    bic: float
    delta_aic: float
    delta_bic: float
    p_value: float
    free: dict

    def to_json(self):
        """The candidate's entry in diagnosis.json (without ``free``)."""
        entry = asdict(self)
        del entry["free"]
        return entry


@dataclass(frozen=True)
class Rerun:
    """The baseline's and the winner's FMUs re-run through the master: the ``rerun`` entry of diagnosis.json."""

    how: str
    signal: str
    configs: dict
    rmse_before: float
    max_error_before: float
    max_difference_to_replay_before: float
    rmse_after: float
    max_error_after: float
    max_difference_to_replay_after: float


@dataclass(frozen=True)
class RecordSummary:
    """A record: its data file, the trial's fixed values, its instants, those compared, its time shift [s]."""

    path: str
    parameters: dict
    samples: int
    compared: int
    time_shift: float


@dataclass(frozen=True)
class SegmentRow:
    """A segment and a compared channel, before and after the winner (a ``segments`` entry of diagnosis.json)."""

    segment: str
    kind: str
    t0: float
    t1: float
    level: float
    samples: int
    significant: bool
    shape: str
    sigmas: float
    signal: str
    bias_before: float
    rmse_before: float
    max_error_before: float
    bias_after: float
    rmse_after: float
    max_error_after: float
    significant_after: bool


@dataclass(frozen=True)
class Traces:
    """The series the plots draw.

    Attributes
    ----------
    time : ndarray, shape (N,)
        Time [s], or frequency [Hz] for a frequency response.
    inputs : ndarray, shape (N, n_inputs)
        (N, 0) for a frequency response.
    measured, before, after : ndarray, shape (n_signals, N)
        Measured outputs and the baseline's and the winner's replays (``after`` is ``before`` for "none"); for a
        frequency response the two channels magnitude [dB] and phase [deg].
    mask : ndarray of bool, shape (N,)
        Cost samples.
    candidate_predictions : dict
        "baseline" and each candidate -> its fold-0 replay, shape (n_signals, N).
    """

    time: np.ndarray
    inputs: np.ndarray
    measured: np.ndarray
    before: np.ndarray
    after: np.ndarray
    mask: np.ndarray
    candidate_predictions: dict


@dataclass(frozen=True)
class Round:
    """One round of a diagnosis (:mod:`cosim.diagnose.rounds`): what it named and the gap before and after.

    Attributes
    ----------
    number : int
        1 for the user's baseline; each later round's baseline has the earlier rounds' findings added.
    effect : str
        The candidate named, or ``"none"``.
    form : bool
        Whether it is a law of another form (else a missing effect).
    parameters : dict
        Its own parameters, fitted on every cost sample.
    gap_before, gap_after : float
        RMS residual in noise levels of the round's baseline and after its finding (the baseline's for none).
    outcome, verdict : str
        The round's answer (as a one-round :class:`Diagnosis` says it).
    dropped : bool
        The candidate it named is not in the final model: the later findings explain what it did
        (:func:`~cosim.diagnose.rounds.least_needed`).
    shown_by : tuple of str
        For records of several experiments, the ones that showed its finding (:attr:`Diagnosis.shown_by`).
    """

    number: int
    effect: str
    form: bool
    parameters: dict
    gap_before: float
    gap_after: float
    outcome: str
    verdict: str
    dropped: bool = False
    shown_by: tuple = ()


@dataclass(frozen=True)
class ExperimentGap:
    """One experiment of a job of several (``[[experiments]]``): its gap before and after the winner.

    Attributes
    ----------
    name, kind : str
        The experiment's name and kind.
    samples : int
        Its cost samples.
    noise : list of float
        Its noise level per channel.
    gap_before, gap_after : float
        RMS weighted residual on its cost samples, noise levels: the baseline's, the winner's (the baseline's for
        none).
    chi2_removed : float
        The chi-square the winner removes from this record (0 for none): where the finding shows.
    """

    name: str
    kind: str
    samples: int
    noise: list
    gap_before: float
    gap_after: float
    chi2_removed: float


@dataclass(frozen=True)
class Diagnosis:
    """The result of a diagnosis: :meth:`to_json` is the content of ``diagnosis.json`` (each attribute below is
    the key of that name unless said otherwise); ``traces`` feed the plots.

    Attributes
    ----------
    job, model, data : str
        The job file, the baseline model, the (first) data file.
    records : tuple of RecordSummary
    effect : str
        The named effect, or ``"none"``.
    verdict : str
    also_explained_by : list of str
        Qualified candidates the held-out data cannot tell from the winner (:func:`rivals_of`).
    kind : str
        "staircase", "impact" or "frequency".
    signals, units : list of str
        The compared channels (for a frequency response its magnitude [dB] and phase [deg]).
    inputs, input_units : list of str
        The model's inputs (none for a frequency response).
    parameter_units : dict
    noise : Noise
        Its ``sigma`` weighs the residuals; ``noise`` in the JSON is :meth:`Noise.to_json`.
    rmse_before_per_signal, rmse_after_per_signal : list of float
        On the cost samples; ``rmse_before`` and ``rmse_after`` in the JSON are the first channel's.
    max_error_before, max_error_after : float
        The first channel's.
    gap_removed : float
        Fraction of the baseline's gap above the noise (all channels) the winner removes.
    baseline_parameters, baseline_free : dict
        The baseline's fit and its free parameters (name -> [start, min, max]): ``baseline`` in the JSON.
    after_parameters : dict or None
        The winner's fit on every cost sample: ``after`` in the JSON, with ``fmu``.
    fmu : str or None
        The winner's built FMU (None when not built).
    rerun : Rerun or None
    segments : tuple of SegmentRow
    gap_found : bool
    baseline_mean_square : float
        The baseline's weighted residual on the cost samples, in noise levels squared.
    shapes : list of dict
    whiteness : dict
    input_cross_correlation : dict or None
    fold_samples : list of int
        Training samples of each fold: ``folds`` in the JSON.
    decision : dict
        The decision's thresholds and the baseline's chance mean square.
    candidates : tuple of Candidate
        Best score first.
    traces : Traces
    variant_source : str
        Modelica text of the package with the winner's variant ("" for none).
    variant_diff : str
    outcome : str
        "named", "unexplained gap" (a gap no candidate explains), "diffuse gap" (a residual above chance with no
        significant segment) or "within noise".
    gap : dict
        The baseline's gap: ``noise_levels`` (RMS residual in noise levels), ``where`` (its significant segments,
        largest first, :func:`~cosim.diagnose.advice.gap_locations`) and ``remaining_noise_levels`` (after the
        winner; the baseline's for "none").
    not_identifiable : list of dict
        Effects plausible but not identifiable on these data, each with why, its change here and on the
        experiment that shows it (:func:`~cosim.diagnose.workflow.advise`).
    evidence, next_step : str
        The report's lines under the verdict.
    experiments : tuple of ExperimentGap
        For records of several experiments, each one's gap before and after.
    shown_by : tuple of str
        For records of several experiments, those where the winner removes at least ``min_delta_bic`` of
        chi-square, the most first (the one it removes most from when none does).
    rounds : tuple of Round
        Every round run (:mod:`cosim.diagnose.rounds`); after more than one, the diagnosis is the last named
        round's, with ``effect`` the first finding, the verdict listing every finding in order, and the gap
        before (``baseline_mean_square``, ``rmse_before``, ``gap.noise_levels``) the user's baseline's.
    """

    job: str
    model: str
    data: str
    records: tuple
    effect: str
    verdict: str
    also_explained_by: list
    kind: str
    signals: list
    units: list
    inputs: list
    input_units: list
    parameter_units: dict
    noise: Noise
    rmse_before_per_signal: list
    rmse_after_per_signal: list
    max_error_before: float
    max_error_after: float
    gap_removed: float
    baseline_parameters: dict
    baseline_free: dict
    after_parameters: object
    fmu: object
    rerun: object
    segments: tuple
    gap_found: bool
    baseline_mean_square: float
    shapes: list
    whiteness: dict
    input_cross_correlation: object
    fold_samples: list
    decision: dict
    candidates: tuple
    traces: Traces
    variant_source: str = ""
    variant_diff: str = ""
    outcome: str = "within noise"
    gap: dict = None
    not_identifiable: list = ()
    evidence: str = ""
    next_step: str = ""
    rounds: tuple = ()
    experiments: tuple = ()
    shown_by: tuple = ()

    @property
    def findings(self):
        """The candidates the final model holds, in the order the rounds named them."""
        return list(dict.fromkeys(r.effect for r in self.rounds if r.effect != "none" and not r.dropped))

    @property
    def rmse_before(self):
        """The first channel's RMSE before, on the cost samples."""
        return self.rmse_before_per_signal[0]

    @property
    def rmse_after(self):
        """The first channel's RMSE after (the baseline's for "none"), on the cost samples."""
        return self.rmse_after_per_signal[0]

    def to_json(self):
        """The content of ``diagnosis.json``: a dict of plain values (numpy scalars as Python numbers,
        non-finite floats as None)."""
        return _plain({
            "job": self.job, "model": self.model, "data": self.data,
            "records": [asdict(r) for r in self.records],
            "effect": self.effect, "verdict": self.verdict, "outcome": self.outcome, "evidence": self.evidence,
            "next_step": self.next_step, "gap": self.gap, "not_identifiable": list(self.not_identifiable),
            "also_explained_by": self.also_explained_by,
            "kind": self.kind, "signals": self.signals, "units": self.units, "inputs": self.inputs,
            "input_units": self.input_units, "parameter_units": self.parameter_units,
            "noise": self.noise.to_json(),
            "rmse_before": self.rmse_before, "rmse_after": self.rmse_after,
            "max_error_before": self.max_error_before, "max_error_after": self.max_error_after,
            "rmse_before_per_signal": self.rmse_before_per_signal,
            "rmse_after_per_signal": self.rmse_after_per_signal,
            "gap_removed": self.gap_removed,
            "baseline": {"parameters": self.baseline_parameters, "free": self.baseline_free},
            "after": (None if self.after_parameters is None else
                      {"parameters": self.after_parameters, "fmu": self.fmu}),
            "rerun": None if self.rerun is None else asdict(self.rerun),
            "segments": [asdict(r) for r in self.segments],
            "gap_found": self.gap_found,
            "baseline_mean_square": self.baseline_mean_square,
            "shapes": self.shapes, "whiteness": self.whiteness,
            "input_cross_correlation": self.input_cross_correlation,
            "folds": {"scheme": FOLD_SCHEME, "samples": self.fold_samples},
            "decision": self.decision,
            "candidates": [c.to_json() for c in self.candidates],
            "rounds": [asdict(r) for r in self.rounds],
            "experiments": [asdict(e) for e in self.experiments], "shown_by": list(self.shown_by),
        })


def _plain(value):
    """``value`` with numpy scalars as Python numbers and non-finite floats as None, for JSON."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value
