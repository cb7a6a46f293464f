"""Builds the third-party-style test FMUs of this directory: C sources written for the tests, compiled with gcc
against the FMI headers fmpy ships (``fmpy/c-code``) and zipped with their modelDescription.xml.

Each model lives in ``tests/fmus/<name>/``: ``model.c`` (the equations, see ``common/model.h``) and
``fmi3.xml`` and/or ``fmi2.xml``. The same C source gives the FMI 2.0 and the FMI 3.0 FMU; one FMU carries both
Model Exchange and Co-Simulation (the Co-Simulation side integrates with fixed-step RK4 and handles events
inside doStep, ``common/shared.c``)."""

import platform
import re
import subprocess
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
PLATFORM = {2: "linux64", 3: "x86_64-linux"}


def names():
    """(model name, FMI version) of every test FMU the directory holds."""
    return sorted((d.name, int(x.stem[3])) for d in HERE.iterdir() for x in d.glob("fmi[23].xml"))


def _fmi_headers():
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def build(name, out_dir, fmi_version=3):
    """Compile and zip the test FMU ``name`` for FMI ``fmi_version`` (2 or 3) into ``out_dir``.

    Parameters
    ----------
    name : str
        Directory of the model under tests/fmus, e.g. ``"BouncingBall"``.
    out_dir : path-like
        Where the FMU is written, as ``<name>_fmi<version>.fmu``.
    fmi_version : int
        2 or 3; the model must have the matching ``fmi<version>.xml``.

    Returns
    -------
    pathlib.Path
        The FMU.
    """
    if platform.system() != "Linux" or platform.machine() != "x86_64":
        raise RuntimeError(f"the test FMUs are built for x86_64 Linux only, not {platform.system()} "
                           f"{platform.machine()}")
    xml = (HERE / name / f"fmi{fmi_version}.xml").read_text(encoding="utf-8")
    identifier = re.search(r'modelIdentifier="([^"]+)"', xml).group(1)
    out = Path(out_dir) / f"{name}_fmi{fmi_version}.fmu"
    with tempfile.TemporaryDirectory() as tmp:
        unit = Path(tmp) / "unit.c"
        unit.write_text(f'#include "{name}/model.c"\n#include "fmi{fmi_version}.c"\n', encoding="utf-8")
        lib = Path(tmp) / f"{identifier}.so"
        cmd = ["gcc", "-shared", "-fPIC", "-O2", "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-Wall",
               "-Wno-unused-parameter", "-Wno-unused-function",
               f"-I{HERE}", f"-I{HERE / 'common'}", f"-I{_fmi_headers()}", "-o", str(lib), str(unit), "-lm"]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"gcc failed for test FMU {name} (FMI {fmi_version}):\n{done.stderr}")
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("modelDescription.xml", xml)
            zf.write(lib, f"binaries/{PLATFORM[fmi_version]}/{identifier}.so")
    return out
