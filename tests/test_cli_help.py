"""The commands' help reads as the code is built: options in groups that match the
``_add_*`` sections of their modules, and every option that takes a physical quantity
shows its unit as its metavar (M, S, HZ, PA, GB ...), not the option's name in capitals."""

from __future__ import annotations

import argparse
import re

import pytest

from jaxflex.cli import build_parser

# options whose values have no unit (ratios, counts, names, factors) or several units
# (per-axis lists V; positions X Y Z in m are named by axis); each is checked by its own
# test of the command's input checks
UNITLESS = {
    "--nu", "--zeta", "--scale", "--material", "--element", "--points", "--tolerance",
    "--cup-safety", "--cup-friction", "--freq-scale", "--grid", "--solver", "--method",
    "--units", "--spc-id", "--axis", "--cup-stiffness", "--report", "--key-points",
    "--mesh-sizes", "--scene", "--clamped-edges", "--page-points", "--page-frames", "--fmi",
    "--scale-deformation", "--damping-scale",
}  # fmt: skip


def _subparser(command: str) -> argparse.ArgumentParser:
    parser = build_parser(command)
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sub.choices[command]


def _groups(parser: argparse.ArgumentParser) -> dict[str, set[str]]:
    return {
        group.title: {s for a in group._group_actions for s in a.option_strings}
        for group in parser._action_groups
    }


@pytest.mark.parametrize(
    "command, expected",
    [
        (
            "model",
            {
                "the part's source (one of)": {"--scene", "--mesh", "--cad", "--from-nastran"},
                "the sheet and its material": {"--thickness", "--E", "--mesh-size"},
                "the gripper and supports": {"--cups", "--cup-stiffness", "--allow-rigid-modes"},
                "modes and monitored points": {"--n-modes", "--max-freq", "--zeta", "--points"},
                "outputs": {"-o", "--plot", "--vtu"},
            },
        ),
        (
            "optimize",
            {
                "the move, the robot's limits, the threshold": {"--distance", "--threshold"},
                "the robot cell and its constraints": {"--cell", "--min-distance"},
                "the search": {"--method", "--clearance"},
                "robust mode": {"--robust", "--grid"},
                "the search's budget": {"--max-duration", "--max-steps"},
                "outputs": {"-o", "--no-plots", "--animate"},
            },
        ),
    ],
)
def test_options_are_grouped_as_the_code_adds_them(command, expected):
    groups = _groups(_subparser(command))
    for title, options in expected.items():
        assert title in groups, (command, title, sorted(groups))
        assert options <= groups[title], (command, title, options - groups[title])


@pytest.mark.parametrize("command", ["model", "optimize", "export", "sweep", "animate"])
def test_quantities_show_their_units(command):
    parser = _subparser(command)
    nameless = [
        action.option_strings[-1]
        for action in parser._actions
        if action.option_strings
        and action.type is float
        and action.metavar is None
        and action.option_strings[-1] not in UNITLESS
    ]
    assert nameless == [], f"{command}: float options without a unit metavar: {nameless}"


@pytest.mark.parametrize(
    "command", ["model", "optimize", "export", "sweep", "animate", "demo", "bench"]
)
def test_every_value_says_what_it_takes(command):
    """An option that takes a value shows what it takes (a unit, N, FILE, DIR, FACTOR, NAME,
    or its choices), never argparse's default, the option's name in capitals; S stands for
    seconds only (a safety factor is FACTOR)."""
    parser = _subparser(command)
    takes = [a for a in parser._actions if a.option_strings and a.nargs != 0]
    default_named = [a.option_strings[-1] for a in takes if a.choices is None and a.metavar is None]
    assert default_named == [], f"{command}: options shown by their own name: {default_named}"
    # every S option's help states its unit: "..., s (default ...)" or "... in s"
    not_seconds = [
        a.option_strings[-1]
        for a in takes
        if a.metavar == "S" and not re.search(r"(, | in )s\b", a.help or "")
    ]
    assert not_seconds == [], f"{command}: S shown for a value that is not in seconds"
