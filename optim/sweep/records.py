"""What a stored case record may hold, checked every time one is read.

A record is trusted only if it passes :func:`check_record`:

* **sealed**: the ``sha256`` the store wrote with it matches its content (a record edited by
  hand, forged, or written by a jaxflex without this check is not the one the run stored);
* **its own case**: ``case_id`` is the name of its file;
* **schema**: every field of :data:`FE_FIELDS` / :data:`OPT_FIELDS` of its status has the kind
  and the physical range the table gives (no NaN, no infinity, no zero floor, no text where a
  time belongs); an error names its stage and carries its message;
* **consistent**: the move has ``n_steps + 1`` samples of three finite accelerations at rest
  at both ends, lasts ``n_steps`` steps of the sweep's ``dt_s``, the cycle time is the
  larger of transfer and settle time and no shorter than the kinematic floor.

A record that fails is reported (the file and what is wrong) and its case computed again
(optim.sweep.store); it never stops a sweep.
"""

from __future__ import annotations

import hashlib
import json
import math

from jaxflex.response import VALUE_RANGES

SEAL = "sha256"
STATUSES = ("ok", "error")
STAGES = ("fe", "optimization", "worker")
INF = math.inf
# Relative slack of the consistency checks: times on the sample grid (n * dt) are computed
# in float64 from the same numbers, so they agree to a few ulps.
REL_TOL = 1e-9


class RecordError(ValueError):
    """A stored record that cannot be trusted; the message says what is wrong."""


# name -> (kind, low, high, required). Kinds: "real" (finite float in [low, high]), "int"
# (integer in [low, high]), "text", "real?" (a real or null). Ranges are physical, far
# outside any case of a sweep but excluding what no case can give (negative times, a zero
# floor, a frequency outside the model file's range).
FE_FIELDS: dict[str, tuple[str, float, float]] = {
    "n_dof": ("int", 1, INF),
    "n_modes": ("int", 1, INF),
    "n_points": ("int", 1, INF),
    "first_freq_hz": ("real", *VALUE_RANGES["freq_hz"]),
    "mass_kg": ("real", 1e-12, INF),
    "mass_fraction_z": ("real?", 0.0, 1.0 + REL_TOL),
    "fe_wall_s": ("real", 0.0, INF),
    "fe_cpu_s": ("real", 0.0, INF),
}
OPT_FIELDS: dict[str, tuple[str, float, float]] = {
    "cycle_time_s": ("real", 1e-12, INF),
    "transfer_time_s": ("real", 1e-12, INF),
    "settle_time_s": ("real", 0.0, INF),
    "n_steps": ("int", 2, INF),
    "worst_cycle_time_s": ("real?", 1e-12, INF),
    "kinematic_floor_s": ("real", 1e-12, INF),
    "best_baseline": ("text", 0, 0),
    "best_baseline_cycle_time_s": ("real", 1e-12, INF),
    "best_baseline_s": ("real?", 1e-12, INF),
    "source": ("text", 0, 0),
    "peak_deviation_m": ("real", 0.0, INF),
    "deviation_at_stop_m": ("real", 0.0, INF),
    "opt_wall_s": ("real", 0.0, INF),
    "opt_cpu_s": ("real", 0.0, INF),
}


def seal_digest(record: dict) -> str:
    """SHA-256 of the record's canonical JSON without its seal."""
    body = {k: v for k, v in record.items() if k != SEAL}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def sealed(record: dict) -> dict:
    """``record`` with its seal (what the store writes)."""
    return {**record, SEAL: seal_digest(record)}


def _check_value(where: str, value, kind: str, low: float, high: float) -> None:
    if kind == "real?" and value is None:
        return
    if kind == "text":
        if not isinstance(value, str):
            raise RecordError(f"{where}: must be text, got {value!r:.60}")
        return
    integer = kind == "int"
    if isinstance(value, bool) or not isinstance(value, int if integer else (int, float)):
        what = "an integer" if integer else "a number"
        raise RecordError(f"{where}: must be {what}, got {value!r:.60}")
    if not math.isfinite(value) or not low <= value <= high:
        raise RecordError(f"{where}: {value!r} is outside the allowed range [{low:g}, {high:g}]")


def _check_fields(where: str, section, table: dict) -> None:
    if not isinstance(section, dict):
        raise RecordError(f"{where}: must be an object, got {section!r:.60}")
    for name, (kind, low, high) in table.items():
        if name not in section:
            if kind == "real?":
                continue
            raise RecordError(f"{where}.{name}: missing")
        _check_value(f"{where}.{name}", section[name], kind, low, high)


def check_fe_summary(summary) -> None:
    """The FE summary of a layout (a record's ``fe``, a stored model's ``sweep_fe``)."""
    _check_fields("fe", summary, FE_FIELDS)


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= REL_TOL * max(abs(a), abs(b))


def _check_move(record: dict, opt: dict, dt_s: float | None) -> None:
    n = opt["n_steps"]
    acc = record.get("acc_m_s2")
    if not isinstance(acc, list) or len(acc) != n + 1:
        raise RecordError(f"acc_m_s2: must hold n_steps + 1 = {n + 1} samples")
    for k, sample in enumerate(acc):
        if not isinstance(sample, list) or len(sample) != 3:
            raise RecordError(f"acc_m_s2[{k}]: must be three accelerations (x, y, z)")
        for value in sample:
            _check_value(f"acc_m_s2[{k}]", value, "real", -INF, INF)
    if any(acc[0]) or any(acc[-1]):
        raise RecordError("acc_m_s2: the move must start and end at rest (zero acceleration)")
    if dt_s is not None and not _close(opt["transfer_time_s"], n * dt_s):
        raise RecordError(
            f"opt.transfer_time_s: {opt['transfer_time_s']!r} s is not n_steps x dt = "
            f"{n} x {dt_s:g} s"
        )
    if not _close(opt["cycle_time_s"], max(opt["transfer_time_s"], opt["settle_time_s"])):
        raise RecordError(
            f"opt.cycle_time_s: {opt['cycle_time_s']!r} s is not the larger of the transfer "
            f"({opt['transfer_time_s']!r} s) and settle time ({opt['settle_time_s']!r} s)"
        )
    if opt["cycle_time_s"] < opt["kinematic_floor_s"] * (1 - REL_TOL):
        raise RecordError(
            f"opt.cycle_time_s: {opt['cycle_time_s']!r} s is below the kinematic floor "
            f"{opt['kinematic_floor_s']!r} s"
        )


def check_record(record, case_id: str, dt_s: float | None = None) -> None:
    """Raise RecordError unless ``record`` is a sealed, well-formed record of ``case_id``
    (module docstring); ``dt_s``: the sweep's sample step (None: not checked)."""
    if not isinstance(record, dict):
        raise RecordError(f"must be a JSON object, got {type(record).__name__}")
    if record.get(SEAL) != seal_digest(record):
        raise RecordError(
            "its content does not match its seal (edited, forged, or written by an older jaxflex)"
        )
    if record.get("case_id") != case_id:
        raise RecordError(f"case_id: {record.get('case_id')!r:.60} is not its file's {case_id!r}")
    status = record.get("status")
    if status not in STATUSES:
        raise RecordError(f"status: must be one of {list(STATUSES)}, got {status!r:.60}")
    if record.get("worker") is not None and not isinstance(record["worker"], str):
        raise RecordError("worker: must be text or null")
    if status == "error":
        if record.get("stage") not in STAGES:
            raise RecordError(f"stage: must be one of {list(STAGES)}, got {record.get('stage')!r}")
        for name in ("error_type", "error"):
            _check_value(name, record.get(name), "text", 0, 0)
        for name in ("fe_wall_s", "fe_cpu_s", "opt_wall_s", "opt_cpu_s"):
            if name in record:
                _check_value(name, record[name], "real", 0.0, INF)
        if record.get("fe") is not None:
            check_fe_summary(record["fe"])
        return
    check_fe_summary(record.get("fe"))
    _check_fields("opt", record.get("opt"), OPT_FIELDS)
    opt = record["opt"]
    warnings = opt.get("warnings", [])
    if not isinstance(warnings, list) or not all(
        isinstance(w, dict) and isinstance(w.get("kind"), str) and isinstance(w.get("message"), str)
        for w in warnings
    ):
        raise RecordError("opt.warnings: must be a list of {kind, message} texts")
    _check_move(record, opt, dt_s)


def as_stored(record: dict, dt_s: float | None) -> dict:
    """The sealed record to store for a case just computed: ``record`` itself, or, if it
    fails its own check (a defect, not the case's fault), an error of stage "optimization"
    saying so: stored as it was, it would be rejected and recomputed on every rerun."""
    stored = sealed(record)
    try:
        check_record(stored, record.get("case_id"), dt_s)
    except RecordError as exc:
        return sealed(
            {
                "case_id": record.get("case_id"),
                "status": "error",
                "stage": "optimization",
                "error_type": "RecordError",
                "error": f"the computed record fails its check: {exc}",
                "traceback": None,
                "fe": None,
                "worker": record.get("worker") if isinstance(record.get("worker"), str) else None,
                "finished_unix_s": record.get("finished_unix_s"),
            }
        )
    return stored
