"""Robot limit options shared by the commands that take a move (no subcommand here)."""

from __future__ import annotations

# (option, unit, default): per-axis limits of a jerk-limited move
AXIS_LIMITS = (("vmax", "m/s", 2.0), ("amax", "m/s^2", 10.0), ("jmax", "m/s^3", 100.0))


def add_axis_limits(parser, *, with_defaults: bool, condition: str = "") -> None:
    """--vmax/--amax/--jmax, each one value or three (x y z). ``with_defaults`` False leaves
    them None when not given (the caller applies AXIS_LIMITS' defaults); ``condition`` prefixes
    the help text (e.g. "--distance: ")."""
    for name, unit, default in AXIS_LIMITS:
        parser.add_argument(
            f"--{name}",
            nargs="+",
            type=float,
            default=[default] if with_defaults else None,
            metavar="V",
            help=f"{condition}per-axis limit in {unit}: one value or three (x y z); "
            f"default {default:g}",
        )
