"""Sparse assembly of element matrices computed in blocks of elements (vectorised FE).

Element matrices couple the nodes of an element through b x b blocks (b DOFs per node: 3
for the thin solid, 6 for the shell). The sparsity is built once at node level; each chunk
of element matrices is summed into it with one sparse product; the result is a CSR matrix
with DOF b n + i = component i of node n.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from jaxflex.runtime import progress_bar


class BlockPattern:
    """The node-pair pattern of elements ``element_nodes`` (E, n) over ``n_nodes`` nodes with
    ``block`` DOFs per node."""

    def __init__(self, element_nodes: np.ndarray, n_nodes: int, block: int) -> None:
        nodes = np.asarray(element_nodes, dtype=np.int64)
        self.n_per_element = nodes.shape[1]
        self.n_nodes, self.block = n_nodes, block
        per = self.n_per_element
        pair_keys = (np.repeat(nodes, per, axis=1) * n_nodes + np.tile(nodes, (1, per))).ravel()
        self.keys, self._inverse = np.unique(pair_keys, return_inverse=True)

    def zeros(self) -> np.ndarray:
        """Accumulator of the blocks: (pairs, block * block)."""
        return np.zeros((self.keys.size, self.block**2))

    def add(self, target: np.ndarray, chunk: np.ndarray, matrices: np.ndarray) -> None:
        """Add element matrices (len(chunk), n b, n b) of the consecutive elements ``chunk``
        into ``target`` (from :meth:`zeros`)."""
        per, b = self.n_per_element, self.block
        per_el = per * per
        where = self._inverse[chunk[0] * per_el : (chunk[-1] + 1) * per_el]
        scatter = sp.csc_matrix(
            (np.ones(where.size), where, np.arange(where.size + 1)),
            shape=(self.keys.size, where.size),
        )
        blocks = matrices.reshape(-1, per, b, per, b).transpose(0, 1, 3, 2, 4)
        target += scatter @ blocks.reshape(-1, b * b)

    def matrix(self, blocks: np.ndarray) -> sp.csr_matrix:
        """The assembled (n_nodes b, n_nodes b) CSR matrix of accumulated ``blocks``."""
        b, n = self.block, self.n_nodes
        row, col = np.divmod(self.keys, n)
        indptr = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=n))])
        return sp.bsr_matrix((blocks.reshape(-1, b, b), col, indptr), shape=(n * b, n * b)).tocsr()


def chunks(n_elements: int, size: int) -> list[np.ndarray]:
    """Consecutive element index chunks of at most ``size`` elements."""
    return np.array_split(np.arange(n_elements), max(1, int(np.ceil(n_elements / size))))


def assemble(
    element_nodes: np.ndarray,
    n_nodes: int,
    block: int,
    compute: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    *,
    chunk_size: int,
    label: str,
    progress=None,
) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Stiffness and mass (CSR) from element matrices computed ``chunk_size`` elements at a
    time: ``compute(chunk)`` gives (k, m), each (len(chunk), n b, n b), for the element
    indices ``chunk``; a progress bar named ``label`` counts the chunks."""
    parts = chunks(len(element_nodes), chunk_size)
    with progress_bar(len(parts) + 1, label, progress) as bar:
        pattern = BlockPattern(element_nodes, n_nodes, block)
        bar.update(1)
        k_blocks, m_blocks = pattern.zeros(), pattern.zeros()
        for chunk in parts:
            k_el, m_el = compute(chunk)
            pattern.add(k_blocks, chunk, k_el)
            pattern.add(m_blocks, chunk, m_el)
            bar.update(1)
    return pattern.matrix(k_blocks), pattern.matrix(m_blocks)
