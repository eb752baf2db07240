"""Outputs linear in the modal state besides the displacements: cup reactions and stresses.

Every such quantity obeys (Y rows, M modes; q, q' the modal state, a the base acceleration)

    y(t) = Q q(t) + V q'(t) + A a(t),      A = S + Q Omega^-2 Gamma              (1)

:class:`LinearOutputs` holds Q, V and the exact static response S (Y, 3): the output of the
part at rest under a constant unit base acceleration along x, y, z, from the FE's static
solve (the mode-acceleration method's quasi-static part: fem.outputs). A follows from S and
the modes that are kept (the model that owns the outputs derives it:
:meth:`LinearOutputs.with_modes`), so a mode dropped from the model responds quasi-statically
and the static response stays exact whatever modes are kept. At rest under a constant a the
modes settle at q = -Omega^-2 Gamma a and y = S a exactly.

Gravity g (m/s^2, in the model's frame) acts like a constant base acceleration -g on a part
that hangs at rest in it before the move: its share is the constant offset -S g
(:meth:`LinearOutputs.offset`), the move's own response (from rest) comes on top.

A model may carry (both optional, jaxflex._model_file stores them):

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

from jaxflex._validation import is_validated, validated
from jaxflex.errors import ModelError

VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))  # xx, yy, zz, yz, xz, xy
_ANY_MODES = ("kept by a scaling that leaves a_map as it is",)  # LinearOutputs.scaled
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
    velocity; static_map: (Y, 3) the exact static output per unit base acceleration (m/s^2);
    a_map: (Y, 3) per unit base acceleration in the modal form, static_map + q_map Omega^-2
    Gamma, derived by :meth:`with_modes` (None until then). Units of y: those of the
    quantity (N, N m, Pa).
    """

    q_map: Any
    v_map: Any
    static_map: Any
    a_map: Any = None

    def check(self, owner: str, n_rows: int, n_modes: int) -> LinearOutputs:
        """Validated outputs (shapes (Y, M), (Y, M), (Y, 3), finite); ModelError naming the
        field. Validated arrays are used as they are; a_map is kept (:meth:`with_modes`
        decides whether it still holds)."""
        return _same_or(
            self,
            _checked(owner, "q_map", self.q_map, (n_rows, n_modes)),
            _checked(owner, "v_map", self.v_map, (n_rows, n_modes)),
            _checked(owner, "static_map", self.static_map, (n_rows, 3)),
        )

    def with_modes(self, freq_hz, gamma) -> LinearOutputs:
        """The outputs with a_map = static_map + q_map Omega^-2 Gamma for the modes of
        frequencies ``freq_hz`` (M,) Hz and participation ``gamma`` (M, 3) (equation (1)).
        Returns ``self`` when its a_map was derived from these very arrays (a model derived
        from another with the same modes: nothing is computed again)."""
        modes = getattr(self, "_modes", (None, None))
        if self.a_map is not None and (
            modes is _ANY_MODES or (modes[0] is freq_hz and modes[1] is gamma)
        ):
            if modes is _ANY_MODES:
                object.__setattr__(self, "_modes", (freq_hz, gamma))
            return self
        omega = 2.0 * np.pi * np.asarray(freq_hz, dtype=np.float64)
        a_map = np.asarray(self.static_map) + np.asarray(self.q_map) @ (
            np.asarray(gamma) / omega[:, None] ** 2
        )
        out = LinearOutputs(self.q_map, self.v_map, self.static_map, validated(a_map))
        object.__setattr__(out, "_modes", (freq_hz, gamma))  # what a_map was derived from
        return out

    @property
    def n_rows(self) -> int:
        return int(np.shape(self.static_map)[0])

    def take_modes(self, keep: np.ndarray) -> LinearOutputs:
        """The outputs of the modes ``keep``; the dropped ones respond quasi-statically (their
        share stays in the static response; a_map is derived again by the model)."""
        return LinearOutputs(self.q_map[:, keep], self.v_map[:, keep], self.static_map)

    def scaled(self, q_scale, v_scale, *, same_a_map: bool = False) -> LinearOutputs:
        """The outputs with every mode's column of q_map and v_map multiplied by ``q_scale``
        and ``v_scale`` (M,) (a model whose stiffness or damping is scaled: jaxflex.model).
        With ``same_a_map`` the caller states that a_map stays what it is (stiffness scaled
        by s^2 with frequencies by s: Q Omega^-2 is unchanged; damping: Q is): it is kept
        instead of derived again. The products of validated maps and finite scales are not
        copied or scanned again (they are checked finite here)."""
        q = np.asarray(self.q_map) * np.asarray(q_scale)
        v = np.asarray(self.v_map) * np.asarray(v_scale)
        if not (np.isfinite(q).all() and np.isfinite(v).all()):
            raise ModelError("outputs: scaling the maps overflowed (a scale out of range)")
        kept = self.a_map if same_a_map else None
        out = LinearOutputs(validated(q), validated(v), self.static_map, kept)
        if kept is not None:
            object.__setattr__(out, "_modes", _ANY_MODES)
        return out

    def values(self, states, acc, xp: Any = np):
        """(T, Y) outputs for modal states (T, M, 2) and base accelerations (T, 3)."""
        return (
            states[..., 0] @ xp.asarray(self.q_map).T
            + states[..., 1] @ xp.asarray(self.v_map).T
            + xp.asarray(acc) @ xp.asarray(self.a_map).T
        )

    def offset(self, gravity_m_s2) -> np.ndarray:
        """(Y,) the output of the part at rest under gravity ``gravity_m_s2`` (3,) (a constant
        base acceleration -g): -S g, exact (module docstring)."""
        return -np.asarray(self.static_map) @ np.asarray(gravity_m_s2, dtype=np.float64)

    def transformed(self, block: np.ndarray, rotation: np.ndarray) -> LinearOutputs:
        """The outputs in a frame rotated by ``rotation`` (3, 3): every group of b rows mapped
        by ``block`` (b, b), the acceleration input by a_old = rotation^T a_new (a_map is
        derived again by the posed model, whose participation factors rotate too)."""
        b = block.shape[0]

        def rows(values: np.ndarray) -> np.ndarray:
            values = np.asarray(values)
            grouped = values.reshape(-1, b, values.shape[1])
            return np.einsum("ij,gjm->gim", block, grouped).reshape(values.shape)

        return LinearOutputs(
            rows(self.q_map), rows(self.v_map), rows(self.static_map) @ np.asarray(rotation).T
        )


def _same_or(outputs: LinearOutputs, q_map, v_map, static_map) -> LinearOutputs:
    """``outputs`` itself when it already holds these three arrays, else new outputs of them."""
    if q_map is outputs.q_map and v_map is outputs.v_map and static_map is outputs.static_map:
        return outputs
    return LinearOutputs(q_map, v_map, static_map)


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


def checked_cups(cups: CupSet, freq_hz: np.ndarray, gamma: np.ndarray) -> CupSet:
    """``cups`` with its reaction maps validated against the modes ``freq_hz`` (M,) Hz and
    ``gamma`` (M, 3) and a_map derived from them (ModelError naming the field)."""
    reaction = cups.reaction.check("cups.reaction", 6 * cups.n_cups, len(freq_hz))
    reaction = reaction.with_modes(freq_hz, gamma)
    if reaction is cups.reaction:
        return cups
    return CupSet(
        cups.centre_m, cups.normal, cups.radius_m, cups.holding_force_n, cups.friction, reaction
    )


def checked_stress(stress: StressSet, freq_hz: np.ndarray, gamma: np.ndarray) -> StressSet:
    """``stress`` with its maps validated against the modes and a_map derived (ModelError)."""
    maps = stress.stress.check("stress.stress", 6 * stress.n_points, len(freq_hz))
    maps = maps.with_modes(freq_hz, gamma)
    return stress if maps is stress.stress else StressSet(stress.points_m, maps)


# -- the model file's flat fields (jaxflex._model_file.OPTIONAL_FIELDS) ----------------------


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
        "cup_reaction_s": np.asarray(r.static_map).reshape(c, 6, 3),
    }


def legacy_static_map(q_map, a_map, freq_hz, gamma) -> np.ndarray:
    """(Y, 3) S = A - Q Omega^-2 Gamma: the static response of outputs stored by schema 2
    (which kept A). Exact for the modes the outputs were computed with; a mode dropped
    from the file after that leaves its quasi-static share out."""
    omega = 2.0 * np.pi * np.asarray(freq_hz, dtype=np.float64)
    return np.asarray(a_map) - np.asarray(q_map) @ (np.asarray(gamma) / omega[:, None] ** 2)


def _static_of(f: dict[str, np.ndarray], prefix: str, rows: int, modes) -> np.ndarray:
    """The static map of a group: stored (schema 3) or derived from schema 2's A."""
    if f"{prefix}_s" in f:
        return f[f"{prefix}_s"].reshape(rows, 3)
    q = f[f"{prefix}_q"].reshape(rows, -1)
    return legacy_static_map(q, f[f"{prefix}_a"].reshape(rows, 3), *modes)


def cups_from_fields(f: dict[str, np.ndarray], modes: tuple) -> CupSet:
    """The CupSet of the file's cup fields; ``modes`` = (freq_hz, gamma) of the model (for
    a schema-2 file's static map)."""
    c = f["cup_centre_m"].shape[0]
    reaction = LinearOutputs(
        f["cup_reaction_q"].reshape(6 * c, -1),
        f["cup_reaction_v"].reshape(6 * c, -1),
        _static_of(f, "cup_reaction", 6 * c, modes),
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
        "stress_s": np.asarray(stress.stress.static_map).reshape(s, 6, 3),
    }


def stress_from_fields(f: dict[str, np.ndarray], modes: tuple) -> StressSet:
    """The StressSet of the file's stress fields (``modes`` as :func:`cups_from_fields`)."""
    s = f["stress_points_m"].shape[0]
    maps = LinearOutputs(
        f["stress_q"].reshape(6 * s, -1),
        f["stress_v"].reshape(6 * s, -1),
        _static_of(f, "stress", 6 * s, modes),
    )
    return StressSet(f["stress_points_m"], maps)
