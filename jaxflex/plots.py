"""Pictures users get next to the numbers (matplotlib, written atomically as PNG)."""

from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.ticker import FuncFormatter

from jaxflex._atomic import atomic_open

__all__ = ["PLAIN", "PLAIN_MINOR", "deviation_axes", "plt", "save_figure"]


DPI = 120


def save_figure(fig, path: str | os.PathLike) -> None:
    """Save ``fig`` as PNG (DPI dots per inch) atomically and close it. A figure without a
    layout engine is trimmed to its drawn extent (bbox "tight": one more draw); a
    constrained layout already fits its page: it is laid out once here, at the saved
    resolution, and the figure drawn once (savefig would draw it twice, once without
    rendering to lay it out)."""
    engine = fig.get_layout_engine()
    with atomic_open(path, "wb") as handle:
        if engine is None:
            fig.savefig(handle, format="png", dpi=DPI, bbox_inches="tight")
        else:
            fig.set_dpi(DPI)
            engine.execute(fig)
            fig.set_layout_engine("none")
            # the canvas that laid it out draws it: its renderer's text metrics are reused
            canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
            canvas.print_png(handle)
    plt.close(fig)


def _plain(value: float, _pos=None) -> str:
    """Tick labels as plain numbers (0.01, 0.5, 2, 100), not 2x10^0."""
    return f"{value:g}"


def _plain_minor(value: float, _pos=None) -> str:
    """Minor tick labels of a log axis spanning decades: only 2 and 5 (x 10^k), plain."""
    mantissa = value / 10 ** math.floor(math.log10(value))
    return f"{value:g}" if min(abs(mantissa - 2), abs(mantissa - 5)) < 1e-6 else ""


PLAIN = FuncFormatter(_plain)
PLAIN_MINOR = FuncFormatter(_plain_minor)


def deviation_axes(ax, threshold_m: float, *, label: bool = True) -> None:
    """Make ``ax`` a deviation axis: log scale in mm, the threshold drawn (and in the legend
    if ``label``), two decades below it shown, a grid."""
    ax.axhline(
        threshold_m * 1e3,
        color="k",
        ls="--",
        lw=1,
        label=f"threshold {threshold_m * 1e3:g} mm" if label else None,
    )
    ax.set_yscale("log")
    ax.set_ylim(bottom=threshold_m * 1e3 / 100)
    ax.yaxis.set_major_formatter(PLAIN)
    ax.set_ylabel("deviation max_p |u_p| [mm]")
    ax.grid(True, which="major", alpha=0.3)
