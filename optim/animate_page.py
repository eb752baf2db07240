"""The animation as one self-contained HTML page (optim.animate): no server, no network.

The page inlines plotly.js (the ``plotly`` package's copy), the viewer
(``optim/animate_page.js``) and the data: the part's mid-surface (optim.animate_surface,
reduced to at most ``max_vertices`` of its points by clustering, each drawn point a real
one), the frames (at most ``max_frames`` of the series' frames: every k-th sample, plus the
end of the move, the cycle time and the certified closest approach), the obstacles, the
path and the via points. Controls: play / pause, a time slider, the deformation scale, the
colour (deviation, von Mises, distance to the obstacles) and a time plot of the quantity
coloured over all the model's points (largest deviation or stress, smallest distance) with
its threshold or limit and the cycle time marked. The reductions are stated on the page;
the exact values stay in the ParaView series.

Data are base64 arrays: the rest positions and the path in float64, the displacement in
float32 (the drawn position of a point at scale 1 is the engine's to float32 rounding of
its displacement), the colours as 16-bit steps of their range.
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np

from optim.animate_frames import Frames, Scene
from optim.animate_series import scene_bounds
from optim.animate_surface import Surface, obstacle_surfaces
from optim.result_files import MAX_FRAMES as MAX_FRAMES  # their home: the light names
from optim.result_files import MAX_VERTICES as MAX_VERTICES
from optim.result_files import PAGE as PAGE

SCALES = (1, 2, 5, 10, 20, 50, 100, 200, 500)
SPEEDS = ((0.1, "0.1 x real time"), (0.25, "0.25 x"), (0.5, "0.5 x"), (1.0, "1 x"))


def page_frames(scene: Scene, frames: Frames, max_frames: int) -> np.ndarray:
    """Indices of the frames the page shows: every k-th (at most ``max_frames`` of them)
    plus the first, the last, the end of the move, the cycle time and the closest approach."""
    n = len(frames.t_s)
    step = max(1, int(np.ceil(n / max(int(max_frames), 2))))
    keep = set(range(0, n, step)) | {0, n - 1}
    for t in (scene.transfer_time_s, scene.cycle_time_s):
        keep.add(frames.frame_at(t))
    if scene.witness is not None and np.isfinite(scene.witness["time_s"]):
        keep.add(frames.frame_at(scene.witness["time_s"]))
    return np.array(sorted(keep))


def _b64(values: np.ndarray, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(values, dtype=dtype).tobytes()).decode("ascii")


def _quantised(values: np.ndarray) -> dict:
    """{"low", "high", "data"}: ``values`` as 16-bit steps of their range (base64)."""
    finite = values[np.isfinite(values)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    if high <= low:
        high = low + 1.0
    steps = np.rint((np.nan_to_num(values, nan=low) - low) / (high - low) * 65535)
    return {"low": low, "high": high, "data": _b64(np.clip(steps, 0, 65535), np.uint16)}


def _fields(scene: Scene, frames: Frames, shown: np.ndarray, surface: Surface) -> tuple:
    """The colour fields (name -> description and data) and the time plot's curves."""
    nodes = surface.node
    fields, curves = {}, {}
    threshold = scene.threshold_m
    dev = frames.deviation_m[shown][:, nodes]
    fields["deviation"] = {
        **_quantised(dev),
        "label": "deviation [mm]", "menu": "deviation |u| from the sag", "display": 1e3,
        "colorscale": "Viridis", "reverse": False, "cmin": 0.0, "cmax": float(dev.max()) or 1.0,
    }  # fmt: skip
    peak = frames.deviation_m.max(axis=1)
    curves["deviation"] = {
        "values": np.maximum(peak, threshold / 100).tolist(),  # on the log axis from 1 % of it
        "label": "largest deviation", "limit": threshold,
        "limit_label": f"threshold {threshold * 1e3:g} mm", "log": True,
        "range": [threshold / 100, max(float(peak.max()), threshold) * 2],
    }  # fmt: skip
    if frames.von_mises_pa is not None:
        from scipy.spatial import cKDTree

        near = cKDTree(np.asarray(scene.model.stress.points_m)).query(
            np.asarray(scene.model.points)[nodes]
        )[1]
        vm = frames.von_mises_pa[shown][:, near]
        limit = scene.limits.get("von Mises stress")
        fields["stress"] = {
            **_quantised(vm),
            "label": "von Mises [MPa]", "menu": "von Mises stress", "display": 1e-6,
            "colorscale": "YlOrRd", "reverse": False, "cmin": 0.0,
            "cmax": float(max(vm.max(), limit or 0.0)) or 1.0,
        }  # fmt: skip
        label = None if limit is None else f"limit {limit / 1e6:.3g} MPa"
        curves["stress"] = {
            "values": frames.von_mises_pa.max(axis=1).tolist(), "label": "largest von Mises",
            "limit": limit, "limit_label": label, "log": False, "range": None,
        }  # fmt: skip
    if frames.distance_m is not None:
        dist = frames.distance_m[shown][:, nodes]
        limit = scene.limits.get("distance to obstacles")
        closest = frames.distance_m.min(axis=1)
        top = 5 * limit if limit else float(np.percentile(closest, 90))
        fields["distance"] = {
            **_quantised(dist),
            "label": "distance [mm]", "menu": "distance to the nearest obstacle", "display": 1e3,
            "colorscale": "RdBu", "reverse": True, "cmin": 0.0, "cmax": top,
        }  # fmt: skip
        curves["distance"] = {
            "values": closest.tolist(), "label": "smallest distance", "limit": limit,
            "limit_label": None if limit is None else f"limit {limit * 1e3:g} mm",
            "log": False, "range": [0.0, max(top, 1.5 * float(closest.min()))],
        }  # fmt: skip
    return fields, curves


def page_data(
    scene: Scene, frames: Frames, mid: Surface, shown: np.ndarray, notes: list[str]
) -> dict:
    """Everything the viewer reads (module docstring), JSON-ready."""
    points = np.asarray(scene.model.points)
    nodes = mid.node
    fields, curves = _fields(scene, frames, shown, mid)
    pivot = np.asarray(scene.pivot_m, dtype=np.float64)
    rigid0 = frames.rigid[shown][:, 0]  # the path: pivot + s + R (x_0 - pivot)
    translation = rigid0 - pivot - np.einsum("fab,b->fa", frames.rotation[shown], points[0] - pivot)
    data = {
        "title": scene.title,
        "notes": notes,
        "n_vertices": len(nodes),
        "node": nodes.tolist(),
        "base": _b64(points[nodes], np.float64),
        "triangles": _b64(mid.triangles, np.int32),
        "pivot_m": pivot.tolist(),
        "t_s": frames.t_s[shown].tolist(),
        "translation": _b64(translation, np.float64),
        "rotation": _b64(frames.rotation[shown], np.float64),
        "displacement": _b64(frames.displacement[shown][:, nodes], np.float32),
        "fields": fields,
        "curves": curves,
        "curve_t_s": frames.t_s.tolist(),
        "default_colour": "distance" if "distance" in fields else "deviation",
        "cycle_time_s": scene.cycle_time_s,
        "transfer_time_s": scene.transfer_time_s,
        "path": dict(zip("xyz", frames.origin_m.T.tolist(), strict=True)),
        "via": dict(zip("xyz", scene.via_m.reshape(-1, 3).T.tolist(), strict=True)),
        "obstacles": None,
        "camera": {"eye": {"x": -0.75, "y": -1.3, "z": 0.7}},
    }
    if scene.obstacles:
        vertices, triangles, _ = obstacle_surfaces(scene.obstacles, scene_bounds(frames))
        data["obstacles"] = {
            **dict(zip("xyz", vertices.T.tolist(), strict=True)),
            **dict(zip("ijk", triangles.T.tolist(), strict=True)),
        }
    return data


def _options(values, selected) -> str:
    return "".join(
        f'<option value="{v}"{" selected" if v == selected else ""}>{html.escape(str(label))}'
        "</option>"
        for v, label in values
    )


def page_html(data: dict) -> str:
    """The page: the plotly.js library, the viewer and ``data`` inlined (module docstring)."""
    from plotly.offline import get_plotlyjs  # ~5 MB of JavaScript: only when writing

    viewer = (Path(__file__).parent / "animate_page.js").read_text(encoding="utf-8")
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in data["notes"])
    scales = _options([(s, f"x {s}" + (" (true)" if s == 1 else "")) for s in SCALES], 1)
    speeds = _options(SPEEDS, 0.25)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>jaxflex: {html.escape(data["title"])}</title>
<script>window.__jaxflexErrors = [];
window.addEventListener("error", function (e) {{
  window.__jaxflexErrors.push(String(e.message)); }});
(function () {{ var original = console.error; console.error = function () {{
  window.__jaxflexErrors.push(Array.prototype.join.call(arguments, " "));
  return original.apply(console, arguments); }}; }})();</script>
<style>
body {{ font-family: sans-serif; margin: 0.5em 1em; color: #222; }}
h1 {{ font-size: 1.1em; margin: 0.2em 0; }}
#bar {{ display: flex; gap: 0.8em; align-items: center; flex-wrap: wrap; margin: 0.3em 0; }}
#slider {{ flex: 1; min-width: 200px; }}
#plot {{ width: 100%; height: 78vh; min-height: 520px; }}
ul {{ font-size: 0.8em; color: #555; margin: 0.2em 0; }}
</style>
<script>{get_plotlyjs()}</script>
</head><body>
<h1>{html.escape(data["title"])}</h1>
<div id="bar"><button id="play">play</button>
<input id="slider" type="range" min="0" value="0" step="1">
<span id="time"></span>
<label>deformation <select id="scale">{scales}</select></label>
<label>colour <select id="colour"></select></label>
<label>speed <select id="speed">{speeds}</select></label>
<span id="status" data-frame="" data-ready="0"></span></div>
<div id="plot"></div>
<ul>{notes}</ul>
<script type="application/json" id="jaxflex-data">{payload}</script>
<script>{viewer}</script>
</body></html>
"""
