"""jaxflex: cycle time of robot transfers of thin, vibrating sheet-metal parts.

The core (this package) holds the modal model, the exact discrete-time modal recursion in
JAX, deviation, settle and cycle time and their gradients. SI units throughout.
float64 is enabled when JAX is imported (``jax_enable_x64``); float32 is available on request.
Importing the package loads no JAX: its names are imported from their modules on first use.

The public interface, the only way the layers above (fem, optim, fmu) and users enter the
core, each module's names in its ``__all__`` (tests/test_public_core.py checks it):

* ``jaxflex``: the model, moves, the response (of a turning move too: a ``Turn`` and the
  orientation paths it takes), settle and cycle time, the errors;
* ``jaxflex.model``: the modal model, its files, ``stack_models``;
* ``jaxflex.defaults``: the defaults every layer shares (``DT_S``, ``THRESHOLD_M``, ...);
* ``jaxflex.response``: the building blocks of the certified response (state maps,
  deviation, outputs and loads, decay, peaks, the move's kinematics, point sets);
* ``jaxflex.geometry``: the cell's geometry (obstacles, pose, path) and the certified clearance;
* ``jaxflex.files``: input checks, readers in a child process, atomic outputs, file sets,
  the trajectory and unit-response CSV files;
* ``jaxflex.runtime``: progress, time and memory budgets, advice;
* ``jaxflex.reference``: closed forms and independent methods (convolution, integrators);
* ``jaxflex.plots``: pictures (atomic saving, the deviation axis);
* ``jaxflex.cli``: the ``jaxflex`` command and what a subcommand's module may use;
* ``jaxflex.lazy``: a module's names imported on first use (every package's ``__init__``
  and the public modules above use it, so that importing them loads no JAX);
* ``jaxflex.errors``, ``jaxflex.isolated``, ``jaxflex.stdout``: the errors, a reader run in
  a child process, C libraries' stdout kept off ours; light (no JAX), so that a reader's
  child process (jaxflex.isolated) imports only what it needs.

The layers above take names from these submodules (``from jaxflex.model import
ModalModel``), not from this package's ``__init__``, which a reader's child process does not
run; the submodules re-export what they need of this package's names.

Every other submodule is private to the core (its name begins with an underscore) and free
to change.
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import after_import, lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): `import jaxflex` loads no JAX
    from jaxflex._pose import fixed_axis_path, orientation_path, turn_acceleration
    from jaxflex._profile import Move, as_move, integrate, jerk_limited_move
    from jaxflex._settle import SettleReport, analyze_move, cycle_time
    from jaxflex._simulate import Response, batch_deviation, simulate
    from jaxflex._surrogate import cycle_time_smooth
    from jaxflex._turning import Turn, TurningResponse, simulate_turning, turning_settle
    from jaxflex.errors import (
        BudgetError,
        InputError,
        JaxflexError,
        JaxflexWarning,
        ModelError,
        ModelFileError,
    )
    from jaxflex.model import ModalModel, load_model, stack_models

_lazy_getattr, __dir__ = lazy_names(__name__)
__all__ = [
    "BudgetError",
    "InputError",
    "JaxflexError",
    "JaxflexWarning",
    "ModalModel",
    "ModelError",
    "ModelFileError",
    "Move",
    "Response",
    "SettleReport",
    "Turn",
    "TurningResponse",
    "analyze_move",
    "as_move",
    "batch_deviation",
    "cycle_time",
    "cycle_time_smooth",
    "fixed_axis_path",
    "integrate",
    "jerk_limited_move",
    "load_model",
    "orientation_path",
    "simulate",
    "simulate_turning",
    "stack_models",
    "turn_acceleration",
    "turning_settle",
]


def __getattr__(name: str):
    """The lazy names, and ``__version__``: pyproject.toml's, the one place it is set, read
    from the installed metadata when first asked (importlib.metadata: ~0.03 s of CPU that a
    command which never prints it does not pay)."""
    if name == "__version__":
        from importlib.metadata import version

        globals()["__version__"] = version("jaxflex")
        return globals()["__version__"]
    return _lazy_getattr(name)


def _float64(jax) -> None:
    """jaxflex computes in float64 (float32 on request): set before any JAX array exists."""
    jax.config.update("jax_enable_x64", True)


after_import("jax", _float64)
