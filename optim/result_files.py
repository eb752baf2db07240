"""The files of an optimisation's result set and of its animation, and their checks before
any work (light: no JAX, no model), so that ``jaxflex optimize`` and ``jaxflex animate``
refuse an output in the way before the optimiser or the engine loads.

optim.result, optim.animate, optim.animate_series and optim.animate_page re-export them.
"""

from __future__ import annotations

import os
from pathlib import Path

from jaxflex.files import check_set_dir

RESULT_KIND = "jaxflex.optimize"
RESULT_FILES = (
    "trajectory.csv",
    "report.json",
    "profiles.png",
    "deviation.png",
    "constraints.png",
    "robust.png",
    "deviation_worst_case.png",
    "turn.png",
)
ANIMATION_DIR = "animation"  # optim.animate's set, beside the result's files
SERIES = "part.xdmf"  # the ParaView series (optim.animate_series) over the HDF5 file
SERIES_DATA = "part.h5"
OLD = ("part.pvd",)  # the series' collection before part.xdmf (over part_NNNN.vtu)
CELL_FILE = "cell.vtu"
PATH_FILE = "path.vtu"
PAGE = "animation.html"  # the browser page (optim.animate_page)
MAX_VERTICES = 3000  # the default reduction of the page's surface (points drawn)
MAX_FRAMES = 120  # and of its frames


def series_names(directory: Path) -> tuple[str, ...]:
    """Every member an animation set in ``directory`` may have: this one's and the files of
    the series an earlier jaxflex wrote (``part.pvd`` over ``part_NNNN.vtu``; removed, as
    this one does not write them)."""
    old = sorted(p.name for p in directory.glob("part_*.vtu")) if directory.is_dir() else []
    return tuple(dict.fromkeys([SERIES, SERIES_DATA, CELL_FILE, PATH_FILE, PAGE, *OLD, *old]))


def check_animation_dir(option: str, result_dir: str | os.PathLike) -> Path:
    """``result_dir``/animation if an animation may be written there, checked before any
    work (jaxflex.files.check_set_dir: no link, FIFO, device or directory in a member's
    place; a result directory still to be made holds none); InputError naming ``option``
    otherwise."""
    directory = Path(result_dir) / ANIMATION_DIR
    if not Path(result_dir).is_dir():
        return directory
    return check_set_dir(option, directory, series_names(directory))
