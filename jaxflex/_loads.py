"""What the cup reactions and stresses mean for the hardware: cup utilisation, von Mises.

Both are functionals of the linear outputs of jaxflex._outputs, one value per item (a cup, a
stress point), convex and positively homogeneous in the item's rows, with Lipschitz weights
per row (|f(y + e) - f(y)| <= W . |e|) and a supporting cut (f(y') >= g . y' for every y',
equality at y): what jaxflex._peaks certifies and what the optimiser's LP rows are made of.

**Cup utilisation** (1 = the cup is at its limit). With the force F on the part and the
moment M about the cup centre, the cup normal n (from the part into the cup), the holding
force F_hold = dp A (no safety factor), the friction coefficient mu, the effective radius r
and the safety factor S:

    u = S / F_hold (max(N, 0) + |F_t| / mu + 4 |M_t| / r + 1.5 |M_n| / (mu r)),

N = F . n the pull on the vacuum joint, F_t the shear, M_t the peeling moment (about an axis
in the surface), M_n the torsion. The pull and the shear over mu add as in the makers' load
cases (Schmalz, theoretical holding force, load cases I-III); a peeling moment on a disc
with a linear pressure distribution lifts its edge like a pull of 4 M / r (section modulus
pi r^3 / 4 times the area pi r^2); a torsion slips the disc at 2/3 mu F r (uniform
pressure). The criterion is conservative: a pressing force (N < 0) is not credited.

**von Mises** stress of the Voigt rows (xx, yy, zz, yz, xz, xy) in Pa:
sqrt(s^T P s) with P the quadratic form of the von Mises equivalent stress.
"""

from __future__ import annotations

import numpy as np

from jaxflex._outputs import CupSet
from jaxflex._scalars import check_positive

DEFAULT_CUP_SAFETY = 1.5  # the makers' minimum for smooth, dense parts (fem.cups)
DEFAULT_STRESS_SAFETY = 1.5  # yield / this is the default stress limit

_VM = np.array(
    [
        [1.0, -0.5, -0.5, 0, 0, 0],
        [-0.5, 1.0, -0.5, 0, 0, 0],
        [-0.5, -0.5, 1.0, 0, 0, 0],
        [0, 0, 0, 3.0, 0, 0],
        [0, 0, 0, 0, 3.0, 0],
        [0, 0, 0, 0, 0, 3.0],
    ]
)


def _unit(v: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(norm > 0, v / np.where(norm > 0, norm, 1.0), 0.0)


class CupUtilisation:
    """The utilisation of every cup of ``cups`` (module docstring); items: cups, 6 rows each
    (F_x, F_y, F_z, M_x, M_y, M_z). ``safety``: the safety factor S (>= 1 customary)."""

    rows_per_item = 6

    def __init__(self, cups: CupSet, safety: float = DEFAULT_CUP_SAFETY) -> None:
        self.safety = check_positive("cup safety factor", safety)
        self.normal = np.asarray(cups.normal)
        self.scale = self.safety / np.asarray(cups.holding_force_n)  # (C,) 1/N
        self.friction = np.asarray(cups.friction)
        self.radius = np.asarray(cups.radius_m)
        self.n_items = cups.n_cups

    def parts(self, y: np.ndarray, items: np.ndarray) -> dict[str, np.ndarray]:
        """Pull N (N, >= 0 counted), shear |F_t| (N), peel |M_t| and torsion |M_n| (N m):
        (..., I) each, for outputs ``y`` (..., I, 6)."""
        n = self.normal[items]
        force, moment = y[..., :3], y[..., 3:]
        pull = np.einsum("...ic,ic->...i", force, n)
        twist = np.einsum("...ic,ic->...i", moment, n)
        return {
            "pull_n": pull,
            "shear_n": np.linalg.norm(force - pull[..., None] * n, axis=-1),
            "peel_nm": np.linalg.norm(moment - twist[..., None] * n, axis=-1),
            "torsion_nm": np.abs(twist),
        }

    def _factors(self, items):
        mu, r = self.friction[items], self.radius[items]
        return 1.0 / mu, 4.0 / r, 1.5 / (mu * r)

    def values(self, y: np.ndarray, items: np.ndarray) -> np.ndarray:
        """(..., I) utilisation for outputs ``y`` (..., I, 6)."""
        p = self.parts(y, items)
        shear, peel, torsion = self._factors(items)
        total = np.maximum(p["pull_n"], 0) + shear * p["shear_n"]
        total = total + peel * p["peel_nm"] + torsion * p["torsion_nm"]
        return self.scale[items] * total

    def weights(self, items: np.ndarray) -> np.ndarray:
        """(I, 6) Lipschitz weights per row: |u(y + e) - u(y)| <= weights . |e|."""
        n = self.normal[items]
        tangent = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
        shear, peel, torsion = self._factors(items)
        w_force = np.abs(n) + shear[:, None] * np.linalg.norm(tangent, axis=1)
        w_moment = peel[:, None] * np.linalg.norm(tangent, axis=1) + torsion[:, None] * np.abs(n)
        return self.scale[items, None] * np.concatenate([w_force, w_moment], axis=1)

    def cut(self, y: np.ndarray, item: int) -> np.ndarray:
        """(6,) g with u(y') >= g . y' for all y' and u(y) = g . y (a subgradient)."""
        n = self.normal[item]
        force, moment = y[:3], y[3:]
        pull, twist = force @ n, moment @ n
        shear, peel, torsion = self._factors(np.array([item]))
        g_force = (n if pull > 0 else 0.0) + shear[0] * _unit(force - pull * n)
        g_moment = peel[0] * _unit(moment - twist * n) + torsion[0] * np.sign(twist) * n
        return self.scale[item] * np.concatenate([g_force, g_moment])


class VonMises:
    """The von Mises stress (Pa) at every point of a StressSet; items: points, 6 rows each
    (Voigt xx, yy, zz, yz, xz, xy)."""

    rows_per_item = 6

    def __init__(self, n_points: int) -> None:
        self.n_items = int(n_points)
        values, vectors = np.linalg.eigh(_VM)
        self._root = (vectors * np.sqrt(np.clip(values, 0, None))) @ vectors.T  # P^(1/2)
        self._weights = np.linalg.norm(self._root, axis=0)

    def values(self, y: np.ndarray, items: np.ndarray) -> np.ndarray:
        return np.sqrt(np.maximum(np.einsum("...r,...r->...", y @ _VM, y), 0.0))

    def weights(self, items: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self._weights, (len(items), 6))

    def cut(self, y: np.ndarray, item: int) -> np.ndarray:
        value = float(np.sqrt(max(y @ _VM @ y, 0.0)))
        return _VM @ y / value if value > 0 else np.zeros(6)
