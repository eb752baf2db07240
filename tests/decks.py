"""Nastran decks written by the tests (free field, the forms of the Quick Reference Guide),
and the closed forms they are checked against."""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla

import fem
from fem.sanity import PartWarning

STEEL = "MAT1,1,2.1+11,,.3,7850."  # SI: Pa, kg/m^3
E_PA, NU, RHO = 2.1e11, 0.3, 7850.0


def real(value: float) -> str:
    """A real as Nastran reads it (always with a decimal point or an exponent)."""
    return repr(float(value)).upper()


def card(name: str, *fields) -> str:
    """A free-field card; None is a blank field; more than eight fields go on in continuation
    rows (``+`` lines), as a user writes them."""
    texts = ["" if f is None else (real(f) if isinstance(f, float) else str(f)) for f in fields]
    rows = [texts[k : k + 8] for k in range(0, len(texts), 8)] or [[]]
    lines = [",".join([name, *rows[0]])]
    lines += [",".join(["+", *row]) for row in rows[1:]]
    return "\n".join(lines)


def mpc(sid: int, terms) -> str:
    """An MPC card: sum of coefficient x component = 0 over ``terms`` [(grid, component,
    coefficient)], the first dependent; two terms per row after the first, field 2 blank."""
    terms = [(g, c, float(a)) for g, c, a in terms]
    fields = [sid, *terms[0], *(terms[1] if len(terms) > 1 else (None,) * 3), None]
    for k in range(2, len(terms), 2):
        pair = [*terms[k], *(terms[k + 1] if k + 1 < len(terms) else (None,) * 3)]
        fields += [None, *pair, None]
    return card("MPC", *fields)


def write(path, lines, executive: str = "") -> str:
    """A deck of ``lines`` (cards) at ``path``; ``executive``: case control before BEGIN
    BULK (SOL 103 / CEND added)."""
    head = f"SOL 103\nCEND\n{executive}\nBEGIN BULK\n" if executive else ""
    path.write_text(head + "\n".join(lines) + "\nENDDATA\n")
    return str(path)


def plate(nx: int, ny: int, width: float, height: float, *, first=1, eid=1, pid=1, z=0.0, skew=0.0):
    """(GRID and CQUAD4 cards, grid ids (ny + 1, nx + 1), coordinates (ny + 1, nx + 1, 3)) of a
    flat nx x ny plate in the plane z; ``skew``: x moves by skew x y (a parallelogram, whose
    quads have a shorter diagonal: their split does not hang on round-off, as a rectangle's
    does)."""
    xs, ys = np.linspace(0, width, nx + 1), np.linspace(0, height, ny + 1)
    ids = first + np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    xyz = np.stack([*np.meshgrid(xs, ys), np.full((ny + 1, nx + 1), z)], axis=-1)
    xyz[..., 0] += skew * xyz[..., 1]
    lines = [card("GRID", int(ids[j, i]), None, *map(float, xyz[j, i]))
             for j in range(ny + 1) for i in range(nx + 1)]  # fmt: skip
    for j in range(ny):
        for i in range(nx):
            quad = (ids[j, i], ids[j, i + 1], ids[j + 1, i + 1], ids[j + 1, i])
            lines.append(card("CQUAD4", eid, pid, *map(int, quad)))
            eid += 1
    return lines, ids, xyz


def solve(path, **options):
    """fem.from_nastran of a test deck in SI units, its PartWarnings silenced."""
    options.setdefault("units", "SI")
    options.setdefault("progress", False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return fem.from_nastran(path, **options)


def skew(r) -> np.ndarray:
    x, y, z = r
    return np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]], dtype=float)


def rigid_mass(mass: float, inertia, offset) -> np.ndarray:
    """(6, 6) mass matrix about a point of a rigid body of ``mass`` whose centre of mass lies
    at ``offset`` from it, ``inertia`` (3, 3) about the centre of mass: its motion is
    (u + theta x r, theta), so M = T^T diag(m I, J) T with T = [[I, -S(r)], [0, I]]."""
    t = np.eye(6)
    t[:3, 3:] = -skew(offset)
    return t.T @ sla.block_diag(mass * np.eye(3), inertia) @ t


def rigid_frequencies(stiffness, mass) -> np.ndarray:
    """Natural frequencies (Hz) of K x = w^2 M x (dense, ascending)."""
    return np.sqrt(sla.eigh(stiffness, mass, eigvals_only=True)) / (2 * np.pi)
