"""How accurate a finite-element model built here is: its discretisation error, estimated.

A second analysis of the same part on a mesh ``RATIO`` times coarser (the base element
size and the refinement at the cups scaled alike, so the two meshes are similar) gives the
frequencies and the peak stress again. With the element's known order of convergence p, the
Richardson estimate of the exact value is f_R = f_h + (f_h - f_H) / (RATIO^p - 1), and the
fine model's error |f_h - f_R| / |f_R| = |f_h - f_H| / ((RATIO^p - 1) |f_R|):

* frequencies, ``FREQ_ORDER`` = 1.5: Morley, the DKT shell and the thin solid converge as
  O(h^2) where the mesh follows the cups' rims (fem.mesh.rim), but the coarse mesh of the
  estimate is not yet in that range: between it and the model the observed order is 1.3 (a
  0.6 x 0.4 m plate at 20 mm) to 1.8 (the built-in plate), so order 2 would state about
  half the error; with 1.5 the estimate came within 0.8 ... 1.4 x the true error (against
  the Richardson limit of two finer meshes, tests/test_fem_discretisation.py). Where a
  clamped disc is a staircase of elements (a cup the mesh cannot follow) the clamp
  converges at first order, ``STAIRCASE_ORDER`` = 1, a larger (safer) estimate;
* the peak stress, ``STRESS_ORDER`` = 1: stresses are taken at element centroids (Morley,
  the shell) or face centres (the thin solid), an O(h) distance from the rim where the
  stress of a held part peaks (Morley on a clamped annulus: 2.9, 0.9, 0.32, 0.12 % below
  the closed form, order 1 to 2, tests/test_fem_discretisation.py).

The peak stress is that of the static response to a unit base acceleration along each axis
(the stress of a part hanging at rest in gravity g is g times it; the move's stresses have
the same spatial resolution), so the estimate says how far the stress the optimiser
certifies can be off on the real part (optim's report states it). The error of the
frequencies is taken over the modes both meshes found (the k-th lowest against the k-th
lowest: eigenvalues converge in order). Estimates above ``WARN_ABOVE`` are warned about.

The second analysis costs about 1 / RATIO^2.5 of the first (a quarter of the DOFs; its
truncation check is skipped); fem.mesh.plan includes it in the budget. A mesh that is given (a
mesh file, a Nastran deck) cannot be coarsened: its accuracy is the coarse-mesh advice
(fem.mesh_advice, elements per bending half-wave).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from fem.outputs import physical_outputs, static_response, stress_outputs
from jaxflex.errors import InputError

RATIO = 2.0  # the coarse mesh's element sizes over the model's
FREQ_ORDER = 1.5
STAIRCASE_ORDER = 1.0
STRESS_ORDER = 1.0
WARN_ABOVE = 0.02  # a warning for estimated errors above 2 %
STRESS_SHARE = 0.05  # axes whose peak stress is below this x the largest axis's are left out


def coarse_part(part):
    """The part meshed ``RATIO`` times coarser (base size and cup refinement), or None for
    a part whose mesh is given."""
    if part.mesh_is_given:
        return None
    return replace(
        part,
        mesh_size_m=RATIO * part.element_size_m,
        cup_fine_fraction=RATIO * part.fine_fraction,
    )


def von_mises_pa(stress: np.ndarray) -> np.ndarray:
    """(S,) von Mises stress of Voigt stresses (S, 6) (xx, yy, zz, yz, xz, xy), Pa."""
    xx, yy, zz, yz, xz, xy = stress.T
    return np.sqrt(
        0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2) + 3 * (yz**2 + xz**2 + xy**2)
    )


def static_stress_peaks(result, *, keep: bool = True) -> np.ndarray | None:
    """(3,) the largest von Mises stress (Pa) of ``result``'s static response to a unit base
    acceleration (1 m/s^2) along x, y, z, over its stress points; None for a part without
    stresses or a static response (rigid-body modes). ``keep``: build the outputs the model
    will need (fem.outputs.physical_outputs, kept on ``result``), else the stresses alone."""
    if result.rigid_freq_hz.size or result.system.outputs is None:
        return None
    static = static_response(result)
    stress = physical_outputs(result)[2] if keep else stress_outputs(result)[1]
    values = np.asarray(stress.stiffness @ static)  # (6 S, 3)
    return np.array([von_mises_pa(values[:, d].reshape(-1, 6)).max() for d in range(3)])


def _relative_error(fine: np.ndarray, coarse: np.ndarray, order: float) -> np.ndarray:
    """|f_h - f_R| / |f_R| of the Richardson estimate f_R (module docstring)."""
    gap = (fine - coarse) / (RATIO**order - 1)
    richardson = fine + gap
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.abs(gap) / np.abs(richardson)


@dataclass(frozen=True)
class DiscretisationEstimate:
    """The Richardson estimate of a model's discretisation error (module docstring).

    ``freq_hz`` (M,) and ``coarse_freq_hz`` (M',) of the model and the coarse mesh;
    ``stress_pa``, ``coarse_stress_pa`` (3,) the peak von Mises stress per unit base
    acceleration along x, y, z (Pa per m/s^2) or None; ``freq_order``, ``stress_order`` the
    orders used; ``coarse_mesh`` the coarse mesh's statistics; ``time_s`` its analysis."""

    freq_hz: np.ndarray
    coarse_freq_hz: np.ndarray
    stress_pa: np.ndarray | None
    coarse_stress_pa: np.ndarray | None
    freq_order: float
    stress_order: float
    coarse_mesh: dict
    time_s: float

    @property
    def freq_error(self) -> np.ndarray:
        """(K,) estimated relative error of the first K frequencies (K: the modes both
        meshes found)."""
        k = min(len(self.freq_hz), len(self.coarse_freq_hz))
        return _relative_error(self.freq_hz[:k], self.coarse_freq_hz[:k], self.freq_order)

    @property
    def stress_error(self) -> np.ndarray | None:
        """(3,) estimated relative error of the peak stress per axis (NaN where the axis
        loads the part little, below STRESS_SHARE of the largest), or None."""
        if self.stress_pa is None or self.coarse_stress_pa is None:
            return None
        error = _relative_error(self.stress_pa, self.coarse_stress_pa, self.stress_order)
        small = self.stress_pa < STRESS_SHARE * self.stress_pa.max()
        return np.where(small, np.nan, error)

    @property
    def max_freq_error(self) -> float:
        """The largest estimated relative frequency error over the compared modes."""
        errors = self.freq_error
        return float(np.nanmax(errors)) if errors.size else float("nan")

    @property
    def max_stress_error(self) -> float | None:
        """The largest estimated relative error of the peak stress over the axes, or None."""
        errors = self.stress_error
        if errors is None or not np.isfinite(errors).any():
            return None
        return float(np.nanmax(errors))

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, for the model's meta (``meta["discretisation"]``)."""
        stress = self.stress_error

        def clean(values):
            return None if values is None else [None if not np.isfinite(v) else float(v)
                                                for v in values]  # fmt: skip

        return {
            "method": f"Richardson, a second analysis at {RATIO:g} x the element size",
            "freq_order": self.freq_order,
            "stress_order": self.stress_order,
            "coarse_mesh": self.coarse_mesh,
            "coarse_freq_hz": clean(self.coarse_freq_hz),
            "freq_error": clean(self.freq_error),
            "max_freq_error": self.max_freq_error,
            "stress_peak_pa_per_m_s2": clean(self.stress_pa),
            "coarse_stress_peak_pa_per_m_s2": clean(self.coarse_stress_pa),
            "stress_error": clean(stress),
            "max_stress_error": self.max_stress_error,
            "time_s": round(self.time_s, 3),
        }

    def summary(self) -> str:
        """One line: the largest frequency error (which mode) and the stress peak's."""
        errors = self.freq_error
        worst = int(np.nanargmax(errors)) if errors.size else 0
        text = (
            f"discretisation error (estimate: Richardson with a second mesh at {RATIO:g} x "
            f"the element size, {self.coarse_mesh['n_dof']} DOFs): frequencies <= "
            f"{100 * self.max_freq_error:.2g} % (mode {worst + 1})"
        )
        stress = self.max_stress_error
        if stress is not None:
            axis = "xyz"[int(np.nanargmax(self.stress_error))]
            text += (
                f", peak stress {100 * stress:.2g} % ({self.stress_pa.max() / 1e6:.4g} MPa "
                f"per m/s^2 along {axis})"
            )
        return text

    def warnings(self) -> list[str]:
        """The messages for estimated errors above WARN_ABOVE (empty if none)."""
        out = []
        if self.max_freq_error > WARN_ABOVE:
            out.append(
                f"the frequencies' discretisation error is estimated at up to "
                f"{100 * self.max_freq_error:.2g} % (over {100 * WARN_ABOVE:g} %): refine the "
                "mesh (mesh_size, --mesh-size) or keep fewer modes"
            )
        stress = self.max_stress_error
        if stress is not None and stress > WARN_ABOVE:
            out.append(
                f"the peak stress's discretisation error is estimated at {100 * stress:.2g} % "
                f"(over {100 * WARN_ABOVE:g} %): stresses certified against a limit may be "
                "exceeded on the real part by as much; refine the mesh at the cups "
                "(mesh_size, --mesh-size)"
            )
        return out


def given_mesh_statement(advice: list[str]) -> str:
    """What is known of the accuracy of a model on a given mesh (a mesh file, a deck), from
    the coarse-mesh ``advice`` (fem.mesh_advice's warnings for it)."""
    if not advice:
        return (
            "not estimated (the mesh is given): its elements resolve the kept modes' bending "
            "half-waves and the cups as the ~1 % rules ask (fem.mesh_advice)"
        )
    return "not estimated (the mesh is given); coarse-mesh advice: " + "; ".join(advice)


def estimate(result, analyse: Callable[[Any], Any]) -> DiscretisationEstimate | str:
    """The estimate for ``result`` (a fem.ModalResult of a meshed part), with ``analyse``
    (part -> ModalResult, the same analysis without its truncation check) run on the
    coarse part; a string saying why there is none (a given mesh, a coarse mesh the gripper
    does not fit on)."""
    coarse = coarse_part(result.part)
    if coarse is None:
        return given_mesh_statement([])
    tick = time.perf_counter()
    try:
        other = analyse(coarse)
        coarse_stress = static_stress_peaks(other, keep=False)
    except InputError as exc:
        return (
            f"not estimated: the mesh at {RATIO:g} x the element size could not be analysed ({exc})"
        )
    stats = other.system.stats
    followed = result.system.stats.get("cup_rims", 0) == result.system.stats.get("cup_discs", 0)
    return DiscretisationEstimate(
        freq_hz=np.asarray(result.freq_hz),
        coarse_freq_hz=np.asarray(other.freq_hz),
        stress_pa=static_stress_peaks(result),
        coarse_stress_pa=coarse_stress,
        freq_order=FREQ_ORDER if followed else STAIRCASE_ORDER,
        stress_order=STRESS_ORDER,
        coarse_mesh={
            "mesh_size_m": coarse.element_size_m,
            "n_elements": int(stats["n_elements"]),
            "n_dof": int(stats["n_dof"]),
        },
        time_s=time.perf_counter() - tick,
    )
