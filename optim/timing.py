"""Exact transfer, settle and cycle time of a move, from ``jaxflex.analyze_move``.

``analyze_move`` jit-compiles its modal recursion for every new number of samples (~0.4 s
each here), and an optimisation looks at dozens of move lengths. A part at rest stays at
rest while the acceleration is zero, so the move preceded by k zero samples has the same
response shifted by k dt, and its settle time is shifted by exactly k dt. The zero lead-in
costs the search nothing (the deviation is identically zero there, which certifies at
once). :func:`exact_timing` prepends zeros up to a multiple of PAD_STEPS samples (one
compilation per 128 steps of length) and undoes the shift.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from jaxflex.model import ModalModel
from jaxflex.settle import analyze_move

PAD_STEPS = 128


@dataclass(frozen=True)
class MoveTiming:
    """Times in s from the start of the move, exact (see jaxflex.settle)."""

    transfer_time_s: float
    settle_time_s: float
    cycle_time_s: float

    def as_dict(self) -> dict:
        return asdict(self)


def lead_in(acc: np.ndarray, multiple: int = PAD_STEPS) -> tuple[np.ndarray, int]:
    """(``acc`` preceded by k zero samples, k) with a total length that is a multiple of
    ``multiple``."""
    k = -(-acc.shape[0] // multiple) * multiple - acc.shape[0]
    return np.vstack([np.zeros((k, acc.shape[1])), acc]), k


def exact_timing(
    model: ModalModel, acc, dt: float, threshold_m: float, *, settle: bool = True
) -> MoveTiming:
    """Exact timing of the move ``acc`` ((n+1, 3) m/s^2, at rest at both ends). With
    ``settle=False`` only the cycle time is exact: a settle time during the move is not
    searched for and is reported as the transfer time (as ``analyze_move`` does)."""
    acc = np.asarray(acc, dtype=np.float64)
    transfer = (acc.shape[0] - 1) * dt
    shifted, k = lead_in(acc)
    report = analyze_move(model, shifted, dt, threshold_m, settle=settle)
    settle = max(0.0, report.settle_time_s - k * dt) if report.settle_time_s > 0 else 0.0
    return MoveTiming(transfer, settle, max(transfer, settle))
