"""``jaxflex animate``: the part moving and bending along the move of a written result.

The options and the animation's files are checked before the engine (and JAX) loads.
"""

from __future__ import annotations

import argparse

from jaxflex.errors import InputError
from jaxflex.files import check_input_file, check_positive, read_set
from optim.result_files import MAX_FRAMES, MAX_VERTICES, RESULT_KIND, check_animation_dir

COMMAND = "animate"
HELP = "the part bending along an optimised move, frame by frame: ParaView series, browser page"
ORDER = 22


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "result", metavar="RESULT_DIR", help="the output directory of `jaxflex optimize -o`"
    )
    parser.add_argument(
        "--model",
        default=None,
        metavar="FILE",
        help="the model file of the result (default: the one its report.json records)",
    )
    parser.add_argument(
        "--cell",
        default=None,
        metavar="FILE",
        help="the cell file of the result (default: the one its report.json records)",
    )
    parser.add_argument(
        "--page-points",
        type=int,
        default=MAX_VERTICES,
        metavar="N",
        help=f"the most points the page draws (default {MAX_VERTICES}; the series has all)",
    )
    parser.add_argument(
        "--page-frames",
        type=int,
        default=MAX_FRAMES,
        metavar="N",
        help=f"the most frames the page shows (default {MAX_FRAMES}; the series has all)",
    )
    parser.add_argument(
        "--after",
        type=float,
        default=None,
        metavar="S",
        help="the settling shown after the cycle time, s (default a quarter of it)",
    )


def run(args: argparse.Namespace) -> int:
    for option, value in (("--page-points", args.page_points), ("--page-frames", args.page_frames)):
        check_positive(option, value)
    if args.after is not None and not args.after >= 0:
        raise InputError(f"--after: a time >= 0 s, got {args.after}")
    for option in ("model", "cell"):
        if getattr(args, option) is not None:
            check_input_file(f"--{option}", getattr(args, option))
    # the result set whole (as optim.animate_frames reads it) and the animation's place
    read_set(args.result, RESULT_KIND, ("trajectory.csv", "report.json"), option="RESULT_DIR")
    check_animation_dir("RESULT_DIR", args.result)  # before any work
    from optim.animate import animate_directory  # the engine loads after the checks

    animation = animate_directory(
        args.result,
        model=args.model,
        cell=args.cell,
        max_vertices=args.page_points,
        max_frames=args.page_frames,
        after_s=args.after,
    )
    print(animation.summary())
    return 0
