"""``jaxflex export``: a modal model (and the optimised move) as an FMI 2.0 / 3.0 FMU.

The options and the files are checked before the export's modules (and JAX) load.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

from jaxflex.defaults import THRESHOLD_M
from jaxflex.errors import InputError
from jaxflex.files import check_input_file, check_output_file, check_positive
from optim.cell_file import load_cell

if TYPE_CHECKING:
    from jaxflex.response import Move, Turn
    from jaxflex.runtime import Need

COMMAND = "export"
HELP = (
    "write the part as an FMI 2.0/3.0 co-simulation FMU (optionally with the optimised move) "
    "or an SSP package of the part and the move"
)
ORDER = 30

# what `jaxflex optimize -o DIR` writes into DIR/report.json and the FMU's case file keeps
CASE_KEYS = (
    "distance_m",
    "limits",
    "threshold_m",
    "cycle_time_s",
    "transfer_time_s",
    "settle_time_s",
    "turn",  # a move that turns the part (`jaxflex optimize --rotate`)
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="modal model file (.npz from `jaxflex model`)")
    _add_target(parser.add_argument_group("the FMU or package and its build"))
    _add_move(parser.add_argument_group("the move and the FMU's parameters"))
    _add_cell(parser.add_argument_group("the robot cell's outputs (fmu.CellOutputs)"))
    _add_turning(parser.add_argument_group("a turning part (fmu.Turning)"))


def _add_target(group) -> None:
    group.add_argument("-o", "--output", metavar="FILE", help="FMU file to write (.fmu)")
    group.add_argument(
        "--ssp",
        metavar="FILE",
        help="SSP 1.0 package to write (.ssp): the part FMU and a trajectory source FMU playing "
        "the --trajectory move, connected ax/ay/az (with --turning the pose too), with the "
        "threshold and damping scale as parameters (with or instead of -o)",
    )
    group.add_argument(
        "--fmi", type=int, choices=(2, 3), default=2, help="FMI version 2 or 3 (default 2)"
    )
    group.add_argument(
        "--name", metavar="NAME", help="model name in modelDescription.xml (default: file name)"
    )
    group.add_argument(
        "--windows",
        choices=("auto", "yes", "no"),
        default="auto",
        help="also build the Windows DLLs: auto = when mingw-w64 is installed (default)",
    )
    group.add_argument(
        "--points",
        type=int,
        metavar="N",
        help="export about N voxel-reduced points of the model instead of all of them (a "
        "smaller resource and a faster FMU step; the FMU's deviation, settled flag and "
        "distances then only cover those points)",
    )
    group.add_argument(
        "--no-verify",
        action="store_true",
        help="skip the simulations against jaxflex (fmpy; ecospy and libcosimpy when installed)",
    )


def _add_move(group) -> None:
    group.add_argument(
        "--trajectory",
        metavar="CSV|DIR",
        help="output folder of `jaxflex optimize` (trajectory.csv, report.json) or a trajectory "
        "CSV (columns t_s, ax_m_s2, ay_m_s2, az_m_s2, ...; SI units): embedded in the FMU and "
        "written beside it as <name>_input.csv and <name>_case.json",
    )
    group.add_argument(
        "--threshold",
        type=float,
        metavar="M",
        help="start value of the deviation threshold in m (default: from report.json, else 0.5 mm)",
    )
    group.add_argument(
        "--damping-scale",
        type=float,
        default=1.0,
        metavar="FACTOR",
        help="start value of the factor on every modal damping ratio (default 1)",
    )


def _add_cell(group) -> None:
    group.add_argument(
        "--cell",
        default=None,
        metavar="FILE",
        help="robot cell (.toml or .json): the part is posed in it (inputs and the trajectory "
        "in cell coordinates) and the FMU reports the distance to its obstacles",
    )
    group.add_argument(
        "--cup-safety",
        type=float,
        default=1.5,
        metavar="FACTOR",
        help="safety factor of the cup utilisation outputs (models with cup reactions; "
        "default 1.5)",
    )
    group.add_argument(
        "--stress",
        action="store_true",
        help="also output the von Mises stress (max_stress; FMI 3.0 point_stresses)",
    )


def _add_turning(group) -> None:
    group.add_argument(
        "--turning",
        action="store_true",
        help="the part turns: the FMU takes the pose as inputs too (orientation quaternion "
        "quat_w..quat_z body to world, angular velocity omega_x..z in rad/s and acceleration "
        "alpha_x..z in rad/s^2 in body components; ax, ay, az the world acceleration of the "
        "pivot) and outputs the deviation about the current pose's sag; needs a model with "
        "rotation data; with --trajectory the move of `jaxflex optimize --rotate` (its turn "
        "and pivot) is embedded; with --cell / --stress the cell's outputs of the turning "
        "part (not in the SSP package); with --ssp the package of the turning part and a "
        "source playing the pose",
    )
    group.add_argument(
        "--pivot",
        type=float,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="with --turning: the point of the part (model frame, m) whose acceleration the "
        "inputs ax, ay, az are, e.g. the robot's tool centre point (default: the origin; with "
        "--trajectory the pivot the move was optimised about)",
    )


def trajectory_file(path: Path) -> Path:
    """The trajectory CSV of ``--trajectory`` (a folder of `jaxflex optimize -o DIR` or the
    CSV itself)."""
    if not path.is_dir():
        return check_input_file("--trajectory", path)
    csv = path / "trajectory.csv"
    if not csv.is_file():
        raise InputError(
            f"--trajectory: folder {str(path)!r} has no trajectory.csv (expected the output "
            "folder of `jaxflex optimize ... -o DIR`)"
        )
    return csv


def _read_csv(csv: Path) -> Move:
    """The Move of a trajectory CSV; its refusal names --trajectory."""
    from jaxflex.files import read_trajectory_csv

    try:
        return read_trajectory_csv(csv)
    except InputError as exc:
        raise InputError(f"--trajectory: {exc}") from exc


def load_case(path: Path) -> tuple[Move, dict | None]:
    """(the Move, report dict or None) from an optimize folder or a CSV.

    The trajectory and its report are used together only as members of one complete result
    set (jaxflex._fileset: the manifest lists both with their hashes): a folder whose run was
    interrupted, or a CSV beside a report of another run, is refused naming the file."""
    from jaxflex.files import read_set
    from optim.result_files import RESULT_KIND

    csv = trajectory_file(path)
    if not path.is_dir() and not csv.with_name("report.json").exists():
        return _read_csv(csv), None  # a trajectory on its own
    members = read_set(csv.parent, RESULT_KIND, (csv.name, "report.json"), option="--trajectory")
    move = _read_csv(csv)
    dt_s = move.dt_s
    report_path = members["report.json"]
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"--trajectory: {str(report_path)!r} is not valid JSON ({exc})") from exc
    if not isinstance(report, dict):
        raise InputError(f"--trajectory: {str(report_path)!r} is not a report (a JSON object)")
    report_dt = report.get("dt_s")
    if report_dt is not None and abs(float(report_dt) - dt_s) > 1e-9 * dt_s:
        raise InputError(
            f"--trajectory: {report_path.name} says dt_s = {report_dt} s but {csv.name} is "
            f"sampled every {dt_s} s; they do not belong together"
        )
    return move, {key: report[key] for key in CASE_KEYS if key in report}


def turning_move(path: Path, move: Move, case: dict | None, pivot_m) -> Turn:
    """The embedded move of a turning part from ``--trajectory`` ``path`` (a
    jaxflex.response.Turn: the pose path at the samples of ``move``, its translation, the
    pivot and gravity): the turn of `jaxflex optimize --rotate` (trajectory.csv's turn
    columns, report.json's axis, pivot and gravity), or no turn for a straight move (about
    ``pivot_m``, default the origin). Inconsistent inputs are refused naming the option."""
    import numpy as np

    from jaxflex.files import read_turn_csv
    from jaxflex.geometry import DEFAULT_GRAVITY_M_S2
    from jaxflex.response import Turn, fixed_axis_path
    from optim.turn_via import reported_turn

    turn_acc = read_turn_csv(trajectory_file(path))
    spec = (case or {}).get("turn")
    if turn_acc is None and spec is None:  # a straight move: the part keeps its orientation
        pose = fixed_axis_path("z", np.zeros(move.n_steps + 1), move.dt_s)
        pivot = (0.0, 0.0, 0.0) if pivot_m is None else pivot_m
        return Turn(pose, move, pivot_m=pivot, gravity_m_s2=DEFAULT_GRAVITY_M_S2)
    if turn_acc is None:
        raise InputError(
            "--trajectory: a turning move needs the turn columns of trajectory.csv and the turn "
            "of report.json of the same `jaxflex optimize --rotate` run; its turn columns missing"
        )
    turn = reported_turn(spec, turn_acc, move, DEFAULT_GRAVITY_M_S2)
    if pivot_m is not None and not np.array_equal(np.asarray(pivot_m, np.float64), turn.pivot_m):
        raise InputError(
            f"--pivot: the move was optimised about the pivot {turn.pivot_m.tolist()} m "
            "(report.json's turn); leave --pivot out or give the same point"
        )
    return turn


def _print_binaries(name: str, platforms, skipped: dict[str, str]) -> None:
    print(f"{name}: binaries {', '.join(platforms)}")
    for plat, reason in skipped.items():
        print(f"{name}: skipped {plat}: {reason}")


# per point, mode (or obstacle piece) and step of the FMU's C, for each host the verification
# runs (fmpy, ecospy, libcosimpy; 2-core machine); the build: gcc per platform
STEP_S = 5e-9
HOSTS = 3
BUILD_S = 10.0


def _need(model, trajectory, cell, *, verify: bool) -> Need:
    """What exporting ``model`` (with the Move ``trajectory`` or None, the
    ``cell`` or None) and verifying it take: the resource (model, move, obstacles) held a few
    times while written, and the simulations of the move in each host."""
    from jaxflex.runtime import Need
    from optim.budget import obstacle_pieces

    pieces = 0 if cell is None else obstacle_pieces(cell)
    samples = 0 if trajectory is None else trajectory.n_steps + 1
    values = model.n_modes * (5 + 3 * model.n_points) + 3 * model.n_points + 3 * samples
    values += 12 * pieces
    per_step = model.n_points * (model.n_modes + pieces)
    seconds = BUILD_S + (HOSTS * samples * per_step * STEP_S if verify else 0.0)
    return Need(
        f"the FMU ({model.n_points} points, {model.n_modes} modes, {samples} samples of the "
        f"move, {pieces:,} obstacle pieces)",
        4 * 8.0 * values,
        seconds,
        "export fewer points (jaxflex model --points) or simpler obstacles, or --no-verify",
    )


def _options(args, trajectory: Move | None, threshold_m, case: dict | None, cell) -> tuple:
    """(the keyword arguments the FMU and SSP exports share: ``fmi`` (fmu.Fmi),
    ``threshold_m``, ``damping_scale``, ``case``, ``turning`` (fmu.Turning or None); the cell's
    fmu.CellOutputs; the embedded turning move or None) of the command's options: a turning
    part's embedded move is the turn of ``--trajectory`` (:func:`turning_move`), its pivot
    without one ``--pivot``."""
    from fmu.options import CellOutputs, Fmi, Turning

    windows = {"auto": None, "yes": True, "no": False}[args.windows]
    outputs = CellOutputs(cell, cup_safety=args.cup_safety, stress=args.stress)
    turn = turning = None
    if args.turning and trajectory is not None:
        turn = turning_move(Path(args.trajectory), trajectory, case, args.pivot)
        turning = Turning.of(turn)
    elif args.turning:
        turning = Turning((0.0, 0.0, 0.0) if args.pivot is None else args.pivot)
    shared = {
        "fmi": Fmi(args.fmi, windows=windows, model_name=args.name),
        "threshold_m": threshold_m,
        "damping_scale": args.damping_scale,
        "case": case,
        "turning": turning,
    }
    return shared, outputs, turn


def _export_fmu(args, model, trajectory, threshold_m, case, cell) -> int:
    from fmpy.validation import validate_fmu

    from fmu.crosscheck import crosscheck_fmu
    from fmu.export import export_fmu
    from fmu.verify import verify
    from fmu.verify_turning import after_move_s, verify_turning

    shared, outputs, turn = _options(args, trajectory, threshold_m, case, cell)
    result = export_fmu(model, args.output, trajectory, outputs=outputs, **shared)
    print(
        f"wrote {result.fmu_path}: FMI {result.fmi_version}.0 co-simulation, "
        f"{result.counts.points} points, {result.counts.modes} modes, resource "
        f"{result.resource_bytes / 1e6:.2f} MB"
    )
    if result.counts.available():
        print(
            f"cell outputs: {result.counts.cups} cups, {result.counts.stress} stress points, "
            f"{result.counts.obstacles} obstacle records"
        )
    if result.counts.turning:
        print(
            "turning part: inputs ax, ay, az (pivot, world), quat_w..quat_z (body to world), "
            "omega_x..z, alpha_x..z (body)"
        )
    _print_binaries(result.fmu_path.name, result.platforms, result.skipped)
    if result.case is not None:
        print(
            f"embedded move: {result.counts.trajectory} samples, dt {result.case['dt_s']:g} s, "
            f"cycle time {result.case['cycle_time_s']:.3f} s at threshold "
            f"{threshold_m * 1e3:g} mm; wrote {result.input_csv.name}, {result.case_json.name}"
        )
    if result.case is None or args.no_verify:
        problems = validate_fmu(str(result.fmu_path))
        print("fmpy validation: " + ("clean" if not problems else "; ".join(problems)))
        return 0 if not problems else 1
    if turn is not None:  # other hosts' checks replay a straight move: fmpy only
        extend_s = after_move_s(result.case)
        report = verify_turning(result.fmu_path, model, turn, extend_s=extend_s)
        print(report.summary())
        return 0 if report.ok else 1
    report = verify(result.fmu_path)
    print(report.summary())
    hosts = crosscheck_fmu(result.fmu_path)
    print(hosts.summary())
    return 0 if report.ok and hosts.ok else 1


def _export_ssp(args, model, trajectory, threshold_m, case) -> int:
    from fmu.crosscheck import crosscheck_ssp
    from fmu.ssp import export_ssp

    shared, _, _ = _options(args, trajectory, threshold_m, case, None)
    result = export_ssp(model, args.ssp, trajectory, **shared)
    part, source = result.part, result.source
    print(
        f"wrote {result.ssp_path}: SSP 1.0, part FMU ({part.counts.points} points, "
        f"{part.counts.modes} modes) driven by a trajectory source FMU ({source.n_samples} "
        f"samples every {source.dt_s:g} s, {len(source.outputs)} signals connected), FMI "
        f"{result.fmi_version}.0, parameters "
        + ", ".join(f"{k} = {v:g}" for k, v in result.parameters.items())
    )
    _print_binaries("part.fmu", result.part.platforms, result.part.skipped)
    _print_binaries("trajectory.fmu", result.source.platforms, result.source.skipped)
    if args.no_verify:
        return 0
    report = crosscheck_ssp(result.ssp_path, part_model=model if args.turning else None)
    print(report.summary())
    return 0 if report.ok else 1


def run(args: argparse.Namespace) -> int:
    if not args.output and not args.ssp:
        raise InputError("give -o FILE.fmu, --ssp FILE.ssp or both")
    for option, value, suffix in (
        ("-o/--output", args.output, ".fmu"),
        ("--ssp", args.ssp, ".ssp"),
    ):
        if not value:
            continue
        if Path(value).suffix.lower() != suffix:
            raise InputError(f"{option}: the file name must end in {suffix}, got {value!r}")
        check_output_file(option, value)
    if args.ssp and not args.trajectory:
        raise InputError("--ssp: the package plays a move; give --trajectory as well")
    if args.ssp and (args.cell or args.stress):
        raise InputError("--cell / --stress: only for the FMU (-o), not for the SSP package")
    if args.pivot is not None and not args.turning:
        raise InputError("--pivot: only with --turning (the point the inputs ax, ay, az move)")
    if args.points is not None and args.points < 1:
        raise InputError(f"--points: a count >= 1, got {args.points}")
    if args.threshold is not None:
        check_positive("--threshold", args.threshold)
    check_positive("cup_safety", args.cup_safety)  # before any work
    check_input_file("model", args.model)
    if args.trajectory:
        trajectory_file(Path(args.trajectory))
    cell = None if args.cell is None else load_cell(args.cell)  # light: before JAX loads
    trajectory, case = None, None
    if args.trajectory:  # before the model: a refused move costs no model read
        trajectory, case = load_case(Path(args.trajectory))
        if not args.turning and (case or {}).get("turn") is not None:
            raise InputError(
                "--trajectory: the move turns the part (report.json's turn); export it with "
                "--turning (the straight part's FMU would replay the translation only)"
            )
    threshold_m = args.threshold
    if threshold_m is None:
        threshold_m = (case or {}).get("threshold_m", THRESHOLD_M)
    threshold_m = check_positive("--threshold", threshold_m)
    import numpy as np

    import jaxflex
    from fmu.move_cell import check_move_cell
    from jaxflex.response import downsample_to_count
    from jaxflex.runtime import require

    model = jaxflex.load_model(args.model)
    if args.points is not None:
        kept = downsample_to_count(np.asarray(model.points), args.points)
        print(f"{len(kept)} of {model.n_points} points kept for the FMU (voxel reduction)")
        model = model.select_points(kept)
    if cell is not None and case is not None:  # a move of `jaxflex optimize`: made in it?
        report = trajectory_file(Path(args.trajectory)).with_name("report.json")
        check_move_cell(report, args.cell, cell)
    require(_need(model, trajectory, cell, verify=not args.no_verify))
    status = 0
    if args.output:
        status = _export_fmu(args, model, trajectory, threshold_m, case, cell)
    if args.ssp:
        status = max(status, _export_ssp(args, model, trajectory, threshold_m, case))
    return status
