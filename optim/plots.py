"""Pictures of an optimisation result (PNG, written atomically via jaxflex.plots).

* ``profiles.png``: position, velocity, acceleration and jerk of each moving axis with the
  limits; axes with the same profile are drawn once and named together ("x = y");
* ``deviation.png``: the deviation of the optimum and of every baseline against the
  threshold (left), the cycle time of each (right, from the kinematic floor), the optimum's
  saving over the best feasible baseline (one that meets the cell's constraints and the
  clearance) in the title; baselines that are not allowed marked (hatched bars);
* ``constraints.png``: each cell constraint over time, zoomed to its limit, with the cycle
  time and the certified value marked;
* ``robust.png``: the exact cycle time across the robust grid, one panel per damping ratio,
  every move with its own line style and marker, one legend, a linear time axis zoomed to
  the optimum and the best baseline;
* ``deviation_worst_case.png``: the optimum at its worst point of the grid;
* ``turn.png`` (moves that turn the part): the angle and the angular rate of the optimum
  and of every baseline.

Each picture is one function of plain data (``Trace``, grids of dicts), so a new output
(another constraint, another move to compare) is one more trace or one more panel.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from textwrap import fill

import matplotlib.pyplot as plt
import numpy as np

from jaxflex.plots import deviation_axes, save_figure
from jaxflex.response import Move, integrate
from optim.limits import AXES, Limits

OPTIMISED_COLOR = "tab:blue"
# line style and marker per series after the optimum (baselines), distinct even in grey
STYLES = (("-", "o"), ("--", "s"), ("-.", "^"), (":", "D"), ((0, (5, 1)), "v"), ("-", "P"))
BASELINE_COLORS = ("tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")
INSET_S = 0.06  # constraints.png's inset: this many seconds either side of the closest approach
# constraints.png's curves: every CURVE_STRIDE-th time of the deviation curves (dt / 8), so
# every dt / 2 (5 ms at 10 ms: a few pixels apart on its 10-inch panels), and every time
# within INSET_S of a certified peak
CURVE_STRIDE = 4


@dataclass(frozen=True)
class Trace:
    """One move in the pictures: label, deviation curve (t (T,) s, d (T,) m) and its cycle
    time (s); ``worst_s``: its worst case over the robust grid (robust mode); ``acc``: its
    samples ((n+1, 3) m/s^2), for plots of other responses over the same ``t``; ``breaks``:
    what a baseline breaks (the cell's constraints, the clearance), drawn as not allowed."""

    label: str
    t: np.ndarray
    d: np.ndarray
    cycle_s: float
    worst_s: float | None = None
    acc: np.ndarray | None = None
    breaks: str = ""  # what the move breaks (the cell's constraints, the clearance): "" if none

    @property
    def allowed(self) -> bool:
        return not self.breaks

    @property
    def objective_s(self) -> float:
        return self.cycle_s if self.worst_s is None else self.worst_s


def _styles(n: int) -> list[dict]:
    """Plot styles: the optimum (first) bold blue, then distinct colour/dash/marker each."""
    out = [{"color": OPTIMISED_COLOR, "ls": "-", "marker": "o", "lw": 2.2, "zorder": 5}]
    for i in range(n - 1):
        ls, marker = STYLES[i % len(STYLES)]
        color = BASELINE_COLORS[i % len(BASELINE_COLORS)]
        out.append({"color": color, "ls": ls, "marker": marker, "lw": 1.2, "zorder": 3})
    return out


def _same_profile_groups(acc: np.ndarray) -> list[list[int]]:
    """Moving axes grouped by equal acceleration samples (to 1e-9 of the largest; a diagonal
    move in x and y), so that one line stands for them all instead of hiding another."""
    groups: list[list[int]] = []
    scale = float(np.max(np.abs(acc)))
    for c in (c for c in range(3) if np.any(acc[:, c] != 0)):
        for group in groups:
            if np.allclose(acc[:, group[0]], acc[:, c], rtol=0, atol=1e-9 * scale):
                group.append(c)
                break
        else:
            groups.append([c])
    return groups


def _signs_reached(values: np.ndarray, limit: float) -> tuple[int, ...]:
    """The signs (+1, -1) of the limits an axis's ``values`` come near: a limit is drawn on
    a side the profile reaches beyond a quarter of it, not half a panel of unused limit."""
    return tuple(sign for sign in (1, -1) if (sign * values > 0.25 * limit).any())


def plot_profiles(path: str | os.PathLike, move: Move, limits: Limits, title: str = "") -> None:
    """Position, velocity, acceleration and jerk of every moving axis of ``move`` against
    time, with the per-axis limits (and path limits, if any) as dashed lines (module
    docstring)."""
    acc, dt_s = move.acc, move.dt_s
    vel, pos = integrate(move)
    t = dt_s * np.arange(acc.shape[0])
    jerk = np.diff(acc, axis=0) / dt_s
    groups = _same_profile_groups(acc)
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True, layout="constrained")
    panels = (
        ("position [m]", pos, None, None),
        ("velocity [m/s]", vel, limits.vmax, limits.vpath),
        ("acceleration [m/s^2]", acc, limits.amax, limits.apath),
        ("jerk [m/s^3]", jerk, limits.jmax, limits.jpath),
    )
    for ax, (label, values, per_axis, norm_limit) in zip(axes, panels, strict=True):
        for i, group in enumerate(groups):
            c = group[0]
            name = " = ".join(AXES[k] for k in group)
            style = {"ls": ("-", "--", ":")[i % 3], "lw": 2.0 - 0.4 * i, "label": name}
            if values is jerk:
                (line,) = ax.step(t, np.append(jerk[:, c], jerk[-1, c]), where="post", **style)
            else:
                (line,) = ax.plot(t, values[:, c], **style)
            if per_axis is not None:
                for sign in _signs_reached(values[:, c], per_axis[c]):
                    ax.axhline(sign * per_axis[c], color=line.get_color(), ls="--", lw=0.8)
        if norm_limit is not None and len(groups) + sum(len(g) - 1 for g in groups) > 1:
            ax.plot(
                t[: len(values)], np.linalg.norm(values, axis=1), color="k", lw=0.8, label="norm"
            )
            ax.axhline(norm_limit, color="k", ls="--", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8, title="axis",
                   title_fontsize=8)  # fmt: skip
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(
        title
        or f"optimised profile, {acc.shape[0] - 1} steps of {dt_s * 1e3:g} ms; dashed: the "
        "limits on the sides each axis comes near"
    )
    save_figure(fig, path)


def _saving_text(best: Trace, baseline: Trace | None, what: str) -> str:
    """The bar chart's title: the saving against the best allowed ``baseline`` (None: no
    baseline meets the cell's constraints)."""
    if baseline is None:
        return "no baseline meets the cell's constraints or the clearance (hatched: not allowed)"
    saving = baseline.objective_s - best.objective_s
    if saving < -1e-9:  # cannot happen against an allowed baseline (optim.choice)
        return f"{what} {-saving:.3f} s longer than the best feasible baseline ({baseline.label})"
    if saving <= 0:
        return f"{what} as short as the best feasible baseline ({baseline.label})"
    return (
        f"{saving:.3f} s ({100 * saving / baseline.objective_s:.1f} %) shorter {what} than "
        f"the best feasible baseline ({baseline.label})"
    )


def plot_comparison(
    path: str | os.PathLike,
    traces: list[Trace],
    threshold_m: float,
    floor_s: float,
    title: str,
) -> None:
    """deviation.png: ``traces[0]`` is the returned move, the others the baselines
    (module docstring); ``floor_s``: the kinematic floor (s). The saving is against the
    best baseline that is allowed (meets the cell's constraints and the clearance); the
    others are marked; deviations below the axis (1 % of the threshold) run along it."""
    robust = traces[0].worst_s is not None
    what = "worst case" if robust else "cycle"
    best, others = traces[0], traces[1:]
    allowed = [tr for tr in others if tr.allowed]
    baseline = min(allowed, key=lambda tr: tr.objective_s) if allowed else None
    fig, (ax, ax_bar) = plt.subplots(
        1, 2, figsize=(13, 5.4), gridspec_kw={"width_ratios": [2.0, 1]}, layout="constrained"
    )
    styles = _styles(len(traces))
    floor_mm = threshold_m * 1e3 / 100  # deviation_axes' lower limit
    for trace, style in zip(traces, styles, strict=True):
        note = "" if trace.allowed else " (not allowed)"
        ax.plot(
            trace.t,
            np.maximum(np.asarray(trace.d) * 1e3, floor_mm),
            color=style["color"],
            ls=style["ls"],
            lw=style["lw"] if trace.allowed else 0.9,
            alpha=1.0 if trace.allowed else 0.6,
            zorder=style["zorder"],
            label=f"{trace.label}: cycle {trace.cycle_s:.3f} s{note}",
        )
    deviation_axes(ax, threshold_m)
    ax.set_ylim(bottom=floor_mm)
    ax.axvline(
        best.cycle_s,
        color=OPTIMISED_COLOR,
        lw=1.2,
        zorder=6,
        label=f"cycle time of {best.label}: {best.cycle_s:.3f} s",
    )
    if baseline is not None:
        ax.axvline(
            baseline.cycle_s,
            color="0.2",
            ls=":",
            lw=1.4,
            label=f"cycle time of the best feasible baseline: {baseline.cycle_s:.3f} s",
        )
    ax.set_xlabel("time [s] (deviations below the axis drawn along it)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8)
    ax.set_title(title, fontsize=10)

    _cycle_bars(ax_bar, traces, styles, floor_s, robust)
    ax_bar.set_title(_saving_text(best, baseline, what), fontsize=9, wrap=True)
    save_figure(fig, path)


def _cycle_bars(ax, traces: list[Trace], styles: list[dict], floor_s: float, robust: bool):
    """Horizontal bars from the kinematic floor to each move's objective (robust: the worst
    case, with the nominal cycle as a tick); bars beyond the axis are clipped and labelled."""
    values = [tr.objective_s for tr in traces]
    allowed = [tr.objective_s for tr in traces[1:] if tr.allowed]
    best_baseline = min(allowed or values[1:], default=values[0])
    right = min(max(values), floor_s + 3.0 * max(best_baseline - floor_s, 0.05 * floor_s))
    left = floor_s - 0.15 * (right - floor_s)
    rows = np.arange(len(traces))[::-1]
    for row, trace, style in zip(rows, traces, styles, strict=True):
        end = min(trace.objective_s, right)
        ax.barh(
            row, end - floor_s, left=floor_s, color=style["color"], height=0.6,
            alpha=0.8 if trace.allowed else 0.35, hatch=None if trace.allowed else "///",
            edgecolor="0.3" if not trace.allowed else None,
        )  # fmt: skip
        clipped = trace.objective_s > right
        ax.text(
            end if not clipped else right,
            row,
            f" {trace.objective_s:.3f} s" + (" >" if clipped else ""),
            va="center",
            ha="left" if not clipped else "right",
            fontsize=8,
            color="k" if not clipped else "w",
        )
        if robust and trace.cycle_s <= right:
            ax.plot([trace.cycle_s] * 2, [row - 0.3, row + 0.3], color="k", lw=1.5)
    ax.axvline(floor_s, color="k", lw=1)
    labels = [
        tr.label if tr.allowed else fill(f"{tr.label} - not allowed: {tr.breaks}", 34)
        for tr in traces
    ]
    ax.set_yticks(rows, labels, fontsize=7)
    ax.set_xlim(left, right + 0.25 * (right - floor_s))
    ax.set_xlabel(
        ("worst-case cycle time [s] (|: nominal model)" if robust else "cycle time [s]")
        + f"\nfrom the kinematic floor {floor_s:.3f} s"
    )
    ax.grid(True, axis="x", alpha=0.3)


def plot_worst_case(path: str | os.PathLike, trace: Trace, threshold_m: float) -> None:
    """The optimum's deviation at its worst point of the robust grid."""
    fig, ax = plt.subplots(figsize=(8, 4), layout="constrained")
    ax.plot(trace.t, np.asarray(trace.d) * 1e3, color=OPTIMISED_COLOR, lw=1.5, label=trace.label)
    deviation_axes(ax, threshold_m)
    ax.axvline(trace.cycle_s, color=OPTIMISED_COLOR, lw=1, label=f"cycle {trace.cycle_s:.3f} s")
    ax.set_xlabel("time [s]")
    fig.legend(loc="outside lower center", ncol=3, fontsize=8)  # below the data
    ax.set_title("Optimised move at its worst case over the robust grid", fontsize=10)
    save_figure(fig, path)


def _robust_top(series: dict[str, list[dict]]) -> float:
    """The top of robust.png's time axis (s): the optimum's and the best baseline's whole
    range and a third of their gap above, so that a tenth of a second between them reads
    at a glance; moves beyond it run off the top (their legend entry says how far)."""
    worst = {label: max(g["cycle_time_s"] for g in grid) for label, grid in series.items()}
    first, *others = worst
    best_other = min((worst[label] for label in others), default=worst[first])
    low = min(g["cycle_time_s"] for grid in series.values() for g in grid)
    high = max(worst[first], best_other)
    return high + max(0.35 * (high - low), 0.02 * high)


def plot_robust(path: str | os.PathLike, series: dict[str, list[dict]], title: str) -> None:
    """Exact cycle time against the frequency scale, one panel per damping ratio, for the
    optimum (first entry of ``series``) and every baseline. ``series`` maps a label to grid
    entries {"freq_scale", "zeta", "cycle_time_s"}. A linear time axis from the shortest
    time to just above the optimum's and the best baseline's (:func:`_robust_top`): the gap
    between them is what the picture shows; a move beyond it runs off the top, its worst
    case in the legend."""
    zetas = sorted({g["zeta"] for grid in series.values() for g in grid}, key=lambda z: z or 0)
    fig, axes = plt.subplots(
        1,
        len(zetas),
        figsize=(4.2 * len(zetas) + 3.2, 4.2),
        sharey=True,
        squeeze=False,
        layout="constrained",
    )
    styles = _styles(len(series))
    top = _robust_top(series)
    low = min(g["cycle_time_s"] for grid in series.values() for g in grid)
    for ax, zeta in zip(axes[0], zetas, strict=True):
        for (label, grid), style in zip(series.items(), styles, strict=True):
            points = sorted((g["freq_scale"], g["cycle_time_s"]) for g in grid if g["zeta"] == zeta)
            if points:
                s, c = zip(*points, strict=True)
                worst = max(g["cycle_time_s"] for g in grid)
                beyond = " - off the top" if worst > top else ""
                ax.plot(
                    s,
                    c,
                    color=style["color"],
                    ls=style["ls"],
                    marker=style["marker"],
                    lw=style["lw"],
                    zorder=style["zorder"],
                    ms=4,
                    mfc="none" if style["zorder"] < 5 else style["color"],
                    label=f"{label} (worst {worst:.3f} s{beyond})",
                )
        ax.set_ylim(low - 0.1 * (top - low), top)
        ax.set_xlabel("frequency scale (all modes)")
        ax.set_title("model damping" if zeta is None else f"zeta = {zeta:g}", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("exact cycle time [s]")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right center", fontsize=8)
    fig.suptitle(title)
    save_figure(fig, path)


def _constraint_range(name: str, limit: float, moves: list[np.ndarray]) -> tuple[float, float]:
    """The y range of a constraint's panel, zoomed to its limit: a distance from 0 to three
    times the limit (or the optimum's closest approach, ``moves[0]``, a fifth above it); a
    load from 0 to a tenth above the largest of the limit, the optimum's peak and the other
    moves' peaks up to 1.5 times the limit (a baseline that breaks the limit shows by how
    much, within reason)."""
    if "distance" in name:
        return 0.0, max(3.0 * limit, 1.2 * float(np.min(moves[0])))
    others = max((float(np.max(v)) for v in moves[1:]), default=0.0)
    return 0.0, 1.1 * max(limit, float(np.max(moves[0])), min(others, 1.5 * limit))


def constraint_times(t: np.ndarray, certified_s) -> np.ndarray:
    """The times (s) of ``t`` ((T,) s, increasing: the deviation curves' grid) at which
    constraints.png evaluates the constraints: every CURVE_STRIDE-th, the last, and every one
    within INSET_S of a certified peak's time ``certified_s`` (s; non-finite ones ignored),
    where the panels mark the certified value and the distance's inset zooms in. The
    curves' exact evaluation over every point and item is what the picture costs; a panel
    shows no more than one sample per few pixels elsewhere."""
    t = np.asarray(t, dtype=np.float64)
    keep = np.zeros(t.size, dtype=bool)
    keep[::CURVE_STRIDE] = True
    keep[-1:] = True
    for when in certified_s:
        if when is not None and np.isfinite(when):
            keep |= np.abs(t - when) <= INSET_S
    return t[keep]


def _closest_inset(ax, moves: dict, limit: float, when: float, value: float, scale: float):
    """An inset of the distance panel ``ax``: INSET_S (60 ms) either side of the certified
    closest approach (``when`` s, ``value`` and ``limit`` in the panel's unit), where the
    part passes the obstacle: the margin over the limit reads there."""
    inset = ax.inset_axes([0.56, 0.34, 0.3, 0.5])
    styles = _styles(len(moves))
    for (t, values), style in zip(moves.values(), styles, strict=True):
        near = np.abs(np.asarray(t) - when) <= INSET_S
        inset.plot(np.asarray(t)[near], np.asarray(values)[near] * scale, color=style["color"],
                   ls=style["ls"], lw=1.2)  # fmt: skip
    inset.axhline(limit, color="k", ls="--", lw=0.8)
    inset.plot([when], [value], "k+", ms=9, mew=1.5)
    inset.set_xlim(when - INSET_S, when + INSET_S)
    inset.set_ylim(0.9 * limit, 2.0 * limit)
    inset.set_title(f"{when:.3f} s +- {INSET_S * 1e3:g} ms", fontsize=7)
    inset.tick_params(labelsize=6)
    inset.grid(True, alpha=0.3)


def plot_constraints(
    path: str | os.PathLike,
    curves: dict[str, dict[str, tuple]],
    limits: dict[str, float],
    cycle_s: float | None = None,
    certified: dict[str, tuple[float, float]] | None = None,
) -> None:
    """One panel per cell constraint (``curves``: name -> {move label: (t (T,), values (T,))},
    the optimum first) with its limit (``limits``: name -> value) as a dashed line: the
    largest cup utilisation, the largest von Mises stress, the smallest distance to the
    obstacles over time; each zoomed to its limit (:func:`_constraint_range`), the
    optimum's cycle time ``cycle_s`` marked and its certified value (``certified``: name
    -> (time s, value)) where it occurs; the legend beside the panels."""
    fig, axes = plt.subplots(
        len(curves), 1, figsize=(10, 2.9 * len(curves)), squeeze=False, layout="constrained"
    )
    certified = certified or {}
    for ax, (name, moves) in zip(axes[:, 0], curves.items(), strict=True):
        scale, unit = (
            (1e-6, "MPa") if "stress" in name else (1e3, "mm") if "distance" in name else (1.0, "")
        )
        styles = _styles(len(moves))
        for (label, (t, values)), style in zip(moves.items(), styles, strict=True):
            ax.plot(t, values * scale, label=label, color=style["color"], ls=style["ls"],
                    lw=1.6 if style["zorder"] == 5 else 0.9, zorder=style["zorder"])  # fmt: skip
        limit = limits[name]
        ax.axhline(limit * scale, color="k", ls="--", lw=0.8, label="limit")
        low, high = _constraint_range(name, limit, [values for _, values in moves.values()])
        ax.set_ylim(low * scale, high * scale)
        if cycle_s is not None:
            ax.axvline(cycle_s, color=OPTIMISED_COLOR, lw=1, ls=":", label="cycle time")
        if name in certified and np.isfinite(certified[name][0]):
            when, value = certified[name]
            ax.plot([when], [value * scale], "k+", ms=10, mew=1.5, zorder=7,
                    label=f"certified: {value * scale:.4g} {unit} at {when:.3f} s")  # fmt: skip
            if "distance" in name:
                _closest_inset(ax, moves, limit * scale, when, value * scale, scale)
        ax.set_ylabel(f"{name}{f' [{unit}]' if unit else ''}", fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(
        "cell constraints of the optimised move and the baselines, each zoomed to its limit "
        "(dashed)",
        fontsize=10,
    )
    save_figure(fig, path)


def plot_turn(path: str | os.PathLike, traces: list[Trace], turns: list[np.ndarray], dt_s: float):
    """Angle (degrees) and angular rate (rad/s) against time of each move of ``traces``
    (their labels and cycle times) with its angular acceleration samples ``turns`` (n+1,)
    rad/s^2, the optimum first."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, layout="constrained")
    styles = _styles(len(traces))
    for trace, alpha, style in zip(traces, turns, styles, strict=True):
        padded = np.zeros((alpha.size, 3))
        padded[:, 0] = alpha
        rate, angle = (v[:, 0] for v in integrate(padded, dt_s))
        t = dt_s * np.arange(alpha.size)
        label = f"{trace.label} (cycle {trace.cycle_s:.3f} s)"
        every = max(1, alpha.size // 10)
        top.plot(t, np.degrees(angle), label=label, markevery=every, **style)
        bottom.plot(t, rate, markevery=every, **style)
    top.set_ylabel("angle [deg]")
    bottom.set_ylabel("angular rate [rad/s]")
    bottom.set_xlabel("time [s]")
    fig.legend(loc="outside right center", fontsize=8)  # beside both panels, off the data
    top.set_title("The turn of the optimised move and of the baselines", fontsize=10)
    save_figure(fig, path)
