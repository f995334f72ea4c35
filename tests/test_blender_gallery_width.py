"""The gallery page fits a 1400 px wide window: six generators' columns, no sideways scrolling.

Headless Chromium lays out a gallery of the six paper generators (one seed each, 480x360 stills as
``phyrogen render`` writes them) at 1400 px and reports the page's scroll width. Control: the same page
with the pictures at their old fixed 240 px needs more than 1400 px.
"""

from __future__ import annotations

import re
import subprocess

import pytest
from blender_support import tool

from blender_addon.gallery import write_gallery
from blender_addon.views import DEFAULT_VIEWS, image_name
from phyrogen_core.export import write_puzzle
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.registry import paper_generators
from solver.pipelines.generation import generate_puzzle

CHROMIUM = tool("chromium") or tool("chromium-browser") or tool("google-chrome")
WIDTH = 1400
MEASURE = ("<script>window.addEventListener('load', () => { document.body.dataset.scrollWidth = "
           "String(document.documentElement.scrollWidth); });</script></body>")

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install chromium)")]


def _scroll_width(page_text: str, path) -> int:
    path.write_text(page_text.replace("</body>", MEASURE), encoding="utf-8")
    run = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                          f"--window-size={WIDTH},900", "--virtual-time-budget=3000", "--dump-dom", path.as_uri()],
                         capture_output=True, text=True, timeout=120)
    found = re.search(r'data-scroll-width="(\d+)"', run.stdout)
    assert found, run.stdout[-1000:] + run.stderr[-1000:]
    return int(found[1])


def test_gallery_fits_1400_pixels(tmp_path):
    from PIL import Image

    still = Image.new("RGB", (480, 360), (200, 40, 40))
    for seed, generator in enumerate(paper_generators(), start=5301):  # one puzzle per column is enough
        if generator == "move_n_times" or generator == "simple_slider":
            seed = 9  # their sizes grow with the seed
        folder = PuzzleFolder.open(write_puzzle(generate_puzzle(generator, seed), tmp_path))
        folder.images.mkdir()
        for index, _ in enumerate(DEFAULT_VIEWS):
            still.save(folder.images / image_name(folder.name, index))
    page = write_gallery(tmp_path).read_text()
    assert page.count('<img class="still"') == 6
    assert _scroll_width(page, tmp_path / "measured.html") <= WIDTH
    old = page.replace("img { width: 100%; max-width: 240px;", "img { width: 240px;")
    assert old != page
    assert _scroll_width(old, tmp_path / "control.html") > WIDTH
