"""Discrepancy workflow (``cosim diagnose``): replay and compare a calibrated baseline with measured data, locate
where and how the residual exceeds the noise, name the missing effect (or the law of another form) from a library
of Modelica candidates, add it and show the gap shrink, round after round while a gap is left. See
docs/guide/diagnose.md."""

import sys

from cosim import _callable_package
from cosim.diagnose.effects import EFFECTS, effect_names, get_effect, write_variant
from cosim.diagnose.job import DiagnoseJob, load_diagnose_job
from cosim.diagnose.result import Diagnosis
from cosim.diagnose.rounds import run_diagnosis

__all__ = ["EFFECTS", "effect_names", "get_effect", "write_variant", "DiagnoseJob", "load_diagnose_job",
           "Diagnosis", "run_diagnosis", "diagnose"]

_callable_package(sys.modules[__name__])  # cosim.diagnose(job, ...) is cosim.api.diagnose


def diagnose(path, out="out/diagnosis", overrides=(), progress=True, build=True, force=False):
    """Run the diagnosis job at ``path`` and write its results to ``out``; returns the :class:`Diagnosis`.

    Parameters
    ----------
    path : str or Path
        Job file (TOML, see :mod:`cosim.diagnose.job`).
    out : str or Path or None, default "out/diagnosis"
        Output folder: diagnosis.json, report.md, PNGs, the variant's Modelica and diff, fmu/ (the baseline's and
        the winner's FMUs) and rerun/ (the run configs that replay them through the master); a later round's under
        round<k>/. New, empty, or a
        previous cosim output (with ``force``); written beside it and moved into place at the end
        (:func:`cosim.outputs.output_folder`). None: nothing is written but, with ``build``, the FMUs and the
        re-run configs, in a new temporary folder that the result's ``fmu`` and ``rerun`` name.
    overrides : sequence of str
        ``key=value`` job overrides (``--set``).
    progress : bool, default True
        Progress bar over the candidate fits.
    build : bool, default True
        Build the baseline's and the winner's FMUs into ``out/fmu`` and re-run them through the master.
    force : bool, default False
        Replace a previous cosim output at ``out``.
    """
    from cosim.diagnose.report import write_diagnosis
    from cosim.master.run import SignalsHeld, interrupt_on_signals
    from cosim.outputs import output_folder
    from cosim.parallel import check_scheduler

    job = load_diagnose_job(path, overrides)
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
