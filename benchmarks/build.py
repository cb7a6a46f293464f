"""Print the build time of each model: rumoca load + lowering, and FMU export (C generation, gcc, zip).

Usage: python benchmarks/build.py [models.toml] [--validation]
(default: modelica/models.toml plus the compiler test models; --validation: also write the table into
docs/validation.md)
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


def models(argv):
    listed = Path(argv[0]) if argv else ROOT / "modelica" / "models.toml"
    entries = [(e["name"], e["source"], e["model"]) for e in read_model_list(listed)] if listed.is_file() else []
    test_file = ROOT / "tests" / "models" / "compiler" / "CompilerTests.mo"
    return entries + [(name, test_file, f"CompilerTests.{name}") for name in TEST_MODELS]


def main(argv):
    validation = "--validation" in argv
    argv = [a for a in argv[1:] if a != "--validation"]
    rows = []
    print(f"{'model':<24}{'states':>7}{'load [s]':>10}{'lower [s]':>11}{'export [s]':>12}{'total [s]':>11}")
    with tempfile.TemporaryDirectory() as out, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, source, model in models(argv):
            t0 = time.perf_counter()
            flat = load_flat_model(source, model)
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
        write_section("build", header, rows, notes=["Wall-clock time, one build each."])


if __name__ == "__main__":
    main(sys.argv)
