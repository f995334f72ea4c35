"""`phyrogen render`'s solution animations, and the gallery playing them in headless Chromium."""

from __future__ import annotations

import re
import subprocess

import pytest
from blender_support import every_shape_puzzle, private_blender_home, tool

from blender_addon.gallery import write_gallery
from blender_addon.rendering import render_puzzles
from phyrogen_core.actions import count_actions
from phyrogen_core.export import read_puzzle_dir, write_puzzle
from phyrogen_core.folder import PuzzleFolder

private_blender_home()  # before the in-process bpy of the saved-scene test
pytestmark = [pytest.mark.blender, pytest.mark.slow]
CHROMIUM = tool("chromium") or tool("chromium-browser") or tool("google-chrome")
GENERATED = (("simple_slider", 1), ("move_n_times", 2))


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    from solver.pipelines.generation import generate_puzzle

    root = tmp_path_factory.mktemp("out")
    folders = [write_puzzle(generate_puzzle(generator, seed), root) for generator, seed in GENERATED]
    uncertified = write_puzzle(every_shape_puzzle(), root)  # no certificate: nothing to play
    report = render_puzzles([*folders, uncertified], views=("oblique",), workers=2)
    return root, folders, uncertified, report


def animation_of(folder) -> PuzzleFolder:
    place = PuzzleFolder.open(folder)
    return place.images / f"{place.name}_solution.webp"


def test_every_certified_puzzle_gets_a_short_looping_animation(rendered):
    from PIL import Image, ImageChops

    _, folders, uncertified, report = rendered
    assert report.animations == len(folders)
    for folder in folders:
        loaded = read_puzzle_dir(folder)
        actions = count_actions(loaded.certificate, loaded.chain.factors)
        with Image.open(animation_of(folder)) as movie:
            assert movie.format == "WEBP" and movie.is_animated and movie.size == (320, 240)
            assert movie.info["loop"] == 0
            movie.seek(1)
            movie.load()  # the frame's duration is known once it is decoded
            fps = 1000 / movie.info["duration"]
            seconds = movie.n_frames / fps
            assert 2 <= seconds <= 8 and movie.n_frames >= 4 * actions
            movie.seek(0)
            first = movie.convert("RGB")
            movie.seek(movie.n_frames - 1)
            last = movie.convert("RGB")
            # The solved puzzle is one image shown for the hold (about a second), the frames before it one frame each.
            assert movie.info["duration"] >= 1000 > 1000 / fps
        # The puzzle moved: the first and last frames differ somewhere.
        assert ImageChops.difference(first, last).getbbox() is not None
    assert not animation_of(uncertified).exists()


def test_animations_are_deterministic(rendered):
    _, folders, _, report = rendered
    first = {folder: animation_of(folder).read_bytes() for folder in folders}
    render_puzzles(folders, engine=report.rendered[0].engine, views=("oblique",))
    assert {folder: animation_of(folder).read_bytes() for folder in folders} == first


def test_the_saved_scene_plays_the_solution(rendered):
    bpy = pytest.importorskip("bpy")
    from blender_addon.phobos import ensure_phobostype
    from blender_addon.scene import puzzle_collections, read_chain

    _, folders, _, _ = rendered
    folder = folders[1]
    loaded = read_puzzle_dir(folder)
    bpy.ops.wm.open_mainfile(filepath=str(PuzzleFolder.open(folder).blend))
    ensure_phobostype()
    scene = bpy.context.scene
    actions = count_actions(loaded.certificate, loaded.chain.factors)
    assert (scene.frame_start, scene.frame_end, scene.render.fps) == (1, 1 + 24 * actions, 24)
    assert scene.frame_current == scene.frame_start
    (collection,) = puzzle_collections(scene)
    links = {o.name: o for o in collection.all_objects if o.type == "ARMATURE"}
    target = links[loaded.goal.target]
    scene.frame_set(scene.frame_end)
    assert list(target.matrix_world.translation) == pytest.approx(list(links["goal"].matrix_world.translation),
                                                                  abs=5e-3)
    assert read_chain(collection) == loaded.chain


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install chromium)")
def test_gallery_plays_every_animation_in_headless_chromium(rendered, tmp_path):
    import numpy as np
    from PIL import Image

    root, folders, _, _ = rendered
    page = write_gallery(root, views=("oblique",))
    text = page.read_text()
    animations = re.findall(r'data-animation="([^"]+)"', text)
    assert sorted(animations) == sorted(animation_of(f).relative_to(root).as_posix() for f in folders)
    browser = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               "--allow-file-access-from-files", "--virtual-time-budget=3000"]
    # '#play' starts every animation, as hovering or clicking starts one.
    dom = subprocess.run([*browser, "--dump-dom", page.as_uri() + "#play"], capture_output=True, text=True,
                         timeout=120, check=True).stdout
    assert f'data-animations="{len(folders)}"' in dom
    assert f'data-animations-shown="{len(folders)}"' in dom  # each one decoded by the browser
    screenshot = tmp_path / "gallery.png"
    subprocess.run([*browser, f"--screenshot={screenshot}", "--window-size=900,700", page.as_uri() + "#play"],
                   capture_output=True, timeout=120, check=True)
    r, g, b = np.asarray(Image.open(screenshot).convert("RGB"), dtype=int).transpose(2, 0, 1)
    assert ((r > 80) & (g < 40) & (b < 40)).sum() > 400  # the puzzles' red objects
