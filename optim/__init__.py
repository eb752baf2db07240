"""optim: minimum cycle-time transfers under robot limits.

Public interface (SI units throughout):

* ``Limits(vmax, amax, jmax, vpath=None, apath=None, jpath=None)`` and
  ``check_profile(move, limits, distance_m)`` (a jaxflex.Move);
* ``RobustSpec(freq_scale=(0.9, 1.1), zeta=(0.01, 0.03), n_freq=21, n_zeta=3)``;
* ``baselines(model, distance_m, limits, dt_s, threshold_m)`` -> ruckig floor, ruckig + free
  decay, ZV / ZVD / EI multi-mode shaped moves, each with its exact cycle time;
* ``optimize(model, distance_m, limits, dt_s, threshold_m, robust=None, constraints=None,
  rotation=None, search=None, budget=None)`` -> ``OptimizationResult`` (``.save(directory)``
  writes trajectory.csv, report.json, plots), its options frozen objects checked when made:
  ``Search(method="exact"|"gradient", solver=None, max_shaped_modes=6, progress=None)``,
  ``Constraints(cell=None, clearance_m=None, min_distance_m=None, cup_safety=None,
  max_stress_pa=None)``, ``Rotation(axis, angle_deg, angular_limits=None, pivot_m=None)``,
  ``Budget(max_duration_s=30, max_steps=5000, max_memory_bytes=None)``;
* ``worst_case(model, move, threshold_m, RobustSpec().grid())`` -> the largest exact cycle
  time of a Move over a robust grid, where, and every grid point.
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from optim.baselines import Baseline, BaselineSet, baselines, worst_case
    from optim.cell_file import load_cell
    from optim.limits import ConstraintCheck, Limits, Violation, check_profile
    from optim.optimize import optimize
    from optim.options import Budget, Constraints, RobustSpec, Rotation, Search
    from optim.result import OptimizationResult

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "Baseline",
    "BaselineSet",
    "Budget",
    "ConstraintCheck",
    "Constraints",
    "Limits",
    "OptimizationResult",
    "RobustSpec",
    "Rotation",
    "Search",
    "Violation",
    "baselines",
    "check_profile",
    "load_cell",
    "optimize",
    "worst_case",
]
