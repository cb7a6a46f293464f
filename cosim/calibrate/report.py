"""Calibration outputs: calibration.json (values, standard errors, correlations, costs), parameters.toml (the
calibrated set, loadable by a run config) and a plot of measured vs simulated before and after."""

import json
import math

import matplotlib
import numpy as np

from cosim.outputs import optional_file
from cosim.paramfile import write_parameters_file

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["write_results", "standard_error"]


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


def write_results(result, job, fit, out):
    """Write the :class:`~cosim.calibrate.result.CalibrationResult` ``result`` of a fit of ``job`` into the folder
    ``out``: calibration.json, parameters.toml and fit.png (of ``fit``, the best start's
    :class:`~cosim.calibrate.multistart.StartFit`)."""
    (out / "calibration.json").write_text(json.dumps(result.to_json(), indent=2))
    header = (f"Calibrated by `cosim calibrate {job.path.name}`, model {job.model}, cost {result.cost_after:.6g}",
              "Read by run configs ([fmus.plant] parameters_file = \"<this file>\"), campaign jobs ([campaign]) and",
              "calibration jobs ([model]); [provenance] says which job, data and code made it.")
    write_parameters_file(out / "parameters.toml", result.values,
                          {n: standard_error(p.std_error) for n, p in result.parameters.items()}, result.provenance,
                          header)
    optional_file(out / "fit.png", lambda p: _plot(job, fit, p))


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

