"""The ``jaxflex`` command line. Each subcommand lives in its own module with
``add_arguments(parser)`` and ``run(args) -> int``; heavy imports happen inside ``run``."""

from __future__ import annotations

import argparse
import importlib
import sys

from jaxflex.errors import JaxflexError

# name -> (module, one-line help)
COMMANDS = {
    "demo": ("jaxflex.cli.demo", "run the whole job on the built-in default part"),
    "bench": ("jaxflex.cli.bench", "speed and accuracy figures as JSON"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="jaxflex",
        description="Cycle time of robot transfers of thin, vibrating sheet-metal parts. "
        "All quantities in SI units (m, s, kg, Pa).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (module, help_text) in COMMANDS.items():
        cmd = sub.add_parser(name, help=help_text, description=help_text)
        importlib.import_module(module).add_arguments(cmd)
        cmd.set_defaults(_module=module)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(importlib.import_module(args._module).run(args) or 0)
    except JaxflexError as exc:
        print(f"jaxflex {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"jaxflex {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
