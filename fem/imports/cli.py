"""``jaxflex model --from-ansys | --from-nastran | --from-r1 | --from-modes``: a modal model
from a user's own finite-element results (fem.from_ansys, fem.from_nastran, fem.from_r1,
fem.imports.from_modes); the sources and options that fem.cli adds to the ``model`` command, and
their run."""

from __future__ import annotations

import argparse
import io
import json
from collections.abc import Callable

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_input_file, read_text, write_text_atomic

SOURCES = ("from_ansys", "from_nastran", "from_r1", "from_modes")
IMPORT_ONLY = ("full", "nodes", "units", "gamma", "spc_id", "axis")
# options of the built-in and meshed parts, of sizing and of the imports: each import uses
# those ALLOWED names and refuses the others when they differ from their defaults
CHECKED = (
    *("thickness", "scale", "material", "E_pa", "nu", "rho_kg_m3", "mesh_size"),
    *("point_supports", "clamped_edges", "cups", "element", "allow_rigid_modes"),
    *("tolerance", "trajectory", "distance", "vmax", "amax", "jmax", "threshold"),
    *("mesh_sizes", "max_modes", "key_points", "n_modes", "max_freq", "dt", "report"),
    *IMPORT_ONLY,
)
ALLOWED = {
    "ansys": {"full", "nodes", "units", "gamma", "n_modes", "max_freq", "allow_rigid_modes"},
    "nastran": {"units", "spc_id", "cups", "element", "allow_rigid_modes", "n_modes", "max_freq"},
    "r1": {"nodes", "axis", "dt", "report", "n_modes", "allow_rigid_modes"},
    "modes": {"nodes", "units", "gamma", "n_modes", "max_freq", "allow_rigid_modes", "report"},
}


def add_sources(group) -> None:
    """The three import sources, in the model command's group of sources."""
    group.add_argument(
        "--from-ansys",
        metavar="FILE",
        help="MAPDL .full (modes computed here; coordinates from --nodes) or .rst (modes as "
        "MAPDL computed them; participation from --full or --gamma)",
    )
    group.add_argument(
        "--from-nastran",
        metavar="DECK",
        help="Nastran bulk-data deck solved by our models (shells, beams, springs, masses, "
        "rigid elements)",
    )
    group.add_argument(
        "--from-modes",
        metavar="FILE",
        help="modes another solver computed: Nastran OP2 (.op2) or punch (.pch), Universal "
        "File (.uff/.unv: datasets 55 modes, or 58 time responses to a unit hat, identified "
        "like R1); participation factors from the file or --gamma",
    )
    group.add_argument(
        "--from-r1",
        nargs="+",
        metavar="CSV",
        help="unit response R1 in the preprint's Table 2 layout (one file per --axis), "
        "identified as a modal model; needs --dt",
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options only the imports use (all default to None)."""
    group = parser.add_argument_group(
        "imported results (--from-ansys, --from-nastran, --from-r1, --from-modes)"
    )
    group.add_argument(
        "--full", metavar="FILE", help="--from-ansys .rst: the .full of the same model"
    )
    group.add_argument(
        "--nodes",
        metavar="FILE",
        help="node coordinates: --from-ansys .full: a .cdb, .rst or CSV node,x,y,z of the same "
        "mesh (file units); --from-r1: CSV x,y,z (or node,x,y,z) in m, one row per R1 row; "
        "--from-modes: CSV node,x,y,z (file units) or a result file of the same run",
    )
    group.add_argument(
        "--units",
        metavar="SYSTEM",
        help="unit system of ANSYS/Nastran files that state none (required for them): SI, MPA "
        "(mm, t, s), BIN (in, lbf s^2/in, s), BFT, CGS, UMKS",
    )
    group.add_argument(
        "--gamma",
        metavar="CSV",
        help="--from-ansys .rst, --from-modes: participation factors, one row x,y,z per kept "
        "mode in kg^0.5 (where the file holds none)",
    )
    group.add_argument(
        "--spc-id",
        type=int,
        metavar="ID",
        help="--from-nastran: the SPC set to use (default: the one case control selects, or "
        "the deck's only set)",
    )
    group.add_argument(
        "--axis",
        nargs="+",
        choices=("x", "y", "z"),
        help="--from-r1: the acceleration axis of each R1 file (default z)",
    )


def requested(args: argparse.Namespace) -> bool:
    return any(getattr(args, name) for name in SOURCES)


def refuse_import_options(args: argparse.Namespace) -> None:
    """For scenes and meshes: the import-only options are errors."""
    for name in IMPORT_ONLY:
        if getattr(args, name) is not None:
            raise InputError(
                f"--{name.replace('_', '-')}: only with --from-ansys/--from-nastran/--from-r1/"
                "--from-modes"
            )


def _check_options(args, source: str, defaults: dict) -> None:
    for name in CHECKED:
        if name not in ALLOWED[source] and getattr(args, name) != defaults[name]:
            raise InputError(f"--{name.replace('_', '-')}: not used with --from-{source}")


def _check_at_once(args: argparse.Namespace, defaults: dict) -> None:
    """The options of the chosen import, then its files: before the readers load."""
    source = next(name for name in SOURCES if getattr(args, name)).removeprefix("from_")
    _check_options(args, source, defaults)
    if source == "r1" and args.dt is None:
        raise InputError("--dt: the time step of the R1 file(s) in s is required")
    paths = args.from_r1 if source == "r1" else [getattr(args, f"from_{source}")]
    for path in paths:
        check_input_file(f"--from-{source}", path)
    for option in ("full", "gamma"):
        if getattr(args, option) is not None:
            check_input_file(f"--{option}", getattr(args, option))


def _read_gamma(path):
    text = read_text("--gamma", path)
    try:
        return np.loadtxt(io.StringIO(text), delimiter=",", ndmin=2)
    except ValueError as exc:
        raise InputError(f"--gamma: cannot read {path!r} as rows x,y,z ({exc})") from exc


def run(args: argparse.Namespace, defaults: dict, write: Callable) -> int:
    """Import, print the summary, write the model; ``defaults``: the command's option
    defaults; ``write(args, model, result)``: fem.cli's writer of a model solved here."""
    _check_at_once(args, defaults)
    from fem.sanity import printed_part_warnings  # the readers load after the checks

    n_modes = args.n_modes
    if n_modes is None and args.max_freq is None and not (args.from_r1 or args.from_modes):
        n_modes = 20
    with printed_part_warnings():  # unit slips, a thick part, laminates, model checks
        result, model = _imported(args, n_modes)
    if args.report and not hasattr(result, "fit"):
        raise InputError("--report: the identification report of R1 or of measured responses")
    if hasattr(result, "fit") and args.report:
        write_text_atomic(args.report, json.dumps(result.fit.as_dict(), indent=2))
        print(f"wrote {args.report}")
    if args.from_nastran:
        write(args, model, result)
        return 0
    if args.plot or args.vtu:
        raise InputError("--plot/--vtu: only for models solved here (scenes, meshes, decks)")
    model.save(args.output)
    print(f"wrote {args.output}: {model.n_modes} modes, {model.n_points} points (SI units)")
    return 0


def _imported(args: argparse.Namespace, n_modes):
    """(the import's result, its ModalModel at --points), the summary printed."""
    from fem.imports.ansys import from_ansys
    from fem.imports.from_modes import from_modes
    from fem.imports.nastran.door import from_nastran
    from fem.imports.r1 import from_r1

    if args.from_ansys:
        result = from_ansys(
            args.from_ansys,
            full=args.full,
            nodes=args.nodes,
            units=args.units,
            n_modes=n_modes,
            max_freq_hz=args.max_freq,
            gamma=None if args.gamma is None else _read_gamma(args.gamma),
            zeta=args.zeta,
            allow_rigid_modes=args.allow_rigid_modes,
        )
    elif args.from_modes:
        result = from_modes(
            args.from_modes,
            units=args.units,
            gamma=None if args.gamma is None else _read_gamma(args.gamma),
            nodes=args.nodes,
            n_modes=n_modes,
            max_freq_hz=args.max_freq,
            zeta=args.zeta,
            allow_rigid_modes=args.allow_rigid_modes,
        )
    elif args.from_nastran:
        result = from_nastran(
            args.from_nastran,
            units=args.units,
            cups=list(args.cups or []),
            spc_id=args.spc_id,
            element=args.element,
            n_modes=n_modes,
            max_freq_hz=args.max_freq,
            zeta=args.zeta,
            allow_rigid_modes=args.allow_rigid_modes,
        )
    else:
        result = from_r1(
            args.from_r1,
            args.dt,
            args.axis or ["z"],
            nodes=args.nodes,
            max_modes=n_modes,
            allow_rigid_modes=args.allow_rigid_modes,
        )
    print(result.summary())
    _print_provenance(result.provenance)
    points = None if args.points in (None, "all") else args.points
    identified = hasattr(result, "fit")  # R1 and measured responses: the identified damping
    zeta = None if identified else args.zeta
    return result, result.to_modal_model(points=points, zeta=zeta)


def _print_provenance(provenance: dict) -> None:
    """What an import found beyond its summary: mass normalisation, rigid-body modes, the
    missing static response."""
    derived = provenance.get("derived", {})
    if "mass_normalisation" in derived:
        print(f"mass normalisation: {derived['mass_normalisation']}")
    rigid = provenance.get("rigid_modes", {}).get("count", 0)
    if rigid:
        shown = ", ".join(f"{f:.3g}" for f in provenance["rigid_modes"].get("freq_hz", []))
        print(f"rigid-body modes kept out of the model: {rigid} ({shown} Hz)")
    if "static_response" in provenance:
        print(f"static response: {provenance['static_response']}")
