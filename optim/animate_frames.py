"""The frames of an animation (optim.animate): the engine's response where the part is.

The frames are the engine's own response: every sample of the move and of the settling
after it (until the cycle time plus ``after_s``), and a straight move's certified closest
approach to an obstacle as a frame of its own where it falls between samples. At a frame
the model's point k is where jaxflex.geometry.positions_at (turning moves:
turning_positions_at) puts it, the exact positions the certified clearance evaluates:

    p_k(t) = c + s(t) + R(t) (x_k - c) + d_k(t)

with the rigid pose (the pivot c, the path s, the orientation R; a straight move R = I)
and the displacement d_k from the rigid pose (the sag under gravity and the vibration with
its static residual). Each frame carries d (scalable in the viewers), the deviation |u_k|
about the sag of the current pose (what the threshold limits), von Mises at the model's
stress points (the nearest one drawn at each surface point) and the distance of each point
(its ball of half the thickness, as jaxflex._collision certifies) to the nearest obstacle.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import read_set, read_trajectory_csv, read_turn_csv
from jaxflex.geometry import (
    DEFAULT_GRAVITY_M_S2,
    distances,
    gravity_offset,
    part_half_thickness,
    positions_at,
    rotations_between,
    turning_positions_at,
)
from jaxflex.model import ModalModel, load_model
from jaxflex.response import (
    Move,
    PosePath,
    Turn,
    VonMises,
    kinematics_at,
    outputs_at,
    turning_loads,
)
from jaxflex.runtime import Need, require
from optim.result import RESULT_KIND

ANIMATION_KIND = "jaxflex.animation"
AFTER_SHARE = 0.25  # the settling shown after the cycle time, share of it (at least 10 steps)
FRAME_CHUNK = 32  # frames evaluated at once (memory: chunk x points x 3 floats a field)
# a frame's fields in float64 per point: rigid pose and displacement (3 each), deviation and
# distance, and one for von Mises where the model has stress; the series and the page are
# written from them
FRAME_FLOATS_PER_POINT = 9
# CPU seconds per frame and point of the engine's response (measured: 103 frames of the
# built-in plate's 10 821 points in 1.1 s, the series and the page as much again)
FRAME_POINT_S = 2e-6


@dataclass(frozen=True)
class Scene:
    """What an animation shows: the ``model`` posed in the move's frame (cell coordinates),
    the ``move``, its ``threshold_m``, ``cycle_time_s`` and ``transfer_time_s``, gravity,
    the cell's ``obstacles``, the via points ``via_m`` (V, 3) and the part frame's origin
    at A ``start_m`` (3,), half the sheet's thickness (None: not known, the mid-surface is
    drawn), a turning move's orientation ``path`` about ``pivot_m``, the constraints'
    ``limits`` (name -> limit), the certified closest approach ``witness`` (time_s, point,
    distance_m; of the nominal model) and a ``title``; ``notes`` for the reader."""

    model: ModalModel
    move: Move
    threshold_m: float
    cycle_time_s: float
    transfer_time_s: float
    gravity_m_s2: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_GRAVITY_M_S2))
    obstacles: tuple = ()
    via_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    start_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    half_thickness_m: float | None = None
    path: PosePath | None = None
    pivot_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    limits: dict = field(default_factory=dict)
    witness: dict | None = None
    title: str = ""
    notes: tuple = ()

    @property
    def turn(self) -> Turn:
        """The turning move (jaxflex.response.Turn) of a scene with a ``path``."""
        return Turn(self.path, self.move, pivot_m=self.pivot_m, gravity_m_s2=self.gravity_m_s2)


@dataclass(frozen=True)
class Frames:
    """The engine's response at the frame times ``t_s`` (F,) s (``on_grid``: a sample of
    the move's grid): the model's points at their rigid pose ``rigid`` (F, K, 3) m, their
    ``displacement`` (F, K, 3) m from there (the engine's position is rigid + displacement),
    the deviation about the current pose's sag ``deviation_m`` (F, K), the orientation
    ``rotation`` (F, 3, 3), the part frame's origin ``origin_m`` (F, 3), von Mises at the
    stress points ``von_mises_pa`` (F, S) or None, each point's distance to the nearest
    obstacle ``distance_m`` (F, K, of its ball of half the thickness) or None."""

    t_s: np.ndarray
    on_grid: np.ndarray
    rigid: np.ndarray
    displacement: np.ndarray
    deviation_m: np.ndarray
    rotation: np.ndarray
    origin_m: np.ndarray
    von_mises_pa: np.ndarray | None
    distance_m: np.ndarray | None

    @property
    def positions(self) -> np.ndarray:
        """(F, K, 3) m: where the engine puts the model's points."""
        return self.rigid + self.displacement

    def frame_at(self, time_s: float) -> int:
        """The index of the frame at ``time_s`` (the nearest one)."""
        return int(np.argmin(np.abs(self.t_s - time_s)))


def frame_times(scene: Scene, after_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(times (F,) s, on the sample grid (F,)): every sample of the move and the settling
    until the cycle time plus ``after_s`` (default AFTER_SHARE of it, at least 10 steps),
    and a straight move's certified closest approach where it falls between samples."""
    dt = scene.move.dt_s
    end = max(scene.cycle_time_s, scene.transfer_time_s)
    after = max(AFTER_SHARE * end, 10 * dt) if after_s is None else float(after_s)
    n = math.ceil((end + after) / dt - 1e-9)
    frames, points = n + 2, scene.model.n_points
    require(
        Need(
            f"the animation ({frames} frames of {scene.model.n_points} points, {after:g} s "
            "after the cycle time)",
            memory_bytes=8.0 * FRAME_FLOATS_PER_POINT * frames * points,
            time_s=FRAME_POINT_S * frames * points,
            advice="show less of the settling (--after S)",
        )
    )
    t = dt * np.arange(n + 1)
    on_grid = np.ones(n + 1, dtype=bool)
    witness = scene.witness
    if witness is not None and scene.path is None and math.isfinite(witness["time_s"]):
        w = float(witness["time_s"])
        if 0 < w < t[-1] and np.abs(t - w).min() > 1e-12:
            k = int(np.searchsorted(t, w))
            t, on_grid = np.insert(t, k, w), np.insert(on_grid, k, False)
    return t, on_grid


def engine_frames(scene: Scene, t_s: np.ndarray, on_grid: np.ndarray) -> Frames:
    """The :class:`Frames` of ``scene`` at ``t_s`` (module docstring), evaluated
    FRAME_CHUNK frames at a time."""
    chunks = [
        _frame_chunk(scene, t_s[i : i + FRAME_CHUNK]) for i in range(0, len(t_s), FRAME_CHUNK)
    ]
    joined = {
        key: None if chunks[0][key] is None else np.concatenate([c[key] for c in chunks])
        for key in chunks[0]
    }
    if scene.path is not None and scene.model.stress is not None:
        joined["von_mises_pa"] = _turning_von_mises(scene, t_s)
    return Frames(t_s=t_s, on_grid=on_grid, **joined)


def _frame_chunk(scene: Scene, t: np.ndarray) -> dict:
    model, move = scene.model, scene.move
    points = np.asarray(model.points)
    t_end = move.duration_s
    if scene.path is None:
        positions = positions_at(model, move, t, scene.gravity_m_s2)
        rotation = np.broadcast_to(np.eye(3), (len(t), 3, 3))
    else:
        positions = turning_positions_at(model, scene.turn, t)
        rotation = rotations_between(scene.path, np.minimum(t, t_end))
    path = kinematics_at(move, np.minimum(t, t_end))[0]
    pivot = np.asarray(scene.pivot_m, dtype=np.float64)
    rigid = pivot + path[:, None] + np.einsum("tab,kb->tka", rotation, points - pivot)
    displacement = positions - rigid
    body_gravity = np.einsum("tba,b->ta", rotation, scene.gravity_m_s2)  # R^T g
    sag = np.einsum("tab,tkb->tka", rotation, _sag(model, body_gravity))
    deviation = np.linalg.norm(displacement - sag, axis=2)
    origin = pivot + path + np.einsum("tab,b->ta", rotation, scene.start_m - pivot)
    von_mises = None
    if model.stress is not None and scene.path is None:
        stress = model.stress.stress
        y = outputs_at(model, stress, move, t, stress.offset(scene.gravity_m_s2))
        von_mises = VonMises(model.stress.n_points).values(y.reshape(len(t), -1, 6), None)
    distance = None
    if scene.obstacles:
        d, _, _ = distances(scene.obstacles, positions.reshape(-1, 3))
        distance = d.reshape(len(t), -1) - (scene.half_thickness_m or 0.0)
    return {
        "rigid": rigid,
        "displacement": displacement,
        "deviation_m": deviation,
        "rotation": np.array(rotation),
        "origin_m": origin,
        "von_mises_pa": von_mises,
        "distance_m": distance,
    }


def _sag(model: ModalModel, body_gravity: np.ndarray) -> np.ndarray:
    """(T, K, 3) the points' static sag under the gravities ``body_gravity`` (T, 3) (body
    components): the model's static displacement under -g (jaxflex ModalModel)."""
    if len(body_gravity) and np.allclose(body_gravity, body_gravity[0], rtol=0, atol=0):
        return np.broadcast_to(
            gravity_offset(model, body_gravity[0]), (len(body_gravity), model.n_points, 3)
        )
    return np.stack([gravity_offset(model, g) for g in body_gravity])


def _turning_von_mises(scene: Scene, t_s: np.ndarray) -> np.ndarray:
    """(F, S) von Mises of a turning move at the frames (all on the sample grid):
    jaxflex.response.turning_loads over the move and the settling shown."""
    move = scene.move
    extend = max(0.0, float(t_s[-1]) - move.duration_s)
    loads = turning_loads(scene.model, scene.turn, extend_s=extend)
    k = np.rint(t_s / move.dt_s).astype(np.int64)
    return loads.von_mises_pa[np.minimum(k, len(loads.t_s) - 1)]


# -- scenes: of a result in memory, of a result directory ------------------------------------


def scene_of_result(result) -> Scene:
    """The :class:`Scene` of an optim.OptimizationResult (the returned move, the nominal
    model posed in its cell)."""
    setup = result.cell
    model = result.model if setup is None else setup.model
    cell = None if setup is None else setup.cell
    gravity = np.array(DEFAULT_GRAVITY_M_S2) if setup is None else setup.gravity_m_s2
    path, pivot = None, np.zeros(3)
    if result.turn is not None:
        path = result.turn.path(np.asarray(result.angular_acc), result.dt_s)
        pivot = np.asarray(result.turn.pivot_m, dtype=np.float64)
    report = {
        "constraints": result.constraints,
        "threshold_m": result.threshold_m,
        "cycle_time_s": result.cycle_time_s,
        "transfer_time_s": result.transfer_time_s,
        "source": result.source,
    }
    return _scene(model, result.move, report, cell, gravity, path, pivot)


def _scene(model, move: Move, report: dict, cell, gravity, path, pivot) -> Scene:
    constraints = report.get("constraints") or []
    distance = [c for c in constraints if "distance" in c.get("name", "")]
    half = None
    if distance:
        half = float(distance[0]["half_thickness_m"])
    elif cell is not None and cell.thickness_m is not None:
        half = 0.5 * cell.thickness_m
    else:
        half = part_half_thickness(model)
    notes = []
    witness = None
    if distance and distance[0].get("item", -1) >= 0:
        c = distance[0]
        if c.get("scenario", "nominal") == "nominal":
            witness = {"time_s": float(c["time_s"]), "point": int(c["item"]),
                       "distance_m": float(c["peak"])}  # fmt: skip
        else:
            notes.append(
                f"the certified closest approach is of the model {c['scenario']} of the robust "
                "grid; the animation shows the nominal model"
            )
    return Scene(
        model=model,
        move=move,
        threshold_m=float(report["threshold_m"]),
        cycle_time_s=float(report["cycle_time_s"]),
        transfer_time_s=float(report["transfer_time_s"]),
        gravity_m_s2=np.asarray(gravity, dtype=np.float64),
        obstacles=() if cell is None else tuple(cell.obstacles),
        via_m=np.array([v.position_m for v in cell.via]).reshape(-1, 3)
        if cell is not None
        else np.zeros((0, 3)),
        start_m=np.zeros(3) if cell is None else np.asarray(cell.start_m, dtype=np.float64),
        half_thickness_m=half,
        path=path,
        pivot_m=np.asarray(pivot, dtype=np.float64),
        limits={c["name"]: float(c["limit"]) for c in constraints},
        witness=witness,
        title=_title(report),
        notes=tuple(notes),
    )


def _title(report: dict) -> str:
    source = report.get("source", "optimised")
    what = "optimised move" if source in ("optimised", "search") else f"baseline {source!r}"
    return (
        f"{what}: cycle {float(report['cycle_time_s']):.3f} s, transfer "
        f"{float(report['transfer_time_s']):.3f} s, threshold "
        f"{float(report['threshold_m']) * 1e3:g} mm"
    )


def file_record(path: str | os.PathLike) -> dict:
    """{"path": absolute path, "sha256": hash of the content} of an input file (report.json's
    ``inputs``: what `jaxflex animate RESULT_DIR` reads again)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return {"path": str(Path(path).resolve()), "sha256": digest.hexdigest()}


def _input_file(report: dict, key: str, given, option: str) -> Path:
    """The input file ``key`` of the result: ``given`` (the option's value) or the one its
    report records; refused where it is not the file the result was made with."""
    record = (report.get("inputs") or {}).get(key)
    if given is None and not record:
        raise InputError(
            f"{option}: the result does not record its {key} file (written before `jaxflex "
            f"optimize` recorded its inputs, or by optim.optimize); give it with {option}"
        )
    path = Path(given if given is not None else record["path"])
    if not path.is_file():
        raise InputError(f"{option}: {str(path)!r} is not a file; give the {key} with {option}")
    if record and file_record(path)["sha256"] != record.get("sha256"):
        raise InputError(
            f"{option}: {str(path)!r} is not the {key} file the result was optimised with (its "
            f"SHA-256 differs from report.json's inputs.{key}); give that file"
        )
    return path


def scene_of_directory(directory, *, model=None, cell=None) -> Scene:
    """The :class:`Scene` of the result set in ``directory`` (trajectory.csv, report.json of
    `jaxflex optimize`), with the model and cell files its report records or ``model`` /
    ``cell`` (paths; each must be the file the result was made with)."""
    from optim.cell_file import load_cell
    from optim.turn_via import reported_turn

    members = read_set(
        directory, RESULT_KIND, ("trajectory.csv", "report.json"), option="RESULT_DIR"
    )
    move = read_trajectory_csv(members["trajectory.csv"])
    try:
        report = json.loads(members["report.json"].read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"RESULT_DIR: report.json is not valid JSON ({exc})") from exc
    model_ = load_model(_input_file(report, "model", model, "--model"))
    loaded = None
    if report.get("frame") == "cell":
        loaded = load_cell(_input_file(report, "cell", cell, "--cell"))
        model_ = loaded.posed(model_)
    gravity = loaded.gravity_m_s2 if loaded is not None else np.array(DEFAULT_GRAVITY_M_S2)
    path, pivot = None, np.zeros(3)
    turn_acc = read_turn_csv(members["trajectory.csv"])
    if turn_acc is not None:
        turn = reported_turn(report.get("turn"), turn_acc, move, gravity)
        path, pivot, gravity = turn.path, turn.pivot_m, turn.gravity_m_s2
    return _scene(model_, move, report, loaded, gravity, path, pivot)
