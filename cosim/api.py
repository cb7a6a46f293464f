"""The Python API: one call per job, as ``cosim build``, ``run``, ``calibrate``, ``diagnose`` and ``campaign`` do it
on the command line (the command line is a thin layer over these calls). Everything else of the package is its
inside; docs/reference/python.md documents these names. Nothing is written unless a call is given ``out``.

``cosim.calibrate``, ``cosim.diagnose`` and ``cosim.campaign`` are the functions here, called through their
subpackages (the reason is in :mod:`cosim`'s docstring).

Example::

    import cosim

    cosim.build("modelica/models.toml")
    result = cosim.run("examples/gripper_impact.toml", set={"run.stop": 0.5})
    result.frame("plant").F_g.max()
    fit = cosim.calibrate("examples/calibrate_static.toml", out="out/calibrate_static")
    fit.parameters["eta_g"].value
"""

from pathlib import Path

from cosim.config import Config, _set_items
from cosim.errors import CosimError
from cosim.master.engine import RunResult

__all__ = ["build", "run", "calibrate", "diagnose", "campaign", "Config", "RunResult"]


def build(source_or_models="modelica/models.toml", model=None, *, out=None, modelica_path=(), fmi_version=None,
          force=False, c_sources=None, report=None):
    """Compile Modelica models to FMUs: one model of a source file, or every model a model list names.

    Parameters
    ----------
    source_or_models : path-like or None, default "modelica/models.toml"
        A Modelica source (``.mo``) holding ``model``; without ``model``, a model list (``models.toml``, see
        docs/guide/build.md); None for a model of a library on ``modelica_path``.
    model : str, optional
        The full name of the model to build, e.g. ``"Gripper.GripperPlant"``.
    out : path-like, optional
        The folder of the FMUs (default: ``fmus/``, or the one the model list names): new, or one holding only
        FMUs and cosim's build files; only the FMUs built are replaced.
    modelica_path : sequence of path-like, default ()
        Folders holding Modelica libraries, looked in before the list's ``libraries`` and ``MODELICAPATH``.
    fmi_version : {None, 2, 3}
        FMI version of the FMUs (default: 3, or each model list entry's ``fmi_version``).
    force : bool, default False
        A model list: rebuild the models whose sources, libraries and compiler are unchanged too.
    c_sources : bool, optional
        Also ship the C sources in the FMUs (default: no, or each model list entry's ``c_sources``).
    report : callable, optional
        Called with each model's line of report (``cosim build`` prints them) as it is built.

    Returns
    -------
    list of pathlib.Path
        The FMUs, built or up to date.

    Raises
    ------
    ModelicaError
        A source cannot be compiled.
    BuildError
        ``out`` cannot be used, or an FMU cannot be compiled or packed.
    """
    from cosim.compile.build import build_fmu, build_listed, mark_fmu_folder
    from cosim.compile.library import library_path

    if model is None:
        if source_or_models is None or Path(source_or_models).suffix == ".mo":
            raise CosimError(f"{source_or_models}: name the model to build (model=\"Pkg.Model\"), or give a model "
                             "list (.toml)")
        paths = []
        for path, line in build_listed(models_toml=source_or_models, out_dir=out, force=force,
                                       fmi_version=fmi_version, source=c_sources, modelica_path=modelica_path):
            paths.append(path)
            if report is not None:
                report(line)
        return paths
    path = build_fmu(source_or_models, model, out_dir=mark_fmu_folder(out or "fmus", check_only=True),
                     fmi_version=fmi_version or 3, source=bool(c_sources), modelica_path=library_path(modelica_path))
    mark_fmu_folder(path.parent)
    if report is not None:
        report(f"built {path}")
    return [path]


def run(config, *, set=None, out=None, csv=False, force=False, progress=None):
    """Co-simulate a run config's FMUs and controllers; nothing is written unless ``out`` is given (but numba's
    cache of the compiled controller kernels, in ``__pycache__`` beside each controller's file).

    Parameters
    ----------
    config : path-like or Config
        A TOML run config (docs/config.md), or a :class:`Config` built in code.
    set : dict or sequence of str, optional
        Keys changed before the run, as ``cosim run --set``: ``{"run.stop": 0.5}`` or ``["run.stop=0.5"]``.
    out : path-like, optional
        Write results.parquet, summary.json and the plot there (new, empty, or a previous cosim output with
        ``force``), as ``cosim run --out`` does.
    csv : bool, default False
        With ``out``: also write results.csv.
    force : bool, default False
        With ``out``: replace a previous cosim output there.
    progress : bool or None
        A progress bar on stderr; None: as ``run.progress`` says (long runs on a terminal).

    Returns
    -------
    RunResult
        The records (:meth:`RunResult.frame`), the summary, the config, the output folder (None without ``out``)
        and :meth:`RunResult.plot`.

    Raises
    ------
    ConfigError
        The config is invalid (every problem, with its key).
    RunStopped
        With ``out``: the run stopped on a fault; what was recorded was written first. Without ``out`` the fault
        itself is raised.
    """
    from dataclasses import replace

    from cosim.master.engine import engine_for
    from cosim.master.run import write_run
    from cosim.master.summary import summarize

    if not isinstance(config, Config):
        config = Config.load(config, set)
    elif set:
        config = config.with_set(set)
    if out is None:
        result = engine_for(config).run(progress=progress)
        return replace(result, config=config, summary=summarize(result, config))
    result, summary, files = write_run(config, out, csv=csv, progress=progress, force=force)
    return replace(result, config=config, summary=summary, out=Path(out), files=files)


def calibrate(job, *, set=None, out=None, force=False, progress=False):
    """Fit the free parameters of a calibration job's model to its measured data, as ``cosim calibrate`` does;
    nothing is written unless ``out`` is given.

    Parameters
    ----------
    job : path-like
        The calibration job (.toml, docs/guide/calibrate.md).
    set : dict or sequence of str, optional
        Job keys changed first, as ``cosim calibrate --set``: ``{"multistart.count": 1}`` or
        ``["multistart.count=1"]``.
    out : path-like, optional
        Write calibration.json, parameters.toml (the calibrated set, for a run config) and fit.png there: new,
        empty, or a previous cosim output with ``force``.
    force : bool, default False
        With ``out``: replace a previous cosim output there.
    progress : bool, default False
        A progress bar over the starts' fits on stderr.

    Returns
    -------
    CalibrationResult
        What calibration.json holds: the values with their standard errors, correlations, costs, every start's
        fit, the provenance.

    Raises
    ------
    ConfigError
        The job is invalid (every problem, with its key), or ``out`` cannot be used.
    """
    from cosim.calibrate.job import run_job

    return run_job(job, out=out, overrides=_set_items(set), progress=progress, force=force)


def diagnose(job, *, set=None, out=None, build=True, force=False, progress=False):
    """Find where a calibrated model and a measurement disagree and name the missing effect, as ``cosim diagnose``
    does; nothing is written unless ``out`` is given (but, with ``build``, the FMUs built, see ``out``).

    Parameters
    ----------
    job : path-like
        The diagnosis job (.toml, docs/guide/diagnose.md).
    set : dict or sequence of str, optional
        Job keys changed first, as ``cosim diagnose --set``.
    out : path-like, optional
        Write diagnosis.json, report.md, the plots, the variant's Modelica and its diff, the FMUs and the re-run
        configs there: new, empty, or a previous cosim output with ``force``. Without it, the FMUs and re-run
        configs ``build`` makes go to a new temporary folder that the result's ``fmu`` and ``rerun`` name.
    build : bool, default True
        Build the baseline's and the winner's FMUs and re-run them through the master.
    force : bool, default False
        With ``out``: replace a previous cosim output there.
    progress : bool, default False
        A progress bar over the candidates' fits on stderr.

    Returns
    -------
    Diagnosis
        What diagnosis.json holds: the verdict, the evidence and the next step, the gap before and after, every
        candidate's score.

    Raises
    ------
    ConfigError
        The job is invalid (every problem, with its key), or ``out`` cannot be used.
    """
    from cosim.diagnose import diagnose as diagnose_job

    return diagnose_job(job, out=out, overrides=_set_items(set), progress=progress, build=build, force=force)


def campaign(job, *, set=None, out=None, workers=None, scheduler="", progress=False):
    """Run every trial of a campaign job on Dask, as ``cosim campaign`` does; nothing is written unless ``out``
    is given (the trials' parts then go to a temporary folder, removed at the end).

    Parameters
    ----------
    job : path-like
        The campaign job (.toml, docs/guide/campaign.md).
    set : dict or sequence of str, optional
        Job keys changed first, as ``cosim campaign --set``: ``{"campaign.trials": 2}``.
    out : path-like, optional
        The campaign folder: the finished trials' parts as they arrive, then trials.parquet, table1.csv,
        table1.md, boxplots.png and summary.json. A folder holding the same job is resumed.
    workers : int, optional
        Workers of the local Dask cluster (default: one a core).
    scheduler : str, default ""
        Address of a running Dask scheduler to use instead of a local cluster.
    progress : bool, default False
        A progress bar with the ETA on stderr.

    Returns
    -------
    CampaignResult
        summary.json's figures, the trials and the table of each cell's statistics; after Ctrl-C
        (``interrupted``), those of the trials finished (kept in ``out/parts``: the same call resumes).

    Raises
    ------
    ConfigError
        The job is invalid; ``out`` is not a cosim output or holds another job (the changed keys are named); the
        scheduler does not answer.
    """
    from cosim.campaign import run_campaign

    return run_campaign(job, out=out, overrides=_set_items(set), workers=workers, scheduler=scheduler,
                        progress=progress)
