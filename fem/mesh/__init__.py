"""The meshes a part is analysed on: built-in meshing (refined at the cups, rims followed),
mesh files, CAD sheets and the cost plan of a mesh's analysis."""
