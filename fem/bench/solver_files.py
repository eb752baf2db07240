"""Every modal-results file of a directory through ``--from-modes`` (and every ANSYS .rst
through ``--from-ansys``, with unit participation factors): what was read, what was refused
and why, and frequencies against the solver's own printout where it lies beside the file
(the .f06 of an .op2), as JSON. A read file passes the model checks (fem.imports.checks)
before it counts as read.

    python -m fem.bench.solver_files DIR [--units SI] [-o solver_files.json]

Measured on pyNastran's model library (``models/`` of github.com/SteveDoyle2/pyNastran,
BSD-3-Clause), pyuff's example files (``data/`` of github.com/ladisk/pyuff, MIT) and
pymapdl-reader's test files (``tests/`` of github.com/ansys/pymapdl-reader, MIT); the
figures are in docs/fem.md. Files are tried by suffix (.op2, .pch, .uff, .unv, .rst); the
unit system is a placeholder where the files state none (frequencies do not depend on it).
"""

from __future__ import annotations

import argparse
import json
import re
from collections import Counter
from pathlib import Path

import numpy as np

from fem.imports.from_modes import SUFFIXES, from_modes
from jaxflex.errors import InputError
from jaxflex.files import write_text_atomic

_F06_ROW = re.compile(r"^\s+(\d+)\s+\d+\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$")


def f06_frequencies(path: Path) -> np.ndarray | None:
    """Cycles (Hz) of the first REAL EIGENVALUES table of an .f06, or None."""
    if not path.is_file():
        return None
    lines = path.read_text(encoding="latin-1").splitlines()
    for i, line in enumerate(lines):
        if "R E A L   E I G E N V A L U E S" in line:
            out = []
            heading = 3 + ("AUGMENTATION" in lines[i + 1])  # MSC's residual-vector note
            for row in lines[i + heading :]:
                match = _F06_ROW.match(row)
                if not match:
                    break
                out.append(float(match.group(4)))
            return np.array(out) if out else None
    return None


def _f06_of(path: Path) -> Path:
    """The .f06 of the same run: the same stem, or the one whose stem begins the file's."""
    same = path.with_suffix(".f06")
    if same.is_file():
        return same
    prefixes = [p for p in path.parent.glob("*.f06") if path.stem.startswith(p.stem)]
    return prefixes[0] if len(prefixes) == 1 else same


def _mapdl_result(path: Path) -> bool:
    """A .rst that is a binary file (not reStructuredText)."""
    if path.suffix.lower() != ".rst":
        return False
    with open(path, "rb") as handle:
        return b"\0" in handle.read(512)


def _read(path: Path, units: str):
    if path.suffix.lower() == ".rst":
        from fem.imports.ansys import from_ansys

        result = from_ansys(
            path, units=units, gamma=np.ones((1, 3)), n_modes=1, allow_rigid_modes=True
        )
    else:
        result = from_modes(path, units=units, allow_rigid_modes=True)
    result.check()
    return result


def try_file(path: Path, units: str) -> dict:
    """One file through fem.imports.from_modes (or fem.from_ansys): read (modes, nodes, gamma,
    frequencies) or refused."""
    entry: dict = {"file": str(path), "kind": path.suffix.lower()}
    try:
        result = _read(path, units)
    except InputError as exc:
        entry["status"] = "refused"
        entry["reason"] = str(exc)
        return entry
    entry.update(
        status="read",
        modes=int(result.n_modes),
        nodes=len(result.node_ids),
        freq_hz=[round(float(f), 6) for f in result.freq_hz[:10]],
        gamma="file" if result.gamma is not None else "missing",
        coordinates="file" if result.nodes is not None else "missing",
        rigid_modes=result.provenance.get("rigid_modes", {}).get("count", 0),
    )
    f06 = f06_frequencies(_f06_of(path))
    if f06 is not None:
        elastic = f06[f06 >= 0.01]
        n = min(elastic.size, result.freq_hz.size)
        if n:
            error = np.abs(result.freq_hz[:n] / elastic[:n] - 1).max()
            entry["vs_f06"] = {"modes": n, "max_relative_difference": float(error)}
    return entry


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fem.bench.solver_files", description=__doc__)
    parser.add_argument("directory", help="searched recursively for .op2, .pch, .uff, .unv, .rst")
    parser.add_argument("--units", default="SI", help="for files that state none")
    parser.add_argument("-o", "--output", default="solver_files.json")
    args = parser.parse_args(argv)
    files = sorted(
        p
        for p in Path(args.directory).rglob("*")
        if p.is_file() and (p.suffix.lower() in SUFFIXES or _mapdl_result(p))
    )
    entries = [try_file(p, args.units) for p in files]
    tally = Counter((e["kind"], e["status"]) for e in entries)
    summary = {f"{kind} {status}": n for (kind, status), n in sorted(tally.items())}
    reasons = Counter(
        re.sub(r"'[^']*'|\[[^]]*\] \(\d+ in all\)", "FILE", e["reason"])[:150]
        for e in entries
        if e["status"] == "refused"
    )
    report = {"summary": summary, "refusals": dict(reasons.most_common()), "files": entries}
    write_text_atomic(args.output, json.dumps(report, indent=2))
    print(json.dumps({"summary": summary, "refusals": report["refusals"]}, indent=2))
    for entry in entries:
        if "vs_f06" in entry:
            print(f"{entry['file']}: {entry['vs_f06']}")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
