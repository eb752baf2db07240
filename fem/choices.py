"""What fem offers by name, for the command line's options and help before any finite-element
module loads (light: no imports): the formulations, the mesh and CAD file kinds and the kinds of
the files jaxflex model writes beside its model.
fem.parts and fem.mesh.mesh_io re-export them."""

from __future__ import annotations

PLATE_ELEMENTS = ("morley", "argyris")  # Kirchhoff plates (flat parts)
ELEMENTS = (*PLATE_ELEMENTS, "shell", "hex2")
CAD_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep")
VIEW_SUFFIXES = (".vtu", ".vtk", ".xdmf", ".xmf")  # mode shapes for ParaView (fem.export)
PICTURE_SUFFIXES = (".png",)  # the part's picture (fem.export.plot_part writes PNG)
FORMATS_HELP = (
    "meshio formats: gmsh .msh, .vtu/.vtk, .xdmf, .stl, .obj, .ply, .off, Abaqus .inp, "
    "Nastran .bdf/.nas, ANSYS .ans, .med, .mesh, ... with cells tri3, tri6, tri7, quad4, "
    "quad8, quad9 (any mix, any number of blocks) or one layer of hexahedra"
)
