"""The free coordinates of a deck model: u = T z, as Nastran partitions its DOFs.

1. Displacement systems: u (basic, 6 per grid) = Tcd u_cd, u_cd the components in every
   grid's CD system (Nastran's g-set).
2. Dependent components (RBE2, RBE3, RBAR, RROD, MPC; fem.imports.nastran.constraints) are
   eliminated: u_cd = E u_i; a dependent component that depends on another dependent one is resolved
   through the chain (a cycle is an error).
3. Held components (SPC, PS) and the cups (clamped, pinned or on springs to pads; the
   gripper the user gives, fem.supports) are applied by fem.system.Constraints on u_i.
4. AUTOSPC, as Nastran's default: at every grid the free translations and the free rotations
   form 3 x 3 blocks of the reduced stiffness; directions whose stiffness is below 1e-8 of
   the block's largest (or all of an empty block) are held at the component that dominates
   them (a grid nothing connects, the rotations of a grid only rods or springs reach, the
   normal of a membrane).
5. Components without mass but with stiffness (the end of a massless spring, the rotations
   of a point mass) are condensed exactly (static condensation: they follow the others
   with no inertia of their own), so that the mass matrix of z is definite.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from fem.imports.nastran.constraints import DeckConstraints
from fem.system import Constraints, Spring
from jaxflex.errors import BudgetError, InputError

AUTOSPC_RATIO = 1e-8  # Nastran's EPZERO for grid-point singularities
CONDENSATION_BUDGET = 25_000_000  # entries of the dense block of massless components
DENSE_CONDENSATION = 3000  # massless components solved densely (a pseudo-inverse)


@dataclass(eq=False)
class ReducedConstraints(Constraints):
    """Constraints whose reduction was computed by fem.imports.nastran.reduce (cups included): what
    fem.outputs asks of a system's constraints (pad columns, springs) stays consistent
    with the basis of the analysis."""

    reduced: tuple = ()

    def reduction(self, n_dof: int):
        return self.reduced


@dataclass
class Reduction:
    """u = T z: ``basis`` (n, f), ``stiffness`` and ``mass`` of z (f, f), the supports'
    Constraints on u (``held_by_support``), the ``constraints`` to put on the system, counts
    for the record, and the g-set DOFs AUTOSPC held (``autospc``)."""

    basis: sp.csc_matrix
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    held_by_support: list[Constraints]
    constraints: ReducedConstraints
    info: dict = field(default_factory=dict)
    autospc: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))


def displacement_systems(frames: np.ndarray) -> sp.csr_matrix:
    """(6 N, 6 N) Tcd: basic DOFs of grids whose displacement directions are the rows of
    ``frames`` (N, 3, 3), per CD component: u = Tcd u_cd."""
    n = len(frames)
    blocks = np.zeros((n, 2, 3, 2, 3))
    blocks[:, 0, :, 0, :] = np.swapaxes(frames, 1, 2)
    blocks[:, 1, :, 1, :] = np.swapaxes(frames, 1, 2)
    blocks = blocks.reshape(n, 6, 6)
    return sp.block_diag(list(blocks), format="csr")


def _eliminate(n: int, dof, constraints: DeckConstraints):
    """(E (n, n_i), the g-set index of each i-set column, mask of dependent DOFs)."""
    rows, cols, vals = [], [], []
    dependent = np.zeros(n, dtype=bool)
    cards = {}
    for relation in constraints.relations:
        d = dof(relation.dependent)
        dependent[d] = True
        cards[d] = relation.card
        for key, value in relation.terms.items():
            rows.append(d)
            cols.append(dof(key))
            vals.append(value)
    g = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    h = g.copy()
    m_index = np.flatnonzero(dependent)
    for _ in range(len(m_index) + 1):
        through = h[:, m_index]
        if through.nnz == 0:
            break
        h = (h @ sp.diags((~dependent).astype(float)) + through @ g[m_index]).tocsr()
    else:
        stuck = m_index[np.asarray(abs(h[:, m_index]).sum(axis=0)).ravel() > 0][0]
        raise InputError(
            f"deck: {cards[stuck].where(None)}: its dependent components depend on "
            "themselves through other rigid elements or MPCs (a cycle)"
        )
    independent = np.flatnonzero(~dependent)
    e = sp.eye(n, format="csr")[:, independent] + h[:, independent]
    return e.tocsc(), independent, dependent


def _grid_blocks(k_free, columns: np.ndarray) -> np.ndarray:
    """(G, 3, 3) entries of ``k_free`` at the column triples ``columns`` (G, 3) (-1:
    absent, 0 there)."""
    i = np.repeat(columns, 3, axis=1)
    j = np.tile(columns, (1, 3))
    present = (i >= 0) & (j >= 0)
    values = np.zeros(i.shape)
    values[present] = np.asarray(k_free[i[present], j[present]]).ravel()
    return values.reshape(-1, 3, 3)


def autospc(k_free: sp.csr_matrix, plain_g: np.ndarray, n_grids: int) -> np.ndarray:
    """g-set DOF indices to hold (module docstring, 4): ``plain_g`` the g-set DOF of each
    leading (plain) column of ``k_free``."""
    held = []
    for offset in (0, 3):  # translations, rotations
        columns = np.full((n_grids, 3), -1, dtype=np.int64)
        node, comp = np.divmod(plain_g, 6)
        kind = (comp >= offset) & (comp < offset + 3)
        columns[node[kind], comp[kind] - offset] = np.flatnonzero(kind)
        busy = np.flatnonzero((columns >= 0).any(axis=1))
        blocks = _grid_blocks(k_free, columns[busy])
        present = columns[busy] >= 0
        diagonal = np.abs(np.diagonal(blocks, axis1=1, axis2=2))
        scale = np.where(present, diagonal, 0.0).max(axis=1)
        padded = blocks + np.einsum("g,gi,ij->gij", np.where(scale > 0, scale, 1.0),
                                    (~present).astype(float), np.eye(3))  # fmt: skip
        values, vectors = np.linalg.eigh(padded)
        # an empty block is padded with 1: its own eigenvalues are 0
        limit = np.where(scale > 0, AUTOSPC_RATIO * scale, AUTOSPC_RATIO)
        for g in np.flatnonzero((values <= limit[:, None]).any(axis=1)):
            chosen: set[int] = set()
            for v in np.flatnonzero(values[g] <= limit[g]):
                weight = np.abs(vectors[g][:, v]) * present[g]
                weight[list(chosen)] = -1
                c = int(np.argmax(weight))
                if present[g, c] and c not in chosen:
                    chosen.add(c)
            held.extend(6 * busy[g] + offset + c for c in chosen)
    return np.array(sorted(held), dtype=np.int64)


def massless_directions(m_free, plain_g: np.ndarray, n_grids: int):
    """(an orthogonal change of the leading columns of z, the new columns without mass): at
    every grid the block of ``m_free`` of its free components is turned to its eigenvectors;
    those of zero mass (below 1e-12 of the block's largest: a grid only springs reach, the
    rotations of a point mass) carry no mass anywhere (M is semi-definite)."""
    n = m_free.shape[0]
    columns = np.full((n_grids, 6), -1, dtype=np.int64)
    node, comp = np.divmod(plain_g, 6)
    columns[node, comp] = np.arange(len(plain_g))
    busy = columns[(columns >= 0).any(axis=1)]
    masks, group = np.unique(busy >= 0, axis=0, return_inverse=True)
    rows, new_cols, vals, massless = [np.arange(n)], [np.arange(n)], [np.ones(n)], []
    turned = np.zeros(n, dtype=bool)
    for k, mask in enumerate(masks):
        cols = busy[group.ravel() == k][:, mask]  # (G, c)
        size = cols.shape[1]
        i, j = np.repeat(cols, size, axis=1), np.tile(cols, (1, size))
        blocks = np.asarray(m_free[i.ravel(), j.ravel()]).reshape(-1, size, size)
        values, vectors = np.linalg.eigh(blocks)
        scale = np.abs(values).max(axis=1, keepdims=True)
        zero = values <= 1e-12 * np.where(scale > 0, scale, 1.0)
        for g in np.flatnonzero(zero.any(axis=1)):
            own = cols[g]
            turned[own] = True
            for v in range(size):
                rows.append(own)
                new_cols.append(np.full(size, own[v]))
                vals.append(vectors[g][:, v])
                if zero[g, v]:
                    massless.append(own[v])
    vals[0][turned] = 0.0  # those columns are replaced by the eigenvectors
    turn = sp.csc_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(new_cols))), shape=(n, n)
    )
    return turn, np.array(sorted(massless), dtype=np.int64)


def _condense(t, k_free, m_free, columns: np.ndarray, pads: list):
    """Static condensation of the (massless) ``columns`` of z."""
    kept = np.setdiff1d(np.arange(k_free.shape[0]), columns)
    k_ss = k_free[columns][:, columns].tocsc()
    k_sk = k_free[columns][:, kept].tocsc()
    adjacent = np.flatnonzero(np.diff(k_sk.indptr) > 0)
    if len(columns) * len(adjacent) > CONDENSATION_BUDGET:
        raise BudgetError(
            f"deck: {len(columns)} components have stiffness but no mass next to "
            f"{len(adjacent)} with mass; condensing them needs {len(columns) * len(adjacent):,} "
            f"dense entries (budget {CONDENSATION_BUDGET:,}): give the structure its density "
            "(MAT RHO)"
        )
    rhs = k_sk[:, adjacent].toarray()
    if len(columns) <= DENSE_CONDENSATION:
        # a pseudo-inverse: a motion of massless components that needs no force (a massless
        # appendage turning about its only grid) carries neither energy nor inertia, any
        # particular solution serves; K is semi-definite, so -K_sk z lies in K_ss's range
        values, vectors = np.linalg.eigh(k_ss.toarray())
        keep = values > 1e-12 * max(values.max(initial=0.0), 1e-300)
        solved = -(vectors[:, keep] / values[keep]) @ (vectors[:, keep].T @ rhs)
    else:
        try:
            solved = -splu(k_ss).solve(rhs)
        except RuntimeError:
            solved = np.full(rhs.shape, np.nan)
        if not np.isfinite(solved).all():
            raise InputError(
                f"deck: {len(columns)} components have neither mass nor a stiff connection "
                "(a massless mechanism); hold them (SPC) or give them mass"
            )
    rows = np.concatenate([kept, np.repeat(columns, len(adjacent))])
    cols = np.concatenate([np.arange(len(kept)), np.tile(adjacent, len(columns))])
    vals = np.concatenate([np.ones(len(kept)), solved.ravel()])
    c = sp.csc_matrix((vals, (rows, cols)), shape=(k_free.shape[0], len(kept)))
    position = np.full(k_free.shape[0], -1)
    position[kept] = np.arange(len(kept))
    new_pads = [position[p] for p in pads]
    return t @ c, (c.T @ k_free @ c).tocsr(), (c.T @ m_free @ c).tocsr(), new_pads


def _to_components(support: Constraints, tcd: sp.csr_matrix) -> Constraints:
    """A support's constraints on basic DOFs as constraints on CD components (whole DOF
    triples: clamped or pinned grids, pads of all six)."""
    if support.directions:
        raise InputError("supports: only cups and point supports hold a deck's part")
    springs = [
        Spring(s.dofs, tcd[s.dofs][:, s.dofs].T @ s.shape, s.stiffness, s.frame, s.centre_m)
        for s in support.springs
    ]
    return Constraints(fixed=support.fixed.copy(), springs=springs)


def reduce_deck(
    stiffness, mass, frames: np.ndarray, dof, constraints: DeckConstraints, supports, labels
) -> Reduction:
    """The basis and matrices of the free coordinates (module docstring). ``dof(grid id,
    component)`` the g-set index; ``supports`` the Constraints of each support on basic
    DOFs; ``labels(g-set index)`` names a component in errors."""
    n = stiffness.shape[0]
    tcd = displacement_systems(frames)
    e, independent, dependent = _eliminate(n, dof, constraints)
    position = np.full(n, -1)
    position[independent] = np.arange(len(independent))
    held_g = np.array(sorted({dof(key) for key in constraints.held}), dtype=np.int64)
    support_cd = [_to_components(s, tcd) for s in supports]
    for i, s in enumerate(support_cd):
        touched = np.concatenate([s.fixed, *[sp_.dofs for sp_ in s.springs]]).astype(np.int64)
        if dependent[touched].any():
            raise InputError(
                f"supports: support {i} holds {labels(int(touched[dependent[touched]][0]))}, "
                "which a rigid element or MPC of the deck makes dependent; place the cup "
                "away from it"
            )
    springs = [
        Spring(position[s.dofs], s.shape, s.stiffness, s.frame, s.centre_m)
        for c in support_cd
        for s in c.springs
    ]
    fixed = np.concatenate([position[held_g], *[position[c.fixed] for c in support_cd]])
    info: dict = {"dependent_components": int(dependent.sum()), "held_components": len(held_g)}
    tied = np.zeros(len(independent), dtype=bool)
    for spring in springs:
        tied[spring.dofs] = True
    autospc_held = np.empty(0, dtype=np.int64)
    for attempt in range(3):
        on_i = Constraints(fixed=np.unique(fixed.astype(np.int64)), springs=springs)
        t_y, spring_k, pads = on_i.reduction(len(independent))
        basis = (tcd @ e @ t_y).tocsc()
        k_free = (basis.T @ stiffness @ basis + spring_k).tocsr()
        m_free = (basis.T @ mass @ basis).tocsr()
        free = np.ones(len(independent), dtype=bool)
        free[on_i.fixed] = False
        plain = np.flatnonzero(free & ~tied)  # the leading columns (Constraints.reduction)
        extra = autospc(k_free, independent[plain], len(frames))
        if not len(extra) or attempt == 2:
            break
        info["autospc"] = info.get("autospc", 0) + len(extra)
        info.setdefault("autospc_first", [labels(int(g)) for g in extra[:5]])
        fixed = np.concatenate([fixed, position[extra]])
        autospc_held = np.concatenate([autospc_held, extra])
    turn, massless = massless_directions(m_free, independent[plain], len(frames))
    if len(massless):
        basis, k_free, m_free = (
            basis @ turn,
            (turn.T @ k_free @ turn).tocsr(),
            turn.T @ m_free @ turn,
        )
        basis, k_free, m_free, pads = _condense(basis, k_free, m_free.tocsr(), massless, pads)
        info["massless_condensed"] = len(massless)
    cups = ReducedConstraints(
        fixed=np.unique(np.concatenate([c.fixed for c in support_cd]).astype(np.int64))
        if support_cd
        else np.empty(0, dtype=np.int64),
        springs=[s for c in support_cd for s in c.springs],
        reduced=(basis, sp.csr_matrix(k_free.shape), pads),  # springs: in the stiffness
    )
    return Reduction(basis, k_free, m_free, support_cd, cups, info, np.sort(autospc_held))
