"""``jaxflex optimize``: the minimum-cycle-time move for a modal model under robot limits."""

from __future__ import annotations

import argparse

import jaxflex
from jaxflex.cli import add_axis_limits, axis_limit_values
from jaxflex.progress import step
from jaxflex.validation import check_output_dir, check_positive
from optim.budget import MAX_STEPS
from optim.limits import Limits
from optim.optimize import optimize
from optim.robust import RobustSpec

COMMAND = "optimize"
HELP = "shortest cycle time move under vmax/amax/jmax limits (trajectory CSV, JSON, plots)"
ORDER = 20


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="modal model file (.npz, from `jaxflex model`)")
    parser.add_argument(
        "--distance",
        nargs=3,
        type=float,
        required=True,
        metavar=("X", "Y", "Z"),
        help="move from rest to rest by this displacement, m",
    )
    add_axis_limits(parser, with_defaults=True)
    for name, unit in (("vpath", "m/s"), ("apath", "m/s^2"), ("jpath", "m/s^3")):
        parser.add_argument(
            f"--{name}",
            type=float,
            default=None,
            help=f"optional limit on the norm over the axes, {unit}",
        )
    parser.add_argument(
        "--threshold", type=float, required=True, help="deviation threshold, m (e.g. 0.0005)"
    )
    parser.add_argument("--dt", type=float, default=0.01, help="sample step, s (default 0.01)")
    parser.add_argument(
        "--clearance",
        type=float,
        default=None,
        help="optional limit on the deviation during the move, m (nominal model)",
    )
    parser.add_argument(
        "--method",
        choices=("exact", "gradient"),
        default="exact",
        help="exact: LP feasibility tests (default); gradient: smooth surrogate with Ipopt",
    )
    parser.add_argument(
        "--solver",
        default=None,
        help="exact: highs (default), casadi (Clp) or casadi-highs; gradient: ipopt "
        "(default) or slsqp",
    )
    parser.add_argument(
        "--robust",
        action="store_true",
        help="minimise the worst cycle time over a range of frequency scales and damping "
        "ratios (recommended; see --freq-scale, --zeta, --grid)",
    )
    for flag, default, metavar, kind, text in (
        (
            "--freq-scale",
            (0.9, 1.1),
            ("MIN", "MAX"),
            float,
            "range of the factor on every natural frequency",
        ),
        ("--zeta", (0.01, 0.03), ("MIN", "MAX"), float, "range of the damping ratio of every mode"),
        (
            "--grid",
            (21, 3),
            ("NF", "NZ"),
            int,
            "check-grid points over the frequency and damping ranges",
        ),
    ):
        parser.add_argument(
            flag,
            nargs=2,
            type=kind,
            default=default,
            metavar=metavar,
            help=f"robust: {text} (default {default[0]:g} {default[1]:g})",
        )
    parser.add_argument(
        "--max-duration",
        type=float,
        default=30.0,
        help="longest move considered, s (default 30)",
    )
    parser.add_argument(
        "--max-steps",
        type=int,
        default=MAX_STEPS,
        help=f"budget: most steps of any move an LP is built for (default {MAX_STEPS}; LP time "
        "grows with their square)",
    )
    parser.add_argument(
        "--max-memory",
        type=float,
        default=None,
        metavar="GB",
        help="budget: memory of the search in GB (default: half the machine's memory)",
    )
    parser.add_argument("-o", "--output", required=True, help="output directory")


def run(args: argparse.Namespace) -> int:
    check_output_dir("-o/--output", args.output)
    threshold_m = check_positive("--threshold", args.threshold)
    dt_s = check_positive("--dt", args.dt)
    max_duration = check_positive("--max-duration", args.max_duration)
    limits = Limits(**axis_limit_values(args), vpath=args.vpath, apath=args.apath, jpath=args.jpath)
    robust = None
    if args.robust:
        robust = RobustSpec(tuple(args.freq_scale), tuple(args.zeta), *args.grid)
    model = jaxflex.load_model(args.model)
    step(
        f"{args.model}: {model.n_modes} modes, {model.n_points} points; "
        f"{'robust' if robust else 'nominal'} optimisation ({args.method})"
    )
    result = optimize(
        model,
        args.distance,
        limits,
        dt_s,
        threshold_m,
        method=args.method,
        solver=args.solver,
        robust=robust,
        max_duration_s=max_duration,
        clearance_m=None
        if args.clearance is None
        else check_positive("--clearance", args.clearance),
        max_steps=args.max_steps,
        max_memory_bytes=None
        if args.max_memory is None
        else int(check_positive("--max-memory", args.max_memory) * 1e9),
    )
    paths = result.save(args.output)
    print(result.summary())
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0
