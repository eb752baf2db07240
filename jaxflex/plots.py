"""Pictures users get next to the numbers (matplotlib, written atomically as PNG)."""

from __future__ import annotations

import os
from collections.abc import Mapping

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from jaxflex.atomic import atomic_open


def save_figure(fig, path: str | os.PathLike) -> None:
    """Save ``fig`` as PNG atomically and close it."""
    with atomic_open(path, "wb") as handle:
        fig.savefig(handle, format="png", dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_deviation(
    path: str | os.PathLike,
    curves: Mapping[str, tuple[np.ndarray, np.ndarray, float]],
    threshold_m: float,
    title: str = "",
) -> None:
    """Deviation against time for several moves: ``curves`` maps a label to
    (t (T,) s, deviation (T,) m, cycle time s). The threshold is drawn, each cycle time marked."""
    fig, ax = plt.subplots(figsize=(8, 4))
    for label, (t, d, cycle_s) in curves.items():
        (line,) = ax.plot(t, np.asarray(d) * 1e3, lw=1.2, label=f"{label}: cycle {cycle_s:.3f} s")
        ax.axvline(cycle_s, color=line.get_color(), ls=":", lw=1)
    ax.axhline(
        threshold_m * 1e3, color="k", ls="--", lw=1, label=f"threshold {threshold_m * 1e3:g} mm"
    )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("deviation max_p |u_p| [mm]")
    ax.set_yscale("log")
    ax.set_ylim(bottom=threshold_m * 1e3 / 100)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    if title:
        ax.set_title(title)
    save_figure(fig, path)
