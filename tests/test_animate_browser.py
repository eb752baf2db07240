"""The animation page in a real browser: headless Chromium (Debian's package; .ci/run
installs it) opens the page from the file, with nothing else to reach, and

* loads it without a console error (the page records every error and console.error on its
  status element; Chromium's own console lines are read too);
* draws a known point of the part where the engine puts it at that frame (the position
  plotly holds for the vertex, against optim.animate's frames at scale 1: float32 rounding
  of the displacement, 2^-24 of its size, is the page's only loss);
* plays (the frame advances with the clock);
* changes where the part moved: screenshots of two frames differ inside the 3-D view.

Chromium is driven by its command line (--dump-dom, --screenshot, --virtual-time-budget:
virtual time, so a loaded machine only takes longer). Skips only where Chromium is absent.
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from cells import press_cell

import fem
import optim
from optim.animate import animate

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (apt-get install chromium; CI does)"
)
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--window-size=1200,900",
    "--enable-logging=stderr",
    "--v=0",
)
BUDGET_MS = 8000  # virtual time for the page to load plotly, draw and play


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    """(animation, its page) of a 0.6 x 0.4 m plate (all 1 505 nodes, 4 modes) moved through
    a press opening 10 mm from the dies."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    model = fem.modal_analysis(part, cups, n_modes=4, zeta=0.02, progress=False).to_modal_model()
    cell = press_cell()
    limits = optim.Limits(2.0, 10.0, 100.0)
    result = optim.optimize(
        model,
        None,
        limits,
        0.01,
        5e-4,
        constraints=optim.Constraints(cell=cell, min_distance_m=0.01),
    )
    directory = tmp_path_factory.mktemp("page")
    animation = animate(result, directory)
    return animation, animation.page


def page_data(page: Path) -> dict:
    """The data the page inlines (its JSON script element)."""
    text = page.read_text(encoding="utf-8")
    return json.loads(re.search(r'id="jaxflex-data">(.*?)</script>', text, re.S).group(1))


def chromium(page: Path, fragment: str, tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    """Run headless Chromium on ``page`` with the address fragment ``fragment``."""
    profile = tmp_path / f"profile-{len(list(tmp_path.iterdir()))}"
    command = [
        CHROMIUM,
        *FLAGS,
        f"--user-data-dir={profile}",
        f"--virtual-time-budget={BUDGET_MS}",
        *args,
        f"{page.resolve().as_uri()}#{fragment}",
    ]
    return subprocess.run(command, capture_output=True, text=True, timeout=600, check=True)


def status(page: Path, fragment: str, tmp_path: Path) -> tuple[dict, str]:
    """(the page's status element's data, Chromium's log) after loading ``page``."""
    run = chromium(page, fragment, tmp_path, "--dump-dom")
    tag = re.search(r'<span id="status"[^>]*>', run.stdout)
    assert tag, "the page has no status element: it did not load"
    data = {k: html.unescape(v) for k, v in re.findall(r'data-(\w+)="([^"]*)"', tag.group(0))}
    return data, run.stderr


def test_the_page_loads_and_draws_the_engines_position(page, tmp_path):
    """No console error; the vertex drawn for a known node of the part (the point nearest
    the plate's far corner) at a frame during the move is where the engine's frame puts it,
    to the float32 rounding of its displacement."""
    animation, path = page
    data = page_data(path)
    frames = animation.frames
    k = len(data["t_s"]) // 2
    corner = np.argmax(np.asarray(animation.frames.rigid[0])[data["node"]] @ [1.0, 1.0, 0.0])
    found, log = status(path, f"frame={k}&probe={corner}", tmp_path)
    assert found["ready"] == "1"
    assert json.loads(found["errors"]) == []
    assert not re.search(r"CONSOLE.*(Error|error)|Uncaught", log), log
    assert int(found["frame"]) == k
    probe = json.loads(found["probe"])
    engine = frames.positions[frames.frame_at(float(found["time"])), probe["node"]]
    displacement = np.abs(frames.displacement).max()
    assert np.abs(np.array(probe["drawn"]) - engine).max() <= 2.0**-23 * displacement + 1e-12
    assert float(found["time"]) == pytest.approx(data["t_s"][k], abs=1e-12)


def test_the_page_plays(page, tmp_path):
    """Started with #play, the frame advances with the (virtual) clock."""
    _, path = page
    found, _ = status(path, "play&speed=0.25", tmp_path)
    assert int(found["frame"]) > 0
    assert json.loads(found["errors"]) == []


def test_the_part_moves_on_the_screen(page, tmp_path):
    """Screenshots of the first frame and of the last differ inside the 3-D view, over a
    stretch as wide as the move (the part has left its place at A and stands in the press;
    outside it, only the slider, the time and the time plot's marker change)."""
    import matplotlib.image

    _, path = page
    last = len(page_data(path)["t_s"]) - 1
    shots = []
    for frame in (0, last):
        png = tmp_path / f"frame{frame}.png"
        chromium(path, f"frame={frame}", tmp_path, f"--screenshot={png}")
        shots.append(matplotlib.image.imread(png)[..., :3])
    found, _ = status(path, "frame=0", tmp_path)
    left, top, right, bottom = (round(v) for v in json.loads(found["scene"]))
    changed = np.abs(shots[0] - shots[1]).max(axis=2) > 0.1
    inside = changed[top:bottom, left:right]
    assert inside.sum() > 200  # a few hundred pixels of part at each place at the least
    columns = np.flatnonzero(inside.any(axis=0))
    assert columns.max() - columns.min() > 100  # at A and in the press, 1.6 m apart
