"""Modes that come from another program's files (ANSYS results, an identified
unit response), in SI units, and the jaxflex.ModalModel they give.

What a file cannot tell is kept as None and named when it is needed: participation factors
need the mass matrix, point coordinates need the mesh.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from fem.damping import describe_damping, modal_zeta
from fem.imports.checks import check_finite, check_nodes, check_participation, check_shapes
from fem.modal import select_node_indices
from jaxflex.errors import InputError
from jaxflex.files import file_digest as sha256_of
from jaxflex.model import MODES_ONLY_STATIC, ModalModel
from jaxflex.response import RotationalInertia


@dataclass(eq=False)
class ImportedModes:
    """Elastic modes at the nodes of an imported model (SI units).

    Attributes:
        freq_hz: (M,) natural frequencies, Hz, ascending.
        shapes: (N, 3, M) translations of the nodes per mode, m per kg^0.5 (mass-normalised
            where the source is; see ``provenance``).
        gamma: (M, 3) participation factors along x, y, z in kg^0.5, or None when the
            source cannot know them (``gamma_missing`` says why and how to supply them).
        nodes: (N, 3) node coordinates in m, or None (``nodes_missing`` says why).
        node_ids: (N,) node numbers of the source.
        zeta: damping spec (ratio, per mode, or fem.Rayleigh).
        mobile_mass_kg: (3,) sum of Gamma^2 over all modes when known (else None).
        stress: (N, 6, M) nodal stresses per unit modal coordinate (Sx, Sy, Sz, Sxy, Syz,
            Sxz), Pa per (kg^0.5 m), where the source holds them; kept for later use.
        static_shapes: (N, 3, 3) exact static displacement of the nodes per unit base
            acceleration (m per m/s^2), where the source has a stiffness and a mass matrix
            and the part is held (jaxflex.ModalModel.static_shapes), else None;
            ``static_note`` says where it came from.
        provenance: what was read from where and what was derived how (the model's meta).
        rotation: the turning moves' inertia data (jaxflex.response.RotationalInertia) where
            the source has a mass matrix and node coordinates, else None.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    gamma: np.ndarray | None
    nodes: np.ndarray | None
    node_ids: np.ndarray
    zeta: Any = 0.02
    mobile_mass_kg: np.ndarray | None = None
    stress: np.ndarray | None = None
    static_shapes: np.ndarray | None = None
    static_note: str = "static solve of the source's stiffness and mass (exact)"
    gamma_missing: str = ""
    nodes_missing: str = ""
    provenance: dict[str, Any] = field(default_factory=dict)
    rotation: RotationalInertia | None = None

    @property
    def n_modes(self) -> int:
        return int(self.freq_hz.size)

    def select_nodes(self, points=None, key_points=None, key_tolerance_m: float | None = None):
        """Node indices for ``points`` (None/"all", a count, or (K, 3) coordinates in m)."""
        if points is None or (isinstance(points, str) and points == "all"):
            return select_node_indices(np.zeros((len(self.node_ids), 3)), points, key_points)
        nodes = self._require_nodes()
        if key_tolerance_m is None:
            spacing, _ = cKDTree(nodes).query(nodes, k=min(2, len(nodes)))
            key_tolerance_m = 2 * float(np.max(spacing[:, -1])) or 1e-9
        return select_node_indices(nodes, points, key_points, key_tolerance_m)

    def to_modal_model(
        self,
        points=None,
        *,
        key_points=None,
        labels: Sequence[str] | None = None,
        zeta=None,
        key_tolerance_m: float | None = None,
    ) -> ModalModel:
        """The jaxflex.ModalModel at the monitored points (see :meth:`select_nodes`);
        ``labels`` default to the source's node numbers; ``zeta`` overrides the damping."""
        if self.n_modes == 0:
            raise InputError("to_modal_model: the source holds no elastic mode")
        self.check()
        if self.gamma is None:
            raise InputError(f"participation factors: {self.gamma_missing}")
        nodes = self._require_nodes()
        idx = self.select_nodes(points, key_points, key_tolerance_m)
        if labels is None:
            labels = [f"node {int(n)}" for n in self.node_ids[idx]]
        labels = [str(s) for s in labels]
        if len(labels) != len(idx):
            raise InputError(f"labels: expected {len(idx)} labels, got {len(labels)}")
        spec = self.zeta if zeta is None else zeta
        return ModalModel(
            freq_hz=self.freq_hz,
            zeta=modal_zeta(spec, self.freq_hz),
            gamma=self.gamma,
            shapes=self.shapes[idx],
            points=nodes[idx],
            labels=labels,
            meta=self.meta(spec, len(idx)),
            static_shapes=None if self.static_shapes is None else self.static_shapes[idx],
            rotation=self.rotation,
        )

    def check(self) -> None:
        """Refuse what no valid set of modes can be, warn about what is unusual
        (fem.imports.checks): non-finite values, node ids given twice, all nodes at one
        point, zero shapes, participation factors that contradict the shapes or the mass."""
        source = str(self.provenance.get("source", "imported modes"))
        for name in ("freq_hz", "shapes", "gamma", "nodes", "mobile_mass_kg"):
            check_finite(name, getattr(self, name), source)
        check_nodes(self.node_ids, self.nodes, source)
        check_shapes(self.freq_hz, self.shapes, self.gamma, source)
        rigid = int(self.provenance.get("rigid_modes", {}).get("count", 0))
        check_participation(self.shapes, self.gamma, self.mobile_mass_kg, rigid, source)

    def meta(self, damping=None, n_points: int | None = None) -> dict[str, Any]:
        """JSON-serialisable description stored in the ModalModel."""
        out: dict[str, Any] = {
            "units": "SI: m, s, kg, Pa; freq_hz Hz, gamma kg^0.5, shapes m/kg^0.5",
            **self.provenance,
            "damping": describe_damping(self.zeta if damping is None else damping),
            "n_points": n_points,
            "static_response": (
                self.static_note
                if self.static_shapes is not None
                else f"{MODES_ONLY_STATIC} (the source has no stiffness matrix, or the part is "
                "not held)"
            ),
        }
        if self.mobile_mass_kg is not None and self.gamma is not None:
            out["effective_mass"] = {
                "directions": ["x", "y", "z"],
                "mobile_mass_kg": self.mobile_mass_kg.tolist(),
                "cumulative_fraction": self.cumulative_fraction().tolist(),
            }
        return out

    def cumulative_fraction(self) -> np.ndarray:
        """(3,) share of the mobile mass the modes carry per direction (NaN if unknown)."""
        if self.mobile_mass_kg is None or self.gamma is None:
            return np.full(3, np.nan)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(
                self.mobile_mass_kg > 0,
                np.sum(self.gamma**2, axis=0) / self.mobile_mass_kg,
                np.nan,
            )

    def summary(self) -> str:
        """Human-readable table: frequencies, participation, what is missing."""
        lines = [f"{self.provenance.get('source', 'imported modes')}: {self.n_modes} modes"]
        lines.append(" mode   freq [Hz]   Gamma x     Gamma y     Gamma z   [kg^0.5]")
        for i in range(self.n_modes):
            if self.gamma is None:
                cells = "   (unknown: see below)"
            else:
                cells = " ".join(f"{g:11.4g}" for g in self.gamma[i])
            lines.append(f"{i + 1:5d} {self.freq_hz[i]:11.4f} {cells}")
        frac = self.cumulative_fraction()
        if np.isfinite(frac).any():
            shown = ", ".join(f"{d}: {v:.4f}" for d, v in zip("xyz", frac, strict=True))
            lines.append(f"share of the mobile mass in these modes: {shown}")
        if self.gamma is None:
            lines.append(f"participation factors unknown: {self.gamma_missing}")
        if self.nodes is None:
            lines.append(f"node coordinates unknown: {self.nodes_missing}")
        return "\n".join(lines)

    def _require_nodes(self) -> np.ndarray:
        if self.nodes is None:
            raise InputError(f"node coordinates: {self.nodes_missing}")
        return self.nodes


def file_digest(path: str | os.PathLike) -> dict:
    """{"path", "sha256", "bytes"} of an input file (recorded in the model's meta)."""
    return {"path": str(path), "sha256": sha256_of(path), "bytes": os.path.getsize(path)}
