"""Argument parsing of ``cosim haptic ...``: each subcommand calls one library function (lazily imported)."""

__all__ = ["add_haptic_parser"]


def _cmd_margins(args):
    from cosim.analysis.haptic_report import write_margins

    for path in write_margins(args.out, K=args.K, rate=args.rate, adaptive=args.adaptive):
        print(f"wrote {path}")
    return 0


def add_haptic_parser(sub):
    """Add the ``haptic`` command and its subcommands to an argparse subparsers object."""
    p = sub.add_parser(
        "haptic",
        help="haptic device + user analyses (seed 000 PHANToM, seed 001 arm)",
        description="Analyses of the PHANToM phi axis held by a user: wall stability margins, identification.",
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
    m.add_argument("--K", type=float, default=10.0, help="wall stiffness, N.m/rad (default 10)")
    m.add_argument("--rate", type=float, default=1000.0, help="haptic loop rate, Hz (default 1000)")
    m.add_argument("--adaptive", action="store_true", help="also tune B per position for PM >= 50 deg (user 1)")
    m.add_argument("--out", required=True, help="output directory")
    m.set_defaults(func=_cmd_margins)
    return p
