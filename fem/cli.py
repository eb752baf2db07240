"""``jaxflex model``: part + gripper -> finite-element modal analysis -> modal model file.

With ``--tolerance`` the mesh, the number of modes and the monitored points are chosen for a
move (``--trajectory`` or ``--distance`` with limits) and a ``--threshold`` by fem.size_model.
``--from-ansys``, ``--from-nastran``, ``--from-r1`` and ``--from-modes`` build the model
from a user's own finite-element results (fem.imports.cli).

The options and the input files are checked before the finite-element modules (and JAX)
load: an argument error is answered at once.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from fem.choices import CAD_SUFFIXES, ELEMENTS, FORMATS_HELP, PICTURE_SUFFIXES, VIEW_SUFFIXES
from fem.damping import check_damping
from fem.imports import cli as cli_imports
from fem.materials import resolve_material
from jaxflex.cli import AXIS_LIMITS, add_axis_limits, axis_limit_values
from jaxflex.defaults import DT_S
from jaxflex.errors import InputError
from jaxflex.files import check_input_file, check_output_file, check_positive, file_digest

if TYPE_CHECKING:
    from fem.supports import SuctionCup
    from jaxflex.response import Move

COMMAND = "model"
HELP = (
    "build a modal model (.npz) from a built-in scene, a mesh or CAD file, or ANSYS, Nastran, "
    "R1 or other solvers' modal results (SI units, m)"
)
ORDER = 10


def _cup(text: str) -> SuctionCup:
    """X,Y,R or X,Y,Z,R (m) -> a suction cup (Z: on the surface point nearest (X, Y, Z))."""
    parts = text.split(",")
    if len(parts) not in (3, 4):
        raise argparse.ArgumentTypeError(
            f"expected X,Y,R or X,Y,Z,R in m (e.g. 0.3,0.2,0.04), got {text!r}"
        )
    try:
        values = [float(p) for p in parts]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected numbers X,Y[,Z],R in m, got {text!r}") from exc
    x, y, *z, radius = values
    from fem.supports import SuctionCup  # only when cups are given

    try:
        return SuctionCup(x, y, radius, z=z[0] if z else None)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc


def _pair(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected X,Y in m (e.g. 0.3,0.2), got {text!r}")
    try:
        return float(parts[0]), float(parts[1])
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected numbers X,Y in m, got {text!r}") from exc


def _points(text: str) -> int | str:
    if text == "all":
        return "all"
    try:
        count = int(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a count or 'all', got {text!r}") from exc
    if count < 1:
        raise argparse.ArgumentTypeError(f"expected a count >= 1 or 'all', got {count}")
    return count


def _zeta(text: str) -> float:
    """A damping ratio in [0, 1), checked before any finite-element work."""
    try:
        value = float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a damping ratio, got {text!r}") from exc
    try:
        check_damping(value)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("zeta: ")) from exc
    return value


def _tolerance(text: str) -> float:
    """'1%' -> 0.01, '0.01' -> 0.01."""
    raw = text.strip()
    scale = 0.01 if raw.endswith("%") else 1.0
    try:
        return float(raw.removesuffix("%")) * scale
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected e.g. 1% or 0.01, got {text!r}") from exc


# A value that starts with a minus sign is an option to argparse unless it looks like a
# negative number; a cup or a point at negative coordinates (-0.02,0.05,0.08,0.005) is a
# comma-separated list of numbers, so the model command counts those as numbers too.
_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
NEGATIVE_NUMBERS = re.compile(rf"^-{_NUMBER}(?:,-?{_NUMBER})*$")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser._negative_number_matcher = NEGATIVE_NUMBERS  # argparse's test for "-0.5" etc.
    _add_sources(parser.add_argument_group("the part's source (one of)"))
    cli_imports.add_arguments(parser)
    _add_part(parser.add_argument_group("the sheet and its material"))
    _add_gripper(parser.add_argument_group("the gripper and supports"))
    _add_modes(parser.add_argument_group("modes and monitored points"))
    _add_outputs(parser.add_argument_group("outputs"))
    _add_sizing_arguments(parser)


def _add_sources(group) -> None:
    """Where the part comes from: a built-in scene, a mesh, a CAD body or another tool's
    files (fem.imports.cli)."""
    src = group.add_mutually_exclusive_group(required=True)
    src.add_argument("--scene", choices=("plate", "panel"), help="built-in part and gripper")
    src.add_argument(
        "--mesh",
        metavar="FILE",
        help=f"the part's mid-surface mesh ({FORMATS_HELP}); coordinates in m (see --scale)",
    )
    src.add_argument(
        "--cad",
        metavar="FILE",
        help=f"CAD sheet body ({', '.join(CAD_SUFFIXES)}; a surface, not a solid) meshed with "
        "gmsh at --mesh-size, refined around the cups",
    )
    cli_imports.add_sources(src)


def _add_part(group) -> None:
    """The sheet's thickness, units, material, formulation and mesh size."""
    group.add_argument(
        "--thickness", type=float, metavar="M", help="sheet thickness, e.g. 0.8e-3 (--mesh, --cad)"
    )
    group.add_argument(
        "--scale",
        type=float,
        default=1.0,
        metavar="FACTOR",
        help="factor from the file's coordinates to metres: 1e-3 for a mesh in millimetres "
        "(STEP and IGES state their unit and are converted first)",
    )
    group.add_argument(
        "--material", default="steel", metavar="NAME", help="steel (default) or aluminium"
    )
    group.add_argument(
        "--E",
        dest="E_pa",
        type=float,
        metavar="PA",
        help="Young's modulus (others from --material)",
    )
    group.add_argument(
        "--nu", type=float, metavar="RATIO", help="Poisson ratio (others from --material)"
    )
    group.add_argument(
        "--rho",
        dest="rho_kg_m3",
        type=float,
        metavar="KG_M3",
        help="density, kg/m^3 (others from --material)",
    )
    group.add_argument(
        "--element",
        choices=ELEMENTS,
        help="formulation (default: morley for flat parts in a plane z = const, shell for "
        "curved and folded ones, hex2 for the panel scene and hexahedral meshes)",
    )
    group.add_argument(
        "--mesh-size",
        type=float,
        metavar="M",
        help="element size (--scene, --cad; default per element)",
    )


def _add_gripper(group) -> None:
    """Suction cups and other supports, and whether a free part is accepted."""
    group.add_argument(
        "--cups",
        nargs="+",
        type=_cup,
        metavar="X,Y[,Z],R",
        help="suction cups: centre x,y (the surface point above it) or x,y,z (the nearest "
        "surface point) and radius, in m (replaces the scene's)",
    )
    group.add_argument(
        "--cup-stiffness",
        default=None,
        metavar="KIND",
        help="compliant cups instead of rigid clamps: flat, bellows (presets of fem.cups) or "
        "A,L,T,R (axial N/m, lateral N/m, tilt N m/rad, torsion N m/rad)",
    )
    group.add_argument(
        "--point-supports",
        nargs="+",
        type=_pair,
        metavar="X,Y",
        default=[],
        help="pinned points x,y in m",
    )
    group.add_argument(
        "--clamped-edges",
        nargs="+",
        default=[],
        metavar="SIDE",
        choices=("all", "x0", "x1", "y0", "y1"),
        help="clamped sides",
    )
    group.add_argument(
        "--allow-rigid-modes",
        action="store_true",
        help="accept a part that is not held (free, or a gripper that leaves rigid-body "
        "modes): the rigid-body modes are reported and left out of the model (every source)",
    )


def _add_modes(group) -> None:
    """How many modes, their damping, and the points the model monitors."""
    group.add_argument(
        "--n-modes",
        type=int,
        metavar="N",
        help="number of modes (default 20, or all up to --max-freq)",
    )
    group.add_argument(
        "--max-freq", type=float, metavar="HZ", help="keep modes up to this frequency"
    )
    group.add_argument(
        "--zeta",
        type=_zeta,
        default=0.02,
        metavar="RATIO",
        help="damping ratio in [0, 1) (default 0.02 = 2 %%)",
    )
    group.add_argument(
        "--points",
        type=_points,
        default=None,
        metavar="all|N",
        help="monitored points: 'all' FE nodes (default: the deviation, settle time and "
        "distances cover the whole part) or a count (voxel-reduced: a smaller file and faster "
        "FMU steps, but only those points are checked)",
    )


def _add_outputs(group) -> None:
    """The model file and its pictures."""
    group.add_argument("--plot", metavar="PNG", help="picture of the part, cups and modes (.png)")
    group.add_argument(
        "--vtu", metavar="FILE", help="mode shapes for ParaView (.vtu, .vtk, .xdmf or .xmf)"
    )
    group.add_argument(
        "-o", "--output", default="model.npz", metavar="FILE", help="model file (.npz)"
    )


def _add_sizing_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group(
        "model sizing (--tolerance): choose the mesh, modes and points for a move; exit status "
        "1 if the tolerance was not met (the best model found is still written)"
    )
    group.add_argument(
        "--tolerance",
        type=_tolerance,
        metavar="SHARE",
        help="accuracy of the deviation (share of its peak) and of the settle time (share of "
        "the cycle time), e.g. 1%% or 0.01",
    )
    move = group.add_mutually_exclusive_group()
    move.add_argument(
        "--trajectory",
        metavar="CSV|DIR",
        help="the move: a trajectory CSV (jaxflex optimize -o DIR writes DIR/trajectory.csv)",
    )
    move.add_argument(
        "--distance",
        nargs=3,
        type=float,
        metavar=("X", "Y", "Z"),
        help="the move: jerk-limited straight move by this displacement, m",
    )
    add_axis_limits(group, with_defaults=False, condition="--distance: ")
    group.add_argument(
        "--dt",
        type=float,
        metavar="S",
        help=f"--distance: sample step in s (default {DT_S:g}); --from-r1: the R1 time step in s",
    )
    group.add_argument(
        "--threshold", type=float, metavar="M", help="settle threshold in m (e.g. 0.0005)"
    )
    group.add_argument(
        "--mesh-sizes",
        nargs="+",
        type=float,
        metavar="H",
        help="element sizes to try in m, coarse to fine (default: 4 ... 1/2 x the part's size "
        "in sqrt 2 steps; 4 ... 1 x for the thin solid)",
    )
    group.add_argument(
        "--max-modes",
        type=int,
        default=160,
        metavar="N",
        help="most modes to compute (default 160)",
    )
    group.add_argument(
        "--key-points",
        nargs="+",
        type=_pair,
        metavar="X,Y",
        help="points that must stay monitored (x,y in m on the part)",
    )
    group.add_argument(
        "--report", metavar="JSON", help="write the sizing report (or the R1 fit report) here"
    )


SIZING_ONLY = (
    "trajectory",
    "distance",
    "vmax",
    "amax",
    "jmax",
    "dt",
    "threshold",
    "mesh_sizes",
    "key_points",
    "report",
)


def _material(args):
    """The material of --material with the constants --E, --nu, --rho given replaced (those
    left out, and the yield strength unless all three are given, stay the named one's)."""
    given = {k: v for k in ("E_pa", "nu", "rho_kg_m3") if (v := getattr(args, k)) is not None}
    if not given:
        return args.material
    base = resolve_material(args.material)
    changed = ", ".join(f"{k.split('_')[0]} {v:g}" for k, v in given.items())
    if len(given) == 3:
        return {**given, "name": "custom"}
    return {
        "E_pa": base.E_pa,
        "nu": base.nu,
        "rho_kg_m3": base.rho_kg_m3,
        "yield_pa": base.yield_pa,
        **given,
        "name": f"{base.name} with {changed}",
    }


def _defaults() -> dict:
    """The command's option defaults (what an option left out gives)."""
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return vars(parser.parse_args(["--scene", "plate"]))


def _check_files(args: argparse.Namespace) -> None:
    """The outputs can be written and the inputs read: before any work (and before the
    finite-element modules load)."""
    for option, suffixes in (("plot", PICTURE_SUFFIXES), ("vtu", VIEW_SUFFIXES)):
        path = getattr(args, option)
        if path is not None and Path(path).suffix.lower() not in suffixes:
            ends = " or ".join(suffixes)
            raise InputError(f"--{option}: the file name must end in {ends}, got {path!r}")
    for option in ("output", "plot", "vtu", "report"):
        if getattr(args, option) is not None:
            check_output_file(f"--{option}", getattr(args, option))
    for option in ("mesh", "cad"):  # the imports' files: fem.imports.cli, after its options
        if getattr(args, option) is not None:
            check_input_file(f"--{option}", getattr(args, option))


# numbers checked at the door (before the FE modules load), by the field the errors name
POSITIVE = ("thickness", "scale", "E_pa", "rho_kg_m3", "mesh_size", "max_freq", "dt", "threshold")
COUNTS = ("n_modes", "max_modes")


def _check_numbers(args: argparse.Namespace) -> None:
    """Each given positive number finite and > 0, each count >= 1: InputError naming it."""
    for name in POSITIVE:
        if getattr(args, name, None) is not None:
            check_positive(name, getattr(args, name))
    for name in COUNTS:
        value = getattr(args, name, None)
        if value is not None and value < 1:
            raise InputError(f"{name}: must be an integer >= 1, got {value!r}")


def run(args: argparse.Namespace) -> int:
    _check_files(args)
    _check_numbers(args)
    if cli_imports.requested(args):
        return cli_imports.run(args, _defaults(), _write)
    cli_imports.refuse_import_options(args)
    material = _material(args)
    if args.scene and (args.thickness is not None or args.element is not None):
        raise InputError("--thickness/--element: only for --mesh and --cad (scenes are 1 mm steel)")
    supports = _supports(args, material)
    if not supports and not args.allow_rigid_modes:
        raise InputError(
            "--cups: a mesh or CAD part needs a gripper (--cups X,Y,R ...), or "
            "--allow-rigid-modes for the free part (its rigid-body modes are left out)"
        )
    if args.tolerance is not None:
        _check_sizing(args)
    else:
        for name in SIZING_ONLY:
            if getattr(args, name) is not None:
                raise InputError(f"--{name.replace('_', '-')}: only with --tolerance")
    return _model_from_store(args, material, supports)


def _n_modes(args) -> int | None:
    """--n-modes, 20 when neither it nor --max-freq is given."""
    return 20 if args.n_modes is None and args.max_freq is None else args.n_modes


def _part(args, material):
    """The part of --scene, --mesh or --cad."""
    if args.scene:
        from fem.scenes import scene

        return scene(args.scene, mesh_size=args.mesh_size, material=material)[0]
    return _read_part(args, material)


def _supports(args, material) -> list:
    """The gripper: the scene's or --cups (with --cup-stiffness), the point supports and the
    clamped edges."""
    from fem.supports import ClampedEdge, PointSupport, SuctionCup

    supports = []
    if args.scene:
        from fem.scenes import scene

        supports = scene(args.scene, mesh_size=args.mesh_size, material=material)[1]
    if args.cups is not None:
        supports = list(args.cups)
    if args.cup_stiffness is not None:
        spec = args.cup_stiffness
        stiffness = spec if spec in ("flat", "bellows") else spec.split(",")
        try:
            supports = [
                replace(s, stiffness=stiffness) if isinstance(s, SuctionCup) else s
                for s in supports
            ]
        except InputError as exc:
            raise InputError(f"--cup-stiffness: {exc}") from exc
    supports += [PointSupport(x, y) for x, y in args.point_supports]
    supports += [ClampedEdge(side) for side in args.clamped_edges]
    return supports


def _solve(args, part, supports):
    """(the model, the FE result) of the part on its supports, planned first; prints the
    result's summary and the coarse-mesh warnings."""
    from fem.mesh.plan import fe_plan, points_need
    from fem.mesh_advice import coarse_mesh_warnings
    from fem.modal import modal_analysis
    from jaxflex.runtime import require

    n_modes = _n_modes(args)
    plan = fe_plan(part, n_modes, supports)
    require(plan.need(), points_need(plan, args.points))  # before any meshing
    result = modal_analysis(
        part,
        supports,
        n_modes=n_modes,
        zeta=args.zeta,
        max_freq_hz=args.max_freq,
        allow_rigid_modes=args.allow_rigid_modes,
    )
    print(result.summary())
    for message in coarse_mesh_warnings(result):
        print(f"warning: {message}", file=sys.stderr)
    points = None if args.points in (None, "all") else args.points
    return result.to_modal_model(points=points), result


SIDE_FILES = ("plot", "vtu", "report")  # the command's other outputs, by option


def _model_from_store(args, material, supports) -> int:
    """Solve (or size) the part and write its model and the other files asked for (--plot,
    --vtu, --report), or copy them from the FE store where the same inputs were solved with
    this code (fem.model_store: no FE work, no JAX); the exit status (1: a tolerance not
    met, as the solve found it)."""
    from fem import model_store
    from jaxflex.files import atomic_open

    expected = model_store.fingerprint(
        n_modes=_n_modes(args) if args.max_freq is None and args.tolerance is None else None,
        n_points=None if args.points in (None, "all") else args.points,
        zeta=args.zeta,
        material=resolve_material(material).as_dict(),
        supports=supports,
        part=_part(args, material) if args.scene and args.tolerance is None else None,
        sized=args.tolerance is not None,
    )
    sides = {role: path for role in SIDE_FILES if (path := getattr(args, role))}

    def solve() -> tuple[bytes, str, dict[str, bytes]]:
        with _recorded() as output:
            model, result, sized = _solved_or_sized(args, material, supports)
        _write(args, model, result, sized)
        output["met"] = sized is None or sized.met
        files = {role: Path(path).read_bytes() for role, path in sides.items()}
        return Path(args.output).read_bytes(), json.dumps(output), files

    stored = model_store.model_file(_request(args, material, supports), expected, solve)
    output = json.loads(stored.output or '{"stdout": "", "warnings": [], "met": true}')
    if stored.from_store:
        print(
            f"FE model from the cache ({model_store.MODEL_STORE}: these inputs were solved "
            "before with this code; what that solve printed:)"
        )
        print(output["stdout"], end="")
        for line in output["warnings"]:
            print(line, file=sys.stderr)
        for role, data in {"output": stored.data, **stored.files}.items():
            with atomic_open(getattr(args, role), "wb") as handle:
                handle.write(data)
        fields = stored.fields
        print(
            f"wrote {args.output}: {len(fields['freq_hz'])} modes, {len(fields['points'])} "
            "points (SI units)"
        )
        for role in stored.files:
            print(f"wrote {getattr(args, role)}")
    if output.get("met", True):
        return 0
    print(
        f"jaxflex model: tolerance {100 * args.tolerance:g} % not met; the best model found "
        "was written (see the notes above)",
        file=sys.stderr,
    )
    return 1


def _request(args, material, supports) -> dict:
    """The store key's inputs: every option that changes what the command writes."""
    source = "scene" if args.scene else "mesh" if args.mesh else "cad"
    path = getattr(args, source)
    request = {
        "command": "model",
        "source": source,
        "scene": args.scene,
        "file": None if args.scene else [Path(path).suffix.lower(), file_digest(path)],
        **{k: getattr(args, k) for k in ("thickness", "scale", "element", "mesh_size")},
        "material": material,
        "supports": [support.describe() for support in supports],
        **{k: getattr(args, k) for k in ("allow_rigid_modes", "max_freq", "zeta", "points")},
        "n_modes": _n_modes(args),
        # the other files by kind (a picture's format follows its suffix), not by path
        "files": {
            role: Path(p).suffix.lower() for role in SIDE_FILES if (p := getattr(args, role))
        },
    }
    if args.tolerance is None:
        return request
    # every sizing option by value, the trajectory by its content, the report as a side file
    sizing = [k for k in SIZING_ONLY if k not in ("trajectory", "report")]
    trajectory = _trajectory_file(args)
    if trajectory:  # read only if it is a regular file (a FIFO would block the hash)
        trajectory = check_input_file("--trajectory", trajectory)
    return request | {
        **{k: getattr(args, k) for k in ("tolerance", "max_modes", *sizing)},
        "trajectory": trajectory and file_digest(trajectory),
    }


def _trajectory_file(args) -> Path | None:
    """The CSV of --trajectory (a file, or a result directory's trajectory.csv), or None."""
    if args.trajectory is None:
        return None
    path = Path(args.trajectory)
    return path / "trajectory.csv" if path.is_dir() else path


class _Tee(io.TextIOBase):
    """A text stream writing to ``stream`` and keeping what it wrote (its lines that hold
    ``only``, when given)."""

    def __init__(self, stream, only: str | None = None) -> None:
        self.stream, self.only, self.text = stream, only, []

    def write(self, text: str) -> int:
        self.stream.write(text)
        self.text.append(text)
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return self.stream.isatty()

    def kept(self) -> str:
        text = "".join(self.text)
        if self.only is None:
            return text
        return "".join(line for line in text.splitlines(True) if self.only in line)


@contextlib.contextmanager
def _recorded():
    """Record what a solve prints: stdout, and the warning lines of stderr (not its
    progress); yields a dict filled on exit: {"stdout": text, "warnings": [line, ...]}."""
    output: dict = {}
    out, err = _Tee(sys.stdout), _Tee(sys.stderr, "warning")
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            yield output
    finally:
        output["stdout"] = out.kept()
        output["warnings"] = err.kept().splitlines()


def _read_part(args, material):
    """The part of --mesh or --cad; prints what was read and the unit warnings."""
    from fem.parts import read_cad, read_mesh
    from fem.sanity import printed_part_warnings

    with printed_part_warnings():
        if args.mesh:
            if args.mesh_size is not None:
                raise InputError("--mesh-size: only for --scene and --cad (a mesh is used as is)")
            part = read_mesh(
                args.mesh,
                thickness=args.thickness,
                material=material,
                element=args.element,
                scale=args.scale,
            )
        else:
            if args.thickness is None:
                raise InputError("--thickness: required with --cad (sheet thickness in m)")
            part = read_cad(
                args.cad,
                args.thickness,
                material,
                args.mesh_size,
                element=args.element,
                scale=args.scale,
            )
        print(part.summary())
    return part


def _write(args, model, result, sized=None) -> None:
    """Write the model, its pictures and the sizing report (``sized``: fem.size_model's
    result) as the options ask."""
    from fem.export import export_modes, plot_part

    model.save(args.output)
    print(f"wrote {args.output}: {model.n_modes} modes, {model.n_points} points (SI units)")
    if args.plot:
        plot_part(result, args.plot)
        print(f"wrote {args.plot}")
    if args.vtu:
        export_modes(result, args.vtu)
        print(f"wrote {args.vtu}")
    if sized is not None and args.report:
        sized.save_report(args.report)
        print(f"wrote {args.report}")


def _move(args):
    """The Move at hand from --trajectory or --distance and the limits."""
    from jaxflex.files import read_trajectory_csv
    from jaxflex.response import jerk_limited_move

    for name, _unit, _default in AXIS_LIMITS:
        if getattr(args, name) is not None and args.distance is None:
            raise InputError(f"--{name}: only with --distance (a trajectory has its own limits)")
    limits = axis_limit_values(args)
    if args.trajectory is not None:
        if args.dt is not None:
            raise InputError("--dt: only with --distance (the trajectory file has its step)")
        return read_trajectory_csv(_trajectory_file(args))
    if args.distance is None:
        raise InputError("--tolerance: give the move, --trajectory FILE or --distance X Y Z")
    dt_s = DT_S if args.dt is None else args.dt
    return jerk_limited_move(args.distance, dt_s=dt_s, **limits)


def _threshold_advice(model, move: Move, threshold_m: float) -> None:
    """Warn about a --threshold the sized model cannot mean (jaxflex._advice)."""
    import numpy as np

    from jaxflex.response import analyze_move, deviation_curve
    from jaxflex.runtime import issue, model_resolution, threshold_advice

    _, deviation = deviation_curve(model, move, move.duration_s, 8)
    issue(
        threshold_advice(
            threshold_m,
            analyze_move(model, move, threshold_m=threshold_m).settle_time_s,
            float(np.max(deviation)),
            model_resolution(model, np.sum(np.abs(move.acc), axis=0)),
            name="--threshold",
            move=("the move", "the settle time is 0 and there is nothing to size the model for"),
        )
    )


def _check_sizing(args) -> None:
    """The sizing's options that no other option may accompany, before any work."""
    for name in ("n_modes", "max_freq", "points"):
        if getattr(args, name) is not None:
            raise InputError(
                f"--{name.replace('_', '-')}: chosen by --tolerance (use --max-modes, "
                "--key-points or --mesh-sizes to steer it)"
            )
    if args.threshold is None:
        raise InputError("--threshold: the settle threshold in m is required with --tolerance")
    if args.mesh is not None and args.mesh_sizes is not None:
        raise InputError("--mesh-sizes: a mesh file is used as is (a CAD part can be re-meshed)")


def _solved_or_sized(args, material, supports):
    """(model, FE result, fem.size_model's result or None): the part solved as the options
    say, or sized with --tolerance for the move; prints the summaries and the warnings."""
    part = _part(args, material)
    if args.tolerance is None:
        return (*_solve(args, part, supports), None)
    from fem.sizing.request import Accuracy
    from fem.sizing.run import size_model

    move = _move(args)
    sized = size_model(
        part,
        supports,
        move,
        args.threshold,
        Accuracy(
            args.tolerance,
            mesh_sizes_m=args.mesh_sizes,
            reference_modes=min(40, args.max_modes),
            max_modes=args.max_modes,
        ),
        zeta=args.zeta,
        key_points=args.key_points,
        allow_rigid_modes=args.allow_rigid_modes,
        log=print,
    )
    print(sized.summary())
    _threshold_advice(sized.model, move, args.threshold)
    return sized.model, sized.result, sized
