"""The FMU's variables: one table that both modelDescription.xml and the C build read.

Value references are fixed across exports, so a virtual-commissioning project keeps its
connections when a part is exported again. The C code sees them as ``JXF_VR_*`` macros in the
generated ``jxf_config.h`` (see :func:`config_header`); nothing is numbered twice. Every
variable ``name`` is read by the C function ``jxf_value_<name>`` in ``fmu/c/jxf_values.c``,
which ``jxf_config.h`` declares and lists by value reference: a new output is a row here and
that one function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fmu import obstacles
from fmu.resource import Counts
from jaxflex.response import VALUE_RANGES

RESOURCE_FILE = "jaxflex_model.bin"
INPUT_COLUMNS = ("time", "ax", "ay", "az")  # input CSV / fmpy signal: s, m/s^2

_INPUT_HELD = "held constant over a communication step"
_INPUT_FMI2 = (
    "linear over a communication step when the importer sets its time derivative with "
    "fmi2SetRealInputDerivatives (canInterpolateInputs; in effect until set again), "
    + _INPUT_HELD
    + " otherwise"
)
_INPUT_FMI3 = _INPUT_HELD + " (FMI 3.0 has no input derivatives)"


@dataclass(frozen=True)
class Variable:
    """One FMU variable. ``kind`` is "real" (fmi2 Real / fmi3 Float64) or "bool".

    ``fmi`` lists the FMI major versions that have it; ``needs_trajectory`` marks variables
    that exist only when a trajectory is embedded, ``needs`` those that exist only when the
    model has "cups", "stress" or "obstacles" (the cell) or turns ("turning": the pose
    inputs); ``dims`` gives an array's
    dimensions (FMI 3): "points", "cups", "stress_points" or a number.
    """

    name: str
    vr: int
    kind: str
    causality: str
    variability: str
    initial: str | None
    unit: str | None
    description: str
    macro: str
    fmi: tuple[int, ...] = (2, 3)
    needs_trajectory: bool = False
    dims: tuple = ()
    needs: str | None = None

    @property
    def array(self) -> bool:
        return bool(self.dims)


def _input(axis: str, vr: int) -> Variable:
    return Variable(
        name=f"a{axis}",
        vr=vr,
        kind="real",
        causality="input",
        variability="continuous",
        initial=None,
        unit="m/s2",
        description=f"Base acceleration of the gripper along {axis}, m/s^2",
        macro=f"A{axis.upper()}",
    )


# the pose inputs of a turning part (export with fmu.Turning), in the order of the C's drive
# (jxf_model.h: acceleration, quaternion, angular velocity, angular acceleration)
_POSE_INPUTS = (
    ("quat_w", "1", "Orientation of the gripper (body to world) as a quaternion, scalar part"),
    ("quat_x", "1", "Orientation quaternion (body to world), x of the vector part"),
    ("quat_y", "1", "Orientation quaternion (body to world), y of the vector part"),
    ("quat_z", "1", "Orientation quaternion (body to world), z of the vector part"),
    ("omega_x", "rad/s", "Angular velocity of the gripper, x in body components, rad/s"),
    ("omega_y", "rad/s", "Angular velocity of the gripper, y in body components, rad/s"),
    ("omega_z", "rad/s", "Angular velocity of the gripper, z in body components, rad/s"),
    ("alpha_x", "rad/s2", "Angular acceleration of the gripper, x in body components, rad/s^2"),
    ("alpha_y", "rad/s2", "Angular acceleration of the gripper, y in body components, rad/s^2"),
    ("alpha_z", "rad/s2", "Angular acceleration of the gripper, z in body components, rad/s^2"),
)
POSE_INPUT_NAMES = tuple(name for name, _, _ in _POSE_INPUTS)


def pose_unit(name: str) -> str:
    """The unit of the pose input ``name`` ("1" for the quaternion's components)."""
    return next(unit for n, unit, _ in _POSE_INPUTS if n == name)


def _pose_input(index: int) -> Variable:
    name, unit, description = _POSE_INPUTS[index]
    return Variable(
        name, 40 + index, "real", "input", "continuous", None, unit if unit != "1" else None,
        description, name.upper(), needs="turning",
    )  # fmt: skip


VARIABLES: tuple[Variable, ...] = (
    Variable(
        "time", 0, "real", "independent", "continuous", None, "s", "Simulation time, s",
        "TIME", fmi=(3,),
    ),
    _input("x", 1),
    _input("y", 2),
    _input("z", 3),
    *(_pose_input(i) for i in range(len(_POSE_INPUTS))),
    Variable(
        "deviation", 10, "real", "output", "continuous", "calculated", "m",
        "Largest displacement magnitude over the monitored points relative to the rigid part "
        "at the communication point, m",
        "DEVIATION",
    ),
    Variable(
        "settle_time", 11, "real", "output", "discrete", "calculated", "s",
        "Time at which 'settled' last became true, s (the exact settle time lies within one "
        "communication step before it)",
        "SETTLE_TIME",
    ),
    Variable(
        "settled", 12, "bool", "output", "discrete", "calculated", None,
        "True while deviation <= threshold at the communication point",
        "SETTLED",
    ),
    Variable(
        "threshold", 20, "real", "parameter", "tunable", "exact", "m",
        "Deviation threshold of the 'settled' flag, m (> 0)",
        "THRESHOLD",
    ),
    Variable(
        "damping_scale", 21, "real", "parameter", "tunable", "exact", None,
        "Factor on every modal damping ratio (1 = as exported; >= 0 and keeping each ratio "
        "below 1)",
        "DAMPING_SCALE",
    ),
    Variable(
        "use_embedded_trajectory", 22, "bool", "parameter", "fixed", "exact", None,
        "Replay the embedded optimised trajectory (exact: linear between its samples, at rest "
        "after its end) instead of the inputs ax, ay, az",
        "USE_TRAJECTORY",
        needs_trajectory=True,
    ),
    Variable(
        "displaced_points", 30, "real", "output", "continuous", "calculated", "m",
        "Displaced coordinates of the monitored points (undeformed + deviation), K x 3, m",
        "DISPLACED_POINTS", fmi=(3,), dims=("points", 3),
    ),
    Variable(
        "undeformed_points", 31, "real", "calculatedParameter", "fixed", "calculated", "m",
        "Undeformed coordinates of the monitored points, K x 3, m",
        "POINTS", fmi=(3,), dims=("points", 3),
    ),
    Variable(
        "min_distance", 14, "real", "output", "continuous", "calculated", "m",
        "Smallest distance of a monitored point (path + gravity deflection + deviation) to an "
        "obstacle of the cell at the communication point, m (negative: inside)",
        "MIN_DISTANCE", needs="obstacles",
    ),
    Variable(
        "cup_utilisation", 15, "real", "output", "continuous", "calculated", None,
        "Largest utilisation of a suction cup (pull, shear, peel and torsion against its "
        "holding force with the safety factor; 1 = at its limit) at the communication point",
        "CUP_UTILISATION", needs="cups",
    ),
    Variable(
        "max_stress", 16, "real", "output", "continuous", "calculated", "Pa",
        "Largest von Mises stress at the part's surface (with gravity) at the communication "
        "point, Pa",
        "MAX_STRESS", needs="stress",
    ),
    Variable(
        "point_distances", 32, "real", "output", "continuous", "calculated", "m",
        "Distance of every monitored point to the nearest obstacle, K values, m",
        "POINT_DISTANCES", fmi=(3,), dims=("points",), needs="obstacles",
    ),
    Variable(
        "cup_utilisations", 33, "real", "output", "continuous", "calculated", None,
        "Utilisation of every suction cup, C values",
        "CUP_UTILISATIONS", fmi=(3,), dims=("cups",), needs="cups",
    ),
    Variable(
        "point_stresses", 34, "real", "output", "continuous", "calculated", "Pa",
        "Von Mises stress at every stress point of the part's surface, S values, Pa",
        "POINT_STRESSES", fmi=(3,), dims=("stress_points",), needs="stress",
    ),
    Variable(
        "cup_reactions", 35, "real", "output", "continuous", "calculated", None,
        "Reaction of every suction cup on the part, C x 6: force (N) and moment about the cup "
        "centre (N m), in the part's (body) frame",
        "CUP_REACTIONS", fmi=(3,), dims=("cups", 6), needs="cups",
    ),
)  # fmt: skip
# the counts of an export (fmu.resource.Counts fields) -> their C macros (jxf_config.h)
COUNT_MACROS = {
    "points": "JXF_N_POINTS",
    "modes": "JXF_N_MODES",
    "trajectory": "JXF_N_TRAJ",
    "cups": "JXF_N_CUPS",
    "stress": "JXF_N_STRESS",
    "obstacles": "JXF_N_OBSTACLES",
    "static": "JXF_N_STATIC",
    "turning": "JXF_TURNING",
}
# array dimensions of VARIABLES -> the Counts field of their size
DIMENSIONS = {"points": "points", "cups": "cups", "stress_points": "stress"}


_C_TYPE = {"real": "double", "bool": "int"}


def variables_for(
    fmi_version: int, has_trajectory: bool, available: frozenset[str] = frozenset()
) -> list[Variable]:
    """The variables of one FMU, in modelDescription order; ``available``: which of "cups",
    "stress", "obstacles", "turning" the exported model has."""
    return [
        v
        for v in VARIABLES
        if fmi_version in v.fmi
        and (has_trajectory or not v.needs_trajectory)
        and (v.needs is None or v.needs in available)
    ]


def array_size(v: Variable) -> str:
    """The C expression of the number of values of ``v`` (1 for scalars)."""
    if not v.dims:
        return "1u"
    return " * ".join(
        f"{d}u" if isinstance(d, int) else f"(size_t){COUNT_MACROS[DIMENSIONS[d]]}" for d in v.dims
    )


def input_description(fmi_version: int) -> str:
    """How the FMU treats the inputs over a step (written into each input's description)."""
    return _INPUT_FMI2 if fmi_version == 2 else _INPUT_FMI3


def config_header(
    *,
    fmi_version: int,
    token: str,
    counts: Counts,
    threshold_m: float,
    damping_scale: float,
) -> str:
    """``jxf_config.h`` for one export: sizes, token, start values and value references,
    the same numbers that modelDescription.xml declares."""
    if not all(math.isfinite(x) for x in (threshold_m, damping_scale)):
        raise ValueError("start values must be finite")
    variables = variables_for(fmi_version, counts.trajectory > 0, counts.variable_groups())
    inputs = ", ".join(f"JXF_VR_{v.macro}" for v in variables if v.causality == "input")
    lines = [
        "/* Generated by jaxflex (fmu.variables): must match modelDescription.xml. */",
        "#ifndef JXF_CONFIG_H",
        "#define JXF_CONFIG_H",
        f"#define JXF_FMI_VERSION {int(fmi_version)}",
        f'#define JXF_TOKEN "{token}"',
        f'#define JXF_RESOURCE_FILE "{RESOURCE_FILE}"',
        *(f"#define {macro} {int(getattr(counts, name))}" for name, macro in COUNT_MACROS.items()),
        f"#define JXF_START_THRESHOLD {float(threshold_m)!r}",
        f"#define JXF_START_DAMPING_SCALE {float(damping_scale)!r}",
    ]
    lines += [  # the physical ranges every model is checked against (jaxflex._model_file)
        f"#define JXF_RANGE_{name.upper()} {float(low)!r}, {float(high)!r}"
        for name, (low, high) in VALUE_RANGES.items()
    ]
    lines += obstacles.config_lines()  # the kinds of obstacle records (fmu.obstacles)
    lines += [f"#define JXF_VR_{v.macro} {v.vr}u" for v in variables]
    lines += [f"#define JXF_INPUT_VRS {{{inputs}}}"]  # the drive's order (jxf_model.h)
    table = ", ".join(f'{{{v.vr}u, "{v.name}"}}' for v in variables)
    lines += [f"#define JXF_VARIABLE_TABLE {{{table}}}", "struct jxf_model;"]
    lines += [
        f"void {value_function(v)}(const struct jxf_model *m, {_C_TYPE[v.kind]} *out);"
        for v in variables
    ]
    reals = ", ".join(
        f"{{JXF_VR_{v.macro}, {array_size(v)}, {value_function(v)}}}"
        for v in variables
        if v.kind == "real"
    )
    bools = ", ".join(
        f"{{JXF_VR_{v.macro}, {value_function(v)}}}" for v in variables if v.kind == "bool"
    )
    lines += [f"#define JXF_REAL_VALUES {{{reals}}}", f"#define JXF_BOOL_VALUES {{{bools}}}"]
    lines += ["#endif", ""]
    return "\n".join(lines)


def value_function(v: Variable) -> str:
    """Name of the C function in fmu/c/jxf_values.c that reads ``v``."""
    return f"jxf_value_{v.name}"
