"""CAD sheet bodies (STEP, IGES, BREP) meshed with gmsh's OpenCASCADE kernel.

The file must hold surfaces (a sheet body: the part's mid-surface); a solid body is
refused with what to export instead. STEP and IGES state their length unit: OpenCASCADE
converts the coordinates to metres (for IGES, gmsh sets that target unit only once its IGES
translator has been initialised by a first import: an IGES is read once, dropped and read
again; the unit and the model space scale of its global section are read here, fem.iges, the
scale applied and the result checked against the largest coordinate the file states); BREP
has none (its coordinates are taken as metres); ``scale`` multiplies after that. Faces that
touch are glued (coincident edges become one), so the mesh is continuous across their
common edges (a flange meets its base). The surface is meshed with triangles
(quadrilaterals for the thin solid) of ``mesh_size_m``, finer where curved (at least
``CURVATURE_ELEMENTS`` per full circle of the curvature radius) and refined around given
discs (suction cups), the size growing by ``GROWTH`` of the distance, as the built-in parts
are.

gmsh is imported where a CAD file is read: its library needs X11 and OpenGL system
libraries (libGLU, libXcursor, libXft, libXinerama) that a minimal system may lack, and
``import fem`` must not fail for the parts that do not need it.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np

from fem.iges import iges_units
from fem.mesh_io import CAD_SUFFIXES, SheetMesh, sheet_from_cells
from fem.meshing import GROWTH
from jaxflex.errors import InputError
from jaxflex.isolated import isolated
from jaxflex.stdout import silenced_stdout

CURVATURE_ELEMENTS = 12
_TRIANGLE, _QUAD = 2, 3  # gmsh element types
IGES_SUFFIXES = (".iges", ".igs")
BOX_MARGIN_M = 1e-6  # gmsh's bounding boxes are enlarged by OpenCASCADE's tolerance, 1e-7
_LOCK = threading.Lock()  # gmsh keeps one global state: one session at a time per process


def _gmsh():
    """The gmsh module, or an error saying which system libraries it needs."""
    try:
        import gmsh
    except OSError as exc:  # a shared library of libgmsh is missing
        raise InputError(
            f"cad: gmsh cannot be loaded ({exc}); it needs the system libraries libGLU, "
            "libXcursor, libXft and libXinerama (Debian: apt-get install libglu1-mesa "
            "libxcursor1 libxft2 libxinerama1)"
        ) from exc
    return gmsh


@contextmanager
def _session() -> Iterator[object]:
    """A gmsh model of our own (gmsh keeps global state: a caller's session is left as is);
    yields the gmsh module."""
    gmsh = _gmsh()
    with _LOCK:
        own = not gmsh.isInitialized()
        if own:
            gmsh.initialize(readConfigFiles=False, interruptible=False)
        previous = gmsh.model.getCurrent() if not own else None
        gmsh.model.add("jaxflex-cad")
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.option.setString("Geometry.OCCTargetUnit", "M")
            yield gmsh
        finally:
            gmsh.model.remove()
            if own:
                gmsh.finalize()
            elif previous:
                gmsh.model.setCurrent(previous)


def _import(gmsh, path: str | os.PathLike, scale: float) -> None:
    if not os.path.isfile(path):
        raise InputError(f"cad: file {str(path)!r} does not exist")
    if Path(path).suffix.lower() not in CAD_SUFFIXES:
        raise InputError(
            f"cad: {str(path)!r} is not a CAD file ({', '.join(CAD_SUFFIXES)}); mesh files go "
            "through read_mesh / --mesh"
        )
    iges = iges_units(path) if Path(path).suffix.lower() in IGES_SUFFIXES else None
    quiet = silenced_stdout() if iges is not None else nullcontext()  # IGES reader's counts
    try:
        with quiet:
            if iges is not None:  # the first import initialises gmsh's IGES translator
                gmsh.option.setString("Geometry.OCCTargetUnit", "")
                gmsh.model.occ.remove(gmsh.model.occ.importShapes(str(path)), recursive=True)
                gmsh.option.setString("Geometry.OCCTargetUnit", "M")
            entities = gmsh.model.occ.importShapes(str(path))
    except Exception as exc:  # gmsh raises a plain Exception with the kernel's message
        raise InputError(f"cad: cannot read {str(path)!r} ({exc})") from exc
    if iges is not None:
        _check_iges_extent(gmsh, entities, iges, path)
        scale = scale / iges.model_scale
    if scale != 1.0:
        gmsh.model.occ.dilate(entities, 0, 0, 0, scale, scale, scale)
    gmsh.model.occ.synchronize()
    volumes = gmsh.model.getEntities(3)
    if not volumes:  # faces that touch share their edges: one continuous mesh
        gmsh.model.occ.removeAllDuplicates()
        gmsh.model.occ.synchronize()
    if volumes:
        raise InputError(
            f"cad: {str(path)!r} holds a solid body ({len(volumes)} volume(s)); export the "
            "sheet's mid-surface as a surface (sheet) body instead (CAD tools call it "
            "mid-surface, sheet body or surface body), as STEP, IGES or BREP"
        )
    if not gmsh.model.getEntities(2):
        raise InputError(f"cad: {str(path)!r} holds no surface (a sheet body is required)")


def _check_iges_extent(gmsh, entities, iges, path) -> None:
    """The coordinates read (m) must lie within the largest coordinate the IGES file states
    (global parameter 20, in its unit; 0: not stated) and the tolerance it gives."""
    if iges.max_coordinate <= 0:
        return
    gmsh.model.occ.synchronize()
    box = np.array(gmsh.model.getBoundingBox(-1, -1))
    stated_m = (iges.max_coordinate + iges.resolution) * iges.metres_per_unit
    if np.abs(box).max() > stated_m * (1 + 1e-6) + BOX_MARGIN_M:
        raise InputError(
            f"cad: {str(path)!r} was read with coordinates up to {np.abs(box).max():.6g} m, "
            f"but the file states {iges.max_coordinate:g} {iges.unit} as its largest "
            "coordinate; the unit conversion failed (re-export it as STEP)"
        )


def _refine(gmsh, mesh_size_m: float, discs: Sequence[tuple[np.ndarray, float, float]]) -> None:
    """Background size field: ``mesh_size_m`` away from the discs (centre (3,) m, radius m,
    element size m inside), graded linearly by GROWTH of the distance."""
    if not discs:
        return
    balls = []
    for centre, radius, fine in discs:
        ball = gmsh.model.mesh.field.add("Ball")
        for name, value in zip(("XCenter", "YCenter", "ZCenter"), centre, strict=True):
            gmsh.model.mesh.field.setNumber(ball, name, float(value))
        gmsh.model.mesh.field.setNumber(ball, "Radius", float(radius))
        gmsh.model.mesh.field.setNumber(ball, "VIn", float(fine))
        gmsh.model.mesh.field.setNumber(ball, "VOut", float(mesh_size_m))
        gmsh.model.mesh.field.setNumber(
            ball, "Thickness", float(max(mesh_size_m - fine, 0.0) / GROWTH)
        )
        balls.append(ball)
    smallest = gmsh.model.mesh.field.add("Min")
    gmsh.model.mesh.field.setNumbers(smallest, "FieldsList", balls)
    gmsh.model.mesh.field.setAsBackgroundMesh(smallest)


def cad_unit(path: str | os.PathLike) -> str:
    """What the file says about its length unit, in words."""
    suffix = Path(path).suffix.lower()
    if suffix in IGES_SUFFIXES:
        return iges_units(path).describe() + ", converted to m"
    if suffix == ".brep":
        return "BREP states no unit: coordinates taken as m"
    return "STEP unit converted to m by OpenCASCADE"


@isolated("cad", "gmsh")
def cad_bounds(path: str | os.PathLike, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Lower and upper corners (3,) of the bounding box of a CAD file's sheet body, m, and
    its area, m^2."""
    with _session() as gmsh:
        _import(gmsh, path, scale)
        box = np.array(gmsh.model.getBoundingBox(-1, -1))
        area = sum(gmsh.model.occ.getMass(2, tag) for _, tag in gmsh.model.getEntities(2))
    return box[:3], box[3:], float(area)


@isolated("cad", "gmsh")
def mesh_cad(
    path: str | os.PathLike,
    mesh_size_m: float,
    *,
    scale: float = 1.0,
    discs: Sequence[tuple[np.ndarray, float, float]] = (),
    quads: bool = False,
) -> SheetMesh:
    """Mesh the sheet body of a CAD file (see the module): a SheetMesh of triangles (or
    quadrilaterals with ``quads``), element size ``mesh_size_m`` m, refined in ``discs``
    ((centre (3,) m, radius m, element size m) each)."""
    with _session() as gmsh:
        _import(gmsh, path, scale)
        gmsh.option.setNumber("Mesh.MeshSizeMax", float(mesh_size_m))
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", CURVATURE_ELEMENTS)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
        gmsh.option.setNumber("Mesh.RecombineAll", 1 if quads else 0)
        if quads:
            gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)  # Blossom
            gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)  # all quadrilaterals
        _refine(gmsh, mesh_size_m, discs)
        try:
            gmsh.model.mesh.generate(2)
        except Exception as exc:
            raise InputError(f"cad: gmsh could not mesh {str(path)!r} ({exc})") from exc
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(tags.size)
        blocks = []
        for kind, name, count in ((_TRIANGLE, "triangle", 3), (_QUAD, "quad", 4)):
            _, nodes = gmsh.model.mesh.getElementsByType(kind)
            if nodes.size:
                blocks.append((name, index[nodes.astype(np.int64)].reshape(-1, count)))
    if not blocks:
        raise InputError(f"cad: gmsh made no surface element of {str(path)!r}")
    return sheet_from_cells(coords.reshape(-1, 3), blocks, str(path))
