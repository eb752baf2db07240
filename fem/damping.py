"""Damping shared by the modal model and the full-order transient: Rayleigh C = alpha M + beta K.

For a classically damped system the modal damping ratio of mode i is
zeta_i = alpha / (2 omega_i) + beta omega_i / 2 (omega_i in rad/s, alpha in 1/s, beta in s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_positive


@dataclass(frozen=True)
class Rayleigh:
    """Rayleigh damping C = alpha_per_s M + beta_s K (alpha in 1/s, beta in s, both >= 0)."""

    alpha_per_s: float
    beta_s: float

    def __post_init__(self) -> None:
        for name in ("alpha_per_s", "beta_s"):
            value = float(getattr(self, name))
            if not math.isfinite(value) or value < 0:
                raise InputError(f"Rayleigh.{name}: must be a finite number >= 0, got {value!r}")
            object.__setattr__(self, name, value)

    @classmethod
    def from_zeta(cls, zeta: float, f1_hz: float, f2_hz: float) -> Rayleigh:
        """The Rayleigh damping with ratio ``zeta`` at both f1_hz and f2_hz (Hz); in between
        the ratio is lower, outside it is higher."""
        zeta = check_positive("zeta", zeta)
        w1 = 2 * np.pi * check_positive("f1_hz", f1_hz)
        w2 = 2 * np.pi * check_positive("f2_hz", f2_hz)
        return cls(2 * zeta * w1 * w2 / (w1 + w2), 2 * zeta / (w1 + w2))

    def zeta(self, freq_hz) -> np.ndarray:
        """Modal damping ratios zeta_i = alpha/(2 w_i) + beta w_i/2 at ``freq_hz`` (Hz, any
        shape; the ratios in its shape), w = 2 pi f."""
        omega = 2 * np.pi * np.asarray(freq_hz, dtype=float)
        return self.alpha_per_s / (2 * omega) + self.beta_s * omega / 2

    def describe(self) -> dict:
        return {"type": "rayleigh", "alpha_per_s": self.alpha_per_s, "beta_s": self.beta_s}


def modal_zeta(spec, freq_hz: np.ndarray) -> np.ndarray:
    """Per-mode damping ratios from a scalar, a per-mode array or a Rayleigh; checks 0 <= z < 1."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    if isinstance(spec, Rayleigh):
        zeta = spec.zeta(freq_hz)
    else:
        try:
            zeta = np.broadcast_to(np.asarray(spec, dtype=float), freq_hz.shape).copy()
        except (TypeError, ValueError) as exc:
            raise InputError(
                f"zeta: expected a number, {freq_hz.size} per-mode values or fem.Rayleigh, "
                f"got {spec!r}"
            ) from exc
    i = _bad_ratio(zeta)
    if i is not None:
        hint = (
            "; with Rayleigh damping keep fewer modes or a smaller beta"
            if isinstance(spec, Rayleigh)
            else _ratio_hint(float(zeta[i]))
        )
        raise InputError(
            f"zeta: damping ratio {zeta[i]:.4g} of mode {i} ({freq_hz[i]:.4g} Hz) must lie in "
            f"[0, 1){hint}"
        )
    return zeta


def _ratio_hint(value: float) -> str:
    """What a damping ratio is, and the ratio meant if ``value`` looks like a percentage."""
    meant = f"; {value:g} % would be {value / 100:g}" if 1 <= value < 100 else ""
    return f" (a ratio: 0.02 is 2 % of critical damping{meant})"


def _bad_ratio(zeta: np.ndarray) -> int | None:
    """Index of the first value outside [0, 1) (or not finite), None if all are fine."""
    bad = ~np.isfinite(zeta) | (zeta < 0) | (zeta >= 1)
    return int(np.argmax(bad)) if bad.any() else None


def check_damping(spec) -> None:
    """Check a damping spec before any work: a ratio or per-mode ratios in [0, 1) (a Rayleigh
    spec is checked per mode once the frequencies are known, by :func:`modal_zeta`)."""
    if isinstance(spec, Rayleigh):
        return
    try:
        zeta = np.atleast_1d(np.asarray(spec, dtype=float))
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"zeta: expected a number, per-mode values or fem.Rayleigh, got {spec!r}"
        ) from exc
    i = _bad_ratio(zeta)
    if i is not None:
        raise InputError(
            f"zeta: damping ratio {zeta[i]:.4g} must lie in [0, 1){_ratio_hint(float(zeta[i]))}"
        )


def describe_damping(spec) -> dict:
    if isinstance(spec, Rayleigh):
        return spec.describe()
    arr = np.asarray(spec, dtype=float)
    return {"type": "modal", "zeta": float(arr) if arr.ndim == 0 else arr.tolist()}
