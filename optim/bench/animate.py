"""The animation's figures, as JSON: the README's press scene animated (optim.animate).

    python -m optim.bench.animate [-o animate_bench.json] [--repeat 3]

The built-in plate (1.5 x 0.8 m, 20 modes, all 7 854 FE nodes) optimised through
examples/press_cell.toml as the README's command does (10 mm from the dies, cups at safety
1.5, von Mises within yield / 1.5), then animated ``--repeat`` times: the CPU seconds of the
engine's frames, of the ParaView series and of the page (median), the frame and point
counts, the series' (part.xdmf and part.h5) and the page's size. Targets (issue 35): the
page <= 20 MB at the default reduction, writing it <= 10 s of CPU.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
from pathlib import Path

import fem
import optim
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.files import write_text_atomic
from optim.animate import animate
from optim.animate_series import SERIES, SERIES_DATA
from optim.cell_file import load_cell

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PAGE_MB = 20.0
PAGE_CPU_S = 10.0


def press_result():
    """The README's press optimisation (module docstring)."""
    model = fem.default_model("plate", cache=True, progress=False)
    cell = load_cell(EXAMPLES / "press_cell.toml")
    limits = optim.Limits(2.0, 10.0, 100.0)
    return optim.optimize(
        model,
        None,
        limits,
        DT_S,
        THRESHOLD_M,
        search=optim.Search(progress=False),
        constraints=optim.Constraints(
            cell=cell, min_distance_m=0.01, cup_safety=1.5, max_stress_pa="yield"
        ),
    )


def measure(repeat: int) -> dict:
    result = press_result()
    runs = []
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(repeat):
            animation = animate(result, folder)
            series = sum((animation.directory / n).stat().st_size for n in (SERIES, SERIES_DATA))
            runs.append((animation, series))
    animation, series_bytes = runs[-1]
    cpu = {k: statistics.median(a.cpu_s[k] for a, _ in runs) for k in animation.cpu_s}
    page_mb = animation.page_bytes / 1e6
    return {
        "scene": "README press: built-in plate, 7854 nodes, 20 modes, examples/press_cell.toml",
        "cycle_time_s": result.cycle_time_s,
        "frames": len(animation.frames.t_s),
        "points": result.cell.model.n_points,
        "series_mb": series_bytes / 1e6,
        "page_frames": animation.page_frames,
        "page_points": animation.page_points,
        "page_mb": page_mb,
        "cpu_s": cpu,
        "repeat": repeat,
        "targets": {
            "page_mb": {"target": PAGE_MB, "met": page_mb <= PAGE_MB},
            "page_cpu_s": {"target": PAGE_CPU_S, "met": cpu["page"] <= PAGE_CPU_S},
        },
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="animate_bench.json")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    figures = measure(max(1, args.repeat))
    text = json.dumps(figures, indent=2)
    write_text_atomic(args.output, text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
