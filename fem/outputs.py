"""Cup reactions and surface stresses of a modal analysis, as outputs linear in the modal state.

On the full-order model (free coordinates z, u = T z, base acceleration a) an output is

    y = A_u z + A_v z' + A_acc z'' + A_b a                                         (1)

* the reaction of a rigidly clamped cup (force on the part, moment about the cup centre) is
  the resultant of the support forces on its held DOFs H, rho_H = [M (R a + T z'') + C T z'
  + K T z]_H, taken with the unit rigid motions V of the cup (virtual work):
  A_u = V^T K_H T, A_acc = V^T M_H T, A_b = V^T M_H R;
* a compliant cup's reaction is its spring force -frame (k * m), m its pad coordinates in z;
* the stress is A_u = S T (S: the formulation's stress operator).

The damping force C T z' that passes through a support is that of its stiffness share:
A_v = alpha A_acc + beta A_u for Rayleigh damping, and for modal damping the per-mode
equivalent (2 zeta_i / omega_i) A_u phi_i (stiffness proportional, which reproduces every
modal damping ratio). Stresses carry no damping force.

The modal outputs (jaxflex.response.LinearOutputs) follow by the mode-acceleration method:
the quasi-static response to a is taken exactly (z_s = K_ff^-1 b, one sparse solve), the
modes correct it, z = -z_s a + Phi (q + Omega^-2 Gamma a), z'' = Phi q''. With
q'' = -Gamma a - 2 Z Omega q' - Omega^2 q this gives

    Q = A_u Phi - A_acc Phi Omega^2,   V = A_v Phi - A_acc Phi 2 Z Omega,
    S = A_b - A_u z_s  (the exact static response),   A = S + Q Omega^-2 Gamma.      (2)

The model stores S (jaxflex._outputs derives A from the modes it keeps), and the points'
exact static displacement -T z_s (:func:`static_displacements`, the model's static_shapes).

Checks (tests): summed over the cups, A = m I - sum_i Gamma_i Gamma_i^T and Q = -Omega^2
Gamma, so the reactions add up to m a + sum_i Gamma_i q_i'' at every instant (the part's
mass times the base acceleration plus the modal inertia forces); a quasi-static move of a
stiff part loads the cups with exactly m a. A Kirchhoff plate has no in-plane DOFs: the
in-plane share (F_x, F_y, M_z) is that of a rigid part on the cups' lateral and torsion
springs (rigid cups: in proportion to their contact area and its polar moment).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fem.damping import Rayleigh
from fem.eigen import factorize
from jaxflex.errors import InputError
from jaxflex.response import CupSet, LinearOutputs, StressSet


@dataclass(eq=False)
class PhysicalOutputs:
    """Equation (1): ``stiffness`` A_u (Y, n_free), ``inertia`` A_acc (Y, n_free) or None,
    ``base`` A_b (Y, 3), ``damped``: whether the support's damping force is part of y."""

    stiffness: sp.csr_matrix
    inertia: sp.csr_matrix | None
    base: np.ndarray
    damped: bool

    def full_order(self, z, zd, zdd, acc, damping: Rayleigh) -> np.ndarray:
        """(T, Y) outputs of full-order states z, z', z'' (T, n_free) under base accelerations
        ``acc`` (T, 3) with Rayleigh ``damping``."""
        y = (self.stiffness @ z.T).T + acc @ self.base.T
        if self.damped:
            y += damping.beta_s * (self.stiffness @ zd.T).T
        if self.inertia is not None:
            y += (self.inertia @ zdd.T).T
            if self.damped:
                y += damping.alpha_per_s * (self.inertia @ zd.T).T
        return y

    def modal(self, result, static: np.ndarray, damping) -> LinearOutputs:
        """Equation (2) for the modes of ``result`` (fem.ModalResult): Q, V and the static
        response S; ``static`` is z_s (n_free, 3) = K_ff^-1 (M R)_free; ``damping`` a
        fem.Rayleigh or the per-mode damping ratios (M,) of the model."""
        phi = result.vectors
        omega = 2 * np.pi * result.freq_hz
        zeta = damping.zeta(result.freq_hz) if isinstance(damping, Rayleigh) else damping
        stiff = np.asarray(self.stiffness @ phi)
        inert = np.zeros_like(stiff) if self.inertia is None else np.asarray(self.inertia @ phi)
        q_map = stiff - inert * omega**2
        if not self.damped:
            damp = np.zeros_like(stiff)
        elif isinstance(damping, Rayleigh):
            damp = damping.alpha_per_s * inert + damping.beta_s * stiff
        else:
            damp = stiff * (2 * zeta / omega)
        v_map = damp - inert * (2 * zeta * omega)
        return LinearOutputs(q_map, v_map, self.base - np.asarray(self.stiffness @ static))


def _cup_supports(result) -> list[int]:
    return [i for i, s in enumerate(result.supports) if s.cup_rating is not None]


def cup_frames(result) -> tuple[np.ndarray, np.ndarray]:
    """(centres (C, 3) m, unit normals (C, 3)) of the suction cups of ``result``."""
    formulation = result.system.outputs
    cups = [result.supports[i] for i in _cup_supports(result)]
    frames = [formulation.surface_frame(c.x, c.y, c.z) for c in cups]
    return np.array([c for c, _ in frames]), np.array([n for _, n in frames])


def reaction_outputs(result) -> PhysicalOutputs:
    """The reactions of every suction cup of ``result`` (6 rows per cup), equation (1)."""
    system, T = result.system, result.basis
    cups = _cup_supports(result)
    if not cups:
        raise InputError("supports: no suction cup, so there are no cup reactions")
    centres, _ = cup_frames(result)
    pads = system.constraints.pad_columns(system.n_dof)
    springs = system.constraints.springs
    stiffness, inertia = [], []
    for c, i in enumerate(cups):
        held = system.support_constraints[i]
        if held.springs:
            spring = held.springs[0]
            where = pads[next(k for k, s in enumerate(springs) if s is spring)]
            k_rows = -(spring.frame * spring.stiffness)  # (6, r)
            cols = np.broadcast_to(where, k_rows.shape)
            rows = np.broadcast_to(np.arange(6)[:, None], k_rows.shape)
            stiffness.append(
                sp.csr_matrix((k_rows.ravel(), (rows.ravel(), cols.ravel())), (6, T.shape[1]))
            )
            inertia.append(sp.csr_matrix((6, T.shape[1])))
        else:
            dofs = held.fixed
            motions = sp.csr_matrix(system.outputs.rigid_motion(centres[c])[dofs].T)  # (6, H)
            stiffness.append(motions @ system.K[dofs] @ T)
            inertia.append(motions @ system.M[dofs] @ T)
    base = held_inertia(result, system.M @ system.rigid)
    if not system.outputs.moves_in_plane:
        load = np.zeros((3, 3))
        load[0, 0] = load[1, 1] = result.mass_kg  # (F_x, F_y, M_z) per unit a
        base += in_plane_share(result, load)
    return PhysicalOutputs(
        sp.vstack(stiffness).tocsr(), sp.vstack(inertia).tocsr(), base, damped=True
    )


def held_inertia(result, loads: np.ndarray) -> np.ndarray:
    """(6 C, F) the share of the cup reactions that the mass on the held DOFs of the rigidly
    clamped cups carries under the inertia ``loads`` (n_dof, F) of an acceleration, M times
    its DOF vectors: V^T (loads on the held DOFs) (equation (1)'s A_b for the rigid
    translations; zero for a compliant cup)."""
    system = result.system
    centres, _ = cup_frames(result)
    out = []
    for c, i in enumerate(_cup_supports(result)):
        held = system.support_constraints[i]
        if held.springs:
            out.append(np.zeros((6, loads.shape[1])))
        else:
            dofs = held.fixed
            motions = sp.csr_matrix(system.outputs.rigid_motion(centres[c])[dofs].T)  # (6, H)
            out.append(np.asarray(motions @ loads[dofs]))
    return np.concatenate(out)


def plate_centre(result) -> np.ndarray:
    """(2,) x, y of the centre of mass of a Kirchhoff plate (from its deflection DOFs), m."""
    system = result.system
    origin = system.outputs.rigid_motion(np.zeros(3))
    weighted = system.M @ system.rigid[:, 2]
    return np.array([-(weighted @ origin[:, 4]), weighted @ origin[:, 3]]) / result.mass_kg


def in_plane_share(result, load: np.ndarray) -> np.ndarray:
    """(6 C, F) reactions of a part that is rigid in its plane (a Kirchhoff plate) carrying
    the in-plane loads ``load`` (3, F): the resultant (F_x, F_y, M_z about its centre of
    mass) that its inertia needs per unit input, on lateral and torsion springs at the cups
    (module docstring)."""
    cups = _cup_supports(result)
    centres, _ = cup_frames(result)
    centre = plate_centre(result)
    lateral, torsion = [], []
    for i in cups:
        support = result.supports[i]
        if support.stiffness is None:  # a uniform shear layer over the contact disc
            area = np.pi * support.radius**2
            lateral.append(area)
            torsion.append(area * support.radius**2 / 2)
        else:
            lateral.append(support.stiffness.lateral_n_m)
            torsion.append(support.stiffness.torsion_nm_rad)
    arms = centres[:, :2] - centre
    maps = np.zeros((len(cups), 2, 3))  # cup displacement per part motion (u_x, u_y, theta)
    maps[:, 0, 0] = maps[:, 1, 1] = 1.0
    maps[:, 0, 2], maps[:, 1, 2] = -arms[:, 1], arms[:, 0]
    k3 = np.einsum("c,cia,cib->ab", lateral, maps, maps)
    k3[2, 2] += sum(torsion)
    motion = -np.linalg.solve(k3, load)  # part motion per unit input
    out = np.zeros((len(cups), 6, load.shape[1]))
    out[:, :2] = -np.einsum("c,cia,ab->cib", lateral, maps, motion)
    out[:, 5] = -np.outer(torsion, motion[2])
    return out.reshape(-1, load.shape[1])


def stress_outputs(result) -> tuple[np.ndarray, PhysicalOutputs]:
    """(points (S, 3) m, the surface stresses as equation (1)) of ``result``."""
    points, operator = result.system.outputs.stress_operator()
    stiffness = (operator @ result.basis).tocsr()
    return points, PhysicalOutputs(stiffness, None, np.zeros((stiffness.shape[0], 3)), False)


def static_response(result) -> np.ndarray:
    """z_s (n_free, 3) = K_ff^-1 (M R)_free: the quasi-static deflection per unit base
    acceleration (negated), one sparse solve (kept on ``result`` for the next call). Raises
    InputError when the part is not held (rigid modes)."""
    if result.rigid_freq_hz.size:
        raise InputError(
            "supports: the part has rigid-body modes, so it has no static response and no "
            "cup reactions or stresses; hold it with three non-collinear cups"
        )
    cached = result.__dict__.get("_static_response")
    if cached is None:
        cached = static_solve(result, result.load)
        result.__dict__["_static_response"] = cached
    return cached


def static_solve(result, loads: np.ndarray) -> np.ndarray:
    """(n_free, F) K_ff^-1 ``loads`` (n_free, F) with the factorisation of the free stiffness,
    made once per ``result``."""
    factor = result.__dict__.get("_stiffness_factor")
    if factor is None:
        factor = factorize(result.K_free)
        result.__dict__["_stiffness_factor"] = factor
    return factor.solve(np.ascontiguousarray(loads))


def static_displacements(result, static: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """(K, 3, 3) exact static displacement of the nodes ``nodes`` (K,) per unit base
    acceleration, m per m/s^2: -T z_s observed at the nodes (``static`` = z_s)."""
    n_nodes = len(result.system.nodes)
    values = -(result.observation @ static).reshape(n_nodes, 3, 3)
    return values[nodes]


def has_cups(result) -> bool:
    """Whether ``result`` holds the part with suction cups (which have reactions)."""
    return bool(_cup_supports(result))


def physical_outputs(result) -> tuple[PhysicalOutputs | None, np.ndarray, PhysicalOutputs]:
    """(the cups' reactions or None, the stress points, the stresses) of ``result`` as
    equation (1), built once per ``result``."""
    cached = result.__dict__.get("_physical_outputs")
    if cached is None:
        reactions = reaction_outputs(result) if _cup_supports(result) else None
        cached = (reactions, *stress_outputs(result))
        result.__dict__["_physical_outputs"] = cached
    return cached


def modal_outputs(result, damping) -> tuple[CupSet | None, StressSet]:
    """The CupSet (None without suction cups) and the StressSet of ``result`` with
    ``damping`` (fem.Rayleigh or per-mode ratios (M,))."""
    static = static_response(result)
    reactions, points, stress = physical_outputs(result)
    cups = None
    if reactions is not None:
        centres, normals = cup_frames(result)
        ratings = [result.supports[i].cup_rating for i in _cup_supports(result)]
        cups = CupSet(
            centres,
            normals,
            [r.radius_m for r in ratings],
            [r.holding_force_n for r in ratings],
            [r.friction for r in ratings],
            reactions.modal(result, static, damping),
        )
    return cups, StressSet(points, stress.modal(result, static, damping))
