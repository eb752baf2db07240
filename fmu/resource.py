"""The FMU resource file ``resources/jaxflex_model.bin``: model data and trajectory.

Format version 3, little-endian throughout (read by ``fmu/c/jxf_core.c``):

    offset  type       content
    0       char[8]    magic "JXFLXFMU"
    8       u32        format version (3)
    12      u32        header size in bytes (128)
    16      char[64]   instantiation token (the GUID of modelDescription.xml), NUL padded
    80      u32 x 4    K points, M modes, N trajectory samples, C cups
    96      f64        trajectory sample step in s (0 without a trajectory)
    104     u64        payload size in bytes
    112     u32 x 4    S stress points, O obstacle records, R static-residual coordinates
                       (3 where the model has a static residual, 12 for a turning part
                       that has the rotational one too, else 0), T turning (1: the
                       part takes the pose as inputs, else 0; zero bytes before turning parts)
    128     f64 payload: freq_hz (M) Hz, zeta (M), gamma (M, 3) kg^0.5,
                         shapes (M + R, 3, K) m/kg^0.5 (all x rows, then y, then z; the
                         last R "modes" are the static residual D, m per m/s^2, whose
                         coordinates are the base acceleration: u = Phi q + D a; for
                         R = 12 then D_rot, m s^2, whose coordinates are the rotational
                         load coefficients b: + D_rot b, jaxflex._rotation_residual),
                         points (K, 3) m, trajectory (N, 3) m/s^2; then, when C + S + O > 0,
                         the cell (:class:`CellData`): gravity (3) m/s^2, cup safety factor,
                         half the part's thickness (m); cups: normals (C, 3), radii (C) m,
                         holding forces (C) N, friction (C), reaction maps Q, V (6C, M),
                         A (6C, 3) and the reactions at rest under gravity (6C) N, N m;
                         stresses: Q, V (6S, M), A (6S, 3), at rest (6S) Pa; obstacles: the
                         points at rest under gravity (K, 3) m and the records (O, 16) of
                         :func:`fmu.obstacles.obstacle_records`; then, when T = 1, the
                         turning part (:class:`TurningData`): the inertia shape integrals
                         S (M, 3, 3) kg^0.5 m (jaxflex._rotation), the pivot (3) m in the
                         model frame, gravity (3) m/s^2 in world components, the
                         embedded move's poses (N, 10: :func:`pose_samples`) and the maps
                         A_rot (jaxflex.response.output_residual) of the cups
                         (6C, 9) and stresses (6S, 9); a turning part's cell has no rest
                         terms (zeros: its state carries the sag)
    end     u32 CRC-32 (zlib) of everything before it, u32 0

The outputs are y = Q q + V v + A a + y_rest (jaxflex._outputs: y_rest = -S g, exact), the
distance that of the part's skins (the mid-surface's less half the thickness).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from fmu.obstacles import RECORD_VALUES, allowed_kinds, unknown_codes
from jaxflex.errors import InputError, ModelFileError
from jaxflex.geometry import gravity_offset
from jaxflex.model import ModalModel
from jaxflex.response import Move, as_move, output_residual, rotation_residual

MAGIC = b"JXFLXFMU"
FORMAT_VERSION = 3
# magic, version, header bytes, token, K, M, N, C, dt_s, payload bytes, S, O, R, T (jxf_core.c)
HEADER = struct.Struct("<8sII64sIIIIdQIIII")
_TRAILER = struct.Struct("<II")
TOKEN_BYTES = 64
# the sample steps (s) an embedded trajectory may have (JXF_TRAJ_DT_MIN/MAX in jxf_core.c):
# finer than a microsecond or coarser than a quarter of an hour is no robot move's sampling
TRAJECTORY_STEP_RANGE_S = (1e-6, 1e3)


@dataclass(frozen=True)
class Counts:
    """The sizes of one export, stated once for the resource header, ``jxf_config.h``,
    modelDescription.xml and the export's result: K ``points``, M ``modes``, N
    ``trajectory`` samples, C ``cups``, S ``stress`` points, O ``obstacles`` records and R
    ``static``-residual coordinates (3 or 0)."""

    points: int
    modes: int
    trajectory: int = 0
    cups: int = 0
    stress: int = 0
    obstacles: int = 0
    static: int = 0
    turning: int = 0

    def available(self) -> frozenset[str]:
        """Which optional groups of the cell's variables ("cups", "stress", "obstacles")
        exist."""
        groups = (("cups", self.cups), ("stress", self.stress), ("obstacles", self.obstacles))
        return frozenset(name for name, count in groups if count > 0)

    def variable_groups(self) -> frozenset[str]:
        """Every optional group of variables that exists: :meth:`available` and "turning"
        (the pose inputs)."""
        return self.available() | ({"turning"} if self.turning else set())


@dataclass(frozen=True)
class TurningData:
    """What a turning part's FMU needs besides the model (the forcing of jaxflex._turning):
    the ``pivot_m`` (3,) m in the model frame, whose world acceleration the inputs ax, ay, az
    are, and ``gravity_m_s2`` (3,) in world components; with an embedded move its poses
    ``pose_samples`` (N, 10) (:func:`pose_samples`, at the trajectory's samples). The
    inertia shape integrals come from the model's rotation data."""

    pivot_m: np.ndarray
    gravity_m_s2: np.ndarray
    pose_samples: np.ndarray | None = None

    def pose_count(self) -> int:
        """The embedded poses' samples (N of the trajectory, or 0 without one)."""
        return 0 if self.pose_samples is None else int(self.pose_samples.shape[0])


POSE_VALUES = 10  # per pose sample: quaternion (w, x, y, z), omega (3), alpha (3); jxf_model.h


def pose_samples(path) -> np.ndarray:
    """(n+1, 10) the samples of the jaxflex.response.PosePath ``path`` as the FMU embeds them:
    the orientation as a unit quaternion body -> world, scalar first (w, x, y, z, Hamilton),
    then the angular velocity (rad/s) and acceleration (rad/s^2) in body components."""
    quat = Rotation.from_matrix(np.asarray(path.rotation)).as_quat(scalar_first=True)
    return np.column_stack([quat, path.omega_rad_s, path.alpha_rad_s2]).astype(np.float64)


@dataclass(frozen=True)
class CellData:
    """What the FMU needs for the cell's outputs: ``gravity_m_s2`` (3,) in the model's frame,
    the cups' ``cup_safety`` factor, ``obstacles`` (O, 16) records (fmu.obstacles), whether
    to include the model's cups and stresses, and half the part's thickness (m, taken off the
    distance)."""

    gravity_m_s2: np.ndarray
    cup_safety: float
    obstacles: np.ndarray
    cups: bool = True
    stress: bool = True
    half_thickness_m: float = 0.0


def resource_counts(
    model: ModalModel,
    acc: np.ndarray | None,
    cell: CellData | None,
    turning: TurningData | None = None,
) -> Counts:
    """The counts of the resource of ``model`` with the trajectory ``acc``, ``cell`` and
    ``turning``."""
    with_cups = cell is not None and cell.cups and model.cups is not None
    with_stress = cell is not None and cell.stress and model.stress is not None
    return Counts(
        points=model.n_points,
        modes=model.n_modes,
        trajectory=0 if acc is None else int(np.shape(acc)[0]),
        cups=model.cups.n_cups if with_cups else 0,
        stress=model.stress.n_points if with_stress else 0,
        obstacles=0 if cell is None else len(cell.obstacles),
        static=static_count(model, turning is not None),
        turning=int(turning is not None),
    )


def _cell_parts(model: ModalModel, cell: CellData, counts: Counts) -> list[np.ndarray]:
    """The cell part of the payload."""
    cups = model.cups if counts.cups else None
    stress = model.stress if counts.stress else None
    if cups is None and stress is None and counts.obstacles == 0:
        return []
    gravity = np.asarray(cell.gravity_m_s2, "<f8")
    parts = [gravity, np.array([cell.cup_safety, cell.half_thickness_m], "<f8")]
    # a turning part's outputs have no rest term (its state carries the sag: y_rest = 0)
    # and its points no sag at rest (the FMU adds the current one)
    rest_gravity = np.zeros(3) if counts.turning else gravity
    if cups is not None:
        parts += [
            np.asarray(cups.normal, "<f8"),
            np.asarray(cups.radius_m, "<f8"),
            np.asarray(cups.holding_force_n, "<f8"),
            np.asarray(cups.friction, "<f8"),
            *_output_maps(cups.reaction, rest_gravity),
        ]
    if stress is not None:
        parts += _output_maps(stress.stress, rest_gravity)
    if counts.obstacles:
        rest = np.asarray(model.points) + gravity_offset(model, rest_gravity)
        parts += [np.asarray(rest, "<f8"), np.asarray(cell.obstacles, "<f8")]
    return parts


def _output_maps(outputs, gravity: np.ndarray) -> list[np.ndarray]:
    """Q, V, A and the outputs at rest under ``gravity`` (-S g) of jaxflex LinearOutputs."""
    maps = [np.asarray(getattr(outputs, k), "<f8") for k in ("q_map", "v_map", "a_map")]
    return [*maps, np.asarray(outputs.offset(gravity), "<f8")]


def static_count(model: ModalModel, turning: bool = False) -> int:
    """R: the coordinates of the static residual: 3 where the model has one (driven by the
    base acceleration), 12 for a turning part whose model also has the static response to
    the rotational loads (then the nine load coefficients b of jaxflex._rotation_residual
    follow), else 0."""
    if model.static_residual is None:
        return 0
    return 12 if turning and rotation_residual(model) is not None else 3


def resource_shapes(model: ModalModel, turning: bool = False) -> np.ndarray:
    """(M + R, 3, K) the shapes the FMU evaluates: the modes, then the static residual (and,
    for a turning part, the rotational one, jaxflex._rotation_residual)."""
    shapes = np.asarray(model.shapes)
    if model.static_residual is not None:
        shapes = np.concatenate([shapes, np.asarray(model.static_residual)], axis=2)
        if static_count(model, turning) == 12:
            shapes = np.concatenate([shapes, rotation_residual(model)], axis=2)
    return np.transpose(shapes, (2, 1, 0))


def payload_values(k: int, m: int, n: int, c: int, s: int, o: int, r: int, t: int = 0) -> int:
    """f64 values of the payload for the counts of the header (as jxf_core.c)."""
    count = 5 * m + 3 * (m + r) * k + 3 * k + 3 * n
    count += 5 * (c + s + o > 0) + (6 * c + 12 * c * m + 24 * c) + (12 * s * m + 24 * s)
    return count + ((3 * k + RECORD_VALUES * o) if o else 0) + _turning_values(m, n, c, s) * t


def _turning_values(m: int, n: int, c: int, s: int) -> int:
    """f64 values of a turning part's block: shape integrals, pivot, gravity, poses, the
    cups' and stresses' maps of the rotational loads."""
    return 9 * m + 6 + POSE_VALUES * n + 54 * (c + s)


@dataclass(frozen=True)
class ResourceData:
    """Contents of a resource file. ``acc`` is (N, 3) m/s^2 at step ``dt_s`` or None;
    ``counts``: (C cups, S stress points, O obstacle records) of the cell part; ``model``
    carries the static displacement its static residual gives (the cell's maps are not
    read back); ``turning``: a turning part's pivot and gravity (its shape integrals are
    not read back)."""

    token: str
    model: ModalModel
    acc: np.ndarray | None
    dt_s: float | None
    counts: tuple[int, int, int] = (0, 0, 0)
    turning: TurningData | None = None

    @property
    def move(self) -> Move | None:
        """The embedded trajectory as a jaxflex.Move (None without one)."""
        return None if self.acc is None else as_move(self.acc, self.dt_s)


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
    move: Move | None = None,
    cell: CellData | None = None,
    turning: TurningData | None = None,
) -> bytes:
    """The resource file for ``model`` (and the trajectory ``move``, a jaxflex.Move, the
    ``cell``'s outputs, the ``turning`` part's data)."""
    raw_token = token.encode("ascii")
    if len(raw_token) >= TOKEN_BYTES:
        raise ValueError(f"token: at most {TOKEN_BYTES - 1} ASCII characters, got {token!r}")
    acc, dt_s = (None, None) if move is None else (move.acc, move.dt_s)
    if move is not None:
        check_trajectory_step(dt_s, InputError, "trajectory")
    counts = resource_counts(model, acc, cell, turning)
    extra = _cell_parts(model, cell, counts) if cell is not None else []
    if turning is not None:
        if turning.pose_count() != counts.trajectory:
            raise ValueError(
                f"turning: {turning.pose_count()} pose samples for {counts.trajectory} "
                "trajectory samples"
            )
        extra += [
            np.asarray(model.rotation.shape_integrals, "<f8"),
            np.asarray(turning.pivot_m, "<f8"),
            np.asarray(turning.gravity_m_s2, "<f8"),
        ]
        if turning.pose_samples is not None:
            extra.append(np.asarray(turning.pose_samples, "<f8"))
        rotation = model.rotation  # the maps A_rot of the rotational loads b
        if counts.cups:
            extra.append(output_residual(model.cups.reaction, rotation.cup_static, model))
        if counts.stress:
            extra.append(output_residual(model.stress.stress, rotation.stress_static, model))
    parts = [
        np.asarray(model.freq_hz, "<f8"),
        np.asarray(model.zeta, "<f8"),
        np.asarray(model.gamma, "<f8"),
        np.asarray(resource_shapes(model, turning is not None), "<f8"),
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
        counts.points,
        counts.modes,
        counts.trajectory,
        counts.cups,
        float(dt_s) if acc is not None else 0.0,
        len(payload),
        counts.stress,
        counts.obstacles,
        counts.static,
        counts.turning,
    )
    body = header + payload
    return body + _TRAILER.pack(zlib.crc32(body), 0)


def decode_resource(data: bytes, *, source: str = "resource") -> ResourceData:
    """Parse and check a resource file; raises ModelFileError naming what is wrong."""
    if len(data) < HEADER.size + _TRAILER.size or data[:8] != MAGIC:
        raise ModelFileError(f"{source}: not a jaxflex FMU resource (bad magic or too short)")
    _, version, header_size, raw_token, k, m, n, c, dt_s, payload, s, o, r, t = HEADER.unpack_from(
        data
    )
    if version != FORMAT_VERSION or header_size != HEADER.size:
        raise ModelFileError(
            f"{source}: format version {version} is not supported (reads {FORMAT_VERSION}, as "
            "the FMU's binaries do)"
        )
    if r not in (0, 3) and not (r == 12 and t == 1):
        raise ModelFileError(
            f"{source}: {r} static-residual coordinates (0 or 3 allowed; 12 for a turning part)"
        )
    if t not in (0, 1):
        raise ModelFileError(f"{source}: turning field {t} (0 or 1 allowed)")
    expected = 8 * payload_values(k, m, n, c, s, o, r, t)
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
    turning = None
    if t:  # the turning part ends the payload
        tail = values[len(values) - _turning_values(m, n, c, s) :]
        poses = tail[9 * m + 6 : 9 * m + 6 + POSE_VALUES * n].reshape(n, POSE_VALUES).copy()
        poses = poses if n else None
        if poses is not None and not (np.sum(poses[:, :4] ** 2, axis=1) > 0).all():
            raise ModelFileError(f"{source}: a trajectory sample's quaternion is zero")
        turning = TurningData(
            tail[9 * m : 9 * m + 3].copy(), tail[9 * m + 3 : 9 * m + 6].copy(), poses
        )
        values = values[: len(values) - _turning_values(m, n, c, s)]
    if o:  # the records end the cell
        unknown = unknown_codes(values[-RECORD_VALUES * o :].reshape(o, RECORD_VALUES))
        if unknown:
            raise ModelFileError(
                f"{source}: obstacle kind code(s) {unknown} (allowed: {allowed_kinds()})"
            )
    sizes = [m, m, 3 * m, 3 * (m + r) * k, 3 * k, 3 * n]
    freq, zeta, gamma, shapes, points, traj = np.split(values[: sum(sizes)], np.cumsum(sizes)[:-1])
    shapes = np.transpose(shapes.reshape(m + r, 3, k), (2, 1, 0))
    gamma = gamma.reshape(m, 3)
    static = None
    if r:  # the model's static displacement from its residual D = S + Phi Omega^-2 Gamma
        omega = 2 * np.pi * freq
        static = shapes[:, :, m : m + 3] - shapes[:, :, :m] @ (gamma / omega[:, None] ** 2)
    model = ModalModel(
        freq_hz=freq,
        zeta=zeta,
        gamma=gamma,
        shapes=shapes[:, :, :m],
        points=points.reshape(k, 3),
        static_shapes=static,
    )
    acc = traj.reshape(n, 3).copy() if n else None
    return ResourceData(
        token=raw_token.rstrip(b"\0").decode("ascii"),
        model=model,
        acc=acc,
        dt_s=float(dt_s) if n else None,
        counts=(c, s, o),
        turning=turning,
    )
