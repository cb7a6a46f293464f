"""The PNG of a run, drawn to be read at a glance: a title saying what ran, measured signals above their
references, axes named by their quantity, labelled modes, a zoomed panel around the experiment's event and a
mark where a run stopped early."""

import textwrap
from pathlib import Path

import numpy as np

__all__ = ["plot_results", "run_figure", "run_title"]

# the quantity an axis shows, by its unit (an axis with another unit is named by its columns)
QUANTITIES = {"N": "force", "N.m": "torque", "A": "current", "V": "voltage", "W": "power", "rad/s": "speed",
              "rpm": "speed", "rad": "angle", "m": "position", "m/s": "velocity", "m/s2": "acceleration",
              "s": "time", "K": "temperature", "Hz": "frequency", "Pa": "pressure"}
_REFERENCE_SUFFIXES = ("_ref", "_set", "_sp", "_target", "_cmd")


def run_title(config, result=None):
    """What ran, in two lines: the models and the scenario its controllers describe, then the config file with
    the model parameters it sets and the ``--set`` overrides.

    Parameters
    ----------
    config : cosim.config.Config
    result : cosim.master.engine.RunResult, optional
        Its controllers' parameter values describe the scenario (default: the config's).

    Returns
    -------
    str
    """
    models = ", ".join(dict.fromkeys(spec.path.stem for spec in config.fmus.values()))
    values = result.controller_values if result is not None else {}
    scenarios = [spec.cls.scenario(values.get(name, spec.parameters)) for name, spec in config.controllers.items()
                 if spec.cls is not None]
    scenario = "; ".join(s for s in scenarios if s) or config.name
    params = [f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}"
              for spec in config.fmus.values() for k, v in spec.parameters.items()]
    second = config.path.name + (": " + ", ".join(params) if params else "")
    if config.overrides:  # a path's folder says nothing about what ran
        second += "; --set " + " ".join(_short(o) for o in config.overrides)
    return f"{models}: {scenario}\n" + "\n".join(textwrap.wrap(second, 110))


def _short(override):
    """``key=value`` with a path value cut to its file name."""
    key, _, value = override.partition("=")
    return f"{key}={Path(value).name}" if "/" in value else override


def plot_results(result, path, panels=(), title="", config=None, summary=None):
    """Plot recorded columns against time, one panel per group, and write the PNG.

    Parameters
    ----------
    result : cosim.master.engine.RunResult
    path : path-like
        PNG file; its ``Title`` text chunk holds the figure's title.
    panels : sequence of sequence of str
        Column names per panel; default one panel per recorded column.
    title : str, optional
        The figure's title (default: :func:`run_title` when ``config`` is given).
    config : cosim.config.Config, optional
        The run's config: the title, the controllers' mode labels, the stop time a run that stopped early misses.
    summary : dict, optional
        The run's summary.json: the time of the event the zoomed panel shows (the summary's ``event`` key).

    Returns
    -------
    pathlib.Path
    """
    import matplotlib

    matplotlib.use("Agg")  # a file is drawn: no window, whatever the display
    import matplotlib.pyplot as plt

    fig = run_figure(result, panels=panels, title=title, config=config, summary=summary)
    fig.savefig(path, dpi=110, metadata={"Title": fig.get_suptitle()})
    plt.close(fig)
    return Path(path)


def run_figure(result, panels=(), title="", config=None, summary=None):
    """The figure :func:`plot_results` writes, for a caller that adds to it or checks it.

    Parameters
    ----------
    result : cosim.master.engine.RunResult
    panels : sequence of sequence of str
        Column names per panel; default one panel per recorded column.
    title : str, optional
        The figure's title (default: :func:`run_title` when ``config`` is given).
    config : cosim.config.Config, optional
        The run's config (see :func:`plot_results`).
    summary : dict, optional
        The run's summary.json (see :func:`plot_results`).

    Returns
    -------
    matplotlib.figure.Figure
        Drawn with the backend in use (a notebook's shows it; :func:`plot_results` draws with Agg).
    """
    import matplotlib.pyplot as plt

    names = [n for n in result.data.dtype.names if n != "time"]
    panels = [[n for n in p if n in names] for p in ([list(p) for p in panels] or [[n] for n in names])]
    panels = [p for p in panels if p]
    event = _event(config, summary)
    stop = config.run.stop if config is not None else None
    height = 1.9 * len(panels) + 1.2 + (2.2 if event else 0.0)
    fig = plt.figure(figsize=(8.5, height), layout="constrained")
    grid = fig.add_gridspec(len(panels) + (1 if event else 0), 1,
                            height_ratios=[1.0] * len(panels) + ([1.25] if event else []))
    axes = []
    for k, panel in enumerate(panels):
        ax = fig.add_subplot(grid[k], sharex=axes[0] if axes else None)
        _draw_panel(ax, result, panel, config)
        axes.append(ax)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel("time [s]")
    if stop is not None and len(result.data):
        axes[0].set_xlim(min(config.run.start, result.data["time"][0]), stop)
    if result.stopped is not None:
        _mark_stop(axes, result.stopped, stop)
    if event:
        _draw_zoom(fig.add_subplot(grid[len(panels)]), axes, result, panels[0], config, event)
    title = title or (run_title(config, result) if config is not None else "")
    if result.stopped is not None:
        title += f"\nSTOPPED EARLY at t = {result.stopped['time']:.4g} s: {result.stopped['reason']}"
    fig.suptitle(title, fontsize=9.5)
    return fig


def _source(result, config, column):
    """``(instance, variable, kind)`` of a column, kind "fmu", "controller" or "" when not known."""
    inst, var = result.signals.get(column, ("", column))
    if config is None:
        return inst, var, ""
    return inst, var, "fmu" if inst in config.fmus else "controller" if inst in config.controllers else ""


def _labels(config, inst, var):
    """The controller's names of the values of an output (``Controller.labels``), or None."""
    if config is None or inst not in config.controllers or config.controllers[inst].cls is None:
        return None
    return getattr(config.controllers[inst].cls, "labels", {}).get(var)


def _draw_panel(ax, result, panel, config):
    """One panel: references (controller outputs named ``*_ref``, ``*_set``, ...) wide and pale underneath, other
    controller signals in the middle, measured plant signals thin on top (a measured signal that tracks its
    reference exactly stays visible inside it); the axis named by its quantity."""
    t = result.data["time"]
    for column in panel:
        inst, var, kind = _source(result, config, column)
        reference = var.endswith(_REFERENCE_SUFFIXES)
        style = ({"zorder": 3, "lw": 1.0} if kind == "fmu" else
                 {"zorder": 1, "lw": 3.0, "alpha": 0.45} if reference else {"zorder": 2, "lw": 0.9})
        step = "post" if kind == "controller" else None
        ax.plot(t, result.data[column], label=column + (" (reference)" if reference else ""), drawstyle=(
            "steps-post" if step else "default"), **style)
    units = sorted({result.units.get(n, "") for n in panel} - {""})
    labels = [_labels(config, *_source(result, config, n)[:2]) for n in panel]
    if labels[0] and all(lab == labels[0] for lab in labels):
        ax.set_yticks(sorted(labels[0]), [f"{k:g}: {labels[0][k]}" for k in sorted(labels[0])])
        ax.set_ylim(min(labels[0]) - 0.3, max(labels[0]) + 0.3)
        ax.set_ylabel(", ".join(panel) if len(panel) < 3 else "mode", fontsize=8)
    else:
        ax.set_ylabel(_axis_name(panel, units), fontsize=8)
    if len(panel) > 1:
        ax.legend(fontsize=7, loc="best")
    ax.grid(True, lw=0.3)


def _axis_name(panel, units):
    """``quantity [unit]`` (with the column's name when the panel has one column), else the columns' names."""
    unit = " / ".join(units) or "-"
    quantity = QUANTITIES.get(units[0]) if len(units) == 1 else None
    if quantity:
        return f"{quantity} {panel[0]} [{unit}]" if len(panel) == 1 else f"{quantity} [{unit}]"
    return f"{', '.join(panel)} [{unit}]"


def _event(config, summary):
    """``(name, time)`` of the event the summary plugin names (its ``event`` attribute), or None."""
    if config is None or summary is None or config.summary.plugin is None:
        return None
    key = getattr(config.summary.plugin, "event", None)
    t = summary.get(key) if key else None
    return (key, float(t)) if isinstance(t, (int, float)) else None


def _draw_zoom(ax, axes, result, panel, config, event):
    """The first panel's signals around the event: from 2 % of the run before it to 4 % after, shaded on
    every full-length panel."""
    key, t_event = event
    span = config.run.stop - config.run.start
    lo, hi = t_event - 0.02 * span, t_event + 0.04 * span
    _draw_panel(ax, result, panel, config)
    ax.set_xlim(lo, hi)
    t = result.data["time"]
    inside = (t >= lo) & (t <= hi)
    if inside.any():
        values = np.concatenate([result.data[n][inside] for n in panel])
        pad = 0.08 * (values.max() - values.min()) or 1.0
        ax.set_ylim(values.min() - pad, values.max() + pad)
    ax.axvline(t_event, color="k", lw=0.8, ls=":")
    ax.set_title(f"zoom around the event ({key} = {t_event:.4g} s, shaded above)", fontsize=8)
    ax.set_xlabel("time [s]")
    for full in axes:
        full.axvspan(lo, hi, color="0.85", zorder=0)


def _mark_stop(axes, stopped, stop):
    """A red line where the run stopped and the part it did not simulate hatched."""
    for ax in axes:
        ax.axvline(stopped["time"], color="red", lw=1.2)
        if stop is not None and stop > stopped["time"]:
            ax.axvspan(stopped["time"], stop, facecolor="none", hatch="//", edgecolor="red", lw=0, alpha=0.4)
    axes[0].annotate(f"stopped at {stopped['time']:.4g} s", (stopped["time"], 1.0), xycoords=("data", "axes fraction"),
                     xytext=(3, -10), textcoords="offset points", color="red", fontsize=8)
