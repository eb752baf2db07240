"""Modal analysis of a part held by its gripper, and the jaxflex.ModalModel it yields.

Relative displacement u of the part carried with base acceleration a(t) obeys
M u'' + C u' + K u = -(M R)_free a(t); with mass-normalised modes phi_i the participation
factors are Gamma_i = phi_i^T (M R)_free (kg^0.5, one per direction x, y, z) and
sum over all modes of Gamma_i,d^2 = b_d^T M_ff^-1 b_d (the "mobile mass" along d: the part's
mass less what the supports carry directly). Effective-mass fractions relate Gamma^2 to that
sum, and the residual check evaluates it with one sparse solve. SI units throughout.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from fem.damping import Rayleigh, check_damping, describe_damping, modal_zeta
from fem.discretisation import DiscretisationEstimate, estimate, given_mesh_statement
from fem.eigen import all_modes, factorize, lowest_modes
from fem.elements.plate import assemble_plate
from fem.elements.shell import assemble_shell
from fem.elements.solid import assemble_solid
from fem.mesh.plan import fe_plan
from fem.mesh_advice import coarse_mesh_warnings
from fem.outputs import modal_outputs, static_displacements, static_response
from fem.parts import Part
from fem.rigid_modes import rigid_by_gap
from fem.rotation_integrals import rotational_inertia
from fem.supports import as_support_list, check_layout, contact_discs
from fem.system import FESystem, surface_triangles
from jaxflex.errors import InputError, JaxflexWarning
from jaxflex.files import check_positive
from jaxflex.model import ModalModel
from jaxflex.response import downsample_to_count, snap_key_points
from jaxflex.runtime import require, step

RIGID_MODES = {"plate": 3, "solid": 6, "shell": 6}


def select_node_indices(
    nodes: np.ndarray, points=None, key_points=None, tolerance_m: float | None = None
) -> np.ndarray:
    """Indices into ``nodes`` (N, 3) m of the monitored points.

    ``points``: None or "all" every node; an int N: about N nodes by voxel downsampling
    (``key_points`` (Kk, 3) m always kept); an array (K, 3) m: the nearest nodes (each within
    ``tolerance_m``).
    """
    if points is None or (isinstance(points, str) and points == "all"):
        if key_points is not None:
            raise InputError("key_points: only used with points=<count>")
        return np.arange(len(nodes))
    if isinstance(points, str):
        raise InputError(f"points: a count, 'all' or (K, 3) coordinates in m, got {points!r}")
    if isinstance(points, int | np.integer):
        if int(points) < 1:
            raise InputError(f"points: a count must be >= 1, got {points}")
        return downsample_to_count(
            nodes, int(points), key_points=key_points, key_tolerance_m=tolerance_m
        )
    if key_points is not None:
        raise InputError("key_points: only used with points=<count>")
    arr = np.asarray(points, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise InputError(f"points: expected shape (K, 3) in m, got {arr.shape}")
    return snap_key_points(nodes, arr, tolerance_m)


@dataclass(eq=False)
class ModalResult:
    """Outcome of :func:`modal_analysis` (SI units).

    Attributes:
        part, supports: the inputs.
        system: the assembled FESystem (matrices, nodes, constraints).
        basis: T (n_dof, n_free) admissible displacements u = T z.
        freq_hz: (M,) natural frequencies of the elastic modes, ascending.
        vectors: (n_free, M) mass-normalised elastic modes in the reduced coordinates z.
        gamma: (M, 3) participation factors along x, y, z in kg^0.5.
        rigid_freq_hz: frequencies of rigid-body modes found (only if allowed), Hz.
        rigid_gamma: (R, 3) their participation factors, kg^0.5.
        mobile_mass_kg: (3,) b_d^T M_ff^-1 b_d = sum over all modes of Gamma_d^2, kg.
        static_residual_fraction: (3,) share of the static deflection under uniform
            acceleration that the retained modes miss (0 = complete).
        mass_kg: the part's mass.
        zeta: (M,) modal damping ratios; damping: the spec they came from.
        timings_s: wall times of the steps in s.
        provenance: entries added to the model's meta (e.g. the input file of an import).
        discretisation: the estimate of the discretisation error (fem.discretisation), a
            string saying why there is none, or None (not asked for).
    """

    part: Part
    supports: list
    system: FESystem
    basis: sp.csc_matrix
    K_free: sp.csr_matrix
    M_free: sp.csr_matrix
    load: np.ndarray
    freq_hz: np.ndarray
    vectors: np.ndarray
    gamma: np.ndarray
    rigid_freq_hz: np.ndarray
    rigid_gamma: np.ndarray
    mobile_mass_kg: np.ndarray
    static_residual_fraction: np.ndarray
    mass_kg: float
    zeta: np.ndarray
    damping: Any
    timings_s: dict[str, float] = field(default_factory=dict)
    observation: sp.csr_matrix | None = None
    provenance: dict[str, Any] = field(default_factory=dict)
    discretisation: DiscretisationEstimate | str | None = None

    @property
    def n_modes(self) -> int:
        return int(self.freq_hz.size)

    @property
    def effective_mass_kg(self) -> np.ndarray:
        """(M, 3) effective modal mass Gamma^2 per direction, kg."""
        return self.gamma**2

    @property
    def effective_mass_fraction(self) -> np.ndarray:
        """(M, 3) Gamma^2 / mobile mass per direction; NaN for a direction the formulation
        cannot move in (a Kirchhoff plate along x and y)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.mobile_mass_kg > 0, self.gamma**2 / self.mobile_mass_kg, np.nan)

    @property
    def cumulative_fraction(self) -> np.ndarray:
        """(3,) share of the mobile mass captured by the retained modes, per direction."""
        return np.nansum(self.effective_mass_fraction, axis=0) + np.where(
            self.mobile_mass_kg > 0, 0.0, np.nan
        )

    @property
    def residual_fraction(self) -> np.ndarray:
        """(3,) 1 - cumulative_fraction: the mass the truncated modes carry (residual check)."""
        return 1.0 - self.cumulative_fraction

    def node_shapes(self) -> np.ndarray:
        """(N, 3, M) mode shapes at all reporting nodes, m per kg^0.5."""
        values = self.observation @ self.vectors
        return values.reshape(len(self.system.nodes), 3, self.n_modes)

    def select_nodes(
        self, points=None, key_points=None, key_tolerance_m: float | None = None
    ) -> np.ndarray:
        """Node indices for ``points``: None/"all" every node; an int N: about N nodes by voxel
        downsampling (``key_points`` (Kk, 3) always kept); an array (K, 2) of footprint
        points or (K, 3) points (m): the nearest nodes (within ``key_tolerance_m``, default
        two element sizes)."""
        tol = key_tolerance_m or 2 * self.system.stats["edge_length_max_m"]
        return select_node_indices(
            self.system.nodes, self._as_xyz(points), self._as_xyz(key_points), tol
        )

    def _as_xyz(self, pts):
        if pts is None or isinstance(pts, str | int | np.integer):
            return pts
        arr = np.asarray(pts, dtype=float)
        if arr.ndim != 2 or arr.shape[1] not in (2, 3) or arr.shape[0] == 0:
            raise InputError(f"points: expected shape (K, 2) or (K, 3) in m, got {arr.shape}")
        if arr.shape[1] == 2:
            inside = self.part.contains_xy(arr)
            if not inside.all():
                i = int(np.argmin(inside))
                raise InputError(f"points: point {i} at {arr[i].tolist()} m is off the part")
            arr = self.part.surface_point(arr)
        return arr

    def to_modal_model(
        self,
        points=None,
        *,
        key_points=None,
        labels: Sequence[str] | None = None,
        zeta=None,
        key_tolerance_m: float | None = None,
        outputs: bool = True,
    ) -> ModalModel:
        """The jaxflex.ModalModel at the monitored points (see :meth:`select_nodes`); ``zeta``
        overrides the damping (scalar, per mode or fem.Rayleigh). A held part's model carries
        the points' exact static displacement per unit base acceleration (one extra sparse
        solve, fem.outputs.static_response) and, with ``outputs`` (default), the cup
        reactions and the surface stresses; a part with rigid-body modes has neither. Plate,
        thin-solid and shell models carry the inertia data of turning moves
        (fem.rotation_integrals); a model at every node carries the mesh's triangles
        (``surface``, for pictures and animations)."""
        if self.n_modes == 0:
            raise InputError("to_modal_model: the analysis found no elastic mode")
        idx = self.select_nodes(points, key_points, key_tolerance_m)
        if labels is not None:
            labels = [str(s) for s in labels]
            if len(labels) != len(idx):
                raise InputError(f"labels: expected {len(idx)} labels, got {len(labels)}")
        spec = self.damping if zeta is None else zeta
        zeta_arr = modal_zeta(spec, self.freq_hz)
        shapes = self.node_shapes()[idx]
        cups = stress = static = None
        held = not self.rigid_freq_hz.size
        if held:
            static = static_displacements(self, static_response(self), idx)
        if outputs and held and self.system.outputs is not None:
            cups, stress = modal_outputs(self, spec if isinstance(spec, Rayleigh) else zeta_arr)
        rotation = rotational_inertia(
            self, idx if held else None, outputs=cups is not None or stress is not None
        )
        self.__dict__.pop("_stiffness_factor", None)  # K_ff's LU is not kept with the result
        every_node = np.array_equal(idx, np.arange(len(self.system.nodes)))
        return ModalModel(
            freq_hz=self.freq_hz,
            zeta=zeta_arr,
            gamma=self.gamma,
            shapes=shapes,
            points=self.system.nodes[idx],
            labels=labels,
            meta=self.meta(damping=spec, n_points=len(idx)),
            cups=cups,
            stress=stress,
            static_shapes=static,
            rotation=rotation,
            surface=self.surface() if every_node else None,
        )

    def surface(self) -> np.ndarray:
        """(T, 3) the triangles of the mesh's nodes (fem.system.surface_triangles)."""
        return surface_triangles(self.system.cells, self.system.cell_type)

    def meta(self, damping=None, n_points: int | None = None) -> dict[str, Any]:
        """JSON-serialisable description stored in the ModalModel."""
        frac = self.effective_mass_fraction

        def clean(values):
            return [None if not np.isfinite(v) else float(v) for v in np.atleast_1d(values)]

        return {
            "source": "fem.modal_analysis",
            "units": "SI: m, s, kg, Pa; freq_hz Hz, gamma kg^0.5, shapes m/kg^0.5",
            "part": self.part.describe(),
            "material": self.part.material.as_dict(),
            "gripper": [s.describe() for s in self.supports],
            "mesh": dict(self.system.stats, n_free_dof=int(self.basis.shape[1])),
            "formulation": self.system.formulation,
            "mass_kg": self.mass_kg,
            "effective_mass": {
                "directions": ["x", "y", "z"],
                "mobile_mass_kg": clean(self.mobile_mass_kg),
                "fraction_per_mode": [clean(row) for row in frac],
                "cumulative_fraction": clean(self.cumulative_fraction),
                "residual_fraction": clean(self.residual_fraction),
                "static_residual_fraction": clean(self.static_residual_fraction),
            },
            "rigid_modes": {
                "count": int(self.rigid_freq_hz.size),
                "freq_hz": clean(self.rigid_freq_hz),
            },
            "damping": describe_damping(self.damping if damping is None else damping),
            "static_response": (
                "FE static solve (exact: sag under gravity, cup reactions and stresses at rest)"
                if not self.rigid_freq_hz.size
                else "none: the part is not held (rigid-body modes)"
            ),
            "n_points": n_points,
            **self._discretisation_meta(),
            "timings_s": {k: round(v, 4) for k, v in self.timings_s.items()},
            **self.provenance,
        }

    def _discretisation_meta(self) -> dict[str, Any]:
        found = self.discretisation
        if found is None:
            return {}
        return {"discretisation": found if isinstance(found, str) else found.as_dict()}

    def summary(self) -> str:
        """Human-readable table: frequencies, effective-mass fractions, residuals, timings."""
        frac = self.effective_mass_fraction

        def cells(values) -> str:
            return " ".join("   -  " if not np.isfinite(v) else f"{v:6.3f}" for v in values)

        lines = [
            f"{self.part.name}: {self.system.formulation}",
            f"mesh: {self.system.stats['n_elements']} elements, {self.system.stats['n_dof']} DOFs "
            f"({self.basis.shape[1]} free), mass {self.mass_kg:.4g} kg",
            " mode   freq [Hz]   zeta    eff. mass x     y      z   (fraction of mobile mass)",
        ]
        for i in range(self.n_modes):
            lines.append(
                f"{i + 1:5d} {self.freq_hz[i]:11.4f} {self.zeta[i]:6.4f}    {cells(frac[i])}"
            )
        lines.append(f"{'sum':>5s} {'':11s} {'':6s}    {cells(self.cumulative_fraction)}")
        res = ", ".join(
            f"{d}: {v:.2e}"
            for d, v in zip("xyz", self.residual_fraction, strict=True)
            if np.isfinite(v)
        )
        stat = ", ".join(
            f"{d}: {v:.2e}"
            for d, v in zip("xyz", self.static_residual_fraction, strict=True)
            if np.isfinite(v)
        )
        lines.append(f"residual mass fraction (truncated modes) {res}; static deflection {stat}")
        if self.rigid_freq_hz.size:
            lines.append(f"rigid-body modes kept out of the model: {self.rigid_freq_hz.size}")
        if isinstance(self.discretisation, DiscretisationEstimate):
            lines.append(self.discretisation.summary())
        elif self.discretisation is not None:  # the advice itself is printed as warnings
            text = self.discretisation.split("; coarse-mesh advice:")[0]
            lines.append(f"discretisation error: {text}")
        steps = ", ".join(f"{k.removesuffix('_s')} {v:.2f} s" for k, v in self.timings_s.items())
        lines.append(f"timings: {steps}")
        return "\n".join(lines)


@dataclass(eq=False)
class ModeSolution:
    """Elastic modes of K_free z = omega^2 M_free z with their participation (SI units).

    freq_hz (M,), vectors (n_free, M) mass-normalised, gamma (M, 3) = vectors^T load in
    kg^0.5; rigid_freq_hz (R,), rigid_gamma (R, 3) and rigid_vectors (n_free, R) of the
    rigid-body modes found;
    mobile_mass_kg (3,) = load^T M_free^-1 load (the sum of Gamma^2 over all modes);
    static_residual_fraction (3,) as in :class:`ModalResult`; timings_s.
    """

    freq_hz: np.ndarray
    vectors: np.ndarray
    gamma: np.ndarray
    rigid_freq_hz: np.ndarray
    rigid_gamma: np.ndarray
    mobile_mass_kg: np.ndarray
    static_residual_fraction: np.ndarray
    timings_s: dict[str, float]
    rigid_vectors: np.ndarray | None = None


def solve_modes(
    K_free: sp.spmatrix,
    M_free: sp.spmatrix,
    load: np.ndarray,
    observation: sp.spmatrix,
    n_modes: int | str | None,
    *,
    max_freq_hz: float | None = None,
    rigid_count: int | None = None,
    sigma_hz: float = 1.0,
    rigid_tol_hz: float = 0.01,
    rigid_message: str = "the model has {count} rigid-body mode(s) (below {tol:g} Hz)",
    check_truncation: bool = True,
    progress: bool | None = None,
) -> ModeSolution:
    """Lowest modes of the free system, mass-normalised, with Gamma = phi^T load.

    ``load`` (n_free, 3) is (M R)_free; ``observation`` (3N, n_free) maps the modes to node
    displacements (each mode's largest observed value is made positive). ``n_modes``: a
    count, "all" (dense solve) or None with ``max_freq_hz``. ``rigid_count`` None refuses
    rigid-body modes (InputError with ``rigid_message``), a number computes that many extra
    modes so the elastic count is kept. ``check_truncation`` False leaves the mobile mass
    and the static residual NaN (no extra solves).
    """
    dense = isinstance(n_modes, str)
    timings: dict[str, float] = {}
    sigma = -((2 * np.pi * sigma_hz) ** 2)
    extra = rigid_count or 0
    if dense:
        sol = all_modes(K_free, M_free)
    else:
        sol = lowest_modes(
            K_free,
            M_free,
            None if n_modes is None else int(n_modes) + extra,
            max_freq_hz=max_freq_hz,
            sigma=sigma,
            progress=progress,
        )
    timings["factorization_s"] = sol.factorization_s
    timings["eigen_s"] = sol.solve_s
    values, vectors = sol.eigenvalues, sol.vectors
    vectors = vectors / np.sqrt(np.einsum("im,im->m", vectors, M_free @ vectors))
    rigid_limit = (2 * np.pi * rigid_tol_hz) ** 2
    if dense:  # a dense solve resolves omega^2 only to ~eps * lambda_max (thin solids: ~1e14)
        rigid_limit = max(rigid_limit, 100 * np.finfo(float).eps * np.abs(values).max())
    freq_all = np.sqrt(np.abs(values)) / (2 * np.pi)
    rigid = (values < rigid_limit) | rigid_by_gap(freq_all, rigid_tol_hz)  # fem.rigid_modes
    if rigid.any() and rigid_count is None:
        shown = max(rigid_tol_hz, float(f"{1.01 * freq_all[rigid].max():.2g}"))
        raise InputError(rigid_message.format(count=int(rigid.sum()), tol=shown))
    all_gamma = vectors.T @ load
    values_el, vectors_el = values[~rigid], vectors[:, ~rigid]
    if not dense and n_modes is not None:
        values_el, vectors_el = values_el[: int(n_modes)], vectors_el[:, : int(n_modes)]
    if vectors_el.shape[1]:
        observed = observation @ vectors_el
        peak = observed[np.argmax(np.abs(observed), axis=0), np.arange(observed.shape[1])]
        vectors_el = vectors_el * np.where(peak < 0, -1.0, 1.0)

    if check_truncation:
        step("truncation check (static residual, mobile mass)", enabled=progress)
        tick = time.perf_counter()
        kept = None
        if not dense and n_modes is not None:  # only the retained elastic (and rigid) modes
            kept = np.concatenate([np.flatnonzero(rigid), np.flatnonzero(~rigid)[: int(n_modes)]])
        lu = sol.shifted_lu or factorize(K_free - sigma * M_free)
        mobile, static_res = _truncation(M_free, lu, load, values - sigma, all_gamma, kept)
        timings["residual_s"] = time.perf_counter() - tick
    else:
        mobile, static_res = np.full(3, np.nan), np.full(3, np.nan)
    return ModeSolution(
        freq_hz=np.sqrt(values_el) / (2 * np.pi),
        vectors=vectors_el,
        gamma=vectors_el.T @ load,
        rigid_freq_hz=np.sqrt(np.abs(values[rigid])) / (2 * np.pi),
        rigid_gamma=all_gamma[rigid],
        mobile_mass_kg=mobile,
        static_residual_fraction=static_res,
        timings_s=timings,
        rigid_vectors=vectors[:, rigid],
    )


def _truncation(M_free, shifted_lu, load, shifted_values, gamma, kept) -> tuple:
    """(mobile mass (3,) kg, static residual fraction (3,)) of the modes found: b^T M_ff^-1 b
    per direction, and the share of b^T (K - sigma M)^-1 b the modes ``kept`` (indices, None:
    all found) miss (``shifted_values`` omega^2 - sigma, ``gamma`` their participation)."""
    mobile = np.zeros(3)
    active = np.flatnonzero(np.abs(load).sum(axis=0) > 0)
    if active.size:
        solved = factorize(M_free).solve(np.ascontiguousarray(load[:, active]))
        mobile[active] = np.einsum("id,id->d", load[:, active], solved)
    static_full = np.einsum("id,id->d", load, shifted_lu.solve(np.ascontiguousarray(load)))
    if kept is not None:
        gamma, shifted_values = gamma[kept], shifted_values[kept]
    static_kept = np.sum(gamma**2 / shifted_values[:, None], axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        static_res = np.where(static_full > 0, 1.0 - static_kept / static_full, np.nan)
    return mobile, static_res


def check_request(n_modes, max_freq_hz, zeta) -> float | None:
    """Check what a modal analysis is asked for (``n_modes``, ``max_freq_hz``, ``zeta``:
    see :func:`modal_analysis`); returns max_freq_hz as a float (or None)."""
    dense = isinstance(n_modes, str)
    if dense and n_modes != "all":
        raise InputError(f"n_modes: a count, 'all' or None, got {n_modes!r}")
    if (
        not dense
        and n_modes is not None
        and (not isinstance(n_modes, int | np.integer) or n_modes < 1)
    ):
        raise InputError(f"n_modes: must be an integer >= 1, got {n_modes!r}")
    if n_modes is None and max_freq_hz is None:
        raise InputError("n_modes: give a number of modes or max_freq_hz")
    check_damping(zeta)
    return None if max_freq_hz is None else check_positive("max_freq_hz", max_freq_hz)


def modal_analysis(
    part: Part,
    supports,
    n_modes: int | str | None = 20,
    zeta=0.02,
    max_freq_hz: float | None = None,
    *,
    allow_rigid_modes: bool = False,
    sigma_hz: float = 1.0,
    rigid_tol_hz: float = 0.01,
    error_estimate: bool = True,
    progress: bool | None = None,
) -> ModalResult:
    """Natural modes of ``part`` held by ``supports``.

    Args:
        part: from fem.rectangular_plate / curved_panel / read_mesh.
        supports: fem.Support (SuctionCup, PointSupport, ClampedEdge, SimplySupportedEdge,
            ...) or a list of them.
        n_modes: number of elastic modes; "all" for a full (dense) decomposition of a small
            model; None with ``max_freq_hz`` for every mode up to that frequency.
        zeta: modal damping: a ratio, one per mode, or fem.Rayleigh(alpha, beta).
        max_freq_hz: keep only modes up to this frequency (Hz).
        allow_rigid_modes: accept grippers that leave rigid-body modes (they are reported,
            not put into the model) instead of rejecting them.
        sigma_hz: the shift of the eigen solver is -(2 pi sigma_hz)^2.
        rigid_tol_hz: modes below this frequency count as rigid-body modes.
        error_estimate: estimate the discretisation error of the frequencies and the peak
            stress (fem.discretisation: a second analysis on a mesh twice as coarse, about a
            fifth of the cost; parts whose mesh is meshed here) as ``result.discretisation``,
            in the model's meta and summary; a JaxflexWarning where it exceeds 2 %.
        progress: show progress (jaxflex._progress; None: unless the process is quiet).
    """
    t_start = time.perf_counter()
    if not isinstance(part, Part):
        raise InputError(
            f"part: expected a fem part (rectangular_plate, curved_panel, "
            f"read_mesh, read_cad), got {type(part).__name__}"
        )
    supports = as_support_list(supports)
    max_freq_hz = check_request(n_modes, max_freq_hz, zeta)
    check_positive("sigma_hz", sigma_hz)
    check_layout(supports, part, allow_rigid_modes=allow_rigid_modes)
    # jaxflex._budget, before any meshing
    require(fe_plan(part, n_modes, supports, estimate=error_estimate).need())
    request = _Request(n_modes, zeta, max_freq_hz, allow_rigid_modes, sigma_hz, rigid_tol_hz)
    result = _analyse(part, supports, request, progress, t_start)
    if error_estimate and part.mesh_is_given:
        result.discretisation = given_mesh_statement(coarse_mesh_warnings(result))
    elif error_estimate and n_modes == "all":
        result.discretisation = (
            "not estimated: every mode was asked for (n_modes='all'), and the highest modes "
            "of any mesh are not resolved by it"
        )
    elif error_estimate:
        step("discretisation estimate: the same analysis on a coarser mesh", enabled=progress)
        coarse = replace(request, check_truncation=False)
        found = estimate(
            result, lambda other: _analyse(other, supports, coarse, False, time.perf_counter())
        )
        result.discretisation = found
        if not isinstance(found, str):
            for message in found.warnings():
                warnings.warn(f"{part.name}: {message}", JaxflexWarning, stacklevel=2)
    return result


@dataclass(frozen=True)
class _Request:
    """What :func:`modal_analysis` was asked for (checked); ``check_truncation`` False
    skips the residual check (the discretisation estimate's second analysis)."""

    n_modes: int | str | None
    zeta: Any
    max_freq_hz: float | None
    allow_rigid_modes: bool
    sigma_hz: float
    rigid_tol_hz: float
    check_truncation: bool = True


def _analyse(part, supports, request: _Request, progress, t_start: float) -> ModalResult:
    """Mesh, assemble, reduce to the free coordinates and solve (:func:`modal_analysis`)."""
    timings: dict[str, float] = {}
    tick = time.perf_counter()
    discs = contact_discs(supports)
    mesh = part.mesh(discs)
    timings["mesh_s"] = time.perf_counter() - tick
    tick = time.perf_counter()
    if part.kind == "plate":
        system = assemble_plate(
            mesh, part.element, part.material, part.thickness_m, supports, progress
        )
    elif part.kind == "shell":
        system, _ = assemble_shell(mesh, part, supports, progress)
    else:
        system, _ = assemble_solid(mesh, part, supports, progress)
    system.stats.update(cup_discs=len(discs), cup_rims=len(getattr(mesh, "rims", ())))
    timings["assembly_s"] = time.perf_counter() - tick

    step(f"gripper constraints ({system.n_dof} DOFs)", enabled=progress)
    tick = time.perf_counter()
    T, springs, _ = system.constraints.reduction(system.n_dof)
    K_free = (T.T @ system.K @ T + springs).tocsr()
    M_free = (T.T @ system.M @ T).tocsr()
    load = T.T @ (system.M @ system.rigid)  # (n_free, 3) = (M R)_free
    timings["constraints_s"] = time.perf_counter() - tick

    observation = (system.observation() @ T).tocsr()
    modes = solve_modes(
        K_free,
        M_free,
        load,
        observation,
        request.n_modes,
        max_freq_hz=request.max_freq_hz,
        rigid_count=RIGID_MODES[part.kind] if request.allow_rigid_modes else None,
        sigma_hz=request.sigma_hz,
        rigid_tol_hz=request.rigid_tol_hz,
        rigid_message="supports: the gripper leaves {count} rigid-body mode(s) (below {tol:g} "
        "Hz): the part is not held; add cups or pass allow_rigid_modes=True",
        check_truncation=request.check_truncation,
        progress=progress,
    )
    timings.update(modes.timings_s)
    reduced = (T, K_free, M_free, load, observation)
    return modal_result(part, supports, system, reduced, modes, request.zeta, timings, t_start)


def modal_result(part, supports, system, reduced, modes, zeta, timings, t_start) -> ModalResult:
    """The ModalResult of ``modes`` (a ModeSolution) of ``system`` reduced to free
    coordinates: ``reduced`` = (basis T, K_free, M_free, load, observation); ``timings``
    completed with the total since ``t_start`` (time.perf_counter)."""
    T, K_free, M_free, load, observation = reduced
    mass = float(np.max(np.einsum("id,id->d", system.rigid, system.M @ system.rigid)))
    timings["total_s"] = time.perf_counter() - t_start
    return ModalResult(
        part=part,
        supports=supports,
        system=system,
        basis=T,
        K_free=K_free,
        M_free=M_free,
        load=load,
        freq_hz=modes.freq_hz,
        vectors=modes.vectors,
        gamma=modes.gamma,
        rigid_freq_hz=modes.rigid_freq_hz,
        rigid_gamma=modes.rigid_gamma,
        mobile_mass_kg=modes.mobile_mass_kg,
        static_residual_fraction=modes.static_residual_fraction,
        mass_kg=mass,
        zeta=modal_zeta(zeta, modes.freq_hz),
        damping=zeta,
        timings_s=timings,
        observation=observation,
    )


def describe_model(model: ModalModel) -> str:
    """One line about the part behind a model, read from its meta (fem.modal_analysis):
    "rectangular plate 1.5 x 0.8 m x 1 mm steel on 4 suction cups, 31047 DOFs"; parts of
    the description the meta does not hold are left out."""
    meta = dict(model.meta)
    part, words = meta.get("part") or {}, []
    words.append(part.get("name", "part"))
    if "width_m" in part and "height_m" in part:
        words.append(f"{part['width_m']:g} x {part['height_m']:g} m")
    if "thickness_m" in part:
        words.append(f"x {part['thickness_m'] * 1e3:g} mm")
    material = (meta.get("material") or {}).get("name")
    if material:
        words.append(material)
    grippers = meta.get("gripper") or []
    if grippers:
        kinds = sorted({g.get("type", "support").replace("_", " ") for g in grippers})
        words.append(f"on {len(grippers)} {' / '.join(kinds)}{'s' if len(grippers) > 1 else ''}")
    dofs = (meta.get("mesh") or {}).get("n_dof")
    return " ".join(words) + (f", {dofs} DOFs" if dofs else "")
