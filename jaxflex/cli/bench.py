"""``jaxflex bench``: speed and accuracy figures of the core as a table and JSON."""

from __future__ import annotations

import argparse
import json
import sys

COMMAND = "bench"
HELP = "speed and accuracy figures as JSON"
ORDER = 90


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--output",
        default="jaxflex_bench.json",
        help="JSON file to write (default jaxflex_bench.json)",
    )
    parser.add_argument(
        "--quick", action="store_true", help="small case (K=200, M=10, N=200) for CI"
    )


def run(args: argparse.Namespace) -> int:
    from jaxflex.atomic import write_text_atomic
    from jaxflex.bench import QUICK, BenchCase, format_table, run_bench

    case = QUICK if args.quick else BenchCase()
    report = run_bench(case, progress=lambda msg: print(msg, file=sys.stderr, flush=True))
    print(format_table(report))
    write_text_atomic(args.output, json.dumps(report, indent=2))
    print(f"wrote {args.output}")
    return 0
