"""``jaxflex optimize``: the minimum-cycle-time move for a modal model under robot limits.

The command builds the option objects (optim.options: Search, Constraints, Rotation,
Budget), which check themselves, and checks the numbers, the move's length and the input
files before the optimiser (and JAX) loads and before the model file is read: a bad request
is answered at once.
"""

from __future__ import annotations

import argparse
import time

from jaxflex.cli import add_axis_limits, axis_limit_values
from jaxflex.defaults import DT_S, MAX_DURATION_S
from jaxflex.errors import InputError
from jaxflex.files import check_input_file, check_set_dir
from jaxflex.runtime import step
from optim.cell_file import load_cell
from optim.defaults import ANGULAR_LIMITS, FREQ_SCALE, GRID, MAX_STEPS, ZETA
from optim.limits import Limits
from optim.options import (
    Budget,
    Constraints,
    RobustSpec,
    Rotation,
    Search,
    check_step,
    clean_distance,
    label,
)
from optim.result_files import RESULT_FILES, check_animation_dir

COMMAND = "optimize"
HELP = "shortest cycle time move under vmax/amax/jmax limits (trajectory CSV, JSON, plots)"
ORDER = 20


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="modal model file (.npz, from `jaxflex model`)")
    for title, add in (
        ("the move, the robot's limits, the threshold", _add_move),
        ("the robot cell and its constraints", _add_cell),
        ("the search", _add_search),
        ("robust mode", _add_robust),
        ("the search's budget", _add_budget),
        ("outputs", _add_outputs),
    ):
        add(parser.add_argument_group(title))


def _add_outputs(parser) -> None:
    """The result directory, its pictures and the animation."""
    parser.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    parser.add_argument(
        "--no-plots",
        action="store_true",
        help="write the trajectory and the report only, no pictures (they are drawn after "
        "the answer is printed and take about a second)",
    )
    parser.add_argument(
        "--animate",
        action="store_true",
        help="also write the part moving and bending, frame by frame: a ParaView series and a "
        "browser page in OUTPUT/animation (as `jaxflex animate OUTPUT`)",
    )


def _add_move(parser) -> None:
    """The move, the robot's limits, the threshold and the step."""
    parser.add_argument(
        "--distance",
        nargs=3,
        type=float,
        default=None,
        metavar=("X", "Y", "Z"),
        help="move from rest to rest by this displacement, m (or the path of --cell)",
    )
    add_axis_limits(parser, with_defaults=True)
    for name, unit in (("vpath", "m/s"), ("apath", "m/s^2"), ("jpath", "m/s^3")):
        parser.add_argument(
            f"--{name}",
            type=float,
            default=None,
            metavar=unit.upper().replace("^", ""),
            help=f"optional limit on the norm over the axes, {unit}",
        )
    parser.add_argument(
        "--threshold",
        type=float,
        required=True,
        metavar="M",
        help="deviation threshold, m (e.g. 0.0005)",
    )
    parser.add_argument(
        "--dt", type=float, default=DT_S, metavar="S", help=f"sample step, s (default {DT_S:g})"
    )
    parser.add_argument(
        "--rotate",
        nargs="+",
        default=None,
        metavar="AXIS ANGLE_DEG",
        help="also turn the part by ANGLE_DEG degrees about AXIS (x, y, z or three numbers; "
        "model frame, through the gripper origin) under gravity -9.81 m/s^2 along z (with "
        "--cell: the axis turned with the part, the cell's gravity); takes --robust and "
        "--cell with its constraints; the model needs its rotation data (see docs/optim.md, "
        "Moves that turn the part)",
    )
    parser.add_argument(
        "--angular-limits",
        nargs=3,
        type=float,
        default=None,
        metavar=("W", "A", "J"),
        help="limits of the turn: rate rad/s, acceleration rad/s^2, jerk rad/s^3 (default "
        + " ".join(f"{v:g}" for v in ANGULAR_LIMITS)
        + ": a typical 6-axis robot wrist, jerk 10 x the acceleration)",
    )
    parser.add_argument(
        "--pivot",
        nargs=3,
        type=float,
        default=None,
        metavar=("X", "Y", "Z"),
        help="with --rotate: the point the axis passes through, m, model frame (default the "
        "origin; with --cell placed with the part); --distance (the cell's move) is then this "
        "point's move",
    )


def _add_cell(parser) -> None:
    """The robot cell and its constraints."""
    parser.add_argument(
        "--cell",
        default=None,
        metavar="FILE",
        help="robot cell (.toml or .json): obstacles, the part's pose, the path with via "
        "points, gravity (see docs/optim.md)",
    )
    parser.add_argument(
        "--min-distance",
        type=float,
        default=None,
        metavar="M",
        help="keep every monitored point this far from the cell's obstacles during the move "
        "and the settling, m (needs --cell)",
    )
    parser.add_argument(
        "--cup-safety",
        type=float,
        default=None,
        metavar="FACTOR",
        help="limit every suction cup's utilisation with this safety factor (1.5: smooth, "
        "dry sheet; 2 or more: oiled)",
    )
    parser.add_argument(
        "--cup-friction",
        type=float,
        default=None,
        metavar="MU",
        help="friction coefficient cup/part, replacing the model's (with --cup-safety)",
    )
    parser.add_argument(
        "--cup-vacuum",
        type=float,
        default=None,
        metavar="PA",
        help="vacuum (pressure difference, Pa) of every cup, replacing the model's "
        "(holding force = vacuum x pi r^2; with --cup-safety)",
    )
    parser.add_argument(
        "--max-stress",
        nargs="?",
        const="yield",
        default=None,
        metavar="PA",
        help="limit the von Mises stress, Pa (without a value: the material's yield / 1.5)",
    )


def _add_search(parser) -> None:
    """The clearance during the move, the method and its solver."""
    parser.add_argument(
        "--clearance",
        type=float,
        default=None,
        metavar="M",
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
        metavar="NAME",
        help="exact: highs (default), casadi (Clp) or casadi-highs; gradient: ipopt "
        "(default) or slsqp",
    )


def _add_robust(parser) -> None:
    """The robust mode and its uncertainty range."""
    parser.add_argument(
        "--robust",
        action="store_true",
        help="minimise the worst cycle time over a range of frequency scales and damping "
        "ratios (recommended; see --freq-scale, --zeta, --grid)",
    )
    for flag, default, metavar, kind, text in (
        (
            "--freq-scale",
            FREQ_SCALE,
            ("MIN", "MAX"),
            float,
            "range of the factor on every natural frequency",
        ),
        ("--zeta", ZETA, ("MIN", "MAX"), float, "range of the damping ratio of every mode"),
        (
            "--grid",
            GRID,
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


def _add_budget(parser) -> None:
    """The longest move and the LP budget."""
    parser.add_argument(
        "--max-duration",
        type=float,
        default=MAX_DURATION_S,
        metavar="S",
        help=f"longest move considered, s (default {MAX_DURATION_S:g})",
    )
    parser.add_argument(
        "--max-steps",
        type=int,
        default=MAX_STEPS,
        metavar="N",
        help=f"budget: most steps of any move an LP is built for (default {MAX_STEPS}; LP time "
        "grows with their square)",
    )


def rotation_argument(args: argparse.Namespace) -> Rotation | None:
    """``--rotate`` (AXIS ANGLE or X Y Z ANGLE), ``--angular-limits`` and ``--pivot`` as an
    optim.Rotation (None without --rotate)."""
    values = args.rotate
    if values is None:
        if args.angular_limits is not None or args.pivot is not None:
            raise InputError("--angular-limits, --pivot: only with --rotate AXIS ANGLE_DEG")
        return None
    if len(values) not in (2, 4):
        raise InputError(
            "--rotate: AXIS ANGLE_DEG with AXIS x, y, z or three numbers (e.g. --rotate z 90 or "
            f"--rotate 0 0 1 90), got {' '.join(values)!r}"
        )
    axis: str | list[float] = values[0]
    if len(values) == 4:
        try:
            axis = [float(v) for v in values[:3]]
        except ValueError as exc:
            raise InputError(f"--rotate: the axis must be three numbers, got {values[:3]}") from exc
    return Rotation(axis, values[-1], args.angular_limits, args.pivot)


def _max_stress(text: str | None) -> float | str | None:
    """``--max-stress``: None, "yield" (given without a value) or a stress in Pa."""
    if text in (None, "yield"):
        return text
    try:
        return float(text)
    except ValueError as exc:
        raise InputError(f"--max-stress: a stress in Pa or nothing, got {text!r}") from exc


def _options(args: argparse.Namespace) -> dict:
    """What needs neither the model nor the optimiser, checked before JAX loads and the
    model file is read: the output, the move, the numbers, the input files, the cell;
    returns the option objects (optim.options) by their keyword of optim.optimize."""
    check_set_dir("-o/--output", args.output, RESULT_FILES)
    if args.animate:
        check_animation_dir("-o/--output", args.output)
    if (args.distance is None) == (args.cell is None):
        raise InputError("--distance / --cell: give the move by one of them")
    if args.distance is not None:
        clean_distance(args.distance, label("distance_m"))
    check_step(args.threshold, args.dt)
    axis_limit_values(args)
    search = Search(args.method, args.solver)
    budget = Budget(args.max_duration, args.max_steps)
    rotation = rotation_argument(args)
    check_input_file("model", args.model)
    if args.cell is not None:
        check_input_file("--cell", args.cell)
    if args.cup_safety is None and (args.cup_friction is not None or args.cup_vacuum is not None):
        raise InputError("--cup-friction / --cup-vacuum: only with --cup-safety")
    constraints = Constraints(
        cell=None if args.cell is None else load_cell(args.cell),
        clearance_m=args.clearance,
        min_distance_m=args.min_distance,
        cup_safety=args.cup_safety,
        max_stress_pa=_max_stress(args.max_stress),
    )
    return {"search": search, "budget": budget, "rotation": rotation, "constraints": constraints}


def run(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    options = _options(args)
    limits = Limits(**axis_limit_values(args), vpath=args.vpath, apath=args.apath, jpath=args.jpath)
    robust = None
    if args.robust:
        robust = RobustSpec(tuple(args.freq_scale), tuple(args.zeta), *args.grid)
    import jaxflex
    from optim.cell_setup import with_cup_rating
    from optim.optimize import run as run_request
    from optim.request import Request

    model = jaxflex.load_model(args.model)
    if args.cup_friction is not None or args.cup_vacuum is not None:
        model = with_cup_rating(model, friction=args.cup_friction, vacuum_pa=args.cup_vacuum)
    step(
        f"{args.model}: {model.n_modes} modes, {model.n_points} points; "
        f"{'robust' if robust else 'nominal'} optimisation ({args.method})"
    )
    request = Request(
        model=model,
        distance_m=args.distance,
        limits=limits,
        dt_s=args.dt,
        threshold_m=args.threshold,
        robust=robust,
        **options,
    )
    result = run_request(request, start)
    print(result.summary(), flush=True)  # the answer first, then the files and pictures
    result.inputs = input_records(args.model, args.cell)
    paths = result.save(args.output, plots=not args.no_plots)
    print("wrote " + ", ".join(str(p) for p in paths))
    if args.animate:
        from optim.animate import animate

        print(animate(result, args.output).summary())
    return 0


def input_records(model: str, cell: str | None) -> dict:
    """report.json's ``inputs``: the model and cell files with their hashes (what `jaxflex
    animate RESULT_DIR` reads again)."""
    from optim.animate_frames import file_record

    records = {"model": file_record(model)}
    if cell is not None:
        records["cell"] = file_record(cell)
    return records
