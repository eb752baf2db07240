"""Pictures of an optimisation result (PNG, written atomically via jaxflex.plots)."""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np

from jaxflex.plots import plot_deviation, save_figure
from jaxflex.profile import integrate
from optim.limits import AXES, Limits


def plot_profiles(path: str | os.PathLike, acc: np.ndarray, dt_s: float, limits: Limits) -> None:
    """Position, velocity, acceleration and jerk of every moving axis against time, with
    the per-axis limits (and path limits, if any) drawn as dashed lines."""
    vel, pos = integrate(acc, dt_s)
    t = dt_s * np.arange(acc.shape[0])
    jerk = np.diff(acc, axis=0) / dt_s
    moving = [c for c in range(3) if np.any(acc[:, c] != 0)]
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    panels = (
        ("position [m]", pos, None, None),
        ("velocity [m/s]", vel, limits.vmax, limits.vpath),
        ("acceleration [m/s^2]", acc, limits.amax, limits.apath),
        ("jerk [m/s^3]", jerk, limits.jmax, limits.jpath),
    )
    for ax, (label, values, per_axis, norm_limit) in zip(axes, panels, strict=True):
        for c in moving:
            if values is jerk:
                (line,) = ax.step(
                    t, np.append(jerk[:, c], jerk[-1, c]), where="post", label=AXES[c]
                )
            else:
                (line,) = ax.plot(t, values[:, c], label=AXES[c])
            if per_axis is not None:
                for sign in (1, -1):
                    ax.axhline(sign * per_axis[c], color=line.get_color(), ls="--", lw=0.8)
        if norm_limit is not None:
            steps = t[: len(values)]
            ax.plot(steps, np.linalg.norm(values, axis=1), color="k", lw=0.8, label="norm")
            ax.axhline(norm_limit, color="k", ls="--", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title("optimised profile; dashed: limits")
    save_figure(fig, path)


def plot_deviations(path, curves: dict, threshold_m: float, title: str) -> None:
    """Deviation against time for the optimum and the baselines (jaxflex.plots)."""
    plot_deviation(path, curves, threshold_m, title=title)


def plot_robust(path: str | os.PathLike, series: dict[str, list[dict]], title: str) -> None:
    """Exact cycle time against the frequency scale, one panel per damping ratio, for the
    optimum and every baseline. ``series`` maps a label to grid entries
    {"freq_scale", "zeta", "cycle_time_s"}."""
    zetas = sorted({g["zeta"] for grid in series.values() for g in grid}, key=lambda z: z or 0)
    fig, axes = plt.subplots(
        1, len(zetas), figsize=(4.5 * len(zetas), 4), sharey=True, squeeze=False
    )
    for ax, zeta in zip(axes[0], zetas, strict=True):
        for label, grid in series.items():
            points = sorted((g["freq_scale"], g["cycle_time_s"]) for g in grid if g["zeta"] == zeta)
            if points:
                s, c = zip(*points, strict=True)
                ax.plot(s, c, marker="o", ms=3, label=f"{label} (worst {max(c):.3f} s)")
        ax.set_yscale("log")
        ax.set_xlabel("frequency scale")
        ax.set_title("model damping" if zeta is None else f"zeta = {zeta:.3g}")
        ax.grid(True, alpha=0.3)
    axes[0][0].set_ylabel("exact cycle time [s]")
    axes[0][0].legend(fontsize=7)
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
