"""Pictures of an optimisation result (PNG, written atomically via jaxflex.plots).

* ``profiles.png``: position, velocity, acceleration and jerk of each moving axis with the
  limits; axes with the same profile are drawn once and named together ("x = y");
* ``deviation.png``: the deviation of the optimum and of every baseline against the
  threshold (left), the cycle time of each (right, from the kinematic floor), the optimum's
  saving over the best baseline written on both;
* ``robust.png``: the exact cycle time across the robust grid, one panel per damping ratio,
  every move with its own line style and marker, one legend;
* ``deviation_worst_case.png``: the optimum at its worst point of the grid;
* ``turn.png`` (moves that turn the part): the angle and the angular rate of the optimum
  and of every baseline.

Each picture is one function of plain data (``Trace``, grids of dicts), so a new output
(another constraint, another move to compare) is one more trace or one more panel.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import matplotlib.pyplot as plt
import numpy as np

from jaxflex.plots import PLAIN, deviation_axes, save_figure
from jaxflex.response import Move, integrate
from optim.limits import AXES, Limits

OPTIMISED_COLOR = "tab:blue"
# line style and marker per series after the optimum (baselines), distinct even in grey
STYLES = (("-", "o"), ("--", "s"), ("-.", "^"), (":", "D"), ((0, (5, 1)), "v"), ("-", "P"))
BASELINE_COLORS = ("tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")


@dataclass(frozen=True)
class Trace:
    """One move in the pictures: label, deviation curve (t (T,) s, d (T,) m) and its cycle
    time (s); ``worst_s``: its worst case over the robust grid (robust mode); ``acc``: its
    samples ((n+1, 3) m/s^2), for plots of other responses over the same ``t``."""

    label: str
    t: np.ndarray
    d: np.ndarray
    cycle_s: float
    worst_s: float | None = None
    acc: np.ndarray | None = None

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


def plot_profiles(path: str | os.PathLike, move: Move, limits: Limits, title: str = "") -> None:
    """Position, velocity, acceleration and jerk of every moving axis of ``move`` against
    time, with the per-axis limits (and path limits, if any) as dashed lines (module
    docstring)."""
    acc, dt_s = move.acc, move.dt_s
    vel, pos = integrate(move)
    t = dt_s * np.arange(acc.shape[0])
    jerk = np.diff(acc, axis=0) / dt_s
    groups = _same_profile_groups(acc)
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
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
                for sign in (1, -1):
                    ax.axhline(sign * per_axis[c], color=line.get_color(), ls="--", lw=0.8)
        if norm_limit is not None and len(groups) + sum(len(g) - 1 for g in groups) > 1:
            ax.plot(
                t[: len(values)], np.linalg.norm(values, axis=1), color="k", lw=0.8, label="norm"
            )
            ax.axhline(norm_limit, color="k", ls="--", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize=8, title="axis", title_fontsize=8)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(
        title or f"optimised profile, {acc.shape[0] - 1} steps of {dt_s * 1e3:g} ms; dashed: limits"
    )
    save_figure(fig, path)


def _saving_text(best: Trace, baseline: Trace, what: str) -> str:
    saving = baseline.objective_s - best.objective_s
    if saving < -1e-9:  # that baseline breaks the clearance or a cell constraint
        label = f"{baseline.label}, not allowed"
        return f"{what} {-saving:.3f} s longer than the best baseline ({label})"
    if saving <= 0:
        return f"{what} as short as the best baseline ({baseline.label})"
    return (
        f"{saving:.3f} s ({100 * saving / baseline.objective_s:.1f} %) shorter {what} than "
        f"the best baseline ({baseline.label})"
    )


def plot_comparison(
    path: str | os.PathLike,
    traces: list[Trace],
    threshold_m: float,
    floor_s: float,
    title: str,
) -> None:
    """deviation.png: ``traces[0]`` is the returned move, the others the baselines
    (module docstring); ``floor_s``: the kinematic floor (s)."""
    robust = traces[0].worst_s is not None
    what = "worst case" if robust else "cycle"
    best, others = traces[0], traces[1:]
    baseline = min(others, key=lambda tr: tr.objective_s) if others else None
    fig, (ax, ax_bar) = plt.subplots(
        1, 2, figsize=(12, 4.6), gridspec_kw={"width_ratios": [2.2, 1]}, layout="constrained"
    )
    styles = _styles(len(traces))
    for trace, style in zip(traces, styles, strict=True):
        ax.plot(
            trace.t,
            np.asarray(trace.d) * 1e3,
            color=style["color"],
            ls=style["ls"],
            lw=style["lw"],
            zorder=style["zorder"],
            label=f"{trace.label}: cycle {trace.cycle_s:.3f} s",
        )
    deviation_axes(ax, threshold_m)
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
            label=f"cycle time of the best baseline: {baseline.cycle_s:.3f} s",
        )
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title, fontsize=10)

    _cycle_bars(ax_bar, traces, styles, floor_s, robust)
    if baseline is not None:
        ax_bar.set_title(_saving_text(best, baseline, what), fontsize=9, wrap=True)
    save_figure(fig, path)


def _cycle_bars(ax, traces: list[Trace], styles: list[dict], floor_s: float, robust: bool):
    """Horizontal bars from the kinematic floor to each move's objective (robust: the worst
    case, with the nominal cycle as a tick); bars beyond the axis are clipped and labelled."""
    values = [tr.objective_s for tr in traces]
    best_baseline = min(values[1:], default=values[0])
    right = min(max(values), floor_s + 3.0 * max(best_baseline - floor_s, 0.05 * floor_s))
    left = floor_s - 0.15 * (right - floor_s)
    rows = np.arange(len(traces))[::-1]
    for row, trace, style in zip(rows, traces, styles, strict=True):
        end = min(trace.objective_s, right)
        ax.barh(row, end - floor_s, left=floor_s, color=style["color"], alpha=0.8, height=0.6)
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
    ax.set_yticks(rows, [tr.label for tr in traces], fontsize=8)
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
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("Optimised move at its worst case over the robust grid", fontsize=10)
    save_figure(fig, path)


def plot_robust(path: str | os.PathLike, series: dict[str, list[dict]], title: str) -> None:
    """Exact cycle time against the frequency scale, one panel per damping ratio, for the
    optimum (first entry of ``series``) and every baseline. ``series`` maps a label to grid
    entries {"freq_scale", "zeta", "cycle_time_s"}. The y axis is logarithmic with plain
    tick labels when the times span more than a factor 3."""
    zetas = sorted({g["zeta"] for grid in series.values() for g in grid}, key=lambda z: z or 0)
    fig, axes = plt.subplots(
        1,
        len(zetas),
        figsize=(4.2 * len(zetas) + 2.8, 4),
        sharey=True,
        squeeze=False,
        layout="constrained",
    )
    styles = _styles(len(series))
    every = [g["cycle_time_s"] for grid in series.values() for g in grid]
    spread = max(every) / min(every)
    for ax, zeta in zip(axes[0], zetas, strict=True):
        for (label, grid), style in zip(series.items(), styles, strict=True):
            points = sorted((g["freq_scale"], g["cycle_time_s"]) for g in grid if g["zeta"] == zeta)
            if points:
                s, c = zip(*points, strict=True)
                worst = max(g["cycle_time_s"] for g in grid)
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
                    label=f"{label} (worst {worst:.3f} s)",
                )
        if spread > 3:
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(PLAIN)
            ax.yaxis.set_minor_formatter(PLAIN)
        ax.set_xlabel("frequency scale (all modes)")
        ax.set_title("model damping" if zeta is None else f"zeta = {zeta:g}", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("exact cycle time [s]")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right center", fontsize=8)
    fig.suptitle(title)
    save_figure(fig, path)


def plot_constraints(
    path: str | os.PathLike, curves: dict[str, dict[str, tuple]], limits: dict[str, float]
) -> None:
    """One panel per cell constraint (``curves``: name -> {move label: (t (T,), values (T,))})
    with its limit (``limits``: name -> value) as a dashed line: the largest cup utilisation,
    the largest von Mises stress, the smallest distance to the obstacles over time."""
    fig, axes = plt.subplots(len(curves), 1, figsize=(8, 2.8 * len(curves)), squeeze=False)
    for ax, (name, moves) in zip(axes[:, 0], curves.items(), strict=True):
        scale, unit = (
            (1e-6, "MPa") if "stress" in name else (1e3, "mm") if "distance" in name else (1.0, "")
        )
        for label, (t, values) in moves.items():
            ax.plot(t, values * scale, label=label, lw=1.2 if label == "optimised" else 0.8)
        ax.axhline(limits[name] * scale, color="k", ls="--", lw=0.8, label="limit")
        ax.set_ylabel(f"{name}{f' [{unit}]' if unit else ''}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title("cell constraints: optimised move and baselines (dashed: limit)")
    save_figure(fig, path)


def plot_turn(path: str | os.PathLike, traces: list[Trace], turns: list[np.ndarray], dt_s: float):
    """Angle (degrees) and angular rate (rad/s) against time of each move of ``traces``
    (their labels and cycle times) with its angular acceleration samples ``turns`` (n+1,)
    rad/s^2, the optimum first."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, layout="constrained")
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
    top.legend(loc="lower right", fontsize=8)
    top.set_title("The turn of the optimised move and of the baselines", fontsize=10)
    save_figure(fig, path)
