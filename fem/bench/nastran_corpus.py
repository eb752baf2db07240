"""How many real Nastran shell decks the Nastran door reads, why it refuses the others, and
how its frequencies compare with the solver's own, as JSON and a table.

    python -m fem.bench.nastran_corpus DIR [-o corpus.json] [--modes 6] [--list]

DIR is a library of decks, e.g. the ``models/`` folder of pyNastran
(https://github.com/SteveDoyle2/pyNastran, BSD-3-Clause licence): its NX and MSC examples.

* A **deck** is a file ``.bdf``/``.dat``/``.nas``/``.bulk``/``.blk``/``.inc`` that no other
  file of DIR INCLUDEs (resolved from the including deck's directory, as Nastran does, then
  beside the including file) and whose bulk data (with its INCLUDEs) holds a shell element
  card (CQUAD4, CTRIA3, CQUAD8, CTRIA6, CQUADR, CTRIAR); the selection is a text scan, the
  same whatever fem reads. A **shell deck** holds no solid, fluid or axisymmetric element
  card (CHEXA, CPENTA, CTETRA, CPYRAM, CFLUIDi, CHACAB, CAABSF, CQUADX, CTRIAX): its
  structure is sheets, with beams, springs, masses and rigid elements.
* Each deck goes through ``fem.from_nastran(deck, units="SI", n_modes=...)`` (frequencies
  do not depend on the unit system when the deck's units are consistent). A user follows
  the door's messages: a deck that leaves rigid-body modes is retried with
  ``allow_rigid_modes=True``, one with several SPC sets with the first set its case control
  selects (``--spc-id``). The outcome is ``read``, ``refused`` (an InputError/ModelError:
  the message, and the cards it names, or the kind of a refusal of the model as a whole:
  no mass, a mechanism, modes below the rigid cut-off, heat transfer) or ``traceback`` (any
  other exception: a bug); a refusal for a deck without mass (a static deck: no RHO, no
  CONM) is counted apart.
* **Frequencies**: where an ``.f06`` (else an ``.op2``) with the deck's stem lies beside it
  and the deck's solution computes normal modes (SOL 103, 111, 112, 145, 146, 200), its
  REAL EIGENVALUES tables (the OP2's LAMA tables read with fem.imports.op2, or the eigenvalues of
  its eigenvector tables' headers) give the solver's modes; the elastic ones (above 0.1 Hz)
  are compared with ours in order, the relative difference of the first ``--modes``. Of
  several tables (subcases) the one whose first frequency is nearest ours is compared (SOL
  200: the first, the deck as given). A compared deck is **within** 3 % of the solver,
  **warned** beyond it with a warning that says why (a mesh too coarse for the modes, the
  solver's lumped mass, a Kirchhoff shell of a thick part), or **wrong**; the accuracy
  table also gives our modes with the estimated shift of Nastran's lumped mass
  (fem.imports.nastran.mass) against the solver's.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

import fem
from fem.imports.nastran.scope import ADVICE
from fem.imports.op2 import read_op2
from jaxflex.errors import InputError, ModelError
from jaxflex.files import write_text_atomic

EXTENSIONS = {".bdf", ".dat", ".nas", ".bulk", ".blk", ".inc"}
_SHELL = re.compile(r"^(CQUAD4|CTRIA3|CQUAD8|CTRIA6|CQUADR|CTRIAR)[\s,*]", re.IGNORECASE)
_INCLUDE = re.compile(r"^\s*INCLUDE\s+(.*)$", re.IGNORECASE)
_EIGEN_TABLE = "R E A L   E I G E N V A L U E S"
_ROW = re.compile(r"^\s*(\d+)\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$")
MODAL_SOLUTIONS = {
    *("103", "3", "SEMODES", "111", "112", "11", "12", "SEMFREQ", "SEMTRAN"),
    *("145", "146", "SEFLUTTR", "SEAERO", "200", "DESOPT"),
}
RIGID_HZ = 0.1  # the solver's modes below this count as rigid-body modes
TOLERANCE = 0.03  # the first modes within 3 % of the solver's (issue 33)
EXPLAINING = ("half-wave", "lumped mass", "Kirchhoff", "shear-deformable")  # warnings' words
_SOLID = re.compile(
    r"^(CHEXA|CPENTA|CTETRA|CPYRAM|CFLUID\d|CHACAB|CAABSF|CQUADX\d*|CTRIAX\d*)[\s,*]",
    re.IGNORECASE | re.MULTILINE,
)
_CARD_NAME = re.compile(r"\b([A-Z][A-Z0-9]{2,7})\b")
_FIELD = re.compile(r"(?:row \d+ )?field \d+ [A-Z0-9/*]+")  # "field 3 MID1": no card
_TAKES = re.compile(r"; \w+ takes [A-Z0-9, ]+")  # the kinds a field allows: not the refused
EIGENVECTOR_TABLES = ("OUGV1", "BOUGV1", "OUG1", "OPHIG", "BOPHIG")


def _include_lines(path: Path) -> list[str]:
    """The file names ``path`` INCLUDEs (quoted names may continue over lines)."""
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []
    out = []
    for i, line in enumerate(lines):
        match = _INCLUDE.match(line.split("$", 1)[0])
        if not match:
            continue
        name = match.group(1).strip()
        k = i + 1
        while name.startswith("'") and name.count("'") < 2 and k < len(lines):
            name += lines[k].split("$", 1)[0].strip()
            k += 1
        name = name.strip("'\" ")
        if name:
            out.append(name)
    return out


def _tree(path: Path, job: Path, seen: set) -> set:
    """The files a deck reads: INCLUDEs resolved from the job directory ``job``, then
    beside the including file (as fem.imports.nastran.bdf resolves them)."""
    if path in seen or not path.is_file():
        return seen
    seen.add(path)
    for name in _include_lines(path):
        target = (job / name).resolve()
        if not target.is_file():
            target = (path.parent / name).resolve()
        _tree(target, job, seen)
    return seen


def _has_shell(path: Path) -> bool:
    text = path.read_text(encoding="utf-8", errors="replace")
    return any(_SHELL.match(line) for line in text.splitlines())


def find_decks(root: Path) -> list[Path]:
    """The decks under ``root`` (module docstring), sorted."""
    files = sorted(p.resolve() for p in root.rglob("*") if p.suffix.lower() in EXTENSIONS)
    trees = {p: _tree(p, p.parent, set()) for p in files}
    included = {q for p, tree in trees.items() for q in tree if q != p}
    return [p for p in files if p not in included and any(_has_shell(q) for q in trees[p])]


def is_shell_deck(path: Path) -> bool:
    """Whether the deck and its INCLUDEs hold no solid, fluid or axisymmetric element."""
    files = _tree(path, path.parent, set())
    return not any(_SOLID.search(f.read_text(encoding="utf-8", errors="replace")) for f in files)


def f06_eigen_tables(path: Path) -> list[np.ndarray]:
    """The CYCLES column of every REAL EIGENVALUES table of an .f06 file, Hz; a table that
    continues on the next page (its mode numbers go on) is one table."""
    tables: list[list[tuple[int, float]]] = []
    inside = False
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        if _EIGEN_TABLE in line:
            tables.append([])
            inside = True
            continue
        row = _ROW.match(line) if inside else None
        if row:
            try:
                tables[-1].append((int(row.group(1)), float(row.group(5))))
            except ValueError:
                inside = False
        elif inside and line[:1] == "1":  # a page break ends the table (or its page)
            inside = False
    merged: list[list[tuple[int, float]]] = []
    for table in tables:
        if merged and table and merged[-1] and table[0][0] == merged[-1][-1][0] + 1:
            merged[-1].extend(table)
        elif table:
            merged.append(table)
    return [np.array([hz for _, hz in t]) for t in merged]


def _unique(tables: list[np.ndarray]) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for table in tables:
        if table.size and not any(len(t) == len(table) and np.allclose(t, table) for t in out):
            out.append(table)
    return out


def op2_eigen_tables(path: Path) -> list[np.ndarray]:
    """The natural frequencies of an OP2 file, Hz (fem.imports.op2 reads its tables): the cycles of
    each LAMA table (record 4: seven words per mode), else the eigenvalues the headers of its
    real eigenvector tables state (approach code 2, table code 7: the PARAM,POST,-1 files of
    NX and MSC without LAMA), one table per eigenvector table."""
    try:
        contents = read_op2(path)
    except InputError:
        return []
    tables = []
    for table in contents.tables:
        if table.name == "LAMA" and len(table.records) > 1:
            floats = contents.floats(table.record(1)).astype(float)
            tables.append(floats[: len(floats) // 7 * 7].reshape(-1, 7)[:, 4])
    if tables:
        return _unique(tables)
    headers: dict[str, dict[int, float]] = {}
    for table in contents.tables:
        if table.name not in EIGENVECTOR_TABLES:
            continue
        for k in range(0, len(table.records) - 1, 2):
            head = table.record(k)
            ints, floats = contents.ints(head), contents.floats(head)
            if len(ints) >= 10 and ints[0] // 10 == 2 and ints[1] % 1000 == 7:
                headers.setdefault(table.name, {})[int(ints[4])] = float(floats[5])
    for modes in headers.values():
        values = np.array([modes[m] for m in sorted(modes)])
        tables.append(np.sqrt(np.clip(values, 0.0, None)) / (2 * np.pi))
    return _unique(tables)


def _solution(path: Path) -> str:
    text = path.read_text(encoding="utf-8", errors="replace")
    sol = re.search(r"^\s*SOL\s+(\w+)", text, re.IGNORECASE | re.MULTILINE)
    return "" if sol is None else sol.group(1).upper()


def _is_modal(path: Path) -> bool:
    """Whether the deck's solution computes normal modes: SOL 103 (3, SEMODES), the modal
    frequency and transient responses 111, 112, aeroelastic 145, 146 (their structural
    modes), and 200 (the modes of its first design cycle: the deck as given)."""
    return _solution(path) in MODAL_SOLUTIONS


def _compare(ours: np.ndarray, tables: list[np.ndarray], n_modes: int) -> dict | None:
    if not tables or not ours.size:
        return None
    best = None
    for table in tables:
        theirs = table[table > RIGID_HZ][:n_modes]
        n = min(len(theirs), len(ours))
        if not n:
            continue
        diff = ours[:n] / theirs[:n] - 1
        if best is None or abs(diff[0]) < abs(best["rel_diff"][0]):
            best = {
                "solver_hz": theirs[:n].tolist(),
                "ours_hz": ours[:n].tolist(),
                "rel_diff": diff.tolist(),
                "max_abs_rel_diff": float(np.max(np.abs(diff))),
            }
    return best


def _cards_named(message: str) -> list[str]:
    """What a refusal names: the cards of an element-set refusal (with "(part
    superelements)"), the kind of a refusal for the model as a whole ("(no mass)",
    "(mechanism)", "(modes below the rigid cut-off)", "(heat transfer)"), else the card names
    of the message (upper-case words that look like Nastran cards, field labels left out)."""
    for words, kind in KINDS:
        if words in message:
            return [kind]
    found = ["(part superelements)"] if "part superelements" in message else []
    text = _TAKES.sub("", _FIELD.sub("", message.replace(ADVICE, "").removeprefix("deck: ")))
    if found:
        text = text[text.index(")") :]  # the parts' note names no card
    cards = {w for w in _CARD_NAME.findall(text) if w[0] in "CPMRSGEKB"}
    return found + sorted(cards - {"SUPER", "BEGIN", "RHO"})


KINDS = (  # the first that a refusal's message holds
    ("cannot be solved", "(singular mass or stiffness)"),
    ("has no mass", "(no mass)"),
    ("mechanism(s)", "(mechanism)"),
    ("deform the part", "(modes below the rigid cut-off)"),
    ("heat-transfer", "(heat transfer)"),
)


def try_deck(path: Path, n_modes: int) -> dict:
    """The outcome of one deck (module docstring)."""
    record: dict = {"deck": str(path), "shell_deck": is_shell_deck(path)}
    options: dict = {}
    tick = time.perf_counter()
    for _ in range(3):
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                result = fem.from_nastran(
                    path, units="SI", n_modes=n_modes, progress=False, **options
                )
        except (InputError, ModelError) as exc:
            message = str(exc)
            unheld = "allow_rigid_modes" in message or "no SPC and no cups" in message
            if unheld and "allow_rigid_modes" not in options:
                options["allow_rigid_modes"] = True
                continue
            sets = re.search(r"SPC sets \[(\d+)", message)
            if sets and "spc_id" not in options:
                options["spc_id"] = int(sets.group(1))
                continue
            record.update(outcome="refused", message=message, cards=_cards_named(message))
            break
        except Exception as exc:  # a traceback is what this counts
            record.update(
                outcome="traceback",
                message=f"{type(exc).__name__}: {exc}",
                traceback=traceback.format_exc(limit=-4),
            )
            break
        else:
            record.update(
                outcome="read",
                freq_hz=result.freq_hz.tolist(),
                rigid_modes=int(result.rigid_freq_hz.size),
                warnings=[str(w.message) for w in caught],
            )
            f06, op2 = path.with_suffix(".f06"), path.with_suffix(".op2")
            tables = f06_eigen_tables(f06) if f06.is_file() else []
            source = "f06"
            if not tables and op2.is_file():
                tables, source = op2_eigen_tables(op2), "op2"
            if tables and _is_modal(path):
                if _solution(path) in ("200", "DESOPT"):  # the first design cycle's modes
                    tables = tables[:1]
                record["solver"] = _compare(result.freq_hz, tables, n_modes)
                if record["solver"]:
                    record["solver"]["from"] = source
                    shift = result.provenance["derived"].get("lumped_mass_shift")
                    if isinstance(shift, list):  # ours with Nastran's lumped mass (estimate)
                        n = len(record["solver"]["solver_hz"])
                        lumped = result.freq_hz[:n] * (1 + np.array(shift[:n]))
                        diff = lumped / np.array(record["solver"]["solver_hz"]) - 1
                        record["solver"]["lumped_estimate_rel_diff"] = diff.tolist()
            break
    record["options"] = options
    record["wall_s"] = round(time.perf_counter() - tick, 3)
    return record


def _explained(record: dict) -> bool:
    """Whether a warning of the read says why its modes may differ from the solver's: a
    mesh too coarse for them, the solver's lumped mass, a Kirchhoff shell of a thick part."""
    return any(any(words in w for words in EXPLAINING) for w in record.get("warnings", []))


def _verdict(record: dict) -> str:
    """ "within" the solver's first modes to TOLERANCE, "warned" beyond it with a warning
    that says why, "wrong" beyond it without one, "" when nothing was compared."""
    compared = record.get("solver")
    if not compared:
        return ""
    if compared["max_abs_rel_diff"] <= TOLERANCE:
        return "within"
    return "warned" if _explained(record) else "wrong"


def _counts(records: list[dict]) -> dict:
    outcome = Counter(r["outcome"] for r in records)
    static = sum(r["outcome"] == "refused" and "has no mass" in r["message"] for r in records)
    verdicts = Counter(_verdict(r) for r in records)
    return {
        "tried": len(records),
        "read": outcome["read"],
        "refused": outcome["refused"],
        "refused_no_mass": static,
        "tracebacks": outcome["traceback"],
        "read_share": outcome["read"] / max(len(records), 1),
        "read_share_of_decks_with_mass": outcome["read"] / max(len(records) - static, 1),
        "compared_with_solver": sum(verdicts[v] for v in ("within", "warned", "wrong")),
        "within_tolerance": verdicts["within"],
        "beyond_with_warning": verdicts["warned"],
        "wrong": verdicts["wrong"],
    }


def accuracy_table(records: list[dict]) -> list[dict]:
    """One row per deck compared with its solver: modes, the first mode's and the largest
    relative difference, the verdict and the warnings that say why."""
    rows = []
    for r in records:
        compared = r.get("solver")
        if not compared:
            continue
        rows.append(
            {
                "deck": Path(r["deck"]).name,
                "from": compared["from"],
                "modes": len(compared["rel_diff"]),
                "first_mode_rel_diff": compared["rel_diff"][0],
                "max_abs_rel_diff": compared["max_abs_rel_diff"],
                "verdict": _verdict(r),
                "lumped_estimate_max_abs_rel_diff": float(
                    np.max(np.abs(compared.get("lumped_estimate_rel_diff", [np.nan])))
                ),
                "why": [w for w in r.get("warnings", []) if any(e in w for e in EXPLAINING)],
            }
        )
    return rows


def summarise(records: list[dict]) -> dict:
    """Counts (all decks, shell decks), refusals by the cards they name, frequency agreement."""
    reasons = Counter(
        card for r in records if r["outcome"] == "refused" for card in r["cards"] or ["(none)"]
    )
    shell_reasons = Counter(
        card
        for r in records
        if r["outcome"] == "refused" and r["shell_deck"]
        for card in r["cards"] or ["(none)"]
    )
    return {
        "all_decks": _counts(records),
        "shell_decks": _counts([r for r in records if r["shell_deck"]]),
        "refusals_by_card": dict(reasons.most_common()),
        "shell_deck_refusals_by_card": dict(shell_reasons.most_common()),
        "accuracy": accuracy_table(records),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m fem.bench.nastran_corpus", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("root", type=Path, help="the library of decks (pyNastran's models/)")
    parser.add_argument("-o", "--output", default="nastran_corpus.json", help="JSON written")
    parser.add_argument("--modes", type=int, default=6, help="modes solved and compared")
    parser.add_argument("--list", action="store_true", help="list the decks and stop")
    args = parser.parse_args(argv)
    decks = find_decks(args.root)
    if args.list:
        print("\n".join(str(d.relative_to(args.root.resolve())) for d in decks))
        return 0
    records = []
    for k, deck in enumerate(decks, 1):
        record = try_deck(deck, args.modes)
        records.append(record)
        name = deck.relative_to(args.root.resolve())
        detail = record.get("message", "")[:150] if record["outcome"] != "read" else ""
        compared = record.get("solver")
        if compared:
            detail = f"vs {compared['from']}: max {100 * compared['max_abs_rel_diff']:.2f} %"
        print(f"[{k}/{len(decks)}] {name}: {record['outcome']} {detail}", flush=True)
    summary = summarise(records)
    write_text_atomic(args.output, json.dumps({"summary": summary, "decks": records}, indent=1))
    print(json.dumps(summary, indent=1))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
