"""CAD sheet bodies (STEP, IGES, BREP) meshed with gmsh's OpenCASCADE kernel.

The file must hold surfaces (a sheet body: the part's mid-surface); a solid body is
refused with what to export instead. STEP and IGES state their length unit: OpenCASCADE
converts the coordinates to metres (for IGES, gmsh sets that target unit only once its IGES
translator has been initialised by a first import: an IGES is read once, dropped and read
again; the unit and the model space scale of its global section are read here, fem.mesh.iges, and
the scale applied; the largest coordinate the file states is a plausibility hint only,
:func:`iges_extent_warning`: Rhino writes it in inches in a millimetre file, B-spline boxes
exceed it by 0.05-0.5 %); BREP has none (its coordinates are taken as metres); ``scale``
multiplies after that. A file that was cut off is refused before the kernel reads it
(fem.mesh.cad_check), and gmsh's errors end the work at once (``General.AbortOnError`` 3: an
exception with gmsh's message, instead of meshing on). Faces that
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
import time
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fem.choices import CAD_SUFFIXES
from fem.mesh.cad_check import check_cad_file
from fem.mesh.iges import IgesUnits, iges_units
from fem.mesh.meshing import GROWTH
from fem.sanity import PartWarning
from jaxflex.errors import InputError
from jaxflex.isolated import isolated
from jaxflex.runtime import step
from jaxflex.stdout import silenced_stdout

if TYPE_CHECKING:  # fem.mesh.mesh_io imports scipy: only the meshing child needs it
    from fem.mesh.mesh_io import SheetMesh

CURVATURE_ELEMENTS = 12
FINEST_PER_SPAN = 1e-5  # a mesh size below this share of the part's diagonal: 1e10 elements
_TRIANGLE, _QUAD = 2, 3  # gmsh element types
IGES_SUFFIXES = (".iges", ".igs")
IGES_EXTENT_RTOL = 0.05  # read extent above the stated largest coordinate: a hint beyond this
IGES_FAR_BELOW = 20.0  # read extent this far below it (gmsh states 1000 for 600): a hint
THROW_ON_ERROR = 3  # gmsh's General.AbortOnError: throw an exception on every error
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
            gmsh.option.setNumber("General.AbortOnError", THROW_ON_ERROR)
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


def iges_extent_warning(path, lo: np.ndarray, hi: np.ndarray, scale: float = 1.0) -> str:
    """A warning (or "") when the coordinates read (bounding box ``lo``, ``hi`` in m, after
    ``scale``) exceed the largest coordinate an IGES file states (global parameter 20; 0:
    not stated) by more than ``IGES_EXTENT_RTOL``, or stay ``IGES_FAR_BELOW`` times below
    it: a hint, never a refusal, since writers fill that field loosely (Rhino in inches in
    a millimetre file, gmsh a round upper bound)."""
    if Path(path).suffix.lower() not in IGES_SUFFIXES:
        return ""
    iges: IgesUnits = iges_units(path)
    if iges.max_coordinate <= 0:
        return ""
    read_m = float(np.max(np.abs(np.concatenate([lo, hi]))))
    stated_m = (iges.max_coordinate + iges.resolution) * iges.metres_per_unit * scale
    stated_m /= iges.model_scale
    ratio = read_m / stated_m
    if 1 / IGES_FAR_BELOW <= ratio <= 1 + IGES_EXTENT_RTOL:  # an upper bound, often loose
        return ""
    inches = " (the inch-to-millimetre ratio: the field was written in inches)"
    return (
        f"{Path(path).name}: the coordinates read reach {read_m:.6g} m, {ratio:.4g} times the "
        f"largest coordinate the file states ({iges.max_coordinate:g} {iges.unit}, global "
        f"parameter 20){inches if abs(ratio / 25.4 - 1) < IGES_EXTENT_RTOL else ''}; the "
        f"unit is taken from the units flag ({iges.describe()}): check the part's size"
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


@isolated("cad", "gmsh", precheck=check_cad_file)
def cad_bounds(path: str | os.PathLike, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Lower and upper corners (3,) of the bounding box of a CAD file's sheet body, m, and
    its area, m^2."""
    with _session() as gmsh:
        _import(gmsh, path, scale)
        box = np.array(gmsh.model.getBoundingBox(-1, -1))
        area = sum(gmsh.model.occ.getMass(2, tag) for _, tag in gmsh.model.getEntities(2))
    return box[:3], box[3:], float(area)


@isolated("cad", "gmsh", precheck=check_cad_file)
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
    from fem.mesh.mesh_io import sheet_from_cells  # scipy: not imported by cad_bounds' child

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


def read_cad_bounds(
    path: str | os.PathLike, scale: float, mesh_size_m: float | None
) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`cad_bounds` with a progress line, ``mesh_size_m`` (None: the default) checked
    against the part's size (larger than its diagonal, or below ``FINEST_PER_SPAN`` of it:
    refused naming mesh_size), and the IGES extent hint issued as a PartWarning."""
    step(f"cad: reading {Path(path).name} (gmsh, OpenCASCADE)")
    tick = time.perf_counter()
    lo, hi, area = cad_bounds(path, scale)
    diagonal = float(np.linalg.norm(hi - lo))
    step(
        f"cad: read in {time.perf_counter() - tick:.1f} s: {diagonal:.4g} m across, {area:.4g} m^2"
    )
    if mesh_size_m is not None and not FINEST_PER_SPAN * diagonal <= mesh_size_m <= diagonal:
        raise InputError(
            f"mesh_size (--mesh-size): {mesh_size_m:g} m for a part {diagonal:.4g} m across; "
            f"allowed {FINEST_PER_SPAN * diagonal:.3g} ... {diagonal:.4g} m (at most the "
            "part's diagonal, at least 1e-5 of it)"
        )
    hint = iges_extent_warning(path, lo, hi, scale)
    if hint:
        warnings.warn(hint, PartWarning, stacklevel=2)
    return lo, hi, area


def meshed(path: str | os.PathLike, mesh_size_m: float, **options) -> SheetMesh:
    """:func:`mesh_cad` (same arguments) with a progress line before and after."""
    step(f"cad: meshing {Path(path).name} with gmsh at {mesh_size_m * 1e3:.4g} mm")
    tick = time.perf_counter()
    mesh = mesh_cad(path, mesh_size_m, **options)
    cells = sum(len(c) for c in (mesh.triangles, mesh.quads))
    step(f"cad: {cells} elements, {len(mesh.nodes)} nodes in {time.perf_counter() - tick:.1f} s")
    return mesh
