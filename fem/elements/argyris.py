"""The Argyris triangle with its polynomial basis in each element's own coordinates.

scikit-fem's ``ElementTriArgyris`` (an ``ElementGlobal``) builds each element's quintic
basis from the 21 monomials x^i y^j (i + j <= 5) in *global* coordinates and inverts the
21 x 21 matrix of their degrees of freedom per element. Far from the origin and for small
elements those monomials are nearly dependent on the element: a 30 mm element of a
1.2 x 0.6 m plate gives matrices of condition ~1e12, the basis loses every digit, and the
plate's rigid motions are no longer reproduced (``plate rigid motions: projection differs by
7.9e+04``; the same happened on the built-in plate at 30 mm). The degrees of freedom and the
space spanned are the same in any affine frame, so here the monomials are taken in the
element's coordinates centred at its centroid and scaled by its longest edge h,
xi = (x - x_c) / h, and derivatives of order k pick up 1 / h^k: the matrices then have a
condition number that depends on the element's shape only (~1e4 for gmsh's triangles).
"""

from __future__ import annotations

import itertools

import numpy as np
import skfem
from skfem.element.discrete_field import DiscreteField


def element_frames(mesh: skfem.MeshTri) -> tuple[np.ndarray, np.ndarray]:
    """Centroids (2, E) and longest edges (E,) of the triangles of ``mesh``, m."""
    corners = mesh.p[:, mesh.t]  # (2, 3, E)
    edges = corners - np.roll(corners, 1, axis=1)
    return corners.mean(axis=1), np.sqrt((edges**2).sum(axis=0)).max(axis=0)


def _in_frame(function, centre, scale, order: int):
    """``function`` of the local coordinates as a function of global (x, y); a derivative
    of ``order`` in local coordinates becomes one in global coordinates by / scale^order."""

    def evaluate(x, y):
        return function((x - centre[0]) / scale, (y - centre[1]) / scale) / scale**order

    return evaluate


class ElementTriArgyrisLocal(skfem.ElementTriArgyris):
    """``skfem.ElementTriArgyris`` with the power basis in element coordinates (see the
    module): the same element, the same degrees of freedom, well conditioned on any mesh."""

    def _local_power_basis(self, centre, scale) -> dict:
        return {
            diff: [_in_frame(f, centre, scale, len(diff)) for f in functions]
            for diff, functions in self._pbasis.items()
        }

    def _eval_dofs(self, mesh, tind=None):
        centre, scale = element_frames(mesh)
        if tind is not None:
            centre, scale = centre[:, tind], scale[tind]
        global_basis = self._pbasis
        self._pbasis = self._local_power_basis(centre, scale)
        try:
            return super()._eval_dofs(mesh, tind)
        finally:
            self._pbasis = global_basis

    def gbasis(self, mapping, X, i, tind=None):
        mesh = mapping.mesh
        if tind is None:
            tind = np.arange(mesh.t.shape[1])
        if self.V is None:
            self._pbasis_init(self.maxdeg, self.dim, self.derivatives, self.tensorial_basis)
            self.V = np.linalg.inv(self._eval_dofs(mesh))
        centre, scale = element_frames(mesh)
        centre, scale = centre[:, tind, None], scale[tind, None]
        x = mapping.F(X, tind=tind)
        xi = (x - centre) / scale
        coefficients = self.V[tind][:, :, i]  # (E, N): basis i in the local monomials
        values = [np.zeros((self.dim,) * k + x[0].shape) for k in range(self.derivatives + 1)]
        for k in range(self.derivatives + 1):
            for diff in itertools.product(range(self.dim), repeat=k):
                for n, monomial in enumerate(self._pbasis[diff]):
                    values[k][diff] += coefficients[:, n, None] * monomial(*xi)
            values[k] /= scale**k
        return (DiscreteField(value=values[0], grad=values[1], hess=values[2]),)
