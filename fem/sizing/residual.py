"""What a modal truncation leaves out: effective mass, static residual and a point-wise
estimate of the missing quasi-static deflection (the mode-acceleration correction).

Modes far above the frequency content of a move respond quasi-statically: mode i follows
q_i(t) ~ -Gamma_i . a(t) / omega_i^2. The deflection that the modes above n would add is then
u_miss(t) = -R_n a(t) with the residual flexibility

    R_n = (K - sigma M)^-1 (M R)_free - sum_{i <= n} phi_i Gamma_i / (omega_i^2 - sigma)

(one sparse factorisation; sigma = -(2 pi 1 Hz)^2 as in fem.modal keeps K - sigma M definite
and changes the terms of modes above ~10 Hz by less than 1 %). max_t max_p |u_miss| estimates
the truncation error of the deviation; it leaves out the small free vibration the truncated
modes keep after the move (of order their quasi-static deflection times the jerk
discontinuity over omega, i.e. smaller for smooth moves). SI units: m, s, kg.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from fem.eigen import factorize
from fem.modal import ModalResult

SIGMA_HZ = 1.0  # the shift fem.modal_analysis uses by default
CHUNK_SAMPLES = 64


class TruncationResidual:
    """Residual checks of the lowest-n truncations of one modal analysis (all its modes are
    candidates)."""

    def __init__(self, result: ModalResult):
        self.result = result
        self.sigma = -((2 * np.pi * SIGMA_HZ) ** 2)
        self.active = np.flatnonzero(np.abs(result.load).sum(axis=0) > 0)  # excitable axes

    @cached_property
    def _static(self) -> np.ndarray:
        """(n_free, A) (K - sigma M)^-1 b_d for the excitable directions d."""
        lu = factorize(self.result.K_free - self.sigma * self.result.M_free)
        return lu.solve(np.ascontiguousarray(self.result.load[:, self.active]))

    @cached_property
    def _modal_terms(self) -> np.ndarray:
        """(M, A) Gamma_i,d / (omega_i^2 - sigma)."""
        lam = (2 * np.pi * self.result.freq_hz) ** 2
        return self.result.gamma[:, self.active] / (lam - self.sigma)[:, None]

    def static_residual_fraction(self, n_modes: int) -> np.ndarray:
        """(3,) share of the static deflection energy b^T (K - sigma M)^-1 b along x, y, z that
        the lowest ``n_modes`` modes miss (NaN for directions the part cannot move in)."""
        full = np.einsum("id,id->d", self.result.load[:, self.active], self._static)
        kept = np.sum(self.result.gamma[:n_modes, self.active] * self._modal_terms[:n_modes], 0)
        out = np.full(3, np.nan)
        out[self.active] = 1.0 - kept / full
        return out

    def effective_mass_fraction(self, n_modes: int) -> np.ndarray:
        """(3,) cumulative effective-mass fraction of the lowest ``n_modes`` modes."""
        frac = self.result.effective_mass_fraction[:n_modes]
        return np.where(np.isfinite(frac).any(axis=0), np.nansum(frac, axis=0), np.nan)

    def quasi_static_error_m(self, acc, n_modes: int, nodes: np.ndarray | None = None) -> float:
        """max over the move samples ``acc`` ((n+1, 3) m/s^2) and the given reporting nodes
        (default all) of |R_n a|: the deflection (m) the modes above ``n_modes`` would add if
        they responded quasi-statically. The maximum over the piecewise-linear move is attained
        at a sample (the norm of a linear function is convex on each step)."""
        res = self.result
        modal = res.vectors[:, :n_modes] @ self._modal_terms[:n_modes]
        missing = res.observation @ (self._static - modal)  # (3N, A)
        missing = missing.reshape(len(res.system.nodes), 3, len(self.active))
        if nodes is not None:
            missing = missing[np.asarray(nodes, dtype=np.int64)]
        acc = np.asarray(acc, dtype=float)[:, self.active]  # (T, A)
        worst = 0.0
        for start in range(0, acc.shape[0], CHUNK_SAMPLES):
            u = np.einsum("kca,ta->tkc", missing, acc[start : start + CHUNK_SAMPLES])
            worst = max(worst, float(np.sqrt(np.einsum("tkc,tkc->tk", u, u)).max()))
        return worst
