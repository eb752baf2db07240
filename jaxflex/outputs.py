"""Outputs linear in the modal state besides the displacements: cup reactions and stresses.

Every such quantity obeys (Y rows, M modes; q, q' the modal state, a the base acceleration)

    y(t) = Q q(t) + V q'(t) + A a(t)                                         (1)

:class:`LinearOutputs` holds (Q, V, A). The FE side (fem) derives them with the
mode-acceleration method (the quasi-static response to a is exact, the modes correct it), so
A carries the static share and Q, V the dynamic one. Gravity g (m/s^2, in the model's frame)
acts like a constant base acceleration -g: its share is the constant offset -A g
(:meth:`LinearOutputs.offset`).

A model may carry (both optional, jaxflex.model_file stores them):

* :class:`CupSet`: per cup c the force (N) and moment (N m, about the cup centre) that the cup
  exerts on the part, rows 6 c .. 6 c + 5 = (F_x, F_y, F_z, M_x, M_y, M_z), with the cup's
  centre, surface normal (pointing from the part into the cup), radius, holding force and
  friction coefficient;
* :class:`StressSet`: the stress tensor at S surface points, rows 6 s .. 6 s + 5 in Voigt
  order (xx, yy, zz, yz, xz, xy), Pa.

Both are pytrees (they travel with a ModalModel through jit/vmap) and can be expressed in
another frame (:meth:`CupSet.rotated`, :meth:`StressSet.rotated`). SI units throughout.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import jax
import numpy as np

from jaxflex.errors import ModelError
from jaxflex.validation import is_validated, validated

VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))  # xx, yy, zz, yz, xz, xy
CUP_ROWS = ("F_x", "F_y", "F_z", "M_x", "M_y", "M_z")


def _checked(owner: str, name: str, value: Any, shape: tuple) -> np.ndarray:
    """``value`` as a read-only float64 array of ``shape`` (None entries: any size)."""
    if is_validated(value) and _fits(value.shape, shape):
        return value
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{owner}.{name}: must be numeric") from exc
    if not _fits(arr.shape, shape):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ModelError(f"{owner}.{name}: expected shape {want}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ModelError(f"{owner}.{name}: must be finite")
    return validated(arr)


def _fits(actual: tuple, shape: tuple) -> bool:
    return len(actual) == len(shape) and all(
        s is None or s == a for s, a in zip(shape, actual, strict=True)
    )


def _concrete(*values: Any) -> bool:
    return not any(isinstance(v, jax.core.Tracer) for v in jax.tree_util.tree_leaves(values))


def _pytree(cls):
    """Register a frozen dataclass whose fields are all array leaves (or pytrees)."""
    names = tuple(f.name for f in fields(cls))

    def flatten(obj):
        return tuple(getattr(obj, n) for n in names), None

    def unflatten(_, children):
        obj = object.__new__(cls)
        for n, v in zip(names, children, strict=True):
            object.__setattr__(obj, n, v)
        return obj

    jax.tree_util.register_pytree_node(cls, flatten, unflatten)
    return cls


@_pytree
@dataclass(frozen=True, eq=False)
class LinearOutputs:
    """y = q_map q + v_map q' + a_map a (module docstring, equation (1)).

    q_map: (Y, M) per unit modal coordinate (kg^0.5 m); v_map: (Y, M) per unit modal
    velocity; a_map: (Y, 3) per unit base acceleration (m/s^2). Units of y: those of the
    quantity (N, N m, Pa).
    """

    q_map: Any
    v_map: Any
    a_map: Any

    def check(self, owner: str, n_rows: int, n_modes: int) -> LinearOutputs:
        """Validated copy (shapes (Y, M), (Y, M), (Y, 3), finite); ModelError naming the field."""
        return LinearOutputs(
            _checked(owner, "q_map", self.q_map, (n_rows, n_modes)),
            _checked(owner, "v_map", self.v_map, (n_rows, n_modes)),
            _checked(owner, "a_map", self.a_map, (n_rows, 3)),
        )

    @property
    def n_rows(self) -> int:
        return int(np.shape(self.a_map)[0])

    def take_modes(self, keep: np.ndarray) -> LinearOutputs:
        return LinearOutputs(self.q_map[:, keep], self.v_map[:, keep], self.a_map)

    def values(self, states, acc, xp: Any = np):
        """(T, Y) outputs for modal states (T, M, 2) and base accelerations (T, 3)."""
        return (
            states[..., 0] @ xp.asarray(self.q_map).T
            + states[..., 1] @ xp.asarray(self.v_map).T
            + xp.asarray(acc) @ xp.asarray(self.a_map).T
        )

    def offset(self, gravity_m_s2) -> np.ndarray:
        """(Y,) the constant share of gravity ``gravity_m_s2`` (3,) (a base acceleration -g)."""
        return -np.asarray(self.a_map) @ np.asarray(gravity_m_s2, dtype=np.float64)

    def transformed(self, block: np.ndarray, rotation: np.ndarray) -> LinearOutputs:
        """The outputs in a frame rotated by ``rotation`` (3, 3): every group of b rows mapped
        by ``block`` (b, b), the acceleration input by a_old = rotation^T a_new."""
        b = block.shape[0]

        def rows(values: np.ndarray) -> np.ndarray:
            values = np.asarray(values)
            grouped = values.reshape(-1, b, values.shape[1])
            return np.einsum("ij,gjm->gim", block, grouped).reshape(values.shape)

        return LinearOutputs(
            rows(self.q_map), rows(self.v_map), rows(self.a_map) @ np.asarray(rotation).T
        )


def voigt_rotation(rotation: np.ndarray) -> np.ndarray:
    """(6, 6) T with voigt(R s R^T) = T voigt(s) for symmetric s (Voigt order VOIGT)."""
    r = np.asarray(rotation, dtype=np.float64)
    out = np.zeros((6, 6))
    for a, (i, j) in enumerate(VOIGT):
        for b, (k, l) in enumerate(VOIGT):
            out[a, b] = r[i, k] * r[j, l] + (r[i, l] * r[j, k] if k != l else 0.0)
    return out


@_pytree
@dataclass(frozen=True, eq=False)
class CupSet:
    """The suction cups of a model and their reactions (module docstring).

    centre_m (C, 3) m; normal (C, 3) unit, from the part into the cup; radius_m (C,) m
    (effective suction radius); holding_force_n (C,) N (vacuum x effective area, no safety
    factor); friction (C,) coefficient between cup and part; reaction: LinearOutputs with 6 C
    rows (force on the part N, moment about the cup centre N m).
    """

    centre_m: Any
    normal: Any
    radius_m: Any
    holding_force_n: Any
    friction: Any
    reaction: LinearOutputs

    def __post_init__(self) -> None:
        if not _concrete(self):
            return
        centre = _checked("cups", "centre_m", self.centre_m, (None, 3))
        n = centre.shape[0]
        if n == 0:
            raise ModelError("cups.centre_m: needs at least one cup")
        normal = _checked("cups", "normal", self.normal, (n, 3))
        if not np.allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-9):
            raise ModelError("cups.normal: every normal must be a unit vector")
        values = {
            "centre_m": centre,
            "normal": normal,
            "radius_m": _checked("cups", "radius_m", self.radius_m, (n,)),
            "holding_force_n": _checked("cups", "holding_force_n", self.holding_force_n, (n,)),
            "friction": _checked("cups", "friction", self.friction, (n,)),
        }
        for name in ("radius_m", "holding_force_n", "friction"):
            if (values[name] <= 0).any():
                raise ModelError(f"cups.{name}: must be > 0 for every cup")
        for name, value in values.items():
            object.__setattr__(self, name, value)

    @property
    def n_cups(self) -> int:
        return int(np.shape(self.centre_m)[0])

    def rotated(self, rotation: np.ndarray, offset_m: np.ndarray) -> CupSet:
        """The cups in a frame where old points x map to rotation x + offset_m."""
        r = np.asarray(rotation, dtype=np.float64)
        return CupSet(
            np.asarray(self.centre_m) @ r.T + offset_m,
            np.asarray(self.normal) @ r.T,
            self.radius_m,
            self.holding_force_n,
            self.friction,
            self.reaction.transformed(r, r),  # every force and moment vector rotates
        )


@_pytree
@dataclass(frozen=True, eq=False)
class StressSet:
    """Stresses at S surface points: points_m (S, 3) m; stress: LinearOutputs with 6 S rows
    (Voigt xx, yy, zz, yz, xz, xy per point, Pa)."""

    points_m: Any
    stress: LinearOutputs

    def __post_init__(self) -> None:
        if _concrete(self):
            points = _checked("stress", "points_m", self.points_m, (None, 3))
            if points.shape[0] == 0:
                raise ModelError("stress.points_m: needs at least one point")
            object.__setattr__(self, "points_m", points)

    @property
    def n_points(self) -> int:
        return int(np.shape(self.points_m)[0])

    def rotated(self, rotation: np.ndarray, offset_m: np.ndarray) -> StressSet:
        """The stresses in a frame where old points x map to rotation x + offset_m."""
        r = np.asarray(rotation, dtype=np.float64)
        return StressSet(
            np.asarray(self.points_m) @ r.T + offset_m,
            self.stress.transformed(voigt_rotation(r), r),
        )


def checked_cups(cups: CupSet, n_modes: int) -> CupSet:
    """``cups`` with its reaction maps validated against ``n_modes`` (ModelError)."""
    reaction = cups.reaction.check("cups.reaction", 6 * cups.n_cups, n_modes)
    return CupSet(
        cups.centre_m, cups.normal, cups.radius_m, cups.holding_force_n, cups.friction, reaction
    )


def checked_stress(stress: StressSet, n_modes: int) -> StressSet:
    """``stress`` with its maps validated against ``n_modes`` (ModelError)."""
    return StressSet(
        stress.points_m, stress.stress.check("stress.stress", 6 * stress.n_points, n_modes)
    )


# -- the model file's flat fields (jaxflex.model_file.OPTIONAL_FIELDS) ----------------------


def cups_to_fields(cups: CupSet) -> dict[str, np.ndarray]:
    c = cups.n_cups
    r = cups.reaction
    return {
        "cup_centre_m": np.asarray(cups.centre_m),
        "cup_normal": np.asarray(cups.normal),
        "cup_radius_m": np.asarray(cups.radius_m),
        "cup_holding_force_n": np.asarray(cups.holding_force_n),
        "cup_friction": np.asarray(cups.friction),
        "cup_reaction_q": np.asarray(r.q_map).reshape(c, 6, -1),
        "cup_reaction_v": np.asarray(r.v_map).reshape(c, 6, -1),
        "cup_reaction_a": np.asarray(r.a_map).reshape(c, 6, 3),
    }


def cups_from_fields(f: dict[str, np.ndarray]) -> CupSet:
    c = f["cup_centre_m"].shape[0]
    reaction = LinearOutputs(
        f["cup_reaction_q"].reshape(6 * c, -1),
        f["cup_reaction_v"].reshape(6 * c, -1),
        f["cup_reaction_a"].reshape(6 * c, 3),
    )
    return CupSet(
        f["cup_centre_m"],
        f["cup_normal"],
        f["cup_radius_m"],
        f["cup_holding_force_n"],
        f["cup_friction"],
        reaction,
    )


def stress_to_fields(stress: StressSet) -> dict[str, np.ndarray]:
    s = stress.n_points
    return {
        "stress_points_m": np.asarray(stress.points_m),
        "stress_q": np.asarray(stress.stress.q_map).reshape(s, 6, -1),
        "stress_v": np.asarray(stress.stress.v_map).reshape(s, 6, -1),
        "stress_a": np.asarray(stress.stress.a_map).reshape(s, 6, 3),
    }


def stress_from_fields(f: dict[str, np.ndarray]) -> StressSet:
    s = f["stress_points_m"].shape[0]
    maps = LinearOutputs(
        f["stress_q"].reshape(6 * s, -1),
        f["stress_v"].reshape(6 * s, -1),
        f["stress_a"].reshape(6 * s, 3),
    )
    return StressSet(f["stress_points_m"], maps)
