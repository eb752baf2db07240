"""``jaxflex sweep``: every gripper layout of a spec file with every move, on dask or serially."""

from __future__ import annotations

import argparse
import sys

from jaxflex.errors import InputError
from jaxflex.files import check_input_file, check_output_dir, read_settings_file
from jaxflex.runtime import step

COMMAND = "sweep"
HELP = "gripper-layout sweep from a JSON/TOML spec: FE + optimised cycle time per case (SI units)"
ORDER = 25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "spec", nargs="?", help="sweep specification (.json or .toml; see --example)"
    )
    parser.add_argument("-o", "--output", metavar="DIR", help="results directory (restartable)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--serial", action="store_true", help="compute in this process, no dask (reference)"
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="use the dask.distributed cluster at ADDRESS (tcp://host:8786) instead of an "
        "embedded LocalCluster",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the embedded LocalCluster (default: one per core)",
    )
    parser.add_argument(
        "--dashboard",
        metavar="HOST:PORT",
        default=None,
        help="where the embedded LocalCluster serves its dashboard (default: 127.0.0.1 and a "
        "free port, this machine only; e.g. 0.0.0.0:8787 for other machines)",
    )
    parser.add_argument(
        "--retry-errors",
        action="store_true",
        help="recompute cases stored as errors (results are always kept)",
    )
    parser.add_argument("--no-plots", action="store_true", help="write the table only")
    parser.add_argument(
        "--example", action="store_true", help="print an example spec (TOML) and exit"
    )


def run(args: argparse.Namespace) -> int:
    if args.example:
        from optim.sweep.spec import EXAMPLE

        print(EXAMPLE, end="")
        return 0
    if not args.spec or not args.output:
        raise InputError("spec and -o/--output are required (or --example for a spec to start)")
    for option, value in (("--workers", args.workers), ("--dashboard", args.dashboard)):
        if value is not None and (args.serial or args.scheduler):
            raise InputError(
                f"{option}: only for the embedded LocalCluster (not with --serial/--scheduler)"
            )
    check_output_dir("-o/--output", args.output)
    check_input_file("spec", args.spec)
    table = read_settings_file("spec", args.spec)  # syntax errors before the sweep loads
    from optim.sweep.run import Executor, run_sweep
    from optim.sweep.spec import load_spec

    spec = load_spec(args.spec, table)

    executor = Executor(
        "serial" if args.serial else "dask",
        n_workers=args.workers,
        scheduler=args.scheduler,
        dashboard_address=args.dashboard,
    )
    where = args.scheduler or ("this process" if args.serial else "a local dask cluster")
    step(
        f"{args.spec}: {len(spec.layouts)} layouts x {len(spec.moves)} moves on {where}; "
        f"results in {args.output}"
    )
    result = run_sweep(
        spec,
        args.output,
        executor=executor,
        retry_errors=args.retry_errors,
        plots=not args.no_plots,
    )
    print(result.summary())
    for path in result.outputs:
        print(f"wrote {path}")
    return _status(result)


def _status(result) -> int:
    """0, or 1 when every case of the spec is stored as an error (with the first error)."""
    ok = result.records.count("ok")
    if ok or not result.n_errors:
        return 0
    first = next(r for r in result.rows if r["status"] == "error")
    print(
        f"jaxflex sweep: every case failed ({result.n_errors} errors); the first, "
        f"{first['layout']} / {first['move']}: {first['error']}",
        file=sys.stderr,
    )
    return 1
