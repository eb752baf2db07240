"""The ``jaxflex`` command line.

Every module in this package that defines ``COMMAND`` (the subcommand name), ``HELP`` (one
line), ``add_arguments(parser)`` and ``run(args) -> int`` is a subcommand; ``ORDER`` sorts
them in the help. Heavy imports happen inside ``run``, so ``jaxflex --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from jaxflex.errors import JaxflexError


def _command_modules():
    modules = []
    for info in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{info.name}")
        if hasattr(module, "COMMAND") and hasattr(module, "run"):
            modules.append(module)
    return sorted(modules, key=lambda m: (getattr(m, "ORDER", 100), m.COMMAND))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="jaxflex",
        description="Cycle time of robot transfers of thin, vibrating sheet-metal parts. "
        "All quantities in SI units (m, s, kg, Pa).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in _command_modules():
        cmd = sub.add_parser(module.COMMAND, help=module.HELP, description=module.HELP)
        module.add_arguments(cmd)
        cmd.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except JaxflexError as exc:
        print(f"jaxflex {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"jaxflex {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
