"""Real eigenvectors from a Nastran punch file (DISPLACEMENT(PUNCH) of SOL 103, SORT1).

A punch file is 80-column text: blocks of ``$`` header lines (``$TITLE``, ``$EIGENVECTOR``,
``$REAL OUTPUT``, ``$SUBCASE ID =``, ``$EIGENVALUE = 3.1666141E+05  MODE = 1``) followed
by two lines per grid,

    columns  1-10  grid id   11-18  point type (G: grid, S: scalar, E: extra)
            19-36, 37-54, 55-72  T1, T2, T3          73-80  line number
    ``-CONT-``     19-36, 37-54, 55-72  R1, R2, R3

in the grid's displacement system (CD). Eigenvalues are omega^2 (rad/s)^2; a punch file
holds no generalized masses, participation factors or coordinates. Complex eigenvectors
(``$REAL-IMAGINARY OUTPUT`` or ``$MAGNITUDE-PHASE OUTPUT``) and other results
(``$DISPLACEMENTS``, ``$SPCF``, ...) are named and left out.
"""

from __future__ import annotations

import os
import re

import numpy as np

from fem.imports.solver_modes import SolverModes
from jaxflex.errors import InputError

_EIGENVALUE = re.compile(r"\$EIGENVALUE\s*=\s*(\S+)\s+MODE\s*=\s*(\d+)", re.IGNORECASE)


def _value(text: str, path: str, line: int) -> float:
    try:
        return float(text.replace("D", "E").replace("d", "e"))
    except ValueError as exc:
        raise InputError(f"punch: {path!r} line {line}: {text.strip()!r} is not a number") from exc


def _grid(text: str, path: str, line: int) -> int:
    try:
        return int(text)
    except ValueError as exc:
        raise InputError(
            f"punch: {path!r} line {line}: {text.strip()!r} is not a grid id (columns 1-10)"
        ) from exc


def read_punch_modes(path: str | os.PathLike) -> SolverModes:
    """The real eigenvectors of a punch file (see the module), in file units."""
    path = str(path)
    if not os.path.isfile(path):
        raise InputError(f"punch: file {path!r} does not exist")
    with open(path, encoding="latin-1") as handle:
        lines = handle.read().splitlines()
    modes: dict[int, tuple[float, dict[int, list[float]]]] = {}
    section, complex_output, other, current = "", False, set(), None
    points_left_out, last = 0, None
    for number, raw in enumerate(lines, start=1):
        line = raw[:72]
        if line.startswith("$"):
            word = line[1:].split("=")[0].strip().upper()
            if word in ("TITLE", "SUBTITLE", "LABEL"):
                current = None
            elif word.endswith("OUTPUT"):
                complex_output = word != "REAL OUTPUT"
            elif word == "EIGENVALUE":
                match = _EIGENVALUE.match(line.strip())
                if match is None:
                    if "(" in line:
                        complex_output = True
                        continue
                    raise InputError(f"punch: {path!r} line {number}: unreadable {line.strip()!r}")
                eigenvalue = _value(match.group(1), path, number)
                current = int(match.group(2))
                modes[current] = (eigenvalue, {})
            elif word.replace(" ", "").replace("-", "").isalpha() and "=" not in line:
                section = word
                if section != "EIGENVECTOR":
                    other.add(section)
            continue
        if section != "EIGENVECTOR" or complex_output or current is None or not line.strip():
            continue
        values = modes[current][1]
        if line.startswith("-CONT-"):
            if last in values:
                values[last].extend(_value(line[c : c + 18], path, number) for c in (18, 36, 54))
            continue
        kind = line[10:18].strip().upper()
        if kind != "G":
            points_left_out += 1
            last = None
            continue
        last = _grid(line[:10], path, number)
        values[last] = [_value(line[c : c + 18], path, number) for c in (18, 36, 54)]
    if not modes:
        found = "complex eigenvectors" if complex_output else ", ".join(sorted(other)) or "nothing"
        raise InputError(
            f"punch: {path!r} holds no real eigenvectors ($EIGENVECTOR with $REAL OUTPUT of "
            f"DISPLACEMENT(PUNCH) in SOL 103); found: {found}"
        )
    mode_ids = np.array(sorted(modes))
    node_ids = np.array(sorted(modes[int(mode_ids[0])][1]))
    if node_ids.size == 0:
        raise InputError(f"punch: {path!r}: mode {mode_ids[0]} lists no grid")
    shapes = np.zeros((node_ids.size, 3, mode_ids.size))
    for j, mode in enumerate(mode_ids):
        grids = modes[int(mode)][1]
        if sorted(grids) != node_ids.tolist():
            raise InputError(
                f"punch: {path!r}: mode {mode} lists other grids than mode {mode_ids[0]}"
            )
        rows = [grids[int(n)][:3] for n in node_ids]
        short = [int(n) for n, row in zip(node_ids, rows, strict=True) if len(row) < 3]
        if short:
            raise InputError(f"punch: {path!r}: mode {mode}: grid {short[0]} lacks T1, T2, T3")
        shapes[:, :, j] = np.array(rows)
    eigenvalues = np.array([modes[int(m)][0] for m in mode_ids])
    notes = ["eigenvectors in the grids' displacement systems (CD), as the punch file has them"]
    if points_left_out:
        notes.append(f"{points_left_out} scalar or extra point entries left out")
    if other:
        notes.append("other results left out: " + ", ".join(sorted(other)))
    return SolverModes(
        kind="Nastran punch ($EIGENVECTOR, real)",
        path=path,
        mode_ids=mode_ids,
        freq_hz=np.sqrt(np.maximum(eigenvalues, 0.0)) / (2 * np.pi),
        node_ids=node_ids,
        shapes=shapes,
        nodes_missing=f"{path!r} (a punch file) holds no coordinates; pass nodes= (--nodes) "
        "with a CSV node,x,y,z or an OP2 of the same run",
        gamma_missing=f"{path!r} (a punch file) holds no participation factors",
        notes=notes,
    )
