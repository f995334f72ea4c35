"""Rendering puzzle folders in worker processes, and the HTML gallery seen by headless Chromium."""

from __future__ import annotations

import subprocess

import pytest
from blender_support import every_shape_puzzle, tool

from blender_addon.gallery import write_gallery
from blender_addon.rendering import render_puzzles
from phyrogen_core.export import write_puzzle
from phyrogen_core.folder import find_puzzle_folders

pytestmark = [pytest.mark.blender, pytest.mark.slow]
CHROMIUM = tool("chromium") or tool("chromium-browser") or tool("google-chrome")


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    root = tmp_path_factory.mktemp("out")
    folder = write_puzzle(every_shape_puzzle(), root)
    report = render_puzzles([f.path for f in find_puzzle_folders(root)], views=("top", "oblique"))
    return root, folder, report


def test_render_writes_images_and_blend(rendered):
    root, folder, report = rendered
    assert [r.folder for r in report.rendered] == [folder]
    assert sorted(p.name for p in (folder / "images").iterdir()) == ["every_shape_1_00.png", "every_shape_1_01.png"]
    assert (folder / "every_shape_1.blend").is_file()
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]  # no temporary leftovers


def test_renders_are_deterministic(rendered, tmp_path):
    root, folder, report = rendered
    first = {p.name: p.read_bytes() for p in (folder / "images").iterdir()}
    render_puzzles([folder], engine=report.rendered[0].engine, views=("top", "oblique"))
    assert {p.name: p.read_bytes() for p in (folder / "images").iterdir()} == first


def test_oblique_view_shows_the_coloured_objects(rendered):
    from PIL import Image

    _, folder, _ = rendered
    pixels = list(Image.open(folder / "images" / "every_shape_1_01.png").convert("RGB").getdata())
    red = sum(1 for r, g, b in pixels if r > 80 and g < 40 and b < 40)
    green = sum(1 for r, g, b in pixels if g > 80 and r < 60 and b < 60)
    assert red > 2000 and green > 100


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install chromium)")
def test_gallery_in_headless_chromium(rendered, tmp_path):
    from PIL import Image

    root, folder, _ = rendered
    page = write_gallery(root, views=("top", "oblique"))
    text = page.read_text()
    assert "every_shape/every_shape_1/images/every_shape_1_01.png" in text
    assert "every_shape/every_shape_1/urdf/every_shape_1.urdf" in text
    screenshot = tmp_path / "gallery.png"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--allow-file-access-from-files", f"--screenshot={screenshot}", "--window-size=900,700",
                    page.as_uri()], capture_output=True, timeout=120, check=True)
    pixels = list(Image.open(screenshot).convert("RGB").getdata())
    # The embedded render's red and green objects are on the page, not just text on white.
    assert sum(1 for r, g, b in pixels if r > 80 and g < 40 and b < 40) > 400
    assert sum(1 for r, g, b in pixels if g > 80 and r < 60 and b < 60) > 20


def test_oblique_view_stands_on_a_lit_floor_with_shadows(tmp_path):
    """The gallery's look: a light floor, and shadows on it. The control renders the same view without
    shadows or cavity; where the two differ, the look darkened the floor."""
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    import sys
    from pathlib import Path

    import numpy as np
    from PIL import Image

    from blender_addon.views import STILL_SIZE

    folder = write_puzzle(every_shape_puzzle(), tmp_path / "out")
    script = Path(__file__).resolve().parent / "blender_look_script.py"
    run = subprocess.run([sys.executable, str(script), str(folder), str(tmp_path)], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    ground, plain = (np.asarray(Image.open(tmp_path / f"{name}.png").convert("RGB"), dtype=int)
                     for name in ("ground", "plain"))
    assert ground.shape == (STILL_SIZE[1], STILL_SIZE[0], 3)
    corners = np.concatenate([ground[-20:, :20].reshape(-1, 3), ground[-20:, -20:].reshape(-1, 3)])
    assert corners.min() > 150 and np.ptp(corners, axis=1).max() < 12  # a light, neutral floor
    def shadows(lit, unlit) -> float:
        """The share of pixels that are neutral (the floor) in ``lit`` and 25 levels darker than in ``unlit``."""
        return float(((np.ptp(lit, axis=2) < 12) & ((unlit - lit).min(axis=2) >= 25)).mean())

    assert shadows(ground, plain) > 0.005
    assert shadows(plain, ground) < 0.001  # the control: the measure finds none the other way round
