"""Wall seconds per simulated second of the 1000 rpm impact at the full FOC rate (26.6 kHz): the compiled
engine, the Python engine, a hand-written fmpy loop, and the FMU calls alone from C (the physical limit).

    python benchmarks/engine.py [--fmus DIR] [--stop 1.0] [--fmpy-stop 0.1] [--pairs 9] [--validation]

For ``GripperPlant`` (examples/gripper_impact.toml) and the split ``PMSM`` + ``Drivetrain``
(examples/gripper_impact_split.toml). Needs the gripper FMUs (``cosim build``) and gcc.

* compiled / python: ``cosim.master.run`` with ``run.engine`` set; the loop's wall time (``RunResult.wall_s``),
  numba compile time (or cache load) printed apart.
* fmpy loop: fmpy's FMU3Model, RK4 at the FOC step, the same FOC and outer-loop controllers (numba
  kernels), Python loop (run over ``--fmpy-stop`` s: it is slow).
* C: benchmarks/engine_harness.c (gcc -O2) dlopens the FMUs' shared libraries and makes exactly the
  FMU calls and RK4 arithmetic of the compiled engine's loop, replaying the controller outputs
  recorded at every instant from a compiled run (no controllers).
* compiled / C: the two run alternately, ``--pairs`` times (compiled, C, compiled, C, ...), so that each pair
  sees the same load on a shared machine; the ratio's median over the pairs, its quartiles, min and max, of the
  wall times and of the CPU times (the loop's thread CPU time, the harness's ``CLOCK_THREAD_CPUTIME_ID``: what
  other jobs take of the cores is not in it); the rows "compiled engine" and "C" are the best run of each.
* A config with typed ports: examples/hybrid_ball.toml (the bouncing ball of examples/hybrid, built here,
  records its Integer ``bounces``): which engine runs it (the compiled one, no fallback), its wall time against
  the Python engine's, and whether their results are identical.
* GripperPlant as Co-Simulation (``fmus.plant.kind = "CS"``): the compiled engine makes one ``fmi3DoStep`` per
  FOC period, the FMU's embedded RK4 takes one internal step of the same length (its ``cs_step``); best of 5
  runs, and the largest deviation of any recorded signal from the Model Exchange run, in % of its range.
"""

import argparse
import datetime
import os
import platform
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FOC_RATE = 26600


def _machine():
    cpu = platform.processor() or "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{cpu}, {os.cpu_count()} cores, load average {load:.1f}"


def _configs(fmus, stop):
    from cosim.config import load_config

    base = [f"run.stop={stop}", "plot.panels=[]"]
    return {
        "GripperPlant": lambda extra=(): load_config(ROOT / "examples" / "gripper_impact.toml",
                                                     [f"fmus.plant.path={fmus / 'GripperPlant.fmu'}", *base, *extra]),
        "PMSM + Drivetrain": lambda extra=(): load_config(
            ROOT / "examples" / "gripper_impact_split.toml",
            [f"fmus.plant.path={fmus / 'PMSM.fmu'}", f"fmus.drive.path={fmus / 'Drivetrain.fmu'}", *base, *extra]),
    }


# -- the hand-written fmpy loop ----------------------------------------------------------------------
def fmpy_loop(cfg, stop):
    """RK4 at the FOC step over cfg's ME FMUs through fmpy's FMU3Model; returns wall s per simulated s."""
    import ctypes

    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Model

    fmus, tmp = {}, []
    for name, spec in cfg.fmus.items():
        md = read_model_description(str(spec.path))
        d = extract(str(spec.path))
        tmp.append(d)
        f = FMU3Model(guid=md.instantiationToken, unzipDirectory=d, modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName=name)
        f.instantiate()
        vrs = {v.name: v.valueReference for v in md.modelVariables}
        for k, v in spec.parameters.items():
            f.setFloat64([vrs[k]], [float(v)])
        f.enterInitializationMode(startTime=0.0)
        f.exitInitializationMode()
        f.updateDiscreteStates()
        f.enterContinuousTimeMode()
        n = md.numberOfContinuousStates
        x = np.zeros(n)
        dx = np.zeros(n)
        px, pdx = x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        f.getContinuousStates(px, n)
        fmus[name] = (f, vrs, n, x, dx, px, pdx)
    ctrls = {n: s.cls(rate=s.rate, **s.parameters) for n, s in cfg.controllers.items()}
    outer, foc = ctrls["outer"], ctrls["foc"]
    split = "drive" in fmus
    p, vp = fmus["plant"][0], fmus["plant"][1]
    sample_vr = [vp[v] for v in ("theta_m", "w_m", "i_d", "i_q")]
    in_vr = [vp["v_d"], vp["v_q"]]
    if split:
        d, vd = fmus["drive"][0], fmus["drive"][1]
        pm_out = [vp["theta_m"], vp["w_m"]]
        dr_in = [vd["theta_m"], vd["w_m"]]
        dr_out = [vd["tau_load"]]
        pl_in = [vp["tau_load"]]
    order = list(fmus.values())

    def deriv(t):
        for f, _, n, x, dx, px, pdx in order:
            f.setTime(t)
            f.setContinuousStates(px, n)
        if split:
            d.setFloat64(dr_in, p.getFloat64(pm_out))
            p.setFloat64(pl_in, d.getFloat64(dr_out))
        for f, _, n, x, dx, px, pdx in order:
            f.getContinuousStateDerivatives(pdx, n)

    n_ticks = int(round(stop * FOC_RATE))
    h = 1.0 / FOC_RATE
    per_outer = FOC_RATE // int(cfg.controllers["outer"].rate)
    t0 = time.perf_counter()
    for k in range(n_ticks):
        t = k / FOC_RATE
        for f, _, n, x, dx, px, pdx in order:  # sample the outputs at t_k
            f.setTime(t)
            f.setContinuousStates(px, n)
        th, w, i_d, i_q = p.getFloat64(sample_vr)
        if k % per_outer == 0:
            outer.u[0] = th
            outer.step(t)
        foc.u[:] = (outer.y[0], i_d, i_q, th, w)
        foc.step(t)
        p.setFloat64(in_vr, [foc.y[0], foc.y[1]])  # held until the next tick
        x0 = [e[3].copy() for e in order]
        ks = []
        for dt, c in ((0.0, 0.5), (0.5 * h, 0.5), (0.5 * h, 1.0), (h, None)):
            deriv(t + dt)
            ks.append([e[4].copy() for e in order])
            if c is not None:
                for e, a, kk in zip(order, x0, ks[-1]):
                    e[3][:] = a + c * h * kk
        for i, e in enumerate(order):
            e[3][:] = x0[i] + h / 6.0 * (ks[0][i] + 2 * ks[1][i] + 2 * ks[2][i] + ks[3][i])
    wall = time.perf_counter() - t0
    for f, *_ in order:
        f.terminate()
        f.freeInstance()
        f.freeLibrary()
    for d_ in tmp:
        shutil.rmtree(d_, ignore_errors=True)
    return wall / stop


# -- the plant as a Co-Simulation FMU ----------------------------------------------------------------
def cs_figures(make, me):
    """Compiled engine over the Co-Simulation interface of the plant: (wall s per simulated s, best of 5; largest
    deviation of a recorded signal from the ME run ``me`` in % of its range)."""
    from cosim.master import run

    cs = min((run(make(["run.engine=compiled", 'fmus.plant.kind="CS"']), progress=False) for _ in range(5)),
             key=lambda r: r.wall_s)
    names = [n for n in me.data.dtype.names if n != "time" and np.ptp(me.data[n]) > 0]
    deviation = max(np.max(np.abs(cs.data[n] - me.data[n])) / np.ptp(me.data[n]) for n in names)
    return cs.wall_s / cs.sim_s, 100 * deviation


# -- typed ports ------------------------------------------------------------------------------------
def typed_figures(workdir):
    """examples/hybrid_ball.toml (an Integer output recorded) with both engines: (engine that ran by default,
    compiled wall s per simulated s (best of 5), Python's, results identical)."""
    from cosim.compile import build_fmu
    from cosim.config import load_config
    from cosim.master import run

    fmu = build_fmu(ROOT / "examples" / "hybrid" / "BouncingBall.mo", "BouncingBall", out_dir=workdir)

    def make(engine):
        return load_config(ROOT / "examples" / "hybrid_ball.toml", [f"fmus.ball.path={fmu}", "plot.panels=[]",
                                                                      *([f"run.engine={engine}"] if engine else [])])

    default = run(make(None), progress=False)
    comp = min((run(make("compiled"), progress=False) for _ in range(5)), key=lambda r: r.wall_s)
    py = run(make("python"), progress=False)
    same = comp.data.dtype == py.data.dtype and all(np.array_equal(comp.data[n], py.data[n])
                                                     for n in py.data.dtype.names)
    return default.engine, comp.wall_s / comp.sim_s, py.wall_s / py.sim_s, same


# -- the C harness -----------------------------------------------------------------------------------
def c_harness(cfg, workdir):
    """The C harness set up for ``cfg`` (see the module docstring): a function that runs it once and returns its
    wall s per simulated s, and the number of instants it makes."""
    from fmpy import extract, read_model_description

    from cosim.master import run
    from cosim.master import CompiledLoop, Engine
    from cosim.master.ckernel import FMU_COLS
    from cosim.master.plant import PlantSystem

    eng = Engine(cfg, CompiledLoop)
    lay = eng.layout
    src = lay.route_ctrl_to_fmu[0]
    inverse = {v: k for k, v in lay.index.items()}
    names = [f"{inverse[int(s)][0]}.{inverse[int(s)][1]}" for s in src]
    from cosim.config import load_config

    rec_cfg = load_config(cfg.path, list(cfg.overrides) + ["summary.kind=\"none\"", f"record.rate={FOC_RATE}",
                                                           "record.signals=[" + ", ".join(f'"{n}"' for n in names) + "]"])
    res = run(rec_cfg, progress=False)
    inputs = np.column_stack([res.data[n] for n in names]) if names else np.zeros((len(res.data), 0))
    plant = PlantSystem(cfg, lay, eng.buf)
    try:
        tab = eng.loop._tables(plant)
        x0 = plant.X.copy()
    finally:
        plant.close()
    lines = [str(len(tab["fmu_names"]))]
    for i, name in enumerate(tab["fmu_names"]):
        spec = cfg.fmus[name]
        md = read_model_description(str(spec.path))
        d = extract(str(spec.path), unzipdir=str(workdir / name))
        so = Path(d) / "binaries" / "x86_64-linux" / f"{md.modelExchange.modelIdentifier}.so"
        lines.append(f"{so} {md.instantiationToken}")
        vals = {**spec.start, **spec.parameters}
        x_off, n_x = (tab["fmu"][i, FMU_COLS.index(c)] for c in ("x_off", "n_states"))
        lines.append(f"{x_off} {n_x} {len(vals)} " +
                     " ".join(f"{spec.info.variables[k].vr} {float(v)!r}" for k, v in vals.items()))
    lines.append(str(plant.W.shape[1]))
    lines.append(str(len(eng.buf)))
    lines.append(str(len(tab["port_items"])))
    for (inst, port), row in zip(tab["port_items"], tab["port"]):
        vrs = [inst.info.variables[n].vr for n in port.names]
        lines.append(f"{row[0]} {row[2]} {row[3]} " + " ".join(map(str, vrs)))
    pgrp = tab["pgrp"][:, :2]  # the float64 ports' ranges (the gripper has no typed port)
    lines.append(str(len(pgrp)) + " " + " ".join(map(str, pgrp.ravel().tolist())))
    lines.append(str(len(tab["rsrc"])))
    for j in range(len(tab["rsrc"])):
        lines.append(f"{tab['rsrc'][j]} {tab['rdst'][j]} {float(tab['rgain'][j])!r} {float(tab['roff'][j])!r}")
    lines.append(str(len(tab["rgrp"])) + " " + " ".join(map(str, tab["rgrp"].ravel().tolist())))
    lines.append(str(len(tab["lvl"])) + " " + " ".join(map(str, tab["lvl"].ravel().tolist())))
    lines.append(str(len(tab["me"])) + " " + " ".join(map(str, tab["me"].tolist())))
    ii = tab["ii"]
    lines.append(f"{ii[0]} {ii[2]} {ii[3]} {ii[4]} " + " ".join(map(str, ii[5:].tolist())))
    lines.append(f"{float(tab['ff'][0])!r} {float(tab['ff'][1])!r}")
    lines.append(" ".join(repr(float(v)) for v in x0))
    lines.append(f"{len(src)} " + " ".join(map(str, src.tolist())))
    lines.append(str(len(inputs)))
    lines.extend(" ".join(repr(float(v)) for v in row) for row in inputs)
    plan = workdir / f"plan_{len(tab['fmu_names'])}.txt"
    plan.write_text("\n".join(lines) + "\n")
    exe = workdir / "harness"
    if not exe.exists():
        import fmpy

        include = Path(fmpy.__file__).parent / "c-code"
        subprocess.run(["gcc", "-O2", f"-I{include}", str(ROOT / "benchmarks" / "engine_harness.c"), "-o", str(exe),
                        "-ldl", "-lm"], check=True)

    def once():
        out = subprocess.run([str(exe), str(plan)], capture_output=True, text=True, check=True).stdout.split()
        return float(out[0]) / res.sim_s, int(out[1]), float(out[3]) / res.sim_s

    return once


def c_limit(cfg, workdir):
    """FMU calls of the compiled engine's loop from C, best of 5 runs (the machine is shared); wall s per simulated
    s and the number of instants."""
    once = c_harness(cfg, workdir)
    return min(once()[:2] for _ in range(5))


def interleaved(make, once, pairs):
    """``pairs`` alternating runs of the compiled engine and of the C harness (``once``), so that both see the same
    load: the best compiled run, the C harness's best (wall s per simulated s), and each pair's ratio of wall times
    and of CPU times (the loop's thread CPU time: what the machine's other jobs take is not in it)."""
    from cosim.master import CompiledLoop, Engine

    class CpuTimed(CompiledLoop):
        """The compiled loop, adding up the thread CPU time of its chunks."""

        cpu = 0.0

        def run(self, n):
            t0 = time.thread_time()
            try:
                return super().run(n)
            finally:
                self.cpu += time.thread_time() - t0

    runs, c, wall, cpu = [], [], [], []
    for _ in range(pairs):
        engine = Engine(make(["run.engine=compiled"]), CpuTimed)
        runs.append(engine.run(progress=False))
        c_wall, _, c_cpu = once()
        c.append(c_wall)
        wall.append(runs[-1].wall_s / runs[-1].sim_s / c_wall)
        cpu.append(engine.loop.cpu / runs[-1].sim_s / c_cpu)
    return min(runs, key=lambda r: r.wall_s), min(c), wall, cpu


def spread(ratios):
    """Median, quartiles, min and max of the pairs' ratios, as one line."""
    q1, med, q3 = np.percentile(ratios, [25, 50, 75])
    return (f"median {med:.2f} (IQR {q1:.2f}-{q3:.2f}, min {min(ratios):.2f}, max {max(ratios):.2f}, "
            f"{len(ratios)} pairs)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmus", default=str(ROOT / "fmus"), help="folder with GripperPlant.fmu, PMSM.fmu, Drivetrain.fmu")
    ap.add_argument("--stop", type=float, default=1.0, help="simulated seconds for the engines and C (default 1.0)")
    ap.add_argument("--fmpy-stop", type=float, default=0.1, help="simulated seconds for the fmpy loop (default 0.1)")
    ap.add_argument("--pairs", type=int, default=9, help="alternating compiled-engine / C-harness runs (default 9)")
    ap.add_argument("--validation", action="store_true", help="also write the table into docs/validation.md")
    args = ap.parse_args(argv)
    from cosim.master import run
    from validation import write_section

    print(f"# {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {_machine()}")
    print("# wall s per simulated s (lower is better); x = times faster than real time")
    cfgs = _configs(Path(args.fmus), args.stop)
    columns = {}
    with tempfile.TemporaryDirectory(prefix="cosim-bench-") as tmp:
        for label, make in cfgs.items():
            t0 = time.perf_counter()
            first = run(make(["run.engine=compiled"]), progress=False)
            first_total = time.perf_counter() - t0
            once = c_harness(make(["run.engine=compiled"]), Path(tmp))
            n_inst = once()[1]  # warm-up: the FMUs' libraries in the page cache
            comp, c, ratios, cpu_ratios = interleaved(make, once, args.pairs)
            py = run(make(["run.engine=python"]), progress=False)
            fm = fmpy_loop(make(), args.fmpy_stop)
            wc, wp = comp.wall_s / comp.sim_s, py.wall_s / py.sim_s
            same = all(np.array_equal(comp.data[n], py.data[n]) for n in comp.data.dtype.names)
            print(f"{label}:")
            print(f"  compiled engine : {wc:.4f}  ({1 / wc:5.1f} x real time)  numba compile/cache load "
                  f"{first.compile_s:.2f} s in this process's first run (first run total {first_total:.2f} s)")
            print(f"  python engine   : {wp:.4f}  ({1 / wp:5.1f} x)  results identical to compiled: {same}")
            print(f"  fmpy loop       : {fm:.4f}  ({1 / fm:5.1f} x)  ({args.fmpy_stop} s simulated)")
            print(f"  FMU calls from C: {c:.4f}  ({1 / c:5.1f} x)  {n_inst} instants")
            print(f"  compiled engine / C, alternating pairs, wall: {spread(ratios)}; load now {_machine().split()[-1]}")
            print(f"  compiled engine / C, the same pairs, CPU: {spread(cpu_ratios)}")
            cs = "n/a (ME only)"
            if label == "GripperPlant":
                wcs, deviation = cs_figures(make, comp)
                cs = f"{wcs:.4f} ({1 / wcs:.1f}x), {deviation:.2g} %"
                print(f"  compiled, CS FMU: {wcs:.4f}  ({1 / wcs:5.1f} x)  one fmi3DoStep per FOC period; largest "
                      f"deviation from the ME run {deviation:.2g} % of a signal's range")
            columns[label] = [f"{wc:.4f} ({1 / wc:.1f}x)", f"{wp:.4f} ({1 / wp:.1f}x)", f"{fm:.4f} ({1 / fm:.1f}x)",
                              f"{c:.4f} ({1 / c:.1f}x)", spread(ratios), spread(cpu_ratios), str(same), f"{first.compile_s:.2f}", cs]
        engine, wt, wpt, same_t = typed_figures(Path(tmp))
        typed = (f"examples/hybrid_ball.toml (an Integer output recorded, 3 s with 12 events): the {engine} engine "
                 f"by default; compiled {wt:.2e}, Python {wpt:.2e} wall s per simulated s ({wpt / wt:.0f} x); "
                 f"results identical: {same_t}")
        print(typed)
    if args.validation:
        what = ["compiled engine", "Python engine", f"hand-written fmpy loop ({args.fmpy_stop} s simulated)",
                "the FMU calls alone from C (benchmarks/engine_harness.c)",
                "compiled engine / C, wall (ratio of each alternating pair)",
                "compiled engine / C, CPU time of the loop (the same pairs)",
                "Python and compiled results identical", "numba compile or cache load in the first run [s]",
                "compiled engine, the plant as Co-Simulation FMU (deviation from ME, % of range)"]
        write_section("engine", ["wall s per simulated s (x real time)", *columns],
                      [[w, *(col[k] for col in columns.values())] for k, w in enumerate(what)],
                      notes=[f"1000 rpm impact, {args.stop} s simulated, FOC 26.6 kHz + outer loop 100 Hz, RK4 one "
                             f"step per FOC period; compiled engine and C harness run alternately, {args.pairs} pairs "
                             "(their rows: the best run of each). Machine: "
                             f"{_machine()}.", typed])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
