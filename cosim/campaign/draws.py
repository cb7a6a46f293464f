"""The campaign's trials: the grid in a fixed order, each trial's seed and its drawn values.

A trial's seed derives from the job's seed and the trial's identity (coating, speed, current, index in
its cell) through numpy's ``SeedSequence``, never from its position in the run or the worker that runs
it: the same trial draws the same values whatever the grid around it, the batching or the workers, and
one trial re-runs alone from its seed.
"""

import zlib
from dataclasses import dataclass

import numpy as np

from cosim.campaign.job import SOURCES

__all__ = ["TrialSpec", "trial_list", "trial_seed", "draw"]


@dataclass(frozen=True)
class TrialSpec:
    """One trial of the grid.

    Attributes
    ----------
    index : int
        Its row in trials.parquet (grid order: coating, speed, current, trial).
    coating : str
    speed_rpm, current_A : float
    trial : int
        Its index in its cell.
    seed : int
        Seed of its random generator (see :func:`trial_seed`).
    """

    index: int
    coating: str
    speed_rpm: float
    current_A: float
    trial: int
    seed: int


def trial_seed(job_seed, coating, speed_rpm, current_A, trial):
    """The seed of one trial: 64 bits of ``SeedSequence([job_seed, coating, rpm, mA, trial])``.

    Parameters
    ----------
    job_seed : int
    coating : str
    speed_rpm, current_A : float
    trial : int

    Returns
    -------
    int
    """
    key = [int(job_seed), zlib.crc32(coating.encode()), int(round(speed_rpm * 1000)),
           int(round(current_A * 1e6)), int(trial)]
    return int(np.random.SeedSequence(key).generate_state(1, np.uint64)[0])


def trial_list(job):
    """Every trial of ``job`` in grid order (coating, speed, current, trial).

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob

    Returns
    -------
    list of TrialSpec
    """
    out = []
    for c in job.coatings:
        for v in job.speeds_rpm:
            for i in job.currents_A:
                for k in range(job.trials):
                    out.append(TrialSpec(len(out), c.name, v, i, k, trial_seed(job.seed, c.name, v, i, k)))
    return out


def draw(job, spec):
    """The drawn value of each source of ``job`` for one trial, and the generator of its load-cell noise.

    Each source draws from its own stream, ``default_rng([seed, k])`` with ``k`` its position in
    :data:`cosim.campaign.job.SOURCES`: adding or removing a source leaves the others' values alone.

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob
    spec : TrialSpec

    Returns
    -------
    values : dict of str to float
        Source name -> drawn value (0 for a source the job does not vary; the noise's sd for
        ``load_cell_noise``, whose samples the caller draws from ``noise``).
    noise : numpy.random.Generator
        The load cell noise's stream.
    """
    values = {}
    noise = None
    for k, name in enumerate(SOURCES):
        rng = np.random.default_rng([spec.seed, k])
        s = job.source(name)
        if name == "load_cell_noise":
            values[name] = s.b if s is not None else 0.0
            noise = rng
        elif s is None:
            values[name] = 0.0
        elif s.distribution == "uniform":
            values[name] = float(rng.uniform(s.a, s.b))
        else:
            values[name] = float(rng.normal(s.a, s.b))
    return values, noise
