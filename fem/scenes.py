"""Built-in scenes for the rest of the project: a part with a sensible default gripper.

"plate": flat steel plate 1.5 m x 0.8 m x 1 mm (the preprint's fender footprint), Morley.
"panel": doubly curved steel panel on the same footprint (radii 2.5 m along x, 1.2 m along
         y), one-layer thin solid.
Both are held by four suction cups of 40 mm radius at 22 % / 78 % of width and height (near
the points that minimise the sag of a plate on four supports).

``default_model(..., cache=True)`` keeps the model in the store ``fe-models`` of jaxflex's
cache (jaxflex.runtime.cache_store) under a key that hashes the arguments, the source of the
``fem`` and ``jaxflex`` packages and the versions of the libraries the FE solve uses, so a
later run (``jaxflex demo``) loads it instead of solving again; any change of code or library
is a new key.
"""

from __future__ import annotations

import functools
import hashlib
import tempfile
from importlib.metadata import version
from importlib.util import find_spec
from pathlib import Path

from fem.modal import modal_analysis
from fem.parts import Part, curved_panel, rectangular_plate
from fem.supports import SuctionCup
from jaxflex.errors import InputError
from jaxflex.model import ModalModel, load_model
from jaxflex.runtime import cache_store

SCENES = ("plate", "panel")
MODEL_STORE = "fe-models"  # jaxflex.runtime.cache_store of the built-in scenes' models
MODEL_STORE_BYTES = 1024**3
SOLVER_LIBRARIES = ("numpy", "scipy", "scikit-fem", "meshio", "jax")
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
    models = cache_store(MODEL_STORE, MODEL_STORE_BYTES) if cache else None
    key = _model_key(name, n_modes, n_points, zeta)
    if models is not None and (entry := models.get(key)) is not None:
        model = _model_from_bytes(entry)
        if model is not None:
            return model
    part, supports = scene(name)
    result = modal_analysis(part, supports, n_modes=n_modes, zeta=zeta, progress=progress)
    model = result.to_modal_model(points=n_points).with_meta(scene=name)
    if models is not None:
        with tempfile.TemporaryDirectory() as folder:
            model.save(Path(folder) / "model.npz")
            models.put(key, (Path(folder) / "model.npz").read_bytes())
    return model


@functools.cache
def _code_digest() -> str:
    """The hash of the ``fem`` and ``jaxflex`` sources and the FE libraries' versions."""
    digest = hashlib.sha256()
    for package in (Path(__file__).parent, Path(find_spec("jaxflex").origin).parent):
        for path in sorted(package.rglob("*.py")):
            digest.update(path.name.encode() + b"\0" + path.read_bytes())
    digest.update(" ".join(version(lib) for lib in SOLVER_LIBRARIES).encode())
    return digest.hexdigest()


def _model_key(name: str, n_modes: int, n_points, zeta) -> str:
    """The store key of a built-in scene's model."""
    arguments = repr((name, n_modes, n_points, zeta)).encode()
    return hashlib.sha256(arguments + _code_digest().encode()).hexdigest()


def _model_from_bytes(entry: bytes) -> ModalModel | None:
    """The model of a store entry, None if it cannot be read (a miss: solved again)."""
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "model.npz").write_bytes(entry)
        try:
            return load_model(Path(folder) / "model.npz")
        except Exception:  # a damaged entry is a miss, replaced after the solve
            return None
