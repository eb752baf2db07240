"""Materials and shell sections of a Nastran deck (in the deck's units).

Materials: MAT1 (isotropic; two of E, G, NU give the third by E = 2 (1 + NU) G, one alone
sets the other two to 0, all three are used as given, as in Nastran), MAT2 (anisotropic
plane stress, G11 ... G33), MAT8 (orthotropic plane stress: E1, E2, NU12, G12). A shell
material is its plane-stress matrix Q (3, 3) for (eps_11, eps_22, gamma_12) in its own axes.

Shell sections (per property; stress resultants N = A eps + B kappa, M = B eps + D kappa,
eps(z) = eps + z kappa through the thickness, the Nastran convention):

* PSHELL: A = T Q(MID1), D = (12I/T^3) T^3 / 12 Q(MID2), B = T^2 Q(MID4); MID1 blank: no
  membrane, MID2 blank: no bending; mass per area RHO T + NSM (RHO of MID1, else MID2),
  rotary inertia RHO T^3 / 12 (our shell's; it keeps every rotation massive). MID3 (the
  transverse shear material) and TS/T are read but the shell is Kirchhoff: noted, not used.
  With T blank the elements' corner thicknesses give it (per element, scaled).
* PCOMP, PCOMPG: classical lamination theory over the plies (Z0 default -total / 2; LAM
  blank, SYM, MEM, BEND, SMEAR): A, B, D, the mass per area (plies and NSM) and the rotary
  inertia about the reference plane; an equivalent shell, with a note of what is lost.

A section is a linear function of the thickness for PSHELL (``scales``): the element's mean
thickness and mean cube (fem.imports.nastran.shells) give its A, B, D, mass and inertia.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fem.imports.nastran.bdf import BulkData, Card
from jaxflex.errors import InputError

SHELL_MATERIALS = ("MAT1", "MAT2", "MAT8")


def rotation(theta_rad) -> np.ndarray:
    """(..., 3, 3) R with eps_material = R eps for material axis 1 at ``theta_rad`` from x
    (engineering shear strain)."""
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    return np.stack(
        [
            np.stack([c * c, s * s, c * s], -1),
            np.stack([s * s, c * c, -c * s], -1),
            np.stack([-2 * c * s, 2 * c * s, c * c - s * s], -1),
        ],
        -2,
    )


def rotate(q: np.ndarray, theta_rad) -> np.ndarray:
    """A plane-stress matrix (or A, B, D) given in axes at ``theta_rad`` from x, in x, y:
    R^T q R."""
    r = rotation(theta_rad)
    return np.einsum("...ai,...ab,...bj->...ij", r, q, r)


@dataclass(frozen=True)
class Material:
    """A material as a shell or beam uses it: ``q`` (3, 3) plane stress in its axes,
    ``e``, ``g`` (MAT1 only: beams), ``rho``, ``isotropic``; ``notes`` for the record."""

    id: int
    q: np.ndarray
    rho: float
    card: Card
    e: float | None = None
    g: float | None = None
    nu: float | None = None
    isotropic: bool = False
    notes: tuple[str, ...] = ()


def _mat1(card: Card) -> Material:
    e, g, nu = card.real(1, "E"), card.real(2, "G"), card.real(3, "NU")
    notes = []
    if e is None and g is None:
        raise InputError(f"deck: {card.where(None)}: E and G are both blank (Nastran needs one)")
    if e is not None and g is not None and nu is None:
        nu = e / (2 * g) - 1
        notes.append("NU from E = 2 (1 + NU) G")
    elif e is None and nu is not None:
        e = 2 * (1 + nu) * g
        notes.append("E from E = 2 (1 + NU) G")
    elif g is None and nu is not None:
        g = e / (2 * (1 + nu))
        notes.append("G from E = 2 (1 + NU) G")
    elif nu is None:  # one of E, G alone: Nastran sets the other and NU to 0
        e, g, nu = e or 0.0, g or 0.0, 0.0
        notes.append("only one of E, G: the other and NU are 0 (Nastran's rule)")
    elif abs(e / (2 * (1 + nu) * g) - 1) > 0.01:
        notes.append(
            f"E, G, NU all given, E / (2 (1 + NU) G) = {e / (2 * (1 + nu) * g):.4g}: used as "
            "given (G for in-plane shear), as in Nastran"
        )
    if e < 0 or g < 0:
        raise InputError(f"deck: {card.where(None)}: E = {e:g}, G = {g:g}; both must be >= 0")
    plane = e / (1 - nu**2) if abs(nu) < 1 else np.nan  # a shell checks it (plane_stress)
    q = np.array([[plane, nu * plane, 0.0], [nu * plane, plane, 0.0], [0.0, 0.0, g]])
    rho = card.real(4, "RHO", 0.0)
    return Material(card.integer(0, "MID"), q, rho, card, e, g, nu, True, tuple(notes))


def _mat2(card: Card) -> Material:
    g11, g12, g13, g22, g23, g33 = (card.real(k, f"G{n}", 0.0) for k, n in enumerate(
        ("11", "12", "13", "22", "23", "33"), start=1))  # fmt: skip
    q = np.array([[g11, g12, g13], [g12, g22, g23], [g13, g23, g33]])
    return Material(card.integer(0, "MID"), q, card.real(7, "RHO", 0.0), card)


def _mat8(card: Card) -> Material:
    e1 = card.required(card.real(1, "E1"), 1, "E1")
    e2 = card.required(card.real(2, "E2"), 2, "E2")
    nu12 = card.required(card.real(3, "NU12"), 3, "NU12")
    g12 = card.real(4, "G12", 0.0)
    nu21 = nu12 * e2 / e1
    if nu12 * nu21 >= 1:
        raise InputError(f"deck: {card.where(3, 'NU12')}: NU12 NU21 = {nu12 * nu21:g} >= 1")
    d = 1 - nu12 * nu21
    q = np.array([[e1 / d, nu12 * e2 / d, 0.0], [nu12 * e2 / d, e2 / d, 0.0], [0.0, 0.0, g12]])
    return Material(card.integer(0, "MID"), q, card.real(7, "RHO", 0.0), card)


READERS = {"MAT1": _mat1, "MAT2": _mat2, "MAT8": _mat8}


def plane_stress_ok(q: np.ndarray) -> bool:
    """Whether a plane-stress matrix is finite and positive definite."""
    if not np.isfinite(q).all():
        return False
    values = np.linalg.eigvalsh(q)
    return bool(values.max() > 0 and values.min() > 1e-9 * values.max())


class Materials:
    """The deck's shell and beam materials, read when first used."""

    def __init__(self, bulk: BulkData) -> None:
        self.bulk = bulk
        self.cards = bulk.by_id(*READERS)
        self._read: dict[int, Material] = {}

    def get(self, mid: int, user: Card, index: int, label: str, allowed=SHELL_MATERIALS):
        """Material ``mid`` that ``user``'s field refers to; refused by name if it is not
        in the deck or not of an ``allowed`` kind."""
        material = self.any(mid, user, index, label, allowed)
        if allowed == SHELL_MATERIALS and not plane_stress_ok(material.q):
            notes = "; ".join(material.notes) or "check E, G, NU"
            raise InputError(
                f"deck: {user.where(index, label)}: material {mid} gives no positive "
                f"plane-stress stiffness for a shell ({material.card.label}: {notes})"
            )
        return material

    def any(self, mid: int, user: Card, index: int, label: str, allowed):
        """Material ``mid`` of an ``allowed`` kind (unchecked for shells)."""
        card = self.bulk.referenced(self.cards, mid, allowed, user, (index, label))
        if mid not in self._read:
            self._read[mid] = READERS[card.name](card)
        return self._read[mid]

    def notes(self) -> dict[str, str]:
        return {m.card.label: "; ".join(m.notes) for m in self._read.values() if m.notes}


@dataclass
class ShellSection:
    """A shell property per unit thickness (``scales``: PSHELL, A = t qm, B = t^2 qc,
    D = t3 qb / 12, mass rho t + nsm, inertia rho t3 / 12) or fixed (a laminate: ``a``,
    ``b``, ``d``, ``mass``, ``inertia`` as given). Matrices in the property's material
    axes; ``oriented``: they depend on the material direction (not isotropic)."""

    card: Card
    thickness: float | None
    qm: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    qb: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    qc: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    rho: float = 0.0
    nsm: float = 0.0
    laminate: tuple | None = None  # (a, b, d, mass, inertia) of a PCOMP
    oriented: bool = False
    shear_flexible: bool = False  # MID3 given: Nastran's element has transverse shear
    poisson: float = 0.3  # for the membrane's drilling stiffness (OPT beta_0)
    notes: tuple[str, ...] = ()

    def resultants(self, t_mean, t3_mean):
        """(A, B, D, mass per area, rotary inertia per area) for elements of mean thickness
        ``t_mean`` (E,) and mean cube ``t3_mean`` (E,); A, B, D (E, 3, 3)."""
        t = np.asarray(t_mean, float)[:, None, None]
        t3 = np.asarray(t3_mean, float)[:, None, None]
        if self.laminate is not None:
            a, b, d, mass, inertia = self.laminate
            n = t.shape[0]
            full = [np.broadcast_to(m, (n, 3, 3)) for m in (a, b, d)]
            return (*full, np.full(n, mass), np.full(n, inertia))
        return (
            t * self.qm,
            t**2 * self.qc,
            t3 / 12 * self.qb,
            self.rho * t[:, 0, 0] + self.nsm,
            self.rho * t3[:, 0, 0] / 12,
        )


def pshell(card: Card, materials: Materials) -> ShellSection:
    """The section of a PSHELL (module docstring)."""
    t = card.real(2, "T")
    if t is not None and t <= 0:
        raise InputError(f"deck: {card.where(2, 'T')}: the thickness must be > 0, got {t:g}")
    mids = {}
    for index, label in ((1, "MID1"), (3, "MID2"), (5, "MID3"), (10, "MID4")):
        mid = card.integer(index, label)
        if label == "MID2" and mid is not None and mid < 0:
            raise InputError(
                f"deck: {card.where(3, 'MID2')}: MID2 = {mid} (plane strain) is not a shell "
                "that jaxflex models; give a bending material or leave it blank"
            )
        if mid and label == "MID3":  # transverse shear: read (named if missing), not used
            mids[label] = materials.any(mid, card, index, label, SHELL_MATERIALS)
        elif mid:
            mids[label] = materials.get(mid, card, index, label)
    if "MID1" not in mids and "MID2" not in mids:
        raise InputError(f"deck: {card.where(None)}: neither MID1 nor MID2: no stiffness")
    ratio = card.real(4, "12I/T**3", 1.0)
    section = ShellSection(card, t, nsm=card.real(7, "NSM", 0.0))
    notes = []
    if "MID1" in mids:
        section.qm = mids["MID1"].q
    else:
        notes.append("no MID1: bending only")
    if "MID2" in mids:
        section.qb = ratio * mids["MID2"].q
    else:
        notes.append("no MID2: membrane only")
    if "MID4" in mids:
        section.qc = mids["MID4"].q
    if "MID3" in mids:
        section.shear_flexible = True
        notes.append("MID3 (transverse shear) not used: the shell is Kirchhoff")
    mass_from = mids.get("MID1") or mids["MID2"]
    section.rho = mass_from.rho
    used = [m for k, m in mids.items() if k != "MID3"]
    section.oriented = not all(m.isotropic for m in used)
    first = next((m for m in used if m.nu is not None), None)
    section.poisson = first.nu if first is not None else 0.3
    section.notes = tuple(notes)
    return section


LAMINATE_OPTIONS = ("", "SYM", "MEM", "BEND", "SMEAR")


def _plies(card: Card) -> list[tuple[int, float, float, int]]:
    """(MID, T, THETA, field index of MID) of each ply listed (MID and T default to the
    previous ply's)."""
    plies = []
    compact = card.name == "PCOMPG"
    width, first = (8, 8) if compact else (4, 8)
    index = first
    mid, t = None, None
    while index < len(card.texts):
        row = card.texts[index : index + (5 if compact else 4)]
        offset = 1 if compact else 0
        if not any(row):
            index += width
            continue
        mid = card.integer(index + offset, "MID", mid)
        t = card.real(index + offset + 1, "T", t)
        theta = card.real(index + offset + 2, "THETA", 0.0)
        if mid is None or t is None:
            card.required(None, index + offset + (0 if mid is None else 1), "MID/T")
        plies.append((mid, t, theta, index + offset))
        index += width
    if not plies:
        card.required(None, first, "MID1")
    return plies


def laminate(card: Card, materials: Materials) -> ShellSection:
    """The equivalent shell of a PCOMP or PCOMPG by classical lamination theory."""
    lam = card.text(7)
    if lam not in LAMINATE_OPTIONS:
        raise InputError(
            f"deck: {card.where(7, 'LAM')}: {lam!r}; supported: blank, SYM, MEM, BEND, SMEAR"
        )
    plies = _plies(card)
    if lam == "SYM":
        plies = plies + plies[::-1]
    total = sum(t for _, t, _, _ in plies)
    if total <= 0:
        raise InputError(f"deck: {card.where(None)}: the plies' thickness is {total:g}")
    z = card.real(1, "Z0", -total / 2)
    a, b, d = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    mass = card.real(2, "NSM", 0.0)
    inertia = 0.0
    for mid, t, theta, index in plies:
        q = rotate(materials.get(mid, card, index, "MID").q, np.radians(theta))
        rho = materials.get(mid, card, index, "MID").rho
        top = z + t
        a += q * t
        b += q * (top**2 - z**2) / 2
        d += q * (top**3 - z**3) / 3
        mass += rho * t
        inertia += rho * (top**3 - z**3) / 3
        z = top
    if lam == "SMEAR":
        b, d = np.zeros((3, 3)), a * total**2 / 12
    elif lam == "MEM":
        b, d = np.zeros((3, 3)), np.zeros((3, 3))
    elif lam == "BEND":
        a, b = np.zeros((3, 3)), np.zeros((3, 3))
    lost = f"{card.label}: {len(plies)} plies, {total:.4g} thick, an equivalent shell (CLT)"
    section = ShellSection(card, total, laminate=(a, b, d, mass, inertia), oriented=True)
    nu = a[0, 1] / a[1, 1] if a[1, 1] > 0 else 0.3
    section.poisson = float(np.clip(nu, 0.0, 0.49))
    section.notes = (lost,)
    return section
