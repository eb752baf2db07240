"""The modal model: everything the response computation needs to know about a part.

A part clamped at its gripper and carried without rotation obeys, per mode i,

    q_i'' + 2 zeta_i omega_i q_i' + omega_i^2 q_i = -gamma_i . a(t),
    u_p(t) = sum_i phi_i(p) q_i(t)

with mass-normalised mode shapes phi_i, so the model is fully described by the natural
frequencies, the damping ratios, the participation factors and the mode shapes at the
monitored points. SI units throughout: Hz, kg^0.5 (participation), m / (kg^0.5) (shapes), m.
"""

from __future__ import annotations

import json
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from functools import cached_property
from typing import Any

import jax
import numpy as np

from jaxflex._model_file import ARRAY_FIELDS, VALUE_RANGES, read_model_file, write_model_file
from jaxflex._outputs import (
    CupSet,
    LinearOutputs,
    StressSet,
    checked_cups,
    checked_stress,
    cups_from_fields,
    cups_to_fields,
    stress_from_fields,
    stress_to_fields,
    voigt_rotation,
)
from jaxflex._rotation import RotationalInertia, checked_rotation, posed_tensor
from jaxflex._validation import is_validated, validated
from jaxflex.errors import InputError, ModelError

# Data derived from a concrete model's shapes and points alone (the point blocks of
# jaxflex._deviation and jaxflex._settle), shared by every model with the same arrays: the
# models a robust grid derives (other frequencies or damping) keep them (a validated array
# is not copied). (id(shapes), id(points)) -> (weak references to both, the cache).
_SHAPE_CACHES: dict[tuple[int, int], tuple[weakref.ref, weakref.ref, dict]] = {}
# optional pytree children after ARRAY_FIELDS
OUTPUT_FIELDS = ("cups", "stress", "static_shapes", "rotation")
# meta["static_response"] of a model whose static displacement is not the FE's (an older file,
# or a source without a stiffness matrix): what its gravity sag and quasi-static share are
__all__ = [
    "MODES_ONLY_STATIC",
    "ModalModel",
    "load_model",
    "require_model",
    "stack_models",
]

MODES_ONLY_STATIC = (
    "from the kept modes only (no FE static solve): the sag under gravity and the quasi-static "
    "share of the modes left out are truncated"
)


class _Annotations:
    """Labels, meta and surface of a model as pytree auxiliary data that compares equal to
    any other annotations: models that differ only in their description share compiled code
    and stack (jax.vmap, jaxflex.stack_models). Nothing traced reads them. A model returned
    *from* a jitted function therefore carries the annotations of the call that compiled it."""

    __slots__ = ("labels", "meta", "surface")

    def __init__(self, labels, meta, surface=None) -> None:
        self.labels, self.meta, self.surface = labels, meta, surface

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Annotations)

    def __hash__(self) -> int:
        return hash(_Annotations)


def _is_concrete(x: Any) -> bool:
    return not isinstance(x, jax.core.Tracer)


def _as_float_array(name: str, value: Any, ndim: int) -> np.ndarray:
    """``value`` as a checked, read-only float64 array (a validated one is used as is)."""
    if is_validated(value) and value.ndim == ndim:
        return value
    if np.iscomplexobj(value):
        raise ModelError(f"ModalModel.{name}: must be real, got complex numbers")
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"ModalModel.{name}: must be numeric, got {type(value).__name__}") from exc
    if arr.ndim != ndim:
        raise ModelError(f"ModalModel.{name}: must be {ndim}-D, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ModelError(f"ModalModel.{name}: must be finite, found {arr[where]} at index {where}")
    return validated(arr)


def _checked_surface(value: Any, n_points: int) -> np.ndarray:
    """``value`` as a read-only (T, 3) int64 array of point indices in [0, n_points)."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iu" and not (
        arr.dtype.kind == "f" and arr.size and np.array_equal(arr, np.round(arr))
    ):
        raise ModelError(f"ModalModel.surface: must be integer point indices, got {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise ModelError(f"ModalModel.surface: expected shape (T, 3) with T >= 1, got {arr.shape}")
    arr = arr.astype(np.int64)
    if arr.min() < 0 or arr.max() >= n_points:
        raise ModelError(
            f"ModalModel.surface: point indices must lie in [0, {n_points - 1}], got "
            f"{arr.min()} ... {arr.max()}"
        )
    arr.setflags(write=False)
    return arr


def _check_range(name: str, arr: np.ndarray) -> None:
    """Values within jaxflex._model_file.VALUE_RANGES (where it says why)."""
    low, high = VALUE_RANGES[name]
    outside = (arr < low) | (arr > high)
    if outside.any():
        where = tuple(int(i) for i in np.argwhere(outside)[0])
        raise ModelError(
            f"ModalModel.{name}: {arr[where]:.6g} at index {where} is outside the physical "
            f"range [{low:g}, {high:g}] (a unit slip or a damaged file?)"
        )


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True, eq=False)
class ModalModel:
    """Modal data of a part at K monitored points, M modes.

    Attributes:
        freq_hz: (M,) undamped natural frequencies in Hz, > 0, ascending is customary.
        zeta: (M,) modal damping ratios, 0 <= zeta < 1.
        gamma: (M, 3) participation factors Gamma_i = phi_i^T M R in kg^0.5 for base
            acceleration along x, y, z.
        shapes: (K, 3, M) mass-normalised mode shapes at the points, m per kg^0.5.
        points: (K, 3) undeformed point coordinates in m.
        labels: optional K point labels (e.g. "weld_3"); empty strings for unlabelled points.
        meta: free JSON-serialisable description (source, material, gripper, mesh).
        cups: optional jaxflex._outputs.CupSet (the suction cups and their reactions).
        stress: optional jaxflex._outputs.StressSet (surface stresses).
        static_shapes: optional (K, 3, 3) exact static displacement of the points per unit
            base acceleration, m per m/s^2: column d is the part at rest under a constant
            unit acceleration of its gripper along d (the FE's static solve, fem). The
            displacement is then u_p = sum_i phi_i(p) q_i + D_p a with the static residual
            D = static_shapes + Phi Omega^-2 Gamma (the quasi-static share of the modes not
            kept: the mode-acceleration method), and gravity g sags the part at rest by
            -static_shapes g. None: only the modes are known (D = 0; the sag from the modes,
            truncated).
        rotation: optional jaxflex._rotation.RotationalInertia (inertia shape integrals and
            the rigid inertia: what moves that turn the part need). None: the model cannot
            turn the part.
        surface: optional (T, 3) int point indices: the triangles of the surface the points
            span (the FE mesh's cells, fem), for pictures and animations; not traced, no
            part of the response. None: the points alone (imports of modal results, R1, a
            point selection that cut the mesh).

    Construction from concrete arrays validates every field and raises ModelError naming
    the field. Inside ``jax.jit``/``jax.vmap`` the model is a pytree and is not re-validated.
    """

    freq_hz: Any
    zeta: Any
    gamma: Any
    shapes: Any
    points: Any
    labels: tuple[str, ...] | None = None
    meta: Mapping[str, Any] = field(default_factory=dict)
    cups: CupSet | None = None
    stress: StressSet | None = None
    static_shapes: Any = None
    rotation: RotationalInertia | None = None
    surface: Any = None

    def __post_init__(self) -> None:
        traced = tuple(getattr(self, name) for name in (*ARRAY_FIELDS, *OUTPUT_FIELDS))
        if all(_is_concrete(x) for x in jax.tree_util.tree_leaves(traced)):
            for name, value in _checked_fields(self).items():
                object.__setattr__(self, name, value)

    # -- pytree protocol: arrays are leaves, labels and meta ride along (_Annotations) -----
    def tree_flatten(self):
        children = tuple(getattr(self, name) for name in (*ARRAY_FIELDS, *OUTPUT_FIELDS))
        return children, _Annotations(self.labels, self.meta, self.surface)

    @classmethod
    def tree_unflatten(cls, aux: _Annotations, children):
        """The inverse of :meth:`tree_flatten`; the optional outputs (cups, stress) may be
        left out of ``children`` (then None)."""
        obj = object.__new__(cls)
        children = (*children, *(None,) * (len(ARRAY_FIELDS) + len(OUTPUT_FIELDS) - len(children)))
        for name, value in zip((*ARRAY_FIELDS, *OUTPUT_FIELDS), children, strict=True):
            object.__setattr__(obj, name, value)
        object.__setattr__(obj, "labels", aux.labels)
        object.__setattr__(obj, "meta", aux.meta)
        object.__setattr__(obj, "surface", aux.surface)
        return obj

    # -- derived quantities ------------------------------------------------------------
    @property
    def n_modes(self) -> int:
        return int(np.shape(self.freq_hz)[-1])

    @property
    def n_points(self) -> int:
        return int(np.shape(self.points)[-2])

    @property
    def omega_rad_s(self):
        """(M,) natural circular frequencies in rad/s."""
        return 2.0 * np.pi * self.freq_hz

    @cached_property
    def static_residual(self) -> np.ndarray | None:
        """(K, 3, 3) D = static_shapes + Phi Omega^-2 Gamma, m per m/s^2: the quasi-static
        displacement per unit base acceleration that the kept modes miss (u_p = Phi q + D a);
        None where the model knows no static displacement."""
        if self.static_shapes is None:
            return None
        omega = 2.0 * np.pi * np.asarray(self.freq_hz)
        modal = np.asarray(self.shapes) @ (np.asarray(self.gamma) / omega[:, None] ** 2)
        return validated(np.asarray(self.static_shapes) + modal)

    def static_displacement(self, acceleration_m_s2) -> np.ndarray:
        """(K, 3) m: the points at rest under a constant base acceleration (3,) m/s^2 (for
        gravity g pass -g): static_shapes a, or from the modes, -Phi Omega^-2 Gamma a."""
        a = np.asarray(acceleration_m_s2, dtype=np.float64)
        if self.static_shapes is not None:
            return np.asarray(self.static_shapes) @ a
        omega = 2.0 * np.pi * np.asarray(self.freq_hz)
        return -np.asarray(self.shapes) @ ((np.asarray(self.gamma) @ a) / omega**2)

    @cached_property
    def shape_norms(self) -> np.ndarray:
        """(K, M) Euclidean norm of each mode shape vector at each point, m per kg^0.5."""
        return np.linalg.norm(np.asarray(self.shapes), axis=1)

    def __repr__(self) -> str:
        f = np.asarray(self.freq_hz)
        span = f"{f.min():.4g}-{f.max():.4g} Hz" if f.size else "no modes"
        return f"ModalModel(K={self.n_points} points, M={self.n_modes} modes, {span})"

    # -- helpers returning new models --------------------------------------------------
    def truncate_modes(
        self, n_modes: int | None = None, *, max_freq_hz: float | None = None
    ) -> ModalModel:
        """Keep the lowest modes: the first ``n_modes`` and/or those at or below ``max_freq_hz``
        (the static displacement stays: the dropped modes join the static residual)."""
        return _truncated(self, n_modes, max_freq_hz)

    def select_points(self, indices: Sequence[int] | np.ndarray) -> ModalModel:
        """Keep the points at ``indices`` (in that order)."""
        return _selected(self, indices)

    def with_damping(self, zeta: float | Sequence[float] | np.ndarray) -> ModalModel:
        """Same model with damping ratio ``zeta`` (scalar for all modes, or one per mode).

        The damping force the cups carry (the outputs' v_map) scales with each mode's ratio;
        where the model had none (zeta = 0) it becomes the stiffness-proportional share
        2 zeta / omega Q that reproduces the ratio (fem.outputs)."""
        z = np.broadcast_to(np.asarray(zeta, dtype=np.float64), (self.n_modes,)).copy()
        old = np.asarray(self.zeta)
        ratio = np.where(old > 0, z / np.where(old > 0, old, 1.0), 0.0)
        from_stiffness = np.where(old > 0, 0.0, 2.0 * z / np.asarray(self.omega_rad_s))

        def damped(outputs: LinearOutputs) -> LinearOutputs:
            if not from_stiffness.any():
                return outputs.scaled(1.0, ratio, same_a_map=True)
            v = np.asarray(outputs.v_map) * ratio + np.asarray(outputs.q_map) * from_stiffness
            return LinearOutputs(outputs.q_map, v, outputs.static_map)

        return self._replace(zeta=z, **self._mapped_outputs(damped))

    def with_frequency_scale(self, scale: float) -> ModalModel:
        """Same model with every natural frequency multiplied by ``scale`` (> 0).

        Stiffness uncertainty at fixed mass (K scaled by scale^2): mode shapes and
        participation are unchanged; the static displacement scales by 1 / scale^2, the
        outputs' stiffness share q_map by scale^2 and their damping share v_map by scale
        (the same damping ratios), their static response stays (equilibrium).
        """
        if not scale > 0:
            raise ModelError(f"with_frequency_scale: scale must be > 0, got {scale}")
        s = float(scale)
        static = self.static_shapes
        rotation = self.rotation
        if rotation is not None and rotation.static_shapes is not None:
            rotation = rotation.replace(static_shapes=np.asarray(rotation.static_shapes) / s**2)
        return self._replace(
            freq_hz=np.asarray(self.freq_hz) * s,
            static_shapes=None if static is None else np.asarray(static) / s**2,
            rotation=rotation,
            **self._mapped_outputs(lambda outputs: outputs.scaled(s * s, s, same_a_map=True)),
        )

    def _mapped_outputs(self, change) -> dict[str, Any]:
        """{"cups": ..., "stress": ...} with ``change`` (LinearOutputs -> LinearOutputs)
        applied to the maps of the outputs the model carries."""
        out: dict[str, Any] = {}
        if self.cups is not None:
            c = self.cups
            out["cups"] = CupSet(
                c.centre_m, c.normal, c.radius_m, c.holding_force_n, c.friction, change(c.reaction)
            )
        if self.stress is not None:
            out["stress"] = StressSet(self.stress.points_m, change(self.stress.stress))
        return out

    def without_outputs(self) -> ModalModel:
        """Same model without its cups and stresses (what the response and the cycle time
        need: models derived from it do not carry and scale the output maps)."""
        if self.cups is None and self.stress is None:
            return self
        return self._replace(cups=None, stress=None)

    def with_meta(self, **entries: Any) -> ModalModel:
        """Same model with ``meta`` updated by ``entries``."""
        return self._replace(meta={**dict(self.meta), **entries})

    def with_outputs(
        self, *, cups: CupSet | None = None, stress: StressSet | None = None
    ) -> ModalModel:
        """Same model with the cups and/or the stresses given replaced (jaxflex._outputs)."""
        changes = {k: v for k, v in (("cups", cups), ("stress", stress)) if v is not None}
        return self._replace(**changes)

    def posed(self, rotation, offset_m) -> ModalModel:
        """The same part in another frame (e.g. the robot cell's), where a point x of the
        model's frame is at ``rotation`` x + ``offset_m`` ((3, 3) proper rotation, (3,) m).
        Base accelerations, shapes, points, cups and stresses are expressed in that frame, so
        a move given in the new frame drives the posed model exactly as the rotated move
        drives this one."""
        return _posed(self, rotation, offset_m)

    def _replace(self, **changes: Any) -> ModalModel:
        return ModalModel(**{f.name: getattr(self, f.name) for f in fields(self)} | changes)

    def save(self, path) -> None:
        """Write the model to a versioned ``.npz`` file, atomically (jaxflex._model_file)."""
        save_model(self, path)


def _checked_fields(model: ModalModel) -> dict[str, Any]:
    """The fields of the concrete ``model`` checked and in their final form (read-only
    float64 arrays, a labels tuple, a meta dict, checked outputs); ModelError naming the
    field otherwise."""
    freq = _as_float_array("freq_hz", model.freq_hz, 1)
    zeta = _as_float_array("zeta", model.zeta, 1)
    gamma = _as_float_array("gamma", model.gamma, 2)
    shapes = _as_float_array("shapes", model.shapes, 3)
    points = _as_float_array("points", model.points, 2)
    n_modes = freq.shape[0]
    if n_modes == 0:
        raise ModelError("ModalModel.freq_hz: needs at least one mode")
    if (freq <= 0).any():
        i = int(np.argmax(freq <= 0))
        raise ModelError(
            f"ModalModel.freq_hz: frequencies must be > 0 Hz (rigid-body modes are not "
            f"allowed), got {freq[i]} at mode {i}"
        )
    if zeta.shape != (n_modes,):
        raise ModelError(f"ModalModel.zeta: expected shape ({n_modes},), got {zeta.shape}")
    if ((zeta < 0) | (zeta >= 1)).any():
        i = int(np.argmax((zeta < 0) | (zeta >= 1)))
        raise ModelError(f"ModalModel.zeta: must satisfy 0 <= zeta < 1, got {zeta[i]} at mode {i}")
    if gamma.shape != (n_modes, 3):
        raise ModelError(f"ModalModel.gamma: expected shape ({n_modes}, 3), got {gamma.shape}")
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise ModelError(
            f"ModalModel.points: expected shape (K, 3) with K >= 1, got {points.shape}"
        )
    n_points = points.shape[0]
    if shapes.shape != (n_points, 3, n_modes):
        raise ModelError(
            f"ModalModel.shapes: expected shape (K, 3, M) = ({n_points}, 3, {n_modes}), "
            f"got {shapes.shape}"
        )
    arrays = dict(zip(ARRAY_FIELDS, (freq, zeta, gamma, shapes, points), strict=True))
    if model.static_shapes is not None:
        static = _as_float_array("static_shapes", model.static_shapes, 3)
        if static.shape != (n_points, 3, 3):
            raise ModelError(
                f"ModalModel.static_shapes: expected shape (K, 3, 3) = ({n_points}, 3, 3), "
                f"got {static.shape}"
            )
        arrays["static_shapes"] = static
    for name in VALUE_RANGES:
        if name not in arrays:
            continue
        if arrays[name] is not getattr(model, name):  # else checked in the model it came from
            _check_range(name, arrays[name])
    labels = model.labels
    if labels is not None:
        labels = tuple(str(s) for s in labels)
        if len(labels) != n_points:
            raise ModelError(f"ModalModel.labels: expected {n_points} labels, got {len(labels)}")
    meta = dict(model.meta)
    try:
        json.dumps(meta)
    except TypeError as exc:
        raise ModelError(f"ModalModel.meta: must be JSON-serialisable ({exc})") from exc
    out = _checked_outputs(model, freq, gamma, n_points)
    surface = model.surface
    if surface is not None and not (is_validated(surface) and surface.dtype == np.int64):
        surface = validated(_checked_surface(surface, n_points))
    return {**arrays, **out, "labels": labels, "meta": meta, "surface": surface}


def _checked_outputs(model: ModalModel, freq, gamma, n_points: int) -> dict[str, Any]:
    """The model's cups, stresses and rotation data checked against its modes ``freq``,
    ``gamma`` and ``n_points`` points (only those it carries)."""
    out: dict[str, Any] = {}
    for name, kind, check in (
        ("cups", CupSet, checked_cups),
        ("stress", StressSet, checked_stress),
    ):
        value = getattr(model, name)
        if value is not None:
            if not isinstance(value, kind):
                raise ModelError(
                    f"ModalModel.{name}: expected jaxflex.response.{kind.__name__} or None, "
                    f"got {type(value).__name__}"
                )
            out[name] = check(value, freq, gamma)
    if model.rotation is not None:
        rows = (
            None if model.static_shapes is None else n_points,
            None if model.cups is None else 6 * model.cups.n_cups,
            None if model.stress is None else 6 * model.stress.n_points,
        )
        out["rotation"] = checked_rotation(model.rotation, len(freq), rows)
    return out


def _truncated(model: ModalModel, n_modes: int | None, max_freq_hz: float | None) -> ModalModel:
    """ModalModel.truncate_modes."""
    freq = np.asarray(model.freq_hz)
    keep = np.argsort(freq, kind="stable")
    if n_modes is not None:
        if int(n_modes) < 1:
            raise ModelError(f"truncate_modes: n_modes must be >= 1, got {n_modes}")
        keep = keep[: int(n_modes)]
    if max_freq_hz is not None:
        keep = keep[freq[keep] <= max_freq_hz]
        if keep.size == 0:
            raise ModelError(
                f"truncate_modes: no mode at or below max_freq_hz={max_freq_hz} Hz "
                f"(lowest is {freq.min():.4g} Hz)"
            )
    keep = np.sort(keep)
    return model._replace(
        freq_hz=model.freq_hz[keep],
        zeta=model.zeta[keep],
        gamma=model.gamma[keep],
        shapes=model.shapes[:, :, keep],
        rotation=None if model.rotation is None else model.rotation.take_modes(keep),
        **model._mapped_outputs(lambda outputs: outputs.take_modes(keep)),
    )


def _selected(model: ModalModel, indices) -> ModalModel:
    """ModalModel.select_points."""
    idx = np.asarray(indices)
    if idx.dtype == bool:
        idx = np.flatnonzero(idx)
    idx = idx.astype(np.int64)
    if idx.ndim != 1 or idx.size == 0:
        raise ModelError("select_points: indices must be a non-empty 1-D sequence")
    if (idx < 0).any() or (idx >= model.n_points).any():
        raise ModelError(
            f"select_points: indices must lie in [0, {model.n_points - 1}], "
            f"got min {idx.min()}, max {idx.max()}"
        )
    labels = None if model.labels is None else tuple(model.labels[i] for i in idx)
    static = None if model.static_shapes is None else model.static_shapes[idx]
    rotation = model.rotation
    if rotation is not None and rotation.static_shapes is not None:
        rotation = rotation.replace(static_shapes=np.asarray(rotation.static_shapes)[idx])
    return model._replace(
        shapes=model.shapes[idx],
        points=model.points[idx],
        labels=labels,
        static_shapes=static,
        rotation=rotation,
        surface=kept_surface(model.surface, idx, model.n_points),
    )


def _posed(model: ModalModel, rotation, offset_m) -> ModalModel:
    """ModalModel.posed."""
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-9):
        raise ModelError(f"posed: rotation must be a 3 x 3 rotation matrix, got {r.tolist()}")
    if np.linalg.det(r) < 0:
        raise ModelError("posed: rotation must be proper (determinant +1), not a reflection")
    offset = np.asarray(offset_m, dtype=np.float64).reshape(3)
    static = model.static_shapes
    return model._replace(
        static_shapes=None if static is None else r @ np.asarray(static) @ r.T,
        gamma=np.asarray(model.gamma) @ r.T,
        shapes=np.einsum("ij,kjm->kim", r, np.asarray(model.shapes)),
        points=np.asarray(model.points) @ r.T + offset,
        cups=None if model.cups is None else model.cups.rotated(r, offset),
        stress=None if model.stress is None else model.stress.rotated(r, offset),
        rotation=None
        if model.rotation is None
        else model.rotation.posed(r, offset, np.asarray(model.gamma), _static_posers(model)),
        meta={**dict(model.meta), "pose": {"rotation": r.tolist(), "offset_m": offset.tolist()}},
    )


def _static_posers(model: ModalModel) -> dict[str, Any]:
    """For RotationalInertia.posed: how each static response to the rotational loads
    moves to another frame (jaxflex._rotation.posed_tensor with the translation's static
    response of the same quantity and the rotation of its rows)."""
    out: dict[str, Any] = {}
    if model.static_shapes is not None:
        static = np.asarray(model.static_shapes)

        def points(values, r, o):
            return np.einsum("ab,kb...->ka...", r, posed_tensor(values, static, r, o))

        out["static_shapes"] = points
    for name, owner, block in (
        ("cup_static", model.cups, lambda r: r),
        ("stress_static", model.stress, voigt_rotation),
    ):
        if owner is not None:
            maps = owner.reaction if name == "cup_static" else owner.stress
            out[name] = _rows_poser(np.asarray(maps.static_map), block)
    return out


def kept_surface(surface, indices: np.ndarray, n_points: int) -> np.ndarray | None:
    """The triangles of ``surface`` ((T, 3) point indices, or None) whose three points are all
    among ``indices`` (the kept points, in their new order), renumbered; None where none is
    left."""
    if surface is None:
        return None
    new = np.full(n_points, -1, dtype=np.int64)
    new[indices] = np.arange(len(indices))
    mapped = new[np.asarray(surface)]
    kept = mapped[(mapped >= 0).all(axis=1)]
    return kept if len(kept) else None


def _rows_poser(translation: np.ndarray, block):
    """RotationalInertia.posed's function for outputs (Y, 3, 3) whose translation's static
    map is ``translation`` (Y, 3) and whose groups of b rows turn by ``block(r)`` (b, b)."""

    def posed(values, r, o):
        moved = posed_tensor(values, translation, r, o)  # (Y, 3, 3)
        b = block(r)
        grouped = moved.reshape(-1, b.shape[0], 3, 3)
        return np.einsum("ab,gbij->gaij", b, grouped).reshape(moved.shape)

    return posed


def shape_cache(model: ModalModel) -> dict:
    """A dict for data derived from the concrete ``model``'s shapes and points alone, shared
    by every model holding the same two arrays (gone with them)."""
    shapes, points = model.shapes, model.points
    key = (id(shapes), id(points))
    entry = _SHAPE_CACHES.get(key)
    if entry is not None and entry[0]() is shapes and entry[1]() is points:
        return entry[2]
    cache: dict = {}
    _SHAPE_CACHES[key] = (weakref.ref(shapes), weakref.ref(points), cache)
    weakref.finalize(shapes, _SHAPE_CACHES.pop, key, None)
    return cache


def save_model(model: ModalModel, path) -> None:
    """Write ``model`` to ``path`` (a versioned .npz that jaxflex.files.read_model_file
    reads) atomically: the file is complete or absent."""
    arrays = {name: getattr(model, name) for name in ARRAY_FIELDS}
    if model.static_shapes is not None:
        arrays["static_shapes"] = model.static_shapes
    if model.cups is not None:
        arrays.update(cups_to_fields(model.cups))
    if model.stress is not None:
        arrays.update(stress_to_fields(model.stress))
    if model.rotation is not None:
        arrays.update(model.rotation.to_fields())
    if model.surface is not None:
        arrays["surface_triangles"] = model.surface
    write_model_file(path, arrays, model.labels, dict(model.meta))


def require_model(model: Any) -> ModalModel:
    """``model`` if it is a :class:`ModalModel`; InputError naming the argument otherwise
    (what every function of a model checks at its door)."""
    if not isinstance(model, ModalModel):
        raise InputError(
            "model: expected a jaxflex.ModalModel (jaxflex.load_model, fem's "
            f"to_modal_model), got {type(model).__name__}"
        )
    return model


def load_model(path) -> ModalModel:
    """Read a model written by :func:`save_model`.

    Raises ModelFileError for a missing, truncated or corrupt file, a file of another format,
    an unknown schema version or a missing field; ModelError if the stored data are invalid.
    """
    fields = read_model_file(path)
    optional = fields.pop("optional")
    version = fields.pop("schema_version")
    modes = (fields["freq_hz"], fields["gamma"])
    try:
        if "static" in optional:
            fields["static_shapes"] = optional["static"]["static_shapes"]
        if "cups" in optional:
            fields["cups"] = cups_from_fields(optional["cups"], modes)
        if "stress" in optional:
            fields["stress"] = stress_from_fields(optional["stress"], modes)
        if "rotation" in optional:
            rotation_fields = dict(optional["rotation"])
            for group in (
                "rotation_static",
                "rotation_cups",
                "rotation_stress",
                "rotation_coupling",
            ):
                rotation_fields.update(optional.get(group, {}))
            fields["rotation"] = RotationalInertia.from_fields(rotation_fields)
        if "surface" in optional:
            fields["surface"] = optional["surface"]["surface_triangles"]
        if version < 3:
            fields["meta"] = {**fields["meta"], "static_response": _legacy_static(version)}
        return ModalModel(**fields)
    except ModelError as exc:
        raise ModelError(f"{str(path)!r}: {exc}") from exc


def _legacy_static(version: int) -> str:
    """meta["static_response"] of a model read from a schema-``version`` file (< 3)."""
    text = (
        f"schema {version} file (before the FE's static response was stored): points "
        + MODES_ONLY_STATIC
    )
    if version == 2:
        text += (
            "; cup reactions and stresses at rest from the stored maps (exact for the modes "
            "the file was written with)"
        )
    return text


def stack_models(models: Sequence[ModalModel]) -> ModalModel:
    """B models of equal size (K points, M modes) as one model whose arrays have a leading
    batch axis (B, ...): the input of ``jax.vmap`` over models and of
    jaxflex._simulate.batch_deviation. Labels and meta are those of the first model."""
    models = list(models)
    if not models:
        raise ModelError("stack_models: needs at least one model")
    sizes = sorted({(m.n_points, m.n_modes) for m in models})
    if len(sizes) != 1:
        raise ModelError(f"stack_models: models must have equal size (points, modes), got {sizes}")
    return jax.tree_util.tree_map(lambda *leaves: np.stack(leaves), *models)
