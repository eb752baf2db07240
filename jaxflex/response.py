"""The building blocks of the certified response, for the layers above the core (fem, optim,
fmu): the exact modal state maps (engine), deviation and outputs at points (deviation,
outputs, loads), the decay envelopes and certified peaks (decay, peaks), the move's samples
(profile, grid), the point sets (points), the soft maximum (surrogate), and turning moves
(pose, rotation, turning, rotation_residual, turning_outputs, turning_peaks: a turn about a
fixed axis, the model's rotational inertia data, the rotational loads' static residual, cups
and stresses of a turning part and their certified peaks).
Public: these names are kept stable for the upper layers; the modules they come from are
private to the core.

Units and shapes: each function's docstring (SI units throughout; a move ``acc`` is
(n+1, 3) m/s^2 at step ``dt_s`` s).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): each name loads only its module
    from jaxflex._decay import (
        amplitudes,
        envelope_horizon,
        free_rows,
    )
    from jaxflex._deviation import (
        component_blocks,
        deviation,
        deviation_curve,
        deviation_curves,
        max_norms,
        outputs_at,
        point_displacements,
        response_shapes,
        with_acceleration,
    )
    from jaxflex._engine import (
        end_state_map,
        forced_states,
        free_states,
        modal_forces,
        modal_states,
        padded_steps,
        rest_padded,
        state_map,
        state_maps_at,
        states_at,
        states_between,
        upsample,
    )
    from jaxflex._grid import (
        grid_values,
    )
    from jaxflex._loads import (
        DEFAULT_CUP_SAFETY,
        DEFAULT_STRESS_SAFETY,
        CupUtilisation,
        VonMises,
    )
    from jaxflex._model_file import (
        ARRAY_FIELDS,
        VALUE_RANGES,
    )
    from jaxflex._outputs import (
        CupSet,
        LinearOutputs,
        StressSet,
    )
    from jaxflex._peaks import (
        Peak,
        item_bounds,
        once_per_array,
        one_blas_thread,
        output_peak,
        outputs_above,
    )
    from jaxflex._points import (
        downsample_to_count,
        snap_key_points,
        voxel_downsample,
    )
    from jaxflex._pose import (
        PosePath,
        axis_angle,
        axis_rotation,
        fixed_axis_path,
        joined_paths,
        orientation_path,
        turn_acceleration,
        unit_axis,
    )
    from jaxflex._profile import (
        Move,
        acceleration_at,
        as_move,
        axis_limits,
        enforce_end_state,
        integrate,
        jerk_limited_move,
        kinematics_at,
        position_weights,
        samples_at,
    )
    from jaxflex._rotation import LEVI_CIVITA, RotationalInertia, require_rotation
    from jaxflex._rotation_residual import (
        load_coefficients,
        output_residual,
        rotation_residual,
        turning_blocks,
        turning_coordinates,
        turning_shapes,
    )
    from jaxflex._settle import SettleReport, analyze_move
    from jaxflex._simulate import (
        move_deviation,
        on_device,
    )
    from jaxflex._surrogate import soft_max
    from jaxflex._turning import (
        GRAVITY_M_S2,
        Turn,
        TurningInputs,
        TurningResponse,
        body_loads,
        gravity_coordinates,
        simulate_turning,
        turning_forces,
        turning_inputs,
        turning_settle,
    )
    from jaxflex._turning_bound import setup_need as turning_bound_need
    from jaxflex._turning_outputs import TurningLoads, turning_loads
    from jaxflex._turning_peaks import turning_output_peak

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "ARRAY_FIELDS",
    "DEFAULT_CUP_SAFETY",
    "DEFAULT_STRESS_SAFETY",
    "GRAVITY_M_S2",
    "LEVI_CIVITA",
    "VALUE_RANGES",
    "CupSet",
    "CupUtilisation",
    "LinearOutputs",
    "Move",
    "Peak",
    "PosePath",
    "RotationalInertia",
    "SettleReport",
    "StressSet",
    "Turn",
    "TurningInputs",
    "TurningLoads",
    "TurningResponse",
    "VonMises",
    "acceleration_at",
    "amplitudes",
    "analyze_move",
    "as_move",
    "axis_angle",
    "axis_limits",
    "axis_rotation",
    "body_loads",
    "component_blocks",
    "deviation",
    "deviation_curve",
    "deviation_curves",
    "downsample_to_count",
    "end_state_map",
    "enforce_end_state",
    "envelope_horizon",
    "fixed_axis_path",
    "forced_states",
    "free_rows",
    "free_states",
    "gravity_coordinates",
    "grid_values",
    "integrate",
    "item_bounds",
    "jerk_limited_move",
    "joined_paths",
    "kinematics_at",
    "load_coefficients",
    "max_norms",
    "modal_forces",
    "modal_states",
    "move_deviation",
    "on_device",
    "once_per_array",
    "one_blas_thread",
    "orientation_path",
    "output_peak",
    "output_residual",
    "outputs_above",
    "outputs_at",
    "padded_steps",
    "point_displacements",
    "position_weights",
    "require_rotation",
    "response_shapes",
    "rest_padded",
    "rotation_residual",
    "samples_at",
    "simulate_turning",
    "snap_key_points",
    "soft_max",
    "state_map",
    "state_maps_at",
    "states_at",
    "states_between",
    "turn_acceleration",
    "turning_blocks",
    "turning_bound_need",
    "turning_coordinates",
    "turning_forces",
    "turning_inputs",
    "turning_loads",
    "turning_output_peak",
    "turning_settle",
    "turning_shapes",
    "unit_axis",
    "upsample",
    "voxel_downsample",
    "with_acceleration",
]
