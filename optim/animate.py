"""See it move: the part bending along its move through the cell, for ParaView and a browser.

:func:`animate` (``jaxflex optimize ... --animate``; ``jaxflex animate RESULT_DIR`` for a
result written before) writes into ``RESULT_DIR/animation/`` one set of files
(jaxflex._fileset, kind ``jaxflex.animation``):

* ``part.xdmf`` over ``part.h5``: the part's surface at every frame, for ParaView
  (optim.animate_series; the fields it carries are listed there);
* ``cell.vtu`` (the obstacles) and ``path.vtu`` (the path of the part frame's origin, the
  via points);
* ``animation.html``: one self-contained page for a browser (optim.animate_page).

The frames are the engine's own response (optim.animate_frames): every sample of the move
and of the settling until the cycle time and a quarter of it after, and a straight move's
certified closest approach to an obstacle where it falls between samples.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jaxflex.files import make_output_dir, writing
from jaxflex.runtime import step
from optim.animate_frames import (
    ANIMATION_KIND,
    Frames,
    Scene,
    engine_frames,
    frame_times,
    scene_of_directory,
    scene_of_result,
)
from optim.animate_page import page_data, page_frames, page_html
from optim.animate_series import write_cell, write_series
from optim.animate_surface import mid_surface, node_normals, reduced, skins
from optim.result_files import ANIMATION_DIR, MAX_FRAMES, MAX_VERTICES, PAGE, SERIES, series_names
from optim.result_files import check_animation_dir as check_animation_dir  # its home: light

__all__ = ["Animation", "animate", "animate_directory"]


@dataclass(frozen=True)
class Animation:
    """What :func:`animate` wrote: the ``directory``, the ParaView ``series`` (part.xdmf),
    the ``page``, the ``frames`` (optim.animate_frames.Frames), the page's frame and point
    counts and its size in bytes, the ``notes`` it states and the CPU time of each stage
    ``cpu_s`` (frames, series, page; s, this process)."""

    directory: Path
    series: Path
    page: Path
    frames: Frames
    page_frames: int
    page_points: int
    page_bytes: int
    notes: tuple[str, ...]
    cpu_s: dict

    def summary(self) -> str:
        frames = len(self.frames.t_s)
        return (
            f"animation: {frames} frames to {self.frames.t_s[-1]:.3f} s in {self.series} "
            f"(ParaView), {self.page} ({self.page_bytes / 1e6:.1f} MB: {self.page_frames} "
            f"frames, {self.page_points} points)"
        )


def write_animation(
    scene: Scene,
    result_dir: str | os.PathLike,
    *,
    max_vertices: int = MAX_VERTICES,
    max_frames: int = MAX_FRAMES,
    after_s: float | None = None,
) -> Animation:
    """Write the animation of ``scene`` into ``result_dir``/animation (module docstring)."""
    cpu = [time.process_time()]
    t_s, on_grid = frame_times(scene, after_s)
    step(f"animation: the engine's response at {len(t_s)} frames, {scene.model.n_points} points")
    frames = engine_frames(scene, t_s, on_grid)
    cpu.append(time.process_time())
    mid = mid_surface(scene.model)
    normals = node_normals(scene.model.points, mid.triangles) if len(mid.triangles) else None
    half = scene.half_thickness_m
    surface = skins(mid) if half and normals is not None else mid
    if normals is None:
        normals = 0.0 * scene.model.points
    shown = page_frames(scene, frames, max_frames)
    small = reduced(scene.model.points, mid, max_vertices)
    notes = [mid.note, *scene.notes]
    if surface is not mid:
        notes.append(
            f"ParaView's series draws both skins {2 * half * 1e3:g} mm apart; this page the "
            "mid-surface"
        )
    every = int(np.max(np.diff(shown), initial=1))
    notes.append(
        f"reduced for size: {len(shown)} of the series' {len(t_s)} frames ("
        + ("every sample" if every == 1 else f"one sample in {every}")
        + ", the end of the move, the cycle time and the closest approach), "
        f"{small.n_vertices} of the model's {scene.model.n_points} points; the exact values "
        "at every point and frame are in part.xdmf beside this page (ParaView)"
    )
    directory = make_output_dir(result_dir) / ANIMATION_DIR
    step(f"animation: writing {len(t_s)} frames for ParaView and the page")
    with writing(directory, ANIMATION_KIND, series_names(directory)) as files:
        write_series(files, scene, frames, surface, normals)
        write_cell(files, scene, frames)
        cpu.append(time.process_time())
        files.add_text(PAGE, page_html(page_data(scene, frames, small, shown, notes)))
        cpu.append(time.process_time())
    page = directory / PAGE
    return Animation(
        directory=directory,
        series=directory / SERIES,
        page=page,
        frames=frames,
        page_frames=len(shown),
        page_points=small.n_vertices,
        page_bytes=page.stat().st_size,
        notes=tuple(notes),
        cpu_s=dict(zip(("frames", "series", "page"), np.diff(cpu).tolist(), strict=True)),
    )


def animate(result, result_dir: str | os.PathLike, **options) -> Animation:
    """Write the animation of an optim.OptimizationResult ``result`` (its returned move, the
    nominal model posed in its cell) into ``result_dir``/animation; ``options``:
    ``max_vertices`` and ``max_frames`` (the page's reduction), ``after_s`` (the settling
    shown after the cycle time, s; default a quarter of it)."""
    return write_animation(scene_of_result(result), result_dir, **options)


def animate_directory(
    result_dir: str | os.PathLike, *, model=None, cell=None, **options
) -> Animation:
    """:func:`animate` for the result that `jaxflex optimize` wrote into ``result_dir``,
    with the model and cell files its report records (or ``model`` / ``cell``: paths of the
    same files)."""
    scene = scene_of_directory(result_dir, model=model, cell=cell)
    return write_animation(scene, result_dir, **options)
