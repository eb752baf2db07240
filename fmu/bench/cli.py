"""``jaxflex bench``: speed and accuracy of every method as JSON plus PNG charts."""

from __future__ import annotations

import argparse
from pathlib import Path

from jaxflex.files import check_output_dir
from jaxflex.runtime import step

COMMAND = "bench"
HELP = "speed and accuracy figures of every method as JSON + charts (SI units)"
ORDER = 90


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--output",
        default="jaxflex_bench",
        metavar="DIR|JSON",
        help="directory for bench.json and the PNG charts (default jaxflex_bench); a path "
        "ending in .json names the JSON file itself, the charts go next to it",
    )
    size = parser.add_mutually_exclusive_group()
    size.add_argument(
        "--quick",
        action="store_true",
        help="CI size: small scenes, few sweep points, core case K=200 M=10 N=200 (about 45 s "
        "of CPU time; longer on a loaded machine)",
    )
    size.add_argument(
        "--size",
        choices=("tiny", "quick", "medium", "full"),
        default="full",
        help="full (default): the built-in scenes, several minutes; medium: small scenes with "
        "the full sweeps; tiny: the small plate only",
    )


def run(args: argparse.Namespace) -> int:
    size = "quick" if args.quick else args.size
    out = Path(args.output)
    json_path = out if out.suffix == ".json" else None
    out_dir = out.parent if json_path is not None else out
    check_output_dir("-o/--output", out_dir)
    from fem.bench.core import format_table  # the benchmarks load at the run
    from fmu.bench.suite import run_suite, summary_lines

    report = run_suite(
        out_dir,
        size,
        progress=step,
        json_path=json_path,
    )
    print(format_table(report))
    print("\n".join(summary_lines(report)))
    charts = ", ".join(report["charts"].values())
    print(f"wrote {report['json_path']} and charts {charts} in {out_dir}")
    return 0
