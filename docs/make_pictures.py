"""The README's picture of the animation page (docs/images/animation_page.png), made from a
result animated by `jaxflex optimize ... --animate`:

    jaxflex model --scene plate -o plate.npz
    jaxflex optimize plate.npz --cell examples/press_cell.toml --min-distance 0.01 \\
        --cup-safety 1.5 --max-stress --threshold 5e-4 -o press --animate
    python docs/make_pictures.py press

The page as headless Chromium draws it at the closest approach to the die (the browser test's
command line), scaled down to a small PNG. The picture of the ParaView series beside it is
ParaView's own: docs/make_paraview_view.py (run with pvpython).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

IMAGES = Path(__file__).resolve().parent / "images"
WIDTH_PX = 900
WARP = 20  # the deformation scale of both pictures (make_paraview_view.py's too)


def closest_time(result: Path) -> float:
    """The time of the certified closest approach (report.json's distance constraint)."""
    report = json.loads((result / "report.json").read_text(encoding="utf-8"))
    (distance,) = [c for c in report["constraints"] if "distance" in c["name"]]
    return float(distance["time_s"])


def page_picture(result: Path, time_s: float, out: Path) -> None:
    page = result / "animation" / "animation.html"
    text = page.read_text(encoding="utf-8")
    start = text.index('id="jaxflex-data">') + len('id="jaxflex-data">')
    data = json.loads(text[start : text.index("</script>", start)])
    frame = int(np.argmin(np.abs(np.array(data["t_s"]) - time_s)))
    with tempfile.TemporaryDirectory() as profile:
        shot = Path(profile) / "page.png"
        subprocess.run(
            [
                shutil.which("chromium") or "chromium",
                "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run",
                f"--user-data-dir={profile}/user", "--window-size=1200,820",
                "--virtual-time-budget=8000", f"--screenshot={shot}",
                f"{page.resolve().as_uri()}#frame={frame}&scale={WARP}",
            ],
            check=True, capture_output=True, timeout=600,
        )  # fmt: skip
        _save_small(Image.open(shot), out)


def _save_small(image, out: Path) -> None:
    height = round(image.height * WIDTH_PX / image.width)
    small = image.convert("RGB").resize((WIDTH_PX, height), Image.LANCZOS)
    small.quantize(colors=256).save(out, optimize=True)


def main(argv: list[str]) -> int:
    result = Path(argv[0] if argv else "press")
    time_s = closest_time(result)
    IMAGES.mkdir(exist_ok=True)
    page_picture(result, time_s, IMAGES / "animation_page.png")
    print(f"wrote {IMAGES / 'animation_page.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
