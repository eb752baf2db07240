"""The finite-element formulations (Morley/Argyris plate, flat-facet shell, thin solid, 12-DOF
beam) and their block assembly. No module here reads another tool's files."""
