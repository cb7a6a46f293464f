"""Small Modelica packages written by the compiler tests (the model text of a test stands in the test), and how
the event tests run their FMUs with fmpy and read the events off the results."""

import textwrap

import fmpy
import numpy as np

from cosim.compile import build_fmu


def write_package(folder, body):
    """``folder/T.mo`` holding ``package T`` around ``body`` (dedented; its first line is line 2 of the file)."""
    path = folder / "T.mo"
    path.write_text("package T\n" + textwrap.dedent(body).strip("\n") + "\nend T;\n")
    return path


def fmu_builder(package):
    """``get(name)``: the FMU of the package's model ``T.<name>``, built on first use into the package's folder."""
    built = {}

    def get(name):
        if name not in built:
            built[name] = build_fmu(package, f"T.{name}", out_dir=package.parent / "fmus")
        return built[name]

    return get


def simulate(fmu_path, fmi_type, outputs, stop_time, **options):
    """fmpy's run of an FMU on a 10 ms grid; Model Exchange under CVode at rtol 1e-10 unless ``options`` say."""
    if fmi_type == "ModelExchange":
        options.setdefault("relative_tolerance", 1e-10)
    return fmpy.simulate_fmu(str(fmu_path), fmi_type=fmi_type, stop_time=stop_time, output_interval=0.01,
                             output=outputs, **options)


def event_instants(result):
    """The instants fmpy recorded twice (before and after an event) in a Model Exchange result."""
    t = result["time"]
    return np.unique(t[1:][np.diff(t) == 0])


def away(t, instants, distance=1e-6):
    """Mask of the times farther than ``distance`` from every instant (values at an event are left or right)."""
    instants = np.asarray(instants, dtype=float)
    return np.min(np.abs(t[:, None] - instants[None, :]), axis=1) > distance if instants.size else t == t
