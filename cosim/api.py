"""The Python API of a build and a run, as ``cosim build`` and ``cosim run`` do them on the command line (the
command line is a thin layer over these calls). Nothing is written unless a call is given ``out``. The jobs'
calls, ``cosim.calibrate``, ``cosim.diagnose`` and ``cosim.campaign``, are their subpackages' own (the reason is
in :mod:`cosim`'s docstring); docs/reference/python.md documents them all.

Example::

    import cosim

    cosim.build("modelica/models.toml")
    result = cosim.run("examples/gripper_impact.toml", set={"run.stop": 0.5})
    result.frame("plant").F_g.max()
    fit = cosim.calibrate("examples/calibrate_static.toml", out="out/calibrate_static")
    fit.parameters["eta_g"].value
"""

from pathlib import Path

from cosim.config import Config
from cosim.errors import CosimError
from cosim.master.engine import RunResult

__all__ = ["build", "run", "Config", "RunResult"]


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
    cache of the compiled kernels, in the user's cache folder: ``~/.cache/cosim`` on Linux).

    Parameters
    ----------
    config : path-like or Config
        A TOML run config (docs/config.md), an SSP archive (``.ssp``, docs/guide/ssp.md), or a :class:`Config`
        built in code. An SSP read by this call (the archive, or one a config names) is unpacked into a temporary
        folder removed when the call returns or raises.
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
        and :meth:`RunResult.plot`. Of an SSP unpacked by this call, ``config`` names FMU and controller files
        that are gone: run the archive again by its path (``config.path``).

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
    from cosim.ssp.read import unpacked_archives

    with unpacked_archives():  # an SSP read here is unpacked for this run only (its FMUs closed before the end)
        if not isinstance(config, Config):
            config = Config.load(config, set)
        elif set:
            config = config.with_set(set)
        if out is None:
            result = engine_for(config).run(progress=progress)
            return replace(result, config=config, summary=summarize(result, config))
        result, summary, files = write_run(config, out, csv=csv, progress=progress, force=force)
        return replace(result, config=config, summary=summary, out=Path(out), files=files)
