"""``scripts/generate.py --render``: the entry script generates a puzzle and renders its images, in the Blender
binary (``blender --background --python scripts/generate.py -- ... --render``) and under the bpy wheel."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from blender_support import blender_environment, tool
from waiting import BACKSTOP

from blender_addon.views import DEFAULT_VIEWS, image_name

REPOSITORY = Path(__file__).resolve().parent.parent
SCRIPT = REPOSITORY / "scripts" / "generate.py"
BLENDER = tool("blender")
pytestmark = pytest.mark.blender
needs_blender = pytest.mark.skipif(BLENDER is None,
                                   reason="the blender binary is not installed (apt-get install blender)")


def _coloured_pixels(path: Path) -> tuple[int, int]:
    """Red and green pixels of an image: the puzzle's blockers and target, not an empty stage."""
    import numpy as np
    from PIL import Image

    r, g, b = np.asarray(Image.open(path).convert("RGB"), dtype=int).transpose(2, 0, 1)
    return int(((r > 80) & (g < 40) & (b < 40)).sum()), int(((g > 80) & (r < 60) & (b < 60)).sum())


@needs_blender
@pytest.mark.slow
def test_generate_script_renders_in_blender_background(tmp_path):
    result = subprocess.run(
        [BLENDER, "--background", "--factory-startup", "--python-exit-code", "1", "--python", str(SCRIPT), "--",
         "--generator", "simple_slider", "--seed", "2", "--out", str(tmp_path / "out"), "--render"],
        capture_output=True, text=True, timeout=BACKSTOP, env=blender_environment(tmp_path))
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    folder = tmp_path / "out" / "simple_slider" / "simple_slider_2"
    assert "URDF from the scene equals the core's" in result.stdout and "rendered" in result.stdout
    images = folder / "images"
    expected = [image_name("simple_slider_2", i) for i in range(len(DEFAULT_VIEWS))]
    assert set(expected) <= {p.name for p in images.iterdir()}
    for name in expected:
        red, green = _coloured_pixels(images / name)
        assert red > 500 and green > 100, (name, red, green)
    assert (folder / "simple_slider_2.blend").is_file() and (folder / "urdf" / "simple_slider_2.urdf").is_file()
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]  # no temporary leftovers


@pytest.mark.slow
def test_generate_script_renders_under_plain_python_with_cycles(tmp_path):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed")
    result = subprocess.run([sys.executable, str(SCRIPT), "--generator", "move_n_times", "--seed", "1",
                             "--out", str(tmp_path / "out"), "--render", "--engine", "cycles", "--views", "oblique",
                             "--size", "160x120"],
                            capture_output=True, text=True, timeout=BACKSTOP, env=blender_environment(tmp_path))
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    image = tmp_path / "out" / "move_n_times" / "move_n_times_1" / "images" / image_name("move_n_times_1", 0)
    from PIL import Image

    assert Image.open(image).size == (160, 120)
    assert _coloured_pixels(image)[0] > 0


@pytest.mark.parametrize("bad", [["--size", "10x10"], ["--views", "nowhere"]])
def test_generate_script_refuses_bad_render_options_before_any_work(tmp_path, bad):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed")
    result = subprocess.run([sys.executable, str(SCRIPT), "--generator", "simple_slider", "--seed", "2",
                             "--out", str(tmp_path / "out"), "--render", *bad],
                            capture_output=True, text=True, timeout=120, env=blender_environment(tmp_path))
    assert result.returncode == 2
    assert "generate.py: error:" in result.stderr and bad[1] in result.stderr
    assert not (tmp_path / "out").exists()
