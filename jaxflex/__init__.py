"""jaxflex: cycle time of robot transfers of thin, vibrating sheet-metal parts.

The core (this package) holds the modal model, the exact discrete-time modal recursion in
JAX, deviation, settle and cycle time and their gradients. SI units throughout.
float64 is enabled on import (``jax_enable_x64``); float32 is available on request.
"""

from importlib.metadata import version

import jax

jax.config.update("jax_enable_x64", True)

from jaxflex.engine import free_states, modal_states, upsample  # noqa: E402
from jaxflex.errors import (  # noqa: E402
    BudgetError,
    InputError,
    JaxflexError,
    JaxflexWarning,
    ModelError,
    ModelFileError,
)
from jaxflex.model import ModalModel, load_model, save_model, stack_models  # noqa: E402
from jaxflex.profile import integrate, jerk_limited_move  # noqa: E402
from jaxflex.settle import SettleReport, analyze_move, cycle_time, settle_time  # noqa: E402
from jaxflex.simulate import Response, batch_deviation, end_state, simulate  # noqa: E402
from jaxflex.surrogate import cycle_time_smooth, envelope_time  # noqa: E402

__all__ = [
    "BudgetError",
    "InputError",
    "JaxflexError",
    "JaxflexWarning",
    "ModalModel",
    "ModelError",
    "ModelFileError",
    "Response",
    "SettleReport",
    "analyze_move",
    "batch_deviation",
    "cycle_time",
    "cycle_time_smooth",
    "end_state",
    "envelope_time",
    "free_states",
    "integrate",
    "jerk_limited_move",
    "load_model",
    "modal_states",
    "save_model",
    "settle_time",
    "simulate",
    "stack_models",
    "upsample",
]
__version__ = version("jaxflex")  # pyproject.toml's, the one place it is set
