"""The defaults every layer shares, in one place (SI units). Public (light: no imports).

Commands, the optimiser, sweeps, sizing and the FMU export take these when the user gives
nothing; a number written out elsewhere would drift from them.
"""

from __future__ import annotations

THRESHOLD_M = 5e-4  # deviation threshold: 0.5 mm
DT_S = 0.01  # sample step of a move: 10 ms
MAX_DURATION_S = 30.0  # longest move the optimiser considers

__all__ = ["DT_S", "MAX_DURATION_S", "THRESHOLD_M"]
