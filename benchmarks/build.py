"""Print the build time of each model: rumoca load + lowering, and FMU export (C generation, gcc, zip).

Usage: python benchmarks/build.py [models.toml] [--msl DIR] [--validation]
(default: modelica/models.toml plus the compiler test models; --msl DIR: also MSL examples of four packages,
built from the library folder DIR (the one holding Modelica/) in one process: the first parses the library,
the others reuse the session; --validation: also write the table into docs/validation.md)
"""

import sys
import tempfile
import time
import warnings
from pathlib import Path

from cosim.compile import read_model_list
from cosim.compile.export import export_fmu
from cosim.compile.frontend import load_flat_model
from cosim.compile.lower import lower_system
from cosim.compile.translate import translate
from validation import write_section

ROOT = Path(__file__).resolve().parent.parent
TEST_MODELS = ["MassSpringDamper", "Drive", "PMSM", "AlgebraicChain", "NonlinearLoop", "DependentParameters",
               "InitialAndInteger"]
MSL_MODELS = ["Modelica.Mechanics.Rotational.Examples.First", "Modelica.Mechanics.Translational.Examples.Oscillator",
              "Modelica.Electrical.Analog.Examples.CauerLowPassAnalog", "Modelica.Blocks.Examples.PID_Controller"]


def models(argv, msl=None):
    """(name, source, model, library path) of every model to build."""
    listed = Path(argv[0]) if argv else ROOT / "modelica" / "models.toml"
    entries = [(e["name"], e["source"], e["model"], ()) for e in read_model_list(listed)] if listed.is_file() else []
    test_file = ROOT / "tests" / "models" / "compiler" / "CompilerTests.mo"
    entries += [(name, test_file, f"CompilerTests.{name}", ()) for name in TEST_MODELS]
    return entries + [(m.rsplit(".", 1)[-1], None, m, (Path(msl),)) for m in MSL_MODELS] if msl else entries


def main(argv):
    validation = "--validation" in argv
    argv = [a for a in argv[1:] if a != "--validation"]
    msl = None
    if "--msl" in argv:
        k = argv.index("--msl")
        msl, argv = argv[k + 1], argv[:k] + argv[k + 2:]
    rows = []
    print(f"{'model':<24}{'states':>7}{'load [s]':>10}{'lower [s]':>11}{'export [s]':>12}{'total [s]':>11}")
    with tempfile.TemporaryDirectory() as out, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, source, model, library in models(argv, msl):
            t0 = time.perf_counter()
            flat = load_flat_model(source, model, library)
            t1 = time.perf_counter()
            lowered = lower_system(translate(flat))
            t2 = time.perf_counter()
            export_fmu(lowered, Path(out) / f"{name}.fmu")
            t3 = time.perf_counter()
            print(f"{name:<24}{len(lowered.states):>7}{t1 - t0:>10.3f}{t2 - t1:>11.3f}{t3 - t2:>12.3f}{t3 - t0:>11.3f}")
            rows.append([model, len(lowered.states), *(f"{d:.3f}" for d in (t1 - t0, t2 - t1, t3 - t2, t3 - t0))])
    print("source: wall-clock time on this machine (time.perf_counter), one build each")
    if validation:
        header = ["Modelica model", "states", "load [s]", "lower [s]", "export (C, gcc, zip) [s]", "total [s]"]
        write_section("build", header, rows, notes=[
            "Wall-clock time, one build each. The MSL models (with --msl) are built in one process: the first "
            "one's load includes rumoca's parse of the whole library, the others reuse it."])


if __name__ == "__main__":
    main(sys.argv)
