"""Built-in scenes for the rest of the project: a part with a sensible default gripper.

"plate": flat steel plate 1.5 m x 0.8 m x 1 mm (the preprint's fender footprint), Morley.
"panel": doubly curved steel panel on the same footprint (radii 2.5 m along x, 1.2 m along
         y), one-layer thin solid.
Both are held by four suction cups of 40 mm radius at 22 % / 78 % of width and height (near
the points that minimise the sag of a plate on four supports).

``default_model(..., cache=True)`` keeps the model in the store ``fe-models`` of jaxflex's
cache (fem.model_store), so a later run (``jaxflex demo``) loads it instead of solving again;
any change of arguments, code or library is a new key, and a stored model that is not the
scene's (its fingerprint: part, gripper, material, damping, modes, points) is a miss.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from fem import model_store
from fem.parts import Part, curved_panel, rectangular_plate
from fem.supports import SuctionCup
from jaxflex.errors import InputError

if TYPE_CHECKING:
    from jaxflex.model import ModalModel

SCENES = ("plate", "panel")
CUP_RADIUS_M = 0.04
CUP_FRACTIONS = (0.22, 0.78)


def default_gripper(width_m: float, height_m: float, radius_m: float = CUP_RADIUS_M) -> list:
    """Four suction cups at 22 % / 78 % of the width and height of the footprint."""
    return [
        SuctionCup(fx * width_m, fy * height_m, radius_m)
        for fx in CUP_FRACTIONS
        for fy in CUP_FRACTIONS
    ]


def scene(
    name: str = "plate", *, mesh_size: float | None = None, material="steel"
) -> tuple[Part, list]:
    """(part, supports) of a built-in scene ("plate" or "panel")."""
    if name == "plate":
        part = rectangular_plate(1.5, 0.8, 1e-3, material, mesh_size)
    elif name == "panel":
        part = curved_panel(1.5, 0.8, 1e-3, material, mesh_size)
    else:
        raise InputError(f"scene: must be one of {list(SCENES)}, got {name!r}")
    return part, default_gripper(1.5, 0.8)


def default_model(
    name: str = "plate",
    n_modes: int = 20,
    n_points: int | None = None,
    zeta=0.02,
    *,
    progress: bool | None = None,
    cache: bool = False,
) -> ModalModel:
    """Modal model of a built-in scene: ``n_modes`` modes at every FE node (or about
    ``n_points`` voxel-reduced points), damping ``zeta``. The plate takes ~1-2 s, the panel
    ~20 s; with ``cache`` a later call with the same arguments and code loads the model
    written by the first (module docstring)."""
    from fem.modal import modal_analysis
    from jaxflex.model import load_model

    part, supports = scene(name)

    def solve() -> ModalModel:
        result = modal_analysis(part, supports, n_modes=n_modes, zeta=zeta, progress=progress)
        return result.to_modal_model(points=n_points).with_meta(scene=name)

    if not cache:
        return solve()
    request = {"scene": name, "n_modes": n_modes, "n_points": n_points, "zeta": zeta}
    expected = model_store.fingerprint(
        n_modes=n_modes, n_points=n_points, zeta=zeta, supports=supports, part=part, scene=name
    )
    solved: list[ModalModel] = []

    def solved_file() -> tuple[bytes, str, dict[str, bytes]]:
        solved.append(solve())
        return _file_bytes(solved[0]), "", {}

    stored = model_store.model_file(request, expected, solved_file)
    if solved:
        return solved[0]
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "model.npz").write_bytes(stored.data)
        return load_model(Path(folder) / "model.npz")


def _file_bytes(model: ModalModel) -> bytes:
    """The bytes of ``model``'s file (ModalModel.save)."""
    with tempfile.TemporaryDirectory() as folder:
        model.save(Path(folder) / "model.npz")
        return (Path(folder) / "model.npz").read_bytes()
