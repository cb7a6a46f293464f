"""Files and plots of the haptic analyses: what the ``cosim haptic ...`` commands write."""

from pathlib import Path

import numpy as np

from cosim.haptic.margins import MARGIN_COLUMNS, adaptive_damping, margins_table, position_means

__all__ = ["write_margins", "plot_margins", "write_collisions", "write_identification",
           "identification_figure", "write_arm"]


def plot_margins(table, path, title="Virtual wall margins"):
    """Plot K_CR and PM against grasp position (each user a thin line, the mean thick) to a PNG.

    Parameters
    ----------
    table : pandas.DataFrame
        A `margins_table`.
    path : str or Path
        Output PNG.
    title : str, optional
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    means = position_means(table)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, col, label in (
        (axes[0], "K_CR_Nm_per_rad", "K_CR (N.m/rad)"),
        (axes[1], "PM_deg", "phase margin (deg)"),
        (axes[2], "settling_s", "predicted settling 4/(zeta w_cg) (s)"),
    ):
        for u, g in table.groupby("user"):
            ax.plot(g["position"], g[col], color="0.7", lw=0.8, marker=".")
        ax.plot(means["position"], means[col], color="C0", lw=2.5, marker="o", label="mean of 13 users")
        u1 = table[table["user"] == 1]
        ax.plot(u1["position"], u1[col], color="C3", lw=1.5, marker="s", label="user 1")
        ax.set_xlabel("grasp position")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[1].axhline(50, color="k", ls=":", lw=1)
    axes[2].set_yscale("log")
    axes[0].legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_margins(out_dir, K=10.0, rate=1000.0, adaptive=False):
    """Compute the wall margins for 13 users x 6 positions and write them with per-position means and a plot.

    Parameters
    ----------
    out_dir : str or Path
        Directory to write into (created if needed).
    K : float, optional
        Wall stiffness, N.m/rad (default 10).
    rate : float, optional
        Loop rate, Hz (default 1000).
    adaptive : bool, optional
        Also tune B per position on user 1 for PM >= 50 deg and write the damped table (default False).

    Returns
    -------
    list of Path
        The files written: ``margins.csv``, ``margins_means.csv``, ``margins.png`` and, with ``adaptive``,
        ``adaptive_damping.csv``, ``margins_adaptive.csv``, ``margins_adaptive_means.csv``, ``margins_adaptive.png``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = margins_table(K=K, rate=rate)
    written = []
    p = out / "margins.csv"
    table[MARGIN_COLUMNS].to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    p = out / "margins_means.csv"
    position_means(table).to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    p = out / "margins.png"
    plot_margins(table, p, title=f"Virtual wall K = {K:g} N.m/rad, B = 0, {rate:g} Hz loop")
    written.append(p)
    if adaptive:
        B = adaptive_damping(user=1, K=K, rate=rate)
        p = out / "adaptive_damping.csv"
        with open(p, "w", encoding="utf-8") as fh:
            fh.write("position,B_Nms_per_rad\n")
            for pos, b in B.items():
                fh.write(f"{pos},{b:.6g}\n")
        written.append(p)
        damped = margins_table(K=K, rate=rate, damping=B)
        p = out / "margins_adaptive.csv"
        damped[MARGIN_COLUMNS + ["B_Nms_per_rad"]].to_csv(p, index=False, float_format="%.6g")
        written.append(p)
        p = out / "margins_adaptive_means.csv"
        position_means(damped).to_csv(p, index=False, float_format="%.6g")
        written.append(p)
        p = out / "margins_adaptive.png"
        plot_margins(damped, p, title=f"Adaptive wall K = {K:g} N.m/rad, B tuned on user 1 (PM >= 50 deg)")
        written.append(p)
    return written


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def write_collisions(out_dir, users=(1,), adaptive=False, fmu_dir="fmus", K=10.0, rate=1000.0):
    """Simulate wall contacts through the master for ``users`` x 6 positions and write the comparison.

    Writes ``collisions.csv`` (predicted vs simulated, `cosim.haptic.collision.collision_study`),
    ``collisions_means.csv`` (per position) and ``collisions.png`` (user ``users[0]`` at positions 1, 3, 5:
    step and collision responses, as the paper's Figs. 12 and 15).

    Returns
    -------
    list of Path
    """
    from cosim.haptic.collision import collision_study, simulate_contact
    from cosim.haptic.margins import adaptive_damping
    from cosim.haptic.params import load_user_params

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    df = collision_study(users=users, adaptive=adaptive, fmu_dir=fmu_dir, K=K, rate=rate)
    written = []
    tag = "_adaptive" if adaptive else ""
    p = out / f"collisions{tag}.csv"
    df.to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    p = out / f"collisions{tag}_means.csv"
    df.drop(columns=["user", "model"]).groupby("position").mean().reset_index().to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    plt = _plt()
    table = adaptive_damping(user=1, K=K, rate=rate) if adaptive else {}
    fig, ax = plt.subplots(1, 2, figsize=(12, 4))
    u = users[0]
    for i, pos in enumerate((1, 3, 5)):
        params = load_user_params(u, pos, zero_as=5e-4)
        kw = dict(adaptive=adaptive, B=table.get(pos, 0.0), fmu_dir=fmu_dir, K=K, rate=rate)
        d = simulate_contact(params, "step", **kw)
        ax[0].plot(d["time"] - 0.05, 1e3 * (d["phi"] - 0.7), color=f"C{i}", label=f"position {pos}")
        d = simulate_contact(params, "collision", **kw)
        k = np.nonzero(d["phi"] > 0.7)[0][0]
        ax[1].plot(d["time"] - d["time"][k], 1e3 * (d["phi"] - 0.7), color=f"C{i}", label=f"position {pos}")
    ax[0].set_title(f"user {u}: torque step 0.1 N.m at the wall surface")
    ax[1].set_title(f"user {u}: collision at 0.5 rad/s, final wall torque 0.1 N.m")
    ax[1].set_xlim(-0.1, 0.6)
    ax[1].set_ylim(-10.0, 25.0)
    for a in ax:
        a.axhline(0, color="k", ls="--", lw=0.8)
        a.set_xlabel("time from step / contact (s)")
        a.set_ylabel("phi - 0.7 rad (mrad)")
        a.grid(True, alpha=0.3)
        a.legend()
    fig.suptitle(("adaptive wall (B per position)" if adaptive else "wall K = 10 N.m/rad, B = 0") + f", {rate:g} Hz")
    fig.tight_layout()
    p = out / f"collisions{tag}.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    written.append(p)
    return written


def write_identification(out_dir, user=1, position=3, use_fmu=False, fmu_dir="fmus", seed=0):
    """Run seed 000's identification experiment on one Table I row and write the fit and a Bode plot.

    Parameters
    ----------
    out_dir : path-like
    user, position : int
    use_fmu : bool, optional
        Simulate through the Haptic FMU (RK4, ZOH input) instead of the exact sampled LTI model.
    fmu_dir : path-like, optional
    seed : int, optional

    Returns
    -------
    list of Path
        ``identification.csv`` (true, fitted, error, relative SE, informative per parameter) and
        ``identification.png``.
    """
    import pandas as pd

    from cosim.haptic.experiments import device_experiment
    from cosim.haptic.fmu import fmu_parameters, simulate_fmu
    from cosim.haptic.params import load_user_params
    from cosim.haptic.tf import tf_user

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    params = load_user_params(user, position, zero_as=5e-4)
    if use_fmu:
        name, par = fmu_parameters(params)
        path = Path(fmu_dir) / f"{name}.fmu"

        def plant(u):
            return simulate_fmu(path, u, 1000.0, par)
    else:
        plant = tf_user(params)
    experiment = {"band": (0.1, 150.0), "duration": 20.0, "fs": 1000.0}  # seed 000 Sec. II-C
    fr, fit = device_experiment(plant, params.structure, position=position, seed=seed, **experiment)
    rows = [{"parameter": n, "true": params[n], "fitted": fit.parameters_[n], "rel_error": fit.parameters_[n] / params[n] - 1,
             "rel_se": fit.relative_se_[n], "informative": n in fit.informative_} for n in fit.names]
    written = []
    p = out / "identification.csv"
    pd.DataFrame(rows).to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    fig = identification_figure(fr, fit, f"user {user}, position {position}" + (" (FMU)" if use_fmu else ""),
                                **experiment)
    p = out / "identification.png"
    fig.savefig(p, dpi=110, metadata={"Title": fig.axes[0].get_title()})
    _plt().close(fig)
    written.append(p)
    return written


def identification_figure(fr, fit, what, band, duration, fs):
    """The Bode plot of an identification: the Welch estimate and the fitted model over the band the fit used,
    the title naming that band (its first and last Welch frequencies) beside the excitation's.

    Parameters
    ----------
    fr : cosim.freqresp.FrequencyResponse
    fit : cosim.haptic.ident.DeviceUserFit
        Fitted on ``fr``.
    what : str
        Who was identified (the title's start).
    band : (float, float)
        The white-noise torque's band, Hz (:func:`~cosim.haptic.experiments.device_experiment`).
    duration, fs : float
        Experiment length (s) and sample rate (Hz).

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    excitation, band = band, fr.band(*fit.freq_range)
    fig, ax = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    Hm = fit.predict(band.f)
    ax[0].semilogx(band.f, 20 * np.log10(np.abs(band.H)), ".", ms=3, label="Welch estimate (Hann 4096, 50 %)")
    ax[0].semilogx(band.f, 20 * np.log10(np.abs(Hm)), "-", label=f"fitted {fit.structure}-parameter model")
    ax[1].semilogx(band.f, np.degrees(np.unwrap(np.angle(band.H))), ".", ms=3)
    ax[1].semilogx(band.f, np.degrees(np.unwrap(np.angle(Hm))), "-")
    ax[2].semilogx(band.f, band.coherence)
    ax[0].set_ylabel("|phi/tau| (dB re 1 rad/N.m)")
    ax[1].set_ylabel("phase (deg)")
    ax[2].set_ylabel("coherence")
    ax[2].set_xlabel("frequency (Hz)")
    ax[2].set_xlim(band.f[0], band.f[-1])
    ax[0].legend()
    ax[0].set_title(f"{what}: fitted {band.f[0]:.2f}-{band.f[-1]:.1f} Hz\nexcitation: white-noise torque "
                    f"{excitation[0]:g}-{excitation[1]:g} Hz, {duration:g} s at {fs:g} Hz", fontsize=10)
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def write_arm(out_dir, seed=0):
    """Seed 001: simulate the experiment on the 9 Table I arms and the 3 Table II arms, fit them, and write the
    fits, the Bode/uncertainty-weight plot and the robust-stability check of the wall.

    Returns
    -------
    list of Path
        ``arm_fits.csv``, ``arm_models.png``, ``arm_robust.csv``.
    """
    import pandas as pd

    from cosim.haptic.experiments import arm_experiment, arm_robust_stability, plot_arm_models
    from cosim.haptic.ident import ARM_PARAMS
    from cosim.haptic.params import load_arm_params

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for axis in "XYZ":
        for grip in ("1", "2", "3", "nominal"):
            a = load_arm_params(axis, grip)
            _, fit = arm_experiment(a, seed=seed)
            row = {"axis": axis, "grip": grip}
            for n in ARM_PARAMS:
                row[f"{n}_true"] = getattr(a, n)
                row[f"{n}_fit"] = fit.parameters_[n]
                row[f"{n}_rel_error"] = fit.parameters_[n] / getattr(a, n) - 1
            rows.append(row)
    written = []
    p = out / "arm_fits.csv"
    pd.DataFrame(rows).to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    p = out / "arm_models.png"
    plot_arm_models(p)
    written.append(p)
    rob = []
    for axis in "XYZ":
        for level in ("max", "67ci"):
            for B in (0.0, 0.05):
                c = arm_robust_stability(axis, level, B=B)
                rob.append({"axis": axis, "level": level, "K_Nm_per_rad": 10.0, "B_Nms_per_rad": B,
                            "nominal_stable": c.nominal_stable, "peak_WT": c.peak, "f_peak_Hz": c.f_peak_Hz,
                            "robust": c.robust})
    p = out / "arm_robust.csv"
    pd.DataFrame(rob).to_csv(p, index=False, float_format="%.6g")
    written.append(p)
    return written
