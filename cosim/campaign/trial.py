"""One impact trial: the coating's shipped impact run config with a trial's drawn values, run in process by
the master's engine, reduced to the trial's row (peak, minimum after the peak, steady force, bounce, contact).

:class:`TrialRunner` keeps one :class:`~cosim.master.engine.Engine` per coating alive across trials (its
controller and loop kernels are compiled or loaded once, ~2 s, against ~0.3 s for a trial) and its FMU
loaded (:class:`~cosim.master.plant.FmuPool`: loading costs ~40 ms, a tenth of a trial); a trial is a variant
run of that engine (:meth:`~cosim.master.engine.Engine.run_variant`) with its own FMU parameters and start values,
outer-loop parameters and stop instant.
"""

import math
import shlex

import numpy as np

from cosim.campaign.draws import draw
from cosim.errors import ConfigError

__all__ = ["TrialRunner", "COLUMNS", "run_command"]

# trials.parquet's columns (issue #30): identity, drawn values, results
DRAWN = ("free_travel_m", "play_position", "encoder_phase", "friction_scatter", "gear_efficiency",
         "controller_phase_s", "load_cell_noise_N")
COLUMNS = ("coating", "speed_rpm", "current_A", "trial", "seed", *DRAWN, "peak_force_N", "min_force_after_peak_N",
           "steady_force_N", "bounced", "t_contact_s")
_PLANT, _OUTER = "plant", "outer"
_LATE_MARGIN_S = 0.01  # s simulated past the end of a late trigger's tightening (above one record period)


def _fmu_value(spec, name):
    """A plant parameter's value: the config's, else the FMU's start value."""
    if name in spec.parameters:
        return float(spec.parameters[name])
    var = spec.info.variables.get(name)
    if var is None or var.start is None:
        raise ConfigError(f"{spec.path}: the FMU has no parameter {name!r} with a value; a campaign trial needs it")
    return float(var.start)


def _plant_sets(job, coating):
    """``--set`` items of a coating's plant on top of its run config: the campaign's parameters file, then the
    coating's own parameters."""
    upstream = job.parameters_file.values if job.parameters_file is not None else {}
    return [f"fmus.{_PLANT}.parameters.{k}={v!r}" for k, v in {**upstream, **coating.parameters}.items()]


def _trial_settings(job, base, spec, values):
    """Plant parameters, start values, outer-loop values and stop time (s) of one trial."""
    plant = base.fmus[_PLANT]
    outer = dict(base.controllers[_OUTER].parameters)
    p = {k: _fmu_value(plant, k) for k in ("gap0", "t_coat", "T_c0", "F_cj", "eta_g", "ratio", "r_p", "play")}
    params = dict(plant.parameters)
    params["gap0"] = p["gap0"] + values["free_travel"]
    params["T_c0"] = p["T_c0"] * (1.0 + values["friction_scatter"])
    params["F_cj"] = p["F_cj"] * (1.0 + values["friction_scatter"])
    params["eta_g"] = p["eta_g"] + values["gear_efficiency"]
    cpt = float(outer.get("enc_cpt", 2048.0))
    phi0 = p["ratio"] * p["play"] * values["play_position"] + 2.0 * math.pi / cpt * values["encoder_phase"]
    start = {**plant.start, "motor.phi": phi0}
    ramp = float(outer.get("ramp_s", 0.2))
    ctrl = {"speed_rpm": spec.speed_rpm, "i_tight": spec.current_A, "hold_s": job.hold_s,
            "t_start": values["controller_phase"]}
    v_jaw = spec.speed_rpm * 2.0 * math.pi / 60.0 / p["ratio"] * p["r_p"]
    travel = params["gap0"] - p["t_coat"]
    t_contact = values["controller_phase"] + (ramp + (travel - v_jaw * ramp / 2) / v_jaw if travel > v_jaw * ramp / 2
                                              else math.sqrt(2 * max(travel, 0.0) * ramp / v_jaw))
    stop = t_contact + job.hold_s + job.margin_s
    return params, start, ctrl, stop


class TrialRunner:
    """Run the trials of one coating with one engine (see the module docstring).

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob
    coating : cosim.campaign.job.Coating
    """

    def __init__(self, job, coating):
        from cosim.config import load_config
        from cosim.master.engine import engine_for
        from cosim.master.plant import FmuPool

        overrides = _plant_sets(job, coating) + [f'record.signals=["{_PLANT}.F_g"]', "plot.panels=[]"]
        self.job, self.coating = job, coating
        self.base = load_config(coating.config, overrides)
        if _PLANT not in self.base.fmus or _OUTER not in self.base.controllers or self.base.summary.kind != "impact":
            raise ConfigError(f"{coating.config}: coating {coating.name!r}: a campaign trial needs an impact run "
                              f"config (an FMU instance {_PLANT!r}, a controller {_OUTER!r}, [summary] kind = "
                              "\"impact\"), as examples/gripper_impact.toml")
        self.engine = engine_for(self.base)
        self.engine.fmu_pool = FmuPool()  # the FMU stays loaded from one trial to the next
        self.loop_s = 0.0  # wall time inside the engine's loop, summed over the trials run
        self.kernel_s = 0.0  # wall time compiling or loading the loop's kernel (the first run), summed
        self.stop_s = None  # the stop time (s) of the last trial's run, the longer one of a late trigger

    def close(self):
        """Unload the FMU kept between trials (and remove the folder it was unpacked into)."""
        self.engine.fmu_pool.close()

    def run(self, spec, plant=None, outer=None):
        """Run one trial.

        The run stops ``margin_s`` after the expected end of tightening; when the impact trigger fired later than
        that allows (a window of eq. (2) broken by the encoder's quantisation or a rebound, so the trigger fires
        once the motor stands still), the same trial is run again up to the end of its tightening. The engine's
        fixed steps make the longer run the same as the shorter one up to its stop.

        Parameters
        ----------
        spec : cosim.campaign.draws.TrialSpec
        plant, outer : dict, optional
            Further plant parameters and outer-loop values of this run only (a sensitivity analysis's point).

        Returns
        -------
        dict
            The trial's row of trials.parquet (:data:`COLUMNS`).
        """
        job = self.job
        values, noise = draw(job, spec)
        params, start, ctrl, stop = _trial_settings(job, self.base, spec, values)
        params.update(plant or {})
        ctrl.update(outer or {})
        result, s = self._simulate(params, start, ctrl, stop)
        if s["t_switch_s"] is not None and result.data["time"][-1] < s["t_switch_s"] + job.hold_s - 1e-6:
            result, s = self._simulate(params, start, ctrl, s["t_switch_s"] + job.hold_s + _LATE_MARGIN_S)
        return self._row(spec, values, noise, result, s)

    def _simulate(self, params, start, ctrl, stop):
        """Run the engine with a trial's plant values, outer-loop values and stop; (result, impact summary)."""
        eng, base = self.engine, self.base
        self.stop_s = stop
        result = eng.run_variant(stop=stop, parameters={_PLANT: params}, start={_PLANT: start},
                                 controllers={_OUTER: ctrl})
        self.loop_s += result.wall_s
        self.kernel_s += result.compile_s - eng.compile_s
        summary = base.summary
        return result, summary.plugin.summarize(result.data, result.controller_values[_OUTER], dict(summary.columns))

    def _row(self, spec, values, noise, result, s):
        """Reduce a run and its impact summary ``s`` to the trial's row: the impact summary of the recorded force,
        the steady force from the load cell's 100 Hz samples (with their noise) over the last ``steady_s`` of
        tightening."""
        job, summary = self.job, self.base.summary
        t = result.data["time"]
        f = result.data[summary.columns["force"]]
        steady = math.nan
        noise_mean = 0.0
        window = s.get("steady_window_s")  # None when the trigger never fired; else it ends with the tightening (run)
        if window is not None:
            end = window[1]
            n = int(round(job.steady_s * job.load_cell_rate))
            ts = end - np.arange(n)[::-1] / job.load_cell_rate
            ts = ts[ts >= t[0]]
            e = noise.normal(0.0, values["load_cell_noise"], len(ts)) if values["load_cell_noise"] > 0 else 0 * ts
            steady = float(np.mean(np.interp(ts, t, f) + e))
            noise_mean = float(np.mean(e))
        peak = s["peak_force_N"] if s["peak_force_N"] is not None else math.nan
        low = s["min_force_after_peak_N"] if s["min_force_after_peak_N"] is not None else math.nan
        drawn = [values["free_travel"], values["play_position"], values["encoder_phase"], values["friction_scatter"],
                 values["gear_efficiency"], values["controller_phase"], noise_mean]
        return dict(zip(COLUMNS, (
            spec.coating, spec.speed_rpm, spec.current_A, spec.trial, spec.seed, *drawn, peak, low, steady,
            bool(low < job.bounce_fraction * steady), s["t_contact_s"] if s["t_contact_s"] is not None else math.nan)))


def run_command(job, spec, stop=None):
    """The ``cosim run`` command that runs one trial's co-simulation alone (the load cell's noise and the
    steady force's 100 Hz sampling are the campaign's post-processing: not in it).

    Parameters
    ----------
    job : cosim.campaign.job.CampaignJob
    spec : cosim.campaign.draws.TrialSpec
    stop : float, optional
        The run's stop time (s), when it was not the expected one (:attr:`TrialRunner.stop_s`).

    Returns
    -------
    str
    """
    from cosim.config import load_config

    coating = next(c for c in job.coatings if c.name == spec.coating)
    base = load_config(coating.config, _plant_sets(job, coating))
    values, _ = draw(job, spec)
    params, start, ctrl, expected_stop = _trial_settings(job, base, spec, values)
    stop = expected_stop if stop is None else stop
    sets = [f"run.stop={stop!r}"]
    sets += [f"fmus.{_PLANT}.parameters.{k}={v!r}" for k, v in params.items()]
    sets += [f'fmus.{_PLANT}.start."{k}"={v!r}' for k, v in start.items()]
    sets += [f"controllers.{_OUTER}.parameters.{k}={v!r}" for k, v in ctrl.items()]
    return "python -m cosim run " + shlex.quote(str(coating.config)) + "".join(f" --set {shlex.quote(s)}" for s in sets)
