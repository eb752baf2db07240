"""Whether the move an FMU embeds was optimised in the cell the FMU is posed in.

``jaxflex export --trajectory RUN --cell CELL`` poses the part in CELL and replays RUN's move
in its coordinates. A move `jaxflex optimize` made without a cell (report.json's frame
"model") or in another cell knows neither CELL's pose nor its obstacles: its distances and
loads in the FMU would be those of a move nobody planned there. Such a pair is refused,
naming the cell the move was made for; a trajectory without a report (a bare CSV) is the
user's own move and is taken as it is.
"""

from __future__ import annotations

import json
from pathlib import Path

from jaxflex.errors import InputError
from optim.animate_frames import file_record

ADVICE = (
    "optimise the move in this cell (jaxflex optimize MODEL --cell CELL ... -o DIR) or export "
    "without --cell"
)


def check_move_cell(report_path: Path, cell_path: str | Path, cell) -> None:
    """InputError unless the move of the `jaxflex optimize` result whose report is
    ``report_path`` (already read once by the export, as a member of its result set) was
    optimised in the cell of the file ``cell_path`` (the jaxflex.geometry.Cell ``cell``): the
    same file (report.json's inputs.cell, by its SHA-256) or the same cell (its
    description)."""
    try:
        report = json.loads(Path(report_path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"--trajectory: {str(report_path)!r} cannot be read ({exc})") from None
    if report.get("frame") != "cell":
        raise InputError(
            f"--cell: the move of --trajectory was optimised without a cell (report.json's "
            f"frame: {report.get('frame', 'model')!r}), not in {str(cell_path)!r}: its path "
            f"knows neither the cell's pose nor its obstacles; {ADVICE}"
        )
    record = (report.get("inputs") or {}).get("cell") or {}
    if record.get("sha256") == file_record(cell_path)["sha256"]:
        return
    if report.get("cell") == json.loads(json.dumps(cell.describe())):
        return
    made_in = record.get("path", "a cell report.json describes")
    raise InputError(
        f"--cell: the move of --trajectory was optimised in another cell ({made_in!r}, by "
        f"report.json's inputs.cell and cell), not in {str(cell_path)!r}; {ADVICE}"
    )
