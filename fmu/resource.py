"""The FMU resource file ``resources/jaxflex_model.bin``: model data and trajectory.

Format version 1, little-endian throughout (read by ``fmu/c/jxf_core.c``):

    offset  type       content
    0       char[8]    magic "JXFLXFMU"
    8       u32        format version (1)
    12      u32        header size in bytes (128)
    16      char[64]   instantiation token (the GUID of modelDescription.xml), NUL padded
    80      u32 x 4    K points, M modes, N trajectory samples, 0
    96      f64        trajectory sample step in s (0 without a trajectory)
    104     u64        payload size in bytes
    112     16 zero bytes
    128     f64 payload: freq_hz (M) Hz, zeta (M), gamma (M, 3) kg^0.5,
                         shapes (M, 3, K) m/kg^0.5 (all x rows, then y, then z),
                         points (K, 3) m, trajectory (N, 3) m/s^2
    end     u32 CRC-32 (zlib) of everything before it, u32 0
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import ModelFileError
from jaxflex.model import ModalModel

MAGIC = b"JXFLXFMU"
FORMAT_VERSION = 1
_HEADER = struct.Struct("<8sII64sIIIIdQ16x")
_TRAILER = struct.Struct("<II")
TOKEN_BYTES = 64


@dataclass(frozen=True)
class ResourceData:
    """Contents of a resource file. ``acc`` is (N, 3) m/s^2 at step ``dt_s`` or None."""

    token: str
    model: ModalModel
    acc: np.ndarray | None
    dt_s: float | None


def encode_resource(
    model: ModalModel, token: str, acc: np.ndarray | None = None, dt_s: float | None = None
) -> bytes:
    """The resource file for ``model`` (and the trajectory ``acc`` sampled at ``dt_s``)."""
    raw_token = token.encode("ascii")
    if len(raw_token) >= TOKEN_BYTES:
        raise ValueError(f"token: at most {TOKEN_BYTES - 1} ASCII characters, got {token!r}")
    n_traj = 0 if acc is None else int(np.shape(acc)[0])
    parts = [
        np.asarray(model.freq_hz, "<f8"),
        np.asarray(model.zeta, "<f8"),
        np.asarray(model.gamma, "<f8"),
        np.transpose(np.asarray(model.shapes, "<f8"), (2, 1, 0)),
        np.asarray(model.points, "<f8"),
    ]
    if acc is not None:
        parts.append(np.asarray(acc, "<f8"))
    payload = b"".join(np.ascontiguousarray(p).tobytes() for p in parts)
    header = _HEADER.pack(
        MAGIC,
        FORMAT_VERSION,
        _HEADER.size,
        raw_token,
        model.n_points,
        model.n_modes,
        n_traj,
        0,
        float(dt_s) if acc is not None else 0.0,
        len(payload),
    )
    body = header + payload
    return body + _TRAILER.pack(zlib.crc32(body), 0)


def decode_resource(data: bytes, *, source: str = "resource") -> ResourceData:
    """Parse and check a resource file; raises ModelFileError naming what is wrong."""
    if len(data) < _HEADER.size + _TRAILER.size or data[:8] != MAGIC:
        raise ModelFileError(f"{source}: not a jaxflex FMU resource (bad magic or too short)")
    _, version, header_size, raw_token, k, m, n, _pad, dt_s, payload = _HEADER.unpack_from(data)
    if version != FORMAT_VERSION or header_size != _HEADER.size:
        raise ModelFileError(
            f"{source}: format version {version} is not supported (reads {FORMAT_VERSION})"
        )
    expected = 8 * (5 * m + 3 * m * k + 3 * k + 3 * n)
    if payload != expected or len(data) != _HEADER.size + expected + _TRAILER.size:
        raise ModelFileError(f"{source}: truncated or padded ({len(data)} bytes)")
    crc, _ = _TRAILER.unpack_from(data, len(data) - _TRAILER.size)
    if zlib.crc32(data[: -_TRAILER.size]) != crc:
        raise ModelFileError(f"{source}: corrupt (CRC-32 mismatch)")
    values = np.frombuffer(data, "<f8", count=expected // 8, offset=_HEADER.size)
    sizes = [m, m, 3 * m, 3 * m * k, 3 * k, 3 * n]
    freq, zeta, gamma, shapes, points, traj = np.split(values, np.cumsum(sizes)[:-1])
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
    )
