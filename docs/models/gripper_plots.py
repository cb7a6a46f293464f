"""Render the gripper model's characteristic curves into docs/models/ (PNG).

- ``gripper_force_deflection.png``: gripping force against jaw penetration for the four contact conditions
  (bare, P1, P2, P3 on the ABS cylinder and on aluminium), and against the coating's own deflection.
- ``gripper_torque_map.png``: gear output torque against motor torque (driving / holding / back-driving,
  eta_g = 0.68 and 0.75) with a quasi-static current staircase of the whole plant on top, and the torque of
  the 0.8 deg play against the gear-output angle.

Run from the repository root: ``python3 docs/models/gripper_plots.py`` (builds the FMUs into a temporary
directory; about 20 s).
"""

import csv
import sys
import tempfile
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
OUT = Path(__file__).resolve().parent
MO = ROOT / "modelica" / "Gripper" / "package.mo"
CONDITIONS = ROOT / "cosim" / "data" / "gripper_conditions.csv"


def load_conditions():
    out = {}
    with open(CONDITIONS, newline="") as f:
        for row in csv.DictReader(r for r in f if not r.startswith("#")):
            out.setdefault(row["condition"], {})[row["parameter"]] = float(row["value"])
    return out


def drivetrain_force(lowered, params, pens):
    """Static gripping force of the lowered Drivetrain at jaw penetrations ``pens`` (jaw at rest)."""
    names = [v.name for v in lowered.parameters]
    p = np.array([v.start for v in lowered.parameters], float)
    for k, v in params.items():
        p[names.index(k)] = v
    states = [v.name for v in lowered.states]
    x = np.array(lowered.x0(p)).ravel()
    outs = [v.name for v in lowered.outputs]
    touch = params["gap0"] - params["t_coat"]
    forces = []
    for pen in pens:
        x[states.index("drive.jaw.x")] = touch + pen
        y = np.array(lowered.out(x, [0.0, 0.0], p, 0.0)).ravel()
        forces.append(y[outs.index("F_g")])
    return np.array(forces)


def plot_force_deflection(conds):
    from cosim.compile import lower

    dt = lower(MO, "Gripper.Drivetrain")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    colors = {"bare": "k", "P1": "tab:blue", "P2": "tab:orange", "P3": "tab:green"}
    for coat, col in colors.items():
        for obj, ls in (("dynamic_abs", "-"), ("static_al", "--")):
            c = conds[f"{coat}_{obj}"]
            pens = np.linspace(-0.1e-3, 2.5e-3, 1200)
            F = drivetrain_force(dt, c, pens)
            label = f"{coat}, {'ABS' if obj == 'dynamic_abs' else 'aluminium'}"
            axes[0].plot(pens * 1e3, F, ls, color=col, label=label)
            pens_z = np.linspace(-5e-6, 150e-6, 600)
            axes[1].plot(pens_z * 1e6, drivetrain_force(dt, c, pens_z), ls, color=col, label=label)
            if coat != "bare" and obj == "dynamic_abs":
                c_rest = 1 / 1.46e6 + 1 / c["k_obj"]
                defl = np.maximum(pens - F * c_rest, 0)
                axes[2].plot(defl * 1e3, F, color=col, label=f"{coat}: k_P = {c['k_P']:.3g} N/m, k_H = 100 k_P")
    axes[0].set(xlabel="jaw penetration past first touch [mm]", ylabel="gripping force F_g [N]", ylim=(-5, 250),
                title="Force vs penetration (finger + coating + object)")
    axes[1].set(xlabel="jaw penetration past first touch [µm]", ylabel="gripping force F_g [N]", ylim=(-5, 250),
                title="Zoom: bare and P1 (stiff paths)")
    axes[2].set(xlabel="coating deflection [mm]", ylabel="gripping force F_g [N]", ylim=(-5, 250),
                title="Coating alone (region boundary 1.5 mm)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "gripper_force_deflection.png", dpi=120)
    plt.close(fig)


def staircase(fmu, conds, eta, step=1.0):
    from fmpy import simulate_fmu

    R = 0.45
    levels = list(np.round(np.arange(0, 2.51, 0.1), 2)) + list(np.round(np.arange(2.4, -0.01, -0.1), 2))
    t, u = [], []
    for k, i in enumerate(levels):
        t += [k * step, (k + 1) * step]
        u += [R * i, R * i]
    sig = np.zeros(len(t), dtype=[("time", float), ("v_d", float), ("v_q", float)])
    sig["time"], sig["v_q"] = t, u
    res = simulate_fmu(str(fmu), start_values=dict(conds["bare_static_al"], eta_g=eta), input=sig,
                       stop_time=len(levels) * step, output_interval=1e-3, solver="CVode")
    F_end = [np.interp((k + 1) * step - 0.01, res["time"], res["F_g"]) for k in range(len(levels))]
    return np.array(levels), np.array(F_end)


def plot_torque_map(conds):
    from cosim.compile import build_fmu, lower

    k_t, T_c0, r_p, n = 0.13 / 3.3, 0.2 * 0.13 / 3.3, 0.008957, 28.0
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fmu = build_fmu(MO, "Gripper.GripperPlant", out_dir=tmp)
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
        T_m = np.linspace(0, 0.11, 200)
        for eta, col in ((0.68, "tab:blue"), (0.75, "tab:red")):
            drive = eta * n * np.maximum(T_m - T_c0, 0)
            back = n * (T_m + T_c0) / eta
            axes[0].plot(T_m * 1e3, drive, color=col, label=f"driving: eta_g*28*(T_m - T_c0), eta_g = {eta}")
            axes[0].plot(T_m * 1e3, back, "--", color=col, label=f"back-driven: 28*(T_m + T_c0)/eta_g, eta_g = {eta}")
            axes[0].fill_between(T_m * 1e3, drive, back, color=col, alpha=0.08)
            levels, F = staircase(fmu, conds, eta)
            axes[0].plot(levels * k_t * 1e3, 2 * r_p * F, "o", ms=3, color=col,
                         label=f"GripperPlant, 0.1 A staircase up and down (eta_g = {eta})")
        axes[0].set(xlabel="motor torque k_t*i_q [mN·m]", ylabel="gear output torque 2*r_p*F_g [N·m]",
                    title="Gear torque map: output locked (aluminium), shaded = holds", ylim=(0, 4))
        axes[0].legend(fontsize=7, loc="upper left")

        dt = lower(MO, "Gripper.Drivetrain")
        names = [v.name for v in dt.parameters]
        p = np.array([v.start for v in dt.parameters], float)
        p[names.index("gap0")] = 0.02
        p[names.index("T_c0")] = 0.0
        states = [v.name for v in dt.states]
        x = np.array(dt.x0(p)).ravel()
        outs = [v.name for v in dt.outputs]
        phis = np.deg2rad(np.linspace(-0.6, 0.6, 601))
        tau = []
        for ph in phis:
            x[states.index("shaft.theta")] = ph * n
            tau.append(np.array(dt.out(x, [ph * n, 0.0], p, 0.0)).ravel()[outs.index("tau_load")] * n)
        axes[1].plot(np.rad2deg(phis), tau, "k")
        axes[1].axvspan(-0.4, 0.4, color="0.9", label="play 0.8 deg (paper)")
        axes[1].set(xlabel="gear output angle minus pinion angle [deg]", ylabel="play torque at the gear output [N·m]",
                    title="Shaft play: elastic hard stop (c_play = 1000 N·m/rad)")
        axes[1].legend(fontsize=8)
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(OUT / "gripper_torque_map.png", dpi=120)
        plt.close(fig)


def main():
    sys.path.insert(0, str(ROOT))
    conds = load_conditions()
    plot_force_deflection(conds)
    plot_torque_map(conds)
    print(f"wrote {OUT / 'gripper_force_deflection.png'} and {OUT / 'gripper_torque_map.png'}")


if __name__ == "__main__":
    main()
