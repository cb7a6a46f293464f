"""The ``cosim campaign`` job: a TOML grid of impact trials (coatings x speeds x currents x trials) and the
sources of trial-to-trial variability, parsed once into frozen records and checked up front.

A coating names the shipped impact run config it is simulated with (``[coatings.NAME] config``) and the
FMU parameters that make it that coating (``parameters``, checked against its config's plant FMU as a run config's
are); a coating of the grid without such a table has no parameters and is refused. Each variability source has a
distribution and the physical reason it varies.
"""

import json
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

from cosim.paramfile import parameters_file_key
from cosim.tomldoc import number, read_toml, sections

__all__ = ["COATINGS", "SOURCES", "Source", "Coating", "CampaignJob", "load_campaign", "job_changes"]

COATINGS = ("bare", "P1", "P2", "P3")  # the paper's contact conditions (Sec. 4.4)

# source -> (unit of its drawn value, what the value does to a trial); see docs/guide/campaign.md
SOURCES = {
    "free_travel": ("m", "added to the plant's gap0: where the object sits between the open fingers"),
    "play_position": ("1", "where the gear starts inside its play, as a fraction of the play from its centre"),
    "encoder_phase": ("1", "where the encoder's count edge sits at rest, as a fraction of one count"),
    "friction_scatter": ("1", "relative change of the motor-side drag T_c0 and of the jaw guide friction F_cj"),
    "gear_efficiency": ("1", "added to the gear mesh efficiency eta_g"),
    "controller_phase": ("s", "delay of the ramp start after the 100 Hz outer loop's first sample"),
    "load_cell_noise": ("N", "standard deviation of the load cell's noise at each 100 Hz sample"),
}
_DISTRIBUTIONS = {"uniform": ("low", "high"), "normal": ("mean", "sd")}

_SCHEMA = {
    "campaign": ("seed", "trials", "coatings", "speeds_rpm", "currents_A", "hold_s", "steady_s", "margin_s",
                 "batch", "bounce_fraction", "load_cell_rate", "parameters_file"),
    "coatings": COATINGS,
    "sources": tuple(SOURCES),
}


@dataclass(frozen=True)
class Source:
    """One source of variability.

    Attributes
    ----------
    name : str
        A key of :data:`SOURCES`.
    distribution : {"uniform", "normal"}
    a, b : float
        ``low, high`` (uniform) or ``mean, sd`` (normal), in the source's unit.
    reason : str
        Why the quantity varies from one real impact to the next.
    """

    name: str
    distribution: str
    a: float
    b: float
    reason: str


@dataclass(frozen=True)
class Coating:
    """A contact condition: the impact run config it is simulated with and its FMU parameters.

    Attributes
    ----------
    name : str
    config : pathlib.Path
        The run config, resolved against the job's folder.
    parameters : dict
        FMU parameters of the ``plant`` instance set on top of the config's (SI units).
    """

    name: str
    config: Path
    parameters: dict


@dataclass(frozen=True)
class CampaignJob:
    """A validated campaign job.

    Attributes
    ----------
    path : pathlib.Path
    seed : int
        The job's seed; each trial's seed derives from it and the trial's cell and index.
    trials : int
        Trials per grid cell.
    coatings : tuple of Coating
    speeds_rpm, currents_A : tuple of float
        Impact speeds (motor, rpm) and tightening currents (A).
    hold_s, steady_s, margin_s : float
        Tightening time, the averaging window at its end (steady force) and the time simulated past
        the expected end of tightening (covers the trigger's delay), s.
    batch : int
        Trials per Dask task.
    bounce_fraction : float
        A trial bounced when the force after the peak falls below this fraction of the steady force.
    load_cell_rate : float
        Sampling rate of the load cell (Hz).
    sources : tuple of Source
    parameters_file : cosim.paramfile.ParametersFile or None
        A calibration's parameters set on every coating's plant, over its run config's values and under the
        coating's ``parameters``.
    overrides : tuple of str
        The ``--set`` items applied.
    """

    path: Path
    seed: int
    trials: int
    coatings: tuple
    speeds_rpm: tuple
    currents_A: tuple
    hold_s: float
    steady_s: float
    margin_s: float
    batch: int
    bounce_fraction: float
    load_cell_rate: float
    sources: tuple
    parameters_file: object = None
    overrides: tuple = field(default=(), compare=False)

    def canonical(self):
        """The job as plain data without its path and overrides: what a resumed run must match (a parameters
        file by its path and SHA-256)."""
        d = asdict(self)
        del d["path"], d["overrides"]
        f = self.parameters_file
        d["parameters_file"] = None if f is None else {"file": str(f.path), "sha256": f.sha256}
        d["coatings"] = [{**c, "config": str(c["config"])} for c in d["coatings"]]
        return json.loads(json.dumps(d, sort_keys=True))

    def source(self, name):
        """The Source called ``name``, or None when the job does not vary it."""
        return next((s for s in self.sources if s.name == name), None)


def job_changes(old, new, prefix=""):
    """The keys whose values differ between two canonical jobs, as ``"key: old -> new"`` strings."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(set(old) | set(new)):
            out += job_changes(old.get(k), new.get(k), f"{prefix}.{k}" if prefix else k)
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        out = []
        for i, (a, b) in enumerate(zip(old, new)):
            out += job_changes(a, b, f"{prefix}[{i}]")
        return out
    return [] if old == new else [f"{prefix}: {old!r} -> {new!r}"]


def _number_list(problems, table, key, where):
    values = table.get(key)
    if not isinstance(values, list) or not values:
        problems.add(where + (key,), f"must be a non-empty list of numbers; got {values!r}")
        return ()
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
            problems.add(where + (key,), f"must hold numbers > 0; got {v!r}")
        else:
            out.append(float(v))
    if len(set(out)) != len(out):
        problems.add(where + (key,), f"has repeated values: {values!r}")
    return tuple(out)


def _coatings(tables, camp, base, problems, plants):
    """The job's coatings; ``plants`` gets the plant FMU of each coating's run config (see _plant_parameters)."""
    names = camp.get("coatings")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        problems.add(("campaign", "coatings"), f"must be a non-empty list of coating names; got {names!r}")
        return ()
    out = []
    for name in names:
        if name not in COATINGS:
            problems.add(("campaign", "coatings"), f"unknown coating {name!r}; the paper's are {', '.join(COATINGS)}")
            continue
        t = tables["coatings"].get(name)
        if not isinstance(t, dict):
            problems.add(("coatings", name), f"coating {name!r} has no parameters: add a [coatings.{name}] table "
                                             "with its impact run config (config = \"...\") and FMU parameters")
            continue
        for key in sorted(set(t) - {"config", "parameters"}):
            problems.add(("coatings", name, key), "unknown key; allowed: config, parameters")
        cfg = t.get("config")
        if not isinstance(cfg, str):
            problems.add(("coatings", name, "config"), f"is required: the impact run config (.toml); got {cfg!r}")
            continue
        path = (base / cfg).resolve()
        if not path.is_file():
            problems.add(("coatings", name, "config"), f"{path} does not exist")
        params = t.get("parameters", {})
        if not isinstance(params, dict):
            problems.add(("coatings", name, "parameters"), "must be a table of FMU parameter values")
            params = {}
        numbers = {}
        for k, v in params.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                problems.add(("coatings", name, "parameters", k), f"must be a number; got {v!r}")
            else:
                numbers[k] = float(v)
        if path.is_file():
            _plant_parameters(name, path, numbers, problems, plants)
        out.append(Coating(name, path, numbers))
    return tuple(out)


def _plant_parameters(name, config, parameters, problems, plants):
    """Check a coating's parameters against the plant FMU of its run config, as the run config's own
    ``fmus.plant.parameters`` are checked (names, types, declared ranges). A run config that cannot be read, or
    whose plant FMU cannot, is not checked here: loading it for the first trial says what is wrong with it (a
    missing FMU with how to build it). ``plants`` holds the FMUs read so far (coatings share their configs)."""
    from cosim.config import check_parameter
    from cosim.errors import FmuFileError
    from cosim.fmi import read_model_info

    if config not in plants:
        try:
            fmu = config.parent / tomllib.loads(config.read_text(encoding="utf-8"))["fmus"]["plant"]["path"]
            plants[config] = fmu, read_model_info(fmu)
        except (OSError, ValueError, KeyError, TypeError, FmuFileError):  # TOMLDecodeError is a ValueError
            plants[config] = None
    if plants[config] is None:
        return
    fmu, info = plants[config]
    for k, v in parameters.items():
        check_parameter(info, fmu, k, v, problems, ("coatings", name, "parameters", k))


def _file_parameters(parameters_file, plants, problems):
    """Check the values of the job's ``parameters_file`` against every plant FMU the coatings run, as their own
    parameters are (a calibration of another model, or a value out of a plant's range, fails at load, not on a
    worker)."""
    from cosim.config import check_parameter

    if parameters_file is None:
        return
    for fmu, info in {p[0]: p[1] for p in plants.values() if p is not None}.items():
        for k, v in parameters_file.values.items():
            check_parameter(info, fmu, k, v, problems, ("campaign", "parameters_file"))


def _sources(tables, problems):
    out = []
    for name, t in tables["sources"].items():
        where = ("sources", name)
        if not isinstance(t, dict):
            problems.add(where, "must be a table: distribution, its two numbers, reason")
            continue
        dist = t.get("distribution")
        if not isinstance(dist, str) or dist not in _DISTRIBUTIONS:
            problems.add(where + ("distribution",), f"must be one of {', '.join(_DISTRIBUTIONS)}; got {dist!r}")
            continue
        keys = _DISTRIBUTIONS[dist]
        for key in sorted(set(t) - {"distribution", "reason", *keys}):
            problems.add(where + (key,), f"unknown key; allowed: distribution, {', '.join(keys)}, reason")
        a, b = (number(problems, t, k, where) for k in keys)
        reason = t.get("reason")
        if not isinstance(reason, str) or not reason.strip():
            problems.add(where + ("reason",), "is required: say why this quantity varies between real impacts")
        if None in (a, b):
            continue
        if dist == "uniform" and not a <= b:
            problems.add(where, f"low {a:g} is above high {b:g}")
        if dist == "normal" and b < 0:
            problems.add(where + ("sd",), f"must be >= 0; got {b:g}")
        if name == "load_cell_noise" and (dist != "normal" or a != 0.0):
            problems.add(where, "the load cell's noise is normal with mean 0 (its sd in N)")
        out.append(Source(name, dist, a, b, str(reason)))
    return tuple(out)


def load_campaign(path, overrides=(), origins=None):
    """Read and check a campaign job; every problem is reported at once with its file:line or ``--set`` key.

    Parameters
    ----------
    path : path-like
        The job (.toml).
    overrides : sequence of str
        ``key=value`` items, as ``--set`` (e.g. ``campaign.trials=5``).
    origins : dict, optional
        Override key -> where its value was given, when not on the command line (see
        :func:`cosim.tomldoc.read_toml`).

    Returns
    -------
    CampaignJob

    Raises
    ------
    cosim.errors.ConfigError
        The file is missing or malformed, a key is unknown, a value is out of range, a coating is unknown
        or has no parameters, a coating's run config does not exist, its plant FMU has no such parameter or
        declares a range the value is outside.
    """
    path = Path(path)
    data, problems = read_toml(path, overrides, what="campaign job", origins=origins)
    tables = sections(data, problems, _SCHEMA, free_form=())
    camp = tables["campaign"]
    w = ("campaign",)
    seed = number(problems, camp, "seed", w, integer=True)
    if seed is not None and seed < 0:
        problems.add(w + ("seed",), f"must be >= 0; got {seed}")
    plants = {}  # run config -> (its plant FMU, model info), filled by _coatings
    job = dict(
        seed=seed,
        trials=number(problems, camp, "trials", w, positive=True, integer=True),
        coatings=_coatings(tables, camp, path.parent, problems, plants),
        speeds_rpm=_number_list(problems, camp, "speeds_rpm", w),
        currents_A=_number_list(problems, camp, "currents_A", w),
        hold_s=number(problems, camp, "hold_s", w, default=5.0, positive=True),
        steady_s=number(problems, camp, "steady_s", w, default=1.0, positive=True),
        margin_s=number(problems, camp, "margin_s", w, default=0.15, positive=True),
        batch=number(problems, camp, "batch", w, default=10, positive=True, integer=True),
        bounce_fraction=number(problems, camp, "bounce_fraction", w, default=0.25, positive=True),
        load_cell_rate=number(problems, camp, "load_cell_rate", w, default=100.0, positive=True),
        sources=_sources(tables, problems),
        parameters_file=parameters_file_key(camp, w, path.parent, problems),
    )
    _file_parameters(job["parameters_file"], plants, problems)
    if None not in (job["hold_s"], job["steady_s"]) and job["steady_s"] > job["hold_s"]:
        problems.add(w + ("steady_s",), f"{job['steady_s']:g} s is longer than hold_s = {job['hold_s']:g} s")
    problems.raise_if_any()
    return CampaignJob(path=path, overrides=tuple(overrides), **job)
