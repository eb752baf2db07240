"""The end of every benchmark command: its figures as JSON on stdout and, with ``--output``,
in a file (written atomically). Light: json only."""

from __future__ import annotations

import json
import os

from jaxflex.files import write_text_atomic


def emit_json(figures, output: str | os.PathLike | None) -> int:
    """Print ``figures`` (JSON-serialisable) indented, write them to ``output`` if given;
    returns 0 (the command's exit status)."""
    text = json.dumps(figures, indent=2)
    print(text)
    if output:
        write_text_atomic(output, text + "\n")
    return 0
