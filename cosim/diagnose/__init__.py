"""Discrepancy workflow (``cosim diagnose``): replay and compare a calibrated baseline with measured data, locate
where and how the residual exceeds the noise, name the missing effect from a library of Modelica candidates, add
it and show the gap shrink. See docs/guide/diagnose.md."""

from cosim.diagnose.effects import EFFECTS, effect_names, get_effect, write_variant
from cosim.diagnose.job import DiagnoseJob, load_diagnose_job
from cosim.diagnose.result import Diagnosis
from cosim.diagnose.workflow import run_diagnosis

__all__ = ["EFFECTS", "effect_names", "get_effect", "write_variant", "DiagnoseJob", "load_diagnose_job",
           "Diagnosis", "run_diagnosis", "diagnose"]


def diagnose(path, out="out/diagnosis", overrides=(), progress=True, build=True):
    """Run the diagnosis job at ``path`` and write its results to ``out``; returns the :class:`Diagnosis`.

    Parameters
    ----------
    path : str or Path
        Job file (TOML, see :mod:`cosim.diagnose.job`).
    out : str or Path, default "out/diagnosis"
        Output folder: diagnosis.json, report.md, PNGs, the variant's Modelica and diff, fmu/ (the baseline's and
        the winner's FMUs) and rerun/ (the run configs that replay them through the master).
    overrides : sequence of str
        ``key=value`` job overrides (``--set``).
    progress : bool, default True
        Progress bar over the candidate fits.
    build : bool, default True
        Build the baseline's and the winner's FMUs into ``out/fmu`` and re-run them through the master.
    """
    from pathlib import Path

    from cosim.diagnose.report import write_diagnosis

    job = load_diagnose_job(path, overrides)
    out = Path(out)
    import shutil

    for stale in ("fmu", "rerun"):  # the workflow writes these before the report replaces the rest
        if (out / stale).exists():
            shutil.rmtree(out / stale)
    result = run_diagnosis(job, progress=progress, build=build, out=out)
    write_diagnosis(result, out, source=job.source)
    return result
