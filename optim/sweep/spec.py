"""Sweep specification: the part, the modal settings, the moves and the gripper layouts.

A specification is a JSON (``.json``) or TOML (``.toml``) file, or the same structure as a
Python mapping; :data:`EXAMPLE` (``jaxflex sweep --example``) shows and explains every field.
SI units throughout (m, s, m/s, m/s^2, m/s^3). Every error names the field, e.g.
``moves[1].vmax: ...`` or ``grids[0].inset_x[2]: ...``. Omitted fields take the defaults of
the dataclasses below.

Whether a layout can hold the part (cups on the part, not overlapping, not collinear) is not
checked here: the finite-element step rejects it, and the sweep records that case as an error.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from fem.parts import ELEMENTS
from jaxflex.cli import AXIS_LIMITS
from jaxflex.defaults import DT_S, MAX_DURATION_S, THRESHOLD_M
from jaxflex.errors import InputError
from jaxflex.files import file_digest, read_settings_file
from jaxflex.runtime import require
from optim.options import FREQ_SCALE, ZETA, RobustSpec
from optim.sweep.part import build_part, footprint_box
from optim.sweep.plan import spec_need

SHAPES = ("plate", "panel")
METHODS = ("exact", "gradient")
MATERIALS = ("steel", "aluminium")
_TOP = ("name", "part", "model", "optimization", "moves", "layouts", "grids")

EXAMPLE = """\
# jaxflex sweep specification (TOML; the same structure works as JSON). SI units.
name = "plate-grippers"

[part]                      # one part for every layout
shape = "plate"             # "plate" (flat, Kirchhoff/Morley) or "panel" (curved thin solid)
width_m = 1.2
height_m = 0.8
thickness_m = 0.8e-3
material = "aluminium"      # or "steel"
mesh_size_m = 0.03          # element size (optional; fem's default is finer and slower)
# Your own part instead of shape/width_m/height_m: a mesh file (any format jaxflex model
# --mesh reads, used as is) or a CAD sheet body (.step/.iges/.brep, meshed at mesh_size_m),
# the path relative to this file; cups and grids are then in the part's coordinates (m).
# path = "fender.step"
# scale = 1.0               # file coordinates to metres (1e-3 for a mesh in millimetres)
# element = "shell"         # optional: morley, argyris, shell, hex2 (default: by the part)

[model]
n_modes = 12
zeta = 0.02                 # modal damping ratio
monitor_grid = [24, 16]     # monitored points: nx x ny cell centres of the footprint

[optimization]
dt_s = 0.01
threshold_m = 2e-4          # deviation threshold after the move
method = "exact"            # or "gradient"
max_duration_s = 30.0
robust = false              # true, or {freq_scale = [0.9, 1.1], zeta = [0.01, 0.03],
                            #           n_freq = 21, n_zeta = 3}

[[moves]]
name = "lift"
distance_m = [0.0, 0.0, 0.8]
vmax = 2.0                  # m/s: one value or three (x, y, z); amax, jmax alike
amax = 10.0                 # m/s^2
jmax = 100.0                # m/s^3

[[moves]]
name = "transfer"
distance_m = [1.0, 0.0, 0.3]

[[layouts]]                 # explicit layouts: cups [x_m, y_m, radius_m] or [x, y, z, radius]
name = "three cups"
cups = [[0.25, 0.2, 0.04], [0.95, 0.2, 0.04], [0.6, 0.6, 0.04]]

[[grids]]                   # rectangular patterns: every combination is a layout
name = "rect"
nx = [2, 3]                 # cups along x
ny = [2]                    # cups along y
inset_x = [0.15, 0.25]      # outer cups' distance from the edges, fraction of the width
inset_y = [0.2, 0.3]        # ... of the height
radius_m = [0.03, 0.045]
"""


@dataclass(frozen=True)
class PartSpec:
    """The part every layout holds: a built-in shape (footprint [0, width_m] x [0,
    height_m], m) or the mesh or CAD file ``path`` (absolute; ``scale`` to metres,
    ``element`` None for the part's default; ``file_sha256`` its content, so that a changed
    file makes new cases)."""

    shape: str = "plate"
    width_m: float = 1.5
    height_m: float = 0.8
    thickness_m: float = 1e-3
    material: str = "steel"
    mesh_size_m: float | None = None
    path: str | None = None
    scale: float = 1.0
    element: str | None = None
    file_sha256: str | None = None


_PART_FIELDS = tuple(k for k in PartSpec.__dataclass_fields__ if k != "file_sha256")
_FILE_ONLY = ("path", "scale", "element")


@dataclass(frozen=True)
class ModelSpec:
    """Modal settings: modes kept, damping ratio, monitored-point grid (nx, ny)."""

    n_modes: int = 20
    zeta: float = 0.02
    monitor_grid: tuple[int, int] = (30, 16)


@dataclass(frozen=True)
class OptimizationSpec:
    """Settings of optim.optimize shared by every case; ``robust`` None or a RobustSpec dict."""

    dt_s: float = DT_S
    threshold_m: float = THRESHOLD_M
    method: str = "exact"
    max_duration_s: float = MAX_DURATION_S
    robust: dict | None = None


LIMIT_KEYS = tuple((key, unit) for key, unit, _default in AXIS_LIMITS)


@dataclass(frozen=True)
class MoveSpec:
    """A rest-to-rest move: displacement (m) and per-axis limits (tuples of three, SI)."""

    name: str
    distance_m: tuple[float, float, float]
    vmax: tuple[float, ...]
    amax: tuple[float, ...]
    jmax: tuple[float, ...]


@dataclass(frozen=True)
class LayoutSpec:
    """A gripper layout: cups as (x_m, y_m, radius_m) on the part's footprint."""

    name: str
    cups: tuple[tuple[float, float, float], ...]


@dataclass(frozen=True)
class SweepSpec:
    """A whole sweep: every layout with every move (the cases, see optim.sweep.cases)."""

    name: str
    part: PartSpec
    model: ModelSpec
    optimization: OptimizationSpec
    moves: tuple[MoveSpec, ...]
    layouts: tuple[LayoutSpec, ...]
    source: dict = field(default_factory=dict, compare=False)


# -- field readers: every error names the field ------------------------------------------


def _keys(where: str, data: Any, allowed: tuple[str, ...]) -> Mapping:
    if not isinstance(data, Mapping):
        raise InputError(f"{where or 'spec'}: expected a table/object, got {type(data).__name__}")
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        name = f"{where}.{unknown[0]}" if where else unknown[0]
        raise InputError(f"{name}: unknown field; allowed fields are {', '.join(allowed)}")
    return data


def _number(where: str, value: Any, *, positive: bool = True, unit: str = "") -> float:
    suffix = f" ({unit})" if unit else ""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}: expected a number{suffix}, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise InputError(f"{where}: must be finite, got {value!r}")
    if positive and x <= 0:
        raise InputError(f"{where}: must be > 0{suffix}, got {value!r}")
    return x


def _integer(where: str, value: Any, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{where}: expected an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise InputError(f"{where}: must be >= {minimum}, got {value}")
    return int(value)


def _choice(where: str, value: Any, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise InputError(f"{where}: must be one of {list(allowed)}, got {value!r}")
    return str(value)


def _name(where: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{where}: expected a non-empty string, got {value!r}")
    return value.strip()


def _list(where: str, value: Any, *, min_len: int = 1) -> list:
    if not isinstance(value, list | tuple) or len(value) < min_len:
        raise InputError(f"{where}: expected a list of at least {min_len} item(s), got {value!r}")
    return list(value)


def _axis_values(where: str, value: Any, unit: str) -> tuple[float, ...]:
    if isinstance(value, list | tuple):
        if len(value) != 3:
            raise InputError(f"{where}: give one value or three (x, y, z) in {unit}, got {value}")
        return tuple(_number(f"{where}[{i}]", v, unit=unit) for i, v in enumerate(value))
    return (_number(where, value, unit=unit),) * 3


# -- sections ----------------------------------------------------------------------------


def _part(data: Any, base: Path) -> PartSpec:
    d = _keys("part", data, _PART_FIELDS)
    default = PartSpec()
    mesh = d.get("mesh_size_m")
    if "path" in d:
        return _file_part(d, base)
    for key in _FILE_ONLY:
        if key in d:
            raise InputError(f"part.{key}: only with part.path (a mesh or CAD file)")
    return PartSpec(
        shape=_choice("part.shape", d.get("shape", default.shape), SHAPES),
        width_m=_number("part.width_m", d.get("width_m", default.width_m), unit="m"),
        height_m=_number("part.height_m", d.get("height_m", default.height_m), unit="m"),
        thickness_m=_number(
            "part.thickness_m", d.get("thickness_m", default.thickness_m), unit="m"
        ),
        material=_choice("part.material", d.get("material", default.material), MATERIALS),
        mesh_size_m=None if mesh is None else _number("part.mesh_size_m", mesh, unit="m"),
    )


def _file_part(d: Mapping, base: Path) -> PartSpec:
    """A part from the mesh or CAD file ``d["path"]`` (relative to ``base``)."""
    for key in ("shape", "width_m", "height_m"):
        if key in d:
            raise InputError(f"part.{key}: not used with part.path (the file gives the geometry)")
    raw = _name("part.path", d["path"])
    path = (base / raw).resolve()
    if not path.is_file():
        raise InputError(f"part.path: no such file {str(path)!r}")
    if "thickness_m" not in d:
        raise InputError("part.thickness_m: required with part.path (sheet thickness in m)")
    element = d.get("element")
    if element is not None:
        element = _choice("part.element", element, ELEMENTS)
    mesh = d.get("mesh_size_m")
    return PartSpec(
        shape="file",
        thickness_m=_number("part.thickness_m", d["thickness_m"], unit="m"),
        material=_choice("part.material", d.get("material", "steel"), MATERIALS),
        mesh_size_m=None if mesh is None else _number("part.mesh_size_m", mesh, unit="m"),
        path=str(path),
        scale=_number("part.scale", d.get("scale", 1.0)),
        element=element,
        file_sha256=file_digest(path),
    )


def _model(data: Any) -> ModelSpec:
    d = _keys("model", data, tuple(ModelSpec.__dataclass_fields__))
    default = ModelSpec()
    zeta = _number("model.zeta", d.get("zeta", default.zeta))
    if zeta >= 1:
        raise InputError(f"model.zeta: must be a damping ratio in (0, 1), got {zeta}")
    grid = _list("model.monitor_grid", d.get("monitor_grid", list(default.monitor_grid)))
    if len(grid) != 2:
        raise InputError(f"model.monitor_grid: expected [nx, ny], got {grid}")
    return ModelSpec(
        n_modes=_integer("model.n_modes", d.get("n_modes", default.n_modes)),
        zeta=zeta,
        monitor_grid=tuple(_integer(f"model.monitor_grid[{i}]", v) for i, v in enumerate(grid)),
    )


def _robust(value: Any) -> dict | None:
    if value is False or value is None:
        return None
    if value is True:
        return RobustSpec().as_dict()
    d = _keys("optimization.robust", value, ("freq_scale", "zeta", "n_freq", "n_zeta"))
    try:
        return RobustSpec.from_dict({"freq_scale": FREQ_SCALE, "zeta": ZETA, **d}).as_dict()
    except (InputError, TypeError, ValueError) as exc:
        raise InputError(f"optimization.robust.{exc}") from exc


def _optimization(data: Any) -> OptimizationSpec:
    d = _keys("optimization", data, tuple(OptimizationSpec.__dataclass_fields__))
    default = OptimizationSpec()
    return OptimizationSpec(
        dt_s=_number("optimization.dt_s", d.get("dt_s", default.dt_s), unit="s"),
        threshold_m=_number(
            "optimization.threshold_m", d.get("threshold_m", default.threshold_m), unit="m"
        ),
        method=_choice("optimization.method", d.get("method", default.method), METHODS),
        max_duration_s=_number(
            "optimization.max_duration_s",
            d.get("max_duration_s", default.max_duration_s),
            unit="s",
        ),
        robust=_robust(d.get("robust", False)),
    )


def _move(i: int, data: Any) -> MoveSpec:
    where = f"moves[{i}]"
    d = _keys(where, data, ("name", *MoveSpec.__dataclass_fields__))
    if "distance_m" not in d:
        raise InputError(f"{where}.distance_m: required, e.g. [0, 0, 1.0] (m)")
    dist = _list(f"{where}.distance_m", d["distance_m"])
    if len(dist) != 3:
        raise InputError(f"{where}.distance_m: expected [x, y, z] in m, got {dist}")
    distance = tuple(
        _number(f"{where}.distance_m[{k}]", v, positive=False) for k, v in enumerate(dist)
    )
    if not any(distance):
        raise InputError(f"{where}.distance_m: the move must go somewhere, got {dist}")
    limits = {}
    for key, unit, default in AXIS_LIMITS:  # the command line's defaults
        limits[key] = _axis_values(f"{where}.{key}", d.get(key, default), unit)
    name = _name(f"{where}.name", d.get("name", f"move{i}"))
    return MoveSpec(name=name, distance_m=distance, **limits)  # type: ignore[arg-type]


def _cup(where: str, value: Any) -> tuple[float, float, float]:
    if isinstance(value, Mapping):
        d = _keys(where, value, ("x_m", "y_m", "radius_m"))
        missing = [k for k in ("x_m", "y_m", "radius_m") if k not in d]
        if missing:
            raise InputError(f"{where}.{missing[0]}: required (m)")
        value = [d["x_m"], d["y_m"], d["radius_m"]]
    if not isinstance(value, list | tuple) or len(value) not in (3, 4):
        raise InputError(
            f"{where}: expected [x_m, y_m, radius_m] or [x_m, y_m, z_m, radius_m], got {value!r}"
        )
    *centre, radius = value
    return (
        *(_number(f"{where}[{k}]", v, positive=False, unit="m") for k, v in enumerate(centre)),
        _number(f"{where}[{len(centre)}]", radius, unit="m"),
    )


def _layout(i: int, data: Any) -> LayoutSpec:
    where = f"layouts[{i}]"
    d = _keys(where, data, ("name", "cups"))
    if "cups" not in d:
        raise InputError(f"{where}.cups: required, a list of [x_m, y_m, radius_m]")
    cups = _list(f"{where}.cups", d["cups"])
    return LayoutSpec(
        name=_name(f"{where}.name", d.get("name", f"layout{i}")),
        cups=tuple(_cup(f"{where}.cups[{k}]", c) for k, c in enumerate(cups)),
    )


_GRID_FIELDS = ("nx", "ny", "inset_x", "inset_y", "radius_m")


def _grid_values(i: int, data: Any) -> tuple[str, dict[str, list]]:
    """(name, the checked lists of values of each field) of ``grids[i]``."""
    where = f"grids[{i}]"
    d = _keys(where, data, ("name", *_GRID_FIELDS))
    values: dict[str, list] = {}
    for key in _GRID_FIELDS:
        if key not in d:
            raise InputError(f"{where}.{key}: required, a list of values")
        items = d[key] if isinstance(d[key], list | tuple) else [d[key]]
        items = _list(f"{where}.{key}", items)
        if key in ("nx", "ny"):
            values[key] = [_integer(f"{where}.{key}[{k}]", v) for k, v in enumerate(items)]
        else:
            values[key] = [_number(f"{where}.{key}[{k}]", v) for k, v in enumerate(items)]
        if key.startswith("inset"):
            bad = [k for k, v in enumerate(values[key]) if v >= 0.5]
            if bad:
                raise InputError(
                    f"{where}.{key}[{bad[0]}]: a fraction of the side in (0, 0.5), "
                    f"got {values[key][bad[0]]}"
                )
    return _name(f"{where}.name", d.get("name", f"grid{i}")), values


def _grid_layouts(name: str, values: dict[str, list], box) -> list[LayoutSpec]:
    """Every combination of the grid's values as a layout named ``name/nx3-ny2-...``; the
    insets are fractions of the footprint box (x_min, y_min, x_max, y_max)."""
    layouts = []
    x0, y0, x1, y1 = box
    for nx, ny, fx, fy, r in itertools.product(*(values[k] for k in _GRID_FIELDS)):
        xs = _spread(x0 + fx * (x1 - x0), x1 - fx * (x1 - x0), nx)
        ys = _spread(y0 + fy * (y1 - y0), y1 - fy * (y1 - y0), ny)
        cups = tuple((x, y, r) for y in ys for x in xs)
        # repr: the shortest text that reads back as the value, so distinct values give
        # distinct names (0.05 and 0.0500001 are two layouts)
        label = f"{name}/nx{nx}-ny{ny}-ix{float(fx)!r}-iy{float(fy)!r}-r{float(r)!r}"
        layouts.append(LayoutSpec(name=label, cups=cups))
    return layouts


def _spread(lo: float, hi: float, count: int) -> list[float]:
    if count == 1:
        return [0.5 * (lo + hi)]
    return [lo + (hi - lo) * k / (count - 1) for k in range(count)]


def _box(part: PartSpec) -> tuple[float, float, float, float]:
    """The footprint box of the part (a file part is read for it)."""
    if part.path is None:
        return 0.0, 0.0, part.width_m, part.height_m
    try:
        return footprint_box(build_part(asdict(part)))
    except InputError as exc:
        raise InputError(f"part.path: {exc}") from exc


def parse_spec(data: Mapping, base: str | Path = ".") -> SweepSpec:
    """Validate a specification mapping (see the module docstring) into a SweepSpec;
    ``part.path`` is relative to ``base``."""
    d = _keys("", data, _TOP)
    part = _part(d.get("part", {}), Path(base))
    moves = tuple(_move(i, m) for i, m in enumerate(_list("moves", d.get("moves"))))
    given = _list("layouts", d.get("layouts") or [], min_len=0)
    layouts = [_layout(i, lay) for i, lay in enumerate(given)]
    grids = [
        _grid_values(i, g) for i, g in enumerate(_list("grids", d.get("grids") or [], min_len=0))
    ]
    count = len(layouts) + sum(math.prod(map(len, values.values())) for _, values in grids)
    require(spec_need(count, len(moves)))
    box = _box(part) if grids else None
    for name, values in grids:
        layouts.extend(_grid_layouts(name, values, box))
    if not layouts:
        raise InputError("layouts: give at least one layout (layouts = [...] or grids = [...])")
    for kind, items in (("moves", moves), ("layouts", layouts)):
        seen: set[str] = set()
        for item in items:
            if item.name in seen:
                raise InputError(f"{kind}: the name {item.name!r} is used twice; names must differ")
            seen.add(item.name)
    return SweepSpec(
        name=_name("name", d.get("name", "sweep")),
        part=part,
        model=_model(d.get("model", {})),
        optimization=_optimization(d.get("optimization", {})),
        moves=moves,
        layouts=tuple(layouts),
        source=json.loads(json.dumps(dict(d))),
    )


def load_spec(source: str | Path | Mapping, data: dict | None = None) -> SweepSpec:
    """Read and validate a ``.json`` or ``.toml`` specification file, or a specification
    mapping (module docstring; its ``part.path`` relative to the working directory).
    ``data``: the file's table, if already read (jaxflex.files.read_settings_file: light, so
    that ``jaxflex sweep`` refuses a file it cannot read before the sweep's modules load)."""
    if isinstance(source, Mapping):
        return parse_spec(source)
    path = Path(source)
    if data is None:
        data = read_settings_file("spec", path)
    try:
        return parse_spec(data, path.parent)
    except InputError as exc:
        raise InputError(f"{path.name}: {exc}") from exc
