"""One style for the command's errors and warnings: ``--option (field): what, got X``
(jaxflex._option_style): the option the user typed leads, the field the Python interface
checks follows. Checked against the parser's own option table and through the command."""

from __future__ import annotations

import string

from conftest import random_model
from hypothesis import given
from hypothesis import strategies as st

from jaxflex._option_style import UNIT_SUFFIXES, command_options, in_option_style
from jaxflex.cli import build_parser, main

OPTIONS = {"threshold": "--threshold", "n_modes": "--n-modes", "max_memory": "--max-memory"}


def test_the_field_is_led_by_the_option_that_sets_it():
    assert in_option_style("threshold_m: must be > 0, got -1", OPTIONS) == (
        "--threshold (threshold_m): must be > 0, got -1"
    )
    assert in_option_style("n_modes: must be >= 1, got 0", OPTIONS) == (
        "--n-modes (n_modes): must be >= 1, got 0"
    )
    assert in_option_style("max_memory_bytes: too small", OPTIONS).startswith("--max-memory (")


def test_the_older_order_is_turned_round():
    text = "mesh_size (--mesh-size): 1e+300 m for a part 1.7 m across"
    assert in_option_style(text, {}) == "--mesh-size (mesh_size): 1e+300 m for a part 1.7 m across"
    text = "axis (--rotate AXIS ANGLE_DEG): 'x', 'y', 'z', got 'w'"
    assert in_option_style(text, {}) == "--rotate AXIS ANGLE_DEG (axis): 'x', 'y', 'z', got 'w'"


@given(st.text(alphabet=string.printable, max_size=60))
def test_a_message_no_option_sets_is_left_alone(rest):
    for message in (f"deck: {rest}", f"moves[0].vmax: {rest}", f"--cell: {rest}"):
        assert in_option_style(message, OPTIONS) == message


@given(st.sampled_from(UNIT_SUFFIXES), st.text(alphabet=string.printable, max_size=40))
def test_every_unit_suffix_finds_its_option(suffix, rest):
    options = {"clearance": "--clearance"}
    assert in_option_style(f"clearance{suffix}: {rest}", options) == (
        f"--clearance (clearance{suffix}): {rest}"
    )


def test_the_option_table_is_the_running_commands():
    options = command_options(build_parser("optimize"), "optimize")
    assert options["threshold"] == "--threshold" and options["max_memory"] == "--max-memory"
    assert "n_modes" not in options  # an option of `jaxflex model`, not of `optimize`


def test_the_command_prints_the_option_first(tmp_path, capsys):
    path = tmp_path / "m.npz"
    random_model().save(path)
    for args, lead in (
        (["--threshold", "-1"], "--threshold (threshold_m): "),
        (["--threshold", "5e-4", "--dt", "0"], "--dt (dt_s): "),
        (["--threshold", "5e-4", "--max-duration", "-3"], "--max-duration (max_duration_s): "),
    ):
        out = str(tmp_path / "o")
        argv = ["optimize", str(path), "--distance", "0", "0", "1", *args, "-o", out]
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith(f"jaxflex optimize: error: {lead}"), err
