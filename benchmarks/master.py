"""Wall time per simulated second of the 1000 rpm impact at the full FOC rate (26.6 kHz), Python engine,
next to ``fmpy.simulate_fmu`` (CVode) of the same plant FMU driven by the recorded d/q voltages.

    python benchmarks/master.py [--fmus DIR] [--stop 0.6] [--validation]

Needs the gripper FMUs (``cosim build``). Prints one line per figure; ``--validation`` also writes them into
docs/validation.md.
"""

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmus", default=str(ROOT / "fmus"), help="folder with GripperPlant.fmu, PMSM.fmu, Drivetrain.fmu")
    ap.add_argument("--stop", type=float, default=0.6, help="simulated seconds (default 0.6, the paper's plot window)")
    ap.add_argument("--validation", action="store_true", help="also write the figures into docs/validation.md")
    args = ap.parse_args(argv)
    import fmpy

    from cosim.config import load_config
    from cosim.fmi import FmuInstance
    from cosim.master import run
    from validation import write_section

    fmus = Path(args.fmus)
    plant = fmus / "GripperPlant.fmu"
    sets = [f"fmus.plant.path={plant}", f"run.stop={args.stop}", "run.engine=python", "record.rate=26600",
            'record.signals=["plant.F_g", "plant.i_q", "foc.v_d", "foc.v_q"]', "plot.panels=[]"]
    cfg = load_config(ROOT / "examples" / "gripper_impact.toml", sets)
    run(load_config(ROOT / "examples" / "gripper_impact.toml", sets[:1] + ["run.stop=0.01", "run.engine=python"]),
        progress=False)  # warm-up
    res = run(cfg, progress=False)
    n_foc = res.calls["foc"]
    rows = [["cosim master, Python engine, GripperPlant (RK4 1 substep, FOC 26.6 kHz + outer 100 Hz)",
             f"{res.wall_s / res.sim_s:.3f} ({res.wall_s / n_foc * 1e6:.1f} us per FOC tick)"]]
    print(f"cosim master (python engine, RK4 1 substep, FOC 26.6 kHz + outer 100 Hz), GripperPlant: "
          f"{res.wall_s / res.sim_s:.3f} s wall per simulated s ({res.wall_s / n_foc * 1e6:.1f} us per FOC tick)")

    split = load_config(ROOT / "examples" / "gripper_impact_split.toml",
                        [f"fmus.plant.path={fmus / 'PMSM.fmu'}", f"fmus.drive.path={fmus / 'Drivetrain.fmu'}",
                         f"run.stop={args.stop}", "run.engine=python", "plot.panels=[]"])
    rs = run(split, progress=False)
    print(f"cosim master, split PMSM + Drivetrain:                                       "
          f"{rs.wall_s / rs.sim_s:.3f} s wall per simulated s")
    rows.append(["cosim master, Python engine, split PMSM + Drivetrain", f"{rs.wall_s / rs.sim_s:.3f}"])

    # fmpy.simulate_fmu of the same FMU driven by the recorded voltages (held between FOC instants)
    d = res.data
    sig = np.zeros(len(d), dtype=[("time", "f8"), ("v_d", "f8"), ("v_q", "f8")])
    sig["time"], sig["v_d"], sig["v_q"] = d["time"], d["foc.v_d"], d["foc.v_q"]
    params = {k: v for k, v in cfg.fmus["plant"].parameters.items()}
    for label, interval in (("output interval 1/26600 s", 1 / 26600), ("output interval 1 ms", 1e-3)):
        t0 = time.perf_counter()
        ref = fmpy.simulate_fmu(str(plant), validate=False, stop_time=args.stop, input=sig, start_values=params,
                                output_interval=interval, relative_tolerance=1e-6, output=["F_g", "i_q"])
        wall = time.perf_counter() - t0
        f_ref = np.interp(d["time"], ref["time"], ref["F_g"])
        dev = np.max(np.abs(f_ref - d["F_g"])) / np.ptp(d["F_g"])
        print(f"fmpy.simulate_fmu (CVode, rtol 1e-6, {label}), recorded v_d/v_q:  {wall / args.stop:.3f} s wall per "
              f"simulated s (F_g max deviation from the master: {dev:.1e} of range)")
        rows.append([f"fmpy.simulate_fmu (CVode, rtol 1e-6, {label}), recorded v_d/v_q",
                     f"{wall / args.stop:.3f} (F_g within {dev:.1e} of range of the master)"])

    # the FMU call group the RK4 stage costs from Python through cosim.fmi
    with FmuInstance(plant, "bench") as inst:
        inst.setup(0.0)
        n = 100_000
        t0 = time.perf_counter()
        for _ in range(n):
            inst.set_time(0.1)
            inst.push_states()
            inst.pull_derivatives()
        per = (time.perf_counter() - t0) / n
    print(f"one call group (setTime + setContinuousStates + getDerivatives) through cosim.fmi: {per * 1e6:.2f} us; "
          f"RK4 needs 4 per FOC tick = {4 * per * 26600:.3f} s per simulated s")
    rows.append(["one call group (setTime + setContinuousStates + getDerivatives) through cosim.fmi, x 4 per FOC tick",
                 f"{4 * per * 26600:.3f} ({per * 1e6:.2f} us a group)"])
    if args.validation:
        write_section("master", ["what", "wall s per simulated s"], rows,
                      notes=[f"1000 rpm impact, {args.stop} s simulated at the full FOC rate."])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
