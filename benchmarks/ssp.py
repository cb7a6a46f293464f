"""SSP with other tools: an SSP that ``cosim export-ssp`` writes, run by libcosim, against ``cosim run`` of its
config; SSPs written by hand (SSP 1.0 and 2.0) of the C test FMUs, run by ``cosim run``, against FMPy stepping the
same FMUs by hand. Prints the largest deviation of each signal beside its tolerance.

    python benchmarks/ssp.py [--validation]

Builds what it needs (examples/ssp/Oscillators.mo's Body as an FMI 2.0 FMU, tests/fmus' BouncingBall and
Feedthrough as FMI 3.0 FMUs) into a temporary folder; the systems are those of tests/test_ssp.py
(tests/ssp_support.py). ``--validation`` also writes the table into docs/validation.md.
"""

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))  # ssp_support and the C test FMUs' build (fmus.build)

BODY_STEP, BODY_STOP = 1e-3, 2.0  # the communication step of the exported system, its run
BALL_STEP, BALL_STOP = 0.01, 2.0  # the step the C test FMUs declare, the hand-written SSP's default experiment
ROUND_OFF = 1e-12  # the same FMU calls in the same order: nothing but round-off may differ


def _exported_against_libcosim(folder):
    """Rows of the two coupled bodies: ``cosim run`` of their config against libcosim's run of its export."""
    from ssp_support import TWO_BODIES, libcosim_ssp

    from cosim.compile import build_fmu
    from cosim.master.run import run_config
    from cosim.ssp.write import export_ssp

    fmu = build_fmu(ROOT / "examples" / "ssp" / "Oscillators.mo", "Oscillators.Body", out_dir=folder, fmi_version=2)
    config = folder / "two_bodies.toml"
    config.write_text(TWO_BODIES.format(stop=BODY_STOP, fmu=fmu, rate=1 / BODY_STEP))
    ours = run_config(config, out=folder / "out")[0].data[1:]  # libcosim reports after each step
    signals = ["a.x", "b.x", "a.v", "b.v"]
    theirs = libcosim_ssp(export_ssp(config, folder / "two_bodies.ssp"), signals, BODY_STEP, BODY_STOP)
    if np.max(np.abs(theirs[:, 0] - ours["time"])) > 1e-9:
        raise SystemExit("libcosim's instants are not cosim's")
    tolerance = 1e-3 * BODY_STEP * max(np.max(np.abs(ours["a.v"])), np.max(np.abs(ours["b.v"])))
    return [["`cosim export-ssp` -> libcosim against `cosim run`", "two coupled bodies (Body, FMI 2.0 CS)",
             f"{BODY_STEP * 1e3:g} ms", name, f"{np.ptp(ours[name]):.3g} m",
             f"{np.max(np.abs(theirs[:, k] - ours[name])):.2g} m", f"{tolerance:.2g} m"]
            for k, name in enumerate(signals[:2], start=1)]


def _hand_written_against_fmpy(folder):
    """Rows of the hand-written SSPs (1.0, 2.0, 1.0 with a linear transformation): ``cosim run`` against FMPy."""
    from fmus.build import build
    from ssp_support import fmpy_by_hand, hand_ssp

    from cosim.master.run import run_config

    built = {name: build(name, folder, 3) for name in ("BouncingBall", "Feedthrough")}
    cases = [("SSP 1.0", {"version": "1.0"}, (1.0, 0.0)), ("SSP 2.0", {"version": "2.0"}, (1.0, 0.0)),
             ("SSP 1.0, connection factor 2 offset 0.5",
              {"version": "1.0", "transform": '\n        <ssc:LinearTransformation factor="2" offset="0.5"/>'},
              (2.0, 0.5))]
    rows = []
    for k, (what, keywords, (factor, offset)) in enumerate(cases):
        case = folder / f"case{k}"
        case.mkdir()
        ours = run_config(hand_ssp(case, built.get, **keywords), out=case / "out")[0].data
        theirs = fmpy_by_hand(built["BouncingBall"], built["Feedthrough"], BALL_STEP, BALL_STOP, factor, offset)
        if np.max(np.abs(ours["time"] - theirs[:, 0])) > ROUND_OFF:
            raise SystemExit(f"{what}: cosim's instants are not FMPy's")
        for j, name in enumerate(("h", "x"), start=1):
            rows.append([f"hand-written {what} -> `cosim run` against FMPy by hand",
                         "BouncingBall -> Feedthrough (FMI 3.0 CS)", f"{BALL_STEP * 1e3:g} ms", name,
                         f"{np.ptp(theirs[:, j]):.3g}", f"{np.max(np.abs(ours[name] - theirs[:, j])):.2g}",
                         f"{ROUND_OFF:.0e}"])
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--validation", action="store_true", help="also write the table into docs/validation.md")
    args = ap.parse_args(argv)
    from validation import write_section

    with tempfile.TemporaryDirectory(prefix="cosim-ssp-") as tmp:
        rows = _exported_against_libcosim(Path(tmp)) + _hand_written_against_fmpy(Path(tmp))
    header = ["comparison", "system", "step", "signal", "range", "max deviation", "tolerance"]
    for row in rows:
        print(" | ".join(row))
    failed = [row for row in rows if float(row[5].split()[0]) > float(row[6].split()[0])]
    if args.validation:
        write_section("ssp", header, rows, notes=[
            f"Exported system: {BODY_STOP:g} s at a communication step of {BODY_STEP * 1e3:g} ms, both masters "
            "holding each FMU's inputs over the step (Jacobi); tolerance 1e-3 * step * max|v| (a thousandth of what "
            "one step moves a body at its fastest: an exchange one step early or late moves the positions by about "
            "step * max|v|). Hand-written SSPs: the default experiment's 2 s at the step the FMUs declare, 10 ms; "
            f"the same FMU calls in the same order, so the tolerance is round-off, {ROUND_OFF:.0e} absolute."])
    if failed:
        print(f"{len(failed)} deviations above their tolerance", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
