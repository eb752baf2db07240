"""The tiny sweep the sweep tests share: its spec (5 layouts, one of them bad, x 2 moves) and
the comparison of results tables between runs.

Tiny meshes (50 mm elements on a 0.6 x 0.4 m plate, 6 modes, 48 monitored points) and
nominal optimisation keep every run at seconds per case on 2 cores.
"""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from optim.sweep.table import RUN_COLUMNS

SPEC = {
    "name": "tiny",
    "part": {"width_m": 0.6, "height_m": 0.4, "mesh_size_m": 0.05},
    "model": {"n_modes": 6, "monitor_grid": [8, 6]},
    "optimization": {"threshold_m": 1e-4},
    "moves": [
        {"name": "up", "distance_m": [0, 0, 0.5]},
        {"name": "side", "distance_m": [0.4, 0, 0.1], "vmax": 1.5},
    ],
    # the third cup lies off the 0.6 m wide part: a layout the FE step must reject
    "layouts": [
        {"name": "off part", "cups": [[0.1, 0.1, 0.03], [0.5, 0.1, 0.03], [0.7, 0.3, 0.03]]}
    ],
    "grids": [
        {
            "name": "rect",
            "nx": [2],
            "ny": [2],
            "inset_x": [0.15, 0.25],
            "inset_y": [0.25],
            "radius_m": [0.03, 0.04],
        }
    ],
}
N_CASES = 10  # 5 layouts x 2 moves


def comparable(rows):
    """Table rows without the columns that differ between runs (wall times, worker)."""
    return [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in rows]


def assert_same_table(rows, reference, rel: float = 0.0):
    """Equal tables: strings and integers equal, floats equal to ``rel`` relative. A rerun
    in the same kind of process gives equal files (``rel = 0``: the FE eigen solve starts
    from a fixed vector, fem.eigen); ``rel`` is for processes configured otherwise."""
    assert len(rows) == len(reference)
    for row, ref in zip(comparable(rows), comparable(reference), strict=True):
        assert row.keys() == ref.keys()
        for key, value in ref.items():
            try:
                expected = float(value)
            except ValueError:
                assert row[key] == value, (ref["index"], key)
                continue
            assert float(row[key]) == pytest.approx(expected, rel=rel, abs=0), (ref["index"], key)


def start_sweep(spec_path, out, *options: str) -> subprocess.Popen:
    """``jaxflex sweep SPEC -o OUT OPTIONS --quiet --no-plots`` in its own process group;
    stderr piped (text)."""
    cmd = [sys.executable, "-m", "jaxflex", "sweep", str(spec_path), "-o", str(out)]
    return subprocess.Popen(
        [*cmd, *options, "--quiet", "--no-plots"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def wait_for_records(proc: subprocess.Popen, cases_dir, count: int, timeout_s: float = 300) -> None:
    """Until ``cases_dir`` holds ``count`` records; fails if the sweep ends or stalls first."""
    deadline = time.monotonic() + timeout_s
    while len(list(cases_dir.glob("*.json"))) < count:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the sweep made no progress"
        time.sleep(0.01)
