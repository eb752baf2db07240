"""An optimisation's result in words and as data: report.json's content (:func:`report`),
the terminal summary with the answer first (:func:`summary`, :func:`headline`) and the
comparison with the baselines (:func:`comparison`, :func:`ratios`), functions of an
optim.result.OptimizationResult, which has them as methods through the mixin
:class:`Reported` (so this module needs nothing of optim.result)."""

from __future__ import annotations

import numpy as np


def constraint_line(c: dict) -> str:
    """One line on a cell constraint's certified value (optim.cell_rows describe())."""
    when = "at rest" if not np.isfinite(c["time_s"]) else f"at {c['time_s']:.3f} s"
    if "distance" in c["name"]:
        return (
            f"{c['name']}: {c['peak'] * 1e3:.2f} mm (limit {c['limit'] * 1e3:g} mm) {when}, "
            f"point {c['item']}, obstacle {c.get('obstacle')!r}"
        )
    scale, unit = (1e-6, " MPa") if "stress" in c["name"] else (1.0, "")
    what = "cup" if "cup" in c["name"] else "stress point"
    error = ""
    if c.get("discretisation_error") is not None:  # the FE's estimate (fem.discretisation)
        high = c["peak_with_discretisation"]
        error = (
            f"; FE discretisation error +-{100 * c['discretisation_error']:.2g} %: up to "
            f"{high * scale:.3g}{unit} on the real part"
            + (", above the limit" if high > c["limit"] else "")
        )
    return (
        f"{c['name']}: {c['peak'] * scale:.3g}{unit} (limit {c['limit'] * scale:.3g}{unit}, "
        f"utilisation {c['utilisation']:.1%}{error}) {when}, {what} {c['item']}"
    )


class Reported:
    """The report methods of optim.result.OptimizationResult (a mixin: each calls this
    module's function of its name on the result)."""

    def comparison(self) -> dict:
        """The answer against the best allowed baseline (:func:`comparison`)."""
        return comparison(self)

    def ratios(self) -> dict:
        """Cycle time over the kinematic floor and the best shaper (:func:`ratios`)."""
        return ratios(self)

    def report(self) -> dict:
        """Everything as JSON-ready data, report.json's content (:func:`report`)."""
        return report(self)

    def summary(self) -> str:
        """The answer first, then the details, for the terminal (:func:`summary`)."""
        return summary(self)

    def headline(self) -> str:
        """One line with the answer and how it compares (:func:`headline`)."""
        return headline(self)


def comparison(result: Reported) -> dict:
    """The answer against the best baseline that meets the cell's constraints and the
    clearance (``baseline_allowed``), by the same objective: its name, its objective and
    the saving (s, and relative to the baseline). Where no baseline does, against the
    fastest one, ``baseline_allowed`` False and ``breaks`` saying what it breaks."""
    allowed = result.baselines.best_allowed()
    best = allowed if allowed is not None else result.baselines.best()
    saving = best.score() - result.objective_s
    return {
        "objective": "cycle_time_s" if result.worst_case is None else "worst_cycle_time_s",
        "best_baseline": best.name,
        "best_baseline_s": best.score(),
        "saving_s": saving,
        "saving_rel": saving / best.score(),
        "baseline_allowed": allowed is not None,
        "breaks": best.broken(),
    }


def ratios(result: Reported) -> dict:
    """The issue's figures: cycle time over the kinematic floor and over the best
    shaper (nominal), and the robust worst case over the best shaper's worst case."""
    base = result.baselines
    shapers = [b for b in base.entries if b.shaped_freq_hz]
    out = {
        "cycle_over_kinematic_floor": result.cycle_time_s / base.kinematic_floor_s,
        "cycle_over_floor_on_grid": result.cycle_time_s / (base.floor_steps * result.dt_s),
    }
    if shapers:
        best = min(shapers, key=lambda b: b.cycle_time_s)
        out["cycle_over_best_shaper"] = result.cycle_time_s / best.cycle_time_s
        out["best_shaper"] = best.name
        if result.worst_case is not None:
            worst = min(shapers, key=lambda b: b.worst_cycle_time_s)
            out["worst_over_best_shaper_worst"] = (
                result.worst_cycle_time_s / worst.worst_cycle_time_s
            )
            out["best_shaper_worst_case"] = worst.name
    return out


def report(result: Reported) -> dict:
    """Everything as JSON-ready data (the content of report.json)."""
    model = result.model
    return {
        "units": "SI (m, s, m/s, m/s^2, m/s^3)",
        "inputs": result.inputs or None,
        "model": {
            "n_modes": model.n_modes,
            "n_points": model.n_points,
            "freq_hz_range": [float(np.min(model.freq_hz)), float(np.max(model.freq_hz))],
            "source": dict(model.meta).get("source"),
        },
        "distance_m": result.distance_m.tolist(),
        "dt_s": result.dt_s,
        "threshold_m": result.threshold_m,
        "limits": result.limits.as_dict(),
        "method": result.method,
        "solver": result.solver,
        "robust": None if result.robust is None else result.robust.as_dict(),
        "clearance_m": result.clearance_m,
        "source": result.source,
        "notes": list(result.solver_stats.get("notes", [])),
        "warnings": result.warnings,
        "frame": "model" if result.cell is None or result.cell.cell is None else "cell",
        "cell": None
        if result.cell is None or result.cell.cell is None
        else result.cell.cell.describe(),
        "constraints": result.constraints,
        "turn": None if result.turn is None else _turn_report(result),
        "n_steps": result.n_steps,
        "transfer_time_s": result.transfer_time_s,
        "settle_time_s": result.settle_time_s,
        "cycle_time_s": result.cycle_time_s,
        "worst_case": result.worst_case,
        "comparison": comparison(result),
        "deviation": result.deviation,
        "ratios": ratios(result),
        "constraint_check": result.constraint_check.as_dict(),
        "baselines": result.baselines.as_dict(),
        "solver_stats": result.solver_stats,
        "wall_time_s": result.wall_time_s,
    }


def _turn_report(result: Reported) -> dict:
    """The turn, its schedule's heuristic and the neglected terms' bound (optim.turn)."""
    return {
        "schedule": "fixed per move length: ruckig's turn stretched to the move, or shaped "
        "like the best shaped baselines and stretched (optim.turn)",
        **result.turn.as_dict(),  # a turn through via orientations says its own schedule
        "neglected_bound_m": result.deviation["neglected_bound_m"],
        "angular_acc_rad_s2": result.angular_acc.tolist(),
    }


def _turn_line(result: Reported) -> str:
    spec = result.turn.as_dict()
    axis = ", ".join(f"{v:g}" for v in spec["axis"])
    bound = result.deviation["neglected_bound_m"]
    through = "".join(  # a turn through via orientations (optim.turn_via)
        f"{' then' if i else ' through the via orientations:'} {s['angle_deg']:.4g} deg "
        f"about ({', '.join(f'{v:.3g}' for v in s['axis'])})"
        for i, s in enumerate(spec.get("via_turns", ()))
    )
    return (
        f"  turn: {spec['angle_deg']:g} deg about ({axis}){through} within "
        f"{spec['rate_rad_s']:g} "
        f"rad/s, {spec['acc_rad_s2']:g} rad/s^2, {spec['jerk_rad_s3']:g} rad/s^3; the "
        f"neglected gyroscopic and spin-softening terms change the deviation by at most "
        f"{bound * 1e3:.3g} mm"
    )


def summary(result: Reported) -> str:
    """The answer first (ruckig-style: one line), then the details, for the terminal."""
    lines = [headline(result), f"  {_timeline(result)}"]
    if result.worst_case is not None:
        grid = result.worst_case["grid"]
        lines.append(
            f"  nominal model: cycle {result.cycle_time_s:.3f} s; worst over the "
            f"{len(grid)} models of the robust grid at f x{result.worst_case['freq_scale']:.3g}"
            + ("" if result.worst_case["zeta"] is None else f", zeta {result.worst_case['zeta']:g}")
        )
    peak = result.deviation["peak_during_move_m"]
    clear = "" if result.clearance_m is None else f" (clearance {result.clearance_m * 1e3:g} mm)"
    lines.append(f"  peak deviation during the move: {peak * 1e3:.3f} mm{clear}")
    if result.turn is not None:
        lines.append(_turn_line(result))
    for c in result.constraints:
        lines.append("  " + constraint_line(c))
    base = result.baselines
    lines.append(
        f"  kinematic floor (ruckig): {base.kinematic_floor_s:.3f} s, "
        f"{base.floor_steps} steps on the {result.dt_s * 1e3:g} ms grid"
    )
    robust = result.worst_case is not None
    lines.append("  baselines:" + " " * 16 + "cycle" + ("      worst" if robust else ""))
    for b in base.entries:
        worst = f"    {b.worst_cycle_time_s:7.3f} s" if robust else ""
        bad = "" if b.allowed else f" (not allowed: breaks {b.broken()})"
        lines.append(f"    {b.name:24s}{b.cycle_time_s:7.3f} s{worst}{bad}")
    lines.append(f"  limits: {result.constraint_check.summary()}")
    lines += [f"  note: {note}" for note in result.solver_stats.get("notes", [])]
    lines.append(f"  ({result.method}, {result.solver}; {result.wall_time_s:.1f} s wall)")
    return "\n".join(lines)


def headline(result: Reported) -> str:
    """One line with the answer: which move, its objective, and how it compares with
    the best baseline that meets the cell's constraints and the clearance (the same
    objective), or that no baseline does."""
    cmp = comparison(result)
    what = "worst case" if result.worst_case is not None else "cycle"
    base = f"{cmp['best_baseline']} {cmp['best_baseline_s']:.3f} s"
    if result.source not in ("optimised", "search"):
        return (
            f"best move: the baseline {result.source!r}, {what} {result.objective_s:.3f} s (no "
            "optimised move was shorter; see the note)"
        )
    head = f"best move: optimised, {what} {result.objective_s:.3f} s"
    if not cmp["baseline_allowed"]:
        return (
            f"{head}; no baseline meets the cell's constraints (the fastest, {base}, "
            f"breaks {cmp['breaks']})"
        )
    if cmp["saving_s"] > 0:
        return (
            f"{head}, {cmp['saving_s']:.3f} s ({100 * cmp['saving_rel']:.1f} %) shorter "
            f"than the best feasible baseline, {base}"
        )
    if cmp["saving_s"] < -1e-9:  # not a candidate (optim.stages.choose's notes)
        return (
            f"{head}; the best baseline, {base}, is shorter but breaks the clearance or "
            "a cell constraint"
        )
    floor = " = the kinematic floor, no move is shorter" if _at_floor(result) else ""
    return f"{head}, as short as the best feasible baseline, {base}{floor}"


def _at_floor(result: Reported) -> bool:
    return (
        result.n_steps == result.baselines.floor_steps
        and result.objective_s == result.transfer_time_s
    )


def _timeline(result: Reported) -> str:
    """Transfer, settle and cycle time in words: the cycle is max(transfer, settle)."""
    transfer, settle = result.transfer_time_s, result.settle_time_s
    mm = f"{result.threshold_m * 1e3:g} mm"
    if settle == 0.0:
        after = f"the deviation never exceeds {mm}"
    else:
        when = "before" if settle <= transfer else f"{settle - transfer:.3f} s after"
        after = f"the deviation stays below {mm} from {settle:.3f} s on, {when} the stop"
    return f"transfer {transfer:.3f} s; {after}; cycle {result.cycle_time_s:.3f} s (exact)"
