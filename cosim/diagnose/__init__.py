"""Discrepancy workflow (``cosim diagnose``): replay and compare a calibrated baseline with measured data, locate
where and how the residual exceeds the noise, name the missing effect (or the law of another form) from a library
of Modelica candidates, add it and show the gap shrink, round after round while a gap is left. See
docs/guide/diagnose.md."""

import sys

from cosim.callable_package import make_callable
from cosim.diagnose.effects import EFFECTS, effect_names, get_effect, write_variant
from cosim.diagnose.job import DiagnoseJob, load_diagnose_job
from cosim.diagnose.result import Diagnosis
from cosim.diagnose.rounds import run_diagnosis

__all__ = ["EFFECTS", "effect_names", "get_effect", "write_variant", "DiagnoseJob", "load_diagnose_job",
           "Diagnosis", "run_diagnosis", "diagnose"]

make_callable(sys.modules[__name__])  # cosim.diagnose(job, ...) is diagnose below


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
    from cosim.config import override_items
    from cosim.diagnose.report import write_diagnosis
    from cosim.master.run import SignalsHeld, interrupt_on_signals
    from cosim.outputs import output_folder
    from cosim.parallel import check_scheduler

    job = load_diagnose_job(job, override_items(set))
    if job.scheduler:  # the candidates' fits need it only after the baseline's: say now that it does not answer
        check_scheduler(job.scheduler)
    if out is None:
        return run_diagnosis(job, progress=progress, build=build)
    held = SignalsHeld(out)  # a Ctrl-C while the diagnosis is written waits for the files
    with interrupt_on_signals(), held, output_folder(out, "diagnose", force=force) as staging:
        result = _relocated(run_diagnosis(job, progress=progress, build=build, out=staging), staging, out)
        held.start()
        write_diagnosis(result, staging, source=job.source)
    return result


def _relocated(result, staging, out):
    """``result`` with the paths it holds into the staging folder pointing into ``out`` instead."""
    import dataclasses

    def moved(path):
        return str(path).replace(str(staging), str(out), 1) if path is not None else None

    rerun = result.rerun
    if rerun is not None:
        rerun = dataclasses.replace(rerun, configs={k: moved(v) for k, v in rerun.configs.items()})
    return dataclasses.replace(result, fmu=moved(result.fmu), rerun=rerun)
