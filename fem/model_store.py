"""FE models solved once per input: the store ``fe-models`` of jaxflex's cache
(jaxflex.runtime.cache_store), used by ``fem.default_model(..., cache=True)`` (``jaxflex
demo``) and by ``jaxflex model`` for the parts it solves (``--scene``, ``--mesh``, ``--cad``).

An entry is a model file (.npz, as ``ModalModel.save`` writes it) and what its solve
printed (shown again when the entry is used: the part's summary, the FE result, the
warnings), under a key that hashes the request (every option that changes the model, the
input file's content), the source of
the ``fem`` and ``jaxflex`` packages and the versions of the libraries the FE solve uses, so
any change of input, code or library is a new key. Beyond the store's own checks (the
entry's key and content hash, jaxflex._compile_cache), a model read from it must match the
request's fingerprint (:func:`check_fingerprint`: the part, material, gripper, damping, the
number of modes and of points, the mesh's node count when every node is a point) or it is a
miss, solved again and replaced. Runs that want the same model at the same time solve it
once: the others wait for the entry.
"""

from __future__ import annotations

import functools
import hashlib
import json
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib.metadata import version
from importlib.util import find_spec
from pathlib import Path
from typing import Any

from jaxflex.files import read_model_file
from jaxflex.runtime import cache_fetch, cache_pack_text, cache_store, cache_unpack_text

MODEL_STORE = "fe-models"  # jaxflex.runtime.cache_store of the FE models
MODEL_STORE_BYTES = 1024**3
MODEL_ROLE = "model"  # the model file's role among an entry's files
SOLVER_LIBRARIES = ("numpy", "scipy", "scikit-fem", "meshio", "jax")


@functools.cache
def code_digest() -> str:
    """The hash of the ``fem`` and ``jaxflex`` sources and the FE libraries' versions."""
    digest = hashlib.sha256()
    for package in (Path(__file__).parent, Path(find_spec("jaxflex").origin).parent):
        for path in sorted(package.rglob("*.py")):
            relative = path.relative_to(package.parent).as_posix()
            digest.update(relative.encode() + b"\0" + path.read_bytes())
    digest.update(" ".join(version(lib) for lib in SOLVER_LIBRARIES).encode())
    return digest.hexdigest()


def model_key(request: dict[str, Any]) -> str:
    """The store key of a request (JSON-serialisable: every input that changes the model)."""
    text = json.dumps(request, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode() + b"\0" + code_digest().encode()).hexdigest()


def fingerprint(
    *,
    n_modes: int | None,
    n_points: int | None,
    zeta,
    material: dict | None = None,
    supports=None,
    part=None,
    scene: str | None = None,
    sized: bool = False,
) -> dict[str, Any]:
    """What a model of the request must show (the fields given): its number of modes (None:
    not fixed, e.g. up to a frequency), every FE node as a point (``n_points`` None, unless
    the points are ``sized``: chosen by fem.size_model; a count is voxel-reduced to about
    that many, checked by the key alone), damping, material
    (Material.as_dict), gripper (the supports) and part (fem.parts.Part), and the scene's
    name. Compared by :func:`check_fingerprint` with the model's meta as written (JSON)."""
    from fem.damping import describe_damping

    meta: dict[str, Any] = {"damping": describe_damping(zeta)}
    if material is not None:
        meta["material"] = material
    if supports is not None:
        meta["gripper"] = [support.describe() for support in supports]
    if part is not None:
        meta["part"] = part.describe()
    if scene is not None:
        meta["scene"] = scene
    every_node = n_points is None and not sized
    return {"n_modes": n_modes, "every_node": every_node, "meta": json.loads(json.dumps(meta))}


def check_fingerprint(fields: dict[str, Any], expected: dict[str, Any]) -> None:
    """ValueError naming what differs between a model file's ``fields`` (read_model_file)
    and the request's :func:`fingerprint`."""
    meta = fields["meta"]
    n_modes, n_points = len(fields["freq_hz"]), len(fields["points"])
    if expected["n_modes"] is not None and n_modes != expected["n_modes"]:
        raise ValueError(f"{n_modes} modes, not {expected['n_modes']}")
    nodes = (meta.get("mesh") or {}).get("n_nodes")
    if expected["every_node"] and n_points != nodes:
        raise ValueError(f"{n_points} points, not every one of the mesh's {nodes} nodes")
    if meta.get("n_points") != n_points:
        raise ValueError(f"{n_points} points, its meta says {meta.get('n_points')}")
    for name, value in expected["meta"].items():
        if meta.get(name) != value:
            raise ValueError(f"its {name} is {meta.get(name)!r}, not {value!r}")


@dataclass(frozen=True)
class StoredModel:
    """A model file of the store or just solved: its bytes, its fields (read_model_file;
    None when solved here), what the solve printed (``output``: the text a run that finds it
    in the store shows again), whether it came from the store, and the other files the solve
    wrote (``files``: their bytes by role, e.g. "plot", "vtu", "report")."""

    data: bytes
    fields: dict[str, Any] | None
    output: str
    from_store: bool
    files: dict[str, bytes] = field(default_factory=dict)


def model_file(
    request: dict[str, Any],
    expected: dict[str, Any],
    solve: Callable[[], tuple[bytes, str, dict[str, bytes]]],
) -> StoredModel:
    """The model file of ``request``: the store's entry if it matches the ``expected``
    fingerprint, else ``solve()`` -> (the bytes of the solved model's file, what the solve
    printed, the bytes of the other files it wrote by role), stored. Without a store
    (cache off) always solved."""
    models = cache_store(MODEL_STORE, MODEL_STORE_BYTES)

    def matching(entry: bytes) -> StoredModel:
        output, files = _unpacked(entry)
        data = files.pop(MODEL_ROLE)
        fields = model_fields(data)
        check_fingerprint(fields, expected)
        return StoredModel(data, fields, output, True, files)

    def solved() -> tuple[StoredModel, bytes]:
        data, output, files = solve()
        return StoredModel(data, None, output, False, files), _packed(output, data, files)

    return cache_fetch(models, model_key(request), solved, matching, "FE model")[0]


def _packed(output: str, data: bytes, files: dict[str, bytes]) -> bytes:
    """An entry: a JSON header (what the solve printed, each file's role and size) and the
    files one after the other, the model first."""
    parts = {MODEL_ROLE: data, **files}
    header = {"output": output, "sizes": [[role, len(value)] for role, value in parts.items()]}
    return cache_pack_text(json.dumps(header), b"".join(parts.values()))


def _unpacked(entry: bytes) -> tuple[str, dict[str, bytes]]:
    """(what the solve printed, the files by role) of a :func:`_packed` entry; ValueError if
    it is not one."""
    text, blob = cache_unpack_text(entry)
    try:
        header = json.loads(text)
        sizes = [(str(role), int(size)) for role, size in header["sizes"]]
        output = str(header["output"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"not a model entry ({exc})") from exc
    if sum(size for _, size in sizes) != len(blob) or not sizes or sizes[0][0] != MODEL_ROLE:
        raise ValueError("not a model entry (its files' sizes)")
    files, start = {}, 0
    for role, size in sizes:
        files[role], start = blob[start : start + size], start + size
    return output, files


def model_fields(data: bytes) -> dict[str, Any]:
    """The fields of the model file ``data`` (read_model_file, no JAX); ValueError if it is
    not a model file."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "model.npz"
        path.write_bytes(data)
        try:
            return read_model_file(path)
        except Exception as exc:
            raise ValueError(f"not a model file ({exc})") from exc
