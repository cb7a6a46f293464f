"""Argument parsing of ``cosim haptic ...``: each subcommand calls one library function (lazily imported)."""

from pathlib import Path

__all__ = ["add_haptic_parser"]


def _written(args, command, write, **kwargs):
    """Run ``write(folder, **kwargs)`` into a staging folder moved to ``--out`` (the rule of every command:
    :func:`cosim.outputs.output_folder`) and print the files at their final place."""
    from cosim.master.run import interrupt_on_signals
    from cosim.outputs import output_folder

    out = Path(args.out)
    with output_folder(out, f"haptic {command}", force=args.force) as staging, interrupt_on_signals():
        files = [out / Path(p).relative_to(staging) for p in write(staging, **kwargs)]
    for path in files:
        print(f"wrote {path}")
    return 0


def _cmd_margins(args):
    from cosim.haptic.report import write_margins

    return _written(args, "margins", write_margins, K=args.K, rate=args.rate, adaptive=args.adaptive)


def _cmd_collisions(args):
    from cosim.haptic.report import write_collisions

    users = _int_list(args.users, "--users")
    return _written(args, "collisions", write_collisions, users=users, adaptive=args.adaptive, fmu_dir=args.fmus,
                    K=args.K, rate=args.rate)


def _cmd_identify(args):
    from cosim.haptic.report import write_identification

    return _written(args, "identify", write_identification, user=args.user, position=args.position,
                    use_fmu=args.fmu, fmu_dir=args.fmus, seed=args.seed)


def _cmd_arm(args):
    from cosim.haptic.report import write_arm

    return _written(args, "arm", write_arm, seed=args.seed)


def _int_list(text, flag):
    from cosim.errors import CosimError

    try:
        return tuple(int(x) for x in text.split(","))
    except ValueError as err:
        raise CosimError(f"{flag}: expected comma-separated integers such as 1,2,3; got {text!r}") from err


def _positive(unit):
    """An argparse type: a finite number > 0 (a wall stiffness, a loop rate), refused with its unit otherwise."""
    import argparse
    import math

    def read(text):
        try:
            value = float(text)
        except ValueError:
            value = None
        if value is None or not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"expected a number > 0 in {unit}; got {text!r}")
        return value

    return read


def _seed(text):
    """An argparse type: a noise seed, a whole number >= 0 (what numpy's generators take)."""
    import argparse

    if not text.strip().isdigit():
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0; got {text!r}")
    return int(text)


def add_haptic_parser(sub):
    """Add the ``haptic`` command and its subcommands to an argparse subparsers object."""
    p = sub.add_parser(
        "haptic",
        help="haptic device + user analyses (seed 000 PHANToM, seed 001 arm)",
        description=("Analyses of the PHANToM phi axis held by a user, and of a user's arm: virtual-wall stability "
                     "margins (margins), wall contacts run by the master (collisions), identification of the "
                     "device + user model (identify), the arm model and its robust stability (arm)."),
    )
    hs = p.add_subparsers(dest="haptic_command", metavar="SUBCOMMAND", required=True)

    m = hs.add_parser(
        "margins",
        help="virtual-wall stability margins for 13 users x 6 grasp positions",
        description=(
            "Critical stiffness K_CR = Gm{G(z)}, phase margin at K, crossover, zeta ~ PM/100, overshoot and "
            "settling 4/(zeta w_cg) for every Table I row; writes OUT/margins.csv, OUT/margins_means.csv and "
            "OUT/margins.png (with --adaptive also the damping table tuned on user 1 and the damped margins)."
        ),
    )
    m.add_argument("--K", type=_positive("N.m/rad"), default=10.0, help="wall stiffness, N.m/rad (default 10)")
    m.add_argument("--rate", type=_positive("Hz"), default=1000.0, help="haptic loop rate, Hz (default 1000)")
    m.add_argument("--adaptive", action="store_true", help="also tune B per position for PM >= 50 deg (user 1)")
    m.add_argument("--out", required=True, help="output folder (new, or empty)")
    m.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    m.set_defaults(func=_cmd_margins)

    c = hs.add_parser(
        "collisions",
        help="virtual-wall contacts simulated by the master, measured beside the prediction",
        description=(
            "For each user and grasp position: a torque step at the wall surface and a collision at 0.5 rad/s "
            "(final wall torque 0.1 N.m), run by the co-simulation master with the Haptic FMUs (build them first "
            "with 'cosim build'); writes OUT/collisions.csv, collisions_means.csv and collisions.png."
        ),
    )
    c.add_argument("--users", default="1", help="comma-separated users, 1..13 (default 1)")
    c.add_argument("--adaptive", action="store_true", help="use the adaptive damping table (tuned on user 1)")
    c.add_argument("--K", type=_positive("N.m/rad"), default=10.0, help="wall stiffness, N.m/rad (default 10)")
    c.add_argument("--rate", type=_positive("Hz"), default=1000.0, help="haptic loop rate, Hz (default 1000)")
    c.add_argument("--fmus", default="fmus", help="folder with the built Haptic FMUs (default fmus)")
    c.add_argument("--out", required=True, help="output folder (new, or empty)")
    c.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    c.set_defaults(func=_cmd_collisions)

    i = hs.add_parser(
        "identify",
        help="seed 000 identification experiment on one Table I row",
        description=(
            "White-noise torque 0.1-150 Hz for 20 s at 1 kHz, Welch estimate (Hann 4096, 50 % overlap) with "
            "coherence, fit of the 11- or 7-parameter model; writes OUT/identification.csv and .png."
        ),
    )
    i.add_argument("--user", type=int, default=1, help="user 1..13 (default 1)")
    i.add_argument("--position", type=int, default=3, help="grasp position 1..6 (default 3)")
    i.add_argument("--fmu", action="store_true", help="simulate through the Haptic FMU instead of the LTI model")
    i.add_argument("--fmus", default="fmus", help="folder with the built Haptic FMUs (default fmus)")
    i.add_argument("--seed", type=_seed, default=0, help="noise seed (default 0)")
    i.add_argument("--out", required=True, help="output folder (new, or empty)")
    i.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    i.set_defaults(func=_cmd_identify)

    a = hs.add_parser(
        "arm",
        help="seed 001 arm experiment, fits, Bode plots, uncertainty weights and robust stability",
        description=(
            "Coloured-noise force (30 Hz 13th-order Butterworth, <= 5 N, 60 s, 1 kHz), Welch with 32 Hamming "
            "segments, coherence-weighted fit of M, k1, k2, b1, b2 for the Table I/II arms; Table II Bode plots "
            "and Table IV weights over 0.6-30 Hz; robust stability of the 10 N.m/rad wall. Writes OUT/arm_*."
        ),
    )
    a.add_argument("--seed", type=_seed, default=0, help="noise seed (default 0)")
    a.add_argument("--out", required=True, help="output folder (new, or empty)")
    a.add_argument("--force", action="store_true", help="replace OUT when it holds a previous cosim output")
    a.set_defaults(func=_cmd_arm)
    return p
