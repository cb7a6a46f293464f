"""Calibration outputs: calibration.json (values, standard errors, correlations, costs), parameters.toml (the
calibrated set, loadable by a run config) and a plot of measured vs simulated before and after."""

import json
import math

import matplotlib
import numpy as np

from cosim.outputs import optional_file
from cosim.paramfile import provenance, write_parameters_file

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["write_results", "standard_error"]


def _finite(x):
    """``x``, or None (JSON null) when it is inf or NaN (a parameter the data do not determine)."""
    return x if math.isfinite(x) else None


def standard_error(std):
    """``std`` as a report says it: "+- 0.012 (1 s.e.)", or that the data do not determine the parameter.

    Parameters
    ----------
    std : float or None
        The standard error (inf or None: not identifiable).

    Returns
    -------
    str
    """
    if std is None or not math.isfinite(std):
        return "not identifiable: the fitted samples do not determine it (no s.e.)"
    return f"+- {std:.3g} (1 s.e.)"


def write_results(job, result, runs, out):
    """Write the results of a fit of ``job`` into the folder ``out``: ``result`` the best start's
    :class:`~cosim.calibrate.multistart.StartFit`, ``runs`` every start's; returns the calibration.json content."""
    names = list(job.free)
    summary = {
        "job": str(job.path),
        "model": job.model,
        "data": str(job.data_path),
        "method": job.method,
        "substeps": job.substeps,
        "derivatives": ("finite differences through the FMU (the model has no CasADi form)" if job.fmu else
                        "exact (CasADi automatic differentiation of the lowered Modelica equations)"),
        "parameters": {n: {"value": result.parameters[n], "std_error": _finite(result.std_errors[n]),
                           "identifiable": math.isfinite(result.std_errors[n]), "start": result.start[n]}
                       for n in names},
        "correlation": {"names": names, "matrix": [[_finite(c) for c in row] for row in result.correlation]},
        "cost_before": result.cost_before,
        "cost_after": result.cost_after,
        "cost_definition": "0.5 * sum over fitted samples of ((simulated - measured) / noise)^2",
        "iterations": result.iterations,
        "success": result.success,
        "return_status": result.return_status,
        "samples": int(result.mask.sum()),
        "multistart": [r.summary() for r in runs],
    }
    prov = provenance(job.path, [job.data_path], job.upstream)
    summary["provenance"] = prov
    (out / "calibration.json").write_text(json.dumps(summary, indent=2))
    header = (f"Calibrated by `cosim calibrate {job.path.name}`, model {job.model}, cost {result.cost_after:.6g}",
              "Read by run configs ([fmus.plant] parameters_file = \"<this file>\"), campaign jobs ([campaign]) and",
              "calibration jobs ([model]); [provenance] says which job, data and code made it.")
    write_parameters_file(out / "parameters.toml", {n: result.parameters[n] for n in names},
                          {n: standard_error(result.std_errors[n]) for n in names}, prov, header)
    optional_file(out / "fit.png", lambda p: _plot(job, result, p))
    return summary


def _plot(job, result, path):
    signals = job.signals
    fig, axes = plt.subplots(2 * len(signals), 1, figsize=(9, 4.2 * len(signals)), sharex=True, squeeze=False)
    t = result.time
    for k, (output, column, noise) in enumerate(signals):
        ax, res = axes[2 * k, 0], axes[2 * k + 1, 0]
        measured = result.measured[k]
        ax.plot(t, measured, ".", ms=2, color="0.4", label=f"measured ({column})")
        ax.plot(t, result.predicted_before[k], "--", color="tab:red", label="model, start values")
        ax.plot(t, result.predicted[k], color="tab:blue", label="model, calibrated")
        ax.set_ylabel(f"{output} [{result.units.get(output) or '1'}]")
        ax.legend(loc="best", fontsize=8)
        ax.set_title(f"{job.model}: {output}, cost {result.cost_before:.4g} -> {result.cost_after:.4g}")
        sampled = np.isfinite(measured)
        res.plot(t[sampled], (result.predicted_before[k] - measured)[sampled], "--", color="tab:red", lw=0.8,
                 label="start")
        res.plot(t[sampled], (result.predicted[k] - measured)[sampled], color="tab:blue", lw=0.8,
                 label="calibrated")
        res.axhspan(-noise, noise, color="0.9", label="noise (1 sd)")
        res.set_ylabel(f"residual [{result.units.get(output) or '1'}]")
        res.legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)

