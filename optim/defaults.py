"""The optimiser's defaults, in one place (SI units; light: no imports, so that
``jaxflex optimize`` builds its options and answers an argument error before the optimiser
loads). The modules that use them re-export them (``optim.options.FREQ_SCALE``,
``optim.budget.MAX_STEPS``, ``optim.turn.ANGULAR_LIMITS``); the defaults every layer shares
are jaxflex.defaults.
"""

from __future__ import annotations

MAX_STEPS = 5000  # the most steps of any move an LP is built for (optim.budget)
FREQ_SCALE = (0.9, 1.1)  # robust: default range of the factor on every natural frequency
ZETA = (0.01, 0.03)  # robust: default range of the damping ratio
GRID = (21, 3)  # robust: default check-grid points over the frequency and damping ranges
# Rates of a typical 6-axis robot wrist (3 rad/s, 20 rad/s^2); the jerk 10 x the acceleration,
# the ratio of the translation's defaults (10 m/s^2, 100 m/s^3).
ANGULAR_LIMITS = (3.0, 20.0, 200.0)  # turns: rad/s, rad/s^2, rad/s^3 (optim.turn)
MAX_SHAPED_MODES = 6  # the most modes a shaped baseline cancels (optim.baselines)
LP_SOLVERS = ("highs", "casadi", "casadi-highs")  # the exact route's (optim.lp)
GRADIENT_SOLVERS = ("ipopt", "slsqp")  # the gradient route's (optim.gradient)
