"""The ``jaxflex`` command: a thin dispatcher, and the options several commands share.

Each package contributes its own subcommands through the entry-point group
``jaxflex.commands`` (pyproject.toml), so the core never imports the packages built on it::

    [project.entry-points."jaxflex.commands"]
    model = "fem.cli"

A command module defines ``COMMAND`` (its name, the entry point's), ``HELP`` (one line) and
``ORDER`` (its place in the list) as plain literals, ``add_arguments(parser)`` and
``run(args) -> exit status``.

Only the module of the command being run is imported, and it imports nothing heavy (the
packages import their names on first use, jaxflex.lazy; a command module imports the work in
its ``run`` after checking its options and files), so ``--version``, ``--help`` and argument
errors answer without JAX, SciPy or scikit-fem; the list that ``jaxflex --help`` prints is
read from the literals in each command module's source, without running it. Every command
runs with JAX's persistent compilation cache (jaxflex._compile_cache), set up as JAX is
imported.
"""

from __future__ import annotations

import argparse
import ast
import gc
import importlib
import importlib.util
import os
import signal
import sys
import threading
import warnings
from dataclasses import dataclass
from importlib.metadata import entry_points, version
from pathlib import Path

from jaxflex import _compile_cache as compile_cache
from jaxflex._budget import DEFAULT_TIME_S, make_budget, use_budget
from jaxflex._option_style import command_options, in_option_style
from jaxflex._progress import set_quiet, step
from jaxflex._scalars import check_positive
from jaxflex._undo import whole_or_absent
from jaxflex.errors import InputError, JaxflexError, JaxflexWarning
from jaxflex.lazy import after_import

# the command plugin interface (public): what a subcommand's module may use
__all__ = ["AXIS_LIMITS", "add_axis_limits", "axis_limit_values", "main"]
GROUP = "jaxflex.commands"
DESCRIPTION = (
    "Cycle time of robot transfers of thin, vibrating sheet-metal parts. "
    "All quantities in SI units (m, s, kg, Pa)."
)

# (option, unit, default): per-axis limits of a jerk-limited move (`model --tolerance`, `optimize`)
AXIS_LIMITS = (("vmax", "m/s", 2.0), ("amax", "m/s^2", 10.0), ("jmax", "m/s^3", 100.0))


@dataclass(frozen=True)
class Command:
    """A registered subcommand: its name, help line and place in the list, and its module."""

    name: str
    help: str
    order: int
    module: str


def _literals(module: str) -> dict[str, object]:
    """The top-level ``NAME = literal`` assignments of a module, read from its source file
    without importing it (nor its package)."""
    top, *inner = module.split(".")
    package_dir = Path(importlib.util.find_spec(top).origin).parent
    path = package_dir.joinpath(*inner).with_suffix(".py")
    found = {}
    for node in ast.parse(path.read_text(encoding="utf-8"), filename=str(path)).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target = node.targets[0]
            if isinstance(target, ast.Name) and isinstance(node.value, ast.Constant):
                found[target.id] = node.value.value
    return found


def commands() -> list[Command]:
    """Every registered subcommand, in the order of the help (ORDER, then name)."""
    found = []
    for point in entry_points(group=GROUP):
        literals = _literals(point.module)
        found.append(
            Command(literals["COMMAND"], literals["HELP"], literals["ORDER"], point.module)
        )
    return sorted(found, key=lambda command: (command.order, command.name))


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of ``jaxflex``; ``command``'s module is imported and adds its arguments (the
    other subcommands are listed only)."""
    parser = argparse.ArgumentParser(prog="jaxflex", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"jaxflex {version('jaxflex')}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for listed in commands():
        cmd = sub.add_parser(listed.name, help=listed.help, description=listed.help)
        cmd.add_argument(
            "-q",
            "--quiet",
            action="store_true",
            help="no progress display and no step lines on stderr (results and warnings "
            "are still printed)",
        )
        add_budget_arguments(cmd)
        if listed.name == command:
            module = importlib.import_module(listed.module)
            module.add_arguments(cmd)
            cmd.set_defaults(_run=module.run)
    return parser


# Ctrl-C raises KeyboardInterrupt wherever Python is; inside a garbage-collector callback
# (JAX registers one) it is printed and dropped, and the command would run on. Until the
# interrupt is handled, it is delivered again after this many seconds.
INTERRUPT_REPEAT_S = 0.2


class _Interrupts:
    """SIGINT as KeyboardInterrupt, repeated until :meth:`handled`; ignored after that."""

    def __init__(self) -> None:
        self.pending = False
        self.active = True
        self.lock = threading.Lock()

    def __call__(self, signum, frame) -> None:
        if not self.active:
            return
        self.pending = True
        timer = threading.Timer(INTERRUPT_REPEAT_S, self._again)
        timer.daemon = True
        timer.start()
        raise KeyboardInterrupt

    def _again(self) -> None:
        with self.lock:
            if self.active and self.pending:
                os.kill(os.getpid(), signal.SIGINT)

    def handled(self) -> None:
        with self.lock:
            self.active = False


def console() -> None:
    """The installed ``jaxflex`` command and ``python -m jaxflex``: :func:`main` on the
    process's arguments, collecting less garbage (:func:`_collect_less`), then exit with its
    status."""
    _collect_less()
    status = main()
    gc.freeze()  # the interpreter's last collection at exit would walk every object again
    sys.exit(status)


# Python's cyclic garbage collector walks every object the process holds at each full
# collection and once more at exit. The imports of JAX and matplotlib leave some 10^5
# objects that live as long as the process: a second `jaxflex optimize` of the plate spent
# 0.10 s of CPU in three full collections during its work and 0.15 s at its exit. Frozen
# (gc.freeze) right after each import and before exit, they are never walked again (nor
# freed before exit, which they would not be anyway): 2.71 -> 2.31 s (medians of 8,
# interleaved). Garbage that exists when a freeze comes is kept to the end, once: a command
# runs once per process.
FROZEN_AFTER = ("jax", "matplotlib.pyplot")


def _collect_less() -> None:
    """Freeze the garbage collector's objects after each import of FROZEN_AFTER (a command's
    process only: a test calling :func:`main` keeps its collector as it is)."""
    for name in FROZEN_AFTER:
        after_import(name, lambda _module: gc.freeze())


def main(argv: list[str] | None = None) -> int:
    """The ``jaxflex`` command (module docstring); returns the exit status."""
    try:
        return _main(sys.argv[1:] if argv is None else list(argv))
    except BrokenPipeError:  # the reader went away (`jaxflex ... | head`): stop quietly
        _silence_stdout()
        return 141  # as if killed by SIGPIPE, like other command-line tools


# OpenBLAS's worker threads spin between the calls that woke them. The commands' BLAS work (small
# products around JAX's programs, HiGHS, sparse and ARPACK solves) gains no wall time from
# them, and the spinning costs CPU that a loaded machine needs elsewhere. Measured on 2 cores,
# with threads -> one thread: a second `jaxflex optimize` of the plate 3.4 -> 2.8 s of CPU,
# `jaxflex demo` 17.0 -> 14.3 s, `jaxflex model --scene plate --tolerance 2%` 51.6 -> 46.0 s,
# the same wall time each. A value the user set is kept; children inherit it.
BLAS_THREADS_VAR = "OPENBLAS_NUM_THREADS"


def _one_blas_thread() -> None:
    """One OpenBLAS thread for this process and its children, unless the user chose (the
    library reads the variable when NumPy loads it: a process that has loaded NumPy, such as
    a test calling :func:`main`, keeps its threads)."""
    if "numpy" not in sys.modules:
        os.environ.setdefault(BLAS_THREADS_VAR, "1")


def _main(argv: list[str]) -> int:
    _one_blas_thread()
    # jaxflex itself takes no option but --help and --version: the first other word names the
    # command
    chosen = next((arg for arg in argv if not arg.startswith("-")), None)
    parser = build_parser(chosen)
    args = parser.parse_args(argv)
    set_quiet(args.quiet)
    cache_dir, cache_note = compile_cache.enable()
    if cache_dir is None and cache_note.startswith("off:"):
        step(f"compilation cache {cache_note}; compiling every program")
    try:
        _refuse_empty(args)
        budget = make_budget(args.max_memory, args.max_time)
    except JaxflexError as exc:
        return _error(parser, args.command, exc)
    interrupts = _Interrupts()
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, interrupts) if main_thread else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", JaxflexWarning)
            options = command_options(parser, args.command)
            warnings.showwarning = _warning_printer(args.command, options, warnings.showwarning)
            with use_budget(budget), whole_or_absent():  # a failure undoes the outputs
                return int(args._run(args) or 0)
    except JaxflexError as exc:
        return _error(parser, args.command, exc)
    except BrokenPipeError:
        raise  # main: the reader went away
    except OSError as exc:  # the system refused a file operation: disk full, permissions
        print(f"jaxflex {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        interrupts.handled()
        print(f"jaxflex {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        interrupts.handled()
        if main_thread:
            signal.signal(signal.SIGINT, previous)


def _error(parser: argparse.ArgumentParser, command: str, exc: JaxflexError) -> int:
    """Print a refusal as one line, led by the option the user typed (jaxflex._option_style)."""
    message = in_option_style(str(exc), command_options(parser, command))
    print(f"jaxflex {command}: error: {message}", file=sys.stderr)
    return 2


def _refuse_empty(args: argparse.Namespace) -> None:
    """InputError for an option given an empty text (a path "" would mean the current
    directory, or nothing, and be taken for not given)."""
    for name, value in vars(args).items():
        values = value if isinstance(value, list) else [value]
        if any(isinstance(v, str) and not v.strip() for v in values):
            option = name if name in ("model", "spec") else f"--{name.replace('_', '-')}"
            raise InputError(f"{option}: an empty value")


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's last flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout without a file descriptor
        pass


def _warning_printer(command: str, options: dict[str, str], fallback):
    """``warnings.showwarning`` that prints a JaxflexWarning as one line on stderr, like the
    errors (``jaxflex COMMAND: warning: --option (field): ...``), and leaves other warnings
    to ``fallback``."""

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, JaxflexWarning):
            text = in_option_style(str(message), options)
            print(f"jaxflex {command}: warning: {text}", file=sys.stderr, flush=True)
        else:
            fallback(message, category, filename, lineno, file, line)

    return show


def add_budget_arguments(parser: argparse.ArgumentParser) -> None:
    """--max-memory and --max-time, the budget of every command (jaxflex._budget)."""
    parser.add_argument(
        "--max-memory",
        type=float,
        default=None,
        metavar="GB",
        help="budget: memory the command may use, GB (default: half of what this machine and "
        "its limits allow); work that would need more is refused before it starts",
    )
    parser.add_argument(
        "--max-time",
        type=float,
        default=None,
        metavar="S",
        help=f"budget: wall time the command may take, s (default {DEFAULT_TIME_S:g}); work "
        "estimated to take longer is refused before it starts",
    )


def add_axis_limits(parser, *, with_defaults: bool, condition: str = "") -> None:
    """--vmax/--amax/--jmax, each one value or three (x y z). ``with_defaults`` False leaves
    them None when not given (:func:`axis_limit_values` applies AXIS_LIMITS' defaults);
    ``condition`` prefixes the help text (e.g. "--distance: ")."""
    for name, unit, default in AXIS_LIMITS:
        parser.add_argument(
            f"--{name}",
            nargs="+",
            type=float,
            default=[default] if with_defaults else None,
            metavar="V",
            help=f"{condition}per-axis limit in {unit}: one value or three (x y z); "
            f"default {default:g}",
        )


def axis_limit_values(args: argparse.Namespace) -> dict[str, float | list[float]]:
    """vmax, amax, jmax from the options of :func:`add_axis_limits`: one value for every axis
    or three (x, y, z), each finite and > 0; AXIS_LIMITS' default where an option was not
    given."""
    limits = {}
    for name, _unit, default in AXIS_LIMITS:
        given = getattr(args, name)
        if given is not None and len(given) not in (1, 3):
            raise InputError(f"--{name}: give one value or three (x y z), got {len(given)}")
        for axis, value in zip("xyz", given or (), strict=False):
            check_positive(f"--{name}[{axis}]", value)
        limits[name] = default if given is None else (given[0] if len(given) == 1 else given)
    return limits


if __name__ == "__main__":
    sys.exit(main())
