"""The options of :func:`fmu.export_fmu` and :func:`fmu.export_ssp`, as objects checked once
when made (the style of ``jaxflex.Turn`` and diffrax's ``SaveAt``): what FMU to build
(:class:`Fmi`), which outputs of the robot cell it reports (:class:`CellOutputs`) and the
pose inputs of a turning part (:class:`Turning`). Each refuses a bad field with an InputError
naming it (``version: ...``), what is allowed and what was given."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.geometry import DEFAULT_GRAVITY_M_S2, Cell
from jaxflex.response import DEFAULT_CUP_SAFETY, PosePath, Turn


def _text(name: str, value) -> None:
    if value is not None and (not isinstance(value, str) or not value.strip()):
        raise InputError(f"{name}: None or a non-empty text, got {value!r}")


def _vector(name: str, value, allowed: str) -> np.ndarray:
    """``value`` as a read-only float64 (3,); InputError naming ``name`` otherwise."""
    try:
        vector = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        vector = None
    if vector is None or vector.shape != (3,) or not np.isfinite(vector).all():
        raise InputError(f"{name}: three finite numbers, {allowed}; got {value!r}")
    vector.setflags(write=False)
    return vector


@dataclass(frozen=True)
class Fmi:
    """The FMU to build: FMI ``version`` 2 or 3 (co-simulation); ``windows``: build the
    Windows DLL too (None: when mingw-w64 is installed, True: it must be, False: never);
    ``model_name`` and ``description``: text for modelDescription.xml (None: the file's
    model identifier, and a description of the part)."""

    version: int = 2
    windows: bool | None = None
    model_name: str | None = None
    description: str | None = None

    def __post_init__(self) -> None:
        if isinstance(self.version, bool) or self.version not in (2, 3):
            raise InputError(f"version: the FMI version, 2 or 3, got {self.version!r}")
        object.__setattr__(self, "version", int(self.version))
        if not (self.windows is None or isinstance(self.windows, bool)):
            raise InputError(
                f"windows: None (when mingw-w64 is installed), True or False, got {self.windows!r}"
            )
        _text("model_name", self.model_name)
        _text("description", self.description)


@dataclass(frozen=True, eq=False)
class CellOutputs:
    """The outputs of the robot cell: ``cell`` (a jaxflex.geometry.Cell or None): the model
    is posed in it (inputs, points and trajectory in cell coordinates) and the FMU reports the
    distance to its obstacles (``min_distance``; FMI 3.0 also ``point_distances``);
    ``cup_safety`` (> 0): safety factor of the cup utilisation outputs (``cup_utilisation``;
    FMI 3.0 also ``cup_utilisations``; present when the model has cup reactions); ``stress``:
    also the von Mises outputs (``max_stress``; FMI 3.0 ``point_stresses``: the stress maps
    can make the resource large, 1.9 kB per stress point at 20 modes)."""

    cell: Cell | None = None
    cup_safety: float = DEFAULT_CUP_SAFETY
    stress: bool = False

    def __post_init__(self) -> None:
        if self.cell is not None and not isinstance(self.cell, Cell):
            raise InputError(
                "cell: None or a jaxflex.geometry.Cell (optim.cell_file.load_cell), "
                f"got {type(self.cell).__name__}"
            )
        object.__setattr__(self, "cup_safety", check_positive("cup_safety", self.cup_safety))
        if not isinstance(self.stress, bool):
            raise InputError(f"stress: True or False, got {self.stress!r}")

    @property
    def gravity_m_s2(self) -> tuple[float, float, float]:
        """Gravity (3,) m/s^2, world components: the cell's, else the default."""
        return DEFAULT_GRAVITY_M_S2 if self.cell is None else self.cell.gravity_m_s2


@dataclass(frozen=True, eq=False)
class Turning:
    """A turning part: the FMU takes the pose as inputs too (the orientation quaternion
    quat_w..quat_z body -> world, the angular velocity omega_x..z and acceleration alpha_x..z
    in body components; ax, ay, az the world acceleration of ``pivot_m``) and is forced as
    jaxflex.simulate_turning (the model needs rotation data).

    ``pivot_m`` (3,) m, model frame (with a cell: its coordinates at the start, the posed
    model's frame): the point whose acceleration ax, ay, az are; ``gravity_m_s2`` (3,) m/s^2
    in world components (None: the cell's, else (0, 0, -9.81); with a cell it must be the
    cell's); ``pose``: the orientation path (jaxflex.response.PosePath) of an embedded
    trajectory, at its samples and step, starting and ending at rest (required with a
    trajectory, refused without). :meth:`of` makes one from a jaxflex.Turn."""

    pivot_m: np.ndarray = (0.0, 0.0, 0.0)  # type: ignore[assignment]  # made (3,) float64
    gravity_m_s2: np.ndarray | None = None
    pose: PosePath | None = None

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "pivot_m", _vector("pivot_m", self.pivot_m, "m in the model frame")
        )
        if self.gravity_m_s2 is not None:
            gravity = _vector("gravity_m_s2", self.gravity_m_s2, "m/s^2 in the world frame")
            object.__setattr__(self, "gravity_m_s2", gravity)
        if self.pose is not None and not isinstance(self.pose, PosePath):
            raise InputError(
                "pose: None or a jaxflex.response.PosePath (e.g. fixed_axis_path), got "
                f"{type(self.pose).__name__}"
            )

    @classmethod
    def of(cls, turn: Turn) -> Turning:
        """The turning options of the core's turning move ``turn`` (its pose path, pivot and
        gravity); its translation ``turn.acc`` is the trajectory (``jaxflex.as_move(turn.acc,
        turn.dt_s)``)."""
        if not isinstance(turn, Turn):
            raise InputError(f"turn: a jaxflex.Turn, got {type(turn).__name__}")
        return cls(pivot_m=turn.pivot_m, gravity_m_s2=turn.gravity_m_s2, pose=turn.path)

    def gravity_in(self, outputs: CellOutputs) -> np.ndarray:
        """Gravity (3,) m/s^2 (world) of the turning part with ``outputs``' cell: the cell's;
        InputError if this object gives another."""
        cell_gravity = np.asarray(outputs.gravity_m_s2, dtype=np.float64)
        if self.gravity_m_s2 is None:
            return cell_gravity
        if outputs.cell is not None and not np.allclose(
            self.gravity_m_s2, cell_gravity, rtol=1e-12, atol=0.0
        ):
            raise InputError(
                f"gravity_m_s2: with a cell the cell's gravity "
                f"{cell_gravity.tolist()} m/s^2 (or None), got {self.gravity_m_s2.tolist()}"
            )
        return self.gravity_m_s2
