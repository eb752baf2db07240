"""The FMU resource file ``resources/jaxflex_model.bin``: model data and trajectory.

Format version 2, little-endian throughout (read by ``fmu/c/jxf_core.c``):

    offset  type       content
    0       char[8]    magic "JXFLXFMU"
    8       u32        format version (2)
    12      u32        header size in bytes (128)
    16      char[64]   instantiation token (the GUID of modelDescription.xml), NUL padded
    80      u32 x 4    K points, M modes, N trajectory samples, C cups
    96      f64        trajectory sample step in s (0 without a trajectory)
    104     u64        payload size in bytes
    112     u32 x 2    S stress points, O obstacle records; then 8 zero bytes
    128     f64 payload: freq_hz (M) Hz, zeta (M), gamma (M, 3) kg^0.5,
                         shapes (M, 3, K) m/kg^0.5 (all x rows, then y, then z),
                         points (K, 3) m, trajectory (N, 3) m/s^2; then, when C + S + O > 0,
                         the cell (:class:`CellData`): gravity (3) m/s^2, cup safety factor;
                         cups: normals (C, 3), radii (C) m, holding forces (C) N,
                         friction (C), reaction maps Q, V (6C, M) and A (6C, 3);
                         stresses: Q, V (6S, M), A (6S, 3) Pa; obstacles: the points at rest
                         under gravity (K, 3) m and the records (O, 16) of
                         :func:`obstacle_records`
    end     u32 CRC-32 (zlib) of everything before it, u32 0

Version 1 (no cell; 0 in the counts C, S, O) is version 2 without the cell part.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np

from jaxflex.cell import Box, HalfSpace
from jaxflex.collision import gravity_offset
from jaxflex.errors import InputError, ModelFileError
from jaxflex.model import ModalModel

MAGIC = b"JXFLXFMU"
FORMAT_VERSION = 2
# magic, version, header bytes, token, K, M, N, C, dt_s, payload bytes, S, O (jxf_core.c)
HEADER = struct.Struct("<8sII64sIIIIdQII8x")
_TRAILER = struct.Struct("<II")
TOKEN_BYTES = 64
# the sample steps (s) an embedded trajectory may have (JXF_TRAJ_DT_MIN/MAX in jxf_core.c):
# finer than a microsecond or coarser than a quarter of an hour is no robot move's sampling
TRAJECTORY_STEP_RANGE_S = (1e-6, 1e3)


@dataclass(frozen=True)
class CellData:
    """What the FMU needs for the cell's outputs: ``gravity_m_s2`` (3,) in the model's frame,
    the cups' ``cup_safety`` factor, ``obstacles`` (O, 16) records, and whether to include the
    model's cups and stresses."""

    gravity_m_s2: np.ndarray
    cup_safety: float
    obstacles: np.ndarray
    cups: bool = True
    stress: bool = True


def obstacle_records(obstacles) -> np.ndarray:
    """(O, 16) records of jaxflex.cell obstacles: type 1 box (centre, half edges, rotation
    row-major), type 2 half-space (normal, offset), type 3 triangle (its corners), one per
    triangle of a mesh."""
    rows = []
    for o in obstacles:
        if isinstance(o, Box):
            rows.append([1, *o.centre_m, *(o.size_m / 2), *o.rotation.ravel()])
        elif isinstance(o, HalfSpace):
            rows.append([2, *o.normal, o.offset_m] + [0.0] * 11)
        else:
            rows.extend([3, *corners.ravel()] + [0.0] * 6 for corners in o.vertices[o.triangles])
    return np.array(rows, dtype=np.float64).reshape(-1, 16)


def _cell_parts(model: ModalModel, cell: CellData) -> tuple[list[np.ndarray], tuple[int, int, int]]:
    """The cell part of the payload and the counts (C, S, O)."""
    cups = model.cups if cell.cups else None
    stress = model.stress if cell.stress else None
    if cups is None and stress is None and len(cell.obstacles) == 0:
        return [], (0, 0, 0)
    parts = [np.asarray(cell.gravity_m_s2, "<f8"), np.array([cell.cup_safety], "<f8")]
    if cups is not None:
        r = cups.reaction
        parts += [
            np.asarray(cups.normal, "<f8"),
            np.asarray(cups.radius_m, "<f8"),
            np.asarray(cups.holding_force_n, "<f8"),
            np.asarray(cups.friction, "<f8"),
            np.asarray(r.q_map, "<f8"),
            np.asarray(r.v_map, "<f8"),
            np.asarray(r.a_map, "<f8"),
        ]
    if stress is not None:
        parts += [np.asarray(getattr(stress.stress, k), "<f8") for k in ("q_map", "v_map", "a_map")]
    if len(cell.obstacles):
        rest = np.asarray(model.points) + gravity_offset(model, cell.gravity_m_s2)
        parts += [np.asarray(rest, "<f8"), np.asarray(cell.obstacles, "<f8")]
    counts = (
        0 if cups is None else cups.n_cups,
        0 if stress is None else stress.n_points,
        len(cell.obstacles),
    )
    return parts, counts


@dataclass(frozen=True)
class ResourceData:
    """Contents of a resource file. ``acc`` is (N, 3) m/s^2 at step ``dt_s`` or None;
    ``counts``: (C cups, S stress points, O obstacle records) of the cell part."""

    token: str
    model: ModalModel
    acc: np.ndarray | None
    dt_s: float | None
    counts: tuple[int, int, int] = (0, 0, 0)


def check_trajectory_step(dt_s, error: type[Exception], source: str) -> None:
    """``error`` naming ``source`` unless the trajectory's sample step ``dt_s`` lies in
    TRAJECTORY_STEP_RANGE_S (the FMU's C checks the same when it loads the resource)."""
    low, high = TRAJECTORY_STEP_RANGE_S
    if not low <= dt_s <= high:
        raise error(
            f"{source}: trajectory sample step {dt_s!r} s; the FMU replays steps of {low:g} ... "
            f"{high:g} s"
        )


def encode_resource(
    model: ModalModel,
    token: str,
    acc: np.ndarray | None = None,
    dt_s: float | None = None,
    cell: CellData | None = None,
) -> bytes:
    """The resource file for ``model`` (and the trajectory ``acc`` sampled at ``dt_s``, and
    the ``cell``'s outputs)."""
    raw_token = token.encode("ascii")
    if len(raw_token) >= TOKEN_BYTES:
        raise ValueError(f"token: at most {TOKEN_BYTES - 1} ASCII characters, got {token!r}")
    if acc is not None:
        check_trajectory_step(dt_s, InputError, "trajectory")
    n_traj = 0 if acc is None else int(np.shape(acc)[0])
    extra, counts = _cell_parts(model, cell) if cell is not None else ([], (0, 0, 0))
    parts = [
        np.asarray(model.freq_hz, "<f8"),
        np.asarray(model.zeta, "<f8"),
        np.asarray(model.gamma, "<f8"),
        np.transpose(np.asarray(model.shapes, "<f8"), (2, 1, 0)),
        np.asarray(model.points, "<f8"),
    ]
    if acc is not None:
        parts.append(np.asarray(acc, "<f8"))
    parts += extra
    payload = b"".join(np.ascontiguousarray(p).tobytes() for p in parts)
    header = HEADER.pack(
        MAGIC,
        FORMAT_VERSION,
        HEADER.size,
        raw_token,
        model.n_points,
        model.n_modes,
        n_traj,
        counts[0],
        float(dt_s) if acc is not None else 0.0,
        len(payload),
        counts[1],
        counts[2],
    )
    body = header + payload
    return body + _TRAILER.pack(zlib.crc32(body), 0)


def decode_resource(data: bytes, *, source: str = "resource") -> ResourceData:
    """Parse and check a resource file; raises ModelFileError naming what is wrong."""
    if len(data) < HEADER.size + _TRAILER.size or data[:8] != MAGIC:
        raise ModelFileError(f"{source}: not a jaxflex FMU resource (bad magic or too short)")
    _, version, header_size, raw_token, k, m, n, c, dt_s, payload, s, o = HEADER.unpack_from(data)
    if version != FORMAT_VERSION or header_size != HEADER.size:
        raise ModelFileError(
            f"{source}: format version {version} is not supported (reads {FORMAT_VERSION}, as "
            "the FMU's binaries do)"
        )
    cell_values = 4 * (c + s + o > 0) + (6 * c + 12 * c * m + 18 * c) + (12 * s * m + 18 * s)
    cell_values += (3 * k + 16 * o) if o else 0
    expected = 8 * (5 * m + 3 * m * k + 3 * k + 3 * n + cell_values)
    if payload != expected or len(data) != HEADER.size + expected + _TRAILER.size:
        raise ModelFileError(f"{source}: truncated or padded ({len(data)} bytes)")
    crc, _ = _TRAILER.unpack_from(data, len(data) - _TRAILER.size)
    if zlib.crc32(data[: -_TRAILER.size]) != crc:
        raise ModelFileError(f"{source}: corrupt (CRC-32 mismatch)")
    if n:
        check_trajectory_step(dt_s, ModelFileError, source)
    elif dt_s != 0.0:
        raise ModelFileError(f"{source}: no trajectory but a sample step of {dt_s!r} s (need 0)")
    values = np.frombuffer(data, "<f8", count=expected // 8, offset=HEADER.size)
    sizes = [m, m, 3 * m, 3 * m * k, 3 * k, 3 * n]
    freq, zeta, gamma, shapes, points, traj = np.split(values[: sum(sizes)], np.cumsum(sizes)[:-1])
    model = ModalModel(
        freq_hz=freq,
        zeta=zeta,
        gamma=gamma.reshape(m, 3),
        shapes=np.transpose(shapes.reshape(m, 3, k), (2, 1, 0)),
        points=points.reshape(k, 3),
    )
    acc = traj.reshape(n, 3).copy() if n else None
    return ResourceData(
        token=raw_token.rstrip(b"\0").decode("ascii"),
        model=model,
        acc=acc,
        dt_s=float(dt_s) if n else None,
        counts=(c, s, o),
    )
