"""What exposing every variable costs: a model with one state and N algebraic locals that nothing else reads
(``a[i] = sin(i x) + i x``) against the same state without them (``Bare``), both FMI 3.0 FMUs of cosim build.

    python benchmarks/locals.py [--n 1000] [--repeats 7] [--fmus DIR]

Prints the best of ``--repeats`` runs, the two FMUs interleaved:

* build: lowering, export and gcc of each model (s);
* ME call: one ``setTime`` + ``setContinuousStates`` + ``getContinuousStateDerivatives`` + ``getFloat64(y)``,
  what a master does per derivative evaluation (us, through fmpy's ctypes FMU3Model);
* CS: ``fmi3DoStep`` over 1 s with ``_cs_step`` = 1e-5 s (100,000 internal RK4 steps: 400,000 ``ode`` calls) (ms);
* reading every local once after the state changed: ``fmi3GetFloat64`` of the N value references, which
  evaluates ``observe`` once (us).

The locals are computed only when one is read (the lazy cache of model_core.c), so stepping ``Locals`` costs
what stepping ``Bare`` costs. ``--fmus DIR`` times ``DIR/Locals.fmu`` and ``DIR/Bare.fmu`` instead of building
them (FMUs of another compiler version, for a before/after comparison).
"""

import argparse
import ctypes
import tempfile
import time
from pathlib import Path

import numpy as np

SOURCE = """package Many
  model Locals "one state, N algebraic locals that nothing else reads"
    parameter Integer N = {n};
    parameter Real k = 2 "decay rate";
    Real x(start = 1, fixed = true) "state";
    Real a[N](each unit = "m") "locals";
    output Real y;
  equation
    der(x) = -k * x;
    for i in 1:N loop
      a[i] = sin(i * x) + i * x;
    end for;
    y = x;
  end Locals;
  model Bare "the same state without the locals"
    parameter Real k = 2 "decay rate";
    Real x(start = 1, fixed = true) "state";
    output Real y;
  equation
    der(x) = -k * x;
    y = x;
  end Bare;
end Many;
"""


def _build(folder, n):
    """Build Locals and Bare into ``folder``; the seconds each took."""
    from cosim.compile import build_fmu

    source = Path(folder) / "Many.mo"
    source.write_text(SOURCE.format(n=n))
    seconds = {}
    for name in ("Locals", "Bare"):
        start = time.perf_counter()
        build_fmu(source, f"Many.{name}", out_dir=folder)
        seconds[name] = time.perf_counter() - start
    return seconds


class _Fmu:
    """One FMU through fmpy's FMU3Model, Model Exchange and Co-Simulation instances."""

    def __init__(self, path):
        from fmpy import extract, read_model_description

        self.path = str(path)
        self.md = read_model_description(self.path)
        self.unzipped = extract(self.path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.locals = [v.valueReference for v in self.md.modelVariables if v.name.startswith("a[")]

    def me_call(self, calls=20000):
        """Seconds per derivative evaluation (set time, set states, get derivatives, get the output)."""
        from fmpy.fmi3 import FMU3Model

        f = FMU3Model(guid=self.md.instantiationToken, unzipDirectory=self.unzipped,
                      modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName="me")
        f.instantiate()
        f.enterInitializationMode(startTime=0.0)
        f.exitInitializationMode()
        f.updateDiscreteStates()
        f.enterContinuousTimeMode()
        x, dx = np.ones(1), np.zeros(1)
        px = x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        pdx = dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        y = [self.vr["y"]]
        start = time.perf_counter()
        for k in range(calls):
            x[0] = 1.0 - 1e-6 * k
            f.setTime(1e-6 * k)
            f.setContinuousStates(px, 1)
            f.getContinuousStateDerivatives(pdx, 1)
            f.getFloat64(y)
        per_call = (time.perf_counter() - start) / calls
        read = self._read_locals(f, x, px)
        f.terminate()
        f.freeInstance()
        return per_call, read

    def _read_locals(self, f, x, px, reads=200):
        """Seconds to read every local once after a state change (None when the FMU has none)."""
        if not self.locals:
            return None
        start = time.perf_counter()
        for k in range(reads):
            x[0] = 0.5 + 1e-3 * k
            f.setContinuousStates(px, 1)
            f.getFloat64(self.locals)
        return (time.perf_counter() - start) / reads

    def cs_second(self):
        """Seconds of one fmi3DoStep over 1 s at _cs_step 1e-5 s."""
        from fmpy.fmi3 import FMU3Slave

        f = FMU3Slave(guid=self.md.instantiationToken, unzipDirectory=self.unzipped,
                      modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="cs")
        f.instantiate()
        f.enterInitializationMode(startTime=0.0)
        f.setFloat64([self.vr["_cs_step"]], [1e-5])
        f.exitInitializationMode()
        start = time.perf_counter()
        f.doStep(0.0, 1.0)
        seconds = time.perf_counter() - start
        f.terminate()
        f.freeInstance()
        return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1000, help="number of locals (default 1000)")
    parser.add_argument("--repeats", type=int, default=7, help="runs of each measurement; the best is printed")
    parser.add_argument("--fmus", type=Path, help="time DIR/Locals.fmu and DIR/Bare.fmu instead of building")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="cosim-locals-") as folder:
        build = None
        if args.fmus is None:
            build = _build(folder, args.n)
        where = args.fmus or Path(folder)
        fmus = {name: _Fmu(where / f"{name}.fmu") for name in ("Locals", "Bare")}
        best = {name: [np.inf, np.inf, np.inf] for name in fmus}
        for _ in range(args.repeats):
            for name, fmu in fmus.items():
                call, read = fmu.me_call()
                for j, value in enumerate((call, fmu.cs_second(), read if read is not None else np.nan)):
                    best[name][j] = min(best[name][j], value)
        print(f"# {len(fmus['Locals'].locals)} locals exposed; best of {args.repeats}")
        for name, (call, cs, read) in best.items():
            line = f"{name:7s}: ME call {call * 1e6:6.2f} us   CS 1 s at 1e-5 s {cs * 1e3:7.2f} ms"
            if np.isfinite(read):
                line += f"   read all locals {read * 1e6:7.1f} us"
            if build:
                line += f"   build {build[name]:.2f} s"
            print(line)
        print(f"Locals / Bare: ME call {best['Locals'][0] / best['Bare'][0]:.3f}, "
              f"CS {best['Locals'][1] / best['Bare'][1]:.3f}")


if __name__ == "__main__":
    main()
