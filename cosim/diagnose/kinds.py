"""The experiment kinds of the discrepancy workflow: what differs between a staircase, a speed run, impact and slide
records, and a frequency response.

A job carries its kind (:func:`kind_of` reads ``experiment.kind``), and every stage of
:mod:`cosim.diagnose.workflow` asks the kind instead of testing its name: how a record is read and which channels
it compares, which samples enter the cost, how the noise is estimated, how a record is cut into segments, which
replay gives the model's side, and how a segment's span is said. A new kind is a subclass of
:class:`ExperimentKind`; nothing else in the workflow changes.
"""

from dataclasses import dataclass, replace

import numpy as np

from cosim.diagnose.analysis import (band_shape, cross_correlation, frequency_bands, hold_segments, impact_phases,
                                     noise_level, quiet_phases)
from cosim.diagnose.fitting import Replay
from cosim.diagnose.frequency import DEG_PER_DB, FrequencyReplay, frequency_noise, load_frequency_experiment
from cosim.diagnose.result import Noise
from cosim.diagnose.stages import Samples
from cosim.errors import ConfigError
from cosim.experiment import align_experiment, steady_mask

__all__ = ["ExperimentKind", "Staircase", "SpeedRun", "Records", "FrequencyResponse", "Part", "Several", "KINDS",
           "kind_of", "record_slices", "record_samples"]

MIN_QUIET_SAMPLES = 20  # fewer samples in an impact's approach and steady holds: its noise from every sample
NOISE_WINDOW_S = 0.2  # s: the steady end of each hold a speed run (no steady_s) estimates its noise on


@dataclass(frozen=True)
class ExperimentKind:
    """A time-series experiment: the measured inputs replayed through the model's equations (CVODES), every
    sample compared, the noise from differences inside its segments.

    Attributes
    ----------
    name : str
        ``experiment.kind`` in the job and ``kind`` in ``diagnosis.json``.
    time_series : bool
        The master can re-run it with the measured inputs (a frequency response is not a time series).
    parts : tuple of Part
        For records of several experiments (:class:`Several`), each record's experiment; else empty.
    held_levels : bool
        The input is held at levels, so the output against the held input (rising and falling branches) is worth
        a plot of its own (``curve.png``).
    """

    name: str = ""
    time_series: bool = True
    parts: tuple = ()
    held_levels: bool = False

    def load(self, job, model, path=None):
        """The record at ``path`` (default: the job's first) aligned with ``model``: an Experiment (mask: every
        sample, time from 0) with the checks a diagnosis needs (channels, at least 10 samples, a uniform time
        base, data covering the experiment)."""
        return align_experiment(job, [u.name for u in model.inputs], [o.name for o in model.outputs], path,
                                signals_key="compare.signals", min_samples=10, uniform=True, duration=job.duration,
                                from_zero=True)

    def channels(self, job, model):
        """Names, units and noise floors of the compared channels: the job's signals."""
        units = [model.outputs[model.index("outputs", o)].unit for o, _, _ in job.signals]
        return [o for o, _, _ in job.signals], units, [n for _, _, n in job.signals]

    def cost_mask(self, job, records, present):
        """The samples that enter the cost: every instant each channel has (``present``)."""
        return present

    def noise(self, job, samples):
        """The noise level of each channel from differences of the cost samples, floored by the job's."""
        estimated = noise_level(samples.time, samples.measured, samples.mask)
        return Noise(estimated=estimated, floor=samples.floor, sigma=np.maximum(estimated, samples.floor))

    def segments(self, job, samples, noise):
        """Each record cut into its own segments (:meth:`cut`; labelled by record for repeated trials), and the
        segment shape classifier (None: the time-domain default)."""
        s, segments = samples, []
        for k, ((r, _), shift, p) in enumerate(zip(s.records, s.shifts, s.sampled)):
            for piece in self.cut_record(job, k, r.time[p], r.inputs[p], r.measured[p, 0], noise):
                segments.append(replace(piece, index=len(segments), t0=piece.t0 + shift, t1=piece.t1 + shift,
                                        label=self.record_label(job, k, piece.label)))
        return segments, None

    def cut_record(self, job, k, time, inputs, measured, noise):
        """Record k's segments: :meth:`cut` with the first channel's noise level."""
        return self.cut(job, time, inputs, measured, noise.sigma[0])

    def record_label(self, job, k, label):
        """A segment's label, with its record for repeated trials."""
        return label if len(job.records) == 1 else f"record {k} ({job.records[k][0].name}): {label}"

    def cut(self, job, time, inputs, measured, noise):
        """One record's natural segments (list of :class:`~cosim.diagnose.analysis.Segment`) from its time,
        inputs, first compared channel ``measured`` and that channel's ``noise`` level; each time-series kind
        says how."""
        raise NotImplementedError(f"{type(self).__name__} does not say how to cut a record into segments")

    def replay(self, model, experiment, outputs, free, scale, fixed=None, rtol=1e-6):
        """The model's outputs along ``experiment`` for values of the ``free`` parameters
        (:class:`~cosim.diagnose.fitting.Replay`)."""
        return Replay(model, experiment, outputs, free, scale, fixed=fixed, rtol=rtol)

    def cross_correlation(self, residual, experiment, mask):
        """The residual (on the cost samples ``mask``) cross-correlated with the experiment's first input there
        (:func:`~cosim.diagnose.analysis.cross_correlation`)."""
        return cross_correlation(residual, experiment.inputs[mask, 0])

    def span(self, t0, t1):
        """A segment's extent as words."""
        return f"t = {t0:.4g}-{t1:.4g} s"


@dataclass(frozen=True)
class Staircase(ExperimentKind):
    """A staircase of holds: only the settled end of each hold (``steady_s``) enters the cost, and the noise is
    estimated inside those steady windows."""

    name: str = "staircase"
    held_levels: bool = True

    def cost_mask(self, job, records, present):
        """The settled end (``experiment.steady_s``) of each hold of every record."""
        return present & self._steady(job, records, job.steady_s)

    def noise(self, job, samples):
        """From differences inside the steady windows of the holds."""
        s = samples
        estimated = noise_level(s.time, s.measured, s.present & self._steady(job, s.records,
                                                                             job.steady_s or NOISE_WINDOW_S))
        return Noise(estimated=estimated, floor=s.floor, sigma=np.maximum(estimated, s.floor))

    def cut(self, job, time, inputs, measured, noise):
        """Each hold of at least ``experiment.min_hold_s`` with the ramp before it
        (:func:`~cosim.diagnose.analysis.hold_segments`)."""
        return hold_segments(time, inputs, job.min_hold_s)

    @staticmethod
    def _steady(job, records, window):
        """The last ``window`` seconds of each hold of every record, end to end."""
        return np.concatenate([steady_mask(r.time, r.inputs, window, job.min_hold_s) for r, _ in records])


@dataclass(frozen=True)
class SpeedRun(Staircase):
    """Speed holds under a speed loop (a staircase without ``steady_s``): every sample enters the cost, the noise
    from the steady end of each hold."""

    def cost_mask(self, job, records, present):
        """Every instant each channel has: a speed run's transients carry the effect (cogging, friction)."""
        return present


@dataclass(frozen=True)
class Records(ExperimentKind):
    """Impact and slide records: every sample enters the cost, the noise from the approach and steady hold of
    each record (its quiet phases)."""

    name: str = "impact"

    def noise(self, job, samples):
        """From every sample first, then from the quiet phases of each record when they hold enough samples."""
        s, floor = samples, samples.floor
        estimated = noise_level(s.time, s.measured, s.mask)
        rough = max(estimated[0], floor[0])
        quiet = np.concatenate([_spread(p, quiet_phases(r.time[p], r.measured[p, 0], rough))
                                for (r, _), p in zip(s.records, s.sampled)])
        if (s.mask & quiet).sum() >= MIN_QUIET_SAMPLES:
            estimated = noise_level(s.time, s.measured, s.mask & quiet)
        return Noise(estimated=estimated, floor=floor, sigma=np.maximum(estimated, floor))

    def cut(self, job, time, inputs, measured, noise):
        """Approach, impact, tightening and steady hold from the measured force
        (:func:`~cosim.diagnose.analysis.impact_phases`)."""
        return impact_phases(time, measured, noise)


@dataclass(frozen=True)
class FrequencyResponse(ExperimentKind):
    """A measured frequency response: magnitude [dB] and phase [deg] of one output, compared at every frequency
    with the lowered model's linearisation; segments are frequency bands."""

    name: str = "frequency"
    time_series: bool = False

    def load(self, job, model, path=None):
        """The measured response (:func:`~cosim.diagnose.frequency.load_frequency_experiment`)."""
        return load_frequency_experiment(job, model)

    def channels(self, job, model):
        """Magnitude [dB] and phase [deg] of the one output (the phase floor: the same complex-log error)."""
        output, _, floor = job.signals[0]
        ratio = f"{output}/{job.input}"
        return [f"magnitude {ratio}", f"phase {ratio}"], ["dB", "deg"], [floor, floor * DEG_PER_DB]

    def noise(self, job, samples):
        """Per frequency, from neighbouring frequencies, shaped by the coherence."""
        sigma, estimated = frequency_noise(samples.experiment, samples.floor)
        return Noise(estimated=estimated, floor=samples.floor, sigma=sigma)

    def segments(self, job, samples, noise):
        """Frequency bands of ``experiment.bands_per_decade``."""
        return frequency_bands(samples.time, samples.measured[0], job.bands_per_decade), band_shape

    def replay(self, model, experiment, outputs, free, scale, fixed=None, rtol=None):
        """The model's response (:class:`~cosim.diagnose.frequency.FrequencyReplay`)."""
        return FrequencyReplay(model, experiment, outputs, free, scale, fixed=fixed, rtol=rtol)

    def cross_correlation(self, residual, experiment, mask):
        """None: a frequency response has no input time series."""
        return None

    def span(self, t0, t1):
        """A band's extent in Hz."""
        return f"{t0:.3g}-{t1:.3g} Hz"


@dataclass(frozen=True)
class Part:
    """One experiment of a job of several (``[[experiments]]``): its name, kind and what its kind reads from a
    job (the data's inputs, the duration the data must cover, a staircase's steady tail and shortest hold)."""

    name: str
    kind: ExperimentKind
    inputs: dict
    duration: float = None
    steady_s: float = 0.0
    min_hold_s: float = 0.05


@dataclass(frozen=True)
class Several(ExperimentKind):
    """Records of different time-series experiments of one plant (``[[experiments]]``: a staircase, impacts, a
    slide), diagnosed together: record k is the experiment ``parts[k]``, and each stage asks that part's kind
    about its record (its cost samples, noise, segments), so that the fits sum every record's chi-square over
    one set of parameters, each residual weighed by its own record's noise."""

    name: str = "several"

    def part_job(self, job, k):
        """The job as record k's experiment alone: its record, kind and settings."""
        p = self.parts[k]
        return replace(job, records=(job.records[k],), kind=p.kind, inputs=p.inputs, duration=p.duration,
                       steady_s=p.steady_s, min_hold_s=p.min_hold_s)

    def load(self, job, model, path=None):
        """The record at ``path`` (default: the first) as its experiment's kind reads it."""
        k = [p for p, _ in job.records].index(path) if path is not None else 0
        part = self.part_job(job, k)
        return part.kind.load(part, model, path)

    def cost_mask(self, job, records, present):
        """Each record's cost samples as its kind takes them, end to end.

        Raises
        ------
        cosim.errors.ConfigError
            When a record has none (no hold of a staircase lasts its ``min_hold_s``, by default its
            ``steady_s``).
        """
        masks = []
        for k, (record, cut) in enumerate(zip(records, record_slices(records))):
            part = self.part_job(job, k)
            masks.append(part.kind.cost_mask(part, [record], present[cut]))
            if not masks[-1].any():
                raise ConfigError(f"{job.path}: experiments[{k}] ({self.parts[k].name}): no sample enters the cost "
                                  f"(a staircase: no hold lasts its min_hold_s = {part.min_hold_s:g} s)")
        return np.concatenate(masks)

    def noise(self, job, samples):
        """Each record's noise as its kind estimates it, spread over the record's samples (shape (n_signals,
        N)); ``parts`` holds each record's own."""
        parts = [self.part_job(job, k) for k in range(len(samples.records))]
        own = [part.kind.noise(part, record_samples(samples, k)) for k, part in enumerate(parts)]
        lengths = [len(r.time) for r, _ in samples.records]
        sigma = np.hstack([np.repeat(n.sigma[:, None], m, axis=1) for n, m in zip(own, lengths)])
        estimated = np.median(np.hstack([np.repeat(n.estimated[:, None], m, axis=1)
                                         for n, m in zip(own, lengths)]), axis=1)
        return Noise(estimated=estimated, floor=samples.floor, sigma=sigma, parts=tuple(own))

    def cut_record(self, job, k, time, inputs, measured, noise):
        """Record k cut as its kind cuts it, with its own noise level."""
        part = self.part_job(job, k)
        return part.kind.cut(part, time, inputs, measured, noise.parts[k].sigma[0])

    def record_label(self, job, k, label):
        """A segment's label with its experiment's name."""
        return f"{self.parts[k].name}: {label}"


KINDS = {"staircase": Staircase(), "impact": Records(), "frequency": FrequencyResponse()}


def kind_of(name, steady_s=0.0):
    """The kind named ``name`` (``experiment.kind``); a staircase without ``steady_s`` is a speed run.

    Parameters
    ----------
    name : {"staircase", "impact", "frequency"}
    steady_s : float, default 0.0
        ``experiment.steady_s``.

    Returns
    -------
    ExperimentKind

    Raises
    ------
    KeyError
        For a name not in :data:`KINDS` (the job's loader reports it with its key first).
    """
    kind = KINDS[name]
    return SpeedRun() if isinstance(kind, Staircase) and not steady_s else kind


def record_slices(records):
    """Where each of the ``records`` (``(Experiment, trial)`` pairs) lies in their samples end to end."""
    ends = np.cumsum([0] + [len(r.time) for r, _ in records])
    return [slice(a, b) for a, b in zip(ends[:-1], ends[1:])]


def record_samples(samples, k):
    """Record k of ``samples`` (a :class:`~cosim.diagnose.stages.Samples` of records end to end) alone, on its
    own time base."""
    s = samples
    cut = record_slices(s.records)[k]
    return Samples(model=s.model, records=[s.records[k]], experiment=s.records[k][0], shifts=[0.0],
                   sampled=[s.sampled[k]], present=s.present[cut], mask=s.mask[cut], channels=s.channels,
                   units=s.units, floor=s.floor)


def _spread(where, values):
    """A boolean array over all instants: ``values`` at those ``where`` selects (a record's sampled instants),
    False elsewhere."""
    out = np.zeros(len(where), bool)
    out[where] = values
    return out
