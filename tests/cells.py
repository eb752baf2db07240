"""Cells the tests share (no data files).

* :func:`press_cell`: a press opening for a 0.6 x 0.4 m plate picked at z = 0.1 m and laid
  into a press whose opening (between the lower die, top at 0.3 m, and the upper die, bottom
  at 0.55 m) starts at x = 1.2 m; a straight move hits the lower die's front, the via point
  lifts the part over it; :data:`PRESS_TOML`, the same as a cell file.
"""

from __future__ import annotations

from jaxflex.geometry import Box, Cell, HalfSpace, Via

# press_cell() as a cell file (optim.cell_file)
PRESS_TOML = """
[part]
start_m = [0.0, -0.2, 0.1]
[path]
end_m = [1.6, -0.2, 0.4]
via = [{ position_m = [0.45, -0.2, 0.425], mode = "blend", tolerance_m = 0.2 }]
[[obstacles]]
type = "box"
name = "lower die"
centre_m = [1.9, 0.0, 0.15]
size_m = [1.4, 1.2, 0.3]
[[obstacles]]
type = "box"
name = "upper die"
centre_m = [1.9, 0.0, 0.8]
size_m = [1.4, 1.2, 0.5]
[[obstacles]]
type = "half_space"
name = "floor"
normal = [0.0, 0.0, 1.0]
offset_m = 0.0
"""


def press_cell(via_mode: str = "blend") -> Cell:
    """The press-opening scene (module docstring); the via point blended within 0.2 m, or
    a stop (``via_mode`` "stop")."""
    via = (
        Via([0.45, -0.2, 0.425], "blend", 0.2)
        if via_mode == "blend"
        else Via([0.45, -0.2, 0.425], "stop")
    )
    return Cell(
        obstacles=(
            Box([1.9, 0.0, 0.15], [1.4, 1.2, 0.3], name="lower die"),
            Box([1.9, 0.0, 0.8], [1.4, 1.2, 0.5], name="upper die"),
            HalfSpace([0, 0, 1], 0.0, "floor"),
        ),
        start_m=[0.0, -0.2, 0.1],
        end_m=[1.6, -0.2, 0.4],
        via=(via,),
    )
