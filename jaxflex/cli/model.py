"""``jaxflex model``: part + gripper -> finite-element modal analysis -> modal model file."""

from __future__ import annotations

import argparse

COMMAND = "model"
HELP = "build a modal model (.npz) from a built-in scene or a mesh file (SI units, m)"
ORDER = 10


def _triple(text: str) -> tuple[float, float, float]:
    parts = text.split(",")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected X,Y,R in m (e.g. 0.3,0.2,0.04), got {text!r}")
    try:
        return tuple(float(p) for p in parts)  # type: ignore[return-value]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected numbers X,Y,R in m, got {text!r}") from exc


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
        return int(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a count or 'all', got {text!r}") from exc


def add_arguments(parser: argparse.ArgumentParser) -> None:
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--scene", choices=("plate", "panel"), help="built-in part and gripper")
    src.add_argument("--mesh", metavar="FILE", help="mesh file read by meshio (coordinates in m)")
    parser.add_argument("--thickness", type=float, help="sheet thickness in m (mesh files)")
    parser.add_argument(
        "--scale",
        type=float,
        default=1.0,
        help="factor to metres for mesh coordinates (1e-3 for mm)",
    )
    parser.add_argument("--material", default="steel", help="steel (default) or aluminium")
    parser.add_argument("--E", dest="E_pa", type=float, help="Young's modulus in Pa")
    parser.add_argument("--nu", type=float, help="Poisson ratio")
    parser.add_argument("--rho", dest="rho_kg_m3", type=float, help="density in kg/m^3")
    parser.add_argument(
        "--element",
        choices=("morley", "argyris", "hex2"),
        help="formulation (default: morley for flat, hex2 for curved parts)",
    )
    parser.add_argument("--mesh-size", type=float, help="element size in m (built-in scenes)")
    parser.add_argument(
        "--cups",
        nargs="+",
        type=_triple,
        metavar="X,Y,R",
        help="suction cups: centre x,y and radius in m (replaces the scene's)",
    )
    parser.add_argument(
        "--point-supports",
        nargs="+",
        type=_pair,
        metavar="X,Y",
        default=[],
        help="pinned points x,y in m",
    )
    parser.add_argument(
        "--clamped-edges",
        nargs="+",
        default=[],
        metavar="SIDE",
        choices=("all", "x0", "x1", "y0", "y1"),
        help="clamped sides",
    )
    parser.add_argument(
        "--allow-rigid-modes",
        action="store_true",
        help="accept a gripper that leaves rigid-body modes (they are dropped)",
    )
    parser.add_argument(
        "--n-modes", type=int, help="number of modes (default 20, or all up to --max-freq)"
    )
    parser.add_argument("--max-freq", type=float, help="keep modes up to this frequency in Hz")
    parser.add_argument("--zeta", type=float, default=0.02, help="damping ratio (default 0.02)")
    parser.add_argument(
        "--points",
        type=_points,
        default=1000,
        help="monitored points: a count (voxel-reduced, default 1000) or 'all'",
    )
    parser.add_argument("--plot", metavar="PNG", help="picture of the part, cups and modes")
    parser.add_argument("--vtu", metavar="FILE", help="mode shapes for ParaView (.vtu/.xdmf)")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")
    parser.add_argument("-o", "--output", default="model.npz", help="model file (.npz)")


def _material(args):
    given = {k: getattr(args, k) for k in ("E_pa", "nu", "rho_kg_m3")}
    if any(v is not None for v in given.values()):
        return {**given, "name": "custom"}
    return args.material


def run(args: argparse.Namespace) -> int:
    import fem
    from jaxflex.errors import InputError

    material = _material(args)
    if args.scene:
        if args.thickness is not None or args.element is not None:
            raise InputError("--thickness/--element: only for --mesh (scenes are 1 mm steel)")
        part, supports = fem.scene(args.scene, mesh_size=args.mesh_size, material=material)
    else:
        if args.mesh_size is not None:
            raise InputError("--mesh-size: only for --scene (a mesh file is used as is)")
        part = fem.read_mesh(
            args.mesh,
            thickness=args.thickness,
            material=material,
            element=args.element,
            scale=args.scale,
        )
        supports = []
    if args.cups is not None:
        supports = [fem.SuctionCup(x, y, r) for x, y, r in args.cups]
    supports += [fem.PointSupport(x, y) for x, y in args.point_supports]
    supports += [fem.ClampedEdge(side) for side in args.clamped_edges]
    if not supports:
        raise InputError("--cups: a mesh file needs a gripper (--cups X,Y,R ...)")
    n_modes = args.n_modes
    if n_modes is None and args.max_freq is None:
        n_modes = 20
    result = fem.modal_analysis(
        part,
        supports,
        n_modes=n_modes,
        zeta=args.zeta,
        max_freq_hz=args.max_freq,
        allow_rigid_modes=args.allow_rigid_modes,
        progress=False if args.no_progress else None,
    )
    print(result.summary())
    model = result.to_modal_model(points=None if args.points == "all" else args.points)
    model.save(args.output)
    print(f"wrote {args.output}: {model.n_modes} modes, {model.n_points} points (SI units)")
    if args.plot:
        fem.plot_part(result, args.plot)
        print(f"wrote {args.plot}")
    if args.vtu:
        fem.export_modes(result, args.vtu)
        print(f"wrote {args.vtu}")
    return 0
