"""One style for the command's errors: ``--option (field): what is wrong, got X``.

The checks of the Python interface name the field they check (``threshold_m: must be > 0,
got -1``), as a caller of ``optim.optimize`` or ``fem.modal_analysis`` knows it. On the
command line the user typed an option, not a field: the error printer puts the option that
sets the field in front (``--threshold (threshold_m): must be > 0, got -1``). The option is
found among the running command's arguments: the field itself, or the field without its SI
unit suffix (``threshold_m`` is set by ``--threshold``, ``max_memory_bytes`` by
``--max-memory``). A message whose field no option sets (a field of a file: ``moves[0].vmax``,
``deck: ...``) is left as it is.
"""

from __future__ import annotations

import argparse
import re

# the unit suffixes of field names (docs/design.md, "Names"), longest first
UNIT_SUFFIXES = (
    "_m_s2", "_m_s3", "_m_s", "_bytes", "_hz", "_pa", "_deg", "_rad", "_kg", "_m", "_s",
)  # fmt: skip
_LEAD = re.compile(
    r"(?P<field>[A-Za-z][A-Za-z0-9_]*)(?: \((?P<option>--[a-z0-9-]+(?: [A-Z_]+)*)\))?: "
)


def command_options(parser: argparse.ArgumentParser, command: str | None) -> dict[str, str]:
    """``{dest: '--long-option'}`` of ``command``'s arguments and the shared ones."""
    found: dict[str, str] = {}
    parsers = [parser]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and command in action.choices:
            parsers.append(action.choices[command])
    for each in parsers:
        for action in each._actions:
            longs = [s for s in action.option_strings if s.startswith("--")]
            if longs and action.dest not in found:
                found[action.dest] = longs[0]
    return found


def in_option_style(message: str, options: dict[str, str]) -> str:
    """``message`` led by the option that sets its field, when one does (module docstring)."""
    lead = _LEAD.match(message)
    if lead is None:
        return message
    field = lead["field"]
    option = lead["option"] or _option_for(field, options)
    if option is None:
        return message
    return f"{option} ({field}): {message[lead.end() :]}"


def _option_for(field: str, options: dict[str, str]) -> str | None:
    if field in options:
        return options[field]
    for suffix in UNIT_SUFFIXES:
        if field.endswith(suffix) and field[: -len(suffix)] in options:
            return options[field[: -len(suffix)]]
    return None
