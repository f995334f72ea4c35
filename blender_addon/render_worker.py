"""Render puzzle folders in this process: ``python -m blender_addon.render_worker``.

Started by :func:`blender_addon.rendering.render_puzzles` in a subprocess,
because Workbench aborts the process when no OpenGL context can be made.
For every folder it prints ``RENDERED <folder> <seconds> <images>`` once the
images (``images/``, replaced atomically) and ``<name>.blend`` are in place.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from phyrogen_core.folder import PuzzleFormatError

from .views import DEFAULT_VIEWS, parse_views


def render_folder(folder: Path, engine: str, size: tuple[int, int], views: tuple[str, ...]) -> int:
    """Build, render and save one puzzle folder (the render stage's entries); returns the number of images."""
    import bpy

    from phyrogen_core.folder import PuzzleFolder, atomic_directory

    from .render import render_views, setup_stage
    from .scene import build_puzzle_folder

    place = PuzzleFolder.open(folder)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    built = build_puzzle_folder(place.path, scene)
    setup_stage(scene, built.collection, engine, size)
    with atomic_directory(place.images) as images:
        paths = render_views(scene, built.collection, images, place.name, views)
    temporary = place.path / f".{place.name}.tmp.blend"
    try:
        bpy.ops.wm.save_as_mainfile(filepath=str(temporary), copy=True, compress=False)
        os.replace(temporary, place.blend)
    except BaseException:  # a stop (SIGINT) while saving: no half-written scene stays behind
        temporary.unlink(missing_ok=True)
        raise
    return len(paths)


MIN_IMAGE_SIDE = 16
MAX_IMAGE_SIDE = 8192
"""Largest image width and height: Workbench renders into an OpenGL framebuffer, which many
drivers cap at 8192 per side, and an 8192 x 8192 RGBA image is already 256 MiB per view."""


def parse_size(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` -> (width, height), each side in MIN_IMAGE_SIDE..MAX_IMAGE_SIDE."""
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"bad image size {text!r}; valid: WIDTHxHEIGHT, e.g. 480x360") from None
    if not (MIN_IMAGE_SIDE <= width <= MAX_IMAGE_SIDE and MIN_IMAGE_SIDE <= height <= MAX_IMAGE_SIDE):
        raise ValueError(f"image size {text!r} is out of range; valid: each side {MIN_IMAGE_SIDE}..{MAX_IMAGE_SIDE}")
    return width, height


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m blender_addon.render_worker", description=__doc__)
    parser.add_argument("--engine", choices=("WORKBENCH", "CYCLES"), default="WORKBENCH")
    parser.add_argument("--size", default="480x360")
    parser.add_argument("--views", default=",".join(DEFAULT_VIEWS))
    parser.add_argument("folders", nargs="+")
    args = parser.parse_args(argv)
    size, views = parse_size(args.size), parse_views(args.views)
    for folder in args.folders:
        started = time.perf_counter()
        try:
            count = render_folder(Path(folder), args.engine, size, views)
        except (PuzzleFormatError, FileNotFoundError) as exc:
            # A folder broken after render_puzzles checked it: one line naming it, not a traceback.
            print(f"render_worker: {exc}", file=sys.stderr)
            return 2
        print(f"RENDERED {folder} {time.perf_counter() - started:.3f} {count}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
