"""PNG charts of the bench: accuracy against time per scene, and the stability chart."""

from __future__ import annotations

import os
import textwrap

import numpy as np

from fem.bench.accuracy import pareto_front
from fem.bench.methods import LABELS
from jaxflex.plots import PLAIN, PLAIN_MINOR, plt, save_figure

STYLE = {
    "scan64": ("C0", "o"),
    "scan32": ("C9", "s"),
    "convolution": ("C1", "D"),
    "newmark": ("C2", "^"),
    "central_difference": ("C3", "v"),
    "fe_newmark": ("C7", "P"),
}
ERROR_KEY = "samples_linf_rel_peak"
FLOOR = 1e-7  # errors below are drawn at the floor (log axis)
TITLE_WIDTH = 90  # characters per title line: titles wrap at words, never cut


def pareto_chart(scene: dict, path: str | os.PathLike) -> None:
    """Error (L-infinity of the deviation at the method's samples, relative to the reference
    peak) against wall time, every run as a marker, each method's Pareto front as a line."""
    fig, ax = plt.subplots(figsize=(8, 5.5), layout="constrained")
    points = scene["points"]
    for method, (color, marker) in STYLE.items():
        mine = [p for p in points if p["method"] == method]
        if not mine:
            continue
        t = np.array([p["time_s"] for p in mine])
        e = np.array([p[ERROR_KEY] for p in mine])
        finite = np.isfinite(e)
        ax.scatter(
            t[finite], np.maximum(e[finite], FLOOR), color=color, marker=marker, s=28, alpha=0.7
        )
        front = pareto_front(mine, ERROR_KEY)
        ax.plot(
            [p["time_s"] for p in front],
            [max(p[ERROR_KEY], FLOOR) for p in front],
            color=color,
            lw=1.5,
            label=LABELS[method],
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(PLAIN)
    ax.yaxis.set_minor_formatter(PLAIN_MINOR)
    ax.set_xlabel("wall time per evaluation [s] (compiled, best of repeats)")
    ax.set_ylabel("L-inf error of the deviation / reference peak")
    fe = scene["fe"]
    title = (
        f"{scene['scene']['name']}: {fe['formulation']}, {fe['n_dof']} DOFs, "
        f"{fe['n_points']} points; reference: full-order FE (h = {fe['reference_h_s']:.2g} s)"
    )
    ax.set_title(textwrap.fill(title, TITLE_WIDTH), fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    save_figure(fig, path)


def stability_chart(stab: dict, path: str | os.PathLike) -> None:
    """Three panels: error of each method against omega dt (one mode), settle-time error of
    step sampling against jaxflex.analyze_move, float32 drift against the horizon."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")
    w = np.asarray(stab["omega_dt"])
    ax = axes[0]
    for method, values in stab["error_rel_peak"].items():
        color, marker = STYLE[method]
        v = np.asarray(values, dtype=float)
        v = np.where(np.isfinite(v), np.clip(v, 1e-16, 1e3), 1e3)
        ax.plot(w, v, color=color, marker=marker, ms=4, label=LABELS[method])
    ax.axvline(2.0, color="k", ls=":", lw=1, label="w dt = 2 (central difference limit)")
    ax.set(xscale="log", yscale="log", xlabel="omega dt", ylabel="max error / peak")
    ax.text(0.02, 0.98, "unstable: clipped at 1e3", transform=ax.transAxes, va="top", fontsize=7)
    ax.set_title("one mode after an impulse, 2000 steps", fontsize=9)
    ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 0.16))  # the empty middle
    ax = axes[1]
    for name, color in (("step_sampled", "C3"), ("analyze_move", "C0")):
        v = np.abs(np.asarray(stab["settle_error_s"][name], dtype=float)) * 1e3
        label = "deviation read at the steps" if name == "step_sampled" else "jaxflex.analyze_move"
        ax.plot(w, np.maximum(v, 1e-6), color=color, marker="o", ms=4, label=label)
    ax.set(xscale="log", yscale="log", xlabel="omega dt", ylabel="|settle-time error| [ms]")
    ax.set_title("settle time (5 % threshold) vs 64x finer evaluation", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[2]
    steps = np.array([int(k) for k in stab["float32_drift"]])
    drift = np.array(list(stab["float32_drift"].values()))
    ax.plot(steps, drift, color="C9", marker="s", label="scan float32 vs float64")
    ax.set(xscale="log", yscale="log", xlabel="steps (dt = 10 ms)", ylabel="max error / peak")
    ax.set_title("float32 drift, undamped 1 Hz mode", fontsize=9)
    ax.yaxis.set_major_formatter(PLAIN)
    ax.yaxis.set_minor_formatter(PLAIN)  # less than a decade: every minor tick labelled
    ax.legend(fontsize=7)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    save_figure(fig, path)
